/* fmil_fmi2.c: the FMI 2.0 co-simulation entry points of the layer (fmil.h), for importers
 * that only know FMI 2. Float64 -> Real, Int32 -> Integer, String as is; a model's UInt32,
 * UInt64 and Binary variables have no FMI 2 type (an FMU built for FMI 2 has none).
 * Model exchange, FMU state and derivatives: refused with fmi2Error and a message. */
#include <string.h>

#include "fmi2Functions.h" /* exports the fmi2 functions (visibility default) */
#include "fmil.h"

/* The fmi2Status of a layer result. */
static fmi2Status fmil2_status(fmil_status_t st)
{
    return st == FMIL_OK ? fmi2OK : st == FMIL_WARNING ? fmi2Warning : fmi2Error;
}

/* fmil_log_fn: passes msg to the importer's fmi2CallbackLogger, if it gave one. */
static void fmil2_log(const fmil_instance_t *c, fmil_status_t st, const char *cat, const char *msg)
{
    fmi2CallbackLogger cb = (fmi2CallbackLogger)c->callback;
    if (cb) {
        cb(c->env, c->name, fmil2_status(st), cat, "%s", msg);
    }
}

/* ---------------------------------------------------------------- common */

const char *fmi2GetTypesPlatform(void)
{
    return fmi2TypesPlatform;
}

const char *fmi2GetVersion(void)
{
    return fmi2Version;
}

fmi2Status fmi2SetDebugLogging(fmi2Component comp, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[])
{
    return fmil2_status(fmil_set_debug_logging((fmil_instance_t *)comp, loggingOn, nCategories, categories));
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn)
{
    const char *why = NULL, *resources = fmuResourceLocation;
    (void)visible;
    if (fmuType != fmi2CoSimulation) {
        why = FMIL_MODEL_IDENTIFIER " is co-simulation only";
    } else if (!fmuGUID || strcmp(fmuGUID, FMIL_INSTANTIATION_TOKEN) != 0) {
        why = FMIL_MODEL_IDENTIFIER ": guid does not match modelDescription.xml";
    }
    if (why) {
        if (functions && functions->logger) {
            functions->logger(functions->componentEnvironment, instanceName, fmi2Error, "logStatusError", "%s", why);
        }
        return NULL;
    }
    if (resources && strncmp(resources, "file://", 7) == 0) {
        resources += 7; /* a file URI: file:///abs/path -> /abs/path */
    }
    return fmil_new(instanceName, resources, loggingOn, "fmi2", fmil2_log,
                    functions ? functions->componentEnvironment : NULL,
                    functions ? (void (*)(void))functions->logger : NULL);
}

void fmi2FreeInstance(fmi2Component comp)
{
    fmil_free((fmil_instance_t *)comp);
}

fmi2Status fmi2SetupExperiment(fmi2Component comp, fmi2Boolean toleranceDefined, fmi2Real tolerance, fmi2Real startTime,
                               fmi2Boolean stopTimeDefined, fmi2Real stopTime)
{
    fmil_instance_t *c = (fmil_instance_t *)comp;
    (void)toleranceDefined, (void)tolerance, (void)stopTimeDefined, (void)stopTime;
    if (fmil_allowed(c, FMIL_SETUP_EXPERIMENT)) {
        return fmi2Error;
    }
    c->time = startTime; /* taken over by EnterInitializationMode */
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component comp)
{
    fmil_instance_t *c = (fmil_instance_t *)comp;
    /* the start time: SetupExperiment's, else 0 s (instantiation and Reset set it) */
    return fmil2_status(fmil_enter_init(c, c ? c->time : 0.0));
}

fmi2Status fmi2ExitInitializationMode(fmi2Component comp)
{
    return fmil2_status(fmil_exit_init((fmil_instance_t *)comp));
}

fmi2Status fmi2Terminate(fmi2Component comp)
{
    return fmil2_status(fmil_terminate((fmil_instance_t *)comp));
}

fmi2Status fmi2Reset(fmi2Component comp)
{
    return fmil2_status(fmil_reset((fmil_instance_t *)comp));
}

/* ---------------------------------------------------------------- get / set */

fmi2Status fmi2GetReal(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[])
{
    return fmil2_status(fmil_get((fmil_instance_t *)comp, vr, nvr, value, nvr, FMIL_F64, "fmi2GetReal"));
}

fmi2Status fmi2SetReal(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[])
{
    return fmil2_status(fmil_set((fmil_instance_t *)comp, vr, nvr, value, nvr, FMIL_F64, "fmi2SetReal"));
}

fmi2Status fmi2GetInteger(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, fmi2Integer value[])
{
    return fmil2_status(fmil_get((fmil_instance_t *)comp, vr, nvr, value, nvr, FMIL_I32, "fmi2GetInteger"));
}

fmi2Status fmi2SetInteger(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, const fmi2Integer value[])
{
    return fmil2_status(fmil_set((fmil_instance_t *)comp, vr, nvr, value, nvr, FMIL_I32, "fmi2SetInteger"));
}

fmi2Status fmi2GetString(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, fmi2String value[])
{
    return fmil2_status(fmil_get_strings((fmil_instance_t *)comp, vr, nvr, value, nvr, "fmi2GetString"));
}

fmi2Status fmi2SetString(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, const fmi2String value[])
{
    return fmil2_status(fmil_set_strings((fmil_instance_t *)comp, vr, nvr, value, nvr, "fmi2SetString"));
}

fmi2Status fmi2GetBoolean(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, fmi2Boolean value[])
{
    (void)vr, (void)value;
    return fmil2_status(fmil_no_values((fmil_instance_t *)comp, nvr, "fmi2GetBoolean"));
}

fmi2Status fmi2SetBoolean(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, const fmi2Boolean value[])
{
    (void)vr, (void)value;
    return fmil2_status(fmil_no_values((fmil_instance_t *)comp, nvr, "fmi2SetBoolean"));
}

/* ---------------------------------------------------------------- co-simulation */

fmi2Status fmi2DoStep(fmi2Component comp, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint)
{
    (void)noSetFMUStatePriorToCurrentPoint;
    return fmil2_status(fmil_do_step((fmil_instance_t *)comp, currentCommunicationPoint, communicationStepSize));
}

fmi2Status fmi2CancelStep(fmi2Component comp)
{
    fmil_log((fmil_instance_t *)comp, FMIL_ERROR, "fmi2CancelStep: doStep never runs asynchronously");
    return fmi2Error;
}

/* Whether a status may be asked for in comp's state (logs if not) and s is kind, the one
 * kind the getter answers. */
static int fmil2_status_ok(fmi2Component comp, fmi2StatusKind s, fmi2StatusKind kind)
{
    return fmil_allowed((fmil_instance_t *)comp, FMIL_GET_STATUS) == FMIL_OK && s == kind;
}

fmi2Status fmi2GetStatus(fmi2Component comp, const fmi2StatusKind s, fmi2Status *value)
{
    if (!fmil2_status_ok(comp, s, fmi2DoStepStatus)) {
        return fmi2Error;
    }
    *value = fmi2OK;
    return fmi2OK;
}

fmi2Status fmi2GetRealStatus(fmi2Component comp, const fmi2StatusKind s, fmi2Real *value)
{
    if (!fmil2_status_ok(comp, s, fmi2LastSuccessfulTime)) {
        return fmi2Error;
    }
    *value = ((fmil_instance_t *)comp)->time;
    return fmi2OK;
}

fmi2Status fmi2GetIntegerStatus(fmi2Component comp, const fmi2StatusKind s, fmi2Integer *value)
{
    (void)s, (void)value;
    fmil_log((fmil_instance_t *)comp, FMIL_ERROR, "fmi2GetIntegerStatus: no integer status");
    return fmi2Error;
}

fmi2Status fmi2GetBooleanStatus(fmi2Component comp, const fmi2StatusKind s, fmi2Boolean *value)
{
    if (!fmil2_status_ok(comp, s, fmi2Terminated)) {
        return fmi2Error;
    }
    *value = fmi2False;
    return fmi2OK;
}

fmi2Status fmi2GetStringStatus(fmi2Component comp, const fmi2StatusKind s, fmi2String *value)
{
    (void)s, (void)value;
    fmil_log((fmil_instance_t *)comp, FMIL_ERROR, "fmi2GetStringStatus: no string status");
    return fmi2Error;
}

/* ---------------------------------------------------------------- not supported */

#define FMIL2_UNSUPPORTED(name) fmil2_status(fmil_unsupported((fmil_instance_t *)comp, name))

fmi2Status fmi2GetFMUstate(fmi2Component comp, fmi2FMUstate *FMUstate)
{
    (void)FMUstate;
    return FMIL2_UNSUPPORTED("fmi2GetFMUstate");
}

fmi2Status fmi2SetFMUstate(fmi2Component comp, fmi2FMUstate FMUstate)
{
    (void)FMUstate;
    return FMIL2_UNSUPPORTED("fmi2SetFMUstate");
}

fmi2Status fmi2FreeFMUstate(fmi2Component comp, fmi2FMUstate *FMUstate)
{
    (void)FMUstate;
    return FMIL2_UNSUPPORTED("fmi2FreeFMUstate");
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component comp, fmi2FMUstate FMUstate, size_t *size)
{
    (void)FMUstate, (void)size;
    return FMIL2_UNSUPPORTED("fmi2SerializedFMUstateSize");
}

fmi2Status fmi2SerializeFMUstate(fmi2Component comp, fmi2FMUstate FMUstate, fmi2Byte serializedState[], size_t size)
{
    (void)FMUstate, (void)serializedState, (void)size;
    return FMIL2_UNSUPPORTED("fmi2SerializeFMUstate");
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component comp, const fmi2Byte serializedState[], size_t size,
                                   fmi2FMUstate *FMUstate)
{
    (void)serializedState, (void)size, (void)FMUstate;
    return FMIL2_UNSUPPORTED("fmi2DeSerializeFMUstate");
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component comp, const fmi2ValueReference vUnknown_ref[], size_t nUnknown,
                                        const fmi2ValueReference vKnown_ref[], size_t nKnown, const fmi2Real dvKnown[],
                                        fmi2Real dvUnknown[])
{
    (void)vUnknown_ref, (void)nUnknown, (void)vKnown_ref, (void)nKnown, (void)dvKnown, (void)dvUnknown;
    return FMIL2_UNSUPPORTED("fmi2GetDirectionalDerivative");
}

fmi2Status fmi2SetRealInputDerivatives(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[])
{
    (void)vr, (void)nvr, (void)order, (void)value;
    return FMIL2_UNSUPPORTED("fmi2SetRealInputDerivatives");
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[])
{
    (void)vr, (void)nvr, (void)order, (void)value;
    return FMIL2_UNSUPPORTED("fmi2GetRealOutputDerivatives");
}
