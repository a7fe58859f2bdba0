/* plant_fmi3.c: FMI 3.0 co-simulation wrapper of the plant model (modelIdentifier navkit_plant).
 *
 * States: Instantiated -> InitializationMode -> StepMode -> Terminated; fmi3Reset goes back
 * to Instantiated with start values. The instance logic (state table, get/set, doStep) is
 * plant_instance.c; this file maps it onto the FMI 3 calls and refuses the rest with
 * fmi3Error. No event mode, no clocks, no FMU state, no ME/SE.
 */
#include "plant_instance.h"

#include <string.h>

#include "fmi3Functions.h" /* exports the fmi3 functions (visibility default) */

/* One FMU instance: the shared part plus the importer's logger. */
typedef struct {
  npi_t base;                      /* first: an fmi3Instance is also an npi_t pointer */
  fmi3InstanceEnvironment env;
  fmi3LogMessageCallback log;
} inst_t;

/* The fmi3Status of a shared call's result. */
static fmi3Status to_fmi3(npi_status_t st) { return st == NPI_OK ? fmi3OK : fmi3Error; }

/* npi_log_fn: passes msg to the importer's fmi3LogMessageCallback, if there is one. */
static void log_fmi3(const npi_t *base, npi_status_t st, const char *msg) {
  const inst_t *c = (const inst_t *)base;
  if (c->log) c->log(c->env, to_fmi3(st), st == NPI_ERROR ? "logStatusError" : "logEvents", msg);
}

/* ---------------------------------------------------------------- common */

const char *fmi3GetVersion(void) { return fmi3Version; }

fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn, size_t nCategories,
                               const fmi3String categories[]) {
  (void)nCategories; (void)categories;
  return to_fmi3(npi_set_debug_logging(instance, loggingOn));
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String instantiationToken,
                                          fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                          fmi3InstanceEnvironment instanceEnvironment,
                                          fmi3LogMessageCallback logMessage) {
  (void)instanceName; (void)instantiationToken; (void)resourcePath; (void)visible; (void)loggingOn;
  if (logMessage) logMessage(instanceEnvironment, fmi3Error, "logStatusError", "navkit_plant is co-simulation only");
  return NULL;
}

fmi3Instance fmi3InstantiateCoSimulation(fmi3String instanceName, fmi3String instantiationToken,
                                         fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                         fmi3Boolean eventModeUsed, fmi3Boolean earlyReturnAllowed,
                                         const fmi3ValueReference requiredIntermediateVariables[],
                                         size_t nRequiredIntermediateVariables,
                                         fmi3InstanceEnvironment instanceEnvironment,
                                         fmi3LogMessageCallback logMessage,
                                         fmi3IntermediateUpdateCallback intermediateUpdate) {
  (void)resourcePath; (void)visible; (void)earlyReturnAllowed; (void)requiredIntermediateVariables;
  (void)nRequiredIntermediateVariables; (void)intermediateUpdate;
  const char *why = NULL;
  if (!instantiationToken || strcmp(instantiationToken, NP_INSTANTIATION_TOKEN) != 0)
    why = "instantiationToken does not match modelDescription.xml";
  else if (eventModeUsed)
    why = "event mode is not supported";
  if (why) {
    if (logMessage) logMessage(instanceEnvironment, fmi3Error, "logStatusError", why);
    return NULL;
  }
  inst_t *c = (inst_t *)npi_new(sizeof *c, instanceName, loggingOn, "fmi3", log_fmi3);
  if (!c) return NULL;
  c->env = instanceEnvironment;
  c->log = logMessage;
  return c;
}

fmi3Instance fmi3InstantiateScheduledExecution(fmi3String instanceName, fmi3String instantiationToken,
                                               fmi3String resourcePath, fmi3Boolean visible,
                                               fmi3Boolean loggingOn, fmi3InstanceEnvironment instanceEnvironment,
                                               fmi3LogMessageCallback logMessage,
                                               fmi3ClockUpdateCallback clockUpdate,
                                               fmi3LockPreemptionCallback lockPreemption,
                                               fmi3UnlockPreemptionCallback unlockPreemption) {
  (void)instanceName; (void)instantiationToken; (void)resourcePath; (void)visible; (void)loggingOn;
  (void)clockUpdate; (void)lockPreemption; (void)unlockPreemption;
  if (logMessage) logMessage(instanceEnvironment, fmi3Error, "logStatusError", "navkit_plant is co-simulation only");
  return NULL;
}

void fmi3FreeInstance(fmi3Instance instance) { npi_free(instance); }

fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean toleranceDefined, fmi3Float64 tolerance,
                                       fmi3Float64 startTime, fmi3Boolean stopTimeDefined, fmi3Float64 stopTime) {
  (void)toleranceDefined; (void)tolerance; (void)stopTimeDefined; (void)stopTime;
  return to_fmi3(npi_enter_init(instance, startTime));
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance instance) { return to_fmi3(npi_exit_init(instance)); }

fmi3Status fmi3EnterEventMode(fmi3Instance instance) {
  npi_log(instance, NPI_ERROR, "fmi3EnterEventMode: event mode is not supported");
  return fmi3Error;
}

fmi3Status fmi3Terminate(fmi3Instance instance) { return to_fmi3(npi_terminate(instance)); }

fmi3Status fmi3Reset(fmi3Instance instance) { return to_fmi3(npi_reset(instance)); }

/* ---------------------------------------------------------------- get / set */

fmi3Status fmi3GetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                          fmi3Float64 values[], size_t nValues) {
  return to_fmi3(npi_get(instance, valueReferences, nValueReferences, values, nValues, NP_F64, "fmi3GetFloat64"));
}

fmi3Status fmi3SetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                          const fmi3Float64 values[], size_t nValues) {
  return to_fmi3(npi_set(instance, valueReferences, nValueReferences, values, nValues, NP_F64, "fmi3SetFloat64"));
}

fmi3Status fmi3GetInt32(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        fmi3Int32 values[], size_t nValues) {
  return to_fmi3(npi_get(instance, valueReferences, nValueReferences, values, nValues, NP_I32, "fmi3GetInt32"));
}

fmi3Status fmi3SetInt32(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        const fmi3Int32 values[], size_t nValues) {
  return to_fmi3(npi_set(instance, valueReferences, nValueReferences, values, nValues, NP_I32, "fmi3SetInt32"));
}

fmi3Status fmi3GetString(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         fmi3String values[], size_t nValues) {
  return to_fmi3(npi_get_strings(instance, valueReferences, nValueReferences, values, nValues, "fmi3GetString"));
}

fmi3Status fmi3SetString(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         const fmi3String values[], size_t nValues) {
  return to_fmi3(npi_set_strings(instance, valueReferences, nValueReferences, values, nValues, "fmi3SetString"));
}

/* Getters and setters of types the model has none of: any value reference is wrong. */
#define NP_NO_TYPE(T, CT)                                                                                   \
  fmi3Status fmi3Get##T(fmi3Instance instance, const fmi3ValueReference valueReferences[],                  \
                        size_t nValueReferences, CT values[], size_t nValues) {                             \
    (void)valueReferences; (void)values; (void)nValues;                                                     \
    return to_fmi3(npi_no_values(instance, nValueReferences,                                                \
                                 "fmi3Get" #T ": the model has no variable of this type"));                 \
  }                                                                                                         \
  fmi3Status fmi3Set##T(fmi3Instance instance, const fmi3ValueReference valueReferences[],                  \
                        size_t nValueReferences, const CT values[], size_t nValues) {                       \
    (void)valueReferences; (void)values; (void)nValues;                                                     \
    return to_fmi3(npi_no_values(instance, nValueReferences,                                                \
                                 "fmi3Set" #T ": the model has no variable of this type"));                 \
  }
NP_NO_TYPE(Float32, fmi3Float32)
NP_NO_TYPE(Int8, fmi3Int8)
NP_NO_TYPE(UInt8, fmi3UInt8)
NP_NO_TYPE(Int16, fmi3Int16)
NP_NO_TYPE(UInt16, fmi3UInt16)
NP_NO_TYPE(UInt32, fmi3UInt32)
NP_NO_TYPE(Int64, fmi3Int64)
NP_NO_TYPE(UInt64, fmi3UInt64)
NP_NO_TYPE(Boolean, fmi3Boolean)

fmi3Status fmi3GetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        fmi3Clock values[]) {
  (void)valueReferences; (void)values;
  return to_fmi3(npi_no_values(instance, nValueReferences, "fmi3GetClock: the model has no clocks"));
}

fmi3Status fmi3SetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        const fmi3Clock values[]) {
  (void)valueReferences; (void)values;
  return to_fmi3(npi_no_values(instance, nValueReferences, "fmi3SetClock: the model has no clocks"));
}

fmi3Status fmi3GetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         size_t valueSizes[], fmi3Binary values[], size_t nValues) {
  (void)valueReferences; (void)valueSizes; (void)values; (void)nValues;
  return to_fmi3(npi_no_values(instance, nValueReferences, "fmi3GetBinary: the model has no Binary variable"));
}

fmi3Status fmi3SetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         const size_t valueSizes[], const fmi3Binary values[], size_t nValues) {
  (void)valueReferences; (void)valueSizes; (void)values; (void)nValues;
  return to_fmi3(npi_no_values(instance, nValueReferences, "fmi3SetBinary: the model has no Binary variable"));
}

/* ---------------------------------------------------------------- co-simulation */

fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 currentCommunicationPoint,
                      fmi3Float64 communicationStepSize, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                      fmi3Boolean *eventHandlingNeeded, fmi3Boolean *terminateSimulation, fmi3Boolean *earlyReturn,
                      fmi3Float64 *lastSuccessfulTime) {
  npi_t *c = instance;
  (void)noSetFMUStatePriorToCurrentPoint;
  if (npi_do_step(c, currentCommunicationPoint, communicationStepSize)) return fmi3Error;
  if (eventHandlingNeeded) *eventHandlingNeeded = fmi3False;
  if (terminateSimulation) *terminateSimulation = fmi3False;
  if (earlyReturn) *earlyReturn = fmi3False;
  if (lastSuccessfulTime) *lastSuccessfulTime = c->m.t;
  return fmi3OK;
}

/* ---------------------------------------------------------------- not supported */

/* Logs that fn is not supported and returns fmi3Error. */
static fmi3Status unsupported(fmi3Instance instance, const char *fn) {
  npi_log(instance, NPI_ERROR, "%s is not supported by navkit_plant", fn);
  return fmi3Error;
}

fmi3Status fmi3GetNumberOfVariableDependencies(fmi3Instance instance, fmi3ValueReference valueReference,
                                               size_t *nDependencies) {
  (void)valueReference; (void)nDependencies;
  return unsupported(instance, "fmi3GetNumberOfVariableDependencies");
}

fmi3Status fmi3GetVariableDependencies(fmi3Instance instance, fmi3ValueReference dependent,
                                       size_t elementIndicesOfDependent[], fmi3ValueReference independents[],
                                       size_t elementIndicesOfIndependents[], fmi3DependencyKind dependencyKinds[],
                                       size_t nDependencies) {
  (void)dependent; (void)elementIndicesOfDependent; (void)independents; (void)elementIndicesOfIndependents;
  (void)dependencyKinds; (void)nDependencies;
  return unsupported(instance, "fmi3GetVariableDependencies");
}

fmi3Status fmi3GetFMUState(fmi3Instance instance, fmi3FMUState *FMUState) {
  (void)FMUState;
  return unsupported(instance, "fmi3GetFMUState");
}

fmi3Status fmi3SetFMUState(fmi3Instance instance, fmi3FMUState FMUState) {
  (void)FMUState;
  return unsupported(instance, "fmi3SetFMUState");
}

fmi3Status fmi3FreeFMUState(fmi3Instance instance, fmi3FMUState *FMUState) {
  (void)FMUState;
  return unsupported(instance, "fmi3FreeFMUState");
}

fmi3Status fmi3SerializedFMUStateSize(fmi3Instance instance, fmi3FMUState FMUState, size_t *size) {
  (void)FMUState; (void)size;
  return unsupported(instance, "fmi3SerializedFMUStateSize");
}

fmi3Status fmi3SerializeFMUState(fmi3Instance instance, fmi3FMUState FMUState, fmi3Byte serializedState[],
                                 size_t size) {
  (void)FMUState; (void)serializedState; (void)size;
  return unsupported(instance, "fmi3SerializeFMUState");
}

fmi3Status fmi3DeserializeFMUState(fmi3Instance instance, const fmi3Byte serializedState[], size_t size,
                                   fmi3FMUState *FMUState) {
  (void)serializedState; (void)size; (void)FMUState;
  return unsupported(instance, "fmi3DeserializeFMUState");
}

fmi3Status fmi3GetDirectionalDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns,
                                        const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[],
                                        size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity) {
  (void)unknowns; (void)nUnknowns; (void)knowns; (void)nKnowns; (void)seed; (void)nSeed; (void)sensitivity;
  (void)nSensitivity;
  return unsupported(instance, "fmi3GetDirectionalDerivative");
}

fmi3Status fmi3GetAdjointDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns,
                                    const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[],
                                    size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity) {
  (void)unknowns; (void)nUnknowns; (void)knowns; (void)nKnowns; (void)seed; (void)nSeed; (void)sensitivity;
  (void)nSensitivity;
  return unsupported(instance, "fmi3GetAdjointDerivative");
}

fmi3Status fmi3EnterConfigurationMode(fmi3Instance instance) {
  return unsupported(instance, "fmi3EnterConfigurationMode");
}

fmi3Status fmi3ExitConfigurationMode(fmi3Instance instance) {
  return unsupported(instance, "fmi3ExitConfigurationMode");
}

fmi3Status fmi3GetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                  size_t nValueReferences, fmi3Float64 intervals[],
                                  fmi3IntervalQualifier qualifiers[]) {
  (void)valueReferences; (void)nValueReferences; (void)intervals; (void)qualifiers;
  return unsupported(instance, "fmi3GetIntervalDecimal");
}

fmi3Status fmi3GetIntervalFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                   size_t nValueReferences, fmi3UInt64 counters[], fmi3UInt64 resolutions[],
                                   fmi3IntervalQualifier qualifiers[]) {
  (void)valueReferences; (void)nValueReferences; (void)counters; (void)resolutions; (void)qualifiers;
  return unsupported(instance, "fmi3GetIntervalFraction");
}

fmi3Status fmi3GetShiftDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                               size_t nValueReferences, fmi3Float64 shifts[]) {
  (void)valueReferences; (void)nValueReferences; (void)shifts;
  return unsupported(instance, "fmi3GetShiftDecimal");
}

fmi3Status fmi3GetShiftFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                size_t nValueReferences, fmi3UInt64 counters[], fmi3UInt64 resolutions[]) {
  (void)valueReferences; (void)nValueReferences; (void)counters; (void)resolutions;
  return unsupported(instance, "fmi3GetShiftFraction");
}

fmi3Status fmi3SetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                  size_t nValueReferences, const fmi3Float64 intervals[]) {
  (void)valueReferences; (void)nValueReferences; (void)intervals;
  return unsupported(instance, "fmi3SetIntervalDecimal");
}

fmi3Status fmi3SetIntervalFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                   size_t nValueReferences, const fmi3UInt64 counters[],
                                   const fmi3UInt64 resolutions[]) {
  (void)valueReferences; (void)nValueReferences; (void)counters; (void)resolutions;
  return unsupported(instance, "fmi3SetIntervalFraction");
}

fmi3Status fmi3SetShiftDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                               size_t nValueReferences, const fmi3Float64 shifts[]) {
  (void)valueReferences; (void)nValueReferences; (void)shifts;
  return unsupported(instance, "fmi3SetShiftDecimal");
}

fmi3Status fmi3SetShiftFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                size_t nValueReferences, const fmi3UInt64 counters[], const fmi3UInt64 resolutions[]) {
  (void)valueReferences; (void)nValueReferences; (void)counters; (void)resolutions;
  return unsupported(instance, "fmi3SetShiftFraction");
}

fmi3Status fmi3EvaluateDiscreteStates(fmi3Instance instance) {
  return unsupported(instance, "fmi3EvaluateDiscreteStates");
}

fmi3Status fmi3UpdateDiscreteStates(fmi3Instance instance, fmi3Boolean *discreteStatesNeedUpdate,
                                    fmi3Boolean *terminateSimulation, fmi3Boolean *nominalsOfContinuousStatesChanged,
                                    fmi3Boolean *valuesOfContinuousStatesChanged, fmi3Boolean *nextEventTimeDefined,
                                    fmi3Float64 *nextEventTime) {
  (void)discreteStatesNeedUpdate; (void)terminateSimulation; (void)nominalsOfContinuousStatesChanged;
  (void)valuesOfContinuousStatesChanged; (void)nextEventTimeDefined; (void)nextEventTime;
  return unsupported(instance, "fmi3UpdateDiscreteStates");
}

fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance instance) {
  return unsupported(instance, "fmi3EnterContinuousTimeMode");
}

fmi3Status fmi3CompletedIntegratorStep(fmi3Instance instance, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi3Boolean *enterEventMode, fmi3Boolean *terminateSimulation) {
  (void)noSetFMUStatePriorToCurrentPoint; (void)enterEventMode; (void)terminateSimulation;
  return unsupported(instance, "fmi3CompletedIntegratorStep");
}

fmi3Status fmi3SetTime(fmi3Instance instance, fmi3Float64 time) {
  (void)time;
  return unsupported(instance, "fmi3SetTime");
}

fmi3Status fmi3SetContinuousStates(fmi3Instance instance, const fmi3Float64 continuousStates[],
                                   size_t nContinuousStates) {
  (void)continuousStates; (void)nContinuousStates;
  return unsupported(instance, "fmi3SetContinuousStates");
}

fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance instance, fmi3Float64 derivatives[],
                                             size_t nContinuousStates) {
  (void)derivatives; (void)nContinuousStates;
  return unsupported(instance, "fmi3GetContinuousStateDerivatives");
}

fmi3Status fmi3GetEventIndicators(fmi3Instance instance, fmi3Float64 eventIndicators[], size_t nEventIndicators) {
  (void)eventIndicators; (void)nEventIndicators;
  return unsupported(instance, "fmi3GetEventIndicators");
}

fmi3Status fmi3GetContinuousStates(fmi3Instance instance, fmi3Float64 continuousStates[],
                                   size_t nContinuousStates) {
  (void)continuousStates; (void)nContinuousStates;
  return unsupported(instance, "fmi3GetContinuousStates");
}

fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance instance, fmi3Float64 nominals[],
                                             size_t nContinuousStates) {
  (void)nominals; (void)nContinuousStates;
  return unsupported(instance, "fmi3GetNominalsOfContinuousStates");
}

fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance instance, size_t *nEventIndicators) {
  (void)nEventIndicators;
  return unsupported(instance, "fmi3GetNumberOfEventIndicators");
}

fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance instance, size_t *nContinuousStates) {
  (void)nContinuousStates;
  return unsupported(instance, "fmi3GetNumberOfContinuousStates");
}

fmi3Status fmi3EnterStepMode(fmi3Instance instance) {
  return unsupported(instance, "fmi3EnterStepMode (no event mode)");
}

fmi3Status fmi3GetOutputDerivatives(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                    size_t nValueReferences, const fmi3Int32 orders[], fmi3Float64 values[],
                                    size_t nValues) {
  (void)valueReferences; (void)nValueReferences; (void)orders; (void)values; (void)nValues;
  return unsupported(instance, "fmi3GetOutputDerivatives");
}

fmi3Status fmi3ActivateModelPartition(fmi3Instance instance, fmi3ValueReference clockReference,
                                      fmi3Float64 activationTime) {
  (void)clockReference; (void)activationTime;
  return unsupported(instance, "fmi3ActivateModelPartition");
}
