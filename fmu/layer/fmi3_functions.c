/*
 * fmi3_functions.c - the FMI 3.0 entry points of the shared layer: a thin adapter over the
 * model-independent code the FMI 2.0 entry points use (fmi2_common.c and its parts: the
 * instance, the call table, values by value reference, FMU states, directional
 * derivatives, Model Exchange and Co-Simulation), so one per-model C file (fmu_model)
 * builds both an FMI 2.0 and an FMI 3.0 binary.
 *
 * In an FMI 3.0 binary the fmi2* functions are compiled in but not exported (a linker
 * version script exports fmi3* only).  What FMI 3.0 adds is mapped as follows:
 *  - instantiation: the instantiation token is the layer's GUID; memory comes from
 *    calloc/free (FMI 3.0 has no memory callbacks); the FMI 3.0 logger is called through
 *    a small adapter (the message with the FMI 2.0 '#' escapes undone);
 *  - fmi3EnterInitializationMode carries the experiment (fmi2SetupExperiment);
 *  - Float64, Int32 and Boolean variables are the layer's Real, Integer and Boolean
 *    ones, all scalar (nValues must equal nValueReferences); no variable has another
 *    type, so the other getters and setters accept only an empty list;
 *  - fmi3GetDirectionalDerivative and fmi3GetAdjointDerivative (seed^T J) both come from
 *    the model Jacobian (fmu_derivatives);
 *  - Co-Simulation without event mode, intermediate update, early return or clocks
 *    (fmi3DoStep never returns early; scheduled execution is not provided);
 *  - Model Exchange: fmi3UpdateDiscreteStates is fmi2NewDiscreteStates.
 * Messages name the shared layer's calls (e.g. "fmi2DoStep: ..."): the FMI 2.0 call that
 * implements the FMI 3.0 one.
 */
#include <stdlib.h>
#include <string.h>

#include "fmi2_internal.h"
#include "fmi3Functions.h"

/* fmi3Int32 values pass through the layer's fmi2Integer storage unchanged */
typedef char fmi3_int32_is_fmi2_integer[sizeof(fmi3Int32) == sizeof(fmi2Integer) ? 1 : -1];

/* ------------------------------------------------------------------ instances */

/* The FMI 3.0 logger and its environment (the FMI 2.0 component environment). */
typedef struct {
    fmi3InstanceEnvironment env;
    fmi3LogMessageCallback log;
} fmi3_env;

static void log_adapter(fmi2ComponentEnvironment e, fmi2String name, fmi2Status status,
                        fmi2String category, fmi2String message, ...) {
    const fmi3_env *x = (const fmi3_env *)e;
    char buf[2 * MSG_LEN + 16];
    size_t i, j = 0;
    (void)name;
    if (x == NULL || x->log == NULL) return;
    for (i = 0; message[i] != '\0' && j + 1 < sizeof buf; ++i) {
        buf[j++] = message[i];
        if (message[i] == '#' && message[i + 1] == '#') ++i; /* '##' -> '#' */
    }
    buf[j] = '\0';
    x->log(x->env, (fmi3Status)status, category, buf);
}

static void *alloc_adapter(size_t n, size_t size) { return calloc(n, size); }
static void free_adapter(void *p) { free(p); }

static fmi3Instance instantiate(fmi3String name, fmi2Type type, fmi3String token,
                                fmi3Boolean visible, fmi3Boolean loggingOn,
                                fmi3InstanceEnvironment env, fmi3LogMessageCallback log) {
    fmi2CallbackFunctions cb;
    fmi3_env *x = (fmi3_env *)malloc(sizeof *x);
    fmi2Component c;
    if (x == NULL) return NULL;
    x->env = env;
    x->log = log;
    cb.logger = log_adapter;
    cb.allocateMemory = alloc_adapter;
    cb.freeMemory = free_adapter;
    cb.stepFinished = NULL;
    cb.componentEnvironment = x;
    c = fmi2Instantiate(name, type, token, "", &cb, visible ? fmi2True : fmi2False,
                        loggingOn ? fmi2True : fmi2False);
    if (c == NULL) free(x);
    return (fmi3Instance)c;
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String instantiationToken,
                                          fmi3String resourcePath, fmi3Boolean visible,
                                          fmi3Boolean loggingOn,
                                          fmi3InstanceEnvironment instanceEnvironment,
                                          fmi3LogMessageCallback logMessage) {
    (void)resourcePath;
    return instantiate(instanceName, fmi2ModelExchange, instantiationToken, visible, loggingOn,
                       instanceEnvironment, logMessage);
}

fmi3Instance fmi3InstantiateCoSimulation(
    fmi3String instanceName, fmi3String instantiationToken, fmi3String resourcePath,
    fmi3Boolean visible, fmi3Boolean loggingOn, fmi3Boolean eventModeUsed,
    fmi3Boolean earlyReturnAllowed, const fmi3ValueReference requiredIntermediateVariables[],
    size_t nRequiredIntermediateVariables, fmi3InstanceEnvironment instanceEnvironment,
    fmi3LogMessageCallback logMessage, fmi3IntermediateUpdateCallback intermediateUpdate) {
    (void)resourcePath;
    (void)earlyReturnAllowed; /* never returns early */
    (void)requiredIntermediateVariables;
    (void)intermediateUpdate; /* providesIntermediateUpdate = false */
    if (eventModeUsed || nRequiredIntermediateVariables > 0) {
        if (logMessage != NULL)
            logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                       "fmi3InstantiateCoSimulation: event mode and intermediate variables "
                       "are not provided (hasEventMode = false)");
        return NULL;
    }
    return instantiate(instanceName, fmi2CoSimulation, instantiationToken, visible, loggingOn,
                       instanceEnvironment, logMessage);
}

fmi3Instance fmi3InstantiateScheduledExecution(
    fmi3String instanceName, fmi3String instantiationToken, fmi3String resourcePath,
    fmi3Boolean visible, fmi3Boolean loggingOn, fmi3InstanceEnvironment instanceEnvironment,
    fmi3LogMessageCallback logMessage, fmi3ClockUpdateCallback clockUpdate,
    fmi3LockPreemptionCallback lockPreemption, fmi3UnlockPreemptionCallback unlockPreemption) {
    (void)instanceName;
    (void)instantiationToken;
    (void)resourcePath;
    (void)visible;
    (void)loggingOn;
    (void)clockUpdate;
    (void)lockPreemption;
    (void)unlockPreemption;
    if (logMessage != NULL)
        logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                   "fmi3InstantiateScheduledExecution: scheduled execution is not provided");
    return NULL;
}

void fmi3FreeInstance(fmi3Instance instance) {
    fmu_instance *inst = fmu_as_instance(instance);
    void *x;
    if (inst == NULL) return;
    x = inst->cb.componentEnvironment;
    fmi2FreeInstance(instance);
    free(x);
}

/* ------------------------------------------------------------------ common calls */

const char *fmi3GetVersion(void) { return fmi3Version; }

fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn, size_t nCategories,
                               const fmi3String categories[]) {
    return (fmi3Status)fmi2SetDebugLogging(instance, loggingOn ? fmi2True : fmi2False,
                                           nCategories, categories);
}

fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean toleranceDefined,
                                       fmi3Float64 tolerance, fmi3Float64 startTime,
                                       fmi3Boolean stopTimeDefined, fmi3Float64 stopTime) {
    fmi2Status st = fmi2SetupExperiment(instance, toleranceDefined ? fmi2True : fmi2False,
                                        tolerance, startTime,
                                        stopTimeDefined ? fmi2True : fmi2False, stopTime);
    if (st != fmi2OK) return (fmi3Status)st;
    return (fmi3Status)fmi2EnterInitializationMode(instance);
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance instance) {
    return (fmi3Status)fmi2ExitInitializationMode(instance);
}
fmi3Status fmi3EnterEventMode(fmi3Instance instance) {
    return (fmi3Status)fmi2EnterEventMode(instance);
}
fmi3Status fmi3Terminate(fmi3Instance instance) { return (fmi3Status)fmi2Terminate(instance); }
fmi3Status fmi3Reset(fmi3Instance instance) { return (fmi3Status)fmi2Reset(instance); }

/* A call that is not provided (logged as an error). */
static fmi3Status not_provided(fmi3Instance instance, const char *fn, const char *why) {
    fmu_instance *inst = fmu_as_instance(instance);
    if (inst != NULL) LOG_ERR(inst, "%s: %s", fn, why);
    return fmi3Error;
}

/* ------------------------------------------------------------------ values */

/* Scalar variables only: one value per value reference. */
static int scalar_sizes(fmi3Instance instance, const char *fn, size_t nvr, size_t nValues) {
    fmu_instance *inst = fmu_as_instance(instance);
    if (nvr == nValues) return 1;
    if (inst != NULL)
        LOG_ERR(inst, "%s: nValues = %lu but %lu value references (every variable is a "
                "scalar)", fn, (unsigned long)nValues, (unsigned long)nvr);
    return 0;
}

fmi3Status fmi3GetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, fmi3Float64 values[], size_t nValues) {
    if (!scalar_sizes(instance, "fmi3GetFloat64", nValueReferences, nValues)) return fmi3Error;
    return (fmi3Status)fmi2GetReal(instance, valueReferences, nValueReferences, values);
}
fmi3Status fmi3SetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, const fmi3Float64 values[], size_t nValues) {
    if (!scalar_sizes(instance, "fmi3SetFloat64", nValueReferences, nValues)) return fmi3Error;
    return (fmi3Status)fmi2SetReal(instance, valueReferences, nValueReferences, values);
}
fmi3Status fmi3GetInt32(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                        size_t nValueReferences, fmi3Int32 values[], size_t nValues) {
    if (!scalar_sizes(instance, "fmi3GetInt32", nValueReferences, nValues)) return fmi3Error;
    return (fmi3Status)fmi2GetInteger(instance, valueReferences, nValueReferences,
                                      (fmi2Integer *)values);
}
fmi3Status fmi3SetInt32(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                        size_t nValueReferences, const fmi3Int32 values[], size_t nValues) {
    if (!scalar_sizes(instance, "fmi3SetInt32", nValueReferences, nValues)) return fmi3Error;
    return (fmi3Status)fmi2SetInteger(instance, valueReferences, nValueReferences,
                                      (const fmi2Integer *)values);
}

/* Booleans one at a time (fmi3Boolean is a C bool, fmi2Boolean an int). */
fmi3Status fmi3GetBoolean(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, fmi3Boolean values[], size_t nValues) {
    size_t i;
    fmi2Boolean b;
    if (!scalar_sizes(instance, "fmi3GetBoolean", nValueReferences, nValues)) return fmi3Error;
    if (nValueReferences > 0 && (valueReferences == NULL || values == NULL))
        return (fmi3Status)fmi2GetBoolean(instance, valueReferences, nValueReferences, NULL);
    for (i = 0; i < nValueReferences; ++i) {
        fmi2Status st = fmi2GetBoolean(instance, valueReferences + i, 1, &b);
        if (st != fmi2OK) return (fmi3Status)st;
        values[i] = b != fmi2False;
    }
    return fmi3OK;
}
fmi3Status fmi3SetBoolean(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, const fmi3Boolean values[], size_t nValues) {
    fmi2Boolean b[64];
    size_t i;
    if (!scalar_sizes(instance, "fmi3SetBoolean", nValueReferences, nValues)) return fmi3Error;
    if (nValueReferences > 0 && (valueReferences == NULL || values == NULL))
        return (fmi3Status)fmi2SetBoolean(instance, valueReferences, nValueReferences, NULL);
    if (nValueReferences > sizeof b / sizeof b[0])
        return not_provided(instance, "fmi3SetBoolean", "at most 64 Booleans per call");
    for (i = 0; i < nValueReferences; ++i) b[i] = values[i] ? fmi2True : fmi2False;
    /* all at once: every value is validated before any is stored */
    return (fmi3Status)fmi2SetBoolean(instance, valueReferences, nValueReferences, b);
}

/* Types the FMU has no variables of: only an empty list is accepted. */
static fmi3Status no_such_type(fmi3Instance instance, const char *fn, const char *type,
                               const fmi3ValueReference vr[], size_t nvr) {
    fmu_instance *inst = fmu_as_instance(instance);
    if (inst == NULL) return fmi3Error;
    if (nvr == 0) return fmi3OK;
    LOG_ERR(inst, "%s: unknown value reference %lu (the FMU has no %s variables)", fn,
            vr != NULL ? (unsigned long)vr[0] : 0ul, type);
    return fmi3Error;
}

#define NO_TYPE(get, set, T, name)                                                          \
    fmi3Status get(fmi3Instance instance, const fmi3ValueReference valueReferences[],       \
                   size_t nValueReferences, T values[], size_t nValues) {                    \
        (void)values;                                                                       \
        (void)nValues;                                                                      \
        return no_such_type(instance, #get, name, valueReferences, nValueReferences);      \
    }                                                                                       \
    fmi3Status set(fmi3Instance instance, const fmi3ValueReference valueReferences[],       \
                   size_t nValueReferences, const T values[], size_t nValues) {              \
        (void)values;                                                                       \
        (void)nValues;                                                                      \
        return no_such_type(instance, #set, name, valueReferences, nValueReferences);      \
    }

NO_TYPE(fmi3GetFloat32, fmi3SetFloat32, fmi3Float32, "Float32")
NO_TYPE(fmi3GetInt8, fmi3SetInt8, fmi3Int8, "Int8")
NO_TYPE(fmi3GetUInt8, fmi3SetUInt8, fmi3UInt8, "UInt8")
NO_TYPE(fmi3GetInt16, fmi3SetInt16, fmi3Int16, "Int16")
NO_TYPE(fmi3GetUInt16, fmi3SetUInt16, fmi3UInt16, "UInt16")
NO_TYPE(fmi3GetUInt32, fmi3SetUInt32, fmi3UInt32, "UInt32")
NO_TYPE(fmi3GetInt64, fmi3SetInt64, fmi3Int64, "Int64")
NO_TYPE(fmi3GetUInt64, fmi3SetUInt64, fmi3UInt64, "UInt64")
NO_TYPE(fmi3GetString, fmi3SetString, fmi3String, "String")
#undef NO_TYPE

fmi3Status fmi3GetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                         size_t nValueReferences, size_t valueSizes[], fmi3Binary values[],
                         size_t nValues) {
    (void)valueSizes;
    (void)values;
    (void)nValues;
    return no_such_type(instance, "fmi3GetBinary", "Binary", valueReferences, nValueReferences);
}
fmi3Status fmi3SetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                         size_t nValueReferences, const size_t valueSizes[],
                         const fmi3Binary values[], size_t nValues) {
    (void)valueSizes;
    (void)values;
    (void)nValues;
    return no_such_type(instance, "fmi3SetBinary", "Binary", valueReferences, nValueReferences);
}
fmi3Status fmi3GetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                        size_t nValueReferences, fmi3Clock values[]) {
    (void)values;
    return no_such_type(instance, "fmi3GetClock", "Clock", valueReferences, nValueReferences);
}
fmi3Status fmi3SetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                        size_t nValueReferences, const fmi3Clock values[]) {
    (void)values;
    return no_such_type(instance, "fmi3SetClock", "Clock", valueReferences, nValueReferences);
}

fmi3Status fmi3GetNumberOfVariableDependencies(fmi3Instance instance,
                                               fmi3ValueReference valueReference,
                                               size_t *nDependencies) {
    (void)valueReference;
    (void)nDependencies;
    return not_provided(instance, "fmi3GetNumberOfVariableDependencies",
                        "not provided (the dependencies are in modelDescription.xml)");
}
fmi3Status fmi3GetVariableDependencies(fmi3Instance instance, fmi3ValueReference dependent,
                                       size_t elementIndicesOfDependent[],
                                       fmi3ValueReference independents[],
                                       size_t elementIndicesOfIndependents[],
                                       fmi3DependencyKind dependencyKinds[],
                                       size_t nDependencies) {
    (void)dependent;
    (void)elementIndicesOfDependent;
    (void)independents;
    (void)elementIndicesOfIndependents;
    (void)dependencyKinds;
    (void)nDependencies;
    return not_provided(instance, "fmi3GetVariableDependencies",
                        "not provided (the dependencies are in modelDescription.xml)");
}

/* ------------------------------------------------------------------ FMU states */

fmi3Status fmi3GetFMUState(fmi3Instance instance, fmi3FMUState *FMUState) {
    return (fmi3Status)fmi2GetFMUstate(instance, FMUState);
}
fmi3Status fmi3SetFMUState(fmi3Instance instance, fmi3FMUState FMUState) {
    return (fmi3Status)fmi2SetFMUstate(instance, FMUState);
}
fmi3Status fmi3FreeFMUState(fmi3Instance instance, fmi3FMUState *FMUState) {
    return (fmi3Status)fmi2FreeFMUstate(instance, FMUState);
}
fmi3Status fmi3SerializedFMUStateSize(fmi3Instance instance, fmi3FMUState FMUState,
                                      size_t *size) {
    return (fmi3Status)fmi2SerializedFMUstateSize(instance, FMUState, size);
}
fmi3Status fmi3SerializeFMUState(fmi3Instance instance, fmi3FMUState FMUState,
                                 fmi3Byte serializedState[], size_t size) {
    return (fmi3Status)fmi2SerializeFMUstate(instance, FMUState, (fmi2Byte *)serializedState,
                                             size);
}
fmi3Status fmi3DeserializeFMUState(fmi3Instance instance, const fmi3Byte serializedState[],
                                   size_t size, fmi3FMUState *FMUState) {
    return (fmi3Status)fmi2DeSerializeFMUstate(instance, (const fmi2Byte *)serializedState,
                                               size, FMUState);
}

/* ------------------------------------------------------------------ derivatives */

fmi3Status fmi3GetDirectionalDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[],
                                        size_t nUnknowns, const fmi3ValueReference knowns[],
                                        size_t nKnowns, const fmi3Float64 seed[], size_t nSeed,
                                        fmi3Float64 sensitivity[], size_t nSensitivity) {
    if (nSeed != nKnowns || nSensitivity != nUnknowns)
        return not_provided(instance, "fmi3GetDirectionalDerivative",
                            "nSeed must equal nKnowns and nSensitivity nUnknowns (scalars)");
    return (fmi3Status)fmu_derivatives(instance, "fmi3GetDirectionalDerivative", unknowns,
                                       nUnknowns, knowns, nKnowns, seed, sensitivity, 0);
}

fmi3Status fmi3GetAdjointDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[],
                                    size_t nUnknowns, const fmi3ValueReference knowns[],
                                    size_t nKnowns, const fmi3Float64 seed[], size_t nSeed,
                                    fmi3Float64 sensitivity[], size_t nSensitivity) {
    if (nSeed != nUnknowns || nSensitivity != nKnowns)
        return not_provided(instance, "fmi3GetAdjointDerivative",
                            "nSeed must equal nUnknowns and nSensitivity nKnowns (scalars)");
    return (fmi3Status)fmu_derivatives(instance, "fmi3GetAdjointDerivative", unknowns,
                                       nUnknowns, knowns, nKnowns, seed, sensitivity, 1);
}

/* ------------------------------------------------------------------ not provided */

fmi3Status fmi3EnterConfigurationMode(fmi3Instance instance) {
    return not_provided(instance, "fmi3EnterConfigurationMode", "the FMU has no structural "
                        "parameters");
}
fmi3Status fmi3ExitConfigurationMode(fmi3Instance instance) {
    return not_provided(instance, "fmi3ExitConfigurationMode", "the FMU has no structural "
                        "parameters");
}

#define NO_CLOCKS "the FMU has no clocks (the controller's period is its fixed step)"
fmi3Status fmi3GetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference vr[],
                                  size_t nvr, fmi3Float64 intervals[],
                                  fmi3IntervalQualifier qualifiers[]) {
    (void)vr; (void)nvr; (void)intervals; (void)qualifiers;
    return not_provided(instance, "fmi3GetIntervalDecimal", NO_CLOCKS);
}
fmi3Status fmi3GetIntervalFraction(fmi3Instance instance, const fmi3ValueReference vr[],
                                   size_t nvr, fmi3UInt64 counters[], fmi3UInt64 resolutions[],
                                   fmi3IntervalQualifier qualifiers[]) {
    (void)vr; (void)nvr; (void)counters; (void)resolutions; (void)qualifiers;
    return not_provided(instance, "fmi3GetIntervalFraction", NO_CLOCKS);
}
fmi3Status fmi3GetShiftDecimal(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                               fmi3Float64 shifts[]) {
    (void)vr; (void)nvr; (void)shifts;
    return not_provided(instance, "fmi3GetShiftDecimal", NO_CLOCKS);
}
fmi3Status fmi3GetShiftFraction(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                fmi3UInt64 counters[], fmi3UInt64 resolutions[]) {
    (void)vr; (void)nvr; (void)counters; (void)resolutions;
    return not_provided(instance, "fmi3GetShiftFraction", NO_CLOCKS);
}
fmi3Status fmi3SetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference vr[],
                                  size_t nvr, const fmi3Float64 intervals[]) {
    (void)vr; (void)nvr; (void)intervals;
    return not_provided(instance, "fmi3SetIntervalDecimal", NO_CLOCKS);
}
fmi3Status fmi3SetIntervalFraction(fmi3Instance instance, const fmi3ValueReference vr[],
                                   size_t nvr, const fmi3UInt64 counters[],
                                   const fmi3UInt64 resolutions[]) {
    (void)vr; (void)nvr; (void)counters; (void)resolutions;
    return not_provided(instance, "fmi3SetIntervalFraction", NO_CLOCKS);
}
fmi3Status fmi3SetShiftDecimal(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                               const fmi3Float64 shifts[]) {
    (void)vr; (void)nvr; (void)shifts;
    return not_provided(instance, "fmi3SetShiftDecimal", NO_CLOCKS);
}
fmi3Status fmi3SetShiftFraction(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                const fmi3UInt64 counters[], const fmi3UInt64 resolutions[]) {
    (void)vr; (void)nvr; (void)counters; (void)resolutions;
    return not_provided(instance, "fmi3SetShiftFraction", NO_CLOCKS);
}
fmi3Status fmi3ActivateModelPartition(fmi3Instance instance, fmi3ValueReference clockReference,
                                      fmi3Float64 activationTime) {
    (void)clockReference;
    (void)activationTime;
    return not_provided(instance, "fmi3ActivateModelPartition", NO_CLOCKS);
}
#undef NO_CLOCKS

fmi3Status fmi3EvaluateDiscreteStates(fmi3Instance instance) {
    /* the discrete states change only in fmi3UpdateDiscreteStates / fmi3DoStep */
    return fmu_as_instance(instance) != NULL ? fmi3OK : fmi3Error;
}

fmi3Status fmi3UpdateDiscreteStates(fmi3Instance instance, fmi3Boolean *discreteStatesNeedUpdate,
                                    fmi3Boolean *terminateSimulation,
                                    fmi3Boolean *nominalsOfContinuousStatesChanged,
                                    fmi3Boolean *valuesOfContinuousStatesChanged,
                                    fmi3Boolean *nextEventTimeDefined,
                                    fmi3Float64 *nextEventTime) {
    fmi2EventInfo info;
    fmi2Status st;
    if (discreteStatesNeedUpdate == NULL || terminateSimulation == NULL ||
        nominalsOfContinuousStatesChanged == NULL || valuesOfContinuousStatesChanged == NULL ||
        nextEventTimeDefined == NULL || nextEventTime == NULL)
        return not_provided(instance, "fmi3UpdateDiscreteStates", "NULL argument");
    st = fmi2NewDiscreteStates(instance, &info);
    if (st != fmi2OK && st != fmi2Warning) return (fmi3Status)st;
    *discreteStatesNeedUpdate = info.newDiscreteStatesNeeded != fmi2False;
    *terminateSimulation = info.terminateSimulation != fmi2False;
    *nominalsOfContinuousStatesChanged = info.nominalsOfContinuousStatesChanged != fmi2False;
    *valuesOfContinuousStatesChanged = info.valuesOfContinuousStatesChanged != fmi2False;
    *nextEventTimeDefined = info.nextEventTimeDefined != fmi2False;
    *nextEventTime = info.nextEventTime;
    return (fmi3Status)st;
}

/* ------------------------------------------------------------------ Model Exchange */

fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance instance) {
    return (fmi3Status)fmi2EnterContinuousTimeMode(instance);
}

fmi3Status fmi3CompletedIntegratorStep(fmi3Instance instance,
                                       fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi3Boolean *enterEventMode,
                                       fmi3Boolean *terminateSimulation) {
    fmi2Boolean ev = fmi2False, term = fmi2False;
    fmi2Status st;
    if (enterEventMode == NULL || terminateSimulation == NULL)
        return not_provided(instance, "fmi3CompletedIntegratorStep", "NULL argument");
    st = fmi2CompletedIntegratorStep(instance, noSetFMUStatePriorToCurrentPoint ? fmi2True
                                                                                : fmi2False,
                                     &ev, &term);
    *enterEventMode = ev != fmi2False;
    *terminateSimulation = term != fmi2False;
    return (fmi3Status)st;
}

fmi3Status fmi3SetTime(fmi3Instance instance, fmi3Float64 time) {
    return (fmi3Status)fmi2SetTime(instance, time);
}
fmi3Status fmi3SetContinuousStates(fmi3Instance instance, const fmi3Float64 continuousStates[],
                                   size_t nContinuousStates) {
    return (fmi3Status)fmi2SetContinuousStates(instance, continuousStates, nContinuousStates);
}
fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance instance, fmi3Float64 derivatives[],
                                             size_t nContinuousStates) {
    return (fmi3Status)fmi2GetDerivatives(instance, derivatives, nContinuousStates);
}
fmi3Status fmi3GetEventIndicators(fmi3Instance instance, fmi3Float64 eventIndicators[],
                                  size_t nEventIndicators) {
    return (fmi3Status)fmi2GetEventIndicators(instance, eventIndicators, nEventIndicators);
}
fmi3Status fmi3GetContinuousStates(fmi3Instance instance, fmi3Float64 continuousStates[],
                                   size_t nContinuousStates) {
    return (fmi3Status)fmi2GetContinuousStates(instance, continuousStates, nContinuousStates);
}
fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance instance, fmi3Float64 nominals[],
                                             size_t nContinuousStates) {
    return (fmi3Status)fmi2GetNominalsOfContinuousStates(instance, nominals, nContinuousStates);
}
fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance instance, size_t *nEventIndicators) {
    if (fmu_as_instance(instance) == NULL || nEventIndicators == NULL) return fmi3Error;
    *nEventIndicators = 0;
    return fmi3OK;
}
fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance instance, size_t *nContinuousStates) {
    if (fmu_as_instance(instance) == NULL || nContinuousStates == NULL) return fmi3Error;
    *nContinuousStates = fmu_model.vars->n_states;
    return fmi3OK;
}

/* ------------------------------------------------------------------ Co-Simulation */

fmi3Status fmi3EnterStepMode(fmi3Instance instance) {
    return not_provided(instance, "fmi3EnterStepMode", "no event mode (hasEventMode = false): "
                        "fmi3ExitInitializationMode enters step mode");
}

fmi3Status fmi3GetOutputDerivatives(fmi3Instance instance,
                                    const fmi3ValueReference valueReferences[],
                                    size_t nValueReferences, const fmi3Int32 orders[],
                                    fmi3Float64 values[], size_t nValues) {
    (void)orders;
    (void)values;
    (void)nValues;
    return (fmi3Status)fmi2GetRealOutputDerivatives(instance, valueReferences, nValueReferences,
                                                    NULL, NULL);
}

fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 currentCommunicationPoint,
                      fmi3Float64 communicationStepSize,
                      fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                      fmi3Boolean *eventHandlingNeeded, fmi3Boolean *terminateSimulation,
                      fmi3Boolean *earlyReturn, fmi3Float64 *lastSuccessfulTime) {
    fmu_instance *inst = fmu_as_instance(instance);
    fmi2Status st;
    if (inst == NULL) return fmi3Error;
    if (eventHandlingNeeded == NULL || terminateSimulation == NULL || earlyReturn == NULL ||
        lastSuccessfulTime == NULL)
        return not_provided(instance, "fmi3DoStep", "NULL argument");
    st = fmi2DoStep(instance, currentCommunicationPoint, communicationStepSize,
                    noSetFMUStatePriorToCurrentPoint ? fmi2True : fmi2False);
    *eventHandlingNeeded = false;
    *terminateSimulation = false;
    *earlyReturn = false;
    *lastSuccessfulTime = inst->time;
    return (fmi3Status)st;
}
