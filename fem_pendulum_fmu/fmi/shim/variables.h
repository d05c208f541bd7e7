/* The FMU's variables as its modelDescription declares them (fmu_variables.h, generated at build time
 * by fem_pendulum_fmu/fmi/binary_config.py): every Get/Set is checked against them before the slave
 * is called, so that a wrong value reference, type or causality is refused alike for any slave. */
#ifndef FEM_PENDULUM_VARIABLES_H
#define FEM_PENDULUM_VARIABLES_H

#include <stddef.h>

#include "fmi2Functions.h"
#include "state_machine.h"

/* FMI 2.0: Real, Integer (and Enumeration), Boolean, String; FMI 3.0: Float64, Int32, Boolean, String and Int64
 * (its Enumerations) */
typedef enum { KIND_REAL, KIND_INTEGER, KIND_BOOLEAN, KIND_STRING, KIND_INT64 } Kind;
/* a continuous Real input or output: what has time derivatives (fmi2Set/GetReal*Derivatives) */
typedef enum { ROLE_OTHER, ROLE_INPUT, ROLE_OUTPUT } Role;

typedef struct {
    fmi2ValueReference vr;
    Kind kind;
    const char *name;
    const char *what;      /* "an output", "a fixed parameter": for messages */
    int settable;          /* the states in which a host may set it (MachineState mask) */
    Role role;
    size_t size;           /* its number of elements: 1, or an FMI 3.0 array's */
} Variable;

/* Why getting (setting = 0) or setting these variables of `kind` in `state` is refused, or NULL. */
const char *variables_problem(const fmi2ValueReference vr[], size_t n, Kind kind, int setting, MachineState state,
                              char *why, size_t size);

/* Why n_values values are not the elements of these n variables (FMI 3.0's nValues), or NULL. */
const char *count_problem(const fmi2ValueReference vr[], size_t n, size_t n_values, char *why, size_t size);

/* Why fmi2SetRealInputDerivatives (role ROLE_INPUT) or fmi2GetRealOutputDerivatives (ROLE_OUTPUT) of these
 * variables and orders is refused, or NULL: each a continuous Real variable of that role, each order in
 * 1..max_order. */
const char *derivatives_problem(const fmi2ValueReference vr[], size_t n, const fmi2Integer order[], Role role,
                                int max_order, char *why, size_t size);

#endif
