/* A native host that runs several FMU instances at the same moment, each on a pthread of its own, and checks
 * each one's results bit for bit against the same instance run alone (tests/test_concurrent_instances.py).
 *
 * Build:  cc -DFMI_VERSION=2 (or 3) -I<fmpy>/c-code concurrent_host.c -ldl -lpthread -o concurrent_host
 * Run:    ./concurrent_host FMU_FOLDER TOKEN STEPS ROUNDS VR_FIDELITY VR_THETA0 VR_THETA VR_OMEGA VR_GAP SPEC...
 *
 * Each SPEC is "fidelity:theta0" (model.fidelity's item: 2 rigid, 3 reduced, 4 fem). An instance's life:
 * instantiate, set the fidelity and theta0, initialise, STEPS steps of 1 ms reading theta, omega and gap
 * after each; halfway it saves its FMU state, takes three steps, sets the state back and goes on (a
 * rollback); then it terminates and frees itself. A round starts every instance at once (a barrier in front
 * of fmiInstantiate, so that their models are built at the same moment). After the first round the same
 * instances run one after another on the main thread: the reference. Every round's instances must match it
 * to the last bit, every call answering OK. Prints one line per instance and round, then
 * "rounds: R, instances differing from the sequential run: N"; exits 0 only when N is 0.
 */
#include <dlfcn.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifndef FMI_VERSION
#define FMI_VERSION 2
#endif

#if FMI_VERSION == 3
#include "fmi3Functions.h"
#define BINARY "binaries/x86_64-linux/FemPendulum.so"
typedef fmi3Instance Instance;
typedef fmi3FMUState Saved;
typedef fmi3ValueReference Ref;
#else
#include "fmi2Functions.h"
#define BINARY "binaries/linux64/FemPendulum.so"
typedef fmi2Component Instance;
typedef fmi2FMUstate Saved;
typedef fmi2ValueReference Ref;
#endif

#define MAX_INSTANCES 16
#define OUTPUTS 3 /* theta, omega, gap */

typedef struct {
    int fidelity;
    double theta0;
    double *values; /* STEPS x OUTPUTS */
    int failed_at;  /* -1, or the step (-2 for the set-up) where a call did not answer OK */
    char name[32];
} Run;

static const char *folder, *token;
static int steps;
static Ref vr_fidelity, vr_theta0, outputs[OUTPUTS];
static pthread_barrier_t start_line;

#if FMI_VERSION == 3
static fmi3InstantiateCoSimulationTYPE *instantiate_cs;
static fmi3EnterInitializationModeTYPE *enter_init;
static fmi3ExitInitializationModeTYPE *exit_init;
static fmi3DoStepTYPE *do_step;
static fmi3GetFloat64TYPE *get_float;
static fmi3SetFloat64TYPE *set_float;
static fmi3SetInt64TYPE *set_int;
static fmi3GetFMUStateTYPE *get_state;
static fmi3SetFMUStateTYPE *set_state;
static fmi3FreeFMUStateTYPE *free_state;
static fmi3TerminateTYPE *terminate_instance;
static fmi3FreeInstanceTYPE *free_instance;

static void log_message(fmi3InstanceEnvironment env, fmi3Status status, fmi3String category, fmi3String message) {
    fprintf(stderr, "[%s status %d %s] %s\n", (const char *)env, (int)status, category ? category : "", message);
}

static int load(void *lib) {
    instantiate_cs = (fmi3InstantiateCoSimulationTYPE *)dlsym(lib, "fmi3InstantiateCoSimulation");
    enter_init = (fmi3EnterInitializationModeTYPE *)dlsym(lib, "fmi3EnterInitializationMode");
    exit_init = (fmi3ExitInitializationModeTYPE *)dlsym(lib, "fmi3ExitInitializationMode");
    do_step = (fmi3DoStepTYPE *)dlsym(lib, "fmi3DoStep");
    get_float = (fmi3GetFloat64TYPE *)dlsym(lib, "fmi3GetFloat64");
    set_float = (fmi3SetFloat64TYPE *)dlsym(lib, "fmi3SetFloat64");
    set_int = (fmi3SetInt64TYPE *)dlsym(lib, "fmi3SetInt64");
    get_state = (fmi3GetFMUStateTYPE *)dlsym(lib, "fmi3GetFMUState");
    set_state = (fmi3SetFMUStateTYPE *)dlsym(lib, "fmi3SetFMUState");
    free_state = (fmi3FreeFMUStateTYPE *)dlsym(lib, "fmi3FreeFMUState");
    terminate_instance = (fmi3TerminateTYPE *)dlsym(lib, "fmi3Terminate");
    free_instance = (fmi3FreeInstanceTYPE *)dlsym(lib, "fmi3FreeInstance");
    return instantiate_cs && enter_init && exit_init && do_step && get_float && set_float && set_int && get_state &&
           set_state && free_state && terminate_instance && free_instance;
}

static Instance instantiate(Run *run) {
    char resources[4096];
    snprintf(resources, sizeof resources, "%s/resources/", folder);
    return instantiate_cs(run->name, token, resources, fmi3False, fmi3False, fmi3False, fmi3False, NULL, 0, run->name,
                          log_message, NULL);
}

static int initialise(Instance c, const Run *run) {
    fmi3Int64 fidelity = run->fidelity;
    fmi3Float64 theta0 = run->theta0;
    return enter_init(c, fmi3False, 0.0, 0.0, fmi3False, 0.0) == fmi3OK &&
           set_int(c, &vr_fidelity, 1, &fidelity, 1) == fmi3OK && set_float(c, &vr_theta0, 1, &theta0, 1) == fmi3OK &&
           exit_init(c) == fmi3OK;
}

static int step(Instance c, double t) {
    fmi3Boolean event, terminate, early;
    fmi3Float64 last;
    return do_step(c, t, 1e-3, fmi3True, &event, &terminate, &early, &last) == fmi3OK && !early;
}

static int read_outputs(Instance c, double *values) {
    return get_float(c, outputs, OUTPUTS, values, OUTPUTS) == fmi3OK;
}
#else
static fmi2InstantiateTYPE *instantiate_cs;
static fmi2SetupExperimentTYPE *setup;
static fmi2EnterInitializationModeTYPE *enter_init;
static fmi2ExitInitializationModeTYPE *exit_init;
static fmi2DoStepTYPE *do_step;
static fmi2GetRealTYPE *get_float;
static fmi2SetRealTYPE *set_float;
static fmi2SetIntegerTYPE *set_int;
static fmi2GetFMUstateTYPE *get_state;
static fmi2SetFMUstateTYPE *set_state;
static fmi2FreeFMUstateTYPE *free_state;
static fmi2TerminateTYPE *terminate_instance;
static fmi2FreeInstanceTYPE *free_instance;

static void log_message(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status, fmi2String category,
                        fmi2String message, ...) {
    (void)env;
    char text[2048];
    va_list args;
    va_start(args, message);
    vsnprintf(text, sizeof text, message, args);
    va_end(args);
    fprintf(stderr, "[%s status %d %s] %s\n", name, (int)status, category ? category : "", text);
}

static int load(void *lib) {
    instantiate_cs = (fmi2InstantiateTYPE *)dlsym(lib, "fmi2Instantiate");
    setup = (fmi2SetupExperimentTYPE *)dlsym(lib, "fmi2SetupExperiment");
    enter_init = (fmi2EnterInitializationModeTYPE *)dlsym(lib, "fmi2EnterInitializationMode");
    exit_init = (fmi2ExitInitializationModeTYPE *)dlsym(lib, "fmi2ExitInitializationMode");
    do_step = (fmi2DoStepTYPE *)dlsym(lib, "fmi2DoStep");
    get_float = (fmi2GetRealTYPE *)dlsym(lib, "fmi2GetReal");
    set_float = (fmi2SetRealTYPE *)dlsym(lib, "fmi2SetReal");
    set_int = (fmi2SetIntegerTYPE *)dlsym(lib, "fmi2SetInteger");
    get_state = (fmi2GetFMUstateTYPE *)dlsym(lib, "fmi2GetFMUstate");
    set_state = (fmi2SetFMUstateTYPE *)dlsym(lib, "fmi2SetFMUstate");
    free_state = (fmi2FreeFMUstateTYPE *)dlsym(lib, "fmi2FreeFMUstate");
    terminate_instance = (fmi2TerminateTYPE *)dlsym(lib, "fmi2Terminate");
    free_instance = (fmi2FreeInstanceTYPE *)dlsym(lib, "fmi2FreeInstance");
    return instantiate_cs && setup && enter_init && exit_init && do_step && get_float && set_float && set_int &&
           get_state && set_state && free_state && terminate_instance && free_instance;
}

static const fmi2CallbackFunctions callbacks = {log_message, calloc, free, NULL, NULL};

static Instance instantiate(Run *run) {
    char resources[4096];
    snprintf(resources, sizeof resources, "file://%s/resources", folder);
    return instantiate_cs(run->name, fmi2CoSimulation, token, resources, &callbacks, fmi2False, fmi2False);
}

static int initialise(Instance c, const Run *run) {
    fmi2Integer fidelity = run->fidelity;
    fmi2Real theta0 = run->theta0;
    return setup(c, fmi2False, 0.0, 0.0, fmi2False, 0.0) == fmi2OK && enter_init(c) == fmi2OK &&
           set_int(c, &vr_fidelity, 1, &fidelity) == fmi2OK && set_float(c, &vr_theta0, 1, &theta0) == fmi2OK &&
           exit_init(c) == fmi2OK;
}

static int step(Instance c, double t) {
    return do_step(c, t, 1e-3, fmi2True) == fmi2OK;
}

static int read_outputs(Instance c, double *values) {
    return get_float(c, outputs, OUTPUTS, values) == fmi2OK;
}
#endif

/* Steps from k to the end, reading the outputs after each; halfway, a rollback of three steps. */
static int steps_with_rollback(Instance c, Run *run) {
    for (int k = 0; k < steps; k++) {
        if (k == steps / 2) {
            Saved saved = NULL;
            if (get_state(c, &saved) != 0) return k;
            for (int extra = 0; extra < 3; extra++)
                if (!step(c, k * 1e-3 + extra * 1e-3)) return k;
            if (set_state(c, saved) != 0 || free_state(c, &saved) != 0) return k;
        }
        if (!step(c, k * 1e-3) || !read_outputs(c, run->values + OUTPUTS * k)) return k;
    }
    return -1;
}

static void life(Run *run) {
    Instance c = instantiate(run);
    run->failed_at = -2;
    if (c == NULL) return;
    if (initialise(c, run)) run->failed_at = steps_with_rollback(c, run);
    if (terminate_instance(c) != 0 && run->failed_at == -1) run->failed_at = steps;
    free_instance(c);
}

static void *life_at_start_line(void *arg) {
    pthread_barrier_wait(&start_line);
    life((Run *)arg);
    return NULL;
}

/* SPEC "fidelity:theta0", or "fidelity:theta0:theta0_alone" for a sequential run of another scene (the tests'
 * check that a difference is seen). */
static int parse_runs(Run *runs, int n, char **specs, const char *prefix, int alone) {
    for (int i = 0; i < n; i++) {
        double theta0_alone;
        int fields = sscanf(specs[i], "%d:%lf:%lf", &runs[i].fidelity, &runs[i].theta0, &theta0_alone);
        if (fields < 2) return 0;
        if (fields == 3 && alone) runs[i].theta0 = theta0_alone;
        runs[i].values = calloc((size_t)steps * OUTPUTS, sizeof(double));
        if (runs[i].values == NULL) return 0;
        snprintf(runs[i].name, sizeof runs[i].name, "%s%d", prefix, i);
    }
    return 1;
}

/* The instances all at once, each on its own thread. */
static int concurrent_round(Run *runs, int n) {
    pthread_t threads[MAX_INSTANCES];
    pthread_barrier_init(&start_line, NULL, (unsigned)n);
    for (int i = 0; i < n; i++)
        if (pthread_create(&threads[i], NULL, life_at_start_line, &runs[i]) != 0) return 0;
    for (int i = 0; i < n; i++) pthread_join(threads[i], NULL);
    pthread_barrier_destroy(&start_line);
    return 1;
}

static int compare_round(int round, const Run *runs, const Run *alone, int n) {
    int differing = 0;
    for (int i = 0; i < n; i++) {
        size_t bytes = (size_t)steps * OUTPUTS * sizeof(double);
        int same = runs[i].failed_at == alone[i].failed_at && memcmp(runs[i].values, alone[i].values, bytes) == 0;
        int first = -1;
        for (int k = 0; k < steps * OUTPUTS && first < 0; k++)
            if (memcmp(&runs[i].values[k], &alone[i].values[k], sizeof(double)) != 0) first = k / OUTPUTS;
        printf("round %d instance %d fidelity %d: %s (failed at %d, alone %d; first differing step %d)\n", round, i,
               runs[i].fidelity, same && runs[i].failed_at == -1 ? "same" : "DIFFERENT", runs[i].failed_at,
               alone[i].failed_at, first);
        differing += !(same && runs[i].failed_at == -1);
    }
    fflush(stdout);
    return differing;
}

int main(int argc, char **argv) {
    if (argc < 11 || argc - 10 > MAX_INSTANCES) {
        fprintf(stderr, "usage: %s FMU_FOLDER TOKEN STEPS ROUNDS VR_FIDELITY VR_THETA0 VR_THETA VR_OMEGA VR_GAP SPEC...\n",
                argv[0]);
        return 2;
    }
    folder = argv[1], token = argv[2], steps = atoi(argv[3]);
    int rounds = atoi(argv[4]), n = argc - 10;
    vr_fidelity = (Ref)atoi(argv[5]), vr_theta0 = (Ref)atoi(argv[6]);
    for (int j = 0; j < OUTPUTS; j++) outputs[j] = (Ref)atoi(argv[7 + j]);
    char binary[4096];
    snprintf(binary, sizeof binary, "%s/%s", folder, BINARY);
    void *lib = dlopen(binary, RTLD_NOW | RTLD_LOCAL);
    if (lib == NULL || !load(lib)) {
        fprintf(stderr, "cannot load the FMI %d functions of %s: %s\n", FMI_VERSION, binary, dlerror());
        return 2;
    }
    Run runs[MAX_INSTANCES], alone[MAX_INSTANCES];
    if (steps < 2 || rounds < 1 || !parse_runs(runs, n, argv + 10, "together", 0) ||
        !parse_runs(alone, n, argv + 10, "alone", 1)) {
        fprintf(stderr, "bad STEPS, ROUNDS or SPEC (fidelity:theta0)\n");
        return 2;
    }
    int differing = 0;
    for (int round = 0; round < rounds; round++) {
        if (!concurrent_round(runs, n)) return 2;
        if (round == 0)
            for (int i = 0; i < n; i++) life(&alone[i]);
        differing += compare_round(round, runs, alone, n);
    }
    printf("rounds: %d, instances differing from the sequential run: %d\n", rounds, differing);
    return differing == 0 ? 0 : 1;
}
