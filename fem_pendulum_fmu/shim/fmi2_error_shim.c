/* FMI 2.0 status shim of the FemPendulum FMU (Linux).
 *
 * pythonfmu 0.7.0 can only answer fmi2OK, fmi2Discard (do_step returned False)
 * or fmi2Fatal (any Python exception). This library is the FMU's binary: it
 * forwards every fmi2 call to pythonfmu's binary, renamed FemPendulum_core.so
 * beside it, and turns the answer into fmi2Error when the slave flagged the
 * call as refused input (fem_pendulum_flag_error, called through ctypes while
 * the call is in progress). Nothing else changes.
 */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <stdio.h>
#include <string.h>

#include "fmi2Functions.h"

#ifndef CORE_NAME
#define CORE_NAME "FemPendulum_core.so"
#endif

static void *core = NULL;
static __thread int error_flagged = 0;

FMI2_Export void fem_pendulum_flag_error(void) { error_flagged = 1; }

static void *core_symbol(const char *name) {
    if (core == NULL) {
        Dl_info info;
        char path[4096];
        if (dladdr((void *)&core_symbol, &info) == 0 || info.dli_fname == NULL) return NULL;
        strncpy(path, info.dli_fname, sizeof(path) - sizeof(CORE_NAME) - 1);
        path[sizeof(path) - sizeof(CORE_NAME) - 1] = '\0';
        char *slash = strrchr(path, '/');
        strcpy(slash ? slash + 1 : path, CORE_NAME);
        core = dlopen(path, RTLD_NOW | RTLD_LOCAL);
        if (core == NULL) {
            fprintf(stderr, "FemPendulum: cannot load %s: %s\n", path, dlerror());
            return NULL;
        }
    }
    return dlsym(core, name);
}

static fmi2Status settle(fmi2Status status) {
    if (error_flagged) {
        error_flagged = 0;
        if (status < fmi2Error) return fmi2Error;
    }
    return status;
}

#define FORWARD(name, params, args)                              \
    fmi2Status name params {                                     \
        name##TYPE *f = (name##TYPE *)core_symbol(#name);        \
        if (f == NULL) return fmi2Fatal;                         \
        error_flagged = 0;                                       \
        return settle(f args);                                   \
    }

const char *fmi2GetTypesPlatform(void) {
    fmi2GetTypesPlatformTYPE *f = (fmi2GetTypesPlatformTYPE *)core_symbol("fmi2GetTypesPlatform");
    return f ? f() : fmi2TypesPlatform;
}

const char *fmi2GetVersion(void) {
    fmi2GetVersionTYPE *f = (fmi2GetVersionTYPE *)core_symbol("fmi2GetVersion");
    return f ? f() : fmi2Version;
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String guid,
                              fmi2String resourceLocation, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn) {
    fmi2InstantiateTYPE *f = (fmi2InstantiateTYPE *)core_symbol("fmi2Instantiate");
    return f ? f(instanceName, fmuType, guid, resourceLocation, functions, visible, loggingOn) : NULL;
}

void fmi2FreeInstance(fmi2Component c) {
    fmi2FreeInstanceTYPE *f = (fmi2FreeInstanceTYPE *)core_symbol("fmi2FreeInstance");
    if (f) f(c);
}

FORWARD(fmi2SetDebugLogging, (fmi2Component c, fmi2Boolean on, size_t n, const fmi2String categories[]),
        (c, on, n, categories))
FORWARD(fmi2SetupExperiment, (fmi2Component c, fmi2Boolean tolDefined, fmi2Real tol, fmi2Real start,
        fmi2Boolean stopDefined, fmi2Real stop), (c, tolDefined, tol, start, stopDefined, stop))
FORWARD(fmi2EnterInitializationMode, (fmi2Component c), (c))
FORWARD(fmi2ExitInitializationMode, (fmi2Component c), (c))
FORWARD(fmi2Terminate, (fmi2Component c), (c))
FORWARD(fmi2Reset, (fmi2Component c), (c))
FORWARD(fmi2GetReal, (fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real v[]), (c, vr, n, v))
FORWARD(fmi2GetInteger, (fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Integer v[]), (c, vr, n, v))
FORWARD(fmi2GetBoolean, (fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Boolean v[]), (c, vr, n, v))
FORWARD(fmi2GetString, (fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2String v[]), (c, vr, n, v))
FORWARD(fmi2SetReal, (fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Real v[]), (c, vr, n, v))
FORWARD(fmi2SetInteger, (fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer v[]),
        (c, vr, n, v))
FORWARD(fmi2SetBoolean, (fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Boolean v[]),
        (c, vr, n, v))
FORWARD(fmi2SetString, (fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2String v[]),
        (c, vr, n, v))
FORWARD(fmi2GetFMUstate, (fmi2Component c, fmi2FMUstate *s), (c, s))
FORWARD(fmi2SetFMUstate, (fmi2Component c, fmi2FMUstate s), (c, s))
FORWARD(fmi2FreeFMUstate, (fmi2Component c, fmi2FMUstate *s), (c, s))
FORWARD(fmi2SerializedFMUstateSize, (fmi2Component c, fmi2FMUstate s, size_t *size), (c, s, size))
FORWARD(fmi2SerializeFMUstate, (fmi2Component c, fmi2FMUstate s, fmi2Byte b[], size_t size), (c, s, b, size))
FORWARD(fmi2DeSerializeFMUstate, (fmi2Component c, const fmi2Byte b[], size_t size, fmi2FMUstate *s),
        (c, b, size, s))
FORWARD(fmi2GetDirectionalDerivative, (fmi2Component c, const fmi2ValueReference u[], size_t nu,
        const fmi2ValueReference z[], size_t nz, const fmi2Real dv[], fmi2Real dz[]), (c, u, nu, z, nz, dv, dz))
FORWARD(fmi2SetRealInputDerivatives, (fmi2Component c, const fmi2ValueReference vr[], size_t n,
        const fmi2Integer order[], const fmi2Real value[]), (c, vr, n, order, value))
FORWARD(fmi2GetRealOutputDerivatives, (fmi2Component c, const fmi2ValueReference vr[], size_t n,
        const fmi2Integer order[], fmi2Real value[]), (c, vr, n, order, value))
FORWARD(fmi2DoStep, (fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean noSetPrior), (c, t, h, noSetPrior))
FORWARD(fmi2CancelStep, (fmi2Component c), (c))
FORWARD(fmi2GetStatus, (fmi2Component c, const fmi2StatusKind s, fmi2Status *value), (c, s, value))
FORWARD(fmi2GetRealStatus, (fmi2Component c, const fmi2StatusKind s, fmi2Real *value), (c, s, value))
FORWARD(fmi2GetIntegerStatus, (fmi2Component c, const fmi2StatusKind s, fmi2Integer *value), (c, s, value))
FORWARD(fmi2GetBooleanStatus, (fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value), (c, s, value))
FORWARD(fmi2GetStringStatus, (fmi2Component c, const fmi2StatusKind s, fmi2String *value), (c, s, value))
