/* What every FMI function does first: the state machine's check, then the GIL (call_frame.h). */
#include "python_api.h"

#include <stdio.h>

#include "call_frame.h"
#include "python_runtime.h"

int exiting = 0;

/* the reset of this binary's FMI version, named in messages as its state machine's table names it */
#ifdef FMI3_BINARY
#define RESET_CALL CALL_fmi3Reset
#else
#define RESET_CALL CALL_fmi2Reset
#endif

void mark_exiting(void) { exiting = 1; }

/* Python may be called: not after the host's interpreter was finalised, nor during exit(). */
int python_usable(void) { return !exiting && python_alive(); }

/* The instance for `call`, or NULL after logging why the call is not allowed now (nothing changed). */
Instance *allowed(fmi2Component c, Call call) {
    Instance *inst = (Instance *)c;
    if (inst == NULL) return NULL;
    if (inst->fmi3.in_step) { /* FMI 3.0: called from the host's intermediate-update callback */
        log_error(inst, "%s refused: called during fmi3DoStep (from the intermediate-update callback), where this "
                  "FMU allows no other call; nothing was changed", call_name(call));
        return NULL;
    }
    int mask = allowed_states(call);
    if (!(mask & inst->state)) {
        char states[256];
        describe_states(mask, states, sizeof states);
        log_error(inst, "%s refused in state %s (allowed in: %s); nothing was changed", call_name(call),
                  state_name(inst->state), states);
        return NULL;
    }
    return inst;
}

/* Takes the GIL for a call into the slave; 0 after logging why Python cannot be called. */
int enter_python(Instance *inst, Call call, Frame *frame) {
    if (inst->slave == NULL) {
        log_error(inst, "%s refused: the instance has no Python slave (%s could not rebuild it): reset or free it",
                  call_name(call), call_name(RESET_CALL));
        return 0;
    }
    if (!python_usable()) {
        log_error(inst, "%s refused: the process is exiting or its Python has been finalised", call_name(call));
        return 0;
    }
    frame->gil = py.GILStateEnsure();
    frame->inst = inst;
    clear_reported_error();
    return 1;
}

/* allowed() and enter_python() together, for calls without arguments to check. */
Instance *begin(fmi2Component c, Call call, Frame *frame) {
    Instance *inst = allowed(c, call);
    return inst != NULL && enter_python(inst, call, frame) ? inst : NULL;
}

fmi2Status end(Frame *frame, fmi2Status status) {
    py.GILStateRelease(frame->gil);
    return status;
}

fmi2Status refuse(Instance *inst, Call call, const char *why) {
    log_error(inst, "%s refused: %s; nothing was changed", call_name(call), why);
    return fmi2Error;
}

