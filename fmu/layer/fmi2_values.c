/*
 * fmi2_values.c - fmi2GetReal/Integer/Boolean/String and fmi2SetReal/Integer/Boolean/String
 * of the shared FMI 2.0 layer: variables by value reference.  Getters evaluate the model
 * lazily (fmu_refresh) and, in initialisation mode, preview the held outputs; setters
 * check settability by kind and state (`set_rules`) and every value's range before
 * storing any.  There are no String variables.
 *
 * Part of the layer described in fmi2_common.c (policies) and fmi2_internal.h (parts).
 */
#include "fmi2_internal.h"

#include <math.h>

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
    fmu_copy_values(&inst->backup, &inst->v);
    st = fmu_model.initialize(inst, &inst->v, inst->time, inst->msg, sizeof inst->msg);
    if (st != fmi2OK && st != fmi2Warning) fmu_copy_values(&inst->v, &inst->backup);
    inst->init_dirty = 0;
}

/* ------------------------------------------------------------------ get / set */

static fmi2Status get_values(fmi2Component c, fmu_call call, fmu_vtype t,
                             const fmi2ValueReference vr[], size_t nvr, void *value) {
    fmu_instance *inst = fmu_enter(c, call);
    const char *fn = fmu_call_name(call);
    size_t i, ix = 0;
    int need_eval = 0;
    if (inst == NULL) return fmi2Error;
    if (!fmu_vrs_ok(inst, fn, t, vr, nvr)) return fmi2Error;
    if (nvr > 0 && value == NULL) {
        LOG_ERR(inst, "%s: value is NULL", fn);
        return fmi2Error;
    }
    if (t == FMU_REAL)
        for (i = 0; i < nvr && !need_eval; ++i)
            need_eval = fmu_evaluated(fmu_lookup(t, vr[i], &ix)->kind);
    if (need_eval && fmu_refresh(inst, fn) != fmi2OK) return fmi2Error;
    if (inst->state == FMU_ST_INIT) preview_initial(inst);
    for (i = 0; i < nvr; ++i) {
        fmu_lookup(t, vr[i], &ix);
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
    fmu_instance *inst = fmu_enter(c, call);
    const char *fn = fmu_call_name(call);
    size_t i, ix = 0;
    if (inst == NULL) return fmi2Error;
    if (!fmu_vrs_ok(inst, fn, t, vr, nvr)) return fmi2Error;
    if (nvr > 0 && value == NULL) {
        LOG_ERR(inst, "%s: value is NULL", fn);
        return fmi2Error;
    }
    for (i = 0; i < nvr; ++i) { /* validate everything before storing anything */
        const fmu_var *d = fmu_lookup(t, vr[i], &ix);
        const set_rule *rule = &set_rules[d->kind < FMU_KIND_N ? d->kind : 0];
        double x = given(t, value, i);
        if (d->start_from != 0 && (inst->state & ST_BEFORE_INIT_END)) {
            LOG_ERR(inst, "%s: cannot set '%s' (vr %lu) before initialisation ends: it starts "
                    "from the parameter '%s' (initial = calculated); set that instead", fn,
                    d->name, (unsigned long)vr[i],
                    fmu_model.vars->var[FMU_REAL][d->start_from - 1u].name);
            return fmi2Error;
        }
        if (!(inst->state & (inst->type == fmi2ModelExchange ? rule->me : rule->cs))) {
            LOG_ERR(inst, "%s: cannot set '%s' (vr %lu) in state %s: %s", fn, d->name,
                    (unsigned long)vr[i], fmu_state_name(inst->state), rule->why);
            return fmi2Error;
        }
        inst->msg[0] = '\0';
        if (!fmu_value_ok(t, d, x, inst->msg, sizeof inst->msg)) {
            if (t == FMU_REAL && !isfinite(x))
                LOG_ERR(inst, "%s: '%s' (vr %lu) %s", fn, d->name, (unsigned long)vr[i],
                        inst->msg);
            else
                LOG_ERR(inst, "%s: '%s' = %.17g refused: %s", fn, d->name, x, inst->msg);
            return fmi2Error;
        }
    }
    for (i = 0; i < nvr; ++i) {
        fmu_lookup(t, vr[i], &ix);
        if (t == FMU_REAL)
            inst->v.r[ix] = ((const fmi2Real *)value)[i];
        else if (t == FMU_INTEGER)
            inst->v.i[ix] = ((const fmi2Integer *)value)[i];
        else
            inst->v.b[ix] = ((const fmi2Boolean *)value)[i];
    }
    if (nvr > 0) inst->dirty = inst->init_dirty = 1;
    if (inst->state & ST_BEFORE_INIT_END) fmu_apply_start_from(&inst->v);
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
    fmu_instance *inst = fmu_enter(c, call);
    if (inst == NULL) return fmi2Error;
    if (!fmu_vrs_ok(inst, fmu_call_name(call), FMU_NTYPES, vr, nvr)) return fmi2Error;
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
