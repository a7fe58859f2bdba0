/* plant_fmi3.c: FMI 3.0 co-simulation wrapper of the plant model (modelIdentifier navkit_plant).
 *
 * States: Instantiated -> InitializationMode -> StepMode -> Terminated; fmi3Reset goes back
 * to Instantiated with start values. legal[] says which call is allowed in which state;
 * any other call returns fmi3Error. No event mode, no clocks, no FMU state, no ME/SE.
 */
#include "navkit_plant.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi3Functions.h" /* exports the fmi3 functions (visibility default) */

enum { ST_INSTANTIATED = 1, ST_INIT = 2, ST_STEP = 4, ST_TERMINATED = 8 };
#define ST_ANY (ST_INSTANTIATED | ST_INIT | ST_STEP | ST_TERMINATED)

/* The calls that depend on the state. */
typedef enum {
  FN_SET_DEBUG_LOGGING, FN_ENTER_INIT, FN_EXIT_INIT, FN_TERMINATE, FN_RESET,
  FN_GET, FN_SET, FN_DO_STEP, FN_COUNT
} fn_t;

/* Which states each call is legal in. */
static const struct { const char *name; unsigned states; } legal[FN_COUNT] = {
  [FN_SET_DEBUG_LOGGING] = { "fmi3SetDebugLogging", ST_ANY },
  [FN_ENTER_INIT] = { "fmi3EnterInitializationMode", ST_INSTANTIATED },
  [FN_EXIT_INIT] = { "fmi3ExitInitializationMode", ST_INIT },
  [FN_TERMINATE] = { "fmi3Terminate", ST_STEP },
  [FN_RESET] = { "fmi3Reset", ST_ANY },
  [FN_GET] = { "fmi3Get<Type>", ST_INIT | ST_STEP | ST_TERMINATED },
  [FN_SET] = { "fmi3Set<Type>", ST_INSTANTIATED | ST_INIT | ST_STEP },  /* per variable: see can_set */
  [FN_DO_STEP] = { "fmi3DoStep", ST_STEP },
};

/* One FMU instance: the model plus the wrapper's bookkeeping. */
typedef struct {
  np_model_t m;
  unsigned state;
  int dirty;                       /* parameters changed since the model was started */
  int logging;
  char name[128];
  fmi3InstanceEnvironment env;
  fmi3LogMessageCallback log;
} inst_t;

/* Sends a message to the importer's logger (errors always, the rest when logging is on). */
static void logf3(inst_t *c, fmi3Status st, const char *fmt, ...) {
  if (!c->log || (st == fmi3OK && !c->logging)) return;
  char buf[1024];
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(buf, sizeof buf, fmt, ap);
  va_end(ap);
  c->log(c->env, st, st >= fmi3Error ? "logStatusError" : "logEvents", buf);
}

/* fmi3OK if call fn is legal in c's state, else logs and returns fmi3Error. */
static fmi3Status allowed(inst_t *c, fn_t fn) {
  if (!c) return fmi3Error;
  if (legal[fn].states & c->state) return fmi3OK;
  logf3(c, fmi3Error, "%s is not allowed in state %u", legal[fn].name, c->state);
  return fmi3Error;
}

/* Starts the model from the current parameters when they changed (Initialization Mode). */
static fmi3Status ensure_started(inst_t *c) {
  if (!c->dirty) return fmi3OK;
  char err[1024];
  if (np_start(&c->m, c->m.t, err, sizeof err)) {
    logf3(c, fmi3Error, "%s", err);
    return fmi3Error;
  }
  c->dirty = 0;
  return fmi3OK;
}

/* ---------------------------------------------------------------- common */

const char *fmi3GetVersion(void) { return fmi3Version; }

fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn, size_t nCategories,
                               const fmi3String categories[]) {
  inst_t *c = instance;
  (void)nCategories; (void)categories;
  if (allowed(c, FN_SET_DEBUG_LOGGING)) return fmi3Error;
  c->logging = loggingOn;
  return fmi3OK;
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
  inst_t *c = calloc(1, sizeof *c);
  if (!c) return NULL;
  snprintf(c->name, sizeof c->name, "%s", instanceName ? instanceName : "");
  c->env = instanceEnvironment;
  c->log = logMessage;
  c->logging = loggingOn;
  np_set_start_values(&c->m);
  c->state = ST_INSTANTIATED;
  c->dirty = 1;
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

void fmi3FreeInstance(fmi3Instance instance) {
  inst_t *c = instance;
  if (!c) return;
  np_release(&c->m);
  free(c);
}

fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean toleranceDefined, fmi3Float64 tolerance,
                                       fmi3Float64 startTime, fmi3Boolean stopTimeDefined, fmi3Float64 stopTime) {
  inst_t *c = instance;
  (void)toleranceDefined; (void)tolerance; (void)stopTimeDefined; (void)stopTime;
  if (allowed(c, FN_ENTER_INIT)) return fmi3Error;
  c->m.t = startTime;
  c->m.v.time = startTime;
  c->dirty = 1;
  c->state = ST_INIT;
  return fmi3OK;
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance instance) {
  inst_t *c = instance;
  if (allowed(c, FN_EXIT_INIT) || ensure_started(c)) return fmi3Error;
  c->state = ST_STEP;
  return fmi3OK;
}

fmi3Status fmi3EnterEventMode(fmi3Instance instance) {
  inst_t *c = instance;
  if (c) logf3(c, fmi3Error, "fmi3EnterEventMode: event mode is not supported");
  return fmi3Error;
}

fmi3Status fmi3Terminate(fmi3Instance instance) {
  inst_t *c = instance;
  if (allowed(c, FN_TERMINATE)) return fmi3Error;
  c->state = ST_TERMINATED;
  return fmi3OK;
}

fmi3Status fmi3Reset(fmi3Instance instance) {
  inst_t *c = instance;
  if (allowed(c, FN_RESET)) return fmi3Error;
  np_set_start_values(&c->m);
  c->m.t = 0.0;
  c->state = ST_INSTANTIATED;
  c->dirty = 1;
  return fmi3OK;
}

/* ---------------------------------------------------------------- get / set */

/* Checks vr against the table and type; logs and returns NULL when it does not fit. */
static const np_var_info_t *lookup(inst_t *c, fmi3ValueReference vr, np_type_t type, const char *fn) {
  if (vr >= NP_NUM_VARS) {
    logf3(c, fmi3Error, "%s: unknown value reference %u", fn, vr);
    return NULL;
  }
  if (np_vars[vr].type != type) {
    logf3(c, fmi3Error, "%s: variable %s (vr %u) has another type", fn, np_vars[vr].name, vr);
    return NULL;
  }
  return &np_vars[vr];
}

/* Checks that variable vi may be set in c's state: parameters before StepMode, inputs always. */
static int can_set(inst_t *c, const np_var_info_t *vi) {
  if (vi->causality == NP_INPUT) return 1;
  if (vi->causality == NP_PARAMETER && (c->state & (ST_INSTANTIATED | ST_INIT))) {
    c->dirty = 1;
    return 1;
  }
  logf3(c, fmi3Error, "variable %s cannot be set in state %u", vi->name, c->state);
  return 0;
}

/* Copies nvr values of size sz between vals and the model (get != 0: model -> vals). */
static fmi3Status copy_values(inst_t *c, const fmi3ValueReference vr[], size_t nvr, void *vals, size_t nvals,
                         np_type_t type, size_t sz, int get, const char *fn) {
  if (allowed(c, get ? FN_GET : FN_SET)) return fmi3Error;
  if (nvals != nvr) {
    logf3(c, fmi3Error, "%s: nValues %zu != nValueReferences %zu (all variables are scalars)", fn, nvals, nvr);
    return fmi3Error;
  }
  if (get && c->state == ST_INIT && ensure_started(c)) return fmi3Error;
  for (size_t i = 0; i < nvr; i++) {
    const np_var_info_t *vi = lookup(c, vr[i], type, fn);
    if (!vi || (!get && !can_set(c, vi))) return fmi3Error;
    char *field = (char *)&c->m.v + vi->offset;
    if (get)
      memcpy((char *)vals + i * sz, field, sz);
    else
      memcpy(field, (const char *)vals + i * sz, sz);
  }
  if (!get) np_inputs_changed(&c->m);
  return fmi3OK;
}

fmi3Status fmi3GetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                          fmi3Float64 values[], size_t nValues) {
  return copy_values(instance, valueReferences, nValueReferences, values, nValues, NP_F64, sizeof(double), 1, "fmi3GetFloat64");
}

fmi3Status fmi3SetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                          const fmi3Float64 values[], size_t nValues) {
  return copy_values(instance, valueReferences, nValueReferences, (void *)values, nValues, NP_F64, sizeof(double), 0, "fmi3SetFloat64");
}

fmi3Status fmi3GetInt32(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        fmi3Int32 values[], size_t nValues) {
  return copy_values(instance, valueReferences, nValueReferences, values, nValues, NP_I32, sizeof(int32_t), 1, "fmi3GetInt32");
}

fmi3Status fmi3SetInt32(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        const fmi3Int32 values[], size_t nValues) {
  return copy_values(instance, valueReferences, nValueReferences, (void *)values, nValues, NP_I32, sizeof(int32_t), 0, "fmi3SetInt32");
}

fmi3Status fmi3GetString(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         fmi3String values[], size_t nValues) {
  inst_t *c = instance;
  if (allowed(c, FN_GET)) return fmi3Error;
  if (nValues != nValueReferences) return fmi3Error;
  for (size_t i = 0; i < nValueReferences; i++) {
    const np_var_info_t *vi = lookup(c, valueReferences[i], NP_STR, "fmi3GetString");
    if (!vi) return fmi3Error;
    values[i] = (const char *)&c->m.v + vi->offset;
  }
  return fmi3OK;
}

fmi3Status fmi3SetString(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         const fmi3String values[], size_t nValues) {
  inst_t *c = instance;
  if (allowed(c, FN_SET)) return fmi3Error;
  if (nValues != nValueReferences) return fmi3Error;
  for (size_t i = 0; i < nValueReferences; i++) {
    const np_var_info_t *vi = lookup(c, valueReferences[i], NP_STR, "fmi3SetString");
    if (!vi || !can_set(c, vi)) return fmi3Error;
    const char *s = values[i] ? values[i] : "";
    if (strlen(s) >= NP_STR_MAX) {
      logf3(c, fmi3Error, "fmi3SetString: %s is longer than %d bytes", vi->name, NP_STR_MAX - 1);
      return fmi3Error;
    }
    memcpy((char *)&c->m.v + vi->offset, s, strlen(s) + 1);
  }
  return fmi3OK;
}

/* Getters and setters of types the model has none of: any value reference is wrong. */
#define NP_NO_TYPE(T, CT)                                                                                   \
  fmi3Status fmi3Get##T(fmi3Instance instance, const fmi3ValueReference valueReferences[],                  \
                        size_t nValueReferences, CT values[], size_t nValues) {                             \
    (void)valueReferences; (void)values; (void)nValues;                                                     \
    if (nValueReferences == 0) return fmi3OK;                                                               \
    if (instance) logf3(instance, fmi3Error, "fmi3Get" #T ": the model has no variable of this type");      \
    return fmi3Error;                                                                                       \
  }                                                                                                         \
  fmi3Status fmi3Set##T(fmi3Instance instance, const fmi3ValueReference valueReferences[],                  \
                        size_t nValueReferences, const CT values[], size_t nValues) {                       \
    (void)valueReferences; (void)values; (void)nValues;                                                     \
    if (nValueReferences == 0) return fmi3OK;                                                               \
    if (instance) logf3(instance, fmi3Error, "fmi3Set" #T ": the model has no variable of this type");      \
    return fmi3Error;                                                                                       \
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
  if (nValueReferences == 0) return fmi3OK;
  if (instance) logf3(instance, fmi3Error, "fmi3GetClock: the model has no clocks");
  return fmi3Error;
}

fmi3Status fmi3SetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        const fmi3Clock values[]) {
  (void)valueReferences; (void)values;
  if (nValueReferences == 0) return fmi3OK;
  if (instance) logf3(instance, fmi3Error, "fmi3SetClock: the model has no clocks");
  return fmi3Error;
}

fmi3Status fmi3GetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         size_t valueSizes[], fmi3Binary values[], size_t nValues) {
  (void)valueReferences; (void)valueSizes; (void)values; (void)nValues;
  if (nValueReferences == 0) return fmi3OK;
  if (instance) logf3(instance, fmi3Error, "fmi3GetBinary: the model has no Binary variable");
  return fmi3Error;
}

fmi3Status fmi3SetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         const size_t valueSizes[], const fmi3Binary values[], size_t nValues) {
  (void)valueReferences; (void)valueSizes; (void)values; (void)nValues;
  if (nValueReferences == 0) return fmi3OK;
  if (instance) logf3(instance, fmi3Error, "fmi3SetBinary: the model has no Binary variable");
  return fmi3Error;
}

/* ---------------------------------------------------------------- co-simulation */

fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 currentCommunicationPoint,
                      fmi3Float64 communicationStepSize, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                      fmi3Boolean *eventHandlingNeeded, fmi3Boolean *terminateSimulation, fmi3Boolean *earlyReturn,
                      fmi3Float64 *lastSuccessfulTime) {
  inst_t *c = instance;
  (void)noSetFMUStatePriorToCurrentPoint;
  if (allowed(c, FN_DO_STEP)) return fmi3Error;
  double h = communicationStepSize;
  if (!(h > 0.0) || !isfinite(h)) {
    logf3(c, fmi3Error, "fmi3DoStep: communicationStepSize %g must be > 0", h);
    return fmi3Error;
  }
  if (fabs(currentCommunicationPoint - c->m.t) > 1e-9 * (1.0 + fabs(c->m.t))) {
    logf3(c, fmi3Error, "fmi3DoStep: currentCommunicationPoint %.9f != model time %.9f", currentCommunicationPoint, c->m.t);
    return fmi3Error;
  }
  np_step(&c->m, h);
  c->m.t = currentCommunicationPoint + h;   /* the importer's clock: no drift */
  c->m.v.time = c->m.t;
  if (eventHandlingNeeded) *eventHandlingNeeded = fmi3False;
  if (terminateSimulation) *terminateSimulation = fmi3False;
  if (earlyReturn) *earlyReturn = fmi3False;
  if (lastSuccessfulTime) *lastSuccessfulTime = c->m.t;
  return fmi3OK;
}

/* ---------------------------------------------------------------- not supported */

/* Logs that fn is not supported and returns fmi3Error. */
static fmi3Status unsupported(fmi3Instance instance, const char *fn) {
  if (instance) logf3(instance, fmi3Error, "%s is not supported by navkit_plant", fn);
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
