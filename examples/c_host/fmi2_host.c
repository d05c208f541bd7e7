/* A minimal C FMI 2.0 co-simulation master for the FemPendulum FMU: what a C/C++ host does.
 *
 * Build:  cc -I<fmpy>/c-code fmi2_host.c -ldl -o fmi2_host   (fmi2Functions.h from FMPy or the FMI standard)
 * Run:    ./fmi2_host <unzipped FMU folder> <guid> <steps> <fidelity> <vr model.fidelity> <vr theta>
 *
 * No environment is needed: the FMU starts the Python it was built with (docs/reference/fmi2.md). The host
 * runs <steps> steps of 1 ms with model.fidelity = <fidelity> (2 rigid, 4 fem), printing theta after
 * each; sends a NaN torque, which the FMU refuses with fmi2Error, state kept; saves the FMU state,
 * takes 5 steps, restores the state and takes the same 5 steps again (both printed); serialises the
 * state; then terminates, frees the instance, unloads the library and exits.
 */
#include <dlfcn.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>

#include "fmi2Functions.h"

static void log_message(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status, fmi2String category,
                        fmi2String message, ...) {
    (void)env;
    va_list args;
    va_start(args, message);
    fprintf(stderr, "[%s status %d %s] ", name, (int)status, category ? category : "");
    vfprintf(stderr, message, args);
    fputc('\n', stderr);
    va_end(args);
}

#define LOAD(name)                                                    \
    name##TYPE *name = (name##TYPE *)dlsym(lib, #name);               \
    if (name == NULL) {                                               \
        fprintf(stderr, "the FMU's binary has no %s\n", #name);       \
        return 2;                                                     \
    }

int main(int argc, char **argv) {
    if (argc != 7) {
        fprintf(stderr, "usage: %s FMU_FOLDER GUID STEPS FIDELITY VR_FIDELITY VR_THETA\n", argv[0]);
        return 1;
    }
    char binary[4096], resources[4096];
    snprintf(binary, sizeof binary, "%s/binaries/linux64/FemPendulum.so", argv[1]);
    snprintf(resources, sizeof resources, "file://%s/resources", argv[1]);
    void *lib = dlopen(binary, RTLD_NOW | RTLD_LOCAL);
    if (lib == NULL) {
        fprintf(stderr, "cannot load %s: %s\n", binary, dlerror());
        return 2;
    }
    LOAD(fmi2Instantiate) LOAD(fmi2SetupExperiment) LOAD(fmi2EnterInitializationMode)
    LOAD(fmi2ExitInitializationMode) LOAD(fmi2DoStep) LOAD(fmi2GetReal) LOAD(fmi2SetReal)
    LOAD(fmi2SetInteger) LOAD(fmi2Terminate) LOAD(fmi2FreeInstance) LOAD(fmi2GetFMUstate)
    LOAD(fmi2SetFMUstate) LOAD(fmi2FreeFMUstate) LOAD(fmi2SerializedFMUstateSize) LOAD(fmi2SerializeFMUstate)

    fmi2CallbackFunctions callbacks = {log_message, calloc, free, NULL, NULL};
    fmi2Component c = fmi2Instantiate("c_host", fmi2CoSimulation, argv[2], resources, &callbacks, fmi2False, fmi2False);
    if (c == NULL) {
        fprintf(stderr, "fmi2Instantiate failed (its log message says why)\n");
        dlclose(lib);
        return 3;
    }
    fmi2ValueReference fidelity = (fmi2ValueReference)atoi(argv[5]), theta = (fmi2ValueReference)atoi(argv[6]);
    fmi2ValueReference torque = 0;
    fmi2Integer fidelity_value = atoi(argv[4]);
    fmi2Real t = 0.0, h = 1e-3, value, bad = NAN;
    if (fmi2SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0) != fmi2OK ||
        fmi2EnterInitializationMode(c) != fmi2OK || fmi2SetInteger(c, &fidelity, 1, &fidelity_value) != fmi2OK ||
        fmi2ExitInitializationMode(c) != fmi2OK) {
        fprintf(stderr, "initialisation failed\n");
        return 4;
    }
    int steps = atoi(argv[3]);
    for (int k = 0; k < steps; k++) {
        if (fmi2DoStep(c, t, h, fmi2True) != fmi2OK) return 5;
        t = (k + 1) * h;
        fmi2GetReal(c, &theta, 1, &value);
        printf("%.17g %.17g\n", t, value);
    }
    fmi2SetReal(c, &torque, 1, &bad);
    printf("nan-torque-status %d\n", (int)fmi2DoStep(c, t, h, fmi2True));
    fmi2Real zero = 0.0;
    fmi2SetReal(c, &torque, 1, &zero);

    fmi2FMUstate state = NULL;
    size_t size = 0;
    if (fmi2GetFMUstate(c, &state) != fmi2OK || fmi2SerializedFMUstateSize(c, state, &size) != fmi2OK) return 6;
    fmi2Byte *bytes = malloc(size);
    if (bytes == NULL || fmi2SerializeFMUstate(c, state, bytes, size) != fmi2OK) return 6;
    printf("serialised-state-bytes %zu\n", size);
    free(bytes);
    for (int pass = 0; pass < 2; pass++) {
        if (pass == 1 && fmi2SetFMUstate(c, state) != fmi2OK) return 7;
        for (int k = 0; k < 5; k++) {
            if (fmi2DoStep(c, t + k * h, h, fmi2True) != fmi2OK) return 5;
            fmi2GetReal(c, &theta, 1, &value);
            printf("pass%d %.17g\n", pass, value);
        }
    }
    fmi2FreeFMUstate(c, &state);
    fmi2Terminate(c);
    fmi2FreeInstance(c);
    dlclose(lib);
    return 0;
}
