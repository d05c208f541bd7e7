/* A C program on ecos's C API (libecosc.so of the ecospy wheel) that runs the FemPendulum FMU.
 *
 *   ecos_c_host FMU STEPS FIDELITY_INDEX [MESH_SIZE]
 *
 * One instance "pendulum", its parameters through an ecos parameter set applied at init, STEPS steps of
 * 1 ms; prints ecos's version, then "theta T VALUE" after every step (%.17g: the double itself), and exits
 * with 0 only when every call of the C API succeeded. The wheel ships no header (ecos's include/ecos/ecos.h
 * is C++: default arguments), so the functions used are declared here as that header declares them, with
 * every argument given. tests/test_ecos_host.py compiles and runs it.
 */
#include <stdbool.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>

typedef struct ecos_simulation ecos_simulation_t;
typedef struct ecos_simulation_structure ecos_simulation_structure_t;
typedef struct ecos_parameter_set ecos_parameter_set_t;
typedef struct {
    int major, minor, patch;
} ecos_version;

const char *ecos_last_error_msg(void);
void ecos_set_log_level(const char *level);
ecos_version ecos_library_version(void);
ecos_simulation_structure_t *ecos_simulation_structure_create(void);
void ecos_simulation_structure_destroy(ecos_simulation_structure_t *ss);
bool ecos_simulation_structure_add_model(ecos_simulation_structure_t *ss, const char *instanceName, const char *uri,
                                         double step_size_hint);
bool ecos_simulation_structure_add_parameter_set(ecos_simulation_structure_t *ss, const char *name,
                                                 const ecos_parameter_set_t *pps);
ecos_parameter_set_t *ecos_parameter_set_create(void);
void ecos_parameter_set_destroy(ecos_parameter_set_t *pps);
void ecos_parameter_set_add_int(ecos_parameter_set_t *pps, const char *name, int value);
void ecos_parameter_set_add_real(ecos_parameter_set_t *pps, const char *name, double value);
ecos_simulation_t *ecos_simulation_create_from_structure(ecos_simulation_structure_t *ss, double stepSize);
bool ecos_simulation_init(ecos_simulation_t *sim, double startTime, const char *parameterSet);
double ecos_simulation_step(ecos_simulation_t *sim, size_t numSteps);
bool ecos_simulation_get_real(ecos_simulation_t *sim, const char *identifier, double *value);
bool ecos_simulation_get_integer(ecos_simulation_t *sim, const char *identifier, int *value);
bool ecos_simulation_terminate(ecos_simulation_t *sim);
void ecos_simulation_destroy(ecos_simulation_t *sim);

static int failed(const char *what) {
    fprintf(stderr, "%s failed: %s\n", what, ecos_last_error_msg());
    return 1;
}

int main(int argc, char **argv) {
    if (argc != 4 && argc != 5) {
        fprintf(stderr, "usage: %s FMU STEPS FIDELITY_INDEX [MESH_SIZE]\n", argv[0]);
        return 2;
    }
    const long steps = strtol(argv[2], NULL, 10);
    ecos_version v = ecos_library_version();
    printf("ecos %d.%d.%d\n", v.major, v.minor, v.patch);
    ecos_set_log_level("debug"); /* the FMU's messages reach ecos's log at debug level */

    ecos_simulation_structure_t *ss = ecos_simulation_structure_create();
    if (ss == NULL) return failed("ecos_simulation_structure_create");
    if (!ecos_simulation_structure_add_model(ss, "pendulum", argv[1], -1)) return failed("add_model");
    ecos_parameter_set_t *parameters = ecos_parameter_set_create();
    ecos_parameter_set_add_int(parameters, "pendulum::model.fidelity_index", atoi(argv[3]));
    if (argc == 5) ecos_parameter_set_add_real(parameters, "pendulum::model.mesh_size", strtod(argv[4], NULL));
    if (!ecos_simulation_structure_add_parameter_set(ss, "run", parameters)) return failed("add_parameter_set");
    ecos_parameter_set_destroy(parameters);

    ecos_simulation_t *sim = ecos_simulation_create_from_structure(ss, 1e-3);
    if (sim == NULL) return failed("ecos_simulation_create_from_structure");
    if (!ecos_simulation_init(sim, 0.0, "run")) return failed("ecos_simulation_init");
    int fidelity = -1;
    if (!ecos_simulation_get_integer(sim, "pendulum::model.fidelity_index", &fidelity)) return failed("get_integer");
    printf("fidelity_index %d\n", fidelity);
    for (long k = 0; k < steps; k++) {
        double t = ecos_simulation_step(sim, 1), theta;
        if (!ecos_simulation_get_real(sim, "pendulum::theta", &theta)) return failed("ecos_simulation_get_real");
        printf("theta %.17g %.17g\n", t, theta);
    }
    if (!ecos_simulation_terminate(sim)) return failed("ecos_simulation_terminate");
    ecos_simulation_destroy(sim);
    ecos_simulation_structure_destroy(ss);
    return 0;
}
