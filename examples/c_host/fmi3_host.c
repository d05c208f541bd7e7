/* A minimal C FMI 3.0 co-simulation master for the FMI 3.0 FemPendulum FMU: what a C/C++ host does.
 *
 * Build:  cc -I<fmpy>/c-code fmi3_host.c -ldl -o fmi3_host   (fmi3Functions.h from FMPy or the FMI standard)
 * Run:    ./fmi3_host <unzipped FMU folder> <instantiation token> <steps> <fidelity> <vr model.fidelity> <vr theta>
 *
 * No environment is needed: the FMU starts the Python it was built with (docs/reference/fmi2.md). The host
 * instantiates with early return allowed, sets model.fidelity = <fidelity> (2 rigid, 4 fem; an
 * Enumeration, set as Int64), asks for one 0.5 s step from the release, which returns early at contact
 * onset ("early-return" and the time), runs <steps> steps of 1 ms printing theta; sends a NaN torque,
 * which the FMU refuses with fmi3Error, state kept; saves the FMU state, takes 5 steps, restores it and
 * takes the same 5 steps again (both printed); serialises the state and offers a truncated copy, which
 * is refused with fmi3Error; then terminates, frees the instance, unloads the library and exits.
 */
#include <dlfcn.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "fmi3Functions.h"

static void log_message(fmi3InstanceEnvironment env, fmi3Status status, fmi3String category, fmi3String message) {
    (void)env;
    fprintf(stderr, "[status %d %s] %s\n", (int)status, category ? category : "", message);
}

#define LOAD(name)                                                    \
    name##TYPE *name = (name##TYPE *)dlsym(lib, #name);               \
    if (name == NULL) {                                               \
        fprintf(stderr, "the FMU's binary has no %s\n", #name);       \
        return 2;                                                     \
    }

int main(int argc, char **argv) {
    if (argc != 7) {
        fprintf(stderr, "usage: %s FMU_FOLDER TOKEN STEPS FIDELITY VR_FIDELITY VR_THETA\n", argv[0]);
        return 1;
    }
    char binary[4096], resources[4096];
    snprintf(binary, sizeof binary, "%s/binaries/x86_64-linux/FemPendulum.so", argv[1]);
    snprintf(resources, sizeof resources, "%s/resources/", argv[1]);
    void *lib = dlopen(binary, RTLD_NOW | RTLD_LOCAL);
    if (lib == NULL) {
        fprintf(stderr, "cannot load %s: %s\n", binary, dlerror());
        return 2;
    }
    LOAD(fmi3InstantiateCoSimulation) LOAD(fmi3EnterInitializationMode) LOAD(fmi3ExitInitializationMode)
    LOAD(fmi3DoStep) LOAD(fmi3GetFloat64) LOAD(fmi3SetFloat64) LOAD(fmi3SetInt64) LOAD(fmi3Terminate)
    LOAD(fmi3FreeInstance) LOAD(fmi3GetFMUState) LOAD(fmi3SetFMUState) LOAD(fmi3FreeFMUState)
    LOAD(fmi3SerializedFMUStateSize) LOAD(fmi3SerializeFMUState) LOAD(fmi3DeserializeFMUState)

    fmi3Instance c = fmi3InstantiateCoSimulation("c_host", argv[2], resources, fmi3False, fmi3False, fmi3False,
                                                 fmi3True, NULL, 0, NULL, log_message, NULL);
    if (c == NULL) {
        fprintf(stderr, "fmi3InstantiateCoSimulation failed (its log message says why)\n");
        dlclose(lib);
        return 3;
    }
    fmi3ValueReference fidelity = (fmi3ValueReference)atoi(argv[5]), theta = (fmi3ValueReference)atoi(argv[6]);
    fmi3ValueReference torque = 0;
    fmi3Int64 fidelity_value = atoi(argv[4]);
    fmi3Float64 t = 0.0, h = 1e-3, value, bad = NAN, zero = 0.0, last;
    fmi3Boolean event, terminate, early;
    if (fmi3EnterInitializationMode(c, fmi3False, 0.0, 0.0, fmi3False, 0.0) != fmi3OK ||
        fmi3SetInt64(c, &fidelity, 1, &fidelity_value, 1) != fmi3OK || fmi3ExitInitializationMode(c) != fmi3OK) {
        fprintf(stderr, "initialisation failed\n");
        return 4;
    }
    if (fmi3DoStep(c, t, 0.5, fmi3True, &event, &terminate, &early, &last) != fmi3OK) return 5;
    printf("early-return %d %.17g\n", (int)early, last);
    t = last;
    int steps = atoi(argv[3]);
    for (int k = 0; k < steps; k++) {
        if (fmi3DoStep(c, t, h, fmi3True, &event, &terminate, &early, &last) != fmi3OK) return 5;
        t = last;
        fmi3GetFloat64(c, &theta, 1, &value, 1);
        printf("%.17g %.17g\n", t, value);
    }
    fmi3SetFloat64(c, &torque, 1, &bad, 1);
    printf("nan-torque-status %d\n", (int)fmi3DoStep(c, t, h, fmi3True, &event, &terminate, &early, &last));
    fmi3SetFloat64(c, &torque, 1, &zero, 1);

    fmi3FMUState state = NULL, other = NULL;
    size_t size = 0;
    if (fmi3GetFMUState(c, &state) != fmi3OK || fmi3SerializedFMUStateSize(c, state, &size) != fmi3OK) return 6;
    fmi3Byte *bytes = malloc(size);
    if (bytes == NULL || fmi3SerializeFMUState(c, state, bytes, size) != fmi3OK) return 6;
    printf("serialised-state-bytes %zu\n", size);
    printf("truncated-state-status %d\n", (int)fmi3DeserializeFMUState(c, bytes, size - 1, &other));
    free(bytes);
    for (int pass = 0; pass < 2; pass++) {
        if (pass == 1 && fmi3SetFMUState(c, state) != fmi3OK) return 7;
        for (int k = 0; k < 5; k++) {
            if (fmi3DoStep(c, t + k * h, h, fmi3True, &event, &terminate, &early, &last) != fmi3OK) return 5;
            fmi3GetFloat64(c, &theta, 1, &value, 1);
            printf("pass%d %.17g\n", pass, value);
        }
    }
    fmi3FreeFMUState(c, &state);
    fmi3Terminate(c);
    fmi3FreeInstance(c);
    dlclose(lib);
    return 0;
}
