/*
 * fmi2_common.c - shared, hand-written FMI 2.0 layer (Model Exchange and/or Co-Simulation).
 *
 * See fmi2_common.h.  Policies:
 *  - Every call checks the instance pointer, the FMU type and the state machine against
 *    one table (`call_rules` below: FMI 2.0 sections 3.2.3 and 4.2.4); a call in the
 *    wrong state returns fmi2Error with a message and leaves the instance unchanged.
 *    Which variable kind may be set in which state is a second table (`set_rules`).
 *  - Invalid arguments (unknown value reference, variable not settable now, NaN/Inf
 *    (NaN is accepted by Real inputs declared nan_missing: "no value"),
 *    value outside the variable's range, Boolean other than 0/1, NULL pointers, bad
 *    sizes) return fmi2Error with a message and change nothing: setters validate all
 *    values before storing any.
 *  - Numerical failure (non-finite derivatives or outputs) returns fmi2Error and puts the
 *    instance into the error state, where the value getters keep returning fmi2Error
 *    (never values that may be NaN) until fmi2Reset or fmi2SetFMUstate; a failed
 *    co-simulation step returns fmi2Discard, restores every value at the start of the
 *    step and enters the stepFailed state; a step the model refuses (fmi2Error) restores
 *    every value and keeps the state.
 *  - FMU states (fmi2SetFMUstate, fmi2DeSerializeFMUstate) are validated before they are
 *    restored: exactly one mode bit, matching FMU type, finite times, every stored value
 *    within its variable's range and the model's start-value checks (the checksum of a
 *    serialised state is public, so a crafted state must not bypass them).
 *  - Derivatives and continuous outputs are evaluated lazily: only a read of such a
 *    variable (or fmi2GetDerivatives) evaluates the model, once per change.
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

#define FMU_MAGIC 0x464d5532u  /* "FMU2" */
#define SNAP_MAGIC 0x534e4150u /* "SNAP" */
#define SER_MAGIC "FMU2SNP\x02"
#define MSG_LEN 512

#define NVARS(t) (fmu_model.vars->n[t])

static const char *const fmu_log_category_names[FMU_LOG_N] = {
    "logStatusError", "logStatusWarning", "logCalls"};
static const char *const type_names[FMU_NTYPES + 1] = {"Real", "Integer", "Boolean", "String"};

struct fmu_instance {
    unsigned magic;
    fmi2Type type;
    fmu_state state;
    fmi2CallbackFunctions cb;
    char *name;
    int log_on[FMU_LOG_N];
    double time;
    double t_start;
    int dirty;             /* derivatives/continuous outputs must be re-evaluated */
    int init_dirty;        /* initialization mode: held outputs must be re-computed */
    fmu_values v;          /* all values (one block) */
    fmu_values backup;     /* values at the start of a co-simulation step */
    double *jac;           /* Jacobian buffer (models with directional derivatives) */
    void *work;            /* model scratch memory */
    char msg[MSG_LEN];     /* message buffer of the model callbacks */
    char logbuf[2 * MSG_LEN + 16];
};

void *fmu_model_work(fmu_instance *inst) { return inst->work; }
double fmu_start_time(const fmu_instance *inst) { return inst->t_start; }

/* ------------------------------------------------------------------ the call table */

typedef enum {
    CALL_SET_DEBUG_LOGGING, CALL_SETUP_EXPERIMENT, CALL_ENTER_INIT, CALL_EXIT_INIT,
    CALL_TERMINATE, CALL_RESET,
    CALL_GET_REAL, CALL_GET_INTEGER, CALL_GET_BOOLEAN, CALL_GET_STRING,
    CALL_SET_REAL, CALL_SET_INTEGER, CALL_SET_BOOLEAN, CALL_SET_STRING,
    CALL_GET_FMU_STATE, CALL_SET_FMU_STATE, CALL_FREE_FMU_STATE, CALL_SERIALIZED_SIZE,
    CALL_SERIALIZE, CALL_DESERIALIZE, CALL_DIRECTIONAL_DERIVATIVE,
    CALL_ENTER_EVENT_MODE, CALL_NEW_DISCRETE_STATES, CALL_ENTER_CONT_MODE,
    CALL_COMPLETED_INTEGRATOR_STEP, CALL_SET_TIME, CALL_SET_CONT_STATES, CALL_GET_DERIVATIVES,
    CALL_GET_EVENT_INDICATORS, CALL_GET_CONT_STATES, CALL_GET_NOMINALS,
    CALL_SET_REAL_INPUT_DERIVATIVES, CALL_GET_REAL_OUTPUT_DERIVATIVES, CALL_DO_STEP,
    CALL_CANCEL_STEP, CALL_GET_STATUS, CALL_GET_REAL_STATUS, CALL_GET_INTEGER_STATUS,
    CALL_GET_BOOLEAN_STATUS, CALL_GET_STRING_STATUS,
    CALL_N
} fmu_call;

typedef struct {
    const char *name;
    unsigned interfaces; /* FMU_ME and/or FMU_CS instances may make the call */
    unsigned states;     /* fmu_state bits in which the call is allowed */
} call_rule;

#define ME FMU_ME
#define CS FMU_CS
#define RULE(fn, iface, inst, init, evnt, cont, step, fail, term, err)                         \
    {fn, iface,                                                                             \
     (inst ? FMU_ST_INSTANTIATED : 0u) | (init ? FMU_ST_INIT : 0u) |                        \
         (evnt ? FMU_ST_EVENT : 0u) | (cont ? FMU_ST_CONT : 0u) |                           \
         (step ? FMU_ST_STEP_COMPLETE : 0u) | (fail ? FMU_ST_STEP_FAILED : 0u) |            \
         (term ? FMU_ST_TERMINATED : 0u) | (err ? FMU_ST_ERROR : 0u)}

/* Which call is allowed in which state (1) for which instance type: the only place the
 * call sequence is checked.  Columns: instantiated, initializationMode, eventMode,
 * continuousTimeMode (ME), stepComplete, stepFailed (CS), terminated, error.  No call but
 * fmi2FreeInstance is allowed in the fatal state.  Deviations from the FMI 2.0 tables:
 * the value getters and directional derivatives are refused in the error state (values
 * may be NaN there); fmi2CancelStep is answered (with an error) in stepComplete and
 * stepFailed, since fmi2DoStep never returns fmi2Pending. */
static const call_rule call_rules[CALL_N] = {
    /*                                                           inst init evnt cont step fail term err */
    [CALL_SET_DEBUG_LOGGING] = RULE("fmi2SetDebugLogging", ME | CS, 1, 1, 1, 1, 1, 1, 1, 1),
    [CALL_SETUP_EXPERIMENT] = RULE("fmi2SetupExperiment", ME | CS,  1, 0, 0, 0, 0, 0, 0, 0),
    [CALL_ENTER_INIT] = RULE("fmi2EnterInitializationMode", ME | CS, 1, 0, 0, 0, 0, 0, 0, 0),
    [CALL_EXIT_INIT] = RULE("fmi2ExitInitializationMode", ME | CS,  0, 1, 0, 0, 0, 0, 0, 0),
    [CALL_TERMINATE] = RULE("fmi2Terminate", ME | CS,               0, 0, 1, 1, 1, 1, 0, 0),
    [CALL_RESET] = RULE("fmi2Reset", ME | CS,                       1, 1, 1, 1, 1, 1, 1, 1),
    [CALL_GET_REAL] = RULE("fmi2GetReal", ME | CS,                  0, 1, 1, 1, 1, 1, 1, 0),
    [CALL_GET_INTEGER] = RULE("fmi2GetInteger", ME | CS,            0, 1, 1, 1, 1, 1, 1, 0),
    [CALL_GET_BOOLEAN] = RULE("fmi2GetBoolean", ME | CS,            0, 1, 1, 1, 1, 1, 1, 0),
    [CALL_GET_STRING] = RULE("fmi2GetString", ME | CS,              0, 1, 1, 1, 1, 1, 1, 0),
    [CALL_SET_REAL] = RULE("fmi2SetReal", ME | CS,                  1, 1, 1, 1, 1, 0, 0, 0),
    [CALL_SET_INTEGER] = RULE("fmi2SetInteger", ME | CS,            1, 1, 1, 1, 1, 0, 0, 0),
    [CALL_SET_BOOLEAN] = RULE("fmi2SetBoolean", ME | CS,            1, 1, 1, 1, 1, 0, 0, 0),
    [CALL_SET_STRING] = RULE("fmi2SetString", ME | CS,              1, 1, 1, 1, 1, 0, 0, 0),
    [CALL_GET_FMU_STATE] = RULE("fmi2GetFMUstate", ME | CS,         1, 1, 1, 1, 1, 1, 1, 1),
    [CALL_SET_FMU_STATE] = RULE("fmi2SetFMUstate", ME | CS,         1, 1, 1, 1, 1, 1, 1, 1),
    [CALL_FREE_FMU_STATE] = RULE("fmi2FreeFMUstate", ME | CS,       1, 1, 1, 1, 1, 1, 1, 1),
    [CALL_SERIALIZED_SIZE] = RULE("fmi2SerializedFMUstateSize", ME | CS, 1, 1, 1, 1, 1, 1, 1, 1),
    [CALL_SERIALIZE] = RULE("fmi2SerializeFMUstate", ME | CS,       1, 1, 1, 1, 1, 1, 1, 1),
    [CALL_DESERIALIZE] = RULE("fmi2DeSerializeFMUstate", ME | CS,   1, 1, 1, 1, 1, 1, 1, 1),
    [CALL_DIRECTIONAL_DERIVATIVE] = RULE("fmi2GetDirectionalDerivative", ME | CS,
                                                                    0, 1, 1, 1, 1, 1, 1, 0),
    [CALL_ENTER_EVENT_MODE] = RULE("fmi2EnterEventMode", ME,        0, 0, 1, 1, 0, 0, 0, 0),
    [CALL_NEW_DISCRETE_STATES] = RULE("fmi2NewDiscreteStates", ME,  0, 0, 1, 0, 0, 0, 0, 0),
    [CALL_ENTER_CONT_MODE] = RULE("fmi2EnterContinuousTimeMode", ME, 0, 0, 1, 0, 0, 0, 0, 0),
    [CALL_COMPLETED_INTEGRATOR_STEP] = RULE("fmi2CompletedIntegratorStep", ME,
                                                                    0, 0, 0, 1, 0, 0, 0, 0),
    [CALL_SET_TIME] = RULE("fmi2SetTime", ME,                       0, 0, 1, 1, 0, 0, 0, 0),
    [CALL_SET_CONT_STATES] = RULE("fmi2SetContinuousStates", ME,    0, 0, 0, 1, 0, 0, 0, 0),
    [CALL_GET_DERIVATIVES] = RULE("fmi2GetDerivatives", ME,         0, 1, 1, 1, 0, 0, 1, 0),
    [CALL_GET_EVENT_INDICATORS] = RULE("fmi2GetEventIndicators", ME, 0, 1, 1, 1, 0, 0, 1, 0),
    [CALL_GET_CONT_STATES] = RULE("fmi2GetContinuousStates", ME,    0, 1, 1, 1, 0, 0, 1, 0),
    [CALL_GET_NOMINALS] = RULE("fmi2GetNominalsOfContinuousStates", ME,
                                                                    1, 1, 1, 1, 0, 0, 1, 0),
    [CALL_SET_REAL_INPUT_DERIVATIVES] = RULE("fmi2SetRealInputDerivatives", CS,
                                                                    1, 1, 0, 0, 1, 0, 0, 0),
    [CALL_GET_REAL_OUTPUT_DERIVATIVES] = RULE("fmi2GetRealOutputDerivatives", CS,
                                                                    0, 0, 0, 0, 1, 1, 1, 0),
    [CALL_DO_STEP] = RULE("fmi2DoStep", CS,                         0, 0, 0, 0, 1, 0, 0, 0),
    [CALL_CANCEL_STEP] = RULE("fmi2CancelStep", CS,                 0, 0, 0, 0, 1, 1, 0, 0),
    [CALL_GET_STATUS] = RULE("fmi2GetStatus", CS,                   0, 0, 0, 0, 1, 1, 1, 0),
    [CALL_GET_REAL_STATUS] = RULE("fmi2GetRealStatus", CS,          0, 0, 0, 0, 1, 1, 1, 0),
    [CALL_GET_INTEGER_STATUS] = RULE("fmi2GetIntegerStatus", CS,    0, 0, 0, 0, 1, 1, 1, 0),
    [CALL_GET_BOOLEAN_STATUS] = RULE("fmi2GetBooleanStatus", CS,    0, 0, 0, 0, 1, 1, 1, 0),
    [CALL_GET_STRING_STATUS] = RULE("fmi2GetStringStatus", CS,      0, 0, 0, 0, 1, 1, 1, 0),
};
#undef RULE

/* When may a variable of each kind be set (fmi2Set*), per instance type. */
typedef struct {
    unsigned me, cs;
    const char *why; /* reason of a refusal */
} set_rule;

#define ST_BEFORE_INIT_END (FMU_ST_INSTANTIATED | FMU_ST_INIT)
static const set_rule set_rules[FMU_KIND_N] = {
    [0] = {0u, 0u, "the variable has no kind"},
    [FMU_KIND_STATE] = {ST_BEFORE_INIT_END | FMU_ST_EVENT | FMU_ST_CONT, ST_BEFORE_INIT_END,
                        "states can only be set before initialisation ends (Model Exchange: "
                        "also in event and continuous-time mode)"},
    [FMU_KIND_DERIVATIVE] = {0u, 0u, "derivatives are calculated and cannot be set"},
    [FMU_KIND_INPUT] = {ST_BEFORE_INIT_END | FMU_ST_EVENT | FMU_ST_CONT,
                        ST_BEFORE_INIT_END | FMU_ST_STEP_COMPLETE,
                        "inputs cannot be set in this state"},
    [FMU_KIND_DISCRETE_INPUT] = {ST_BEFORE_INIT_END | FMU_ST_EVENT,
                                 ST_BEFORE_INIT_END | FMU_ST_STEP_COMPLETE,
                                 "discrete inputs can only be set in event mode, between "
                                 "steps or before initialisation ends"},
    [FMU_KIND_OUTPUT] = {0u, 0u, "outputs are calculated and cannot be set"},
    [FMU_KIND_DISCRETE_OUTPUT] = {0u, 0u, "outputs are calculated and cannot be set"},
    [FMU_KIND_PARAMETER] = {ST_BEFORE_INIT_END, ST_BEFORE_INIT_END,
                            "fixed parameters can only be set before initialisation ends"},
    [FMU_KIND_LOCAL] = {0u, 0u, "local variables are internal states of the model and cannot "
                                "be set"},
};
#undef ME
#undef CS

#define ALL_STATES                                                                          \
    (FMU_ST_INSTANTIATED | FMU_ST_INIT | FMU_ST_EVENT | FMU_ST_CONT | FMU_ST_STEP_COMPLETE |  \
     FMU_ST_STEP_FAILED | FMU_ST_TERMINATED | FMU_ST_ERROR)
#define ME_ONLY_STATES (FMU_ST_EVENT | FMU_ST_CONT)
#define CS_ONLY_STATES (FMU_ST_STEP_COMPLETE | FMU_ST_STEP_FAILED)

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

/* Log a model callback's message with the status it returned (nothing for fmi2OK). */
static void log_model(fmu_instance *inst, fmi2Status st, const char *fn) {
    if (st == fmi2OK) return;
    if (st == fmi2Warning || st == fmi2Discard)
        fmu_log(inst, st, FMU_LOG_WARNING, "%s: %s", fn, inst->msg);
    else
        fmu_log(inst, st, FMU_LOG_ERROR, "%s: %s", fn, inst->msg);
}

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

static unsigned interface_of(fmi2Type type) {
    return type == fmi2ModelExchange ? FMU_ME : FMU_CS;
}

/* Resolve the instance and check the call against the call table; NULL if refused (logged). */
static fmu_instance *enter(fmi2Component c, fmu_call call) {
    const call_rule *rule = &call_rules[call];
    fmu_instance *inst = as_instance(c);
    if (inst == NULL) return NULL; /* nothing to log to */
    if (!(rule->interfaces & interface_of(inst->type))) {
        LOG_ERR(inst, "%s: only available for %s instances", rule->name,
                rule->interfaces == FMU_ME ? "Model Exchange" : "Co-Simulation");
        return NULL;
    }
    if (!(inst->state & rule->states)) {
        if (inst->state == FMU_ST_ERROR)
            LOG_ERR(inst, "%s: not allowed in state error: the instance is in the error state "
                          "after a failed call at t = %g; call fmi2Reset (or fmi2SetFMUstate) "
                          "first", rule->name, inst->time);
        else
            LOG_ERR(inst, "%s: not allowed in state %s", rule->name, state_name(inst->state));
        return NULL;
    }
    LOG_CALL(inst, "%s", rule->name);
    return inst;
}

/* The descriptor of value reference vr of type t (its value index in *ix), or NULL. */
static const fmu_var *lookup(fmu_vtype t, fmi2ValueReference vr, size_t *ix) {
    const fmu_variables *V = fmu_model.vars;
    *ix = 0;
    if (t >= FMU_NTYPES || vr < V->vr0[t] || (size_t)(vr - V->vr0[t]) >= V->n[t]) return NULL;
    *ix = (size_t)(vr - V->vr0[t]);
    return &V->var[t][*ix];
}

/* Are all value references known variables of type t (t = FMU_NTYPES: String)? */
static int vrs_ok(fmu_instance *inst, const char *fn, fmu_vtype t, const fmi2ValueReference vr[],
                  size_t nvr) {
    size_t i, ix;
    if (nvr > 0 && vr == NULL) {
        LOG_ERR(inst, "%s: vr is NULL but nvr = %lu", fn, (unsigned long)nvr);
        return 0;
    }
    for (i = 0; i < nvr; ++i) {
        if (lookup(t, vr[i], &ix) == NULL) {
            LOG_ERR(inst, "%s: unknown value reference %lu (no %s variable has it)", fn,
                    (unsigned long)vr[i], type_names[t]);
            return 0;
        }
    }
    return 1;
}

/* Is v an allowed stored value of variable d of type t?  1, or 0 with a reason in msg. */
static int value_ok(fmu_vtype t, const fmu_var *d, double v, char *msg, size_t len) {
    if (t == FMU_REAL && isnan(v) && d->nan_missing) return 1; /* "no value" */
    if (t == FMU_REAL && !isfinite(v)) {
        snprintf(msg, len, "must be finite, got %g", v);
        return 0;
    }
    if (t == FMU_BOOLEAN && v != 0.0 && v != 1.0) {
        snprintf(msg, len, "must be fmi2True (1) or fmi2False (0), got %.0f", v);
        return 0;
    }
    if ((d->min_open ? !(v > d->min) : !(v >= d->min)) ||
        (d->max_open ? !(v < d->max) : !(v <= d->max))) {
        if (d->rule != NULL)
            snprintf(msg, len, "non-physical value, must be %s", d->rule);
        else
            snprintf(msg, len, "out of range, must be in [%.17g, %.17g]", d->min, d->max);
        return 0;
    }
    return 1;
}

static double stored(const fmu_values *v, fmu_vtype t, size_t ix) {
    if (t == FMU_REAL) return v->r[ix];
    if (t == FMU_INTEGER) return (double)v->i[ix];
    return (double)v->b[ix];
}

/* Is the kind calculated by evaluate (read through refresh)? */
static int evaluated(unsigned kind) {
    return kind == FMU_KIND_DERIVATIVE || kind == FMU_KIND_OUTPUT;
}

/* Evaluate derivatives and continuous outputs if inputs, states or parameters changed. */
static fmi2Status refresh(fmu_instance *inst, const char *fn) {
    if (!inst->dirty) return fmi2OK;
    if (fmu_model.evaluate != NULL && fmu_model.evaluate(inst, &inst->v) != 0) {
        LOG_ERR(inst, "%s: the model evaluated to NaN or Inf at t = %g", fn, inst->time);
        inst->state = FMU_ST_ERROR;
        return fmi2Error;
    }
    inst->dirty = 0;
    return fmi2OK;
}

/* ------------------------------------------------------------------ values */

static size_t values_bytes(void) {
    return NVARS(FMU_REAL) * sizeof(double) + NVARS(FMU_INTEGER) * sizeof(fmi2Integer) +
           NVARS(FMU_BOOLEAN) * sizeof(fmi2Boolean);
}

/* Point v at a block of values_bytes() (reals first: aligned for double). */
static void bind_values(fmu_values *v, void *block) {
    v->r = (double *)block;
    v->i = (fmi2Integer *)(v->r + NVARS(FMU_REAL));
    v->b = (fmi2Boolean *)(v->i + NVARS(FMU_INTEGER));
}

static void copy_values(fmu_values *dst, const fmu_values *src) {
    memcpy(dst->r, src->r, values_bytes()); /* one contiguous block */
}

/* Initialization mode: the held outputs (and the model's discrete states) computed by the
 * model's initialize callback from the values set so far, so that an importer reading
 * the initial unknowns before fmi2ExitInitializationMode gets them (FMI 2.0 section
 * 3.2.3).  If the values are not consistent yet (check_initial) or initialize fails, the
 * stored values are kept and nothing is logged: fmi2ExitInitializationMode reports it. */
static void preview_initial(fmu_instance *inst) {
    fmi2Status st;
    if (!inst->init_dirty || fmu_model.initialize == NULL) return;
    inst->msg[0] = '\0';
    if (fmu_model.check_initial != NULL &&
        fmu_model.check_initial(&inst->v, 0, inst->msg, sizeof inst->msg) != 0)
        return;
    copy_values(&inst->backup, &inst->v);
    st = fmu_model.initialize(inst, &inst->v, inst->time, inst->msg, sizeof inst->msg);
    if (st != fmi2OK && st != fmi2Warning) copy_values(&inst->v, &inst->backup);
    inst->init_dirty = 0;
}

static void load_start(fmu_instance *inst) {
    size_t k;
    const fmu_variables *V = fmu_model.vars;
    for (k = 0; k < V->n[FMU_REAL]; ++k) inst->v.r[k] = V->var[FMU_REAL][k].start;
    for (k = 0; k < V->n[FMU_INTEGER]; ++k)
        inst->v.i[k] = (fmi2Integer)V->var[FMU_INTEGER][k].start;
    for (k = 0; k < V->n[FMU_BOOLEAN]; ++k)
        inst->v.b[k] = V->var[FMU_BOOLEAN][k].start != 0.0 ? fmi2True : fmi2False;
    inst->time = 0.0;
    inst->t_start = 0.0;
    inst->dirty = inst->init_dirty = 1;
}

/* ------------------------------------------------------------------ common API */

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[]) {
    fmu_instance *inst = enter(c, CALL_SET_DEBUG_LOGGING);
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

/* Instance memory is one block (one allocation, one free): the instance, the model work
 * memory, the values, their backup, the Jacobian and the name, each on whole cache lines. */
#define CACHE_LINE 64u
static size_t whole_lines(size_t n) { return (n + CACHE_LINE - 1u) / CACHE_LINE * CACHE_LINE; }

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType,
                              fmi2String fmuGUID, fmi2String fmuResourceLocation,
                              const fmi2CallbackFunctions *functions, fmi2Boolean visible,
                              fmi2Boolean loggingOn) {
    fmu_instance *inst;
    const char *name = instanceName ? instanceName : "(null)";
    const fmu_variables *V = fmu_model.vars;
    size_t len, off_work, off_val, off_bak, off_jac, off_name;
    size_t njac = (V->n_states + V->n_outputs) * (V->n_states + V->n_inputs);
    unsigned char *block;
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
    if (!(fmu_model.interfaces & interface_of(fmuType))) {
        early_error(functions, name, "fmi2Instantiate: %s does not implement %s",
                    fmu_model.model_identifier,
                    fmuType == fmi2ModelExchange ? "Model Exchange" : "Co-Simulation");
        return NULL;
    }
    if (fmuGUID == NULL || strcmp(fmuGUID, fmu_model.guid) != 0) {
        early_error(functions, name,
                    "fmi2Instantiate: wrong GUID '%s', this binary of %s has GUID '%s'",
                    fmuGUID ? fmuGUID : "(null)", fmu_model.model_identifier, fmu_model.guid);
        return NULL;
    }
    len = strlen(instanceName) + 1;
    off_work = whole_lines(sizeof(fmu_instance));
    off_val = off_work + whole_lines(fmu_model.work_bytes);
    off_bak = off_val + whole_lines(values_bytes());
    off_jac = off_bak + whole_lines(values_bytes());
    off_name = off_jac + whole_lines(njac * sizeof(double));
    block = (unsigned char *)functions->allocateMemory((off_name + len) / sizeof(double) + 1,
                                                       sizeof(double));
    if (block == NULL) {
        early_error(functions, name, "fmi2Instantiate: out of memory");
        return NULL;
    }
    inst = (fmu_instance *)(void *)block;
    memset(inst, 0, sizeof *inst);
    inst->cb = *functions;
    inst->work = fmu_model.work_bytes ? (void *)(block + off_work) : NULL;
    bind_values(&inst->v, block + off_val);
    bind_values(&inst->backup, block + off_bak);
    inst->jac = fmu_model.jacobian != NULL && njac > 0 ? (double *)(void *)(block + off_jac)
                                                        : NULL;
    inst->name = (char *)(block + off_name);
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
    fmi2CallbackFunctions cb;
    if (inst == NULL) return; /* allowed in every state, fatal included */
    LOG_CALL(inst, "fmi2FreeInstance");
    cb = inst->cb;
    inst->magic = 0;
    cb.freeMemory(inst); /* one block */
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined,
                               fmi2Real tolerance, fmi2Real startTime,
                               fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    fmu_instance *inst = enter(c, CALL_SETUP_EXPERIMENT);
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
    fmu_instance *inst = enter(c, CALL_ENTER_INIT);
    if (inst == NULL) return fmi2Error;
    inst->state = FMU_ST_INIT;
    inst->dirty = inst->init_dirty = 1;
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    const char *fn = "fmi2ExitInitializationMode";
    fmu_instance *inst = enter(c, CALL_EXIT_INIT);
    fmi2Status st = fmi2OK;
    if (inst == NULL) return fmi2Error;
    inst->msg[0] = '\0';
    if (fmu_model.check_initial != NULL &&
        fmu_model.check_initial(&inst->v, 0, inst->msg, sizeof inst->msg) != 0) {
        LOG_ERR(inst, "%s: %s", fn, inst->msg);
        return fmi2Error;
    }
    inst->dirty = inst->init_dirty = 1;
    if (refresh(inst, fn) != fmi2OK) return fmi2Error; /* error state */
    if (fmu_model.initialize != NULL) { /* refused: stay in initialisation mode */
        st = fmu_model.initialize(inst, &inst->v, inst->time, inst->msg, sizeof inst->msg);
        log_model(inst, st, fn);
        if (st != fmi2OK && st != fmi2Warning) return fmi2Error;
        inst->dirty = inst->init_dirty = 1;
    }
    inst->state = inst->type == fmi2ModelExchange ? FMU_ST_EVENT : FMU_ST_STEP_COMPLETE;
    return st;
}

fmi2Status fmi2Terminate(fmi2Component c) {
    fmu_instance *inst = enter(c, CALL_TERMINATE);
    if (inst == NULL) return fmi2Error;
    inst->state = FMU_ST_TERMINATED;
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component c) {
    fmu_instance *inst = enter(c, CALL_RESET);
    if (inst == NULL) return fmi2Error;
    load_start(inst);
    inst->state = FMU_ST_INSTANTIATED;
    return fmi2OK;
}

/* ------------------------------------------------------------------ get / set */

static fmi2Status get_values(fmi2Component c, fmu_call call, fmu_vtype t,
                             const fmi2ValueReference vr[], size_t nvr, void *value) {
    fmu_instance *inst = enter(c, call);
    const char *fn = call_rules[call].name;
    size_t i, ix = 0;
    int need_eval = 0;
    if (inst == NULL) return fmi2Error;
    if (!vrs_ok(inst, fn, t, vr, nvr)) return fmi2Error;
    if (nvr > 0 && value == NULL) {
        LOG_ERR(inst, "%s: value is NULL", fn);
        return fmi2Error;
    }
    if (t == FMU_REAL)
        for (i = 0; i < nvr && !need_eval; ++i)
            need_eval = evaluated(lookup(t, vr[i], &ix)->kind);
    if (need_eval && refresh(inst, fn) != fmi2OK) return fmi2Error;
    if (inst->state == FMU_ST_INIT) preview_initial(inst);
    for (i = 0; i < nvr; ++i) {
        lookup(t, vr[i], &ix);
        if (t == FMU_REAL)
            ((fmi2Real *)value)[i] = inst->v.r[ix];
        else if (t == FMU_INTEGER)
            ((fmi2Integer *)value)[i] = inst->v.i[ix];
        else
            ((fmi2Boolean *)value)[i] = inst->v.b[ix];
    }
    return fmi2OK;
}

static double given(fmu_vtype t, const void *value, size_t i) {
    if (t == FMU_REAL) return ((const fmi2Real *)value)[i];
    if (t == FMU_INTEGER) return (double)((const fmi2Integer *)value)[i];
    return (double)((const fmi2Boolean *)value)[i];
}

static fmi2Status set_values(fmi2Component c, fmu_call call, fmu_vtype t,
                             const fmi2ValueReference vr[], size_t nvr, const void *value) {
    fmu_instance *inst = enter(c, call);
    const char *fn = call_rules[call].name;
    size_t i, ix = 0;
    if (inst == NULL) return fmi2Error;
    if (!vrs_ok(inst, fn, t, vr, nvr)) return fmi2Error;
    if (nvr > 0 && value == NULL) {
        LOG_ERR(inst, "%s: value is NULL", fn);
        return fmi2Error;
    }
    for (i = 0; i < nvr; ++i) { /* validate everything before storing anything */
        const fmu_var *d = lookup(t, vr[i], &ix);
        const set_rule *rule = &set_rules[d->kind < FMU_KIND_N ? d->kind : 0];
        double x = given(t, value, i);
        if (!(inst->state & (inst->type == fmi2ModelExchange ? rule->me : rule->cs))) {
            LOG_ERR(inst, "%s: cannot set '%s' (vr %lu) in state %s: %s", fn, d->name,
                    (unsigned long)vr[i], state_name(inst->state), rule->why);
            return fmi2Error;
        }
        inst->msg[0] = '\0';
        if (!value_ok(t, d, x, inst->msg, sizeof inst->msg)) {
            if (t == FMU_REAL && !isfinite(x))
                LOG_ERR(inst, "%s: '%s' (vr %lu) %s", fn, d->name, (unsigned long)vr[i],
                        inst->msg);
            else
                LOG_ERR(inst, "%s: '%s' = %.17g refused: %s", fn, d->name, x, inst->msg);
            return fmi2Error;
        }
    }
    for (i = 0; i < nvr; ++i) {
        lookup(t, vr[i], &ix);
        if (t == FMU_REAL)
            inst->v.r[ix] = ((const fmi2Real *)value)[i];
        else if (t == FMU_INTEGER)
            inst->v.i[ix] = ((const fmi2Integer *)value)[i];
        else
            inst->v.b[ix] = ((const fmi2Boolean *)value)[i];
    }
    if (nvr > 0) inst->dirty = inst->init_dirty = 1;
    return fmi2OK;
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       fmi2Real value[]) {
    return get_values(c, CALL_GET_REAL, FMU_REAL, vr, nvr, value);
}
fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Integer value[]) {
    return get_values(c, CALL_GET_INTEGER, FMU_INTEGER, vr, nvr, value);
}
fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Boolean value[]) {
    return get_values(c, CALL_GET_BOOLEAN, FMU_BOOLEAN, vr, nvr, value);
}
fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       const fmi2Real value[]) {
    return set_values(c, CALL_SET_REAL, FMU_REAL, vr, nvr, value);
}
fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Integer value[]) {
    return set_values(c, CALL_SET_INTEGER, FMU_INTEGER, vr, nvr, value);
}
fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Boolean value[]) {
    return set_values(c, CALL_SET_BOOLEAN, FMU_BOOLEAN, vr, nvr, value);
}

/* No String variables: any value reference is unknown. */
static fmi2Status no_strings(fmi2Component c, fmu_call call, const fmi2ValueReference vr[],
                             size_t nvr) {
    fmu_instance *inst = enter(c, call);
    if (inst == NULL) return fmi2Error;
    if (!vrs_ok(inst, call_rules[call].name, FMU_NTYPES, vr, nvr)) return fmi2Error;
    return fmi2OK; /* nvr == 0 */
}
fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                         fmi2String value[]) {
    (void)value;
    return no_strings(c, CALL_GET_STRING, vr, nvr);
}
fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                         const fmi2String value[]) {
    (void)value;
    return no_strings(c, CALL_SET_STRING, vr, nvr);
}

/* ------------------------------------------------------------------ FMU state */

/* Snapshot created by fmi2GetFMUstate: the mode, the times and every value. */
typedef struct {
    unsigned magic;
    fmi2Type type;
    fmu_state state;
    double time;
    double t_start;
    double data[1]; /* values_bytes(): reals, integers, booleans */
} fmu_snapshot;

static size_t snapshot_bytes(void) { return offsetof(fmu_snapshot, data) + values_bytes(); }

static fmu_values snapshot_values(fmu_snapshot *s) {
    fmu_values v;
    bind_values(&v, s->data);
    return v;
}

static fmu_snapshot *new_snapshot(fmu_instance *inst, const char *fn) {
    fmu_snapshot *s = (fmu_snapshot *)inst->cb.allocateMemory(
        snapshot_bytes() / sizeof(double) + 1, sizeof(double));
    if (s == NULL) LOG_ERR(inst, "%s: out of memory", fn);
    return s;
}

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    fmu_instance *inst = enter(c, CALL_GET_FMU_STATE);
    fmu_snapshot *s;
    fmu_values v;
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
    if (s == NULL && (s = new_snapshot(inst, "fmi2GetFMUstate")) == NULL) return fmi2Error;
    s->magic = SNAP_MAGIC;
    s->type = inst->type;
    s->state = inst->state;
    s->time = inst->time;
    s->t_start = inst->t_start;
    v = snapshot_values(s);
    copy_values(&v, &inst->v);
    *FMUstate = (fmi2FMUstate)s;
    return fmi2OK;
}

/* Is a snapshot consistent (type, mode, finite times, every stored value in range, the
 * model's start-value checks)?  Logs the reason if not. */
static int snapshot_valid(fmu_instance *inst, fmu_snapshot *s, const char *fn) {
    fmu_values v;
    size_t k;
    int t;
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
    v = snapshot_values(s);
    for (t = 0; t < FMU_NTYPES; ++t) {
        for (k = 0; k < NVARS(t); ++k) {
            const fmu_var *d = &fmu_model.vars->var[t][k];
            double x = stored(&v, (fmu_vtype)t, k);
            if (evaluated(d->kind)) continue; /* recomputed */
            inst->msg[0] = '\0';
            if (!value_ok((fmu_vtype)t, d, x, inst->msg, sizeof inst->msg)) {
                LOG_ERR(inst, "%s: the FMU state has an invalid value of '%s' (%g): %s", fn,
                        d->name, x, inst->msg);
                return 0;
            }
        }
    }
    inst->msg[0] = '\0'; /* the start-value checks of fmi2ExitInitializationMode */
    if (fmu_model.check_initial != NULL &&
        fmu_model.check_initial(&v, 1, inst->msg, sizeof inst->msg) != 0) {
        LOG_ERR(inst, "%s: the FMU state is inconsistent: %s", fn, inst->msg);
        return 0;
    }
    return 1;
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate) {
    fmu_instance *inst = enter(c, CALL_SET_FMU_STATE);
    fmu_snapshot *s = (fmu_snapshot *)FMUstate;
    fmu_values v;
    if (inst == NULL) return fmi2Error;
    if (s == NULL) {
        LOG_ERR(inst, "fmi2SetFMUstate: FMUstate is NULL");
        return fmi2Error;
    }
    if (!snapshot_valid(inst, s, "fmi2SetFMUstate")) return fmi2Error;
    inst->state = s->state;
    inst->time = s->time;
    inst->t_start = s->t_start;
    v = snapshot_values(s);
    copy_values(&inst->v, &v);
    inst->dirty = inst->init_dirty = 1;
    return fmi2OK;
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    fmu_instance *inst = enter(c, CALL_FREE_FMU_STATE);
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

/* Serialised layout (host byte order):
 *   magic[8] "FMU2SNP\x02" | GUID hash u64 | n_reals u64 | n_integers u64 | n_booleans u64 |
 *   type i32 | mode u32 | time f64 | t_start f64 | reals f64[n_reals] |
 *   integers i32[n_integers] | booleans i32[n_booleans] | FNV-1a 64 of everything before. */
#define SER_HEADER 64
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
    return SER_HEADER + NVARS(FMU_REAL) * 8 + (NVARS(FMU_INTEGER) + NVARS(FMU_BOOLEAN)) * 4 + 8;
}

static uint64_t guid_hash(void) {
    return fnv1a((const unsigned char *)fmu_model.guid, strlen(fmu_model.guid), FNV_OFFSET);
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate FMUstate, size_t *size) {
    fmu_instance *inst = enter(c, CALL_SERIALIZED_SIZE);
    if (inst == NULL) return fmi2Error;
    if (FMUstate == NULL || size == NULL ||
        ((const fmu_snapshot *)FMUstate)->magic != SNAP_MAGIC) {
        LOG_ERR(inst, "fmi2SerializedFMUstateSize: invalid FMUstate or size pointer");
        return fmi2Error;
    }
    *size = serialized_size();
    return fmi2OK;
}

static unsigned char *put(unsigned char *p, const void *x, size_t n) {
    memcpy(p, x, n);
    return p + n;
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate, fmi2Byte data[],
                                 size_t size) {
    fmu_instance *inst = enter(c, CALL_SERIALIZE);
    fmu_snapshot *s = (fmu_snapshot *)FMUstate;
    unsigned char *p = (unsigned char *)data;
    fmu_values v;
    uint64_t u, h;
    int32_t i32;
    uint32_t st;
    size_t k;
    int t;
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
    p = put(p, SER_MAGIC, 8);
    u = guid_hash();
    p = put(p, &u, 8);
    for (t = 0; t < FMU_NTYPES; ++t) {
        u = (uint64_t)NVARS(t);
        p = put(p, &u, 8);
    }
    i32 = (int32_t)s->type;
    p = put(p, &i32, 4);
    st = (uint32_t)s->state;
    p = put(p, &st, 4);
    p = put(p, &s->time, 8);
    p = put(p, &s->t_start, 8);
    v = snapshot_values(s);
    p = put(p, v.r, NVARS(FMU_REAL) * 8);
    for (k = 0; k < NVARS(FMU_INTEGER); ++k) {
        i32 = (int32_t)v.i[k];
        p = put(p, &i32, 4);
    }
    for (k = 0; k < NVARS(FMU_BOOLEAN); ++k) {
        i32 = (int32_t)v.b[k];
        p = put(p, &i32, 4);
    }
    h = fnv1a((const unsigned char *)data, (size_t)(p - (unsigned char *)data), FNV_OFFSET);
    memcpy(p, &h, 8);
    return fmi2OK;
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[],
                                   size_t size, fmi2FMUstate *FMUstate) {
    const char *fn = "fmi2DeSerializeFMUstate";
    fmu_instance *inst = enter(c, CALL_DESERIALIZE);
    const unsigned char *p = (const unsigned char *)serializedState;
    uint64_t u, h;
    int32_t i32;
    uint32_t st;
    fmu_snapshot *s;
    fmu_values v;
    size_t need = serialized_size(), k, off;
    int t;
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
    if (u != guid_hash()) {
        LOG_ERR(inst, "%s: the state was serialised by an FMU with a different GUID", fn);
        return fmi2Error;
    }
    for (t = 0; t < FMU_NTYPES; ++t) {
        memcpy(&u, p + 16 + 8 * (size_t)t, 8);
        if (u != (uint64_t)NVARS(t)) {
            LOG_ERR(inst, "%s: corrupt state: wrong number of %s variables", fn, type_names[t]);
            return fmi2Error;
        }
    }
    s = (fmu_snapshot *)*FMUstate;
    if (s == NULL) {
        if ((s = new_snapshot(inst, fn)) == NULL) return fmi2Error;
        *FMUstate = (fmi2FMUstate)s;
    }
    s->magic = SNAP_MAGIC;
    memcpy(&i32, p + 40, 4);
    memcpy(&st, p + 44, 4);
    s->type = (fmi2Type)i32;
    s->state = (fmu_state)st;
    memcpy(&s->time, p + 48, 8);
    memcpy(&s->t_start, p + 56, 8);
    v = snapshot_values(s);
    off = SER_HEADER;
    memcpy(v.r, p + off, NVARS(FMU_REAL) * 8);
    off += NVARS(FMU_REAL) * 8;
    for (k = 0; k < NVARS(FMU_INTEGER); ++k, off += 4) {
        memcpy(&i32, p + off, 4);
        v.i[k] = (fmi2Integer)i32;
    }
    for (k = 0; k < NVARS(FMU_BOOLEAN); ++k, off += 4) {
        memcpy(&i32, p + off, 4);
        v.b[k] = (fmi2Boolean)i32;
    }
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
    fmu_instance *inst = enter(c, CALL_DIRECTIONAL_DERIVATIVE);
    const fmu_variables *V = fmu_model.vars;
    size_t i, j, ix = 0, nrow = V->n_states + V->n_outputs;
    const fmu_var *d;
    int need_jac = 0;
    if (inst == NULL) return fmi2Error;
    if (fmu_model.jacobian == NULL) {
        LOG_ERR(inst, "%s: %s does not provide directional derivatives", fn,
                fmu_model.model_identifier);
        return fmi2Error;
    }
    if (!vrs_ok(inst, fn, FMU_REAL, vUnknown_ref, nUnknown) ||
        !vrs_ok(inst, fn, FMU_REAL, vKnown_ref, nKnown))
        return fmi2Error;
    if ((nKnown > 0 && dvKnown == NULL) || (nUnknown > 0 && dvUnknown == NULL)) {
        LOG_ERR(inst, "%s: NULL value array", fn);
        return fmi2Error;
    }
    for (j = 0; j < nKnown; ++j) {
        d = lookup(FMU_REAL, vKnown_ref[j], &ix);
        if (d->kind != FMU_KIND_STATE && d->kind != FMU_KIND_INPUT) {
            LOG_ERR(inst, "%s: known '%s' (vr %lu) is not a state or a continuous input", fn,
                    d->name, (unsigned long)vKnown_ref[j]);
            return fmi2Error;
        }
        if (!isfinite(dvKnown[j])) {
            LOG_ERR(inst, "%s: dvKnown[%lu] is not finite", fn, (unsigned long)j);
            return fmi2Error;
        }
    }
    for (i = 0; i < nUnknown; ++i) {
        d = lookup(FMU_REAL, vUnknown_ref[i], &ix);
        if (d->kind != FMU_KIND_STATE && !evaluated(d->kind)) {
            LOG_ERR(inst, "%s: unknown '%s' (vr %lu) is not a derivative, state or continuous "
                    "output", fn, d->name, (unsigned long)vUnknown_ref[i]);
            return fmi2Error;
        }
        need_jac |= d->kind != FMU_KIND_STATE;
    }
    inst->msg[0] = '\0';
    if (need_jac && fmu_model.jacobian(inst, &inst->v, inst->jac, inst->msg,
                                       sizeof inst->msg) != 0) {
        LOG_ERR(inst, "%s: %s", fn, inst->msg);
        return fmi2Error;
    }
    for (i = 0; i < nUnknown; ++i) {
        const fmu_var *du = lookup(FMU_REAL, vUnknown_ref[i], &ix);
        size_t row = du->kind == FMU_KIND_DERIVATIVE ? du->index : V->n_states + du->index;
        double acc = 0.0;
        for (j = 0; j < nKnown; ++j) {
            const fmu_var *dk = lookup(FMU_REAL, vKnown_ref[j], &ix);
            size_t col = dk->kind == FMU_KIND_STATE ? dk->index : V->n_states + dk->index;
            if (du->kind == FMU_KIND_STATE) /* a state as an unknown: identity */
                acc += vUnknown_ref[i] == vKnown_ref[j] ? dvKnown[j] : 0.0;
            else
                acc += inst->jac[col * nrow + row] * dvKnown[j];
        }
        dvUnknown[i] = acc;
    }
    for (i = 0; i < nUnknown; ++i) {
        if (!isfinite(dvUnknown[i])) {
            LOG_ERR(inst, "%s: the directional derivative is not finite", fn);
            return fmi2Error;
        }
    }
    return fmi2OK;
}

/* ------------------------------------------------------------------ Model Exchange */

fmi2Status fmi2EnterEventMode(fmi2Component c) {
    fmu_instance *inst = enter(c, CALL_ENTER_EVENT_MODE);
    if (inst == NULL) return fmi2Error;
    if (inst->state == FMU_ST_CONT && fmu_model.event_entered != NULL)
        fmu_model.event_entered(inst, &inst->v, inst->time);
    inst->state = FMU_ST_EVENT;
    return fmi2OK;
}

fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *eventInfo) {
    const char *fn = "fmi2NewDiscreteStates";
    fmu_instance *inst = enter(c, CALL_NEW_DISCRETE_STATES);
    fmi2Status st = fmi2OK;
    if (inst == NULL) return fmi2Error;
    if (eventInfo == NULL) {
        LOG_ERR(inst, "%s: eventInfo is NULL", fn);
        return fmi2Error;
    }
    eventInfo->newDiscreteStatesNeeded = fmi2False;
    eventInfo->terminateSimulation = fmi2False;
    eventInfo->nominalsOfContinuousStatesChanged = fmi2False;
    eventInfo->valuesOfContinuousStatesChanged = fmi2False;
    eventInfo->nextEventTimeDefined = fmi2False;
    eventInfo->nextEventTime = 0.0;
    if (fmu_model.event_update != NULL) {
        inst->msg[0] = '\0';
        st = fmu_model.event_update(inst, &inst->v, inst->time, eventInfo, inst->msg,
                                    sizeof inst->msg);
        inst->dirty = inst->init_dirty = 1;
        log_model(inst, st, fn);
        if (st != fmi2OK && st != fmi2Warning) {
            inst->state = FMU_ST_ERROR;
            return fmi2Error;
        }
    }
    return st;
}

fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c) {
    fmu_instance *inst = enter(c, CALL_ENTER_CONT_MODE);
    if (inst == NULL) return fmi2Error;
    inst->state = FMU_ST_CONT;
    return fmi2OK;
}

fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi2Boolean *enterEventMode,
                                       fmi2Boolean *terminateSimulation) {
    fmu_instance *inst = enter(c, CALL_COMPLETED_INTEGRATOR_STEP);
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
    fmu_instance *inst = enter(c, CALL_SET_TIME);
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
    fmu_instance *inst = enter(c, CALL_SET_CONT_STATES);
    const fmu_variables *V = fmu_model.vars;
    size_t i;
    if (inst == NULL) return fmi2Error;
    if (!n_ok(inst, fn, x, nx, V->n_states)) return fmi2Error;
    for (i = 0; i < nx; ++i) {
        if (!isfinite(x[i])) {
            LOG_ERR(inst, "%s: state '%s' must be finite, got %g", fn,
                    V->var[FMU_REAL][V->state[i]].name, x[i]);
            return fmi2Error;
        }
    }
    for (i = 0; i < nx; ++i) inst->v.r[V->state[i]] = x[i];
    inst->dirty = inst->init_dirty = 1;
    return fmi2OK;
}

fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real derivatives[], size_t nx) {
    const char *fn = "fmi2GetDerivatives";
    fmu_instance *inst = enter(c, CALL_GET_DERIVATIVES);
    const fmu_variables *V = fmu_model.vars;
    size_t i;
    if (inst == NULL) return fmi2Error;
    if (!n_ok(inst, fn, derivatives, nx, V->n_states)) return fmi2Error;
    if (refresh(inst, fn) != fmi2OK) return fmi2Error;
    for (i = 0; i < nx; ++i) derivatives[i] = inst->v.r[V->der[i]];
    return fmi2OK;
}

fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real eventIndicators[], size_t ni) {
    fmu_instance *inst = enter(c, CALL_GET_EVENT_INDICATORS);
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
    fmu_instance *inst = enter(c, CALL_GET_CONT_STATES);
    const fmu_variables *V = fmu_model.vars;
    size_t i;
    if (inst == NULL) return fmi2Error;
    if (!n_ok(inst, fn, x, nx, V->n_states)) return fmi2Error;
    for (i = 0; i < nx; ++i) x[i] = inst->v.r[V->state[i]];
    return fmi2OK;
}

fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x_nominal[], size_t nx) {
    const char *fn = "fmi2GetNominalsOfContinuousStates";
    fmu_instance *inst = enter(c, CALL_GET_NOMINALS);
    size_t i;
    if (inst == NULL) return fmi2Error;
    if (!n_ok(inst, fn, x_nominal, nx, fmu_model.vars->n_states)) return fmi2Error;
    for (i = 0; i < nx; ++i) x_nominal[i] = 1.0;
    return fmi2OK;
}

/* ------------------------------------------------------------------ Co-Simulation */

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[]) {
    fmu_instance *inst = enter(c, CALL_SET_REAL_INPUT_DERIVATIVES);
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
    fmu_instance *inst = enter(c, CALL_GET_REAL_OUTPUT_DERIVATIVES);
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
    fmu_instance *inst = enter(c, CALL_DO_STEP);
    fmi2Status st;
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
    if (fmu_model.do_step == NULL) {
        LOG_ERR(inst, "%s: %s has no co-simulation step", fn, fmu_model.model_identifier);
        return fmi2Error;
    }
    copy_values(&inst->backup, &inst->v);
    inst->msg[0] = '\0';
    st = fmu_model.do_step(inst, &inst->v, currentCommunicationPoint, communicationStepSize,
                           inst->msg, sizeof inst->msg);
    inst->dirty = inst->init_dirty = 1;
    if (st == fmi2OK || st == fmi2Warning) {
        log_model(inst, st, fn);
        inst->time = currentCommunicationPoint + communicationStepSize;
        return st;
    }
    copy_values(&inst->v, &inst->backup); /* nothing of a failed or refused step remains */
    if (st == fmi2Discard) {
        fmu_log(inst, fmi2Discard, FMU_LOG_WARNING, "%s: step from t = %g discarded: %s", fn,
                inst->time, inst->msg);
        inst->state = FMU_ST_STEP_FAILED;
        return fmi2Discard;
    }
    LOG_ERR(inst, "%s: step from t = %g refused: %s", fn, inst->time, inst->msg);
    return fmi2Error;
}

fmi2Status fmi2CancelStep(fmi2Component c) {
    fmu_instance *inst = enter(c, CALL_CANCEL_STEP);
    if (inst == NULL) return fmi2Error;
    LOG_ERR(inst, "fmi2CancelStep: not supported (fmi2DoStep is synchronous)");
    return fmi2Error;
}

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value) {
    fmu_instance *inst = enter(c, CALL_GET_STATUS);
    if (inst == NULL) return fmi2Error;
    if (value == NULL || s != fmi2DoStepStatus) {
        LOG_ERR(inst, "fmi2GetStatus: only fmi2DoStepStatus is provided (non-NULL value)");
        return fmi2Error;
    }
    *value = inst->state == FMU_ST_STEP_FAILED ? fmi2Discard : fmi2OK;
    return fmi2OK;
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    fmu_instance *inst = enter(c, CALL_GET_REAL_STATUS);
    if (inst == NULL) return fmi2Error;
    if (value == NULL || s != fmi2LastSuccessfulTime) {
        LOG_ERR(inst, "fmi2GetRealStatus: only fmi2LastSuccessfulTime is provided");
        return fmi2Error;
    }
    *value = inst->time;
    return fmi2OK;
}

fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value) {
    fmu_instance *inst = enter(c, CALL_GET_INTEGER_STATUS);
    (void)s;
    (void)value;
    if (inst == NULL) return fmi2Error;
    LOG_ERR(inst, "fmi2GetIntegerStatus: no integer status is provided");
    return fmi2Error;
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value) {
    fmu_instance *inst = enter(c, CALL_GET_BOOLEAN_STATUS);
    if (inst == NULL) return fmi2Error;
    if (value == NULL || s != fmi2Terminated) {
        LOG_ERR(inst, "fmi2GetBooleanStatus: only fmi2Terminated is provided");
        return fmi2Error;
    }
    *value = fmi2False;
    return fmi2OK;
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value) {
    fmu_instance *inst = enter(c, CALL_GET_STRING_STATUS);
    (void)s;
    (void)value;
    if (inst == NULL) return fmi2Error;
    LOG_ERR(inst, "fmi2GetStringStatus: no string status is provided");
    return fmi2Error;
}
