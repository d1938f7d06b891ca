/*
 * fmi2_common.c - shared, hand-written FMI 2.0 layer (Model Exchange + Co-Simulation).
 *
 * See fmi2_common.h.  Policies:
 *  - Every call checks the instance pointer, the FMU type and the state machine (FMI 2.0
 *    section 3.2.3 / 4.2.4); a call in the wrong state returns fmi2Error with a message
 *    and leaves the instance unchanged.
 *  - Invalid arguments (unknown value reference, variable not settable now, NaN/Inf,
 *    non-physical parameter, NULL pointers, bad sizes) return fmi2Error with a message
 *    and change nothing: setters validate all values before storing any.
 *  - Numerical failure (non-finite derivatives) returns fmi2Error and puts the instance
 *    into the error state, where fmi2GetReal keeps returning fmi2Error (never values that
 *    may be NaN) until fmi2Reset or fmi2SetFMUstate; a failed co-simulation step returns
 *    fmi2Discard, restores the state at the start of the step and enters the stepFailed
 *    state.
 *  - FMU states (fmi2SetFMUstate, fmi2DeSerializeFMUstate) are validated before they are
 *    restored: exactly one mode bit, matching FMU type, finite time, every value accepted
 *    by the model's value checks and the start-value checks of
 *    fmi2ExitInitializationMode (the checksum of a serialised state is public, so a
 *    crafted state must not bypass them).
 *  - Logging: categories logStatusError and logStatusWarning are on by default, so every
 *    error is reported; logCalls (call tracing) is off unless loggingOn is true.  Nothing
 *    is logged on success unless logCalls is enabled.
 */
#include "fmi2_common.h"

#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#define FMU_MAGIC 0x42424d55u /* "BBMU" */
#define SNAP_MAGIC 0x42425353u /* "BBSS" */
#define SER_MAGIC "BBPLANT\x01"
#define MSG_LEN 512

static const char *const fmu_log_category_names[FMU_LOG_N] = {
    "logStatusError", "logStatusWarning", "logCalls"};

struct fmu_instance {
    unsigned magic;
    fmi2Type type;
    fmu_state state;
    fmi2CallbackFunctions cb;
    char *name;
    int log_on[FMU_LOG_N];
    double time;
    double t_start;
    int dirty;             /* derivatives/outputs must be re-evaluated */
    double *r;             /* all reals, indexed by value reference */
    double *r_backup;      /* state at the start of a co-simulation step */
    void *work;            /* model work memory */
    char msg[MSG_LEN];     /* message buffer of the model callbacks */
    char logbuf[2 * MSG_LEN + 16];
};

/* Snapshot created by fmi2GetFMUstate. */
typedef struct {
    unsigned magic;
    fmi2Type type;
    fmu_state state;
    double time;
    double t_start;
    double r[1]; /* n_reals entries */
} fmu_snapshot;

static size_t snapshot_bytes(void) {
    return offsetof(fmu_snapshot, r) + fmu_model.n_reals * sizeof(double);
}

void *fmu_model_work(fmu_instance *inst) { return inst->work; }

/* ------------------------------------------------------------------ logging */

static void vlog_to(const fmi2CallbackFunctions *cb, const char *name, fmi2Status status,
                    int category, char *buf, size_t buflen, const char *fmt, va_list ap) {
    char raw[2 * MSG_LEN];
    size_t i, j = 0;
    vsnprintf(raw, sizeof raw, fmt, ap);
    /* Escape for the FMI message syntax: '#' -> '##'; never pass '%' to the logger. */
    for (i = 0; raw[i] != '\0' && j + 3 < buflen; ++i) {
        if (raw[i] == '#') {
            buf[j++] = '#';
            buf[j++] = '#';
        } else if (raw[i] == '%') {
            buf[j++] = ' ';
        } else {
            buf[j++] = raw[i];
        }
    }
    buf[j] = '\0';
    cb->logger(cb->componentEnvironment, name, status, fmu_log_category_names[category], buf);
}

void fmu_log(fmu_instance *inst, fmi2Status status, int category, const char *fmt, ...) {
    va_list ap;
    if (inst == NULL || category < 0 || category >= FMU_LOG_N || !inst->log_on[category])
        return;
    va_start(ap, fmt);
    vlog_to(&inst->cb, inst->name, status, category, inst->logbuf, sizeof inst->logbuf, fmt,
            ap);
    va_end(ap);
}

#define LOG_ERR(inst, ...) fmu_log((inst), fmi2Error, FMU_LOG_ERROR, __VA_ARGS__)
#define LOG_CALL(inst, ...) fmu_log((inst), fmi2OK, FMU_LOG_CALLS, __VA_ARGS__)

/* ------------------------------------------------------------------ checks */

static fmu_instance *as_instance(fmi2Component c) {
    fmu_instance *inst = (fmu_instance *)c;
    if (inst == NULL || inst->magic != FMU_MAGIC) return NULL;
    return inst;
}

static const char *state_name(fmu_state s) {
    switch (s) {
    case FMU_ST_INSTANTIATED: return "instantiated";
    case FMU_ST_INIT: return "initializationMode";
    case FMU_ST_EVENT: return "eventMode";
    case FMU_ST_CONT: return "continuousTimeMode";
    case FMU_ST_STEP_COMPLETE: return "stepComplete";
    case FMU_ST_STEP_FAILED: return "stepFailed";
    case FMU_ST_TERMINATED: return "terminated";
    case FMU_ST_ERROR: return "error";
    case FMU_ST_FATAL: return "fatal";
    }
    return "unknown";
}

/* Resolve the instance and check the call is allowed now; NULL if not (logged). */
static fmu_instance *enter(fmi2Component c, const char *fn, unsigned allowed, int me_only,
                           int cs_only) {
    fmu_instance *inst = as_instance(c);
    if (inst == NULL) return NULL; /* nothing to log to */
    if (me_only && inst->type != fmi2ModelExchange) {
        LOG_ERR(inst, "%s: only available for Model Exchange instances", fn);
        return NULL;
    }
    if (cs_only && inst->type != fmi2CoSimulation) {
        LOG_ERR(inst, "%s: only available for Co-Simulation instances", fn);
        return NULL;
    }
    if (!(inst->state & allowed)) {
        LOG_ERR(inst, "%s: not allowed in state %s", fn, state_name(inst->state));
        return NULL;
    }
    LOG_CALL(inst, "%s", fn);
    return inst;
}

#define ALL_STATES                                                                          \
    (FMU_ST_INSTANTIATED | FMU_ST_INIT | FMU_ST_EVENT | FMU_ST_CONT | FMU_ST_STEP_COMPLETE |  \
     FMU_ST_STEP_FAILED | FMU_ST_TERMINATED | FMU_ST_ERROR)
#define ME_ONLY_STATES (FMU_ST_EVENT | FMU_ST_CONT)
#define CS_ONLY_STATES (FMU_ST_STEP_COMPLETE | FMU_ST_STEP_FAILED)
#define RESULT_STATES                                                                       \
    (FMU_ST_INIT | FMU_ST_EVENT | FMU_ST_CONT | FMU_ST_STEP_COMPLETE | FMU_ST_STEP_FAILED |   \
     FMU_ST_TERMINATED | FMU_ST_ERROR)

static int vr_ok(fmu_instance *inst, const char *fn, const fmi2ValueReference vr[], size_t nvr) {
    size_t i;
    if (nvr > 0 && vr == NULL) {
        LOG_ERR(inst, "%s: vr is NULL but nvr = %lu", fn, (unsigned long)nvr);
        return 0;
    }
    for (i = 0; i < nvr; ++i) {
        if (vr[i] >= fmu_model.n_reals) {
            LOG_ERR(inst, "%s: unknown value reference %lu", fn, (unsigned long)vr[i]);
            return 0;
        }
    }
    return 1;
}

/* Evaluate derivatives and outputs if inputs, states or parameters changed. */
static fmi2Status refresh(fmu_instance *inst, const char *fn) {
    if (!inst->dirty) return fmi2OK;
    if (fmu_model.evaluate(inst, inst->r) != 0) {
        LOG_ERR(inst, "%s: the model evaluated to NaN or Inf at t = %g", fn, inst->time);
        inst->state = FMU_ST_ERROR;
        return fmi2Error;
    }
    inst->dirty = 0;
    return fmi2OK;
}

static void load_start(fmu_instance *inst) {
    memcpy(inst->r, fmu_model.start, fmu_model.n_reals * sizeof(double));
    inst->time = 0.0;
    inst->t_start = 0.0;
    inst->dirty = 1;
}

/* ------------------------------------------------------------------ common API */

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[]) {
    fmu_instance *inst = enter(c, "fmi2SetDebugLogging", ALL_STATES, 0, 0);
    size_t i;
    int k, found;
    if (inst == NULL) return fmi2Error;
    if (nCategories == 0) {
        inst->log_on[FMU_LOG_CALLS] = loggingOn ? 1 : 0;
        return fmi2OK;
    }
    if (categories == NULL) {
        LOG_ERR(inst, "fmi2SetDebugLogging: categories is NULL but nCategories = %lu",
                (unsigned long)nCategories);
        return fmi2Error;
    }
    for (i = 0; i < nCategories; ++i) {
        found = 0;
        for (k = 0; k < FMU_LOG_N; ++k)
            if (categories[i] != NULL && strcmp(categories[i], fmu_log_category_names[k]) == 0)
                found = 1;
        if (!found) {
            LOG_ERR(inst, "fmi2SetDebugLogging: unknown log category '%s'",
                    categories[i] ? categories[i] : "(null)");
            return fmi2Error;
        }
    }
    for (i = 0; i < nCategories; ++i)
        for (k = 0; k < FMU_LOG_N; ++k)
            if (strcmp(categories[i], fmu_log_category_names[k]) == 0)
                inst->log_on[k] = loggingOn ? 1 : 0;
    return fmi2OK;
}

static void early_error(const fmi2CallbackFunctions *cb, const char *name, const char *fmt,
                        ...) {
    char buf[2 * MSG_LEN + 16];
    va_list ap;
    va_start(ap, fmt);
    vlog_to(cb, name, fmi2Error, FMU_LOG_ERROR, buf, sizeof buf, fmt, ap);
    va_end(ap);
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType,
                              fmi2String fmuGUID, fmi2String fmuResourceLocation,
                              const fmi2CallbackFunctions *functions, fmi2Boolean visible,
                              fmi2Boolean loggingOn) {
    fmu_instance *inst;
    const char *name = instanceName ? instanceName : "(null)";
    size_t n = fmu_model.n_reals, len;
    (void)fmuResourceLocation;
    (void)visible;
    if (functions == NULL || functions->logger == NULL) return NULL; /* cannot log */
    if (functions->allocateMemory == NULL || functions->freeMemory == NULL) {
        early_error(functions, name, "fmi2Instantiate: allocateMemory/freeMemory is NULL");
        return NULL;
    }
    if (instanceName == NULL || instanceName[0] == '\0') {
        early_error(functions, name, "fmi2Instantiate: missing instance name");
        return NULL;
    }
    if (fmuType != fmi2ModelExchange && fmuType != fmi2CoSimulation) {
        early_error(functions, name, "fmi2Instantiate: unknown fmuType %d", (int)fmuType);
        return NULL;
    }
    if (fmuGUID == NULL || strcmp(fmuGUID, fmu_model.guid) != 0) {
        early_error(functions, name,
                    "fmi2Instantiate: wrong GUID '%s', this binary of %s has GUID '%s'",
                    fmuGUID ? fmuGUID : "(null)", fmu_model.model_identifier, fmu_model.guid);
        return NULL;
    }
    inst = (fmu_instance *)functions->allocateMemory(1, sizeof(fmu_instance));
    if (inst == NULL) {
        early_error(functions, name, "fmi2Instantiate: out of memory");
        return NULL;
    }
    memset(inst, 0, sizeof *inst);
    inst->cb = *functions;
    len = strlen(instanceName) + 1;
    inst->name = (char *)functions->allocateMemory(len, 1);
    inst->r = (double *)functions->allocateMemory(n, sizeof(double));
    inst->r_backup = (double *)functions->allocateMemory(n, sizeof(double));
    inst->work = fmu_model.work_bytes
                     ? functions->allocateMemory(fmu_model.work_bytes / sizeof(double) + 1,
                                                 sizeof(double))
                     : NULL;
    if (inst->name == NULL || inst->r == NULL || inst->r_backup == NULL ||
        (fmu_model.work_bytes && inst->work == NULL)) {
        early_error(functions, name, "fmi2Instantiate: out of memory");
        if (inst->name) functions->freeMemory(inst->name);
        if (inst->r) functions->freeMemory(inst->r);
        if (inst->r_backup) functions->freeMemory(inst->r_backup);
        if (inst->work) functions->freeMemory(inst->work);
        functions->freeMemory(inst);
        return NULL;
    }
    memcpy(inst->name, instanceName, len);
    inst->magic = FMU_MAGIC;
    inst->type = fmuType;
    inst->state = FMU_ST_INSTANTIATED;
    inst->log_on[FMU_LOG_ERROR] = 1;
    inst->log_on[FMU_LOG_WARNING] = 1;
    inst->log_on[FMU_LOG_CALLS] = loggingOn ? 1 : 0;
    load_start(inst);
    LOG_CALL(inst, "fmi2Instantiate: %s instance of %s",
             fmuType == fmi2ModelExchange ? "Model Exchange" : "Co-Simulation",
             fmu_model.model_identifier);
    return (fmi2Component)inst;
}

void fmi2FreeInstance(fmi2Component c) {
    fmu_instance *inst = as_instance(c);
    fmi2CallbackFreeMemory fr;
    if (inst == NULL) return;
    LOG_CALL(inst, "fmi2FreeInstance");
    fr = inst->cb.freeMemory;
    inst->magic = 0;
    fr(inst->name);
    fr(inst->r);
    fr(inst->r_backup);
    if (inst->work) fr(inst->work);
    fr(inst);
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined,
                               fmi2Real tolerance, fmi2Real startTime,
                               fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    fmu_instance *inst = enter(c, "fmi2SetupExperiment", FMU_ST_INSTANTIATED, 0, 0);
    (void)toleranceDefined;
    (void)tolerance;
    if (inst == NULL) return fmi2Error;
    if (!isfinite(startTime)) {
        LOG_ERR(inst, "fmi2SetupExperiment: startTime must be finite");
        return fmi2Error;
    }
    if (stopTimeDefined && (!isfinite(stopTime) || stopTime < startTime)) {
        LOG_ERR(inst, "fmi2SetupExperiment: stopTime %g must be finite and >= startTime %g",
                stopTime, startTime);
        return fmi2Error;
    }
    inst->time = startTime;
    inst->t_start = startTime;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    fmu_instance *inst = enter(c, "fmi2EnterInitializationMode", FMU_ST_INSTANTIATED, 0, 0);
    if (inst == NULL) return fmi2Error;
    inst->state = FMU_ST_INIT;
    inst->dirty = 1;
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    fmu_instance *inst = enter(c, "fmi2ExitInitializationMode", FMU_ST_INIT, 0, 0);
    if (inst == NULL) return fmi2Error;
    inst->msg[0] = '\0';
    if (fmu_model.check_initial(inst->r, 0, inst->msg, sizeof inst->msg) != 0) {
        LOG_ERR(inst, "fmi2ExitInitializationMode: %s", inst->msg);
        return fmi2Error;
    }
    inst->dirty = 1;
    if (refresh(inst, "fmi2ExitInitializationMode") != fmi2OK) return fmi2Error;
    inst->state = inst->type == fmi2ModelExchange ? FMU_ST_EVENT : FMU_ST_STEP_COMPLETE;
    return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component c) {
    fmu_instance *inst =
        enter(c, "fmi2Terminate",
              FMU_ST_EVENT | FMU_ST_CONT | FMU_ST_STEP_COMPLETE | FMU_ST_STEP_FAILED, 0, 0);
    if (inst == NULL) return fmi2Error;
    inst->state = FMU_ST_TERMINATED;
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component c) {
    fmu_instance *inst = enter(c, "fmi2Reset", ALL_STATES, 0, 0);
    if (inst == NULL) return fmi2Error;
    load_start(inst);
    inst->state = FMU_ST_INSTANTIATED;
    return fmi2OK;
}

/* ------------------------------------------------------------------ values */

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       fmi2Real value[]) {
    fmu_instance *inst = enter(c, "fmi2GetReal", RESULT_STATES, 0, 0);
    size_t i;
    if (inst == NULL) return fmi2Error;
    if (!vr_ok(inst, "fmi2GetReal", vr, nvr)) return fmi2Error;
    if (nvr > 0 && value == NULL) {
        LOG_ERR(inst, "fmi2GetReal: value is NULL");
        return fmi2Error;
    }
    if (inst->state == FMU_ST_ERROR) { /* no values until fmi2Reset (they may be NaN) */
        LOG_ERR(inst, "fmi2GetReal: the instance is in the error state after a failed call "
                      "at t = %g; call fmi2Reset (or fmi2SetFMUstate) first", inst->time);
        return fmi2Error;
    }
    if (refresh(inst, "fmi2GetReal") != fmi2OK) return fmi2Error;
    for (i = 0; i < nvr; ++i) value[i] = inst->r[vr[i]];
    return fmi2OK;
}

/* May variable vr be set with fmi2SetReal now? Returns a reason or NULL. */
static const char *not_settable(const fmu_instance *inst, fmi2ValueReference vr) {
    unsigned s = inst->state;
    switch (fmu_model.kind[vr]) {
    case FMU_KIND_INPUT:
        if (s & (FMU_ST_INSTANTIATED | FMU_ST_INIT | FMU_ST_EVENT | FMU_ST_CONT |
                 FMU_ST_STEP_COMPLETE))
            return NULL;
        return "inputs cannot be set in this state";
    case FMU_KIND_STATE: /* Model Exchange: like fmi2SetContinuousStates (CasADi uses it) */
        if (s & (FMU_ST_INSTANTIATED | FMU_ST_INIT)) return NULL;
        if (inst->type == fmi2ModelExchange && (s & (FMU_ST_EVENT | FMU_ST_CONT))) return NULL;
        return "states can only be set before initialisation ends (Co-Simulation)";
    case FMU_KIND_PARAMETER:
        if (s & (FMU_ST_INSTANTIATED | FMU_ST_INIT)) return NULL;
        return "fixed parameters can only be set before initialisation ends";
    case FMU_KIND_DERIVATIVE:
        return "derivatives are calculated and cannot be set";
    default:
        return "outputs are calculated and cannot be set";
    }
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       const fmi2Real value[]) {
    fmu_instance *inst =
        enter(c, "fmi2SetReal",
              FMU_ST_INSTANTIATED | FMU_ST_INIT | FMU_ST_EVENT | FMU_ST_CONT |
                  FMU_ST_STEP_COMPLETE | FMU_ST_STEP_FAILED | FMU_ST_TERMINATED,
              0, 0);
    size_t i;
    const char *why;
    if (inst == NULL) return fmi2Error;
    if (!vr_ok(inst, "fmi2SetReal", vr, nvr)) return fmi2Error;
    if (nvr > 0 && value == NULL) {
        LOG_ERR(inst, "fmi2SetReal: value is NULL");
        return fmi2Error;
    }
    for (i = 0; i < nvr; ++i) { /* validate everything before storing anything */
        why = not_settable(inst, vr[i]);
        if (why != NULL) {
            LOG_ERR(inst, "fmi2SetReal: cannot set '%s' (vr %lu) in state %s: %s",
                    fmu_model.names[vr[i]], (unsigned long)vr[i], state_name(inst->state), why);
            return fmi2Error;
        }
        if (!isfinite(value[i])) {
            LOG_ERR(inst, "fmi2SetReal: '%s' (vr %lu) must be finite, got %g",
                    fmu_model.names[vr[i]], (unsigned long)vr[i], value[i]);
            return fmi2Error;
        }
        inst->msg[0] = '\0';
        if (fmu_model.check_value(vr[i], value[i], inst->msg, sizeof inst->msg) != 0) {
            LOG_ERR(inst, "fmi2SetReal: '%s' = %g refused: %s", fmu_model.names[vr[i]],
                    value[i], inst->msg);
            return fmi2Error;
        }
    }
    for (i = 0; i < nvr; ++i) inst->r[vr[i]] = value[i];
    if (nvr > 0) inst->dirty = 1;
    return fmi2OK;
}

static fmi2Status no_such_type(fmi2Component c, const char *fn, const fmi2ValueReference vr[],
                               size_t nvr) {
    fmu_instance *inst = enter(c, fn, ALL_STATES, 0, 0);
    if (inst == NULL) return fmi2Error;
    if (nvr == 0) return fmi2OK;
    LOG_ERR(inst, "%s: unknown value reference %lu (the model has no variables of this type)",
            fn, vr ? (unsigned long)vr[0] : 0ul);
    return fmi2Error;
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Integer value[]) {
    (void)value;
    return no_such_type(c, "fmi2GetInteger", vr, nvr);
}
fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Boolean value[]) {
    (void)value;
    return no_such_type(c, "fmi2GetBoolean", vr, nvr);
}
fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                         fmi2String value[]) {
    (void)value;
    return no_such_type(c, "fmi2GetString", vr, nvr);
}
fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Integer value[]) {
    (void)value;
    return no_such_type(c, "fmi2SetInteger", vr, nvr);
}
fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Boolean value[]) {
    (void)value;
    return no_such_type(c, "fmi2SetBoolean", vr, nvr);
}
fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                         const fmi2String value[]) {
    (void)value;
    return no_such_type(c, "fmi2SetString", vr, nvr);
}

/* ------------------------------------------------------------------ FMU state */

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    fmu_instance *inst = enter(c, "fmi2GetFMUstate", ALL_STATES, 0, 0);
    fmu_snapshot *s;
    if (inst == NULL) return fmi2Error;
    if (FMUstate == NULL) {
        LOG_ERR(inst, "fmi2GetFMUstate: FMUstate is NULL");
        return fmi2Error;
    }
    s = (fmu_snapshot *)*FMUstate;
    if (s != NULL && s->magic != SNAP_MAGIC) {
        LOG_ERR(inst, "fmi2GetFMUstate: *FMUstate is neither NULL nor a state of this FMU");
        return fmi2Error;
    }
    if (s == NULL) {
        s = (fmu_snapshot *)inst->cb.allocateMemory(1, snapshot_bytes());
        if (s == NULL) {
            LOG_ERR(inst, "fmi2GetFMUstate: out of memory");
            return fmi2Error;
        }
    }
    s->magic = SNAP_MAGIC;
    s->type = inst->type;
    s->state = inst->state;
    s->time = inst->time;
    s->t_start = inst->t_start;
    memcpy(s->r, inst->r, fmu_model.n_reals * sizeof(double));
    *FMUstate = (fmi2FMUstate)s;
    return fmi2OK;
}

/* Is a snapshot consistent (type, state, finite values, valid parameters)? */
static int snapshot_valid(fmu_instance *inst, const fmu_snapshot *s, const char *fn) {
    size_t i;
    if (s->magic != SNAP_MAGIC) {
        LOG_ERR(inst, "%s: not an FMU state of this FMU", fn);
        return 0;
    }
    if (s->type != inst->type) {
        LOG_ERR(inst, "%s: the FMU state belongs to a %s instance", fn,
                s->type == fmi2ModelExchange ? "Model Exchange" : "Co-Simulation");
        return 0;
    }
    if (!((unsigned)s->state & ALL_STATES) ||
        ((unsigned)s->state & ((unsigned)s->state - 1u)) != 0) {
        LOG_ERR(inst, "%s: the FMU state has an invalid mode 0x%x (exactly one mode bit must "
                "be set)", fn, (unsigned)s->state);
        return 0;
    }
    if ((unsigned)s->state & (s->type == fmi2ModelExchange ? CS_ONLY_STATES : ME_ONLY_STATES)) {
        LOG_ERR(inst, "%s: the FMU state's mode %s does not exist for a %s instance", fn,
                state_name(s->state),
                s->type == fmi2ModelExchange ? "Model Exchange" : "Co-Simulation");
        return 0;
    }
    if (!isfinite(s->time) || !isfinite(s->t_start)) {
        LOG_ERR(inst, "%s: the FMU state has a non-finite time", fn);
        return 0;
    }
    for (i = 0; i < fmu_model.n_reals; ++i) {
        if (fmu_model.kind[i] == FMU_KIND_DERIVATIVE || fmu_model.kind[i] == FMU_KIND_OUTPUT)
            continue;
        inst->msg[0] = '\0';
        if (!isfinite(s->r[i]) || fmu_model.check_value(i, s->r[i], inst->msg,
                                                        sizeof inst->msg) != 0) {
            LOG_ERR(inst, "%s: the FMU state has an invalid value of '%s' (%g)%s%s", fn,
                    fmu_model.names[i], s->r[i], inst->msg[0] ? ": " : "", inst->msg);
            return 0;
        }
    }
    inst->msg[0] = '\0'; /* the start-value checks of fmi2ExitInitializationMode */
    if (fmu_model.check_initial(s->r, 1, inst->msg, sizeof inst->msg) != 0) {
        LOG_ERR(inst, "%s: the FMU state is inconsistent: %s", fn, inst->msg);
        return 0;
    }
    return 1;
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate) {
    fmu_instance *inst = enter(c, "fmi2SetFMUstate", ALL_STATES, 0, 0);
    const fmu_snapshot *s = (const fmu_snapshot *)FMUstate;
    if (inst == NULL) return fmi2Error;
    if (s == NULL) {
        LOG_ERR(inst, "fmi2SetFMUstate: FMUstate is NULL");
        return fmi2Error;
    }
    if (!snapshot_valid(inst, s, "fmi2SetFMUstate")) return fmi2Error;
    inst->state = s->state;
    inst->time = s->time;
    inst->t_start = s->t_start;
    memcpy(inst->r, s->r, fmu_model.n_reals * sizeof(double));
    inst->dirty = 1;
    return fmi2OK;
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    fmu_instance *inst = enter(c, "fmi2FreeFMUstate", ALL_STATES, 0, 0);
    fmu_snapshot *s;
    if (inst == NULL) return fmi2Error;
    if (FMUstate == NULL) {
        LOG_ERR(inst, "fmi2FreeFMUstate: FMUstate is NULL");
        return fmi2Error;
    }
    s = (fmu_snapshot *)*FMUstate;
    if (s == NULL) return fmi2OK;
    if (s->magic != SNAP_MAGIC) {
        LOG_ERR(inst, "fmi2FreeFMUstate: not an FMU state of this FMU");
        return fmi2Error;
    }
    s->magic = 0;
    inst->cb.freeMemory(s);
    *FMUstate = NULL;
    return fmi2OK;
}

/* Serialised layout: magic[8] | guid hash u64 | n_reals u64 | type i32 | state u32 |
 * time f64 | t_start f64 | r[n_reals] f64 | FNV-1a 64 checksum of everything before. */
static uint64_t fnv1a(const unsigned char *p, size_t n, uint64_t h) {
    size_t i;
    for (i = 0; i < n; ++i) {
        h ^= p[i];
        h *= 1099511628211ull;
    }
    return h;
}

#define FNV_OFFSET 1469598103934665603ull

static size_t serialized_size(void) {
    return 8 + 8 + 8 + 4 + 4 + 8 + 8 + fmu_model.n_reals * 8 + 8;
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate FMUstate, size_t *size) {
    fmu_instance *inst = enter(c, "fmi2SerializedFMUstateSize", ALL_STATES, 0, 0);
    if (inst == NULL) return fmi2Error;
    if (FMUstate == NULL || size == NULL ||
        ((const fmu_snapshot *)FMUstate)->magic != SNAP_MAGIC) {
        LOG_ERR(inst, "fmi2SerializedFMUstateSize: invalid FMUstate or size pointer");
        return fmi2Error;
    }
    *size = serialized_size();
    return fmi2OK;
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate, fmi2Byte data[],
                                 size_t size) {
    fmu_instance *inst = enter(c, "fmi2SerializeFMUstate", ALL_STATES, 0, 0);
    const fmu_snapshot *s = (const fmu_snapshot *)FMUstate;
    unsigned char *p = (unsigned char *)data;
    uint64_t u, h;
    int32_t ty;
    uint32_t st;
    if (inst == NULL) return fmi2Error;
    if (s == NULL || s->magic != SNAP_MAGIC || data == NULL) {
        LOG_ERR(inst, "fmi2SerializeFMUstate: invalid FMUstate or NULL buffer");
        return fmi2Error;
    }
    if (size < serialized_size()) {
        LOG_ERR(inst, "fmi2SerializeFMUstate: buffer of %lu bytes is too small, need %lu",
                (unsigned long)size, (unsigned long)serialized_size());
        return fmi2Error;
    }
    memcpy(p, SER_MAGIC, 8);
    p += 8;
    u = fnv1a((const unsigned char *)fmu_model.guid, strlen(fmu_model.guid), FNV_OFFSET);
    memcpy(p, &u, 8);
    p += 8;
    u = (uint64_t)fmu_model.n_reals;
    memcpy(p, &u, 8);
    p += 8;
    ty = (int32_t)s->type;
    memcpy(p, &ty, 4);
    p += 4;
    st = (uint32_t)s->state;
    memcpy(p, &st, 4);
    p += 4;
    memcpy(p, &s->time, 8);
    p += 8;
    memcpy(p, &s->t_start, 8);
    p += 8;
    memcpy(p, s->r, fmu_model.n_reals * 8);
    p += fmu_model.n_reals * 8;
    h = fnv1a((const unsigned char *)data, (size_t)(p - (unsigned char *)data), FNV_OFFSET);
    memcpy(p, &h, 8);
    return fmi2OK;
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[],
                                   size_t size, fmi2FMUstate *FMUstate) {
    fmu_instance *inst = enter(c, "fmi2DeSerializeFMUstate", ALL_STATES, 0, 0);
    const unsigned char *p = (const unsigned char *)serializedState;
    uint64_t u, h;
    int32_t ty;
    uint32_t st;
    fmu_snapshot *s;
    size_t need = serialized_size();
    const char *fn = "fmi2DeSerializeFMUstate";
    if (inst == NULL) return fmi2Error;
    if (p == NULL || FMUstate == NULL) {
        LOG_ERR(inst, "%s: NULL argument", fn);
        return fmi2Error;
    }
    if (*FMUstate != NULL && ((fmu_snapshot *)*FMUstate)->magic != SNAP_MAGIC) {
        LOG_ERR(inst, "%s: *FMUstate is neither NULL nor a state of this FMU", fn);
        return fmi2Error;
    }
    if (size != need) {
        LOG_ERR(inst, "%s: corrupt state: %lu bytes, expected %lu", fn, (unsigned long)size,
                (unsigned long)need);
        return fmi2Error;
    }
    if (memcmp(p, SER_MAGIC, 8) != 0) {
        LOG_ERR(inst, "%s: corrupt state: bad magic", fn);
        return fmi2Error;
    }
    memcpy(&h, p + need - 8, 8);
    if (h != fnv1a(p, need - 8, FNV_OFFSET)) {
        LOG_ERR(inst, "%s: corrupt state: checksum mismatch", fn);
        return fmi2Error;
    }
    memcpy(&u, p + 8, 8);
    if (u != fnv1a((const unsigned char *)fmu_model.guid, strlen(fmu_model.guid), FNV_OFFSET)) {
        LOG_ERR(inst, "%s: the state was serialised by an FMU with a different GUID", fn);
        return fmi2Error;
    }
    memcpy(&u, p + 16, 8);
    if (u != (uint64_t)fmu_model.n_reals) {
        LOG_ERR(inst, "%s: corrupt state: wrong number of variables", fn);
        return fmi2Error;
    }
    s = (fmu_snapshot *)*FMUstate;
    if (s == NULL) {
        s = (fmu_snapshot *)inst->cb.allocateMemory(1, snapshot_bytes());
        if (s == NULL) {
            LOG_ERR(inst, "%s: out of memory", fn);
            return fmi2Error;
        }
        *FMUstate = (fmi2FMUstate)s;
    }
    s->magic = SNAP_MAGIC;
    memcpy(&ty, p + 24, 4);
    memcpy(&st, p + 28, 4);
    s->type = (fmi2Type)ty;
    s->state = (fmu_state)st;
    memcpy(&s->time, p + 32, 8);
    memcpy(&s->t_start, p + 40, 8);
    memcpy(s->r, p + 48, fmu_model.n_reals * 8);
    if (!snapshot_valid(inst, s, fn)) {
        s->magic = 0;
        inst->cb.freeMemory(s);
        *FMUstate = NULL;
        return fmi2Error;
    }
    return fmi2OK;
}

/* ------------------------------------------------------------------ derivatives */

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c,
                                        const fmi2ValueReference vUnknown_ref[],
                                        size_t nUnknown, const fmi2ValueReference vKnown_ref[],
                                        size_t nKnown, const fmi2Real dvKnown[],
                                        fmi2Real dvUnknown[]) {
    const char *fn = "fmi2GetDirectionalDerivative";
    fmu_instance *inst = enter(c, fn,
                               FMU_ST_INIT | FMU_ST_EVENT | FMU_ST_CONT | FMU_ST_STEP_COMPLETE |
                                   FMU_ST_STEP_FAILED | FMU_ST_TERMINATED,
                               0, 0);
    size_t i;
    if (inst == NULL) return fmi2Error;
    if (!vr_ok(inst, fn, vUnknown_ref, nUnknown) || !vr_ok(inst, fn, vKnown_ref, nKnown))
        return fmi2Error;
    if ((nKnown > 0 && dvKnown == NULL) || (nUnknown > 0 && dvUnknown == NULL)) {
        LOG_ERR(inst, "%s: NULL value array", fn);
        return fmi2Error;
    }
    for (i = 0; i < nKnown; ++i) {
        if (!isfinite(dvKnown[i])) {
            LOG_ERR(inst, "%s: dvKnown[%lu] is not finite", fn, (unsigned long)i);
            return fmi2Error;
        }
    }
    inst->msg[0] = '\0';
    if (fmu_model.directional_derivative(inst, inst->r, vUnknown_ref, nUnknown, vKnown_ref,
                                         nKnown, dvKnown, dvUnknown, inst->msg,
                                         sizeof inst->msg) != 0) {
        LOG_ERR(inst, "%s: %s", fn, inst->msg);
        return fmi2Error;
    }
    return fmi2OK;
}

/* ------------------------------------------------------------------ Model Exchange */

fmi2Status fmi2EnterEventMode(fmi2Component c) {
    fmu_instance *inst = enter(c, "fmi2EnterEventMode", FMU_ST_EVENT | FMU_ST_CONT, 1, 0);
    if (inst == NULL) return fmi2Error;
    inst->state = FMU_ST_EVENT;
    return fmi2OK;
}

fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *eventInfo) {
    fmu_instance *inst = enter(c, "fmi2NewDiscreteStates", FMU_ST_EVENT, 1, 0);
    if (inst == NULL) return fmi2Error;
    if (eventInfo == NULL) {
        LOG_ERR(inst, "fmi2NewDiscreteStates: eventInfo is NULL");
        return fmi2Error;
    }
    eventInfo->newDiscreteStatesNeeded = fmi2False;
    eventInfo->terminateSimulation = fmi2False;
    eventInfo->nominalsOfContinuousStatesChanged = fmi2False;
    eventInfo->valuesOfContinuousStatesChanged = fmi2False;
    eventInfo->nextEventTimeDefined = fmi2False;
    eventInfo->nextEventTime = 0.0;
    return fmi2OK;
}

fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c) {
    fmu_instance *inst = enter(c, "fmi2EnterContinuousTimeMode", FMU_ST_EVENT, 1, 0);
    if (inst == NULL) return fmi2Error;
    inst->state = FMU_ST_CONT;
    return fmi2OK;
}

fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi2Boolean *enterEventMode,
                                       fmi2Boolean *terminateSimulation) {
    fmu_instance *inst = enter(c, "fmi2CompletedIntegratorStep", FMU_ST_CONT, 1, 0);
    (void)noSetFMUStatePriorToCurrentPoint;
    if (inst == NULL) return fmi2Error;
    if (enterEventMode == NULL || terminateSimulation == NULL) {
        LOG_ERR(inst, "fmi2CompletedIntegratorStep: NULL argument");
        return fmi2Error;
    }
    *enterEventMode = fmi2False;
    *terminateSimulation = fmi2False;
    return fmi2OK;
}

fmi2Status fmi2SetTime(fmi2Component c, fmi2Real time) {
    fmu_instance *inst = enter(c, "fmi2SetTime", FMU_ST_EVENT | FMU_ST_CONT, 1, 0);
    if (inst == NULL) return fmi2Error;
    if (!isfinite(time)) {
        LOG_ERR(inst, "fmi2SetTime: time must be finite, got %g", time);
        return fmi2Error;
    }
    inst->time = time;
    return fmi2OK;
}

static int n_ok(fmu_instance *inst, const char *fn, const void *p, size_t n, size_t expect) {
    if (p == NULL) {
        LOG_ERR(inst, "%s: NULL array", fn);
        return 0;
    }
    if (n != expect) {
        LOG_ERR(inst, "%s: size %lu, the model has %lu", fn, (unsigned long)n,
                (unsigned long)expect);
        return 0;
    }
    return 1;
}

fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t nx) {
    const char *fn = "fmi2SetContinuousStates";
    fmu_instance *inst = enter(c, fn, FMU_ST_CONT, 1, 0);
    size_t i;
    if (inst == NULL) return fmi2Error;
    if (!n_ok(inst, fn, x, nx, fmu_model.n_states)) return fmi2Error;
    for (i = 0; i < nx; ++i) {
        if (!isfinite(x[i])) {
            LOG_ERR(inst, "%s: state '%s' must be finite, got %g", fn,
                    fmu_model.names[fmu_model.state_vr0 + i], x[i]);
            return fmi2Error;
        }
    }
    memcpy(inst->r + fmu_model.state_vr0, x, nx * sizeof(double));
    inst->dirty = 1;
    return fmi2OK;
}

fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real derivatives[], size_t nx) {
    const char *fn = "fmi2GetDerivatives";
    fmu_instance *inst = enter(c, fn, FMU_ST_INIT | FMU_ST_EVENT | FMU_ST_CONT |
                                          FMU_ST_TERMINATED, 1, 0);
    if (inst == NULL) return fmi2Error;
    if (!n_ok(inst, fn, derivatives, nx, fmu_model.n_states)) return fmi2Error;
    if (refresh(inst, fn) != fmi2OK) return fmi2Error;
    memcpy(derivatives, inst->r + fmu_model.der_vr0, nx * sizeof(double));
    return fmi2OK;
}

fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real eventIndicators[], size_t ni) {
    fmu_instance *inst = enter(c, "fmi2GetEventIndicators",
                               FMU_ST_INIT | FMU_ST_EVENT | FMU_ST_CONT | FMU_ST_TERMINATED, 1, 0);
    (void)eventIndicators;
    if (inst == NULL) return fmi2Error;
    if (ni != 0) {
        LOG_ERR(inst, "fmi2GetEventIndicators: the model has no event indicators, got ni = %lu",
                (unsigned long)ni);
        return fmi2Error;
    }
    return fmi2OK;
}

fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t nx) {
    const char *fn = "fmi2GetContinuousStates";
    fmu_instance *inst =
        enter(c, fn, FMU_ST_INIT | FMU_ST_EVENT | FMU_ST_CONT | FMU_ST_TERMINATED, 1, 0);
    if (inst == NULL) return fmi2Error;
    if (!n_ok(inst, fn, x, nx, fmu_model.n_states)) return fmi2Error;
    memcpy(x, inst->r + fmu_model.state_vr0, nx * sizeof(double));
    return fmi2OK;
}

fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x_nominal[], size_t nx) {
    const char *fn = "fmi2GetNominalsOfContinuousStates";
    fmu_instance *inst = enter(c, fn,
                               FMU_ST_INSTANTIATED | FMU_ST_INIT | FMU_ST_EVENT | FMU_ST_CONT |
                                   FMU_ST_TERMINATED,
                               1, 0);
    size_t i;
    if (inst == NULL) return fmi2Error;
    if (!n_ok(inst, fn, x_nominal, nx, fmu_model.n_states)) return fmi2Error;
    for (i = 0; i < nx; ++i) x_nominal[i] = 1.0;
    return fmi2OK;
}

/* ------------------------------------------------------------------ Co-Simulation */

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[]) {
    fmu_instance *inst = enter(c, "fmi2SetRealInputDerivatives", ALL_STATES, 0, 1);
    (void)vr;
    (void)order;
    (void)value;
    if (inst == NULL) return fmi2Error;
    if (nvr == 0) return fmi2OK;
    LOG_ERR(inst, "fmi2SetRealInputDerivatives: not supported (canInterpolateInputs = false)");
    return fmi2Error;
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[]) {
    fmu_instance *inst = enter(c, "fmi2GetRealOutputDerivatives", ALL_STATES, 0, 1);
    (void)vr;
    (void)order;
    (void)value;
    if (inst == NULL) return fmi2Error;
    if (nvr == 0) return fmi2OK;
    LOG_ERR(inst, "fmi2GetRealOutputDerivatives: not supported (maxOutputDerivativeOrder = 0)");
    return fmi2Error;
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint,
                      fmi2Real communicationStepSize, fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
    const char *fn = "fmi2DoStep";
    fmu_instance *inst = enter(c, fn, FMU_ST_STEP_COMPLETE, 0, 1);
    double tol;
    (void)noSetFMUStatePriorToCurrentPoint;
    if (inst == NULL) return fmi2Error;
    if (!isfinite(communicationStepSize) || communicationStepSize <= 0.0) {
        LOG_ERR(inst, "%s: communicationStepSize must be finite and > 0, got %g", fn,
                communicationStepSize);
        return fmi2Error;
    }
    tol = 1e-9 * (1.0 + fabs(inst->time));
    if (!isfinite(currentCommunicationPoint) ||
        fabs(currentCommunicationPoint - inst->time) > tol) {
        LOG_ERR(inst, "%s: currentCommunicationPoint %.17g differs from the FMU time %.17g", fn,
                currentCommunicationPoint, inst->time);
        return fmi2Error;
    }
    memcpy(inst->r_backup, inst->r, fmu_model.n_reals * sizeof(double));
    inst->msg[0] = '\0';
    if (fmu_model.do_step(inst, inst->r, communicationStepSize, inst->msg, sizeof inst->msg) !=
        0) {
        memcpy(inst->r, inst->r_backup, fmu_model.n_reals * sizeof(double));
        inst->dirty = 1;
        fmu_log(inst, fmi2Discard, FMU_LOG_WARNING, "%s: step from t = %g discarded: %s", fn,
                inst->time, inst->msg);
        inst->state = FMU_ST_STEP_FAILED;
        return fmi2Discard;
    }
    inst->time = currentCommunicationPoint + communicationStepSize;
    inst->dirty = 1;
    return fmi2OK;
}

fmi2Status fmi2CancelStep(fmi2Component c) {
    fmu_instance *inst = enter(c, "fmi2CancelStep", ALL_STATES, 0, 1);
    if (inst == NULL) return fmi2Error;
    LOG_ERR(inst, "fmi2CancelStep: not supported (fmi2DoStep is synchronous)");
    return fmi2Error;
}

#define STATUS_STATES (FMU_ST_STEP_COMPLETE | FMU_ST_STEP_FAILED | FMU_ST_TERMINATED)

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value) {
    fmu_instance *inst = enter(c, "fmi2GetStatus", STATUS_STATES, 0, 1);
    if (inst == NULL) return fmi2Error;
    if (value == NULL || s != fmi2DoStepStatus) {
        LOG_ERR(inst, "fmi2GetStatus: only fmi2DoStepStatus is provided (non-NULL value)");
        return fmi2Error;
    }
    *value = inst->state == FMU_ST_STEP_FAILED ? fmi2Discard : fmi2OK;
    return fmi2OK;
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    fmu_instance *inst = enter(c, "fmi2GetRealStatus", STATUS_STATES, 0, 1);
    if (inst == NULL) return fmi2Error;
    if (value == NULL || s != fmi2LastSuccessfulTime) {
        LOG_ERR(inst, "fmi2GetRealStatus: only fmi2LastSuccessfulTime is provided");
        return fmi2Error;
    }
    *value = inst->time;
    return fmi2OK;
}

fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value) {
    fmu_instance *inst = enter(c, "fmi2GetIntegerStatus", STATUS_STATES, 0, 1);
    (void)s;
    (void)value;
    if (inst == NULL) return fmi2Error;
    LOG_ERR(inst, "fmi2GetIntegerStatus: no integer status is provided");
    return fmi2Error;
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value) {
    fmu_instance *inst = enter(c, "fmi2GetBooleanStatus", STATUS_STATES, 0, 1);
    if (inst == NULL) return fmi2Error;
    if (value == NULL || s != fmi2Terminated) {
        LOG_ERR(inst, "fmi2GetBooleanStatus: only fmi2Terminated is provided");
        return fmi2Error;
    }
    *value = fmi2False;
    return fmi2OK;
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value) {
    fmu_instance *inst = enter(c, "fmi2GetStringStatus", STATUS_STATES, 0, 1);
    (void)s;
    (void)value;
    if (inst == NULL) return fmi2Error;
    LOG_ERR(inst, "fmi2GetStringStatus: no string status is provided");
    return fmi2Error;
}
