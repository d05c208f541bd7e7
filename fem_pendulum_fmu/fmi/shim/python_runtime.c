/* The Python an FMU of this project runs in (Linux).
 *
 * pythonfmu's binary does not link libpython and, when it finds no Python in
 * the process, starts one and finalises it when the process exits. Finalising
 * from an exit handler runs the extension modules' cleanup after their C++
 * statics are gone (NGSolve's segfaults, docs/fmu.md), so this file makes sure
 * a Python is running before pythonfmu's binary is ever called, and never
 * finalises the one it starts:
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
#include <Python.h>
#include <dlfcn.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "python_runtime.h"

typedef struct {
    int (*IsInitialized)(void);
    const char *(*GetVersion)(void);
    void (*ConfigInitPythonConfig)(PyConfig *);
    PyStatus (*ConfigSetBytesString)(PyConfig *, wchar_t **, const char *);
    PyStatus (*InitializeFromConfig)(const PyConfig *);
    void (*ConfigClear)(PyConfig *);
    int (*StatusException)(PyStatus);
    PyThreadState *(*EvalSaveThread)(void);
    PyGILState_STATE (*GILStateEnsure)(void);
    void (*GILStateRelease)(PyGILState_STATE);
    PyObject *(*ImportModule)(const char *);
    PyObject *(*CallMethod)(PyObject *, const char *, const char *, ...);
    PyObject *(*CallFunction)(PyObject *, const char *, ...);
    PyObject *(*DictGetItemString)(PyObject *, const char *);
    const char *(*UnicodeAsUTF8)(PyObject *);
    PyObject *(*ObjectStr)(PyObject *);
    void (*ErrFetch)(PyObject **, PyObject **, PyObject **);
    void (*DecRef)(PyObject *);
} PythonApi;

static PythonApi py;

static int bind(void **slot, const char *name, char *why, size_t n) {
    *slot = dlsym(RTLD_DEFAULT, name);
    if (*slot == NULL) snprintf(why, n, "the loaded libpython has no %s", name);
    return *slot != NULL;
}

static int bind_api(char *why, size_t n) {
    return bind((void **)&py.IsInitialized, "Py_IsInitialized", why, n) &&
           bind((void **)&py.GetVersion, "Py_GetVersion", why, n) &&
           bind((void **)&py.ConfigInitPythonConfig, "PyConfig_InitPythonConfig", why, n) &&
           bind((void **)&py.ConfigSetBytesString, "PyConfig_SetBytesString", why, n) &&
           bind((void **)&py.InitializeFromConfig, "Py_InitializeFromConfig", why, n) &&
           bind((void **)&py.ConfigClear, "PyConfig_Clear", why, n) &&
           bind((void **)&py.StatusException, "PyStatus_Exception", why, n) &&
           bind((void **)&py.EvalSaveThread, "PyEval_SaveThread", why, n) &&
           bind((void **)&py.GILStateEnsure, "PyGILState_Ensure", why, n) &&
           bind((void **)&py.GILStateRelease, "PyGILState_Release", why, n) &&
           bind((void **)&py.ImportModule, "PyImport_ImportModule", why, n) &&
           bind((void **)&py.CallMethod, "PyObject_CallMethod", why, n) &&
           bind((void **)&py.CallFunction, "PyObject_CallFunction", why, n) &&
           bind((void **)&py.DictGetItemString, "PyDict_GetItemString", why, n) &&
           bind((void **)&py.UnicodeAsUTF8, "PyUnicode_AsUTF8", why, n) &&
           bind((void **)&py.ObjectStr, "PyObject_Str", why, n) &&
           bind((void **)&py.ErrFetch, "PyErr_Fetch", why, n) &&
           bind((void **)&py.DecRef, "Py_DecRef", why, n);
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

static void setting(const char *variable, const char *resources, const char *key, char *value, size_t n) {
    const char *env = getenv(variable);
    if (env != NULL && env[0] != '\0')
        snprintf(value, n, "%s", env);
    else
        recorded(resources, key, value, n);
}

static int load_libpython(const char *resources, char *why, size_t n) {
    if (dlsym(RTLD_DEFAULT, "Py_IsInitialized") != NULL) return 1; /* the host has one (or preloaded it) */
    char lib[4096];
    setting("FEM_PENDULUM_LIBPYTHON", resources, "libpython", lib, sizeof lib);
    if (lib[0] == '\0') {
        snprintf(why, n, "this host has no Python and the FMU records none: set FEM_PENDULUM_LIBPYTHON to the "
                 "libpython%d.%d shared library and FEM_PENDULUM_PYTHON to the python executable of an environment "
                 "with the FMU's requirements (resources/requirements.txt)", PY_MAJOR_VERSION, PY_MINOR_VERSION);
        return 0;
    }
    if (dlopen(lib, RTLD_NOW | RTLD_GLOBAL) == NULL) {
        snprintf(why, n, "this host has no Python and the FMU cannot load %s (%s): set FEM_PENDULUM_LIBPYTHON to "
                 "the libpython%d.%d shared library and FEM_PENDULUM_PYTHON to the python executable of an "
                 "environment with the FMU's requirements (resources/requirements.txt); `fem-pendulum host-env` "
                 "prints both for the environment it runs in", lib, dlerror(), PY_MAJOR_VERSION, PY_MINOR_VERSION);
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
    setting("FEM_PENDULUM_PYTHON", resources, "executable", executable, sizeof executable);
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
