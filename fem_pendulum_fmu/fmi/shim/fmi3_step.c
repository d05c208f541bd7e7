/* fmi3DoStep, event mode, and the intermediate update of the FMI 3.0 FMU.
 *
 * The slave (fmi/slave3.py) takes the step; when the host allowed early return, it stops at the first
 * internal step where the gap closes (contact onset), and at each internal step it calls the host's
 * intermediate-update callback through fem_pendulum_intermediate_update (ctypes), which may ask it to
 * return early there. While the callback runs, the instance answers no other call (fmi3IntermediateUpdate
 * passes intermediateVariableGetAllowed and SetRequested false). With eventModeUsed, a step during which
 * the contact began or ended answers eventHandlingNeeded; the host then calls fmi3EnterEventMode,
 * fmi3UpdateDiscreteStates and fmi3EnterStepMode. docs/reference/fmi3.md. */
#include "python_api.h"

#include <math.h>
#include <stdio.h>

#include "call_frame.h"
#include "fmi3Functions.h"
#include "fmi3_shim.h"
#include "fmu_build.h"
#include "slave.h"
#include "values.h"
#include "variables.h"

#define TIME_TOLERANCE 1e-9 /* as fmi/slave.py's _TIME_TOL */

static __thread Instance *stepping = NULL; /* the instance whose fmi3DoStep runs on this thread */

/* Called by the slave (ctypes) after an internal step at `time`: the host's intermediate-update callback,
 * if any; 1 when the host asks to return early there. */
FMI3_Export int fem_pendulum_intermediate_update(double time, int can_return_early) {
    Instance *inst = stepping;
    fmi3IntermediateUpdateCallback update =
        inst != NULL ? (fmi3IntermediateUpdateCallback)inst->fmi3.intermediate_update : NULL;
    if (update == NULL) return 0;
    fmi3Boolean requested = fmi3False;
    fmi3Float64 early_time = time;
    update(inst->fmi3.environment, time, fmi3False, fmi3False, fmi3True, can_return_early ? fmi3True : fmi3False,
           &requested, &early_time);
    return can_return_early && requested;
}

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

fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 t, fmi3Float64 h, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                      fmi3Boolean *eventHandlingNeeded, fmi3Boolean *terminateSimulation, fmi3Boolean *earlyReturn,
                      fmi3Float64 *lastSuccessfulTime) {
    (void)noSetFMUStatePriorToCurrentPoint;
    Frame f;
    Instance *inst = allowed(instance, CALL_fmi3DoStep);
    if (inst == NULL) return fmi3Error;
    if (!eventHandlingNeeded || !terminateSimulation || !earlyReturn || !lastSuccessfulTime)
        return (fmi3Status)refuse(inst, CALL_fmi3DoStep, "an output argument pointer is NULL");
    char why[256];
    const char *bad = step_problem(inst, t, h, why, sizeof why);
    if (bad != NULL) return (fmi3Status)refuse(inst, CALL_fmi3DoStep, bad);
    if (!enter_python(inst, CALL_fmi3DoStep, &f)) return fmi3Error;
    Instance *outer = stepping;
    stepping = inst;
    inst->fmi3.in_step = 1;
    PyObject *r = py.CallMethod(inst->slave, "do_step", "(dd)", t, h);
    inst->fmi3.in_step = 0;
    stepping = outer;
    int done = r != NULL ? py.IsTrue(r) : 0;
    if (done < 0) py.ErrClear();
    fmi2Status status = slave_settle(inst, "fmi3DoStep", r, done == 1 ? fmi2OK : fmi2Discard);
    if (status == fmi2OK) take_slave_time(inst, t + h);
    inst->cannot_continue = status == fmi2Discard && slave_flag(inst, "cannot_continue");
    *eventHandlingNeeded = status == fmi2OK && inst->fmi3.event_mode_used && slave_flag(inst, "event_handling_needed");
    *earlyReturn = status == fmi2OK && slave_flag(inst, "early_return");
    *terminateSimulation = inst->cannot_continue ? fmi3True : fmi3False;
    *lastSuccessfulTime = inst->time;
    return (fmi3Status)end(&f, status);
}

fmi3Status fmi3EnterEventMode(fmi3Instance instance) {
    Instance *inst = allowed(instance, CALL_fmi3EnterEventMode);
    if (inst == NULL) return fmi3Error;
    if (!inst->fmi3.event_mode_used)
        return (fmi3Status)refuse(inst, CALL_fmi3EnterEventMode, "the instance was made with eventModeUsed = false");
    return fmi3_simple_call(instance, CALL_fmi3EnterEventMode, "enter_event_mode", STATE_EVENT_MODE);
}

fmi3Status fmi3EnterStepMode(fmi3Instance instance) {
    return fmi3_simple_call(instance, CALL_fmi3EnterStepMode, "enter_step_mode", STATE_STEP_COMPLETE);
}

/* The contact's change is the only event and changes no discrete state: nothing to update, no next event
 * known in advance. */
fmi3Status fmi3UpdateDiscreteStates(fmi3Instance instance, fmi3Boolean *discreteStatesNeedUpdate,
                                    fmi3Boolean *terminateSimulation, fmi3Boolean *nominalsOfContinuousStatesChanged,
                                    fmi3Boolean *valuesOfContinuousStatesChanged, fmi3Boolean *nextEventTimeDefined,
                                    fmi3Float64 *nextEventTime) {
    Instance *inst = allowed(instance, CALL_fmi3UpdateDiscreteStates);
    if (inst == NULL) return fmi3Error;
    fmi3Boolean *flags[] = {discreteStatesNeedUpdate, terminateSimulation, nominalsOfContinuousStatesChanged,
                            valuesOfContinuousStatesChanged, nextEventTimeDefined};
    for (size_t k = 0; k < sizeof flags / sizeof flags[0]; k++)
        if (flags[k] == NULL || nextEventTime == NULL)
            return (fmi3Status)refuse(inst, CALL_fmi3UpdateDiscreteStates, "an output argument pointer is NULL");
    fmi3Status status = fmi3_simple_call(instance, CALL_fmi3UpdateDiscreteStates, "update_discrete_states",
                                         STATE_EVENT_MODE);
    for (size_t k = 0; k < sizeof flags / sizeof flags[0]; k++) *flags[k] = fmi3False;
    *nextEventTime = 0.0;
    return status;
}

/* The orders as a Python list (a new reference), or NULL. */
static PyObject *order_list(const fmi3Int32 order[], size_t n) {
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

/* Output derivatives at the FMU's time, as fmi2GetRealOutputDerivatives: each a continuous scalar Float64
 * output, order 1 to maxOutputDerivativeOrder (the slave refuses the per-step summaries, saying why). */
fmi3Status fmi3GetOutputDerivatives(fmi3Instance instance, const fmi3ValueReference vr[], size_t n,
                                    const fmi3Int32 order[], fmi3Float64 value[], size_t nValues) {
    Frame f;
    Instance *inst = allowed(instance, CALL_fmi3GetOutputDerivatives);
    if (inst == NULL) return fmi3Error;
    if (n == 0) return fmi3OK;
    if (vr == NULL || order == NULL || value == NULL)
        return (fmi3Status)refuse(inst, CALL_fmi3GetOutputDerivatives, "the value reference, order or value array is NULL");
    char why[512];
    const char *bad = derivatives_problem(vr, n, order, ROLE_OUTPUT, FMU_MAX_OUTPUT_DERIVATIVE_ORDER, why, sizeof why);
    if (bad == NULL && nValues != n) {
        snprintf(why, sizeof why, "nValues is %zu for %zu value references: only scalar outputs have derivatives here",
                 nValues, n);
        bad = why;
    }
    if (bad == NULL) bad = count_problem(vr, n, n, why, sizeof why); /* an array among them */
    if (bad != NULL) return (fmi3Status)refuse(inst, CALL_fmi3GetOutputDerivatives, bad);
    if (!enter_python(inst, CALL_fmi3GetOutputDerivatives, &f)) return fmi3Error;
    PyObject *refs = references(vr, n), *orders = order_list(order, n);
    PyObject *answer = refs && orders ? py.CallMethod(inst->slave, "get_output_derivatives", "(OO)", refs, orders)
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
            log_error(inst, "fmi3GetOutputDerivatives failed: the FMU's Python code gave no usable values (%s)", text);
            status = fmi2Error;
        }
    }
    return (fmi3Status)end(&f, slave_settle(inst, "fmi3GetOutputDerivatives", answer, status));
}
