/*
 * fmi2_instance.c - the life cycle of an instance of the shared FMI 2.0 layer:
 * fmi2Instantiate (one allocation), fmi2FreeInstance, fmi2SetupExperiment,
 * initialisation mode (fmi2EnterInitializationMode, fmi2ExitInitializationMode: the
 * model's start-value checks and initialize callback), fmi2Terminate and fmi2Reset.
 *
 * Part of the layer described in fmi2_common.c (policies) and fmi2_internal.h (parts).
 */
#include "fmi2_internal.h"

#include <math.h>
#include <string.h>

/* The start values of every variable, time 0, everything to be (re)computed. */
static void load_start(fmu_instance *inst) {
    size_t k;
    const fmu_variables *V = fmu_model.vars;
    for (k = 0; k < V->n[FMU_REAL]; ++k) inst->v.r[k] = V->var[FMU_REAL][k].start;
    for (k = 0; k < V->n[FMU_INTEGER]; ++k)
        inst->v.i[k] = (fmi2Integer)V->var[FMU_INTEGER][k].start;
    for (k = 0; k < V->n[FMU_BOOLEAN]; ++k)
        inst->v.b[k] = V->var[FMU_BOOLEAN][k].start != 0.0 ? fmi2True : fmi2False;
    fmu_apply_start_from(&inst->v);
    inst->time = 0.0;
    inst->t_start = 0.0;
    inst->dirty = inst->init_dirty = 1;
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
        fmu_log_early(functions, name, "fmi2Instantiate: allocateMemory/freeMemory is NULL");
        return NULL;
    }
    if (instanceName == NULL || instanceName[0] == '\0') {
        fmu_log_early(functions, name, "fmi2Instantiate: missing instance name");
        return NULL;
    }
    if (fmuType != fmi2ModelExchange && fmuType != fmi2CoSimulation) {
        fmu_log_early(functions, name, "fmi2Instantiate: unknown fmuType %d", (int)fmuType);
        return NULL;
    }
    if (!(fmu_model.interfaces & fmu_interface_of(fmuType))) {
        fmu_log_early(functions, name, "fmi2Instantiate: %s does not implement %s",
                    fmu_model.model_identifier,
                    fmuType == fmi2ModelExchange ? "Model Exchange" : "Co-Simulation");
        return NULL;
    }
    if (fmuGUID == NULL || strcmp(fmuGUID, fmu_model.guid) != 0) {
        fmu_log_early(functions, name,
                    "fmi2Instantiate: wrong GUID '%s', this binary of %s has GUID '%s'",
                    fmuGUID ? fmuGUID : "(null)", fmu_model.model_identifier, fmu_model.guid);
        return NULL;
    }
    len = strlen(instanceName) + 1;
    off_work = whole_lines(sizeof(fmu_instance));
    off_val = off_work + whole_lines(fmu_model.work_bytes);
    off_bak = off_val + whole_lines(fmu_values_bytes());
    off_jac = off_bak + whole_lines(fmu_values_bytes());
    off_name = off_jac + whole_lines(njac * sizeof(double));
    block = (unsigned char *)functions->allocateMemory((off_name + len) / sizeof(double) + 1,
                                                       sizeof(double));
    if (block == NULL) {
        fmu_log_early(functions, name, "fmi2Instantiate: out of memory");
        return NULL;
    }
    inst = (fmu_instance *)(void *)block;
    memset(inst, 0, sizeof *inst);
    inst->cb = *functions;
    inst->work = fmu_model.work_bytes ? (void *)(block + off_work) : NULL;
    fmu_bind_values(&inst->v, block + off_val);
    fmu_bind_values(&inst->backup, block + off_bak);
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
    fmu_instance *inst = fmu_as_instance(c);
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
    fmu_instance *inst = fmu_enter(c, CALL_SETUP_EXPERIMENT);
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
    fmu_instance *inst = fmu_enter(c, CALL_ENTER_INIT);
    if (inst == NULL) return fmi2Error;
    inst->state = FMU_ST_INIT;
    inst->dirty = inst->init_dirty = 1;
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    const char *fn = "fmi2ExitInitializationMode";
    fmu_instance *inst = fmu_enter(c, CALL_EXIT_INIT);
    fmi2Status st = fmi2OK;
    if (inst == NULL) return fmi2Error;
    inst->msg[0] = '\0';
    if (fmu_model.check_initial != NULL &&
        fmu_model.check_initial(&inst->v, 0, inst->msg, sizeof inst->msg) != 0) {
        LOG_ERR(inst, "%s: %s", fn, inst->msg);
        return fmi2Error;
    }
    inst->dirty = inst->init_dirty = 1;
    if (fmu_refresh(inst, fn) != fmi2OK) return fmi2Error; /* error state */
    if (fmu_model.initialize != NULL) { /* refused: stay in initialisation mode */
        st = fmu_model.initialize(inst, &inst->v, inst->time, inst->msg, sizeof inst->msg);
        fmu_log_model(inst, st, fn);
        if (st != fmi2OK && st != fmi2Warning) return fmi2Error;
        inst->dirty = inst->init_dirty = 1;
    }
    inst->state = inst->type == fmi2ModelExchange ? FMU_ST_EVENT : FMU_ST_STEP_COMPLETE;
    return st;
}

fmi2Status fmi2Terminate(fmi2Component c) {
    fmu_instance *inst = fmu_enter(c, CALL_TERMINATE);
    if (inst == NULL) return fmi2Error;
    inst->state = FMU_ST_TERMINATED;
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component c) {
    fmu_instance *inst = fmu_enter(c, CALL_RESET);
    if (inst == NULL) return fmi2Error;
    load_start(inst);
    inst->state = FMU_ST_INSTANTIATED;
    return fmi2OK;
}
