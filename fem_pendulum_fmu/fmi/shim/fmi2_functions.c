/* FMI 2.0 co-simulation interface of this project's FMUs (Linux): the exported fmi2 functions.
 *
 * Each call is checked against the state machine (state_machine.h) and its arguments before the
 * Python slave object (slave.c) is called; a call that is not allowed answers fmi2Error with a log
 * message naming the call and the state, and changes nothing. The Python is made ready by
 * python_runtime.c; FMU states are handles of fmu_states.h and travel as bytes with a header of this
 * binary (format, version, the FMU's GUID, the time). Built by fem_pendulum_fmu/fmi/builder.py with
 * FMU_GUID and the modelDescription's capability flags defined; docs/reference/fmi2.md says what a host can
 * rely on. */
#include "python_api.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"
#include "python_runtime.h"
#include "call_frame.h"
#include "fmu_build.h"
#include "slave.h"
#include "state_machine.h"
#include "values.h"
#include "variables.h"

#define TIME_TOLERANCE 1e-9 /* as fmi/slave.py's _TIME_TOL */


/* ------------------------------------------------------------- life cycle */

static void free_instance_memory(Instance *inst) {
    for (size_t k = 0; k < inst->n_categories; k++) free(inst->categories[k]);
    free(inst->categories);
    registry_clear(&inst->states);
    free(inst->name);
    free(inst);
}

/* fmuResourceLocation (a file URI) as a path: file:///a%20b/resources -> /a b/resources */
static void uri_to_path(const char *uri, char *path, size_t n) {
    if (strncmp(uri, "file://", 7) == 0)
        uri += 7;
    else if (strncmp(uri, "file:", 5) == 0)
        uri += 5;
    size_t k = 0;
    for (; *uri && k + 1 < n; k++) {
        unsigned int byte;
        if (uri[0] == '%' && sscanf(uri + 1, "%2x", &byte) == 1) {
            path[k] = (char)byte;
            uri += 3;
        } else {
            path[k] = *uri++;
        }
    }
    path[k] = '\0';
    if (k > 1 && path[k - 1] == '/') path[k - 1] = '\0';
}

/* Why fmi2Instantiate's arguments are refused, or NULL. */
static const char *bad_instantiate_arguments(fmi2String name, fmi2Type type, fmi2String guid, fmi2String resources,
                                             char *why, size_t n) {
    if (name == NULL) return "instanceName is NULL";
    if (type != fmi2CoSimulation) return "this FMU is for co-simulation only (fmuType must be fmi2CoSimulation)";
    if (guid == NULL || strcmp(guid, FMU_GUID) != 0) {
        snprintf(why, n, "the GUID %s is not this FMU's %s (modelDescription.xml)", guid ? guid : "(NULL)", FMU_GUID);
        return why;
    }
    if (resources == NULL) return "fmuResourceLocation is NULL";
    return NULL;
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn) {
    char why[4096] = "", resources[4096];
    if (functions == NULL || functions->logger == NULL) { /* FMI 2.0 requires both */
        log_to_host(NULL, instanceName, fmi2Error, "logStatusError",
                    "fmi2Instantiate refused: the host passed no callback functions or no logger");
        return NULL;
    }
    const char *bad = bad_instantiate_arguments(instanceName, fmuType, fmuGUID, fmuResourceLocation, why, sizeof why);
    if (bad != NULL) {
        char message[4400];
        snprintf(message, sizeof message, "fmi2Instantiate refused: %s", bad);
        log_to_host(functions, instanceName, fmi2Error, "logStatusError", message);
        return NULL;
    }
    uri_to_path(fmuResourceLocation, resources, sizeof resources);
    if (exiting || python_prepare(resources, why, sizeof why) != 0) {
        log_to_host(functions, instanceName, fmi2Error, "logStatusError", exiting ? "the process is exiting" : why);
        return NULL;
    }
    Instance *inst = calloc(1, sizeof *inst);
    if (inst == NULL || (inst->name = strdup(instanceName)) == NULL) {
        free(inst);
        return NULL;
    }
    inst->callbacks = *functions;
    inst->logging_on = loggingOn == fmi2True;
    inst->state = STATE_INSTANTIATED;
    PyGILState_STATE gil = py.GILStateEnsure();
    clear_reported_error();
    int failed = slave_create(inst, resources, visible, why, sizeof why);
    if (failed) slave_release(inst);
    py.GILStateRelease(gil);
    if (failed) {
        log_to_host(functions, instanceName, fmi2Error, "logStatusError", why);
        free_instance_memory(inst);
        return NULL;
    }
    static int handler_registered = 0; /* after the slave's imports: runs before their exit-time cleanup */
    if (!__atomic_exchange_n(&handler_registered, 1, __ATOMIC_ACQ_REL)) atexit(mark_exiting);
    return inst;
}

void fmi2FreeInstance(fmi2Component c) {
    Instance *inst = (Instance *)c;
    if (inst == NULL) return;
    if (python_usable()) { /* else the Python objects are left to the ending process */
        PyGILState_STATE gil = py.GILStateEnsure();
        release_all_states(inst);
        slave_release(inst);
        py.GILStateRelease(gil);
    }
    free_instance_memory(inst);
}

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }

const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t n, const fmi2String categories[]) {
    Instance *inst = allowed(c, CALL_fmi2SetDebugLogging);
    if (inst == NULL) return fmi2Error;
    if (n > 0 && categories == NULL) return refuse(inst, CALL_fmi2SetDebugLogging, "categories is NULL");
    for (size_t k = 0; k < n; k++)
        if (categories[k] == NULL) return refuse(inst, CALL_fmi2SetDebugLogging, "a category is NULL");
    char **copy = n ? calloc(n, sizeof *copy) : NULL;
    for (size_t k = 0; copy != NULL && k < n; k++) copy[k] = strdup(categories[k]);
    for (size_t k = 0; k < inst->n_categories; k++) free(inst->categories[k]);
    free(inst->categories);
    inst->categories = copy;
    inst->n_categories = copy ? n : 0;
    inst->logging_on = loggingOn == fmi2True;
    return fmi2OK;
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance, fmi2Real startTime,
                               fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    Frame f;
    Instance *inst = begin(c, CALL_fmi2SetupExperiment, &f);
    if (inst == NULL) return fmi2Error;
    PyObject *stop = stopTimeDefined ? py.FloatFromDouble(stopTime) : NULL;
    PyObject *tol = toleranceDefined ? py.FloatFromDouble(tolerance) : NULL;
    PyObject *r = py.CallMethod(inst->slave, "setup_experiment", "(dOO)", startTime, stop ? stop : py.None,
                                tol ? tol : py.None);
    if (stop) py.DecRef(stop);
    if (tol) py.DecRef(tol);
    fmi2Status status = slave_settle(inst, "fmi2SetupExperiment", r, fmi2OK);
    if (status == fmi2OK) take_slave_time(inst, inst->restored ? inst->time : startTime);
    return end(&f, status);
}

/* A call of a slave method without arguments; on fmi2OK the instance moves to `next`. */
static fmi2Status simple_call(fmi2Component c, Call call, const char *method, MachineState next) {
    Frame f;
    Instance *inst = begin(c, call, &f);
    if (inst == NULL) return fmi2Error;
    fmi2Status status = slave_settle(inst, call_name(call), py.CallMethod(inst->slave, method, NULL), fmi2OK);
    if (status == fmi2OK) inst->state = next;
    if (status == fmi2OK && call == CALL_fmi2ExitInitializationMode) take_slave_time(inst, inst->time);
    return end(&f, status);
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    return simple_call(c, CALL_fmi2EnterInitializationMode, "enter_initialization_mode", STATE_INITIALIZATION_MODE);
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    return simple_call(c, CALL_fmi2ExitInitializationMode, "exit_initialization_mode", STATE_STEP_COMPLETE);
}

fmi2Status fmi2Terminate(fmi2Component c) {
    return simple_call(c, CALL_fmi2Terminate, "terminate", STATE_TERMINATED);
}

fmi2Status fmi2Reset(fmi2Component c) {
    Instance *inst = allowed(c, CALL_fmi2Reset);
    if (inst == NULL) return fmi2Error;
    if (!python_usable()) return refuse(inst, CALL_fmi2Reset, "the process is exiting or its Python is finalised");
    PyGILState_STATE gil = py.GILStateEnsure(); /* also when an earlier reset left no slave: try again */
    char why[2048];
    fmi2Status status = fmi2OK;
    if (slave_rebuild(inst, why, sizeof why) != 0) { /* the instance can only be freed, or reset again */
        log_error(inst, "fmi2Reset failed: %s", why);
        status = fmi2Error;
    }
    inst->state = STATE_INSTANTIATED;
    inst->time = 0.0;
    inst->restored = 0;
    inst->cannot_continue = 0;
    py.GILStateRelease(gil);
    return status;
}

/* Why doStep(t, h) is refused, or NULL: h finite and > 0, t the FMU's time (within 1e-9, relative
 * above 1 s), for any slave. */
static const char *step_problem(const Instance *inst, double t, double h, char *why, size_t n) {
    if (!(isfinite(h) && h > 0)) {
        snprintf(why, n, "communication step size %.17g must be a finite number > 0", h);
        return why;
    }
    double mismatch = fabs(t - inst->time);
    if (!isfinite(t) || (mismatch > TIME_TOLERANCE && mismatch > TIME_TOLERANCE * fmax(1.0, fabs(t)))) {
        snprintf(why, n, "communication point %.17g does not match the FMU's time %.17g", t, inst->time);
        return why;
    }
    return NULL;
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
    (void)noSetFMUStatePriorToCurrentPoint;
    Frame f;
    Instance *inst = allowed(c, CALL_fmi2DoStep);
    if (inst == NULL) return fmi2Error;
    char why[256];
    const char *bad = step_problem(inst, t, h, why, sizeof why);
    if (bad != NULL) return refuse(inst, CALL_fmi2DoStep, bad);
    if (!enter_python(inst, CALL_fmi2DoStep, &f)) return fmi2Error;
    PyObject *r = py.CallMethod(inst->slave, "do_step", "(dd)", t, h);
    int done = r != NULL ? py.IsTrue(r) : 0;
    if (done < 0) py.ErrClear();
    fmi2Status status = slave_settle(inst, "fmi2DoStep", r, done == 1 ? fmi2OK : fmi2Discard);
    if (status == fmi2OK) inst->time = t + h;
    inst->cannot_continue = status == fmi2Discard && slave_flag(inst, "cannot_continue");
    return end(&f, status);
}

fmi2Status fmi2CancelStep(fmi2Component c) {
    allowed(c, CALL_fmi2CancelStep); /* never allowed: it logs why */
    return fmi2Error;
}

/* ---------------------------------------------------------- variable access */

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real v[]) {
    return get_values(c, CALL_fmi2GetReal, "get_real", KIND_REAL, vr, n, v, n);
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Integer v[]) {
    return get_values(c, CALL_fmi2GetInteger, "get_integer", KIND_INTEGER, vr, n, v, n);
}

fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Boolean v[]) {
    return get_values(c, CALL_fmi2GetBoolean, "get_boolean", KIND_BOOLEAN, vr, n, v, n);
}

fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2String v[]) {
    return get_values(c, CALL_fmi2GetString, "get_string", KIND_STRING, vr, n, (void *)v, n);
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Real v[]) {
    return set_values(c, CALL_fmi2SetReal, "set_real", KIND_REAL, vr, n, v, n);
}

fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer v[]) {
    return set_values(c, CALL_fmi2SetInteger, "set_integer", KIND_INTEGER, vr, n, v, n);
}

fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Boolean v[]) {
    return set_values(c, CALL_fmi2SetBoolean, "set_boolean", KIND_BOOLEAN, vr, n, v, n);
}

fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2String v[]) {
    return set_values(c, CALL_fmi2SetString, "set_string", KIND_STRING, vr, n, (const void *)v, n);
}

/* A function the modelDescription says this FMU does not provide: refused in every state. */
fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference u[], size_t nu,
                                        const fmi2ValueReference z[], size_t nz, const fmi2Real dv[], fmi2Real dz[]) {
    (void)u, (void)nu, (void)z, (void)nz, (void)dv, (void)dz;
    allowed(c, CALL_fmi2GetDirectionalDerivative);
    return fmi2Error;
}

/* The orders and values of a derivative call as Python lists (new references), or NULL. */
static PyObject *order_list(const fmi2Integer order[], size_t n) {
    PyObject *list = py.ListNew((Py_ssize_t)n);
    for (size_t k = 0; list != NULL && k < n; k++) {
        PyObject *item = py.LongFromLong((long)order[k]);
        if (item == NULL || py.ListSetItem(list, (Py_ssize_t)k, item) != 0) {
            py.DecRef(list);
            list = NULL;
        }
    }
    return list;
}

static PyObject *real_list(const fmi2Real value[], size_t n) {
    PyObject *list = py.ListNew((Py_ssize_t)n);
    for (size_t k = 0; list != NULL && k < n; k++) {
        PyObject *item = py.FloatFromDouble(value[k]);
        if (item == NULL || py.ListSetItem(list, (Py_ssize_t)k, item) != 0) {
            py.DecRef(list);
            list = NULL;
        }
    }
    return list;
}

/* Input interpolation (FMI 2.0, section 4.2.1): derivatives of the inputs at the communication point, for the
 * next doStep. Each a continuous Real input, order 1 to FMU_INPUT_DERIVATIVE_ORDER, a finite value; anything
 * else is fmi2Error with nothing changed. docs/reference/fmi2.md says what the slave does with them after the step. */
fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                       const fmi2Integer order[], const fmi2Real value[]) {
    Frame f;
    Instance *inst = allowed(c, CALL_fmi2SetRealInputDerivatives);
    if (inst == NULL) return fmi2Error;
    if (n == 0) return fmi2OK;
    if (vr == NULL || order == NULL || value == NULL)
        return refuse(inst, CALL_fmi2SetRealInputDerivatives, "the value reference, order or value array is NULL");
    char why[512];
    const char *bad = derivatives_problem(vr, n, order, ROLE_INPUT, FMU_INPUT_DERIVATIVE_ORDER, why, sizeof why);
    for (size_t k = 0; bad == NULL && k < n; k++) {
        if (!isfinite(value[k])) {
            snprintf(why, sizeof why, "the derivative of order %d of value reference %u is %g: it must be a finite "
                     "number", (int)order[k], vr[k], value[k]);
            bad = why;
        }
    }
    if (bad != NULL) return refuse(inst, CALL_fmi2SetRealInputDerivatives, bad);
    if (!enter_python(inst, CALL_fmi2SetRealInputDerivatives, &f)) return fmi2Error;
    PyObject *refs = references(vr, n), *orders = order_list(order, n), *values = real_list(value, n);
    PyObject *r = refs && orders && values
                      ? py.CallMethod(inst->slave, "set_real_input_derivatives", "(OOO)", refs, orders, values) : NULL;
    PyObject *lists[] = {refs, orders, values};
    for (size_t k = 0; k < 3; k++)
        if (lists[k]) py.DecRef(lists[k]);
    return end(&f, slave_settle(inst, "fmi2SetRealInputDerivatives", r, fmi2OK));
}

/* Output derivatives at the FMU's time: each a continuous Real output, order 1 to maxOutputDerivativeOrder
 * (the slave refuses outputs that have none, saying why). */
fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                        const fmi2Integer order[], fmi2Real value[]) {
    Frame f;
    Instance *inst = allowed(c, CALL_fmi2GetRealOutputDerivatives);
    if (inst == NULL) return fmi2Error;
    if (n == 0) return fmi2OK;
    if (vr == NULL || order == NULL || value == NULL)
        return refuse(inst, CALL_fmi2GetRealOutputDerivatives, "the value reference, order or value array is NULL");
    char why[512];
    const char *bad = derivatives_problem(vr, n, order, ROLE_OUTPUT, FMU_MAX_OUTPUT_DERIVATIVE_ORDER, why, sizeof why);
    if (bad != NULL) return refuse(inst, CALL_fmi2GetRealOutputDerivatives, bad);
    if (!enter_python(inst, CALL_fmi2GetRealOutputDerivatives, &f)) return fmi2Error;
    PyObject *refs = references(vr, n), *orders = order_list(order, n);
    PyObject *answer = refs && orders ? py.CallMethod(inst->slave, "get_real_output_derivatives", "(OO)", refs, orders)
                                      : NULL;
    if (refs) py.DecRef(refs);
    if (orders) py.DecRef(orders);
    fmi2Status status = fmi2OK;
    if (answer != NULL && !error_pending()) {
        int ok = py.ListSize(answer) == (Py_ssize_t)n;
        for (size_t k = 0; ok && k < n; k++) ok = read_item(KIND_REAL, py.ListGetItem(answer, (Py_ssize_t)k), value, k);
        if (!ok) {
            char text[2048] = "the answer is not a list of the right length";
            if (py.ErrOccurred()) exception_message(text, sizeof text);
            log_error(inst, "fmi2GetRealOutputDerivatives failed: the FMU's Python code gave no usable values (%s)",
                      text);
            status = fmi2Error;
        }
    }
    return end(&f, slave_settle(inst, "fmi2GetRealOutputDerivatives", answer, status));
}

/* --------------------------------------------------------- status functions */

static const char *status_kind_name(fmi2StatusKind s) {
    switch (s) {
    case fmi2DoStepStatus: return "fmi2DoStepStatus";
    case fmi2PendingStatus: return "fmi2PendingStatus";
    case fmi2LastSuccessfulTime: return "fmi2LastSuccessfulTime";
    case fmi2Terminated: return "fmi2Terminated";
    }
    return NULL;
}

/* The checks every status function makes; the instance, or NULL after fmi2Error was logged. */
static Instance *status_call(fmi2Component c, Call call, fmi2StatusKind s, const void *value) {
    Instance *inst = allowed(c, call);
    if (inst == NULL) return NULL;
    if (status_kind_name(s) == NULL) {
        char why[128];
        snprintf(why, sizeof why, "%d is not an fmi2StatusKind", (int)s);
        refuse(inst, call, why);
        return NULL;
    }
    if (value == NULL) {
        refuse(inst, call, "the value pointer is NULL");
        return NULL;
    }
    return inst;
}

/* No asynchronous step is ever pending: the standard's answer for a status a slave cannot give. */
static fmi2Status no_such_status(Instance *inst, Call call, fmi2StatusKind s) {
    char message[512];
    snprintf(message, sizeof message, "%s(%s): this FMU has no such status (doStep is synchronous and never "
             "pending; the statuses it gives are fmi2LastSuccessfulTime and fmi2Terminated)",
             call_name(call), status_kind_name(s));
    log_to_host(&inst->callbacks, inst->name, fmi2Discard, "logStatusDiscard", message);
    return fmi2Discard;
}

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value) {
    Instance *inst = status_call(c, CALL_fmi2GetStatus, s, value);
    return inst ? no_such_status(inst, CALL_fmi2GetStatus, s) : fmi2Error;
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    Instance *inst = status_call(c, CALL_fmi2GetRealStatus, s, value);
    if (inst == NULL) return fmi2Error;
    if (s != fmi2LastSuccessfulTime) return no_such_status(inst, CALL_fmi2GetRealStatus, s);
    *value = inst->time;
    return fmi2OK;
}

fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value) {
    Instance *inst = status_call(c, CALL_fmi2GetIntegerStatus, s, value);
    return inst ? no_such_status(inst, CALL_fmi2GetIntegerStatus, s) : fmi2Error;
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value) {
    Instance *inst = status_call(c, CALL_fmi2GetBooleanStatus, s, value);
    if (inst == NULL) return fmi2Error;
    if (s != fmi2Terminated) return no_such_status(inst, CALL_fmi2GetBooleanStatus, s);
    /* true once terminated, and after a Discard that no shorter step can avoid (the step's solve failed
     * down to the smallest internal step): the master should end the run or restore an earlier state */
    *value = inst->state == STATE_TERMINATED || inst->cannot_continue ? fmi2True : fmi2False;
    return fmi2OK;
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value) {
    Instance *inst = status_call(c, CALL_fmi2GetStringStatus, s, value);
    return inst ? no_such_status(inst, CALL_fmi2GetStringStatus, s) : fmi2Error;
}
