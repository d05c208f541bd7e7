/* FMI 2.0 front binary of this project's FMUs (Linux): <id>.so in front of pythonfmu's <id>_core.so.
 *
 * It forwards every fmi2 call to pythonfmu 0.7.0's binary and adds what that
 * binary lacks (docs/fmu.md):
 *
 * - Python first: before the core binary is loaded, python_runtime.c makes sure
 *   a Python runs in the process (the host's, or the environment recorded at
 *   build time, never finalised) and that the FMU's packages are importable;
 *   otherwise fmi2Instantiate returns NULL with a log message saying what to do.
 * - A clean exit: the core keeps its Python state in a global shared_ptr that
 *   both its static destructor and its ELF destructor release, and glibc never
 *   unloads it (STB_GNU_UNIQUE symbols), so at exit() the second release reads
 *   the block the first one freed. An exit handler registered here after the
 *   core is loaded runs before both and releases the state through the core's
 *   own finalizePythonInterpreter; the two later releases then find it empty.
 * - FMU states checked: pythonfmu dereferences whatever pointer a host passes as
 *   a state (a host that passes the state where its address is due crashed in
 *   fmi2FreeFMUstate). The front binary keeps the states it handed out, refuses
 *   anything else with fmi2Error, sets a freed state to NULL and frees what a
 *   host forgot at fmi2FreeInstance.
 * - fmi2Error: pythonfmu can only answer OK, Discard or Fatal. The slave reports
 *   refused input through fem_pendulum_report_error (ctypes) during the call;
 *   the call then answers fmi2Error and the message reaches the host's logger
 *   whether or not debug logging is on, as errors should.
 */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"
#include "python_runtime.h"

typedef struct {
    fmi2Component core;
    fmi2CallbackFunctions callbacks;
    char *name;
    fmi2FMUstate *states; /* the FMU states handed out and not yet freed */
    size_t n_states, capacity;
} Instance;

static void *core = NULL;
static __thread int error_reported = 0;
static __thread char error_message[4096];

FMI2_Export void fem_pendulum_report_error(const char *message) {
    error_reported = 1;
    snprintf(error_message, sizeof error_message, "%s", message ? message : "");
}

static void release_core_python_state(void) {
    void (*release)(void) = (void (*)(void))dlsym(core, "finalizePythonInterpreter");
    if (release != NULL) release();
}

/* <folder of this library>/<its name without .so>_core.so, loaded once. */
static void *load_core(char *why, size_t n) {
    if (core != NULL) return core;
    Dl_info info;
    char path[4096];
    if (dladdr((void *)&load_core, &info) == 0 || info.dli_fname == NULL) {
        snprintf(why, n, "the FMU's binary cannot find its own path");
        return NULL;
    }
    size_t len = strlen(info.dli_fname);
    if (len < 3 || len + 6 > sizeof path || strcmp(info.dli_fname + len - 3, ".so") != 0) {
        snprintf(why, n, "unexpected name of the FMU's binary: %s", info.dli_fname);
        return NULL;
    }
    snprintf(path, sizeof path, "%.*s_core.so", (int)(len - 3), info.dli_fname);
    core = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (core == NULL) {
        snprintf(why, n, "cannot load %s: %s", path, dlerror());
        return NULL;
    }
    atexit(release_core_python_state); /* registered after the core's statics: runs before them */
    return core;
}

static void *core_symbol(const char *name) { return core ? dlsym(core, name) : NULL; }

/* The message is the logger's format string (FMI 2.0): every '%' doubled, no arguments. */
static void log_error(const fmi2CallbackFunctions *callbacks, fmi2String instance, const char *message) {
    char format[2 * sizeof error_message];
    size_t k = 0;
    for (const char *m = message; *m && k + 2 < sizeof format; m++) {
        if (*m == '%') format[k++] = '%';
        format[k++] = *m;
    }
    format[k] = '\0';
    if (callbacks != NULL && callbacks->logger != NULL)
        callbacks->logger(callbacks->componentEnvironment, instance, fmi2Error, "logStatusError", format);
    else
        fprintf(stderr, "%s: %s\n", instance ? instance : "FMU", message);
}

static fmi2Status settle(Instance *inst, fmi2Status status) {
    if (error_reported) {
        error_reported = 0;
        log_error(&inst->callbacks, inst->name, error_message);
        if (status < fmi2Error) return fmi2Error;
    }
    return status;
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

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String guid,
                              fmi2String resourceLocation, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn) {
    char why[4096] = "", resources[4096];
    if (functions == NULL || functions->logger == NULL) { /* FMI 2.0 requires both; pythonfmu would crash */
        log_error(NULL, instanceName, "fmi2Instantiate refused: the host passed no callback functions or no logger");
        return NULL;
    }
    uri_to_path(resourceLocation ? resourceLocation : "", resources, sizeof resources);
    if (python_prepare(resources, why, sizeof why) != 0 || load_core(why, sizeof why) == NULL) {
        log_error(functions, instanceName, why);
        return NULL;
    }
    Instance *inst = calloc(1, sizeof *inst);
    fmi2InstantiateTYPE *f = (fmi2InstantiateTYPE *)core_symbol("fmi2Instantiate");
    error_reported = 0;
    if (inst == NULL || f == NULL ||
        (inst->core = f(instanceName, fmuType, guid, resourceLocation, functions, visible, loggingOn)) == NULL) {
        if (error_reported) log_error(functions, instanceName, error_message);
        error_reported = 0;
        log_error(functions, instanceName, "fmi2Instantiate failed in the FMU's Python code; instantiate with "
                  "logging on for pythonfmu's messages");
        free(inst);
        return NULL;
    }
    inst->callbacks = *functions;
    inst->name = strdup(instanceName ? instanceName : "");
    return inst;
}

static fmi2Status free_core_state(Instance *inst, fmi2FMUstate state) {
    fmi2FreeFMUstateTYPE *f = (fmi2FreeFMUstateTYPE *)core_symbol("fmi2FreeFMUstate");
    return f ? f(inst->core, &state) : fmi2Error;
}

void fmi2FreeInstance(fmi2Component c) {
    Instance *inst = (Instance *)c;
    if (inst == NULL) return;
    for (size_t k = 0; k < inst->n_states; k++) free_core_state(inst, inst->states[k]);
    fmi2FreeInstanceTYPE *f = (fmi2FreeInstanceTYPE *)core_symbol("fmi2FreeInstance");
    if (f) f(inst->core);
    free(inst->states);
    free(inst->name);
    free(inst);
}

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }

const char *fmi2GetVersion(void) { return fmi2Version; }

#define FORWARD(name, params, args)                                    \
    fmi2Status name params {                                           \
        Instance *inst = (Instance *)c;                                \
        name##TYPE *f = (name##TYPE *)core_symbol(#name);              \
        if (inst == NULL || f == NULL) return fmi2Error;               \
        error_reported = 0;                                            \
        return settle(inst, f args);                                   \
    }

FORWARD(fmi2SetDebugLogging, (fmi2Component c, fmi2Boolean on, size_t n, const fmi2String categories[]),
        (inst->core, on, n, categories))
FORWARD(fmi2SetupExperiment, (fmi2Component c, fmi2Boolean tolDefined, fmi2Real tol, fmi2Real start,
        fmi2Boolean stopDefined, fmi2Real stop), (inst->core, tolDefined, tol, start, stopDefined, stop))
FORWARD(fmi2EnterInitializationMode, (fmi2Component c), (inst->core))
FORWARD(fmi2ExitInitializationMode, (fmi2Component c), (inst->core))
FORWARD(fmi2Terminate, (fmi2Component c), (inst->core))
FORWARD(fmi2Reset, (fmi2Component c), (inst->core))
FORWARD(fmi2GetReal, (fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real v[]), (inst->core, vr, n, v))
FORWARD(fmi2GetInteger, (fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Integer v[]),
        (inst->core, vr, n, v))
FORWARD(fmi2GetBoolean, (fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Boolean v[]),
        (inst->core, vr, n, v))
FORWARD(fmi2GetString, (fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2String v[]),
        (inst->core, vr, n, v))
FORWARD(fmi2SetReal, (fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Real v[]),
        (inst->core, vr, n, v))
FORWARD(fmi2SetInteger, (fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer v[]),
        (inst->core, vr, n, v))
FORWARD(fmi2SetBoolean, (fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Boolean v[]),
        (inst->core, vr, n, v))
FORWARD(fmi2SetString, (fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2String v[]),
        (inst->core, vr, n, v))
FORWARD(fmi2GetDirectionalDerivative, (fmi2Component c, const fmi2ValueReference u[], size_t nu,
        const fmi2ValueReference z[], size_t nz, const fmi2Real dv[], fmi2Real dz[]),
        (inst->core, u, nu, z, nz, dv, dz))
FORWARD(fmi2SetRealInputDerivatives, (fmi2Component c, const fmi2ValueReference vr[], size_t n,
        const fmi2Integer order[], const fmi2Real value[]), (inst->core, vr, n, order, value))
FORWARD(fmi2GetRealOutputDerivatives, (fmi2Component c, const fmi2ValueReference vr[], size_t n,
        const fmi2Integer order[], fmi2Real value[]), (inst->core, vr, n, order, value))
FORWARD(fmi2DoStep, (fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean noSetPrior), (inst->core, t, h, noSetPrior))
FORWARD(fmi2CancelStep, (fmi2Component c), (inst->core))
FORWARD(fmi2GetStatus, (fmi2Component c, const fmi2StatusKind s, fmi2Status *value), (inst->core, s, value))
FORWARD(fmi2GetRealStatus, (fmi2Component c, const fmi2StatusKind s, fmi2Real *value), (inst->core, s, value))
FORWARD(fmi2GetIntegerStatus, (fmi2Component c, const fmi2StatusKind s, fmi2Integer *value), (inst->core, s, value))
FORWARD(fmi2GetBooleanStatus, (fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value), (inst->core, s, value))
FORWARD(fmi2GetStringStatus, (fmi2Component c, const fmi2StatusKind s, fmi2String *value), (inst->core, s, value))

/* ----------------------------------------------------------------- FMU states */

static int remember(Instance *inst, fmi2FMUstate state) {
    if (inst->n_states == inst->capacity) {
        size_t capacity = inst->capacity ? 2 * inst->capacity : 8;
        fmi2FMUstate *grown = realloc(inst->states, capacity * sizeof *grown);
        if (grown == NULL) return 0;
        inst->states = grown;
        inst->capacity = capacity;
    }
    inst->states[inst->n_states++] = state;
    return 1;
}

static int known(const Instance *inst, fmi2FMUstate state) {
    for (size_t k = 0; state != NULL && k < inst->n_states; k++)
        if (inst->states[k] == state) return 1;
    return 0;
}

static void forget(Instance *inst, fmi2FMUstate state) {
    for (size_t k = 0; k < inst->n_states; k++)
        if (inst->states[k] == state) {
            inst->states[k] = inst->states[--inst->n_states];
            return;
        }
}

static fmi2Status refuse_state(Instance *inst, const char *call, const void *state) {
    char message[256];
    snprintf(message, sizeof message, "%s refused: %p is not an FMU state of this instance (taken with "
             "fmi2GetFMUstate or fmi2DeSerializeFMUstate and not yet freed); nothing was changed", call, state);
    log_error(&inst->callbacks, inst->name, message);
    return fmi2Error;
}

/* Stores a state the core made in *s, remembered; a known state already in *s is replaced (FMI 2.0). */
static fmi2Status keep_state(Instance *inst, fmi2FMUstate *s, fmi2FMUstate made, fmi2Status status) {
    if (status > fmi2Warning || made == NULL) return status;
    if (known(inst, *s)) {
        forget(inst, *s);
        free_core_state(inst, *s);
    }
    if (!remember(inst, made)) {
        free_core_state(inst, made);
        return fmi2Error;
    }
    *s = made;
    return status;
}

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *s) {
    Instance *inst = (Instance *)c;
    fmi2GetFMUstateTYPE *f = (fmi2GetFMUstateTYPE *)core_symbol("fmi2GetFMUstate");
    if (inst == NULL || f == NULL || s == NULL) return fmi2Error;
    fmi2FMUstate made = NULL;
    error_reported = 0;
    return keep_state(inst, s, made, settle(inst, f(inst->core, &made)));
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte bytes[], size_t size, fmi2FMUstate *s) {
    Instance *inst = (Instance *)c;
    fmi2DeSerializeFMUstateTYPE *f = (fmi2DeSerializeFMUstateTYPE *)core_symbol("fmi2DeSerializeFMUstate");
    if (inst == NULL || f == NULL || s == NULL || (bytes == NULL && size > 0)) return fmi2Error;
    fmi2FMUstate made = NULL;
    error_reported = 0;
    return keep_state(inst, s, made, settle(inst, f(inst->core, bytes, size, &made)));
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *s) {
    Instance *inst = (Instance *)c;
    if (inst == NULL) return fmi2Error;
    if (s == NULL) return fmi2OK; /* nothing to free (FMI 2.0) */
    fmi2FMUstate state = (fmi2FMUstate)s;
    if (!known(inst, state)) {
        state = *s;
        if (state == NULL) return fmi2OK;
        if (!known(inst, state)) return refuse_state(inst, "fmi2FreeFMUstate", state);
        *s = NULL;
    } /* else the host passed the state itself where its address is due: free it all the same */
    forget(inst, state);
    return free_core_state(inst, state);
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate s) {
    Instance *inst = (Instance *)c;
    fmi2SetFMUstateTYPE *f = (fmi2SetFMUstateTYPE *)core_symbol("fmi2SetFMUstate");
    if (inst == NULL || f == NULL) return fmi2Error;
    if (!known(inst, s)) return refuse_state(inst, "fmi2SetFMUstate", s);
    error_reported = 0;
    return settle(inst, f(inst->core, s));
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate s, size_t *size) {
    Instance *inst = (Instance *)c;
    fmi2SerializedFMUstateSizeTYPE *f = (fmi2SerializedFMUstateSizeTYPE *)core_symbol("fmi2SerializedFMUstateSize");
    if (inst == NULL || f == NULL || size == NULL) return fmi2Error;
    if (!known(inst, s)) return refuse_state(inst, "fmi2SerializedFMUstateSize", s);
    error_reported = 0;
    return settle(inst, f(inst->core, s, size));
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate s, fmi2Byte bytes[], size_t size) {
    Instance *inst = (Instance *)c;
    fmi2SerializeFMUstateTYPE *f = (fmi2SerializeFMUstateTYPE *)core_symbol("fmi2SerializeFMUstate");
    if (inst == NULL || f == NULL || bytes == NULL) return fmi2Error;
    if (!known(inst, s)) return refuse_state(inst, "fmi2SerializeFMUstate", s);
    error_reported = 0;
    return settle(inst, f(inst->core, s, bytes, size));
}
