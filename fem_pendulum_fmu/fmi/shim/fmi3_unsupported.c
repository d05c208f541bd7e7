/* The FMI 3.0 functions this FMU does not provide (its modelDescription declares no model exchange, no
 * scheduled execution, no clocks, no types but Float64, Int32, Int64 (Enumerations), Boolean and String,
 * no directional derivatives, no configuration mode, no variable dependencies):
 * each answers fmi3Error with a log message naming it, changes nothing, and never reads its arguments.
 * Generated once from fmpy's fmi3FunctionTypes.h; the exported names must cover the whole FMI 3.0 API,
 * since hosts look every function up when they load the binary. */
#include <stdio.h>

#include "call_frame.h"
#include "fmi3Functions.h"
#include "fmi3_shim.h"
#include "python_runtime.h"

fmi3Status not_provided(fmi3Instance instance, const char *function) {
    Instance *inst = (Instance *)instance;
    if (inst != NULL)
        log_error(inst, "%s is not provided by this FMU (see its modelDescription.xml); nothing was changed", function);
    return fmi3Error;
}

static void instantiation_refused(fmi3String name, fmi3InstanceEnvironment env, fmi3LogMessageCallback log,
                                  const char *function) {
    char text[512];
    snprintf(text, sizeof text, "%s refused: this FMU is for co-simulation only (fmi3InstantiateCoSimulation)",
             function);
    if (python_ended()) return; /* the callback may be Python code (python_runtime.h) */
    if (log != NULL)
        log(env, fmi3Error, "logStatusError", text);
    else
        fprintf(stderr, "%s: %s\n", name ? name : "FMU", text);
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String instantiationToken, fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn, fmi3InstanceEnvironment instanceEnvironment, fmi3LogMessageCallback logMessage) {
    (void)instantiationToken;
    (void)resourcePath;
    (void)visible;
    (void)loggingOn;
    instantiation_refused(instanceName, instanceEnvironment, logMessage, "fmi3InstantiateModelExchange");
    return NULL;
}

fmi3Instance fmi3InstantiateScheduledExecution(fmi3String instanceName, fmi3String instantiationToken, fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn, fmi3InstanceEnvironment instanceEnvironment, fmi3LogMessageCallback logMessage, fmi3ClockUpdateCallback clockUpdate, fmi3LockPreemptionCallback lockPreemption, fmi3UnlockPreemptionCallback unlockPreemption) {
    (void)instantiationToken;
    (void)resourcePath;
    (void)visible;
    (void)loggingOn;
    (void)clockUpdate;
    (void)lockPreemption;
    (void)unlockPreemption;
    instantiation_refused(instanceName, instanceEnvironment, logMessage, "fmi3InstantiateScheduledExecution");
    return NULL;
}

/* The scalar types this FMU has no variable of: Get and Set refuse them alike. */
#define NOT_PROVIDED_GET(T)                                                                                        \
    fmi3Status fmi3Get##T(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, \
                          fmi3##T values[], size_t nValues) {                                                       \
        (void)valueReferences;                                                                                     \
        (void)nValueReferences;                                                                                    \
        (void)values;                                                                                              \
        (void)nValues;                                                                                             \
        return not_provided(instance, "fmi3Get" #T);                                                               \
    }
#define NOT_PROVIDED_SET(T)                                                                                        \
    fmi3Status fmi3Set##T(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, \
                          const fmi3##T values[], size_t nValues) {                                                 \
        (void)valueReferences;                                                                                     \
        (void)nValueReferences;                                                                                    \
        (void)values;                                                                                              \
        (void)nValues;                                                                                             \
        return not_provided(instance, "fmi3Set" #T);                                                               \
    }

NOT_PROVIDED_GET(Float32)
NOT_PROVIDED_GET(Int8)
NOT_PROVIDED_GET(UInt8)
NOT_PROVIDED_GET(Int16)
NOT_PROVIDED_GET(UInt16)
NOT_PROVIDED_GET(UInt32)
NOT_PROVIDED_GET(UInt64)

NOT_PROVIDED_SET(Float32)
NOT_PROVIDED_SET(Int8)
NOT_PROVIDED_SET(UInt8)
NOT_PROVIDED_SET(Int16)
NOT_PROVIDED_SET(UInt16)
NOT_PROVIDED_SET(UInt32)
NOT_PROVIDED_SET(UInt64)

fmi3Status fmi3GetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, size_t valueSizes[], fmi3Binary values[], size_t nValues) {
    (void)valueReferences;
    (void)nValueReferences;
    (void)valueSizes;
    (void)values;
    (void)nValues;
    return not_provided(instance, "fmi3GetBinary");
}

fmi3Status fmi3GetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, fmi3Clock values[]) {
    (void)valueReferences;
    (void)nValueReferences;
    (void)values;
    return not_provided(instance, "fmi3GetClock");
}

fmi3Status fmi3SetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const size_t valueSizes[], const fmi3Binary values[], size_t nValues) {
    (void)valueReferences;
    (void)nValueReferences;
    (void)valueSizes;
    (void)values;
    (void)nValues;
    return not_provided(instance, "fmi3SetBinary");
}

fmi3Status fmi3SetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3Clock values[]) {
    (void)valueReferences;
    (void)nValueReferences;
    (void)values;
    return not_provided(instance, "fmi3SetClock");
}

fmi3Status fmi3GetNumberOfVariableDependencies(fmi3Instance instance, fmi3ValueReference valueReference, size_t* nDependencies) {
    (void)valueReference;
    (void)nDependencies;
    return not_provided(instance, "fmi3GetNumberOfVariableDependencies");
}

fmi3Status fmi3GetVariableDependencies(fmi3Instance instance, fmi3ValueReference dependent, size_t elementIndicesOfDependent[], fmi3ValueReference independents[], size_t elementIndicesOfIndependents[], fmi3DependencyKind dependencyKinds[], size_t nDependencies) {
    (void)dependent;
    (void)elementIndicesOfDependent;
    (void)independents;
    (void)elementIndicesOfIndependents;
    (void)dependencyKinds;
    (void)nDependencies;
    return not_provided(instance, "fmi3GetVariableDependencies");
}

fmi3Status fmi3GetDirectionalDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns, const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[], size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity) {
    (void)unknowns;
    (void)nUnknowns;
    (void)knowns;
    (void)nKnowns;
    (void)seed;
    (void)nSeed;
    (void)sensitivity;
    (void)nSensitivity;
    return not_provided(instance, "fmi3GetDirectionalDerivative");
}

fmi3Status fmi3GetAdjointDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns, const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[], size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity) {
    (void)unknowns;
    (void)nUnknowns;
    (void)knowns;
    (void)nKnowns;
    (void)seed;
    (void)nSeed;
    (void)sensitivity;
    (void)nSensitivity;
    return not_provided(instance, "fmi3GetAdjointDerivative");
}

fmi3Status fmi3EnterConfigurationMode(fmi3Instance instance) {
    return not_provided(instance, "fmi3EnterConfigurationMode");
}

fmi3Status fmi3ExitConfigurationMode(fmi3Instance instance) {
    return not_provided(instance, "fmi3ExitConfigurationMode");
}

fmi3Status fmi3GetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, fmi3Float64 intervals[], fmi3IntervalQualifier qualifiers[]) {
    (void)valueReferences;
    (void)nValueReferences;
    (void)intervals;
    (void)qualifiers;
    return not_provided(instance, "fmi3GetIntervalDecimal");
}

fmi3Status fmi3GetIntervalFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, fmi3UInt64 counters[], fmi3UInt64 resolutions[], fmi3IntervalQualifier qualifiers[]) {
    (void)valueReferences;
    (void)nValueReferences;
    (void)counters;
    (void)resolutions;
    (void)qualifiers;
    return not_provided(instance, "fmi3GetIntervalFraction");
}

fmi3Status fmi3GetShiftDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, fmi3Float64 shifts[]) {
    (void)valueReferences;
    (void)nValueReferences;
    (void)shifts;
    return not_provided(instance, "fmi3GetShiftDecimal");
}

fmi3Status fmi3GetShiftFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, fmi3UInt64 counters[], fmi3UInt64 resolutions[]) {
    (void)valueReferences;
    (void)nValueReferences;
    (void)counters;
    (void)resolutions;
    return not_provided(instance, "fmi3GetShiftFraction");
}

fmi3Status fmi3SetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3Float64 intervals[]) {
    (void)valueReferences;
    (void)nValueReferences;
    (void)intervals;
    return not_provided(instance, "fmi3SetIntervalDecimal");
}

fmi3Status fmi3SetIntervalFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3UInt64 counters[], const fmi3UInt64 resolutions[]) {
    (void)valueReferences;
    (void)nValueReferences;
    (void)counters;
    (void)resolutions;
    return not_provided(instance, "fmi3SetIntervalFraction");
}

fmi3Status fmi3SetShiftDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3Float64 shifts[]) {
    (void)valueReferences;
    (void)nValueReferences;
    (void)shifts;
    return not_provided(instance, "fmi3SetShiftDecimal");
}

fmi3Status fmi3SetShiftFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3UInt64 counters[], const fmi3UInt64 resolutions[]) {
    (void)valueReferences;
    (void)nValueReferences;
    (void)counters;
    (void)resolutions;
    return not_provided(instance, "fmi3SetShiftFraction");
}

fmi3Status fmi3EvaluateDiscreteStates(fmi3Instance instance) {
    return not_provided(instance, "fmi3EvaluateDiscreteStates");
}

fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance instance) {
    return not_provided(instance, "fmi3EnterContinuousTimeMode");
}

fmi3Status fmi3CompletedIntegratorStep(fmi3Instance instance, fmi3Boolean noSetFMUStatePriorToCurrentPoint, fmi3Boolean* enterEventMode, fmi3Boolean* terminateSimulation) {
    (void)noSetFMUStatePriorToCurrentPoint;
    (void)enterEventMode;
    (void)terminateSimulation;
    return not_provided(instance, "fmi3CompletedIntegratorStep");
}

fmi3Status fmi3SetTime(fmi3Instance instance, fmi3Float64 time) {
    (void)time;
    return not_provided(instance, "fmi3SetTime");
}

fmi3Status fmi3SetContinuousStates(fmi3Instance instance, const fmi3Float64 continuousStates[], size_t nContinuousStates) {
    (void)continuousStates;
    (void)nContinuousStates;
    return not_provided(instance, "fmi3SetContinuousStates");
}

fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance instance, fmi3Float64 derivatives[], size_t nContinuousStates) {
    (void)derivatives;
    (void)nContinuousStates;
    return not_provided(instance, "fmi3GetContinuousStateDerivatives");
}

fmi3Status fmi3GetEventIndicators(fmi3Instance instance, fmi3Float64 eventIndicators[], size_t nEventIndicators) {
    (void)eventIndicators;
    (void)nEventIndicators;
    return not_provided(instance, "fmi3GetEventIndicators");
}

fmi3Status fmi3GetContinuousStates(fmi3Instance instance, fmi3Float64 continuousStates[], size_t nContinuousStates) {
    (void)continuousStates;
    (void)nContinuousStates;
    return not_provided(instance, "fmi3GetContinuousStates");
}

fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance instance, fmi3Float64 nominals[], size_t nContinuousStates) {
    (void)nominals;
    (void)nContinuousStates;
    return not_provided(instance, "fmi3GetNominalsOfContinuousStates");
}

fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance instance, size_t* nEventIndicators) {
    (void)nEventIndicators;
    return not_provided(instance, "fmi3GetNumberOfEventIndicators");
}

fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance instance, size_t* nContinuousStates) {
    (void)nContinuousStates;
    return not_provided(instance, "fmi3GetNumberOfContinuousStates");
}

fmi3Status fmi3ActivateModelPartition(fmi3Instance instance, fmi3ValueReference clockReference, fmi3Float64 activationTime) {
    (void)clockReference;
    (void)activationTime;
    return not_provided(instance, "fmi3ActivateModelPartition");
}
