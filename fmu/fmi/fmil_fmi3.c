/* fmil_fmi3.c: the FMI 3.0 co-simulation entry points of the layer (fmil.h). Each maps
 * onto the version-neutral calls of fmil_instance.c; model exchange, scheduled execution,
 * event mode, clocks, FMU state and derivatives are refused with fmi3Error and a message. */
#include <string.h>

#include "fmi3Functions.h" /* exports the fmi3 functions (visibility default; the rest is hidden) */
#include "fmil.h"

/* The fmi3Status of a layer result. */
static fmi3Status fmil3_status(fmil_status_t st)
{
    return st == FMIL_OK ? fmi3OK : st == FMIL_WARNING ? fmi3Warning : fmi3Error;
}

/* fmil_log_fn: passes msg to the importer's fmi3LogMessageCallback, if it gave one. */
static void fmil3_log(const fmil_instance_t *c, fmil_status_t st, const char *cat, const char *msg)
{
    fmi3LogMessageCallback cb = (fmi3LogMessageCallback)c->callback;
    if (cb) {
        cb(c->env, fmil3_status(st), cat, msg);
    }
}

/* ---------------------------------------------------------------- instances */

const char *fmi3GetVersion(void)
{
    return fmi3Version;
}

fmi3Instance fmi3InstantiateCoSimulation(fmi3String instanceName, fmi3String instantiationToken,
                                         fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                         fmi3Boolean eventModeUsed, fmi3Boolean earlyReturnAllowed,
                                         const fmi3ValueReference requiredIntermediateVariables[],
                                         size_t nRequiredIntermediateVariables,
                                         fmi3InstanceEnvironment instanceEnvironment, fmi3LogMessageCallback logMessage,
                                         fmi3IntermediateUpdateCallback intermediateUpdate)
{
    const char *why = NULL;
    (void)visible, (void)requiredIntermediateVariables, (void)intermediateUpdate;
    if (!instantiationToken || strcmp(instantiationToken, FMIL_INSTANTIATION_TOKEN) != 0) {
        why = FMIL_MODEL_IDENTIFIER ": instantiationToken does not match modelDescription.xml";
    } else if (eventModeUsed || earlyReturnAllowed || nRequiredIntermediateVariables != 0u) {
        why = FMIL_MODEL_IDENTIFIER ": event mode, early return and intermediate variables are not supported";
    }
    if (why) {
        if (logMessage) {
            logMessage(instanceEnvironment, fmi3Error, "logStatusError", why);
        }
        return NULL;
    }
    return fmil_new(instanceName, resourcePath, loggingOn, "fmi3", fmil3_log, instanceEnvironment,
                    (void (*)(void))logMessage);
}

/* The refusal of an interface type the FMUs do not implement. */
static fmi3Instance fmil3_cosim_only(fmi3InstanceEnvironment env, fmi3LogMessageCallback log)
{
    if (log) {
        log(env, fmi3Error, "logStatusError", FMIL_MODEL_IDENTIFIER " is co-simulation only");
    }
    return NULL;
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String instantiationToken,
                                          fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                          fmi3InstanceEnvironment instanceEnvironment,
                                          fmi3LogMessageCallback logMessage)
{
    (void)instanceName, (void)instantiationToken, (void)resourcePath, (void)visible, (void)loggingOn;
    return fmil3_cosim_only(instanceEnvironment, logMessage);
}

fmi3Instance fmi3InstantiateScheduledExecution(fmi3String instanceName, fmi3String instantiationToken,
                                               fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                               fmi3InstanceEnvironment instanceEnvironment,
                                               fmi3LogMessageCallback logMessage, fmi3ClockUpdateCallback clockUpdate,
                                               fmi3LockPreemptionCallback lockPreemption,
                                               fmi3UnlockPreemptionCallback unlockPreemption)
{
    (void)instanceName, (void)instantiationToken, (void)resourcePath, (void)visible, (void)loggingOn;
    (void)clockUpdate, (void)lockPreemption, (void)unlockPreemption;
    return fmil3_cosim_only(instanceEnvironment, logMessage);
}

void fmi3FreeInstance(fmi3Instance instance)
{
    fmil_free((fmil_instance_t *)instance);
}

fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn, size_t nCategories,
                               const fmi3String categories[])
{
    return fmil3_status(fmil_set_debug_logging((fmil_instance_t *)instance, loggingOn, nCategories, categories));
}

fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean toleranceDefined, fmi3Float64 tolerance,
                                       fmi3Float64 startTime, fmi3Boolean stopTimeDefined, fmi3Float64 stopTime)
{
    (void)toleranceDefined, (void)tolerance, (void)stopTimeDefined, (void)stopTime;
    return fmil3_status(fmil_enter_init((fmil_instance_t *)instance, startTime));
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance instance)
{
    return fmil3_status(fmil_exit_init((fmil_instance_t *)instance));
}

fmi3Status fmi3Terminate(fmi3Instance instance)
{
    return fmil3_status(fmil_terminate((fmil_instance_t *)instance));
}

fmi3Status fmi3Reset(fmi3Instance instance)
{
    return fmil3_status(fmil_reset((fmil_instance_t *)instance));
}

/* ---------------------------------------------------------------- get / set */

/* fmi3Get<T> / fmi3Set<T> of a scalar type the layer stores (FMIL type LT). */
#define FMIL3_SCALAR(T, CT, LT)                                                                                        \
    fmi3Status fmi3Get##T(fmi3Instance instance, const fmi3ValueReference vrs[], size_t nvr, CT values[], size_t nv)   \
    {                                                                                                                  \
        return fmil3_status(fmil_get((fmil_instance_t *)instance, vrs, nvr, values, nv, LT, "fmi3Get" #T));            \
    }                                                                                                                  \
    fmi3Status fmi3Set##T(fmi3Instance instance, const fmi3ValueReference vrs[], size_t nvr, const CT values[],        \
                          size_t nv)                                                                                   \
    {                                                                                                                  \
        return fmil3_status(fmil_set((fmil_instance_t *)instance, vrs, nvr, values, nv, LT, "fmi3Set" #T));            \
    }
FMIL3_SCALAR(Float64, fmi3Float64, FMIL_F64)
FMIL3_SCALAR(Int32, fmi3Int32, FMIL_I32)
FMIL3_SCALAR(UInt32, fmi3UInt32, FMIL_U32)
FMIL3_SCALAR(UInt64, fmi3UInt64, FMIL_U64)

/* fmi3Get<T> / fmi3Set<T> of a type no model has: an error for any value reference. */
#define FMIL3_NO_TYPE(T, CT)                                                                                           \
    fmi3Status fmi3Get##T(fmi3Instance instance, const fmi3ValueReference vrs[], size_t nvr, CT values[], size_t nv)   \
    {                                                                                                                  \
        (void)vrs, (void)values, (void)nv;                                                                             \
        return fmil3_status(fmil_no_values((fmil_instance_t *)instance, nvr, "fmi3Get" #T));                           \
    }                                                                                                                  \
    fmi3Status fmi3Set##T(fmi3Instance instance, const fmi3ValueReference vrs[], size_t nvr, const CT values[],        \
                          size_t nv)                                                                                   \
    {                                                                                                                  \
        (void)vrs, (void)values, (void)nv;                                                                             \
        return fmil3_status(fmil_no_values((fmil_instance_t *)instance, nvr, "fmi3Set" #T));                           \
    }
FMIL3_NO_TYPE(Float32, fmi3Float32)
FMIL3_NO_TYPE(Int8, fmi3Int8)
FMIL3_NO_TYPE(UInt8, fmi3UInt8)
FMIL3_NO_TYPE(Int16, fmi3Int16)
FMIL3_NO_TYPE(UInt16, fmi3UInt16)
FMIL3_NO_TYPE(Int64, fmi3Int64)
FMIL3_NO_TYPE(Boolean, fmi3Boolean)

fmi3Status fmi3GetString(fmi3Instance instance, const fmi3ValueReference vrs[], size_t nvr, fmi3String values[],
                         size_t nv)
{
    return fmil3_status(fmil_get_strings((fmil_instance_t *)instance, vrs, nvr, values, nv, "fmi3GetString"));
}

fmi3Status fmi3SetString(fmi3Instance instance, const fmi3ValueReference vrs[], size_t nvr, const fmi3String values[],
                         size_t nv)
{
    return fmil3_status(fmil_set_strings((fmil_instance_t *)instance, vrs, nvr, values, nv, "fmi3SetString"));
}

fmi3Status fmi3GetBinary(fmi3Instance instance, const fmi3ValueReference vrs[], size_t nvr, size_t valueSizes[],
                         fmi3Binary values[], size_t nv)
{
    return fmil3_status(
        fmil_get_binaries((fmil_instance_t *)instance, vrs, nvr, valueSizes, values, nv, "fmi3GetBinary"));
}

fmi3Status fmi3SetBinary(fmi3Instance instance, const fmi3ValueReference vrs[], size_t nvr, const size_t valueSizes[],
                         const fmi3Binary values[], size_t nv)
{
    return fmil3_status(
        fmil_set_binaries((fmil_instance_t *)instance, vrs, nvr, valueSizes, values, nv, "fmi3SetBinary"));
}

fmi3Status fmi3GetClock(fmi3Instance instance, const fmi3ValueReference vrs[], size_t nvr, fmi3Clock values[])
{
    (void)vrs, (void)values;
    return fmil3_status(fmil_no_values((fmil_instance_t *)instance, nvr, "fmi3GetClock"));
}

fmi3Status fmi3SetClock(fmi3Instance instance, const fmi3ValueReference vrs[], size_t nvr, const fmi3Clock values[])
{
    (void)vrs, (void)values;
    return fmil3_status(fmil_no_values((fmil_instance_t *)instance, nvr, "fmi3SetClock"));
}

/* ---------------------------------------------------------------- co-simulation */

fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 currentCommunicationPoint, fmi3Float64 communicationStepSize,
                      fmi3Boolean noSetFMUStatePriorToCurrentPoint, fmi3Boolean *eventHandlingNeeded,
                      fmi3Boolean *terminateSimulation, fmi3Boolean *earlyReturn, fmi3Float64 *lastSuccessfulTime)
{
    fmil_instance_t *c = (fmil_instance_t *)instance;
    fmil_status_t st;
    (void)noSetFMUStatePriorToCurrentPoint;
    st = fmil_do_step(c, currentCommunicationPoint, communicationStepSize);
    if (eventHandlingNeeded) {
        *eventHandlingNeeded = fmi3False;
    }
    if (terminateSimulation) {
        *terminateSimulation = fmi3False;
    }
    if (earlyReturn) {
        *earlyReturn = fmi3False;
    }
    if (lastSuccessfulTime && c) {
        *lastSuccessfulTime = c->time;
    }
    return fmil3_status(st);
}

/* ---------------------------------------------------------------- not supported */

#define FMIL3_UNSUPPORTED(name) fmil3_status(fmil_unsupported((fmil_instance_t *)instance, name))

fmi3Status fmi3EnterEventMode(fmi3Instance instance)
{
    return FMIL3_UNSUPPORTED("fmi3EnterEventMode");
}
fmi3Status fmi3EnterStepMode(fmi3Instance instance)
{
    return FMIL3_UNSUPPORTED("fmi3EnterStepMode (no event mode)");
}
fmi3Status fmi3EnterConfigurationMode(fmi3Instance instance)
{
    return FMIL3_UNSUPPORTED("fmi3EnterConfigurationMode");
}
fmi3Status fmi3ExitConfigurationMode(fmi3Instance instance)
{
    return FMIL3_UNSUPPORTED("fmi3ExitConfigurationMode");
}
fmi3Status fmi3EvaluateDiscreteStates(fmi3Instance instance)
{
    return FMIL3_UNSUPPORTED("fmi3EvaluateDiscreteStates");
}
fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance instance)
{
    return FMIL3_UNSUPPORTED("fmi3EnterContinuousTimeMode");
}

fmi3Status fmi3GetNumberOfVariableDependencies(fmi3Instance instance, fmi3ValueReference vr, size_t *n)
{
    (void)vr, (void)n;
    return FMIL3_UNSUPPORTED("fmi3GetNumberOfVariableDependencies");
}

fmi3Status fmi3GetVariableDependencies(fmi3Instance instance, fmi3ValueReference dependent,
                                       size_t elementIndicesOfDependent[], fmi3ValueReference independents[],
                                       size_t elementIndicesOfIndependents[], fmi3DependencyKind dependencyKinds[],
                                       size_t nDependencies)
{
    (void)dependent, (void)elementIndicesOfDependent, (void)independents, (void)elementIndicesOfIndependents;
    (void)dependencyKinds, (void)nDependencies;
    return FMIL3_UNSUPPORTED("fmi3GetVariableDependencies");
}

fmi3Status fmi3GetFMUState(fmi3Instance instance, fmi3FMUState *s)
{
    (void)s;
    return FMIL3_UNSUPPORTED("fmi3GetFMUState");
}

fmi3Status fmi3SetFMUState(fmi3Instance instance, fmi3FMUState s)
{
    (void)s;
    return FMIL3_UNSUPPORTED("fmi3SetFMUState");
}

fmi3Status fmi3FreeFMUState(fmi3Instance instance, fmi3FMUState *s)
{
    (void)s;
    return FMIL3_UNSUPPORTED("fmi3FreeFMUState");
}

fmi3Status fmi3SerializedFMUStateSize(fmi3Instance instance, fmi3FMUState s, size_t *size)
{
    (void)s, (void)size;
    return FMIL3_UNSUPPORTED("fmi3SerializedFMUStateSize");
}

fmi3Status fmi3SerializeFMUState(fmi3Instance instance, fmi3FMUState s, fmi3Byte bytes[], size_t size)
{
    (void)s, (void)bytes, (void)size;
    return FMIL3_UNSUPPORTED("fmi3SerializeFMUState");
}

fmi3Status fmi3DeserializeFMUState(fmi3Instance instance, const fmi3Byte bytes[], size_t size, fmi3FMUState *s)
{
    (void)s, (void)bytes, (void)size;
    return FMIL3_UNSUPPORTED("fmi3DeserializeFMUState");
}

fmi3Status fmi3GetDirectionalDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns,
                                        const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[],
                                        size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity)
{
    (void)unknowns, (void)nUnknowns, (void)knowns, (void)nKnowns, (void)seed, (void)nSeed, (void)sensitivity;
    (void)nSensitivity;
    return FMIL3_UNSUPPORTED("fmi3GetDirectionalDerivative");
}

fmi3Status fmi3GetAdjointDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns,
                                    const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[],
                                    size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity)
{
    (void)unknowns, (void)nUnknowns, (void)knowns, (void)nKnowns, (void)seed, (void)nSeed, (void)sensitivity;
    (void)nSensitivity;
    return FMIL3_UNSUPPORTED("fmi3GetAdjointDerivative");
}

fmi3Status fmi3GetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference vrs[], size_t nvr,
                                  fmi3Float64 intervals[], fmi3IntervalQualifier qualifiers[])
{
    (void)vrs, (void)nvr, (void)intervals, (void)qualifiers;
    return FMIL3_UNSUPPORTED("fmi3GetIntervalDecimal");
}

fmi3Status fmi3GetIntervalFraction(fmi3Instance instance, const fmi3ValueReference vrs[], size_t nvr,
                                   fmi3UInt64 counters[], fmi3UInt64 resolutions[], fmi3IntervalQualifier qualifiers[])
{
    (void)vrs, (void)nvr, (void)counters, (void)resolutions, (void)qualifiers;
    return FMIL3_UNSUPPORTED("fmi3GetIntervalFraction");
}

fmi3Status fmi3GetShiftDecimal(fmi3Instance instance, const fmi3ValueReference vrs[], size_t nvr, fmi3Float64 shifts[])
{
    (void)vrs, (void)nvr, (void)shifts;
    return FMIL3_UNSUPPORTED("fmi3GetShiftDecimal");
}

fmi3Status fmi3GetShiftFraction(fmi3Instance instance, const fmi3ValueReference vrs[], size_t nvr,
                                fmi3UInt64 counters[], fmi3UInt64 resolutions[])
{
    (void)vrs, (void)nvr, (void)counters, (void)resolutions;
    return FMIL3_UNSUPPORTED("fmi3GetShiftFraction");
}

fmi3Status fmi3SetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference vrs[], size_t nvr,
                                  const fmi3Float64 intervals[])
{
    (void)vrs, (void)nvr, (void)intervals;
    return FMIL3_UNSUPPORTED("fmi3SetIntervalDecimal");
}

fmi3Status fmi3SetIntervalFraction(fmi3Instance instance, const fmi3ValueReference vrs[], size_t nvr,
                                   const fmi3UInt64 counters[], const fmi3UInt64 resolutions[])
{
    (void)vrs, (void)nvr, (void)counters, (void)resolutions;
    return FMIL3_UNSUPPORTED("fmi3SetIntervalFraction");
}

fmi3Status fmi3SetShiftDecimal(fmi3Instance instance, const fmi3ValueReference vrs[], size_t nvr,
                               const fmi3Float64 shifts[])
{
    (void)vrs, (void)nvr, (void)shifts;
    return FMIL3_UNSUPPORTED("fmi3SetShiftDecimal");
}

fmi3Status fmi3SetShiftFraction(fmi3Instance instance, const fmi3ValueReference vrs[], size_t nvr,
                                const fmi3UInt64 counters[], const fmi3UInt64 resolutions[])
{
    (void)vrs, (void)nvr, (void)counters, (void)resolutions;
    return FMIL3_UNSUPPORTED("fmi3SetShiftFraction");
}

fmi3Status fmi3UpdateDiscreteStates(fmi3Instance instance, fmi3Boolean *discreteStatesNeedUpdate,
                                    fmi3Boolean *terminateSimulation, fmi3Boolean *nominalsOfContinuousStatesChanged,
                                    fmi3Boolean *valuesOfContinuousStatesChanged, fmi3Boolean *nextEventTimeDefined,
                                    fmi3Float64 *nextEventTime)
{
    (void)discreteStatesNeedUpdate, (void)terminateSimulation, (void)nominalsOfContinuousStatesChanged;
    (void)valuesOfContinuousStatesChanged, (void)nextEventTimeDefined, (void)nextEventTime;
    return FMIL3_UNSUPPORTED("fmi3UpdateDiscreteStates");
}

fmi3Status fmi3CompletedIntegratorStep(fmi3Instance instance, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi3Boolean *enterEventMode, fmi3Boolean *terminateSimulation)
{
    (void)noSetFMUStatePriorToCurrentPoint, (void)enterEventMode, (void)terminateSimulation;
    return FMIL3_UNSUPPORTED("fmi3CompletedIntegratorStep");
}

fmi3Status fmi3SetTime(fmi3Instance instance, fmi3Float64 time)
{
    (void)time;
    return FMIL3_UNSUPPORTED("fmi3SetTime");
}

fmi3Status fmi3SetContinuousStates(fmi3Instance instance, const fmi3Float64 x[], size_t nx)
{
    (void)x, (void)nx;
    return FMIL3_UNSUPPORTED("fmi3SetContinuousStates");
}

fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance instance, fmi3Float64 derivatives[], size_t nx)
{
    (void)derivatives, (void)nx;
    return FMIL3_UNSUPPORTED("fmi3GetContinuousStateDerivatives");
}

fmi3Status fmi3GetEventIndicators(fmi3Instance instance, fmi3Float64 eventIndicators[], size_t ni)
{
    (void)eventIndicators, (void)ni;
    return FMIL3_UNSUPPORTED("fmi3GetEventIndicators");
}

fmi3Status fmi3GetContinuousStates(fmi3Instance instance, fmi3Float64 x[], size_t nx)
{
    (void)x, (void)nx;
    return FMIL3_UNSUPPORTED("fmi3GetContinuousStates");
}

fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance instance, fmi3Float64 nominals[], size_t nx)
{
    (void)nominals, (void)nx;
    return FMIL3_UNSUPPORTED("fmi3GetNominalsOfContinuousStates");
}

fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance instance, size_t *n)
{
    (void)n;
    return FMIL3_UNSUPPORTED("fmi3GetNumberOfEventIndicators");
}

fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance instance, size_t *n)
{
    (void)n;
    return FMIL3_UNSUPPORTED("fmi3GetNumberOfContinuousStates");
}

fmi3Status fmi3GetOutputDerivatives(fmi3Instance instance, const fmi3ValueReference vrs[], size_t nvr,
                                    const fmi3Int32 orders[], fmi3Float64 values[], size_t nv)
{
    (void)vrs, (void)nvr, (void)orders, (void)values, (void)nv;
    return FMIL3_UNSUPPORTED("fmi3GetOutputDerivatives");
}

fmi3Status fmi3ActivateModelPartition(fmi3Instance instance, fmi3ValueReference clockReference,
                                      fmi3Float64 activationTime)
{
    (void)clockReference, (void)activationTime;
    return FMIL3_UNSUPPORTED("fmi3ActivateModelPartition");
}
