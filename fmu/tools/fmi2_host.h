/*
 * fmi2_host.h - what the small C hosts (host.c, controller_host.c) share: the FMI 2.0
 * functions they call, loaded from an FMU binary with dlopen, the callbacks (a logger on
 * stderr, calloc/free) and a monotonic clock.  Header-only (static functions), so each
 * host stays one translation unit.
 */
#ifndef FMI2_HOST_H
#define FMI2_HOST_H

#include <dlfcn.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "fmi2FunctionTypes.h"

typedef struct {
    fmi2InstantiateTYPE *instantiate;
    fmi2FreeInstanceTYPE *free_instance;
    fmi2SetupExperimentTYPE *setup;
    fmi2EnterInitializationModeTYPE *enter_init;
    fmi2ExitInitializationModeTYPE *exit_init;
    fmi2SetRealTYPE *set_real;
    fmi2GetRealTYPE *get_real;
    fmi2DoStepTYPE *do_step;
    fmi2TerminateTYPE *terminate;
} host_api;

static void host_logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status,
                        fmi2String category, fmi2String message, ...) {
    (void)env;
    fprintf(stderr, "[%s] %s (status %d): %s\n", category, name, (int)status, message);
}

static void *host_sym(void *lib, const char *name) {
    void *p = dlsym(lib, name);
    if (p == NULL) {
        fprintf(stderr, "missing symbol %s\n", name);
        exit(3);
    }
    return p;
}

/* Load the FMU binary at `path` and its functions into `f`; exit status 3 on failure. */
static void *host_load(const char *path, host_api *f) {
    void *lib = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (lib == NULL) {
        fprintf(stderr, "dlopen failed: %s\n", dlerror());
        exit(3);
    }
    *(void **)&f->instantiate = host_sym(lib, "fmi2Instantiate");
    *(void **)&f->free_instance = host_sym(lib, "fmi2FreeInstance");
    *(void **)&f->setup = host_sym(lib, "fmi2SetupExperiment");
    *(void **)&f->enter_init = host_sym(lib, "fmi2EnterInitializationMode");
    *(void **)&f->exit_init = host_sym(lib, "fmi2ExitInitializationMode");
    *(void **)&f->set_real = host_sym(lib, "fmi2SetReal");
    *(void **)&f->get_real = host_sym(lib, "fmi2GetReal");
    *(void **)&f->do_step = host_sym(lib, "fmi2DoStep");
    *(void **)&f->terminate = host_sym(lib, "fmi2Terminate");
    return lib;
}

/* The callbacks of fmi2Instantiate: the stderr logger, calloc and free. */
static fmi2CallbackFunctions host_callbacks(void) {
    fmi2CallbackFunctions cb;
    cb.logger = host_logger;
    cb.allocateMemory = calloc;
    cb.freeMemory = free;
    cb.stepFinished = NULL;
    cb.componentEnvironment = NULL;
    return cb;
}

/* One line on stderr, "prog: " and the printf-style message; returns `status` (the exit
 * status the caller returns). */
#ifdef __GNUC__
__attribute__((format(printf, 3, 4)))
#endif
static int host_fail(const char *prog, int status, const char *fmt, ...) {
    va_list ap;
    fprintf(stderr, "%s: ", prog);
    va_start(ap, fmt);
    vfprintf(stderr, fmt, ap);
    va_end(ap);
    fputc('\n', stderr);
    return status;
}

/* A Co-Simulation instance of the loaded FMU; exit status 4, after the FMU's log and one
 * line naming the program `prog`, when fmi2Instantiate refuses (e.g. a wrong GUID). */
static fmi2Component host_instantiate(const host_api *f, const char *prog, const char *name,
                                      const char *guid, const fmi2CallbackFunctions *cb) {
    fmi2Component c = f->instantiate(name, fmi2CoSimulation, guid, "", cb, fmi2False, fmi2False);
    if (c == NULL) exit(host_fail(prog, 4, "fmi2Instantiate refused the FMU"));
    return c;
}

static double host_now_s(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

#endif /* FMI2_HOST_H */
