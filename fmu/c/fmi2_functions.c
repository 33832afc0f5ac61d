/*
 * The FMI 2.0 API for Model Exchange and Co-Simulation, written once for every
 * exported model. This file owns the state machine (which call is legal in
 * which mode), the argument checks and the status handling; the model itself
 * is reached only through the contract of model.h.
 *
 * Status policy: a call that returns fmi2Error logs why and puts the instance
 * in its error mode (from which fmi2SetFMUstate, fmi2Reset, fmi2FreeInstance
 * and the getters remain legal); a rejected call changes no value. fmi2Discard
 * (a co-simulation step whose state became non-finite, a status that is not
 * available) keeps the last good state. Non-finite computed values (derivatives,
 * outputs, directional derivatives) have one policy wherever they are read:
 * they are returned as computed, with fmi2Discard and a message.
 *
 * The fmi2Component must be NULL or an instance of this FMU: NULL is refused
 * with fmi2Error; any other pointer (a freed instance, another FMU's) is
 * undefined behaviour, as in FMI 2.0, and is not detected.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "fmi2Functions.h"
#include "instance.h"

/* ------------------------------------------------------- legal modes per call */

#define ALL_MODES (MW_MODE_INSTANTIATED | MW_MODE_INIT | MW_MODE_EVENT | MW_MODE_CONTINUOUS | \
                   MW_MODE_STEP_COMPLETE | MW_MODE_STEP_FAILED | MW_MODE_TERMINATED | MW_MODE_ERROR)
#define AFTER_INIT_MODES (MW_MODE_INIT | MW_MODE_EVENT | MW_MODE_CONTINUOUS | MW_MODE_STEP_COMPLETE | \
                          MW_MODE_STEP_FAILED | MW_MODE_TERMINATED | MW_MODE_ERROR)

#define MODES_SetDebugLogging ALL_MODES
#define MODES_SetupExperiment MW_MODE_INSTANTIATED
#define MODES_EnterInitializationMode MW_MODE_INSTANTIATED
#define MODES_ExitInitializationMode MW_MODE_INIT
#define MODES_Terminate (MW_MODE_EVENT | MW_MODE_CONTINUOUS | MW_MODE_STEP_COMPLETE | MW_MODE_STEP_FAILED)
#define MODES_Reset ALL_MODES
#define MODES_GetValue AFTER_INIT_MODES
#define MODES_SetReal (MW_MODE_INSTANTIATED | MW_MODE_INIT | MW_MODE_EVENT | MW_MODE_CONTINUOUS | MW_MODE_STEP_COMPLETE)
#define MODES_SetOther (MW_MODE_INSTANTIATED | MW_MODE_INIT | MW_MODE_EVENT | MW_MODE_STEP_COMPLETE)
#define MODES_FMUstate ALL_MODES
#define MODES_GetDirectionalDerivative AFTER_INIT_MODES
/* Model Exchange */
#define MODES_EnterEventMode (MW_MODE_EVENT | MW_MODE_CONTINUOUS)
#define MODES_NewDiscreteStates MW_MODE_EVENT
#define MODES_EnterContinuousTimeMode MW_MODE_EVENT
#define MODES_CompletedIntegratorStep MW_MODE_CONTINUOUS
/* FMI 2.0.5 (3.2.3; fmi-standard #394): time moves only in Continuous-Time Mode; Event Mode keeps the time of
   the event (only a model without continuous states, a pure sampled system, may advance it there) */
#define MODES_SetTime MW_MODE_CONTINUOUS
#define MODES_SetContinuousStates MW_MODE_CONTINUOUS
#define MODES_GetDerivatives (MW_MODE_INIT | MW_MODE_EVENT | MW_MODE_CONTINUOUS | MW_MODE_TERMINATED | MW_MODE_ERROR)
#define MODES_GetEventIndicators MODES_GetDerivatives
#define MODES_GetContinuousStates MODES_GetDerivatives
#define MODES_GetNominalsOfContinuousStates (MW_MODE_INSTANTIATED | MODES_GetDerivatives)
/* Co-Simulation */
#define MODES_SetRealInputDerivatives (MW_MODE_INSTANTIATED | MW_MODE_INIT | MW_MODE_STEP_COMPLETE)
#define MODES_GetRealOutputDerivatives (MW_MODE_STEP_COMPLETE | MW_MODE_STEP_FAILED | MW_MODE_TERMINATED | MW_MODE_ERROR)
#define MODES_DoStep MW_MODE_STEP_COMPLETE
#define MODES_CancelStep MW_MODE_STEP_COMPLETE
#define MODES_GetStatus (MW_MODE_STEP_COMPLETE | MW_MODE_STEP_FAILED | MW_MODE_TERMINATED)

#define FOR_ANY MW_FOR_ANY
#define FOR_ME MW_FOR_ME
#define FOR_CS MW_FOR_CS
/* the shared argument checks of instance.c, with this version's status type */
#define fail(inst, fn, what) ((fmi2Status)mw_fail(inst, fn, what))
#define null_arg mw_null_arg
#define wrong_size mw_wrong_size
#define non_finite(inst, fn, what, v, n) ((fmi2Status)mw_non_finite(inst, fn, what, v, n))

static const char *mode_name(unsigned int mode) {
    switch (mode) {
    case MW_MODE_INSTANTIATED: return "instantiated";
    case MW_MODE_INIT: return "initialization mode";
    case MW_MODE_EVENT: return "event mode";
    case MW_MODE_CONTINUOUS: return "continuous-time mode";
    case MW_MODE_STEP_COMPLETE: return "step complete";
    case MW_MODE_STEP_FAILED: return "step failed";
    case MW_MODE_TERMINATED: return "terminated";
    case MW_MODE_ERROR: return "error";
    default: return "unknown";
    }
}

#define ENTER(fn, type, modes)                                 \
    MwInstance *inst = mw_enter(c, "fmi2" #fn, type, modes, mode_name); \
    if (inst == NULL) return fmi2Error

static fmi2Status no_variables_of_type(MwInstance *inst, const char *fn, const char *type_name,
                                       const fmi2ValueReference vr[], size_t nvr, const void *values) {
    char what[160];
    if (nvr == 0) return fmi2OK;
    if (null_arg(inst, fn, "vr[]", vr) || null_arg(inst, fn, "value[]", values)) return fmi2Error;
    snprintf(what, sizeof(what), "unknown value reference %u: the model has no %s variables", vr[0], type_name);
    return fail(inst, fn, what);
}

/* --------------------------------------------------------- common functions */

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }

const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[]) {
    ENTER(SetDebugLogging, FOR_ANY, MODES_SetDebugLogging);
    if (nCategories > 0 && null_arg(inst, "fmi2SetDebugLogging", "categories[]", categories)) return fmi2Error;
    return (fmi2Status)mw_set_logging(inst, "fmi2SetDebugLogging", loggingOn, nCategories, categories);
}

/* The instance's log lines to the importer's fmi2CallbackLogger, whose message is a format string. */
static void log_to_importer(const MwInstance *inst, MwStatus status, const char *category, const char *message) {
    char escaped[2048];
    size_t i, j;
    fmi2CallbackLogger logger = (fmi2CallbackLogger)inst->host.logger;
    for (i = 0, j = 0; message[i] != '\0' && j + 2 < sizeof(escaped); i++) {
        if (message[i] == '%') escaped[j++] = '%'; /* protect every '%' */
        escaped[j++] = message[i];
    }
    escaped[j] = '\0';
    logger(inst->host.env, inst->name, (fmi2Status)status, category, escaped);
}

static void log_before_instance(const fmi2CallbackFunctions *functions, fmi2String name, const char *message) {
    functions->logger(functions->componentEnvironment, name != NULL ? name : "", fmi2Error, "logStatusError",
                      message);
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn) {
    const MwModel *model = mw_model();
    MwInstance *inst;
    MwHost host;
    (void)fmuResourceLocation; /* the model needs no resources */
    (void)visible;

    if (functions == NULL || functions->logger == NULL) {
        /* no logger to report through: say it on stderr, the only channel left */
        fprintf(stderr, "fmi2Instantiate(%.100s): refused: %s is NULL (FMI 2.0 requires a logger)\n",
                instanceName != NULL ? instanceName : "", functions == NULL ? "functions" : "functions->logger");
        return NULL;
    }
    if (functions->allocateMemory == NULL || functions->freeMemory == NULL) {
        log_before_instance(functions, instanceName, "fmi2Instantiate: allocateMemory and freeMemory are required");
        return NULL;
    }
    if (instanceName == NULL || instanceName[0] == '\0') {
        log_before_instance(functions, instanceName, "fmi2Instantiate: instanceName is NULL or empty");
        return NULL;
    }
    if (fmuType != fmi2ModelExchange && fmuType != fmi2CoSimulation) {
        log_before_instance(functions, instanceName, "fmi2Instantiate: fmuType is neither fmi2ModelExchange nor fmi2CoSimulation");
        return NULL;
    }
    if (fmuType == fmi2ModelExchange && model->nd > 0) {
        log_before_instance(functions, instanceName,
                            "fmi2Instantiate: this model has sampled discrete states (a digital controller): it is "
                            "Co-Simulation only, the modelDescription.xml has no ModelExchange");
        return NULL;
    }
    if (fmuGUID == NULL || strcmp(fmuGUID, model->guid) != 0) {
        log_before_instance(functions, instanceName,
                            "fmi2Instantiate: wrong GUID: it does not match the modelDescription.xml of this binary");
        return NULL;
    }
    host.alloc = functions->allocateMemory;
    host.release = functions->freeMemory;
    host.log = log_to_importer;
    host.env = functions->componentEnvironment;
    host.logger = (MwAnyFunction)functions->logger;
    inst = mw_instance_new(model, fmuType == fmi2ModelExchange ? MW_MODEL_EXCHANGE : MW_CO_SIMULATION, instanceName,
                           &host, loggingOn);
    if (inst == NULL) {
        log_before_instance(functions, instanceName, "fmi2Instantiate: out of memory");
        return NULL;
    }
    return (fmi2Component)inst;
}

void fmi2FreeInstance(fmi2Component c) {
    MwInstance *inst = (MwInstance *)c;
    if (inst == NULL) return;
    mw_log(inst, MW_OK, MW_LOG_CALLS, "fmi2FreeInstance");
    mw_instance_free(inst);
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    ENTER(SetupExperiment, FOR_ANY, MODES_SetupExperiment);
    (void)toleranceDefined; /* the integrator is fixed-step; the tolerance is the importer's */
    (void)tolerance;
    if (!isfinite(startTime)) return fail(inst, "fmi2SetupExperiment", "startTime is not finite");
    if (stopTimeDefined && !(stopTime >= startTime))
        return fail(inst, "fmi2SetupExperiment", "stopTime is before startTime or not a number");
    inst->time = startTime;
    inst->last_successful_time = startTime;
    inst->stop_time_defined = stopTimeDefined ? 1 : 0;
    inst->stop_time = stopTimeDefined ? stopTime : 0.0;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    ENTER(EnterInitializationMode, FOR_ANY, MODES_EnterInitializationMode);
    inst->mode = MW_MODE_INIT;
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    const char *problem;
    char what[512];
    ENTER(ExitInitializationMode, FOR_ANY, MODES_ExitInitializationMode);
    problem = mw_exit_initialization(inst, what, sizeof(what));
    return problem == NULL ? fmi2OK : fail(inst, "fmi2ExitInitializationMode", problem);
}

fmi2Status fmi2Terminate(fmi2Component c) {
    ENTER(Terminate, FOR_ANY, MODES_Terminate);
    inst->mode = MW_MODE_TERMINATED;
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component c) {
    ENTER(Reset, FOR_ANY, MODES_Reset);
    mw_set_start_values(inst);
    inst->mode = MW_MODE_INSTANTIATED;
    return fmi2OK;
}

/* ------------------------------------------------------------ get and set */

/* The variable behind vr, or NULL after logging the error. */
static const MwVariable *lookup(MwInstance *inst, const char *fn, fmi2ValueReference vr) {
    char what[96];
    if ((size_t)vr < inst->model->nvars) return &inst->model->variables[vr];
    snprintf(what, sizeof(what), "unknown value reference %u (Real variables are 0..%u)", vr,
             (unsigned int)(inst->model->nvars - 1));
    fail(inst, fn, what);
    return NULL;
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]) {
    size_t i;
    ENTER(GetReal, FOR_ANY, MODES_GetValue);
    if (nvr == 0) return fmi2OK;
    if (null_arg(inst, "fmi2GetReal", "vr[]", vr) || null_arg(inst, "fmi2GetReal", "value[]", value)) return fmi2Error;
    for (i = 0; i < nvr; i++) {
        if (lookup(inst, "fmi2GetReal", vr[i]) == NULL) return fmi2Error;
    }
    for (i = 0; i < nvr; i++) {
        const MwVariable *v = &inst->model->variables[vr[i]];
        if (mw_prepare(inst, v) != 0) return fail(inst, "fmi2GetReal", "the model failed to evaluate");
        value[i] = mw_value(inst, v);
    }
    return non_finite(inst, "fmi2GetReal", "the values", value, nvr);
}

/* Whether variable v may be set in the instance's current mode; logs why not. */
static int settable_now(MwInstance *inst, const MwVariable *v) {
    const char *why = NULL;
    unsigned int mode = inst->mode;
    char what[256];
    switch ((MwSettable)v->settable) {
    case MW_SET_NEVER:
        why = "is calculated by the model and cannot be set";
        break;
    case MW_SET_INITIAL:
        if (!(mode & (MW_MODE_INSTANTIATED | MW_MODE_INIT)))
            why = "is fixed: it can only be set before fmi2ExitInitializationMode";
        break;
    case MW_SET_STATE:
        /* FMI 2.0.5 (3.2.3): in Event Mode only inputs and tunable parameters may be set; a continuous state
           may be set before initialisation ends and in Continuous-Time Mode (FMI 2.0.1) */
        if (!(mode & (MW_MODE_INSTANTIATED | MW_MODE_INIT | MW_MODE_CONTINUOUS)))
            why = "is a continuous state: it can be set before fmi2ExitInitializationMode, or in continuous-time "
                  "mode (Model Exchange), not in event mode";
        break;
    case MW_SET_TUNABLE:
        if (!(mode & (MW_MODE_INSTANTIATED | MW_MODE_INIT | MW_MODE_EVENT | MW_MODE_STEP_COMPLETE)))
            why = "is a tunable parameter: it can be set in event mode (Model Exchange) or between steps (Co-Simulation)";
        break;
    case MW_SET_INPUT:
        break;
    default:
        why = "has a corrupt table entry";
        break;
    }
    if (why == NULL) return 1;
    snprintf(what, sizeof(what), "variable %.60s %s (mode \"%s\")", v->name, why, mode_name(mode));
    fail(inst, "fmi2SetReal", what);
    return 0;
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[]) {
    size_t i;
    char what[256];
    ENTER(SetReal, FOR_ANY, MODES_SetReal);
    if (nvr == 0) return fmi2OK;
    if (null_arg(inst, "fmi2SetReal", "vr[]", vr) || null_arg(inst, "fmi2SetReal", "value[]", value)) return fmi2Error;
    /* check every value first: a rejected call changes nothing */
    for (i = 0; i < nvr; i++) {
        const MwVariable *v = lookup(inst, "fmi2SetReal", vr[i]);
        if (v == NULL || !settable_now(inst, v)) return fmi2Error;
        if (mw_value_problem(v, value[i], what, sizeof(what)) != NULL) return fail(inst, "fmi2SetReal", what);
    }
    for (i = 0; i < nvr; i++) {
        if (mw_assign(inst, &inst->model->variables[vr[i]], value[i]) != 0)
            return fail(inst, "fmi2SetReal", "corrupt variable table");
    }
    return fmi2OK;
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Integer value[]) {
    ENTER(GetInteger, FOR_ANY, MODES_GetValue);
    return no_variables_of_type(inst, "fmi2GetInteger", "Integer", vr, nvr, value);
}

fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Boolean value[]) {
    ENTER(GetBoolean, FOR_ANY, MODES_GetValue);
    return no_variables_of_type(inst, "fmi2GetBoolean", "Boolean", vr, nvr, value);
}

fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2String value[]) {
    ENTER(GetString, FOR_ANY, MODES_GetValue);
    return no_variables_of_type(inst, "fmi2GetString", "String", vr, nvr, value);
}

fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Integer value[]) {
    ENTER(SetInteger, FOR_ANY, MODES_SetOther);
    return no_variables_of_type(inst, "fmi2SetInteger", "Integer", vr, nvr, value);
}

fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Boolean value[]) {
    ENTER(SetBoolean, FOR_ANY, MODES_SetOther);
    return no_variables_of_type(inst, "fmi2SetBoolean", "Boolean", vr, nvr, value);
}

fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2String value[]) {
    ENTER(SetString, FOR_ANY, MODES_SetOther);
    return no_variables_of_type(inst, "fmi2SetString", "String", vr, nvr, value);
}

/* ---------------------------------------------------------------- FMU state */

/* The FMU-state calls: instance.c does the work, a problem is an error with its message. */
static fmi2Status state_call(MwInstance *inst, const char *fn, const char *problem) {
    return problem == NULL ? fmi2OK : fail(inst, fn, problem);
}

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    ENTER(GetFMUstate, FOR_ANY, MODES_FMUstate);
    return state_call(inst, "fmi2GetFMUstate", mw_state_get(inst, (void **)FMUstate));
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate) {
    ENTER(SetFMUstate, FOR_ANY, MODES_FMUstate);
    return state_call(inst, "fmi2SetFMUstate", mw_state_set(inst, FMUstate));
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    ENTER(FreeFMUstate, FOR_ANY, MODES_FMUstate);
    return state_call(inst, "fmi2FreeFMUstate", mw_state_free(inst, (void **)FMUstate));
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate FMUstate, size_t *size) {
    ENTER(SerializedFMUstateSize, FOR_ANY, MODES_FMUstate);
    return state_call(inst, "fmi2SerializedFMUstateSize", mw_state_size(inst, FMUstate, size));
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate, fmi2Byte serializedState[], size_t size) {
    char what[160];
    ENTER(SerializeFMUstate, FOR_ANY, MODES_FMUstate);
    return state_call(inst, "fmi2SerializeFMUstate",
                      mw_state_serialize(inst, FMUstate, (unsigned char *)serializedState, size, "fmi2SerializedFMUstateSize", what,
                                         sizeof(what)));
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[], size_t size, fmi2FMUstate *FMUstate) {
    char what[192];
    ENTER(DeSerializeFMUstate, FOR_ANY, MODES_FMUstate);
    return state_call(inst, "fmi2DeSerializeFMUstate", mw_state_deserialize(inst, (const unsigned char *)serializedState, size,
                                                                     (void **)FMUstate, what, sizeof(what)));
}

/* ----------------------------------------------------- directional derivatives */

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[], size_t nUnknown,
                                        const fmi2ValueReference vKnown_ref[], size_t nKnown,
                                        const fmi2Real dvKnown[], fmi2Real dvUnknown[]) {
    const char *fn = "fmi2GetDirectionalDerivative";
    const MwModel *m;
    size_t i;
    int need_dxdot = 0, need_dy = 0;
    char what[192];
    ENTER(GetDirectionalDerivative, FOR_ANY, MODES_GetDirectionalDerivative);
    m = inst->model;
    if (nUnknown == 0) return fmi2OK;
    if (null_arg(inst, fn, "vUnknown_ref[]", vUnknown_ref) || null_arg(inst, fn, "dvUnknown[]", dvUnknown))
        return fmi2Error;
    if (nKnown > 0 && (null_arg(inst, fn, "vKnown_ref[]", vKnown_ref) || null_arg(inst, fn, "dvKnown[]", dvKnown)))
        return fmi2Error;

    mw_clear_seeds(inst);
    for (i = 0; i < nKnown; i++) {
        const MwVariable *v = lookup(inst, fn, vKnown_ref[i]);
        if (v == NULL) return fmi2Error;
        if (!isfinite(dvKnown[i])) {
            snprintf(what, sizeof(what), "the seed of %.60s is not finite", v->name);
            return fail(inst, fn, what);
        }
        if (mw_seed(inst, v, dvKnown[i], 0) != 0) {
            snprintf(what, sizeof(what), "%.60s cannot be a known: knowns are states, inputs and parameters", v->name);
            return fail(inst, fn, what);
        }
    }
    for (i = 0; i < nUnknown; i++) {
        const MwVariable *v = lookup(inst, fn, vUnknown_ref[i]);
        if (v == NULL) return fmi2Error;
        if (v->kind == MW_KIND_DERIVATIVE) {
            need_dxdot = 1;
        } else if (v->kind == MW_KIND_OUTPUT) {
            need_dy = 1;
        } else if (v->kind != MW_KIND_STATE) {
            snprintf(what, sizeof(what), "%.60s cannot be an unknown: unknowns are derivatives and outputs", v->name);
            return fail(inst, fn, what);
        }
    }
    if (mw_directional(inst, need_dxdot, need_dy) != 0) return fail(inst, fn, "the model failed to evaluate");
    for (i = 0; i < nUnknown; i++) dvUnknown[i] = mw_sensitivity(inst, &m->variables[vUnknown_ref[i]], 0);
    return non_finite(inst, fn, "the directional derivatives", dvUnknown, nUnknown);
}

/* -------------------------------------------------------- Model Exchange */

fmi2Status fmi2EnterEventMode(fmi2Component c) {
    ENTER(EnterEventMode, FOR_ME, MODES_EnterEventMode);
    inst->mode = MW_MODE_EVENT;
    return fmi2OK;
}

fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *eventInfo) {
    int x_changed;
    const char *problem;
    ENTER(NewDiscreteStates, FOR_ME, MODES_NewDiscreteStates);
    if (null_arg(inst, "fmi2NewDiscreteStates", "eventInfo", eventInfo)) return fmi2Error;
    problem = mw_event_update(inst, &x_changed);
    if (problem != NULL) return fail(inst, "fmi2NewDiscreteStates", problem);
    eventInfo->newDiscreteStatesNeeded = fmi2False;
    eventInfo->terminateSimulation = fmi2False;
    eventInfo->nominalsOfContinuousStatesChanged = fmi2False;
    eventInfo->valuesOfContinuousStatesChanged = x_changed ? fmi2True : fmi2False;
    eventInfo->nextEventTimeDefined = fmi2False;
    eventInfo->nextEventTime = 0.0;
    return fmi2OK;
}

fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c) {
    ENTER(EnterContinuousTimeMode, FOR_ME, MODES_EnterContinuousTimeMode);
    inst->mode = MW_MODE_CONTINUOUS;
    return fmi2OK;
}

fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi2Boolean *enterEventMode, fmi2Boolean *terminateSimulation) {
    char what[192];
    ENTER(CompletedIntegratorStep, FOR_ME, MODES_CompletedIntegratorStep);
    (void)noSetFMUStatePriorToCurrentPoint;
    if (mw_past_stop_time(inst, inst->time)) {
        snprintf(what, sizeof(what), "an integrator step completed at t = %.17g, past the stopTime %.17g of "
                 "fmi2SetupExperiment", inst->time, inst->stop_time);
        return fail(inst, "fmi2CompletedIntegratorStep", what);
    }
    if (null_arg(inst, "fmi2CompletedIntegratorStep", "enterEventMode", enterEventMode) ||
        null_arg(inst, "fmi2CompletedIntegratorStep", "terminateSimulation", terminateSimulation))
        return fmi2Error;
    *enterEventMode = fmi2False;
    *terminateSimulation = fmi2False;
    return fmi2OK;
}

fmi2Status fmi2SetTime(fmi2Component c, fmi2Real time) {
    const char *problem;
    char what[192];
    MwInstance *inst = mw_enter(c, "fmi2SetTime", FOR_ME,
                                MODES_SetTime | (c != NULL && mw_model()->nx == 0 ? MW_MODE_EVENT : 0u), mode_name);
    if (inst == NULL) return fmi2Error;
    problem = mw_set_time(inst, time, what, sizeof(what));
    return problem == NULL ? fmi2OK : fail(inst, "fmi2SetTime", problem);
}

fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t nx) {
    const char *fn = "fmi2SetContinuousStates";
    ENTER(SetContinuousStates, FOR_ME, MODES_SetContinuousStates);
    if (wrong_size(inst, fn, "nx", nx, inst->model->nx)) return fmi2Error;
    if (nx == 0) return fmi2OK;
    if (null_arg(inst, fn, "x[]", x)) return fmi2Error;
    if (!mw_all_finite(x, nx)) return fail(inst, fn, "the states are not all finite");
    memcpy(inst->x, x, nx * sizeof(double));
    mw_invalidate(inst);
    return fmi2OK;
}

fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real derivatives[], size_t nx) {
    const char *fn = "fmi2GetDerivatives";
    ENTER(GetDerivatives, FOR_ME, MODES_GetDerivatives);
    if (wrong_size(inst, fn, "nx", nx, inst->model->nx)) return fmi2Error;
    if (nx == 0) return fmi2OK;
    if (null_arg(inst, fn, "derivatives[]", derivatives)) return fmi2Error;
    if (mw_update_derivatives(inst) != 0) return fail(inst, fn, "the model failed to evaluate the derivatives");
    memcpy(derivatives, inst->xdot, nx * sizeof(double));
    return (fmi2Status)mw_check_derivatives(inst, fn, derivatives, nx);
}

fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real eventIndicators[], size_t ni) {
    const char *fn = "fmi2GetEventIndicators";
    ENTER(GetEventIndicators, FOR_ME, MODES_GetEventIndicators);
    if (wrong_size(inst, fn, "ni", ni, inst->model->nz)) return fmi2Error;
    if (ni == 0) return fmi2OK;
    if (null_arg(inst, fn, "eventIndicators[]", eventIndicators)) return fmi2Error;
    if (mw_events(inst, inst->x, eventIndicators) != 0) return fail(inst, fn, "the model failed to evaluate");
    return non_finite(inst, fn, "the event indicators", eventIndicators, ni);
}

fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t nx) {
    const char *fn = "fmi2GetContinuousStates";
    ENTER(GetContinuousStates, FOR_ME, MODES_GetContinuousStates);
    if (wrong_size(inst, fn, "nx", nx, inst->model->nx)) return fmi2Error;
    if (nx == 0) return fmi2OK;
    if (null_arg(inst, fn, "x[]", x)) return fmi2Error;
    memcpy(x, inst->x, nx * sizeof(double));
    return fmi2OK;
}

fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x_nominal[], size_t nx) {
    const char *fn = "fmi2GetNominalsOfContinuousStates";
    ENTER(GetNominalsOfContinuousStates, FOR_ME, MODES_GetNominalsOfContinuousStates);
    if (wrong_size(inst, fn, "nx", nx, inst->model->nx)) return fmi2Error;
    if (nx == 0) return fmi2OK;
    if (null_arg(inst, fn, "x_nominal[]", x_nominal)) return fmi2Error;
    memcpy(x_nominal, inst->model->x_nominal, nx * sizeof(double));
    return fmi2OK;
}

/* --------------------------------------------------------- Co-Simulation */

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[]) {
    ENTER(SetRealInputDerivatives, FOR_CS, MODES_SetRealInputDerivatives);
    (void)vr;
    (void)order;
    (void)value;
    if (nvr == 0) return fmi2OK;
    return fail(inst, "fmi2SetRealInputDerivatives",
                "input derivatives are not supported (canInterpolateInputs=\"false\")");
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[]) {
    ENTER(GetRealOutputDerivatives, FOR_CS, MODES_GetRealOutputDerivatives);
    (void)vr;
    (void)order;
    (void)value;
    if (nvr == 0) return fmi2OK;
    return fail(inst, "fmi2GetRealOutputDerivatives",
                "output derivatives are not supported (maxOutputDerivativeOrder=\"0\")");
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentCommunicationPoint) {
    ENTER(DoStep, FOR_CS, MODES_DoStep);
    (void)noSetFMUStatePriorToCurrentCommunicationPoint;
    return (fmi2Status)mw_do_step(inst, "fmi2DoStep", currentCommunicationPoint, communicationStepSize);
}

fmi2Status fmi2CancelStep(fmi2Component c) {
    ENTER(CancelStep, FOR_CS, MODES_CancelStep);
    return fail(inst, "fmi2CancelStep", "fmi2DoStep is synchronous: there is no step to cancel");
}

static fmi2Status status_unavailable(MwInstance *inst, const char *fn, int kind) {
    mw_log(inst, MW_DISCARD, MW_LOG_DISCARD, "%s: status kind %d is not available from this FMU", fn, kind);
    return fmi2Discard;
}

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value) {
    ENTER(GetStatus, FOR_CS, MODES_GetStatus);
    if (null_arg(inst, "fmi2GetStatus", "value", value)) return fmi2Error;
    return status_unavailable(inst, "fmi2GetStatus", (int)s);
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    ENTER(GetRealStatus, FOR_CS, MODES_GetStatus);
    if (null_arg(inst, "fmi2GetRealStatus", "value", value)) return fmi2Error;
    if (s != fmi2LastSuccessfulTime) return status_unavailable(inst, "fmi2GetRealStatus", (int)s);
    *value = inst->last_successful_time;
    return fmi2OK;
}

fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value) {
    ENTER(GetIntegerStatus, FOR_CS, MODES_GetStatus);
    if (null_arg(inst, "fmi2GetIntegerStatus", "value", value)) return fmi2Error;
    return status_unavailable(inst, "fmi2GetIntegerStatus", (int)s);
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value) {
    ENTER(GetBooleanStatus, FOR_CS, MODES_GetStatus);
    if (null_arg(inst, "fmi2GetBooleanStatus", "value", value)) return fmi2Error;
    if (s != fmi2Terminated) return status_unavailable(inst, "fmi2GetBooleanStatus", (int)s);
    *value = fmi2False;
    return fmi2OK;
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value) {
    ENTER(GetStringStatus, FOR_CS, MODES_GetStatus);
    if (null_arg(inst, "fmi2GetStringStatus", "value", value)) return fmi2Error;
    return status_unavailable(inst, "fmi2GetStringStatus", (int)s);
}
