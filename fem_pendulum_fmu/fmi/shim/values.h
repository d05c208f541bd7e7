/* Get and Set of the variables, for both binaries (values.c): the state machine's check, every value
 * reference checked against the modelDescription's variables (variables.h), then the slave's method
 * `method` with the list of references (and of values). n_values is the number of values: n for
 * scalars, the elements of every array for FMI 3.0. */
#ifndef FEM_PENDULUM_VALUES_H
#define FEM_PENDULUM_VALUES_H

#include "python_api.h"

#include "fmi2Functions.h"
#include "state_machine.h"
#include "variables.h"

int read_item(Kind kind, PyObject *item, void *values, size_t k);
PyObject *value_object(Kind kind, const void *values, size_t k);
fmi2Status get_values(fmi2Component c, Call call, const char *method, Kind kind, const fmi2ValueReference vr[],
                      size_t n, void *values, size_t n_values);
fmi2Status set_values(fmi2Component c, Call call, const char *method, Kind kind, const fmi2ValueReference vr[],
                      size_t n, const void *values, size_t n_values);

#endif
