/* Get and Set of the variables for both binaries (values.h): the checks, then the slave's method.
 * The FMI 3.0 binary (FMI3_BINARY) reads Booleans as one byte (fmi3Boolean is bool) and has Int64
 * (its Enumerations) and arrays: n_values counts the elements of every variable, n the references. */
#include "python_api.h"

#include <stdbool.h>
#include <stdint.h>

#include "call_frame.h"
#include "values.h"
#include "variables.h"

/* Fill values[k] from the k-th item of the slave's answer list. */
int read_item(Kind kind, PyObject *item, void *values, size_t k) {
    switch (kind) {
    case KIND_REAL: ((fmi2Real *)values)[k] = py.FloatAsDouble(item); break;
    case KIND_INTEGER: ((fmi2Integer *)values)[k] = (fmi2Integer)py.LongAsLong(item); break;
#ifdef FMI3_BINARY
    case KIND_BOOLEAN: ((bool *)values)[k] = py.IsTrue(item) == 1; break;
#else
    case KIND_BOOLEAN: ((fmi2Boolean *)values)[k] = py.IsTrue(item) == 1 ? fmi2True : fmi2False; break;
#endif
    case KIND_STRING: ((fmi2String *)values)[k] = py.UnicodeAsUTF8(item); break;
    case KIND_INT64: ((int64_t *)values)[k] = (int64_t)py.LongAsLong(item); break;
    }
    return py.ErrOccurred() == NULL;
}

fmi2Status get_values(fmi2Component c, Call call, const char *method, Kind kind, const fmi2ValueReference vr[],
                      size_t n, void *values, size_t n_values) {
    Frame f;
    Instance *inst = allowed(c, call);
    if (inst == NULL) return fmi2Error;
    if (n == 0) return fmi2OK;
    if (vr == NULL || values == NULL) return refuse(inst, call, "the value reference or value array is NULL");
    char why[512];
    const char *bad = variables_problem(vr, n, kind, 0, inst->state, why, sizeof why);
    if (bad == NULL) bad = count_problem(vr, n, n_values, why, sizeof why);
    if (bad != NULL) return refuse(inst, call, bad);
    if (!enter_python(inst, call, &f)) return fmi2Error;
    PyObject *list = references(vr, n);
    PyObject *answer = list ? py.CallMethod(inst->slave, method, "(O)", list) : NULL;
    if (list) py.DecRef(list);
    fmi2Status status = fmi2OK;
    if (answer != NULL && !error_pending()) {
        int ok = py.ListSize(answer) == (Py_ssize_t)n_values;
        for (size_t k = 0; ok && k < n_values; k++) ok = read_item(kind, py.ListGetItem(answer, (Py_ssize_t)k), values, k);
        if (!ok) {
            char text[2048] = "the answer is not a list of the right length";
            if (py.ErrOccurred()) exception_message(text, sizeof text);
            log_error(inst, "%s failed: the FMU's Python code gave no usable values (%s)", call_name(call), text);
            status = fmi2Error;
        } else if (kind == KIND_STRING) { /* the texts live as long as the list: kept until the next call */
            if (inst->strings) py.DecRef(inst->strings);
            inst->strings = answer;
            py.IncRef(answer);
        }
    }
    return end(&f, slave_settle(inst, call_name(call), answer, status));
}

/* The k-th value as a Python object (a new reference), or NULL. */
PyObject *value_object(Kind kind, const void *values, size_t k) {
    switch (kind) {
    case KIND_REAL: return py.FloatFromDouble(((const fmi2Real *)values)[k]);
    case KIND_INTEGER: return py.LongFromLong(((const fmi2Integer *)values)[k]);
#ifdef FMI3_BINARY
    case KIND_BOOLEAN: return py.BoolFromLong(((const bool *)values)[k]);
#else
    case KIND_BOOLEAN: return py.BoolFromLong(((const fmi2Boolean *)values)[k] != fmi2False);
#endif
    case KIND_STRING: return py.UnicodeFromString(((const fmi2String *)values)[k]);
    case KIND_INT64: return py.LongFromLong((long)((const int64_t *)values)[k]);
    }
    return NULL;
}

fmi2Status set_values(fmi2Component c, Call call, const char *method, Kind kind, const fmi2ValueReference vr[],
                      size_t n, const void *values, size_t n_values) {
    Frame f;
    Instance *inst = allowed(c, call);
    if (inst == NULL) return fmi2Error;
    if (n == 0) return fmi2OK;
    if (vr == NULL || values == NULL) return refuse(inst, call, "the value reference or value array is NULL");
    for (size_t k = 0; kind == KIND_STRING && k < n_values; k++)
        if (((const fmi2String *)values)[k] == NULL) return refuse(inst, call, "a string value is NULL");
    char why[512];
    const char *bad = variables_problem(vr, n, kind, 1, inst->state, why, sizeof why);
    if (bad == NULL) bad = count_problem(vr, n, n_values, why, sizeof why);
    if (bad != NULL) return refuse(inst, call, bad);
    if (!enter_python(inst, call, &f)) return fmi2Error;
    PyObject *list = references(vr, n), *items = py.ListNew((Py_ssize_t)n_values);
    for (size_t k = 0; items != NULL && k < n_values; k++) {
        PyObject *item = value_object(kind, values, k);
        if (item == NULL || py.ListSetItem(items, (Py_ssize_t)k, item) != 0) {
            py.DecRef(items);
            items = NULL;
        }
    }
    PyObject *r = list && items ? py.CallMethod(inst->slave, method, "(OO)", list, items) : NULL;
    if (list) py.DecRef(list);
    if (items) py.DecRef(items);
    return end(&f, slave_settle(inst, call_name(call), r, fmi2OK));
}

