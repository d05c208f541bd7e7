/* A native FMI 2.0 host that runs instance after instance of one FMU and prints its resident size after each.
 *
 * Build:  cc -I<fmpy>/c-code fmi2_cycle_host.c -ldl -o fmi2_cycle_host
 * Run:    ./fmi2_cycle_host FMU_FOLDER MODEL_IDENTIFIER GUID CYCLES STEPS [iVR=VALUE | rVR=VALUE ...]
 *
 * The FMU's binary is loaded once. Each cycle instantiates, sets up the experiment, enters initialisation
 * mode, sets the given Integer (i) and Real (r) parameters by value reference, exits initialisation mode,
 * takes STEPS doSteps of 1 ms, terminates and frees the instance, then prints
 *     cycle <k> <resident kB> <worst status of the cycle>
 * with the resident size read from /proc/self/statm. Used by tests/test_fmu_memory.py. Exit code 0 when
 * every call answered fmi2OK, else the number of the first failing step of the cycle (2 to 5).
 */
#include <dlfcn.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "fmi2Functions.h"

static void log_message(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status, fmi2String category,
                        fmi2String message, ...) {
    (void)env;
    if (status == fmi2OK) return;
    va_list args;
    va_start(args, message);
    fprintf(stderr, "[%s status %d %s] ", name, (int)status, category ? category : "");
    vfprintf(stderr, message, args);
    fputc('\n', stderr);
    va_end(args);
}

static long resident_kb(void) {
    long pages_total = 0, pages_resident = 0;
    FILE *f = fopen("/proc/self/statm", "r");
    if (f == NULL) return -1;
    if (fscanf(f, "%ld %ld", &pages_total, &pages_resident) != 2) pages_resident = -1;
    fclose(f);
    return pages_resident < 0 ? -1 : pages_resident * (sysconf(_SC_PAGESIZE) / 1024);
}

#define LOAD(name)                                                    \
    name##TYPE *name = (name##TYPE *)dlsym(lib, #name);               \
    if (name == NULL) {                                               \
        fprintf(stderr, "the FMU's binary has no %s\n", #name);       \
        return 2;                                                     \
    }

int main(int argc, char **argv) {
    if (argc < 6) {
        fprintf(stderr, "usage: %s FMU_FOLDER MODEL_IDENTIFIER GUID CYCLES STEPS [iVR=VALUE | rVR=VALUE ...]\n",
                argv[0]);
        return 1;
    }
    char binary[4096], resources[4096];
    snprintf(binary, sizeof binary, "%s/binaries/linux64/%s.so", argv[1], argv[2]);
    snprintf(resources, sizeof resources, "file://%s/resources", argv[1]);
    void *lib = dlopen(binary, RTLD_NOW | RTLD_LOCAL);
    if (lib == NULL) {
        fprintf(stderr, "cannot load %s: %s\n", binary, dlerror());
        return 2;
    }
    LOAD(fmi2Instantiate) LOAD(fmi2SetupExperiment) LOAD(fmi2EnterInitializationMode)
    LOAD(fmi2ExitInitializationMode) LOAD(fmi2DoStep) LOAD(fmi2SetInteger) LOAD(fmi2SetReal)
    LOAD(fmi2Terminate) LOAD(fmi2FreeInstance)

    fmi2CallbackFunctions callbacks = {log_message, calloc, free, NULL, NULL};
    int cycles = atoi(argv[4]), steps = atoi(argv[5]);
    printf("start %ld\n", resident_kb());
    fflush(stdout);
    for (int k = 0; k < cycles; k++) {
        fmi2Component c = fmi2Instantiate("cycle", fmi2CoSimulation, argv[3], resources, &callbacks, fmi2False,
                                          fmi2False);
        if (c == NULL) return 3;
        int worst = fmi2SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0);
        int status = fmi2EnterInitializationMode(c);
        worst = status > worst ? status : worst;
        for (int a = 6; a < argc; a++) {
            fmi2ValueReference vr = (fmi2ValueReference)strtoul(argv[a] + 1, NULL, 10);
            const char *value = strchr(argv[a], '=');
            if (value == NULL) return 1;
            if (argv[a][0] == 'i') {
                fmi2Integer v = atoi(value + 1);
                status = fmi2SetInteger(c, &vr, 1, &v);
            } else {
                fmi2Real v = atof(value + 1);
                status = fmi2SetReal(c, &vr, 1, &v);
            }
            worst = status > worst ? status : worst;
        }
        status = fmi2ExitInitializationMode(c);
        worst = status > worst ? status : worst;
        if (worst != fmi2OK) return 4;
        for (int s = 0; s < steps; s++) {
            status = fmi2DoStep(c, s * 1e-3, 1e-3, fmi2True);
            if (status != fmi2OK) return 5;
        }
        status = fmi2Terminate(c);
        worst = status > worst ? status : worst;
        fmi2FreeInstance(c);
        printf("cycle %d %ld %d\n", k, resident_kb(), worst);
        fflush(stdout);
    }
    dlclose(lib);
    return 0;
}
