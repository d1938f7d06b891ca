/*
 * fmi2_modes.c - the mode-specific calls of the shared FMI 2.0 layer: directional
 * derivatives from the model Jacobian (fmi2GetDirectionalDerivative), Model Exchange
 * (event and continuous-time mode, time, continuous states, derivatives) and
 * Co-Simulation (fmi2DoStep: a failed step restores every value; the status getters).
 *
 * Part of the layer described in fmi2_common.c (policies) and fmi2_internal.h (parts).
 */
#include "fmi2_internal.h"

#include <math.h>

/* ------------------------------------------------------------------ derivatives */

/* Entry (unknown du, known dk) of the model Jacobian computed into inst->jac (a state as
 * an unknown: the identity). */
static double jac_entry(const fmu_instance *inst, const fmu_var *du, fmi2ValueReference vu,
                        const fmu_var *dk, fmi2ValueReference vk) {
    const fmu_variables *V = fmu_model.vars;
    size_t nrow = V->n_states + V->n_outputs;
    size_t row = du->kind == FMU_KIND_DERIVATIVE ? du->index : V->n_states + du->index;
    size_t col = dk->kind == FMU_KIND_STATE ? dk->index : V->n_states + dk->index;
    if (du->kind == FMU_KIND_STATE) return vu == vk ? 1.0 : 0.0;
    return inst->jac[col * nrow + row];
}

fmi2Status fmu_derivatives(fmi2Component c, const char *fn, const fmi2ValueReference unknown[],
                           size_t nUnknown, const fmi2ValueReference known[], size_t nKnown,
                           const double seed[], double out[], int adjoint) {
    fmu_instance *inst = fmu_enter(c, CALL_DIRECTIONAL_DERIVATIVE);
    size_t i, j, ix = 0, nseed = adjoint ? nUnknown : nKnown, nout = adjoint ? nKnown : nUnknown;
    const fmu_var *d;
    int need_jac = 0;
    if (inst == NULL) return fmi2Error;
    if (fmu_model.jacobian == NULL) {
        LOG_ERR(inst, "%s: %s does not provide directional derivatives", fn,
                fmu_model.model_identifier);
        return fmi2Error;
    }
    if (!fmu_vrs_ok(inst, fn, FMU_REAL, unknown, nUnknown) ||
        !fmu_vrs_ok(inst, fn, FMU_REAL, known, nKnown))
        return fmi2Error;
    if ((nseed > 0 && seed == NULL) || (nout > 0 && out == NULL)) {
        LOG_ERR(inst, "%s: NULL value array", fn);
        return fmi2Error;
    }
    for (j = 0; j < nKnown; ++j) {
        d = fmu_lookup(FMU_REAL, known[j], &ix);
        if (d->kind != FMU_KIND_STATE && d->kind != FMU_KIND_INPUT) {
            LOG_ERR(inst, "%s: known '%s' (vr %lu) is not a state or a continuous input", fn,
                    d->name, (unsigned long)known[j]);
            return fmi2Error;
        }
    }
    for (j = 0; j < nseed; ++j) {
        if (!isfinite(seed[j])) {
            LOG_ERR(inst, "%s: seed[%lu] is not finite", fn, (unsigned long)j);
            return fmi2Error;
        }
    }
    for (i = 0; i < nUnknown; ++i) {
        d = fmu_lookup(FMU_REAL, unknown[i], &ix);
        if (d->kind != FMU_KIND_STATE && !fmu_evaluated(d->kind)) {
            LOG_ERR(inst, "%s: unknown '%s' (vr %lu) is not a derivative, state or continuous "
                    "output", fn, d->name, (unsigned long)unknown[i]);
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
    for (i = 0; i < nout; ++i) out[i] = 0.0;
    for (i = 0; i < nUnknown; ++i) {
        const fmu_var *du = fmu_lookup(FMU_REAL, unknown[i], &ix);
        for (j = 0; j < nKnown; ++j) {
            const fmu_var *dk = fmu_lookup(FMU_REAL, known[j], &ix);
            double e = jac_entry(inst, du, unknown[i], dk, known[j]);
            if (adjoint)
                out[j] += seed[i] * e; /* seed^T J */
            else
                out[i] += e * seed[j]; /* J seed */
        }
    }
    for (i = 0; i < nout; ++i) {
        if (!isfinite(out[i])) {
            LOG_ERR(inst, "%s: the %s derivative is not finite", fn,
                    adjoint ? "adjoint" : "directional");
            return fmi2Error;
        }
    }
    return fmi2OK;
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c,
                                        const fmi2ValueReference vUnknown_ref[],
                                        size_t nUnknown, const fmi2ValueReference vKnown_ref[],
                                        size_t nKnown, const fmi2Real dvKnown[],
                                        fmi2Real dvUnknown[]) {
    return fmu_derivatives(c, "fmi2GetDirectionalDerivative", vUnknown_ref, nUnknown,
                           vKnown_ref, nKnown, dvKnown, dvUnknown, 0);
}

/* ------------------------------------------------------------------ Model Exchange */

fmi2Status fmi2EnterEventMode(fmi2Component c) {
    fmu_instance *inst = fmu_enter(c, CALL_ENTER_EVENT_MODE);
    if (inst == NULL) return fmi2Error;
    if (inst->state == FMU_ST_CONT && fmu_model.event_entered != NULL)
        fmu_model.event_entered(inst, &inst->v, inst->time);
    inst->state = FMU_ST_EVENT;
    return fmi2OK;
}

fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *eventInfo) {
    const char *fn = "fmi2NewDiscreteStates";
    fmu_instance *inst = fmu_enter(c, CALL_NEW_DISCRETE_STATES);
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
        fmu_log_model(inst, st, fn);
        if (st != fmi2OK && st != fmi2Warning) {
            inst->state = FMU_ST_ERROR;
            return fmi2Error;
        }
    }
    return st;
}

fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c) {
    fmu_instance *inst = fmu_enter(c, CALL_ENTER_CONT_MODE);
    if (inst == NULL) return fmi2Error;
    inst->state = FMU_ST_CONT;
    return fmi2OK;
}

fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi2Boolean *enterEventMode,
                                       fmi2Boolean *terminateSimulation) {
    fmu_instance *inst = fmu_enter(c, CALL_COMPLETED_INTEGRATOR_STEP);
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
    fmu_instance *inst = fmu_enter(c, CALL_SET_TIME);
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
    fmu_instance *inst = fmu_enter(c, CALL_SET_CONT_STATES);
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
    fmu_instance *inst = fmu_enter(c, CALL_GET_DERIVATIVES);
    const fmu_variables *V = fmu_model.vars;
    size_t i;
    if (inst == NULL) return fmi2Error;
    if (!n_ok(inst, fn, derivatives, nx, V->n_states)) return fmi2Error;
    if (fmu_refresh(inst, fn) != fmi2OK) return fmi2Error;
    for (i = 0; i < nx; ++i) derivatives[i] = inst->v.r[V->der[i]];
    return fmi2OK;
}

fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real eventIndicators[], size_t ni) {
    fmu_instance *inst = fmu_enter(c, CALL_GET_EVENT_INDICATORS);
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
    fmu_instance *inst = fmu_enter(c, CALL_GET_CONT_STATES);
    const fmu_variables *V = fmu_model.vars;
    size_t i;
    if (inst == NULL) return fmi2Error;
    if (!n_ok(inst, fn, x, nx, V->n_states)) return fmi2Error;
    for (i = 0; i < nx; ++i) x[i] = inst->v.r[V->state[i]];
    return fmi2OK;
}

fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x_nominal[], size_t nx) {
    const char *fn = "fmi2GetNominalsOfContinuousStates";
    fmu_instance *inst = fmu_enter(c, CALL_GET_NOMINALS);
    size_t i;
    if (inst == NULL) return fmi2Error;
    if (!n_ok(inst, fn, x_nominal, nx, fmu_model.vars->n_states)) return fmi2Error;
    for (i = 0; i < nx; ++i) x_nominal[i] = 1.0;
    return fmi2OK;
}

/* ------------------------------------------------------------------ Co-Simulation */

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[]) {
    fmu_instance *inst = fmu_enter(c, CALL_SET_REAL_INPUT_DERIVATIVES);
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
    fmu_instance *inst = fmu_enter(c, CALL_GET_REAL_OUTPUT_DERIVATIVES);
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
    fmu_instance *inst = fmu_enter(c, CALL_DO_STEP);
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
    fmu_copy_values(&inst->backup, &inst->v);
    inst->msg[0] = '\0';
    st = fmu_model.do_step(inst, &inst->v, currentCommunicationPoint, communicationStepSize,
                           inst->msg, sizeof inst->msg);
    inst->dirty = inst->init_dirty = 1;
    if (st == fmi2OK || st == fmi2Warning) {
        fmu_log_model(inst, st, fn);
        inst->time = currentCommunicationPoint + communicationStepSize;
        return st;
    }
    fmu_copy_values(&inst->v, &inst->backup); /* nothing of a failed or refused step remains */
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
    fmu_instance *inst = fmu_enter(c, CALL_CANCEL_STEP);
    if (inst == NULL) return fmi2Error;
    LOG_ERR(inst, "fmi2CancelStep: not supported (fmi2DoStep is synchronous)");
    return fmi2Error;
}

/* The instance for a status query when it asks for what is provided (`provided`);
 * otherwise NULL, with `what` logged as the error. */
static fmu_instance *status_query(fmi2Component c, fmu_call call, int provided, const char *what) {
    fmu_instance *inst = fmu_enter(c, call);
    if (inst != NULL && !provided) {
        LOG_ERR(inst, "%s", what);
        return NULL;
    }
    return inst;
}

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value) {
    fmu_instance *inst =
        status_query(c, CALL_GET_STATUS, value != NULL && s == fmi2DoStepStatus,
                     "fmi2GetStatus: only fmi2DoStepStatus is provided (non-NULL value)");
    if (inst == NULL) return fmi2Error;
    *value = inst->state == FMU_ST_STEP_FAILED ? fmi2Discard : fmi2OK;
    return fmi2OK;
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    fmu_instance *inst =
        status_query(c, CALL_GET_REAL_STATUS, value != NULL && s == fmi2LastSuccessfulTime,
                     "fmi2GetRealStatus: only fmi2LastSuccessfulTime is provided");
    if (inst == NULL) return fmi2Error;
    *value = inst->time;
    return fmi2OK;
}

fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value) {
    (void)s;
    (void)value;
    status_query(c, CALL_GET_INTEGER_STATUS, 0,
                 "fmi2GetIntegerStatus: no integer status is provided");
    return fmi2Error;
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value) {
    fmu_instance *inst =
        status_query(c, CALL_GET_BOOLEAN_STATUS, value != NULL && s == fmi2Terminated,
                     "fmi2GetBooleanStatus: only fmi2Terminated is provided");
    if (inst == NULL) return fmi2Error;
    *value = fmi2False;
    return fmi2OK;
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value) {
    (void)s;
    (void)value;
    status_query(c, CALL_GET_STRING_STATUS, 0, "fmi2GetStringStatus: no string status is provided");
    return fmi2Error;
}
