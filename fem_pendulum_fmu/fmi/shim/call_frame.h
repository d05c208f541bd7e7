/* The frame of an fmi2 call: the state machine's check, Python's availability and the GIL. */
#ifndef FEM_PENDULUM_CALL_FRAME_H
#define FEM_PENDULUM_CALL_FRAME_H

#include "python_api.h"

#include "slave.h"
#include "state_machine.h"

typedef struct {
    Instance *inst;
    PyGILState_STATE gil;
} Frame;

/* Set by an exit handler registered at the first fmi2Instantiate: the process is exiting and the
 * extension modules' statics may be gone, so Python is no longer called. */
extern int exiting;
void mark_exiting(void);
/* Python may be called: not after the host's interpreter was finalised, nor during exit(). */
int python_usable(void);

/* The instance for `call`, or NULL after logging why the call is not allowed now (nothing changed). */
Instance *allowed(fmi2Component c, Call call);
/* Takes the GIL for a call into the slave; 0 after logging why Python cannot be called. */
int enter_python(Instance *inst, Call call, Frame *frame);
/* allowed() and enter_python() together, for calls without arguments to check. */
Instance *begin(fmi2Component c, Call call, Frame *frame);
/* Gives the GIL back; returns `status`. */
fmi2Status end(Frame *frame, fmi2Status status);
/* Logs "<call> refused: <why>; nothing was changed" and answers fmi2Error. */
fmi2Status refuse(Instance *inst, Call call, const char *why);

#endif
