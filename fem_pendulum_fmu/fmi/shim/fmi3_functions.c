/* FMI 3.0 co-simulation interface of the FMI 3.0 FMU (Linux): instantiation, life cycle, Get/Set.
 *
 * The FMI 2.0 binary's pieces serve here too (built with FMI3_BINARY defined, by
 * fem_pendulum_fmu/fmi/builder.py): the state machine's table (fmi3_calls.h), call frames, the Python
 * runtime, the checked Get/Set (values.c), FMU state handles. The host's fmi3LogMessageCallback is
 * reached through an FMI 2.0-shaped logger (`to_fmi3_logger`), so that every message of the shared code
 * reaches it. The Python slave is fmi/slave3.py's (pythonfmu3's Fmi3Slave, in front of the FMI 2.0
 * slave's logic). doStep and event mode: fmi3_step.c; FMU states: fmi3_states.c; what this FMU does
 * not provide: fmi3_unsupported.c. docs/reference/fmi3.md says what a host can rely on. */
#include "python_api.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi3Functions.h"
#include "python_runtime.h"
#include "call_frame.h"
#include "fmi3_shim.h"
#include "fmu_build.h"
#include "slave.h"
#include "state_machine.h"
#include "values.h"

/* The shared code logs through an fmi2CallbackLogger: the message arrives as a format string with each
 * '%' doubled (slave.c log_to_host), which vsnprintf undoes. */
static void to_fmi3_logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status, fmi2String category,
                           fmi2String message, ...) {
    (void)name;
    Instance *inst = (Instance *)env;
    char text[8192];
    va_list args;
    va_start(args, message);
    vsnprintf(text, sizeof text, message, args);
    va_end(args);
    fmi3LogMessageCallback log = (fmi3LogMessageCallback)inst->fmi3.log_message;
    if (log != NULL) log(inst->fmi3.environment, (fmi3Status)status, category, text);
}

static void free_instance_memory(Instance *inst) {
    for (size_t k = 0; k < inst->n_categories; k++) free(inst->categories[k]);
    free(inst->categories);
    registry_clear(&inst->states);
    free(inst->name);
    free(inst);
}

/* Why fmi3InstantiateCoSimulation's arguments are refused, or NULL. */
static const char *bad_arguments(fmi3String name, fmi3String token, fmi3String resources, char *why, size_t n) {
    if (name == NULL) return "instanceName is NULL";
    if (token == NULL || strcmp(token, FMU_GUID) != 0) {
        snprintf(why, n, "the instantiation token %s is not this FMU's %s (modelDescription.xml)",
                 token ? token : "(NULL)", FMU_GUID);
        return why;
    }
    if (resources == NULL) return "resourcePath is NULL";
    return NULL;
}

/* A message before an instance exists: through the host's logger, else on stderr; nothing once the process's
 * Python has ended (python_runtime.h python_ended). */
static void early_log(fmi3String name, fmi3InstanceEnvironment env, fmi3LogMessageCallback log, const char *text) {
    if (python_ended()) return; /* the callback may be Python code (python_runtime.h) */
    if (log != NULL)
        log(env, fmi3Error, "logStatusError", text);
    else
        fprintf(stderr, "%s: %s\n", name ? name : "FMU", text);
}

/* fmi3's resourcePath is a folder path (with a trailing '/'); the shared code wants it without. */
static void resource_folder(const char *path, char *folder, size_t n) {
    snprintf(folder, n, "%s", path);
    size_t k = strlen(folder);
    while (k > 1 && folder[k - 1] == '/') folder[--k] = '\0';
}

static Instance *new_instance(fmi3String name, fmi3Boolean logging_on, fmi3InstanceEnvironment env,
                              fmi3LogMessageCallback log, fmi3IntermediateUpdateCallback update) {
    Instance *inst = calloc(1, sizeof *inst);
    if (inst == NULL || (inst->name = strdup(name)) == NULL) {
        free(inst);
        return NULL;
    }
    inst->callbacks.logger = to_fmi3_logger;
    inst->callbacks.componentEnvironment = inst;
    inst->fmi3.environment = env;
    inst->fmi3.log_message = (void (*)(void))log;
    inst->fmi3.intermediate_update = (void (*)(void))update;
    inst->logging_on = logging_on;
    inst->state = STATE_INSTANTIATED;
    return inst;
}

fmi3Instance fmi3InstantiateCoSimulation(fmi3String instanceName, fmi3String instantiationToken,
                                         fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                         fmi3Boolean eventModeUsed, fmi3Boolean earlyReturnAllowed,
                                         const fmi3ValueReference requiredIntermediateVariables[],
                                         size_t nRequiredIntermediateVariables,
                                         fmi3InstanceEnvironment instanceEnvironment, fmi3LogMessageCallback logMessage,
                                         fmi3IntermediateUpdateCallback intermediateUpdate) {
    char why[4096] = "", resources[4096], message[4400];
    const char *bad = bad_arguments(instanceName, instantiationToken, resourcePath, why, sizeof why);
    (void)requiredIntermediateVariables; /* never read: any number of them is refused */
    if (bad == NULL && nRequiredIntermediateVariables > 0)
        bad = "this FMU offers no intermediate variables (nRequiredIntermediateVariables must be 0)";
    if (bad != NULL) {
        snprintf(message, sizeof message, "fmi3InstantiateCoSimulation refused: %s", bad);
        early_log(instanceName, instanceEnvironment, logMessage, message);
        return NULL;
    }
    resource_folder(resourcePath, resources, sizeof resources);
    if (exiting || python_prepare(resources, why, sizeof why) != 0) {
        early_log(instanceName, instanceEnvironment, logMessage, exiting ? "the process is exiting" : why);
        return NULL;
    }
    Instance *inst = new_instance(instanceName, loggingOn, instanceEnvironment, logMessage, intermediateUpdate);
    if (inst == NULL) return NULL;
    inst->fmi3.event_mode_used = eventModeUsed;
    inst->fmi3.early_return_allowed = earlyReturnAllowed;
    PyGILState_STATE gil = py.GILStateEnsure();
    clear_reported_error();
    int failed = slave_create(inst, resources, visible ? fmi2True : fmi2False, why, sizeof why);
    if (!failed) failed = configure_slave(inst, why, sizeof why);
    if (failed) slave_release(inst);
    py.GILStateRelease(gil);
    if (failed) {
        early_log(instanceName, instanceEnvironment, logMessage, why);
        free_instance_memory(inst);
        return NULL;
    }
    static int handler_registered = 0; /* after the slave's imports: runs before their exit-time cleanup */
    if (!__atomic_exchange_n(&handler_registered, 1, __ATOMIC_ACQ_REL)) atexit(mark_exiting);
    return inst;
}

/* With the GIL held: tell the slave how the host instantiated it (again after fmi3Reset). */
int configure_slave(Instance *inst, char *why, size_t n) {
    PyObject *r = py.CallMethod(inst->slave, "configure", "(iii)", inst->fmi3.event_mode_used,
                                inst->fmi3.early_return_allowed, inst->fmi3.intermediate_update != NULL);
    if (r == NULL) {
        exception_message(why, n);
        return 1;
    }
    py.DecRef(r);
    return 0;
}

void fmi3FreeInstance(fmi3Instance instance) {
    Instance *inst = (Instance *)instance;
    if (inst == NULL) return;
    if (inst->fmi3.in_step) { /* from the intermediate-update callback: the step still uses the instance */
        log_error(inst, "fmi3FreeInstance refused: called during fmi3DoStep (from the intermediate-update callback); "
                  "the instance is kept");
        return;
    }
    if (python_usable()) { /* else the Python objects are left to the ending process */
        PyGILState_STATE gil = py.GILStateEnsure();
        release_all_states(inst);
        slave_release(inst);
        py.GILStateRelease(gil);
    }
    free_instance_memory(inst);
}

const char *fmi3GetVersion(void) { return fmi3Version; }

fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn, size_t n, const fmi3String categories[]) {
    Instance *inst = allowed(instance, CALL_fmi3SetDebugLogging);
    if (inst == NULL) return fmi3Error;
    if (n > 0 && categories == NULL) return (fmi3Status)refuse(inst, CALL_fmi3SetDebugLogging, "categories is NULL");
    for (size_t k = 0; k < n; k++)
        if (categories[k] == NULL) return (fmi3Status)refuse(inst, CALL_fmi3SetDebugLogging, "a category is NULL");
    char **copy = n ? calloc(n, sizeof *copy) : NULL;
    for (size_t k = 0; copy != NULL && k < n; k++) copy[k] = strdup(categories[k]);
    for (size_t k = 0; k < inst->n_categories; k++) free(inst->categories[k]);
    free(inst->categories);
    inst->categories = copy;
    inst->n_categories = copy ? n : 0;
    inst->logging_on = loggingOn;
    return fmi3OK;
}

/* fmi3EnterInitializationMode carries FMI 2.0's fmi2SetupExperiment. */
fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean toleranceDefined, fmi3Float64 tolerance,
                                       fmi3Float64 startTime, fmi3Boolean stopTimeDefined, fmi3Float64 stopTime) {
    Frame f;
    Instance *inst = begin(instance, CALL_fmi3EnterInitializationMode, &f);
    if (inst == NULL) return fmi3Error;
    PyObject *stop = stopTimeDefined ? py.FloatFromDouble(stopTime) : NULL;
    PyObject *tol = toleranceDefined ? py.FloatFromDouble(tolerance) : NULL;
    PyObject *r = py.CallMethod(inst->slave, "setup_experiment", "(dOO)", startTime, stop ? stop : py.None,
                                tol ? tol : py.None);
    if (stop) py.DecRef(stop);
    if (tol) py.DecRef(tol);
    fmi2Status status = slave_settle(inst, "fmi3EnterInitializationMode", r, fmi2OK);
    if (status == fmi2OK) {
        take_slave_time(inst, inst->restored ? inst->time : startTime);
        r = py.CallMethod(inst->slave, "enter_initialization_mode", NULL);
        status = slave_settle(inst, "fmi3EnterInitializationMode", r, fmi2OK);
    }
    if (status == fmi2OK) inst->state = STATE_INITIALIZATION_MODE;
    return (fmi3Status)end(&f, status);
}

/* A call of a slave method without arguments; on fmi3OK the instance moves to `next`. */
fmi3Status fmi3_simple_call(fmi3Instance instance, Call call, const char *method, MachineState next) {
    Frame f;
    Instance *inst = begin(instance, call, &f);
    if (inst == NULL) return fmi3Error;
    fmi2Status status = slave_settle(inst, call_name(call), py.CallMethod(inst->slave, method, NULL), fmi2OK);
    if (status == fmi2OK) inst->state = next;
    if (status == fmi2OK) take_slave_time(inst, inst->time);
    return (fmi3Status)end(&f, status);
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance instance) {
    Instance *inst = (Instance *)instance;
    MachineState next = inst != NULL && inst->fmi3.event_mode_used ? STATE_EVENT_MODE : STATE_STEP_COMPLETE;
    return fmi3_simple_call(instance, CALL_fmi3ExitInitializationMode, "exit_initialization_mode", next);
}

fmi3Status fmi3Terminate(fmi3Instance instance) {
    return fmi3_simple_call(instance, CALL_fmi3Terminate, "terminate", STATE_TERMINATED);
}

fmi3Status fmi3Reset(fmi3Instance instance) {
    Instance *inst = allowed(instance, CALL_fmi3Reset);
    if (inst == NULL) return fmi3Error;
    if (!python_usable()) return (fmi3Status)refuse(inst, CALL_fmi3Reset, "the process is exiting or its Python is finalised");
    PyGILState_STATE gil = py.GILStateEnsure(); /* also when an earlier reset left no slave: try again */
    char why[2048];
    fmi3Status status = fmi3OK;
    if (slave_rebuild(inst, why, sizeof why) != 0 || configure_slave(inst, why, sizeof why) != 0) {
        log_error(inst, "fmi3Reset failed: %s", why); /* the instance can only be freed, or reset again */
        status = fmi3Error;
    }
    inst->state = STATE_INSTANTIATED;
    inst->time = 0.0;
    inst->restored = 0;
    inst->cannot_continue = 0;
    py.GILStateRelease(gil);
    return status;
}

/* ---------------------------------------------------------- variable access */

#define GETTER(fmi3_name, method, kind, type)                                                                  \
    fmi3Status fmi3_name(fmi3Instance instance, const fmi3ValueReference vr[], size_t n, type values[],      \
                         size_t nValues) {                                                                     \
        return (fmi3Status)get_values(instance, CALL_##fmi3_name, method, kind, vr, n, (void *)values, nValues); \
    }
#define SETTER(fmi3_name, method, kind, type)                                                                  \
    fmi3Status fmi3_name(fmi3Instance instance, const fmi3ValueReference vr[], size_t n, const type values[], \
                         size_t nValues) {                                                                     \
        return (fmi3Status)set_values(instance, CALL_##fmi3_name, method, kind, vr, n, (const void *)values,   \
                                      nValues);                                                                \
    }

GETTER(fmi3GetFloat64, "get_float64", KIND_REAL, fmi3Float64)
GETTER(fmi3GetInt32, "get_int32", KIND_INTEGER, fmi3Int32)
GETTER(fmi3GetInt64, "get_int64", KIND_INT64, fmi3Int64)
GETTER(fmi3GetBoolean, "get_boolean", KIND_BOOLEAN, fmi3Boolean)
GETTER(fmi3GetString, "get_string", KIND_STRING, fmi3String)
SETTER(fmi3SetFloat64, "set_float64", KIND_REAL, fmi3Float64)
SETTER(fmi3SetInt32, "set_int32", KIND_INTEGER, fmi3Int32)
SETTER(fmi3SetInt64, "set_int64", KIND_INT64, fmi3Int64)
SETTER(fmi3SetBoolean, "set_boolean", KIND_BOOLEAN, fmi3Boolean)
SETTER(fmi3SetString, "set_string", KIND_STRING, fmi3String)
