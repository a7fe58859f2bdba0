/* plant_fmi2.c: FMI 2.0 co-simulation wrapper of the plant model (modelIdentifier
 * navkit_plant_fmi2), for importers that only know FMI 2. Same model, names and value
 * references as the FMI 3 FMU (Float64 -> Real, Int32 -> Integer).
 *
 * States: Instantiated -> InitializationMode -> StepMode -> Terminated; fmi2Reset goes back
 * to Instantiated with start values. The instance logic (state table, get/set, doStep) is
 * plant_instance.c; this file maps it onto the FMI 2 calls and refuses the rest with
 * fmi2Error. Model exchange, FMU state and derivatives: none.
 */
#include "plant_instance.h"

#include <string.h>

#include "fmi2Functions.h"   /* exports the fmi2 functions (visibility default) */

/* One FMU instance: the shared part plus the FMI 2 start time and callbacks. */
typedef struct {
  npi_t base;                      /* first: an fmi2Component is also an npi_t pointer */
  double start_time;               /* s, from fmi2SetupExperiment */
  fmi2CallbackFunctions cb;
} inst_t;

/* The fmi2Status of a shared call's result. */
static fmi2Status to_fmi2(npi_status_t st) { return st == NPI_OK ? fmi2OK : fmi2Error; }

/* npi_log_fn: passes msg to the importer's fmi2CallbackLogger, if there is one. */
static void log_fmi2(const npi_t *base, npi_status_t st, const char *msg) {
  const inst_t *c = (const inst_t *)base;
  if (c->cb.logger)
    c->cb.logger(c->cb.componentEnvironment, base->name, to_fmi2(st),
                 st == NPI_ERROR ? "logStatusError" : "logEvents", "%s", msg);
}

/* ---------------------------------------------------------------- common */

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }

const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component comp, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[]) {
  (void)nCategories; (void)categories;
  return to_fmi2(npi_set_debug_logging(comp, loggingOn));
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn) {
  (void)fmuResourceLocation; (void)visible;
  const char *why = NULL;
  if (fmuType != fmi2CoSimulation)
    why = "navkit_plant_fmi2 is co-simulation only";
  else if (!fmuGUID || strcmp(fmuGUID, NP_INSTANTIATION_TOKEN) != 0)
    why = "guid does not match modelDescription.xml";
  if (why) {
    if (functions && functions->logger)
      functions->logger(functions->componentEnvironment, instanceName, fmi2Error, "logStatusError", "%s", why);
    return NULL;
  }
  inst_t *c = (inst_t *)npi_new(sizeof *c, instanceName, loggingOn, "fmi2", log_fmi2);
  if (!c) return NULL;
  if (functions) c->cb = *functions;
  return c;
}

void fmi2FreeInstance(fmi2Component comp) { npi_free(comp); }

fmi2Status fmi2SetupExperiment(fmi2Component comp, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
  inst_t *c = comp;
  (void)toleranceDefined; (void)tolerance; (void)stopTimeDefined; (void)stopTime;
  if (npi_allowed(comp, NPI_SETUP_EXPERIMENT)) return fmi2Error;
  c->start_time = startTime;
  return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component comp) {
  inst_t *c = comp;
  if (!c) return fmi2Error;
  return to_fmi2(npi_enter_init(comp, c->start_time));
}

fmi2Status fmi2ExitInitializationMode(fmi2Component comp) { return to_fmi2(npi_exit_init(comp)); }

fmi2Status fmi2Terminate(fmi2Component comp) { return to_fmi2(npi_terminate(comp)); }

fmi2Status fmi2Reset(fmi2Component comp) {
  inst_t *c = comp;
  if (npi_reset(comp)) return fmi2Error;
  c->start_time = 0.0;
  return fmi2OK;
}

/* ---------------------------------------------------------------- get / set */

fmi2Status fmi2GetReal(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]) {
  return to_fmi2(npi_get(comp, vr, nvr, value, nvr, NP_F64, "fmi2GetReal"));
}

fmi2Status fmi2SetReal(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[]) {
  return to_fmi2(npi_set(comp, vr, nvr, value, nvr, NP_F64, "fmi2SetReal"));
}

fmi2Status fmi2GetInteger(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, fmi2Integer value[]) {
  return to_fmi2(npi_get(comp, vr, nvr, value, nvr, NP_I32, "fmi2GetInteger"));
}

fmi2Status fmi2SetInteger(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, const fmi2Integer value[]) {
  return to_fmi2(npi_set(comp, vr, nvr, value, nvr, NP_I32, "fmi2SetInteger"));
}

fmi2Status fmi2GetString(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, fmi2String value[]) {
  return to_fmi2(npi_get_strings(comp, vr, nvr, value, nvr, "fmi2GetString"));
}

fmi2Status fmi2SetString(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, const fmi2String value[]) {
  return to_fmi2(npi_set_strings(comp, vr, nvr, value, nvr, "fmi2SetString"));
}

fmi2Status fmi2GetBoolean(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, fmi2Boolean value[]) {
  (void)vr; (void)value;
  return to_fmi2(npi_no_values(comp, nvr, "fmi2GetBoolean: the model has no Boolean variable"));
}

fmi2Status fmi2SetBoolean(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, const fmi2Boolean value[]) {
  (void)vr; (void)value;
  return to_fmi2(npi_no_values(comp, nvr, "fmi2SetBoolean: the model has no Boolean variable"));
}

/* ---------------------------------------------------------------- co-simulation */

fmi2Status fmi2DoStep(fmi2Component comp, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
  (void)noSetFMUStatePriorToCurrentPoint;
  return to_fmi2(npi_do_step(comp, currentCommunicationPoint, communicationStepSize));
}

fmi2Status fmi2CancelStep(fmi2Component comp) {
  npi_log(comp, NPI_ERROR, "fmi2CancelStep: doStep never runs asynchronously");
  return fmi2Error;
}

/* Whether a status may be asked for in comp's state (logs if not) and s is kind, the one
 * kind the getter answers. */
static int status_ok(fmi2Component comp, fmi2StatusKind s, fmi2StatusKind kind) {
  return npi_allowed(comp, NPI_GET_STATUS) == NPI_OK && s == kind;
}

fmi2Status fmi2GetStatus(fmi2Component comp, const fmi2StatusKind s, fmi2Status *value) {
  if (!status_ok(comp, s, fmi2DoStepStatus)) return fmi2Error;
  *value = fmi2OK;
  return fmi2OK;
}

fmi2Status fmi2GetRealStatus(fmi2Component comp, const fmi2StatusKind s, fmi2Real *value) {
  const npi_t *c = comp;
  if (!status_ok(comp, s, fmi2LastSuccessfulTime)) return fmi2Error;
  *value = c->m.t;
  return fmi2OK;
}

fmi2Status fmi2GetIntegerStatus(fmi2Component comp, const fmi2StatusKind s, fmi2Integer *value) {
  (void)s; (void)value;
  npi_log(comp, NPI_ERROR, "fmi2GetIntegerStatus: no integer status");
  return fmi2Error;
}

fmi2Status fmi2GetBooleanStatus(fmi2Component comp, const fmi2StatusKind s, fmi2Boolean *value) {
  if (!status_ok(comp, s, fmi2Terminated)) return fmi2Error;
  *value = fmi2False;
  return fmi2OK;
}

fmi2Status fmi2GetStringStatus(fmi2Component comp, const fmi2StatusKind s, fmi2String *value) {
  (void)s; (void)value;
  npi_log(comp, NPI_ERROR, "fmi2GetStringStatus: no string status");
  return fmi2Error;
}

/* ---------------------------------------------------------------- not supported */

/* Logs that fn is not supported and returns fmi2Error. */
static fmi2Status unsupported(fmi2Component comp, const char *fn) {
  npi_log(comp, NPI_ERROR, "%s is not supported by navkit_plant_fmi2", fn);
  return fmi2Error;
}

fmi2Status fmi2GetFMUstate(fmi2Component comp, fmi2FMUstate *FMUstate) {
  (void)FMUstate;
  return unsupported(comp, "fmi2GetFMUstate");
}

fmi2Status fmi2SetFMUstate(fmi2Component comp, fmi2FMUstate FMUstate) {
  (void)FMUstate;
  return unsupported(comp, "fmi2SetFMUstate");
}

fmi2Status fmi2FreeFMUstate(fmi2Component comp, fmi2FMUstate *FMUstate) {
  (void)FMUstate;
  return unsupported(comp, "fmi2FreeFMUstate");
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component comp, fmi2FMUstate FMUstate, size_t *size) {
  (void)FMUstate; (void)size;
  return unsupported(comp, "fmi2SerializedFMUstateSize");
}

fmi2Status fmi2SerializeFMUstate(fmi2Component comp, fmi2FMUstate FMUstate, fmi2Byte serializedState[],
                                 size_t size) {
  (void)FMUstate; (void)serializedState; (void)size;
  return unsupported(comp, "fmi2SerializeFMUstate");
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component comp, const fmi2Byte serializedState[], size_t size,
                                   fmi2FMUstate *FMUstate) {
  (void)serializedState; (void)size; (void)FMUstate;
  return unsupported(comp, "fmi2DeSerializeFMUstate");
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component comp, const fmi2ValueReference vUnknown_ref[],
                                        size_t nUnknown, const fmi2ValueReference vKnown_ref[], size_t nKnown,
                                        const fmi2Real dvKnown[], fmi2Real dvUnknown[]) {
  (void)vUnknown_ref; (void)nUnknown; (void)vKnown_ref; (void)nKnown; (void)dvKnown; (void)dvUnknown;
  return unsupported(comp, "fmi2GetDirectionalDerivative");
}

fmi2Status fmi2SetRealInputDerivatives(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[]) {
  (void)vr; (void)nvr; (void)order; (void)value;
  return unsupported(comp, "fmi2SetRealInputDerivatives");
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[]) {
  (void)vr; (void)nvr; (void)order; (void)value;
  return unsupported(comp, "fmi2GetRealOutputDerivatives");
}
