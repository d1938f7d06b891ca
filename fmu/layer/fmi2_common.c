/*
 * fmi2_common.c - shared, hand-written FMI 2.0 layer (Model Exchange and/or Co-Simulation):
 * its core.  The instance, the call table, logging, the variable checks, value storage,
 * fmi2SetDebugLogging and the version queries; the other fmi2* calls are in the layer's
 * other parts (fmi2_instance.c, fmi2_values.c, fmi2_state.c, fmi2_modes.c; see
 * fmi2_internal.h).
 *
 * See fmi2_common.h.  Policies of the whole layer:
 *  - Every call checks the instance pointer, the FMU type and the state machine against
 *    one table (`call_rules` below: FMI 2.0 sections 3.2.3 and 4.2.4); a call in the
 *    wrong state returns fmi2Error with a message and leaves the instance unchanged.
 *    Which variable kind may be set in which state is a second table (`set_rules` in
 *    fmi2_values.c).
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
#include "fmi2_internal.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

static const char *const fmu_log_category_names[FMU_LOG_N] = {
    "logStatusError", "logStatusWarning", "logCalls"};
const char *const fmu_type_names[FMU_NTYPES + 1] = {"Real", "Integer", "Boolean", "String"};

void *fmu_model_work(fmu_instance *inst) { return inst->work; }
double fmu_start_time(const fmu_instance *inst) { return inst->t_start; }

/* ------------------------------------------------------------------ the call table */

typedef struct {
    const char *name;
    unsigned interfaces; /* FMU_ME and/or FMU_CS instances may make the call */
    unsigned states;     /* fmu_state bits in which the call is allowed */
} call_rule;

#define ME FMU_ME
#define CS FMU_CS
/* A table entry is 0 or 1; anything else does not compile (negative array size). */
#define RULE_BIT(flag, bit) \
    (((flag) ? (bit) : 0u) * (unsigned)sizeof(char[((flag) == 0 || (flag) == 1) ? 1 : -1]))
/* A state only the other instance type reaches is 0: a Model Exchange call has no
 * stepComplete or stepFailed entry, a Co-Simulation call no eventMode or
 * continuousTimeMode entry (anything else does not compile). */
#define RULE_IFACE(iface, evnt, cont, step, fail)                                           \
    ((iface) * (unsigned)sizeof(char[(((iface) == ME && ((step) || (fail))) ||                \
                                      ((iface) == CS && ((evnt) || (cont))))                  \
                                         ? -1                                               \
                                         : 1]))
#define RULE(fn, iface, inst, init, evnt, cont, step, fail, term, err)                         \
    {fn, RULE_IFACE(iface, evnt, cont, step, fail),                                         \
     RULE_BIT(inst, FMU_ST_INSTANTIATED) | RULE_BIT(init, FMU_ST_INIT) |                    \
         RULE_BIT(evnt, FMU_ST_EVENT) | RULE_BIT(cont, FMU_ST_CONT) |                       \
         RULE_BIT(step, FMU_ST_STEP_COMPLETE) | RULE_BIT(fail, FMU_ST_STEP_FAILED) |        \
         RULE_BIT(term, FMU_ST_TERMINATED) | RULE_BIT(err, FMU_ST_ERROR)}

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
#undef ME
#undef CS

const char *fmu_call_name(fmu_call call) { return call_rules[call].name; }

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

void fmu_log_early(const fmi2CallbackFunctions *cb, const char *name, const char *fmt, ...) {
    char buf[2 * MSG_LEN + 16];
    va_list ap;
    va_start(ap, fmt);
    vlog_to(cb, name, fmi2Error, FMU_LOG_ERROR, buf, sizeof buf, fmt, ap);
    va_end(ap);
}

/* Log a model callback's message with the status it returned (nothing for fmi2OK). */
void fmu_log_model(fmu_instance *inst, fmi2Status st, const char *fn) {
    if (st == fmi2OK) return;
    if (st == fmi2Warning || st == fmi2Discard)
        fmu_log(inst, st, FMU_LOG_WARNING, "%s: %s", fn, inst->msg);
    else
        fmu_log(inst, st, FMU_LOG_ERROR, "%s: %s", fn, inst->msg);
}

/* ------------------------------------------------------------------ checks */

fmu_instance *fmu_as_instance(fmi2Component c) {
    fmu_instance *inst = (fmu_instance *)c;
    if (inst == NULL || inst->magic != FMU_MAGIC) return NULL;
    return inst;
}

const char *fmu_state_name(fmu_state s) {
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

unsigned fmu_interface_of(fmi2Type type) {
    return type == fmi2ModelExchange ? FMU_ME : FMU_CS;
}

/* Resolve the instance and check the call against the call table; NULL if refused (logged). */
fmu_instance *fmu_enter(fmi2Component c, fmu_call call) {
    const call_rule *rule = &call_rules[call];
    fmu_instance *inst = fmu_as_instance(c);
    if (inst == NULL) return NULL; /* nothing to log to */
    if (!(rule->interfaces & fmu_interface_of(inst->type))) {
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
            LOG_ERR(inst, "%s: not allowed in state %s", rule->name, fmu_state_name(inst->state));
        return NULL;
    }
    LOG_CALL(inst, "%s", rule->name);
    return inst;
}

/* The descriptor of value reference vr of type t (its value index in *ix), or NULL. */
const fmu_var *fmu_lookup(fmu_vtype t, fmi2ValueReference vr, size_t *ix) {
    const fmu_variables *V = fmu_model.vars;
    *ix = 0;
    if (t >= FMU_NTYPES || vr < V->vr0[t] || (size_t)(vr - V->vr0[t]) >= V->n[t]) return NULL;
    *ix = (size_t)(vr - V->vr0[t]);
    return &V->var[t][*ix];
}

/* Are all value references known variables of type t (t = FMU_NTYPES: String)? */
int fmu_vrs_ok(fmu_instance *inst, const char *fn, fmu_vtype t, const fmi2ValueReference vr[],
               size_t nvr) {
    size_t i, ix;
    if (nvr > 0 && vr == NULL) {
        LOG_ERR(inst, "%s: vr is NULL but nvr = %lu", fn, (unsigned long)nvr);
        return 0;
    }
    for (i = 0; i < nvr; ++i) {
        if (fmu_lookup(t, vr[i], &ix) == NULL) {
            LOG_ERR(inst, "%s: unknown value reference %lu (no %s variable has it)", fn,
                    (unsigned long)vr[i], fmu_type_names[t]);
            return 0;
        }
    }
    return 1;
}

/* Is v an allowed stored value of variable d of type t?  1, or 0 with a reason in msg. */
int fmu_value_ok(fmu_vtype t, const fmu_var *d, double v, char *msg, size_t len) {
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
        if (d->rule != NULL && d->min == d->max) /* fixed at its build value */
            snprintf(msg, len, "must be %s", d->rule);
        else if (d->rule != NULL)
            snprintf(msg, len, "non-physical value, must be %s", d->rule);
        else
            snprintf(msg, len, "out of range, must be in [%.17g, %.17g]", d->min, d->max);
        return 0;
    }
    return 1;
}

/* Is the kind calculated by evaluate (read through fmu_refresh)? */
int fmu_evaluated(unsigned kind) {
    return kind == FMU_KIND_DERIVATIVE || kind == FMU_KIND_OUTPUT;
}

/* Evaluate derivatives and continuous outputs if inputs, states or parameters changed. */
fmi2Status fmu_refresh(fmu_instance *inst, const char *fn) {
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

size_t fmu_values_bytes(void) {
    return NVARS(FMU_REAL) * sizeof(double) + NVARS(FMU_INTEGER) * sizeof(fmi2Integer) +
           NVARS(FMU_BOOLEAN) * sizeof(fmi2Boolean);
}

/* Point v at a block of fmu_values_bytes() (reals first: aligned for double). */
void fmu_bind_values(fmu_values *v, void *block) {
    v->r = (double *)block;
    v->i = (fmi2Integer *)(v->r + NVARS(FMU_REAL));
    v->b = (fmi2Boolean *)(v->i + NVARS(FMU_INTEGER));
}

void fmu_apply_start_from(fmu_values *v) {
    size_t k;
    const fmu_var *d = fmu_model.vars->var[FMU_REAL];
    for (k = 0; k < NVARS(FMU_REAL); ++k)
        if (d[k].start_from != 0) v->r[k] = v->r[d[k].start_from - 1u];
}

void fmu_copy_values(fmu_values *dst, const fmu_values *src) {
    memcpy(dst->r, src->r, fmu_values_bytes()); /* one contiguous block */
}

/* ------------------------------------------------------------------ common API */

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[]) {
    fmu_instance *inst = fmu_enter(c, CALL_SET_DEBUG_LOGGING);
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
