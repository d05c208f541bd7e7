/* The Python an FMU of this project runs in (Linux).
 *
 The FMU's binary does not link libpython. Finalising a Python from an exit
 * handler runs the extension modules' cleanup after their C++ statics are gone
 * (NGSolve's segfaults, docs/notes/fmu_layer.md), so this file makes sure a Python is
 * running before the slave is ever called, and never finalises the one it
 * starts:
 *
 *   1. a host that runs Python (fmpy, libcosimpy): nothing to do;
 *   2. otherwise load libpython globally: the one in FEM_PENDULUM_LIBPYTHON, else
 *      the one recorded at build time in resources/python_environment.txt;
 *   3. initialise it as the recorded interpreter (FEM_PENDULUM_PYTHON overrides),
 *      so that its environment's packages are importable, without signal handlers.
 *
 * Then resources/femp_preflight.py checks, before any physics is imported, that
 * the packages the FMU needs are there. Every Python function is looked up with
 * dlsym: this library must load in a process that has no libpython.
 */
#define _GNU_SOURCE
#include "python_api.h" /* Python.h first, as it asks */

#include <dlfcn.h>
#include <errno.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "python_runtime.h"

PythonApi py;

typedef struct {
    void **slot;
    const char *name;
} Binding;

#define BIND(field, symbol) {(void **)&py.field, symbol}

static const Binding bindings[] = {
    BIND(IsInitialized, "Py_IsInitialized"), BIND(GetVersion, "Py_GetVersion"),
    BIND(ConfigInitPythonConfig, "PyConfig_InitPythonConfig"), BIND(ConfigSetBytesString, "PyConfig_SetBytesString"),
    BIND(InitializeFromConfig, "Py_InitializeFromConfig"), BIND(ConfigClear, "PyConfig_Clear"),
    BIND(StatusException, "PyStatus_Exception"), BIND(EvalSaveThread, "PyEval_SaveThread"),
    BIND(GILStateEnsure, "PyGILState_Ensure"), BIND(GILStateRelease, "PyGILState_Release"),
    BIND(ImportModule, "PyImport_ImportModule"), BIND(CallMethod, "PyObject_CallMethod"),
    BIND(CallFunction, "PyObject_CallFunction"), BIND(Call, "PyObject_Call"),
    BIND(GetAttrString, "PyObject_GetAttrString"), BIND(HasAttrString, "PyObject_HasAttrString"),
    BIND(IsSubclass, "PyObject_IsSubclass"), BIND(IsTrue, "PyObject_IsTrue"), BIND(ObjectStr, "PyObject_Str"),
    BIND(IncRef, "Py_IncRef"), BIND(DecRef, "Py_DecRef"), BIND(DictNew, "PyDict_New"),
    BIND(DictSetItemString, "PyDict_SetItemString"), BIND(DictGetItemString, "PyDict_GetItemString"),
    BIND(DictNext, "PyDict_Next"), BIND(TupleNew, "PyTuple_New"), BIND(ListNew, "PyList_New"),
    BIND(ListSetItem, "PyList_SetItem"), BIND(ListGetItem, "PyList_GetItem"), BIND(ListSize, "PyList_Size"),
    BIND(ListInsert, "PyList_Insert"), BIND(SequenceContains, "PySequence_Contains"),
    BIND(SysGetObject, "PySys_GetObject"), BIND(LongFromUnsignedLong, "PyLong_FromUnsignedLong"),
    BIND(LongFromLong, "PyLong_FromLong"), BIND(LongAsLong, "PyLong_AsLong"),
    BIND(FloatFromDouble, "PyFloat_FromDouble"), BIND(FloatAsDouble, "PyFloat_AsDouble"),
    BIND(BoolFromLong, "PyBool_FromLong"), BIND(UnicodeFromString, "PyUnicode_FromString"),
    BIND(UnicodeAsUTF8, "PyUnicode_AsUTF8"), BIND(BytesFromStringAndSize, "PyBytes_FromStringAndSize"),
    BIND(BytesAsStringAndSize, "PyBytes_AsStringAndSize"), BIND(ErrOccurred, "PyErr_Occurred"),
    BIND(ErrFetch, "PyErr_Fetch"), BIND(ErrClear, "PyErr_Clear"), BIND(None, "_Py_NoneStruct"),
};

static int bind_api(char *why, size_t n) {
    for (size_t k = 0; k < sizeof bindings / sizeof bindings[0]; k++) {
        *bindings[k].slot = dlsym(RTLD_DEFAULT, bindings[k].name);
        if (*bindings[k].slot == NULL) {
            snprintf(why, n, "the loaded libpython has no %s", bindings[k].name);
            return 0;
        }
    }
    /* public from 3.13 on, private before */
    py.IsFinalizing = (int (*)(void))dlsym(RTLD_DEFAULT, "Py_IsFinalizing");
    if (py.IsFinalizing == NULL) py.IsFinalizing = (int (*)(void))dlsym(RTLD_DEFAULT, "_Py_IsFinalizing");
    return 1;
}

int python_alive(void) {
    return py.IsInitialized != NULL && py.IsInitialized() && !(py.IsFinalizing != NULL && py.IsFinalizing());
}

/* Whether a Python runs now, asked of the bound API or, before it is bound, of whatever libpython the process has. */
static int python_running(void) {
    if (py.IsInitialized != NULL) return python_alive();
    int (*initialised)(void) = (int (*)(void))dlsym(RTLD_DEFAULT, "Py_IsInitialized");
    int (*finalizing)(void) = (int (*)(void))dlsym(RTLD_DEFAULT, "Py_IsFinalizing");
    if (finalizing == NULL) finalizing = (int (*)(void))dlsym(RTLD_DEFAULT, "_Py_IsFinalizing");
    return initialised != NULL && initialised() && !(finalizing != NULL && finalizing());
}

static int python_has_run = 0; /* a Python ran in this process while this binary was loaded */

__attribute__((constructor)) static void note_host_python(void) {
    if (python_running()) __atomic_store_n(&python_has_run, 1, __ATOMIC_RELAXED);
}

int python_ended(void) {
    if (python_running()) {
        __atomic_store_n(&python_has_run, 1, __ATOMIC_RELAXED);
        return 0;
    }
    return __atomic_load_n(&python_has_run, __ATOMIC_RELAXED);
}

/* The value of `key=` in resources/python_environment.txt, or "" (written by fmi/builder.py). */
static void recorded(const char *resources, const char *key, char *value, size_t n) {
    char path[4096], line[4096];
    size_t len = strlen(key);
    value[0] = '\0';
    snprintf(path, sizeof path, "%s/python_environment.txt", resources);
    FILE *f = fopen(path, "r");
    if (f == NULL) return;
    while (fgets(line, sizeof line, f)) {
        if (strncmp(line, key, len) == 0 && line[len] == '=') {
            line[strcspn(line, "\r\n")] = '\0';
            snprintf(value, n, "%s", line + len + 1);
            break;
        }
    }
    fclose(f);
}

/* The value of a setting: the environment variable when set (returns 1), else what the FMU records (0). */
static int setting(const char *variable, const char *resources, const char *key, char *value, size_t n) {
    const char *env = getenv(variable);
    if (env != NULL && env[0] != '\0') {
        snprintf(value, n, "%s", env);
        return 1;
    }
    recorded(resources, key, value, n);
    return 0;
}

static int load_libpython(const char *resources, char *why, size_t n) {
    if (dlsym(RTLD_DEFAULT, "Py_IsInitialized") != NULL) return 1; /* the host has one (or preloaded it) */
    char lib[4096];
    int from_env = setting("FEM_PENDULUM_LIBPYTHON", resources, "libpython", lib, sizeof lib);
    if (lib[0] == '\0') {
        snprintf(why, n, "this host has no Python and the FMU records none: set FEM_PENDULUM_LIBPYTHON to the "
                 "libpython%d.%d shared library and FEM_PENDULUM_PYTHON to the python executable of an environment "
                 "with the FMU's requirements (resources/requirements.txt)", PY_MAJOR_VERSION, PY_MINOR_VERSION);
        return 0;
    }
    if (dlopen(lib, RTLD_NOW | RTLD_GLOBAL) == NULL) {
        const char *error = dlerror();
        if (from_env)
            snprintf(why, n, "the environment variable FEM_PENDULUM_LIBPYTHON = %s cannot be loaded (%s): set it to "
                     "the libpython%d.%d shared library of an environment with the FMU's requirements, or unset it "
                     "to use the one the FMU records; `fem-pendulum host-env` prints it for the environment it runs "
                     "in", lib, error, PY_MAJOR_VERSION, PY_MINOR_VERSION);
        else
            snprintf(why, n, "this host has no Python and the FMU cannot load %s (%s): set FEM_PENDULUM_LIBPYTHON "
                     "to the libpython%d.%d shared library and FEM_PENDULUM_PYTHON to the python executable of an "
                     "environment with the FMU's requirements (resources/requirements.txt); `fem-pendulum "
                     "host-env` prints both for the environment it runs in", lib, error, PY_MAJOR_VERSION,
                     PY_MINOR_VERSION);
        return 0;
    }
    return 1;
}

/* Starts the interpreter as the recorded (or FEM_PENDULUM_PYTHON's) executable, then releases the GIL. */
static int start_python(const char *resources, char *why, size_t n) {
    char version[16], executable[4096];
    snprintf(version, sizeof version, "%d.%d.", PY_MAJOR_VERSION, PY_MINOR_VERSION);
    if (strncmp(py.GetVersion(), version, strlen(version)) != 0) {
        snprintf(why, n, "the loaded libpython is version %.20s but this FMU's binary was built for %d.%d: point "
                 "FEM_PENDULUM_LIBPYTHON at a libpython%d.%d", py.GetVersion(), PY_MAJOR_VERSION,
                 PY_MINOR_VERSION, PY_MAJOR_VERSION, PY_MINOR_VERSION);
        return 0;
    }
    PyConfig config;
    py.ConfigInitPythonConfig(&config);
    config.install_signal_handlers = 0; /* the host owns its signals */
    config.parse_argv = 0;
    if (setting("FEM_PENDULUM_PYTHON", resources, "executable", executable, sizeof executable) &&
        access(executable, X_OK) != 0) {
        snprintf(why, n, "the environment variable FEM_PENDULUM_PYTHON = %s is not an executable file (%s): set it "
                 "to the python executable of an environment with the FMU's requirements, or unset it to use the "
                 "one the FMU records", executable, strerror(errno));
        py.ConfigClear(&config);
        return 0;
    }
    PyStatus status = {0};
    if (executable[0] != '\0') status = py.ConfigSetBytesString(&config, &config.program_name, executable);
    if (!py.StatusException(status)) status = py.InitializeFromConfig(&config);
    py.ConfigClear(&config);
    if (py.StatusException(status)) {
        snprintf(why, n, "Python did not start as %s: %s%s%s", executable[0] ? executable : "the host program",
                 status.func ? status.func : "", status.func ? ": " : "", status.err_msg ? status.err_msg : "");
        return 0;
    }
    py.EvalSaveThread();
    return 1;
}

/* The text of the pending Python exception (cleared), for a message. */
static void exception_text(const char *what, char *why, size_t n) {
    PyObject *type = NULL, *value = NULL, *trace = NULL;
    py.ErrFetch(&type, &value, &trace);
    PyObject *text = value ? py.ObjectStr(value) : NULL;
    const char *utf8 = text ? py.UnicodeAsUTF8(text) : NULL;
    snprintf(why, n, "%s: %s", what, utf8 ? utf8 : "unknown Python error");
    if (text) py.DecRef(text);
    if (type) py.DecRef(type);
    if (value) py.DecRef(value);
    if (trace) py.DecRef(trace);
}

/* Runs prepare(resources) of resources/femp_preflight.py; 1 when it found no problem. */
static int preflight(const char *resources, char *why, size_t n) {
    char path[4096];
    snprintf(path, sizeof path, "%s/femp_preflight.py", resources);
    FILE *f = fopen(path, "r");
    if (f == NULL) return 1; /* an FMU built without it: nothing to check */
    fclose(f);
    int ok = 0;
    PyGILState_STATE gil = py.GILStateEnsure();
    PyObject *runpy = py.ImportModule("runpy");
    PyObject *globals = runpy ? py.CallMethod(runpy, "run_path", "(s)", path) : NULL;
    PyObject *prepare = globals ? py.DictGetItemString(globals, "prepare") : NULL; /* borrowed */
    PyObject *problems = prepare ? py.CallFunction(prepare, "s", resources) : NULL;
    const char *text = problems ? py.UnicodeAsUTF8(problems) : NULL;
    if (text == NULL)
        exception_text("the FMU's preflight check (femp_preflight.py) failed", why, n);
    else if (text[0] != '\0')
        snprintf(why, n, "%s", text);
    else
        ok = 1;
    if (problems) py.DecRef(problems);
    if (globals) py.DecRef(globals);
    if (runpy) py.DecRef(runpy);
    py.GILStateRelease(gil);
    return ok;
}

static pthread_mutex_t starting = PTHREAD_MUTEX_INITIALIZER;

int python_prepare(const char *resources, char *why, size_t n) {
    pthread_mutex_lock(&starting); /* two instances created at once start one Python */
    int ready = load_libpython(resources, why, n) && bind_api(why, n) &&
                (py.IsInitialized() || start_python(resources, why, n));
    pthread_mutex_unlock(&starting);
    return ready && preflight(resources, why, n) ? 0 : 1;
}
