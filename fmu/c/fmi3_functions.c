/*
 * The FMI 3.0 API for Model Exchange and Co-Simulation, written once for every
 * exported model, over the same instance.c and model contract (model.h) as the
 * FMI 2.0 wrapper. This file owns the FMI 3.0 state machine, the argument
 * checks and the mapping of FMI 3.0 variables onto the rows of the variable
 * table: value reference 0 is time, value reference k >= 1 is the array
 * model->arrays[k - 1] (rows first .. first + count - 1; a scalar has count 1).
 *
 * Status policy (as in fmi2_functions.c): a call that returns fmi3Error logs why
 * and puts the instance in its error mode (from which fmi3SetFMUState,
 * fmi3Reset, fmi3FreeInstance, the FMU-state functions and the getters remain
 * legal); a rejected call changes no value. fmi3Discard (a step whose state
 * became non-finite, non-finite computed values) keeps the last good state.
 *
 * Choices where FMI 3.0 leaves one (as the Modelica Association's Reference
 * FMUs make them): Co-Simulation without event mode (hasEventMode="false":
 * an instantiation asking for eventModeUsed is refused), no early return and
 * no intermediate update (the callback and the required intermediate
 * variables are ignored), no Scheduled Execution, no clocks, no structural
 * parameters (Configuration Mode is refused), memory from calloc/free, a NULL
 * logMessage means no logging.
 *
 * The fmi3Instance must be NULL (refused with fmi3Error) or an instance of this
 * FMU: any other pointer is undefined behaviour, as in FMI 3.0.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi3Functions.h"
#include "instance.h"

/* FMI 3.0 value reference of the independent variable time (fmu.variables.FMI3_TIME_VR). */
#define TIME_VR 0u

/* ------------------------------------------------------- legal modes per call */

#define ALL_MODES (MW_MODE_INSTANTIATED | MW_MODE_INIT | MW_MODE_EVENT | MW_MODE_CONTINUOUS | \
                   MW_MODE_STEP_COMPLETE | MW_MODE_STEP_FAILED | MW_MODE_TERMINATED | MW_MODE_ERROR)
#define AFTER_INIT_MODES (MW_MODE_INIT | MW_MODE_EVENT | MW_MODE_CONTINUOUS | MW_MODE_STEP_COMPLETE | \
                          MW_MODE_STEP_FAILED | MW_MODE_TERMINATED | MW_MODE_ERROR)

#define MODES_EnterInitializationMode MW_MODE_INSTANTIATED
#define MODES_ExitInitializationMode MW_MODE_INIT
#define MODES_Terminate (MW_MODE_EVENT | MW_MODE_CONTINUOUS | MW_MODE_STEP_COMPLETE | MW_MODE_STEP_FAILED)
#define MODES_GetValue AFTER_INIT_MODES
#define MODES_SetValue (MW_MODE_INSTANTIATED | MW_MODE_INIT | MW_MODE_EVENT | MW_MODE_CONTINUOUS | MW_MODE_STEP_COMPLETE)
#define MODES_Derivative AFTER_INIT_MODES
/* Model Exchange */
#define MODES_EnterEventMode MW_MODE_CONTINUOUS
#define MODES_UpdateDiscreteStates MW_MODE_EVENT
#define MODES_EvaluateDiscreteStates (MW_MODE_INIT | MW_MODE_EVENT | MW_MODE_CONTINUOUS)
#define MODES_EnterContinuousTimeMode MW_MODE_EVENT
#define MODES_CompletedIntegratorStep MW_MODE_CONTINUOUS
#define MODES_SetTime (MW_MODE_EVENT | MW_MODE_CONTINUOUS)
#define MODES_SetContinuousStates MW_MODE_CONTINUOUS
#define MODES_GetDerivatives (MW_MODE_INIT | MW_MODE_EVENT | MW_MODE_CONTINUOUS | MW_MODE_TERMINATED | MW_MODE_ERROR)
#define MODES_GetNominals (MW_MODE_INSTANTIATED | MODES_GetDerivatives)
/* Co-Simulation */
#define MODES_DoStep MW_MODE_STEP_COMPLETE
#define MODES_GetOutputDerivatives (MW_MODE_STEP_COMPLETE | MW_MODE_STEP_FAILED | MW_MODE_TERMINATED | MW_MODE_ERROR)

#define FOR_ANY MW_FOR_ANY
#define FOR_ME MW_FOR_ME
#define FOR_CS MW_FOR_CS
/* the shared argument checks of instance.c, with this version's status type */
#define fail(inst, fn, what) ((fmi3Status)mw_fail(inst, fn, what))
#define null_arg mw_null_arg
#define wrong_size mw_wrong_size
#define non_finite(inst, fn, what, v, n) ((fmi3Status)mw_non_finite(inst, fn, what, v, n))

static const char *mode_name(unsigned int mode) {
    switch (mode) {
    case MW_MODE_INSTANTIATED: return "Instantiated";
    case MW_MODE_INIT: return "Initialization Mode";
    case MW_MODE_EVENT: return "Event Mode";
    case MW_MODE_CONTINUOUS: return "Continuous-Time Mode";
    case MW_MODE_STEP_COMPLETE: return "Step Mode";
    case MW_MODE_STEP_FAILED: return "Step Mode after a discarded step";
    case MW_MODE_TERMINATED: return "Terminated";
    case MW_MODE_ERROR: return "error";
    default: return "unknown";
    }
}

#define ENTER(fn, type, modes)                                 \
    MwInstance *inst = mw_enter(instance, "fmi3" #fn, type, modes, mode_name); \
    if (inst == NULL) return fmi3Error

/* The array behind a value reference other than time, or NULL after logging the error. */
static const MwArray *lookup(MwInstance *inst, const char *fn, fmi3ValueReference vr) {
    char what[128];
    if (vr != TIME_VR && (size_t)vr <= inst->model->narrays) return &inst->model->arrays[vr - 1];
    if (vr == TIME_VR) {
        snprintf(what, sizeof(what), "value reference %u is time, which is not a known or settable here", vr);
    } else {
        snprintf(what, sizeof(what), "unknown value reference %u (Float64 variables are 0..%u)", vr,
                 (unsigned int)inst->model->narrays);
    }
    fail(inst, fn, what);
    return NULL;
}

/* Total number of values of the variables vr[0..n-1] (time counts 1); 0 with an error logged if one is unknown. */
static int count_values(MwInstance *inst, const char *fn, const fmi3ValueReference vr[], size_t n, int time_ok,
                        size_t *total) {
    size_t i;
    *total = 0;
    for (i = 0; i < n; i++) {
        const MwArray *a;
        if (time_ok && vr[i] == TIME_VR) {
            *total += 1;
            continue;
        }
        a = lookup(inst, fn, vr[i]);
        if (a == NULL) return 0;
        *total += a->count;
    }
    return 1;
}

/* --------------------------------------------------------- common functions */

const char *fmi3GetVersion(void) { return fmi3Version; }

fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn, size_t nCategories,
                               const fmi3String categories[]) {
    ENTER(SetDebugLogging, FOR_ANY, ALL_MODES);
    if (nCategories > 0 && null_arg(inst, "fmi3SetDebugLogging", "categories[]", categories)) return fmi3Error;
    return (fmi3Status)mw_set_logging(inst, "fmi3SetDebugLogging", loggingOn, nCategories, categories);
}

/* The instance's log lines to the importer's fmi3LogMessageCallback (a plain message, no format). */
static void log_to_importer(const MwInstance *inst, MwStatus status, const char *category, const char *message) {
    fmi3LogMessageCallback logger = (fmi3LogMessageCallback)inst->host.logger;
    logger((fmi3InstanceEnvironment)inst->host.env, (fmi3Status)status, category, message);
}

static void refuse(fmi3InstanceEnvironment env, fmi3LogMessageCallback logger, fmi3String name, const char *message) {
    if (logger != NULL) {
        logger(env, fmi3Error, "logStatusError", message);
    } else {
        fprintf(stderr, "%.100s: %s\n", name != NULL ? name : "", message);
    }
}

static fmi3Instance instantiate(const char *fn, MwInterface type, fmi3String instanceName,
                                fmi3String instantiationToken, fmi3Boolean loggingOn,
                                fmi3InstanceEnvironment env, fmi3LogMessageCallback logMessage) {
    const MwModel *model = mw_model();
    MwInstance *inst;
    MwHost host;
    char message[160];
    if (instanceName == NULL || instanceName[0] == '\0') {
        snprintf(message, sizeof(message), "%s: instanceName is NULL or empty", fn);
        refuse(env, logMessage, instanceName, message);
        return NULL;
    }
    if (instantiationToken == NULL || strcmp(instantiationToken, model->guid) != 0) {
        snprintf(message, sizeof(message),
                 "%s: wrong instantiationToken: it does not match the modelDescription.xml of this binary", fn);
        refuse(env, logMessage, instanceName, message);
        return NULL;
    }
    if (type == MW_MODEL_EXCHANGE && model->nd > 0) {
        snprintf(message, sizeof(message), "%s: this model has sampled discrete states (a digital controller): it "
                 "is Co-Simulation only", fn);
        refuse(env, logMessage, instanceName, message);
        return NULL;
    }
    host.alloc = calloc;
    host.release = free;
    host.log = logMessage != NULL ? log_to_importer : NULL;
    host.env = env;
    host.logger = (MwAnyFunction)logMessage;
    inst = mw_instance_new(model, type, instanceName, &host, loggingOn);
    if (inst == NULL) {
        snprintf(message, sizeof(message), "%s: out of memory", fn);
        refuse(env, logMessage, instanceName, message);
    }
    return (fmi3Instance)inst;
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String instantiationToken,
                                          fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                          fmi3InstanceEnvironment instanceEnvironment,
                                          fmi3LogMessageCallback logMessage) {
    (void)resourcePath; /* the model needs no resources */
    (void)visible;
    return instantiate("fmi3InstantiateModelExchange", MW_MODEL_EXCHANGE, instanceName, instantiationToken, loggingOn,
                       instanceEnvironment, logMessage);
}

fmi3Instance fmi3InstantiateCoSimulation(fmi3String instanceName, fmi3String instantiationToken,
                                         fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                         fmi3Boolean eventModeUsed, fmi3Boolean earlyReturnAllowed,
                                         const fmi3ValueReference requiredIntermediateVariables[],
                                         size_t nRequiredIntermediateVariables,
                                         fmi3InstanceEnvironment instanceEnvironment,
                                         fmi3LogMessageCallback logMessage,
                                         fmi3IntermediateUpdateCallback intermediateUpdate) {
    (void)resourcePath;
    (void)visible;
    (void)earlyReturnAllowed; /* the FMU never returns early */
    (void)requiredIntermediateVariables; /* no variable has intermediateUpdate="true" */
    (void)nRequiredIntermediateVariables;
    (void)intermediateUpdate; /* providesIntermediateUpdate is false */
    if (eventModeUsed) {
        refuse(instanceEnvironment, logMessage, instanceName,
               "fmi3InstantiateCoSimulation: eventModeUsed is true, but this FMU has hasEventMode=\"false\" "
               "(its events are handled inside fmi3DoStep)");
        return NULL;
    }
    return instantiate("fmi3InstantiateCoSimulation", MW_CO_SIMULATION, instanceName, instantiationToken, loggingOn,
                       instanceEnvironment, logMessage);
}

fmi3Instance fmi3InstantiateScheduledExecution(fmi3String instanceName, fmi3String instantiationToken,
                                               fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                               fmi3InstanceEnvironment instanceEnvironment,
                                               fmi3LogMessageCallback logMessage, fmi3ClockUpdateCallback clockUpdate,
                                               fmi3LockPreemptionCallback lockPreemption,
                                               fmi3UnlockPreemptionCallback unlockPreemption) {
    (void)instantiationToken;
    (void)resourcePath;
    (void)visible;
    (void)loggingOn;
    (void)clockUpdate;
    (void)lockPreemption;
    (void)unlockPreemption;
    refuse(instanceEnvironment, logMessage, instanceName,
           "fmi3InstantiateScheduledExecution: this FMU supports Model Exchange and Co-Simulation only");
    return NULL;
}

void fmi3FreeInstance(fmi3Instance instance) {
    MwInstance *inst = (MwInstance *)instance;
    if (inst == NULL) return;
    mw_log(inst, MW_OK, MW_LOG_CALLS, "fmi3FreeInstance");
    mw_instance_free(inst);
}

fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean toleranceDefined, fmi3Float64 tolerance,
                                       fmi3Float64 startTime, fmi3Boolean stopTimeDefined, fmi3Float64 stopTime) {
    const char *fn = "fmi3EnterInitializationMode";
    ENTER(EnterInitializationMode, FOR_ANY, MODES_EnterInitializationMode);
    (void)toleranceDefined; /* the integrator is fixed-step; the tolerance is the importer's */
    (void)tolerance;
    if (!isfinite(startTime)) return fail(inst, fn, "startTime is not finite");
    if (stopTimeDefined && !(stopTime >= startTime)) return fail(inst, fn, "stopTime is before startTime or not a number");
    inst->time = startTime;
    inst->last_successful_time = startTime;
    inst->stop_time_defined = stopTimeDefined ? 1 : 0;
    inst->stop_time = stopTimeDefined ? stopTime : 0.0;
    inst->mode = MW_MODE_INIT;
    return fmi3OK;
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance instance) {
    const char *problem;
    char what[512];
    ENTER(ExitInitializationMode, FOR_ANY, MODES_ExitInitializationMode);
    problem = mw_exit_initialization(inst, what, sizeof(what));
    return problem == NULL ? fmi3OK : fail(inst, "fmi3ExitInitializationMode", problem);
}

fmi3Status fmi3EnterEventMode(fmi3Instance instance) {
    ENTER(EnterEventMode, FOR_ME, MODES_EnterEventMode);
    inst->mode = MW_MODE_EVENT;
    return fmi3OK;
}

fmi3Status fmi3Terminate(fmi3Instance instance) {
    ENTER(Terminate, FOR_ANY, MODES_Terminate);
    inst->mode = MW_MODE_TERMINATED;
    return fmi3OK;
}

fmi3Status fmi3Reset(fmi3Instance instance) {
    ENTER(Reset, FOR_ANY, ALL_MODES);
    mw_set_start_values(inst);
    inst->mode = MW_MODE_INSTANTIATED;
    return fmi3OK;
}

/* ------------------------------------------------------------ get and set */

fmi3Status fmi3GetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                          fmi3Float64 values[], size_t nValues) {
    const char *fn = "fmi3GetFloat64";
    size_t i, k, total, at = 0;
    ENTER(GetFloat64, FOR_ANY, MODES_GetValue);
    if (nValueReferences == 0) return wrong_size(inst, fn, "nValues", nValues, 0) ? fmi3Error : fmi3OK;
    if (null_arg(inst, fn, "valueReferences[]", valueReferences) || null_arg(inst, fn, "values[]", values))
        return fmi3Error;
    if (!count_values(inst, fn, valueReferences, nValueReferences, 1, &total)) return fmi3Error;
    if (wrong_size(inst, fn, "nValues", nValues, total)) return fmi3Error;
    for (i = 0; i < nValueReferences; i++) {
        const MwArray *a;
        if (valueReferences[i] == TIME_VR) {
            values[at++] = inst->time;
            continue;
        }
        a = &inst->model->arrays[valueReferences[i] - 1];
        for (k = 0; k < a->count; k++) {
            const MwVariable *v = &inst->model->variables[a->first + k];
            if (mw_prepare(inst, v) != 0) return fail(inst, fn, "the model failed to evaluate");
            values[at++] = mw_value(inst, v);
        }
    }
    return non_finite(inst, fn, "the values", values, nValues);
}

/* Whether variable v may be set in the instance's current mode (FMI 3.0, 2.3); logs why not. */
static int settable_now(MwInstance *inst, const MwArray *a, const MwVariable *v) {
    const char *why = NULL;
    unsigned int mode = inst->mode;
    char what[256];
    switch ((MwSettable)v->settable) {
    case MW_SET_NEVER:
        why = "is calculated by the model and cannot be set";
        break;
    case MW_SET_INITIAL:
    case MW_SET_STATE:
        if (!(mode & (MW_MODE_INSTANTIATED | MW_MODE_INIT)))
            why = v->settable == MW_SET_STATE
                      ? "is a continuous state: it can be set before fmi3ExitInitializationMode (afterwards, Model "
                        "Exchange sets it with fmi3SetContinuousStates)"
                      : "is fixed: it can only be set before fmi3ExitInitializationMode";
        break;
    case MW_SET_TUNABLE:
        if (!(mode & (MW_MODE_INSTANTIATED | MW_MODE_INIT | MW_MODE_EVENT | MW_MODE_STEP_COMPLETE)))
            why = "is a tunable parameter: it can be set in Event Mode (Model Exchange) or Step Mode (Co-Simulation)";
        break;
    case MW_SET_INPUT:
        break;
    default:
        why = "has a corrupt table entry";
        break;
    }
    if (why == NULL) return 1;
    snprintf(what, sizeof(what), "variable %.60s %s (%s)", a->name, why, mode_name(mode));
    fail(inst, "fmi3SetFloat64", what);
    return 0;
}

fmi3Status fmi3SetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                          const fmi3Float64 values[], size_t nValues) {
    const char *fn = "fmi3SetFloat64";
    size_t i, k, total, at = 0;
    char what[256];
    ENTER(SetFloat64, FOR_ANY, MODES_SetValue);
    if (nValueReferences == 0) return wrong_size(inst, fn, "nValues", nValues, 0) ? fmi3Error : fmi3OK;
    if (null_arg(inst, fn, "valueReferences[]", valueReferences) || null_arg(inst, fn, "values[]", values))
        return fmi3Error;
    if (!count_values(inst, fn, valueReferences, nValueReferences, 0, &total)) return fmi3Error;
    if (wrong_size(inst, fn, "nValues", nValues, total)) return fmi3Error;
    /* check every value first: a rejected call changes nothing */
    for (i = 0; i < nValueReferences; i++) {
        const MwArray *a = &inst->model->arrays[valueReferences[i] - 1];
        for (k = 0; k < a->count; k++, at++) {
            const MwVariable *v = &inst->model->variables[a->first + k];
            if (!settable_now(inst, a, v)) return fmi3Error;
            if (mw_value_problem(v, values[at], what, sizeof(what)) != NULL) return fail(inst, fn, what);
        }
    }
    for (i = 0, at = 0; i < nValueReferences; i++) {
        const MwArray *a = &inst->model->arrays[valueReferences[i] - 1];
        for (k = 0; k < a->count; k++, at++) {
            if (mw_assign(inst, &inst->model->variables[a->first + k], values[at]) != 0)
                return fail(inst, fn, "corrupt variable table");
        }
    }
    return fmi3OK;
}

/* Getters and setters of the types this FMU has no variables of. */
static fmi3Status no_variables_of_type(MwInstance *inst, const char *fn, const char *type_name,
                                       const fmi3ValueReference vr[], size_t nvr, const void *values) {
    char what[160];
    if (nvr == 0) return fmi3OK;
    if (null_arg(inst, fn, "valueReferences[]", vr) || null_arg(inst, fn, "values[]", values)) return fmi3Error;
    snprintf(what, sizeof(what), "unknown value reference %u: the model has no %s variables", vr[0], type_name);
    return fail(inst, fn, what);
}

#define NO_VARIABLES(Type, CType, Const, Modes)                                                                 \
    fmi3Status fmi3##Type(fmi3Instance instance, const fmi3ValueReference valueReferences[],                   \
                          size_t nValueReferences, Const CType values[], size_t nValues) {                     \
        ENTER(Type, FOR_ANY, Modes);                                                                           \
        (void)nValues;                                                                                         \
        return no_variables_of_type(inst, "fmi3" #Type, &(#CType)[4], valueReferences, nValueReferences, values); \
    }

NO_VARIABLES(GetFloat32, fmi3Float32, , MODES_GetValue)
NO_VARIABLES(GetInt8, fmi3Int8, , MODES_GetValue)
NO_VARIABLES(GetUInt8, fmi3UInt8, , MODES_GetValue)
NO_VARIABLES(GetInt16, fmi3Int16, , MODES_GetValue)
NO_VARIABLES(GetUInt16, fmi3UInt16, , MODES_GetValue)
NO_VARIABLES(GetInt32, fmi3Int32, , MODES_GetValue)
NO_VARIABLES(GetUInt32, fmi3UInt32, , MODES_GetValue)
NO_VARIABLES(GetInt64, fmi3Int64, , MODES_GetValue)
NO_VARIABLES(GetUInt64, fmi3UInt64, , MODES_GetValue)
NO_VARIABLES(GetBoolean, fmi3Boolean, , MODES_GetValue)
NO_VARIABLES(GetString, fmi3String, , MODES_GetValue)
NO_VARIABLES(SetFloat32, fmi3Float32, const, MODES_SetValue)
NO_VARIABLES(SetInt8, fmi3Int8, const, MODES_SetValue)
NO_VARIABLES(SetUInt8, fmi3UInt8, const, MODES_SetValue)
NO_VARIABLES(SetInt16, fmi3Int16, const, MODES_SetValue)
NO_VARIABLES(SetUInt16, fmi3UInt16, const, MODES_SetValue)
NO_VARIABLES(SetInt32, fmi3Int32, const, MODES_SetValue)
NO_VARIABLES(SetUInt32, fmi3UInt32, const, MODES_SetValue)
NO_VARIABLES(SetInt64, fmi3Int64, const, MODES_SetValue)
NO_VARIABLES(SetUInt64, fmi3UInt64, const, MODES_SetValue)
NO_VARIABLES(SetBoolean, fmi3Boolean, const, MODES_SetValue)
NO_VARIABLES(SetString, fmi3String, const, MODES_SetValue)

fmi3Status fmi3GetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         size_t valueSizes[], fmi3Binary values[], size_t nValues) {
    ENTER(GetBinary, FOR_ANY, MODES_GetValue);
    (void)valueSizes;
    (void)nValues;
    return no_variables_of_type(inst, "fmi3GetBinary", "Binary", valueReferences, nValueReferences, values);
}

fmi3Status fmi3SetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         const size_t valueSizes[], const fmi3Binary values[], size_t nValues) {
    ENTER(SetBinary, FOR_ANY, MODES_SetValue);
    (void)valueSizes;
    (void)nValues;
    return no_variables_of_type(inst, "fmi3SetBinary", "Binary", valueReferences, nValueReferences, values);
}

fmi3Status fmi3GetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        fmi3Clock values[]) {
    ENTER(GetClock, FOR_ANY, ALL_MODES);
    return no_variables_of_type(inst, "fmi3GetClock", "Clock", valueReferences, nValueReferences, values);
}

fmi3Status fmi3SetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        const fmi3Clock values[]) {
    ENTER(SetClock, FOR_ANY, ALL_MODES);
    return no_variables_of_type(inst, "fmi3SetClock", "Clock", valueReferences, nValueReferences, values);
}

/* --------------------------------------------------- functions not provided */

static fmi3Status not_provided(fmi3Instance instance, const char *fn, const char *why) {
    MwInstance *inst = mw_enter(instance, fn, FOR_ANY, ALL_MODES, mode_name);
    if (inst == NULL) return fmi3Error;
    return fail(inst, fn, why);
}

#define NO_CLOCKS "the model has no clocks"

fmi3Status fmi3GetNumberOfVariableDependencies(fmi3Instance instance, fmi3ValueReference valueReference,
                                               size_t *nDependencies) {
    (void)valueReference;
    (void)nDependencies;
    return not_provided(instance, "fmi3GetNumberOfVariableDependencies",
                        "not provided (providesPerElementDependencies=\"false\"): the dependencies are in "
                        "modelDescription.xml");
}

fmi3Status fmi3GetVariableDependencies(fmi3Instance instance, fmi3ValueReference dependent,
                                       size_t elementIndicesOfDependent[], fmi3ValueReference independents[],
                                       size_t elementIndicesOfIndependents[], fmi3DependencyKind dependencyKinds[],
                                       size_t nDependencies) {
    (void)dependent;
    (void)elementIndicesOfDependent;
    (void)independents;
    (void)elementIndicesOfIndependents;
    (void)dependencyKinds;
    (void)nDependencies;
    return not_provided(instance, "fmi3GetVariableDependencies",
                        "not provided (providesPerElementDependencies=\"false\"): the dependencies are in "
                        "modelDescription.xml");
}

fmi3Status fmi3EnterConfigurationMode(fmi3Instance instance) {
    return not_provided(instance, "fmi3EnterConfigurationMode", "the model has no structural parameters");
}

fmi3Status fmi3ExitConfigurationMode(fmi3Instance instance) {
    return not_provided(instance, "fmi3ExitConfigurationMode", "the model has no structural parameters");
}

fmi3Status fmi3GetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                  size_t nValueReferences, fmi3Float64 intervals[], fmi3IntervalQualifier qualifiers[]) {
    (void)valueReferences;
    (void)nValueReferences;
    (void)intervals;
    (void)qualifiers;
    return not_provided(instance, "fmi3GetIntervalDecimal", NO_CLOCKS);
}

fmi3Status fmi3GetIntervalFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                   size_t nValueReferences, fmi3UInt64 counters[], fmi3UInt64 resolutions[],
                                   fmi3IntervalQualifier qualifiers[]) {
    (void)valueReferences;
    (void)nValueReferences;
    (void)counters;
    (void)resolutions;
    (void)qualifiers;
    return not_provided(instance, "fmi3GetIntervalFraction", NO_CLOCKS);
}

fmi3Status fmi3GetShiftDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                               size_t nValueReferences, fmi3Float64 shifts[]) {
    (void)valueReferences;
    (void)nValueReferences;
    (void)shifts;
    return not_provided(instance, "fmi3GetShiftDecimal", NO_CLOCKS);
}

fmi3Status fmi3GetShiftFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                size_t nValueReferences, fmi3UInt64 counters[], fmi3UInt64 resolutions[]) {
    (void)valueReferences;
    (void)nValueReferences;
    (void)counters;
    (void)resolutions;
    return not_provided(instance, "fmi3GetShiftFraction", NO_CLOCKS);
}

fmi3Status fmi3SetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                  size_t nValueReferences, const fmi3Float64 intervals[]) {
    (void)valueReferences;
    (void)nValueReferences;
    (void)intervals;
    return not_provided(instance, "fmi3SetIntervalDecimal", NO_CLOCKS);
}

fmi3Status fmi3SetIntervalFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                   size_t nValueReferences, const fmi3UInt64 counters[],
                                   const fmi3UInt64 resolutions[]) {
    (void)valueReferences;
    (void)nValueReferences;
    (void)counters;
    (void)resolutions;
    return not_provided(instance, "fmi3SetIntervalFraction", NO_CLOCKS);
}

fmi3Status fmi3SetShiftDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                               size_t nValueReferences, const fmi3Float64 shifts[]) {
    (void)valueReferences;
    (void)nValueReferences;
    (void)shifts;
    return not_provided(instance, "fmi3SetShiftDecimal", NO_CLOCKS);
}

fmi3Status fmi3SetShiftFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                size_t nValueReferences, const fmi3UInt64 counters[], const fmi3UInt64 resolutions[]) {
    (void)valueReferences;
    (void)nValueReferences;
    (void)counters;
    (void)resolutions;
    return not_provided(instance, "fmi3SetShiftFraction", NO_CLOCKS);
}

fmi3Status fmi3ActivateModelPartition(fmi3Instance instance, fmi3ValueReference clockReference,
                                      fmi3Float64 activationTime) {
    (void)clockReference;
    (void)activationTime;
    return not_provided(instance, "fmi3ActivateModelPartition", "this FMU has no Scheduled Execution interface");
}

fmi3Status fmi3EnterStepMode(fmi3Instance instance) {
    return not_provided(instance, "fmi3EnterStepMode",
                        "hasEventMode=\"false\": the instance is in Step Mode after fmi3ExitInitializationMode");
}

/* ---------------------------------------------------------------- FMU state */

/* The FMU-state calls: instance.c does the work, a problem is an error with its message. */
static fmi3Status state_call(MwInstance *inst, const char *fn, const char *problem) {
    return problem == NULL ? fmi3OK : fail(inst, fn, problem);
}

fmi3Status fmi3GetFMUState(fmi3Instance instance, fmi3FMUState *FMUState) {
    ENTER(GetFMUState, FOR_ANY, ALL_MODES);
    return state_call(inst, "fmi3GetFMUState", mw_state_get(inst, (void **)FMUState));
}

fmi3Status fmi3SetFMUState(fmi3Instance instance, fmi3FMUState FMUState) {
    ENTER(SetFMUState, FOR_ANY, ALL_MODES);
    return state_call(inst, "fmi3SetFMUState", mw_state_set(inst, FMUState));
}

fmi3Status fmi3FreeFMUState(fmi3Instance instance, fmi3FMUState *FMUState) {
    ENTER(FreeFMUState, FOR_ANY, ALL_MODES);
    return state_call(inst, "fmi3FreeFMUState", mw_state_free(inst, (void **)FMUState));
}

fmi3Status fmi3SerializedFMUStateSize(fmi3Instance instance, fmi3FMUState FMUState, size_t *size) {
    ENTER(SerializedFMUStateSize, FOR_ANY, ALL_MODES);
    return state_call(inst, "fmi3SerializedFMUStateSize", mw_state_size(inst, FMUState, size));
}

fmi3Status fmi3SerializeFMUState(fmi3Instance instance, fmi3FMUState FMUState, fmi3Byte serializedState[], size_t size) {
    char what[160];
    ENTER(SerializeFMUState, FOR_ANY, ALL_MODES);
    return state_call(inst, "fmi3SerializeFMUState",
                      mw_state_serialize(inst, FMUState, (unsigned char *)serializedState, size, "fmi3SerializedFMUStateSize", what,
                                         sizeof(what)));
}

fmi3Status fmi3DeserializeFMUState(fmi3Instance instance, const fmi3Byte serializedState[], size_t size, fmi3FMUState *FMUState) {
    char what[192];
    ENTER(DeserializeFMUState, FOR_ANY, ALL_MODES);
    return state_call(inst, "fmi3DeserializeFMUState", mw_state_deserialize(inst, (const unsigned char *)serializedState, size,
                                                                     (void **)FMUState, what, sizeof(what)));
}

/* ----------------------------------------------- directional and adjoint derivatives */

/*
 * Forward (reverse = 0): sensitivity = J seed, seeds on the knowns. Reverse (reverse = 1):
 * sensitivity = J^T seed, seeds on the unknowns. Knowns are states, inputs and parameters;
 * unknowns are derivatives, outputs and states; every array counts with all its elements.
 */
static fmi3Status derivatives(MwInstance *inst, const char *fn, int reverse, const fmi3ValueReference unknowns[],
                              size_t nUnknowns, const fmi3ValueReference knowns[], size_t nKnowns,
                              const fmi3Float64 seed[], size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity) {
    const MwModel *m = inst->model;
    const fmi3ValueReference *seeded = reverse ? unknowns : knowns, *sensed = reverse ? knowns : unknowns;
    size_t n_seeded = reverse ? nUnknowns : nKnowns, n_sensed = reverse ? nKnowns : nUnknowns;
    size_t i, k, total, at;
    int need_ode = 0, need_out = 0, status;
    char what[192];

    if (nUnknowns > 0 && null_arg(inst, fn, "unknowns[]", unknowns)) return fmi3Error;
    if (nKnowns > 0 && null_arg(inst, fn, "knowns[]", knowns)) return fmi3Error;
    if (!count_values(inst, fn, seeded, n_seeded, 0, &total)) return fmi3Error;
    if (wrong_size(inst, fn, "nSeed", nSeed, total)) return fmi3Error;
    if (!count_values(inst, fn, sensed, n_sensed, 0, &total)) return fmi3Error;
    if (wrong_size(inst, fn, "nSensitivity", nSensitivity, total)) return fmi3Error;
    if (nSeed > 0 && null_arg(inst, fn, "seed[]", seed)) return fmi3Error;
    if (nSensitivity > 0 && null_arg(inst, fn, "sensitivity[]", sensitivity)) return fmi3Error;
    if (nSensitivity == 0) return fmi3OK;

    /* every unknown must be a derivative, an output or a state; every known a state, input or parameter */
    for (i = 0; i < nUnknowns + nKnowns; i++) {
        int is_unknown = i < nUnknowns;
        const MwArray *a = &m->arrays[(is_unknown ? unknowns[i] : knowns[i - nUnknowns]) - 1];
        unsigned char kind = m->variables[a->first].kind;
        int ok = is_unknown ? (kind == MW_KIND_DERIVATIVE || kind == MW_KIND_OUTPUT || kind == MW_KIND_STATE)
                            : (kind == MW_KIND_STATE || kind == MW_KIND_INPUT || kind == MW_KIND_PARAMETER);
        if (!ok) {
            snprintf(what, sizeof(what), "%.60s cannot be %s", a->name,
                     is_unknown ? "an unknown: unknowns are derivatives, outputs and states"
                                : "a known: knowns are states, inputs and parameters");
            return fail(inst, fn, what);
        }
        need_ode |= is_unknown && kind == MW_KIND_DERIVATIVE;
        need_out |= is_unknown && kind == MW_KIND_OUTPUT;
    }
    if (!mw_all_finite(seed, nSeed)) return fail(inst, fn, "the seed is not all finite");

    mw_clear_seeds(inst);
    for (i = 0, at = 0; i < n_seeded; i++) {
        const MwArray *a = &m->arrays[seeded[i] - 1];
        for (k = 0; k < a->count; k++, at++) (void)mw_seed(inst, &m->variables[a->first + k], seed[at], reverse);
    }
    status = reverse ? mw_adjoint(inst, need_ode, need_out) : mw_directional(inst, need_ode, need_out);
    if (status != 0) return fail(inst, fn, "the model failed to evaluate");
    for (i = 0, at = 0; i < n_sensed; i++) {
        const MwArray *a = &m->arrays[sensed[i] - 1];
        for (k = 0; k < a->count; k++, at++)
            sensitivity[at] = mw_sensitivity(inst, &m->variables[a->first + k], reverse);
    }
    return non_finite(inst, fn, reverse ? "the adjoint derivatives" : "the directional derivatives", sensitivity,
                      nSensitivity);
}

fmi3Status fmi3GetDirectionalDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns,
                                        const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[],
                                        size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity) {
    ENTER(GetDirectionalDerivative, FOR_ANY, MODES_Derivative);
    return derivatives(inst, "fmi3GetDirectionalDerivative", 0, unknowns, nUnknowns, knowns, nKnowns, seed, nSeed,
                       sensitivity, nSensitivity);
}

fmi3Status fmi3GetAdjointDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns,
                                    const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[],
                                    size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity) {
    ENTER(GetAdjointDerivative, FOR_ANY, MODES_Derivative);
    return derivatives(inst, "fmi3GetAdjointDerivative", 1, unknowns, nUnknowns, knowns, nKnowns, seed, nSeed,
                       sensitivity, nSensitivity);
}

/* -------------------------------------------------------- Model Exchange */

fmi3Status fmi3EvaluateDiscreteStates(fmi3Instance instance) {
    ENTER(EvaluateDiscreteStates, FOR_ANY, MODES_EvaluateDiscreteStates);
    return fmi3OK; /* no clocked partitions: the friction modes change only at events (fmi3UpdateDiscreteStates) */
}

fmi3Status fmi3UpdateDiscreteStates(fmi3Instance instance, fmi3Boolean *discreteStatesNeedUpdate,
                                    fmi3Boolean *terminateSimulation, fmi3Boolean *nominalsOfContinuousStatesChanged,
                                    fmi3Boolean *valuesOfContinuousStatesChanged, fmi3Boolean *nextEventTimeDefined,
                                    fmi3Float64 *nextEventTime) {
    const char *fn = "fmi3UpdateDiscreteStates";
    const char *problem;
    int x_changed;
    ENTER(UpdateDiscreteStates, FOR_ME, MODES_UpdateDiscreteStates);
    if (null_arg(inst, fn, "discreteStatesNeedUpdate", discreteStatesNeedUpdate) ||
        null_arg(inst, fn, "terminateSimulation", terminateSimulation) ||
        null_arg(inst, fn, "nominalsOfContinuousStatesChanged", nominalsOfContinuousStatesChanged) ||
        null_arg(inst, fn, "valuesOfContinuousStatesChanged", valuesOfContinuousStatesChanged) ||
        null_arg(inst, fn, "nextEventTimeDefined", nextEventTimeDefined) ||
        null_arg(inst, fn, "nextEventTime", nextEventTime))
        return fmi3Error;
    problem = mw_event_update(inst, &x_changed);
    if (problem != NULL) return fail(inst, fn, problem);
    *discreteStatesNeedUpdate = fmi3False;
    *terminateSimulation = fmi3False;
    *nominalsOfContinuousStatesChanged = fmi3False;
    *valuesOfContinuousStatesChanged = x_changed ? fmi3True : fmi3False;
    *nextEventTimeDefined = fmi3False;
    *nextEventTime = 0.0;
    return fmi3OK;
}

fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance instance) {
    ENTER(EnterContinuousTimeMode, FOR_ME, MODES_EnterContinuousTimeMode);
    inst->mode = MW_MODE_CONTINUOUS;
    return fmi3OK;
}

fmi3Status fmi3CompletedIntegratorStep(fmi3Instance instance, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi3Boolean *enterEventMode, fmi3Boolean *terminateSimulation) {
    const char *fn = "fmi3CompletedIntegratorStep";
    char what[192];
    ENTER(CompletedIntegratorStep, FOR_ME, MODES_CompletedIntegratorStep);
    (void)noSetFMUStatePriorToCurrentPoint;
    if (null_arg(inst, fn, "enterEventMode", enterEventMode) ||
        null_arg(inst, fn, "terminateSimulation", terminateSimulation))
        return fmi3Error;
    if (mw_past_stop_time(inst, inst->time)) {
        snprintf(what, sizeof(what), "an integrator step completed at t = %.17g, past the stopTime %.17g of "
                 "fmi3EnterInitializationMode", inst->time, inst->stop_time);
        return fail(inst, fn, what);
    }
    *enterEventMode = fmi3False;
    *terminateSimulation = fmi3False;
    return fmi3OK;
}

fmi3Status fmi3SetTime(fmi3Instance instance, fmi3Float64 time) {
    const char *problem;
    char what[192];
    ENTER(SetTime, FOR_ME, MODES_SetTime);
    problem = mw_set_time(inst, time, what, sizeof(what));
    return problem == NULL ? fmi3OK : fail(inst, "fmi3SetTime", problem);
}

fmi3Status fmi3SetContinuousStates(fmi3Instance instance, const fmi3Float64 continuousStates[],
                                   size_t nContinuousStates) {
    const char *fn = "fmi3SetContinuousStates";
    ENTER(SetContinuousStates, FOR_ME, MODES_SetContinuousStates);
    if (wrong_size(inst, fn, "nContinuousStates", nContinuousStates, inst->model->nx)) return fmi3Error;
    if (nContinuousStates == 0) return fmi3OK;
    if (null_arg(inst, fn, "continuousStates[]", continuousStates)) return fmi3Error;
    if (!mw_all_finite(continuousStates, nContinuousStates)) return fail(inst, fn, "the states are not all finite");
    memcpy(inst->x, continuousStates, nContinuousStates * sizeof(double));
    mw_invalidate(inst);
    return fmi3OK;
}

fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance instance, fmi3Float64 derivatives[],
                                             size_t nContinuousStates) {
    const char *fn = "fmi3GetContinuousStateDerivatives";
    ENTER(GetContinuousStateDerivatives, FOR_ME, MODES_GetDerivatives);
    if (wrong_size(inst, fn, "nContinuousStates", nContinuousStates, inst->model->nx)) return fmi3Error;
    if (nContinuousStates == 0) return fmi3OK;
    if (null_arg(inst, fn, "derivatives[]", derivatives)) return fmi3Error;
    if (mw_update_derivatives(inst) != 0) return fail(inst, fn, "the model failed to evaluate the derivatives");
    memcpy(derivatives, inst->xdot, nContinuousStates * sizeof(double));
    return (fmi3Status)mw_check_derivatives(inst, fn, derivatives, nContinuousStates);
}

fmi3Status fmi3GetEventIndicators(fmi3Instance instance, fmi3Float64 eventIndicators[], size_t nEventIndicators) {
    const char *fn = "fmi3GetEventIndicators";
    ENTER(GetEventIndicators, FOR_ME, MODES_GetDerivatives);
    if (wrong_size(inst, fn, "nEventIndicators", nEventIndicators, inst->model->nz)) return fmi3Error;
    if (nEventIndicators == 0) return fmi3OK;
    if (null_arg(inst, fn, "eventIndicators[]", eventIndicators)) return fmi3Error;
    if (mw_update_indicators(inst) != 0) return fail(inst, fn, "the model failed to evaluate");
    memcpy(eventIndicators, inst->z, nEventIndicators * sizeof(double));
    return non_finite(inst, fn, "the event indicators", eventIndicators, nEventIndicators);
}

fmi3Status fmi3GetContinuousStates(fmi3Instance instance, fmi3Float64 continuousStates[], size_t nContinuousStates) {
    const char *fn = "fmi3GetContinuousStates";
    ENTER(GetContinuousStates, FOR_ME, MODES_GetDerivatives);
    if (wrong_size(inst, fn, "nContinuousStates", nContinuousStates, inst->model->nx)) return fmi3Error;
    if (nContinuousStates == 0) return fmi3OK;
    if (null_arg(inst, fn, "continuousStates[]", continuousStates)) return fmi3Error;
    memcpy(continuousStates, inst->x, nContinuousStates * sizeof(double));
    return fmi3OK;
}

fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance instance, fmi3Float64 nominals[], size_t nContinuousStates) {
    const char *fn = "fmi3GetNominalsOfContinuousStates";
    ENTER(GetNominalsOfContinuousStates, FOR_ME, MODES_GetNominals);
    if (wrong_size(inst, fn, "nContinuousStates", nContinuousStates, inst->model->nx)) return fmi3Error;
    if (nContinuousStates == 0) return fmi3OK;
    if (null_arg(inst, fn, "nominals[]", nominals)) return fmi3Error;
    memcpy(nominals, inst->model->x_nominal, nContinuousStates * sizeof(double));
    return fmi3OK;
}

fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance instance, size_t *nEventIndicators) {
    ENTER(GetNumberOfEventIndicators, FOR_ANY, ALL_MODES);
    if (null_arg(inst, "fmi3GetNumberOfEventIndicators", "nEventIndicators", nEventIndicators)) return fmi3Error;
    *nEventIndicators = inst->model->nz;
    return fmi3OK;
}

fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance instance, size_t *nContinuousStates) {
    ENTER(GetNumberOfContinuousStates, FOR_ANY, ALL_MODES);
    if (null_arg(inst, "fmi3GetNumberOfContinuousStates", "nContinuousStates", nContinuousStates)) return fmi3Error;
    *nContinuousStates = inst->model->nx;
    return fmi3OK;
}

/* --------------------------------------------------------- Co-Simulation */

fmi3Status fmi3GetOutputDerivatives(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                    size_t nValueReferences, const fmi3Int32 orders[], fmi3Float64 values[],
                                    size_t nValues) {
    ENTER(GetOutputDerivatives, FOR_CS, MODES_GetOutputDerivatives);
    (void)valueReferences;
    (void)orders;
    (void)values;
    (void)nValues;
    if (nValueReferences == 0) return fmi3OK;
    return fail(inst, "fmi3GetOutputDerivatives", "output derivatives are not provided (maxOutputDerivativeOrder=0)");
}

fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 currentCommunicationPoint, fmi3Float64 communicationStepSize,
                      fmi3Boolean noSetFMUStatePriorToCurrentPoint, fmi3Boolean *eventHandlingNeeded,
                      fmi3Boolean *terminateSimulation, fmi3Boolean *earlyReturn, fmi3Float64 *lastSuccessfulTime) {
    const char *fn = "fmi3DoStep";
    MwStatus status;
    ENTER(DoStep, FOR_CS, MODES_DoStep);
    (void)noSetFMUStatePriorToCurrentPoint;
    if (null_arg(inst, fn, "eventHandlingNeeded", eventHandlingNeeded) ||
        null_arg(inst, fn, "terminateSimulation", terminateSimulation) || null_arg(inst, fn, "earlyReturn", earlyReturn) ||
        null_arg(inst, fn, "lastSuccessfulTime", lastSuccessfulTime))
        return fmi3Error;
    status = mw_do_step(inst, fn, currentCommunicationPoint, communicationStepSize);
    if (status == MW_ERROR) return fmi3Error; /* a refused step: the out-arguments are not written */
    *eventHandlingNeeded = fmi3False;
    *terminateSimulation = fmi3False;
    *earlyReturn = fmi3False;
    *lastSuccessfulTime = inst->last_successful_time;
    return (fmi3Status)status;
}
