/* What the FMI 3.0 binary's files share (fmi3_functions.c, fmi3_step.c, fmi3_unsupported.c). */
#ifndef FEM_PENDULUM_FMI3_SHIM_H
#define FEM_PENDULUM_FMI3_SHIM_H

#include <stddef.h>

#include "fmi3Functions.h"
#include "slave.h"
#include "state_machine.h"

/* With the GIL held: tell the slave how the host instantiated it (eventModeUsed, earlyReturnAllowed, whether
 * there is an intermediate-update callback); 0 on success, else 1 with the reason in `why`. */
int configure_slave(Instance *inst, char *why, size_t n);
/* A call of a slave method without arguments; on fmi3OK the instance moves to `next`. */
fmi3Status fmi3_simple_call(fmi3Instance instance, Call call, const char *method, MachineState next);
/* Logs that `function` is not provided by this FMU (for a non-NULL instance) and answers fmi3Error. */
fmi3Status not_provided(fmi3Instance instance, const char *function);

#endif
