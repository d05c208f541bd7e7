/* The C library of a Python host that frees its FMU instances only at exit, after the Python has been finalised.
 *
 * Build:  cc -shared -fPIC -I<fmpy>/c-code exit_time_host.c -ldl -o exit_time_host.so
 * Use:    from Python (ctypes; tests/exit_time_host.py, for tests/test_exit_time_host.py), either
 *         exit_time_host_start(MODE, PENDULUM_FOLDER, PENDULUM_GUID, PID_FOLDER, PID_GUID, VR_FIDELITY, FIDELITY),
 *         or, for instances the script made itself (through fmpy, with fmpy's logger),
 *         exit_time_host_begin(MODE) before it instantiates, exit_time_host_hold(LABEL, INSTANCE, TERMINATE, FREE)
 *         for each instance and exit_time_host_end() after; then let the script end normally.
 *
 * exit_time_host_start loads the binaries of the two unzipped FMUs (FemPendulum, PidController), instantiates
 * (with this library's logger, which prints to stderr), initialises (the pendulum with model.fidelity = FIDELITY)
 * and steps one instance of each (10 steps of 1 ms), and leaves them alive: they are terminated and freed at
 * exit, as a C/C++ library's exit-time destructors would. exit_time_host_hold keeps an instance of an FMI 2.0 or
 * FMI 3.0 binary (fmi2Terminate and fmi3Terminate, fmi2FreeInstance and fmi3FreeInstance have the same C
 * signature) to be terminated and freed at exit in the same way. MODE says from where:
 *   "atexit-last"   an atexit() handler registered after the instances exist (it runs before any handler the
 *                   FMU binaries registered while instantiating),
 *   "atexit-first"  an atexit() handler registered before (it runs after theirs),
 *   "destructor"    this library's __attribute__((destructor)), run when the dynamic linker finalises the
 *                   libraries, after every atexit() handler.
 * A Python script's interpreter is finalised when the script ends, before exit() runs any of these. The
 * handler prints one line to stderr:
 *   exit-time-host <atexit|destructor>: python initialised <0|1|-1>; PidController terminate <status> freed; ...
 * (-1: no Py_IsInitialized in the process). exit_time_host_start returns 0, or the number of the step that
 * failed (1 to 4); exit_time_host_begin 0, or 1 for an unknown MODE; exit_time_host_hold 0, or 1 when it holds
 * too many instances. */
#include <dlfcn.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"

typedef int TerminateFunction(void *instance);   /* fmi2Terminate or fmi3Terminate */
typedef void FreeFunction(void *instance);       /* fmi2FreeInstance or fmi3FreeInstance */

typedef struct {
    char label[64];
    void *component;
    TerminateFunction *terminate;
    FreeFunction *free_instance;
} Held;

#define MAX_HELD 4
static Held held[MAX_HELD];
static int n_held = 0;
static int free_in_destructor = 0, register_last = 0;

static void log_message(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status, fmi2String category,
                        fmi2String message, ...) {
    (void)env;
    va_list args;
    va_start(args, message);
    fprintf(stderr, "[%s status %d %s] ", name ? name : "", (int)status, category ? category : "");
    vfprintf(stderr, message, args);
    fputc('\n', stderr);
    va_end(args);
}

static const fmi2CallbackFunctions callbacks = {log_message, calloc, free, NULL, NULL};

static int python_initialised(void) {
    int (*is_initialised)(void) = (int (*)(void))dlsym(RTLD_DEFAULT, "Py_IsInitialized");
    return is_initialised ? is_initialised() : -1;
}

static void free_held(const char *when) {
    char line[512];
    int at = snprintf(line, sizeof line, "exit-time-host %s: python initialised %d", when, python_initialised());
    for (int k = n_held - 1; k >= 0; k--) { /* the last instantiated first, as destructors run */
        int status = (int)held[k].terminate(held[k].component);
        held[k].free_instance(held[k].component);
        at += snprintf(line + at, sizeof line - (size_t)at, "; %s terminate %d freed", held[k].label, status);
    }
    fprintf(stderr, "%s\n", line); /* one line, after the FMUs' own log messages */
    fflush(stderr);
    n_held = 0;
}

static void at_exit(void) { free_held("atexit"); }

__attribute__((destructor)) static void at_unload(void) {
    if (free_in_destructor && n_held > 0) free_held("destructor");
}

/* Load, instantiate, initialise and step one FMU; keep the instance in held[]. */
static int start_one(const char *label, const char *folder, const char *guid, int fidelity_vr, int fidelity) {
    char binary[4096], resources[4096];
    snprintf(binary, sizeof binary, "%s/binaries/linux64/%s.so", folder, label);
    snprintf(resources, sizeof resources, "file://%s/resources", folder);
    void *lib = dlopen(binary, RTLD_NOW | RTLD_LOCAL); /* never closed: the instance outlives this call */
    if (lib == NULL) {
        fprintf(stderr, "cannot load %s: %s\n", binary, dlerror());
        return 1;
    }
    fmi2InstantiateTYPE *instantiate = (fmi2InstantiateTYPE *)dlsym(lib, "fmi2Instantiate");
    fmi2SetupExperimentTYPE *setup = (fmi2SetupExperimentTYPE *)dlsym(lib, "fmi2SetupExperiment");
    fmi2EnterInitializationModeTYPE *enter =
        (fmi2EnterInitializationModeTYPE *)dlsym(lib, "fmi2EnterInitializationMode");
    fmi2ExitInitializationModeTYPE *exit_init =
        (fmi2ExitInitializationModeTYPE *)dlsym(lib, "fmi2ExitInitializationMode");
    fmi2SetIntegerTYPE *set_integer = (fmi2SetIntegerTYPE *)dlsym(lib, "fmi2SetInteger");
    fmi2DoStepTYPE *do_step = (fmi2DoStepTYPE *)dlsym(lib, "fmi2DoStep");
    Held *h = &held[n_held];
    snprintf(h->label, sizeof h->label, "%s", label);
    h->terminate = (TerminateFunction *)dlsym(lib, "fmi2Terminate");
    h->free_instance = (FreeFunction *)dlsym(lib, "fmi2FreeInstance");
    if (!instantiate || !setup || !enter || !exit_init || !set_integer || !do_step || !h->terminate ||
        !h->free_instance) {
        fprintf(stderr, "%s lacks an fmi2 function\n", binary);
        return 1;
    }
    fmi2Component c = instantiate(label, fmi2CoSimulation, guid, resources, &callbacks, fmi2False, fmi2False);
    if (c == NULL) return 2;
    fmi2ValueReference vr = (fmi2ValueReference)fidelity_vr;
    fmi2Integer value = fidelity;
    if (setup(c, fmi2False, 0.0, 0.0, fmi2False, 0.0) != fmi2OK || enter(c) != fmi2OK ||
        (fidelity_vr >= 0 && set_integer(c, &vr, 1, &value) != fmi2OK) || exit_init(c) != fmi2OK)
        return 3;
    for (int k = 0; k < 10; k++)
        if (do_step(c, k * 1e-3, 1e-3, fmi2True) != fmi2OK) return 4;
    h->component = c;
    n_held++;
    return 0;
}

int exit_time_host_begin(const char *mode) {
    int first = strcmp(mode, "atexit-first") == 0;
    register_last = strcmp(mode, "atexit-last") == 0;
    free_in_destructor = strcmp(mode, "destructor") == 0;
    if (!first && !register_last && !free_in_destructor) return 1;
    if (first) atexit(at_exit);
    return 0;
}

int exit_time_host_hold(const char *label, void *component, void *terminate, void *free_instance) {
    if (n_held == MAX_HELD) return 1;
    Held *h = &held[n_held++];
    snprintf(h->label, sizeof h->label, "%s", label);
    h->component = component;
    h->terminate = (TerminateFunction *)terminate;
    h->free_instance = (FreeFunction *)free_instance;
    return 0;
}

void exit_time_host_end(void) {
    if (register_last) atexit(at_exit);
}

int exit_time_host_start(const char *mode, const char *pendulum, const char *pendulum_guid, const char *pid,
                         const char *pid_guid, int fidelity_vr, int fidelity) {
    if (exit_time_host_begin(mode) != 0) return 1;
    int failed = start_one("FemPendulum", pendulum, pendulum_guid, fidelity_vr, fidelity);
    if (!failed) failed = start_one("PidController", pid, pid_guid, -1, 0);
    exit_time_host_end();
    return failed;
}
