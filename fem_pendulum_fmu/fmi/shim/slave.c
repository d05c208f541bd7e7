/* The Python slave object behind an instance: creating it, calling it, its messages.
 *
 * Every Python exception is caught here and becomes fmi2Error with its text in the log: nothing a
 * host sends can reach fmi2Fatal. The slave reports refused input during a call through
 * fem_pendulum_report_error (ctypes; fmi/fmi_logging.py), which also makes the call answer fmi2Error and is
 * logged whether or not debug logging is on, as errors should be. */
#include "python_api.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "python_runtime.h"
#include "slave.h"

#ifdef FMI3_BINARY
#define SLAVE_BASE "pythonfmu3's Fmi3Slave" /* what the entry module's slave class derives from, for messages */
#else
#define SLAVE_BASE "pythonfmu's Fmi2Slave"
#endif

static __thread int error_reported = 0;
static __thread char error_message[4096];

FMI2_Export void fem_pendulum_report_error(const char *message) {
    error_reported = 1;
    snprintf(error_message, sizeof error_message, "%s", message ? message : "");
}

const char *take_reported_error(void) {
    if (!error_reported) return NULL;
    error_reported = 0;
    return error_message;
}

void clear_reported_error(void) { error_reported = 0; }

int error_pending(void) { return error_reported; }

void log_to_host(const fmi2CallbackFunctions *callbacks, const char *instance, fmi2Status status,
                 const char *category, const char *message) {
    if (python_ended()) return; /* the logger may be Python code: the call's status says enough */
    char format[8192];
    size_t k = 0;
    for (const char *m = message; *m && k + 2 < sizeof format; m++) {
        if (*m == '%') format[k++] = '%';
        format[k++] = *m;
    }
    format[k] = '\0';
    if (callbacks != NULL && callbacks->logger != NULL)
        callbacks->logger(callbacks->componentEnvironment, instance, status, category, format);
    else
        fprintf(stderr, "%s: %s\n", instance ? instance : "FMU", message);
}

void log_error(Instance *inst, const char *fmt, ...) {
    char message[4096];
    va_list args;
    va_start(args, fmt);
    vsnprintf(message, sizeof message, fmt, args);
    va_end(args);
    log_to_host(&inst->callbacks, inst->name, fmi2Error, "logStatusError", message);
}

void exception_message(char *text, size_t n) {
    PyObject *type = NULL, *value = NULL, *trace = NULL;
    py.ErrFetch(&type, &value, &trace);
    PyObject *type_name = type ? py.GetAttrString(type, "__name__") : NULL;
    PyObject *value_text = value ? py.ObjectStr(value) : NULL;
    const char *name = type_name ? py.UnicodeAsUTF8(type_name) : NULL;
    const char *utf8 = value_text ? py.UnicodeAsUTF8(value_text) : NULL;
    snprintf(text, n, "%s: %s", name ? name : "Exception", utf8 ? utf8 : "(no message)");
    py.ErrClear(); /* whatever the calls above raised */
    PyObject *refs[] = {type_name, value_text, type, value, trace};
    for (size_t k = 0; k < sizeof refs / sizeof refs[0]; k++)
        if (refs[k]) py.DecRef(refs[k]);
}

/* ------------------------------------------------------------------ messages */

static int category_on(const Instance *inst, const char *category) {
    if (!inst->logging_on) return 0;
    if (inst->n_categories == 0) return 1;
    for (size_t k = 0; k < inst->n_categories; k++)
        if (category != NULL && strcmp(inst->categories[k], category) == 0) return 1;
    return 0;
}

static void forward_message(Instance *inst, PyObject *message) {
    PyObject *status = py.GetAttrString(message, "status");
    PyObject *category = py.GetAttrString(message, "category");
    PyObject *text = py.GetAttrString(message, "msg");
    long level = status ? py.LongAsLong(status) : (long)fmi2OK;
    const char *cat = category ? py.UnicodeAsUTF8(category) : NULL; /* NULL for None, with an error */
    const char *utf8 = text ? py.UnicodeAsUTF8(text) : NULL;
    py.ErrClear();
    if (level < fmi2OK || level > fmi2Pending) level = fmi2OK;
    /* a Discard, an Error or a Fatal reaches the host whether or not debug logging is on, as errors do */
    if (utf8 != NULL && (level >= fmi2Discard || category_on(inst, cat)))
        log_to_host(&inst->callbacks, inst->name, (fmi2Status)level, cat ? cat : "logAll", utf8);
    PyObject *refs[] = {status, category, text};
    for (size_t k = 0; k < 3; k++)
        if (refs[k]) py.DecRef(refs[k]);
}

/* Forward and empty the slave's queue of log messages. */
static void drain_log_queue(Instance *inst) {
    if (inst->log_queue == NULL) return;
    Py_ssize_t n = py.ListSize(inst->log_queue);
    if (n <= 0) {
        py.ErrClear();
        return;
    }
    for (Py_ssize_t k = 0; k < n; k++) {
        PyObject *message = py.ListGetItem(inst->log_queue, k); /* borrowed */
        if (message) forward_message(inst, message);
    }
    PyObject *cleared = py.CallMethod(inst->log_queue, "clear", NULL);
    if (cleared) py.DecRef(cleared);
    py.ErrClear();
}

fmi2Status slave_settle(Instance *inst, const char *call, PyObject *result, fmi2Status ok) {
    fmi2Status status = ok;
    char text[4096];
    if (result == NULL) {
        exception_message(text, sizeof text);
        status = fmi2Error;
    } else {
        py.DecRef(result);
    }
    drain_log_queue(inst);
    if (result == NULL) log_error(inst, "%s failed in the FMU's Python code (%s)", call, text);
    const char *reported = take_reported_error();
    if (reported != NULL) {
        log_error(inst, "%s", reported);
        if (status < fmi2Error) status = fmi2Error;
    }
    return status;
}

/* ------------------------------------------------------------------ creation */

/* The first line of resources/slavemodule.txt (written by pythonfmu's builder). */
static int module_name(const char *resources, char *name, size_t n, char *why, size_t wn) {
    char path[4096];
    snprintf(path, sizeof path, "%s/slavemodule.txt", resources);
    FILE *f = fopen(path, "r");
    if (f == NULL || fgets(name, (int)n, f) == NULL) {
        snprintf(why, wn, "cannot read %s: the FMU's resources are incomplete", path);
        if (f) fclose(f);
        return 0;
    }
    fclose(f);
    name[strcspn(name, "\r\n")] = '\0';
    return name[0] != '\0';
}

static int put_on_path(const char *resources, char *why, size_t n) {
    PyObject *path = py.SysGetObject("path"); /* borrowed */
    PyObject *folder = py.UnicodeFromString(resources);
    int ok = path != NULL && folder != NULL;
    if (ok && py.SequenceContains(path, folder) != 1) ok = py.ListInsert(path, 0, folder) == 0;
    if (folder) py.DecRef(folder);
    if (!ok) {
        char text[2048];
        exception_message(text, sizeof text);
        snprintf(why, n, "cannot put %s on Python's sys.path (%s)", resources, text);
    }
    return ok;
}

/* The slave class that `module` defines (a new reference): a class whose __module__ is the module and
 * that has pythonfmu's Fmi2Slave interface (do_step, _get_log_queue). Not an identity test against
 * pythonfmu.Fmi2Slave: each extracted FMU carries its own copy of pythonfmu, and the process may hold
 * another one, so the base class in the slave's MRO need not be the object `import pythonfmu` gives. */
static PyObject *find_class(PyObject *module, const char *name, char *why, size_t n) {
    PyObject *items = py.GetAttrString(module, "__dict__");
    PyObject *found = NULL, *key, *value;
    Py_ssize_t pos = 0;
    while (items && found == NULL && py.DictNext(items, &pos, &key, &value)) {
        if (!py.HasAttrString(value, "__mro__") || !py.HasAttrString(value, "do_step") ||
            !py.HasAttrString(value, "_get_log_queue"))
            continue;
        PyObject *home = py.GetAttrString(value, "__module__");
        const char *text = home ? py.UnicodeAsUTF8(home) : NULL;
        if (text != NULL && strcmp(text, name) == 0) {
            found = value;
            py.IncRef(found);
        }
        py.ErrClear();
        if (home) py.DecRef(home);
    }
    if (found == NULL) {
        char text[2048] = "";
        if (py.ErrOccurred()) exception_message(text, sizeof text);
        snprintf(why, n, "module %s defines no FMU slave class (a subclass of %s) %s", name, SLAVE_BASE, text);
    }
    if (items) py.DecRef(items);
    return found;
}

static int new_slave_object(Instance *inst, char *why, size_t n) {
    PyObject *args = py.TupleNew(0);
    PyObject *slave = args ? py.Call(inst->cls, args, inst->kwargs) : NULL;
    if (args) py.DecRef(args);
    PyObject *queue = slave ? py.CallMethod(slave, "_get_log_queue", NULL) : NULL;
    if (queue == NULL) {
        char text[2048];
        exception_message(text, sizeof text);
        snprintf(why, n, "the FMU's Python slave could not be created (%s)", text);
        if (slave) py.DecRef(slave);
        return 1;
    }
    inst->slave = slave;
    inst->log_queue = queue;
    return 0;
}

int slave_create(Instance *inst, const char *resources, fmi2Boolean visible, char *why, size_t n) {
    char name[512];
    if (!module_name(resources, name, sizeof name, why, n) || !put_on_path(resources, why, n)) return 1;
    PyObject *module = py.ImportModule(name);
    if (module == NULL) {
        char text[2048];
        exception_message(text, sizeof text);
        snprintf(why, n, "cannot import the FMU's entry module %s (%s)", name, text);
        return 1;
    }
    inst->cls = find_class(module, name, why, n);
    py.DecRef(module);
    if (inst->cls == NULL) return 1;
    PyObject *kwargs = py.DictNew();
    PyObject *values[] = {py.UnicodeFromString(inst->name), py.UnicodeFromString(resources),
                          py.BoolFromLong(visible == fmi2True)};
    const char *keys[] = {"instance_name", "resources", "visible"};
    int ok = kwargs != NULL;
    for (size_t k = 0; k < 3; k++) {
        ok = ok && values[k] != NULL && py.DictSetItemString(kwargs, keys[k], values[k]) == 0;
        if (values[k]) py.DecRef(values[k]);
    }
    if (!ok) {
        exception_message(why, n);
        if (kwargs) py.DecRef(kwargs);
        return 1;
    }
    inst->kwargs = kwargs;
    return new_slave_object(inst, why, n);
}

static void drop(PyObject **ref) {
    if (*ref) py.DecRef(*ref);
    *ref = NULL;
}

/* release() the slave object and drop it with its queue and strings. */
static void release_slave_object(Instance *inst) {
    if (inst->slave != NULL && py.HasAttrString(inst->slave, "release")) {
        PyObject *r = py.CallMethod(inst->slave, "release", NULL);
        if (r == NULL) {
            char text[2048];
            exception_message(text, sizeof text);
            log_to_host(&inst->callbacks, inst->name, fmi2Warning, "logStatusWarning", text);
        } else {
            py.DecRef(r);
        }
    }
    drain_log_queue(inst);
    clear_reported_error();
    drop(&inst->strings);
    drop(&inst->log_queue);
    drop(&inst->slave);
}

int slave_rebuild(Instance *inst, char *why, size_t n) {
    release_slave_object(inst);
    return new_slave_object(inst, why, n);
}

void slave_release(Instance *inst) {
    release_slave_object(inst);
    drop(&inst->kwargs);
    drop(&inst->cls);
}

/* The pendulum's `communication_time` is its model's time, or the start time before a model exists. */
void take_slave_time(Instance *inst, double fallback) {
    PyObject *t = py.HasAttrString(inst->slave, "communication_time")
                      ? py.GetAttrString(inst->slave, "communication_time") : NULL;
    double value = t ? py.FloatAsDouble(t) : fallback;
    if (t) py.DecRef(t);
    if (py.ErrOccurred()) {
        py.ErrClear();
        value = fallback;
    }
    inst->time = value;
}

int slave_flag(Instance *inst, const char *name) {
    PyObject *v = py.HasAttrString(inst->slave, name) ? py.GetAttrString(inst->slave, name) : NULL;
    int flag = v ? py.IsTrue(v) : 0;
    if (v) py.DecRef(v);
    if (py.ErrOccurred()) py.ErrClear();
    return flag == 1;
}

PyObject *references(const fmi2ValueReference vr[], size_t n) {
    PyObject *list = py.ListNew((Py_ssize_t)n);
    for (size_t k = 0; list != NULL && k < n; k++) {
        PyObject *item = py.LongFromUnsignedLong(vr[k]);
        if (item == NULL || py.ListSetItem(list, (Py_ssize_t)k, item) != 0) drop(&list);
    }
    return list;
}
