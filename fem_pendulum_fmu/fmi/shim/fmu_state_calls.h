/* The FMU state functions shared by both binaries (fmu_state_calls.c): fmi2_states.c exports them under
 * their FMI 2.0 names, fmi3_states.c under their FMI 3.0 names; `call` is the calling function's entry of
 * the state machine's table. The statuses are fmi2Status, whose values FMI 3.0's fmi3Status shares. */
#ifndef FEM_PENDULUM_FMU_STATE_CALLS_H
#define FEM_PENDULUM_FMU_STATE_CALLS_H

#include <stddef.h>

#include "fmi2Functions.h"
#include "state_machine.h"

fmi2Status state_get(void *c, Call call, fmi2FMUstate *s);
fmi2Status state_set(void *c, Call call, fmi2FMUstate s);
fmi2Status state_free(void *c, Call call, fmi2FMUstate *s);
fmi2Status state_size(void *c, Call call, fmi2FMUstate s, size_t *size);
fmi2Status state_serialize(void *c, Call call, fmi2FMUstate s, fmi2Byte out[], size_t size);
fmi2Status state_deserialize(void *c, Call call, const fmi2Byte bytes[], size_t size, fmi2FMUstate *s);

#endif
