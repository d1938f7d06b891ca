/*
 * controller_host.c - minimal FMI 2.0 Co-Simulation host in C (no Python) for the
 * controller FMU: loads the binary with dlopen, instantiates it with its default
 * parameters and runs periods on synthetic readings (at rest with a small wobble).
 *
 * usage: controller_host <BallbotController.so> <guid> <n_steps> <bench_reps>
 *
 * Prints one JSON object: the final wheel torques and "step_us", the best-of-reps mean
 * wall time of one 5 ms controller step (fmi2SetReal of the nine readings, fmi2DoStep,
 * fmi2GetReal of the three torques), in micro-seconds.  Exit status 0 on success.
 */
#define _POSIX_C_SOURCE 200809L
#include <dlfcn.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "ctrl_vr.h" /* generated: value references */
#include "fmi2FunctionTypes.h"

static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status,
                   fmi2String category, fmi2String message, ...) {
    (void)env;
    fprintf(stderr, "[%s] %s (status %d): %s\n", category, name, (int)status, message);
}

static void *sym(void *lib, const char *name) {
    void *p = dlsym(lib, name);
    if (p == NULL) {
        fprintf(stderr, "missing symbol %s\n", name);
        exit(3);
    }
    return p;
}

static double now_s(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

int main(int argc, char **argv) {
    void *lib;
    fmi2InstantiateTYPE *instantiate;
    fmi2FreeInstanceTYPE *free_instance;
    fmi2SetupExperimentTYPE *setup;
    fmi2EnterInitializationModeTYPE *enter_init;
    fmi2ExitInitializationModeTYPE *exit_init;
    fmi2SetRealTYPE *set_real;
    fmi2GetRealTYPE *get_real;
    fmi2DoStepTYPE *do_step;
    fmi2CallbackFunctions cb;
    fmi2Component c;
    const fmi2ValueReference meas_vr[9] = {
        CTRL_VR_sensor_acc_x, CTRL_VR_sensor_acc_y, CTRL_VR_sensor_acc_z,
        CTRL_VR_sensor_gyro_x, CTRL_VR_sensor_gyro_y, CTRL_VR_sensor_gyro_z,
        CTRL_VR_sensor_enc0, CTRL_VR_sensor_enc1, CTRL_VR_sensor_enc2};
    const fmi2ValueReference tau_vr[3] = {CTRL_VR_tau0, CTRL_VR_tau1, CTRL_VR_tau2};
    double meas[9], tau[3] = {0.0, 0.0, 0.0}, best = 1e300, t = 0.0;
    const double h = 0.005;
    long n, reps, r, k;
    if (argc < 5) {
        fprintf(stderr, "usage: %s lib guid n_steps bench_reps\n", argv[0]);
        return 2;
    }
    n = atol(argv[3]);
    reps = atol(argv[4]);
    lib = dlopen(argv[1], RTLD_NOW | RTLD_LOCAL);
    if (lib == NULL) {
        fprintf(stderr, "dlopen failed: %s\n", dlerror());
        return 3;
    }
    *(void **)&instantiate = sym(lib, "fmi2Instantiate");
    *(void **)&free_instance = sym(lib, "fmi2FreeInstance");
    *(void **)&setup = sym(lib, "fmi2SetupExperiment");
    *(void **)&enter_init = sym(lib, "fmi2EnterInitializationMode");
    *(void **)&exit_init = sym(lib, "fmi2ExitInitializationMode");
    *(void **)&set_real = sym(lib, "fmi2SetReal");
    *(void **)&get_real = sym(lib, "fmi2GetReal");
    *(void **)&do_step = sym(lib, "fmi2DoStep");
    cb.logger = logger;
    cb.allocateMemory = calloc;
    cb.freeMemory = free;
    cb.stepFinished = NULL;
    cb.componentEnvironment = NULL;
    c = instantiate("controller", fmi2CoSimulation, argv[2], "", &cb, fmi2False, fmi2False);
    if (c == NULL) return 4;
    if (setup(c, fmi2False, 0.0, 0.0, fmi2False, 0.0) != fmi2OK || enter_init(c) != fmi2OK ||
        exit_init(c) != fmi2OK)
        return 5;
    for (r = 0; r < (reps > 0 ? reps : 1); ++r) {
        double t0 = now_s(), dt;
        for (k = 0; k < n; ++k) {
            double s = sin(0.01 * (double)k);
            meas[0] = 0.05 * s;
            meas[1] = -0.04 * s;
            meas[2] = 9.81;
            meas[3] = 0.01 * s;
            meas[4] = -0.01 * s;
            meas[5] = 0.002;
            meas[6] = 20.0 * s;
            meas[7] = -10.0 * s;
            meas[8] = -10.0 * s;
            if (set_real(c, meas_vr, 9, meas) != fmi2OK || do_step(c, t, h, fmi2True) != fmi2OK ||
                get_real(c, tau_vr, 3, tau) != fmi2OK)
                return 6;
            t += h;
        }
        dt = (now_s() - t0) / (double)n;
        if (dt < best) best = dt;
    }
    printf("{\"t\": %.17g, \"tau\": [%.17g, %.17g, %.17g]", t, tau[0], tau[1], tau[2]);
    if (reps > 0) printf(", \"step_us\": %.6g", best * 1e6);
    printf("}\n");
    free_instance(c);
    dlclose(lib);
    return isfinite(tau[0]) && isfinite(tau[1]) && isfinite(tau[2]) ? 0 : 7;
}
