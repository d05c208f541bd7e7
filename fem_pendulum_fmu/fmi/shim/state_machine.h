/* The FMI 2.0 co-simulation state machine as this project's FMUs implement it: which call is allowed
 * in which state (the standard's section 4.2.4 table, restricted to the states these FMUs can be in).
 *
 * Not entered: stepFailed (a doStep that answers fmi2Discard leaves the model as at the start of the
 * step, so the instance stays in stepComplete and may retry), stepInProgress and stepCanceled (doStep
 * is synchronous and never answers fmi2Pending), error (a call answered fmi2Error changes nothing) and
 * fatal (never answered). docs/reference/fmi2.md has the table in words. */
#ifndef FEM_PENDULUM_STATE_MACHINE_H
#define FEM_PENDULUM_STATE_MACHINE_H

#include "fmu_build.h"

typedef enum {
    STATE_INSTANTIATED = 1 << 0,
    STATE_INITIALIZATION_MODE = 1 << 1,
    STATE_STEP_COMPLETE = 1 << 2,
    STATE_TERMINATED = 1 << 3,
    STATE_EVENT_MODE = 1 << 4, /* FMI 3.0 only (eventModeUsed): fmi3_functions.c */
} MachineState;

#define ANY_STATE \
    (STATE_INSTANTIATED | STATE_INITIALIZATION_MODE | STATE_STEP_COMPLETE | STATE_TERMINATED | STATE_EVENT_MODE)
#define INITIALISED (STATE_INITIALIZATION_MODE | STATE_STEP_COMPLETE | STATE_TERMINATED | STATE_EVENT_MODE)
#define SETTABLE (STATE_INSTANTIATED | STATE_INITIALIZATION_MODE | STATE_STEP_COMPLETE | STATE_EVENT_MODE)
#define NO_STATE 0 /* a function this FMU does not provide: refused in every state */
/* input derivatives are inputs (FMI 2.0: the restrictions of fmi2SetReal); output derivatives are read
 * where the standard allows it of the states these FMUs enter: after a step and once terminated */
#define INPUT_DERIVATIVES (FMU_INPUT_DERIVATIVE_ORDER > 0 ? SETTABLE : NO_STATE)
#define OUTPUT_DERIVATIVES (FMU_MAX_OUTPUT_DERIVATIVE_ORDER > 0 ? (STATE_STEP_COMPLETE | STATE_TERMINATED) : NO_STATE)

/* X(call, states in which it is allowed) */
#define FMI2_CALLS(X)                                                     \
    X(fmi2SetDebugLogging, ANY_STATE)                                     \
    X(fmi2SetupExperiment, STATE_INSTANTIATED)                            \
    X(fmi2EnterInitializationMode, STATE_INSTANTIATED)                    \
    X(fmi2ExitInitializationMode, STATE_INITIALIZATION_MODE)              \
    X(fmi2Terminate, STATE_STEP_COMPLETE)                                 \
    X(fmi2Reset, ANY_STATE)                                               \
    X(fmi2GetReal, INITIALISED)                                           \
    X(fmi2GetInteger, INITIALISED)                                        \
    X(fmi2GetBoolean, INITIALISED)                                        \
    X(fmi2GetString, INITIALISED)                                         \
    X(fmi2SetReal, SETTABLE)                                              \
    X(fmi2SetInteger, SETTABLE)                                           \
    X(fmi2SetBoolean, SETTABLE)                                           \
    X(fmi2SetString, SETTABLE)                                            \
    X(fmi2GetFMUstate, ANY_STATE)                                         \
    X(fmi2SetFMUstate, ANY_STATE) /* the state after: FMU_STATE_RESTORES */ \
    X(fmi2FreeFMUstate, ANY_STATE)                                        \
    X(fmi2SerializedFMUstateSize, ANY_STATE)                              \
    X(fmi2SerializeFMUstate, ANY_STATE)                                   \
    X(fmi2DeSerializeFMUstate, ANY_STATE)                                 \
    X(fmi2GetDirectionalDerivative, NO_STATE)                             \
    X(fmi2SetRealInputDerivatives, INPUT_DERIVATIVES)                     \
    X(fmi2GetRealOutputDerivatives, OUTPUT_DERIVATIVES)                   \
    X(fmi2DoStep, STATE_STEP_COMPLETE)                                    \
    X(fmi2CancelStep, NO_STATE)                                           \
    X(fmi2GetStatus, STATE_STEP_COMPLETE | STATE_TERMINATED)              \
    X(fmi2GetRealStatus, STATE_STEP_COMPLETE | STATE_TERMINATED)          \
    X(fmi2GetIntegerStatus, STATE_STEP_COMPLETE | STATE_TERMINATED)       \
    X(fmi2GetBooleanStatus, STATE_STEP_COMPLETE | STATE_TERMINATED)       \
    X(fmi2GetStringStatus, STATE_STEP_COMPLETE | STATE_TERMINATED)

/* The FMI 3.0 binary (built with FMI3_BINARY defined) has its own table: fmi3_calls.h. */
#ifdef FMI3_BINARY
#include "fmi3_calls.h"
#define FMU_CALLS FMI3_CALLS
#else
#define FMU_CALLS FMI2_CALLS
#endif

/* What setting an FMU state (fmi2SetFMUstate, fmi3SetFMUState: allowed in every state above) does to the
 * instance's state, by the state the FMU state was taken in. Only an instance not yet initialised changes: set to
 * an FMU state taken after initialisation it is in stepComplete (FMI 3.0: stepMode) with that state's parameters,
 * time and model, and steps on without initialisation, as a host resuming a saved run in a new instance expects
 * (fmpy's simulate_fmu given fmu_state); an FMU state taken in eventMode counts as one taken stepping (this FMU's
 * event mode updates nothing). An FMU state taken before initialisation has no model to step on; one taken once
 * terminated may only be read in a terminated instance.
 * X(the instance's state, after an FMU state taken before initialisation [instantiated, initializationMode],
 * after one taken stepping [stepComplete, eventMode], after one taken in terminated); RESTORE_REFUSED: fmi2Error,
 * nothing changed. docs/reference/fmi2.md, "Setting an FMU state". */
#define RESTORE_REFUSED NO_STATE
#define FMU_STATE_RESTORES(X)                                                                          \
    X(STATE_INSTANTIATED, STATE_INSTANTIATED, STATE_STEP_COMPLETE, RESTORE_REFUSED)                   \
    X(STATE_INITIALIZATION_MODE, STATE_INITIALIZATION_MODE, STATE_STEP_COMPLETE, RESTORE_REFUSED)     \
    X(STATE_STEP_COMPLETE, RESTORE_REFUSED, STATE_STEP_COMPLETE, RESTORE_REFUSED)                     \
    X(STATE_EVENT_MODE, RESTORE_REFUSED, STATE_EVENT_MODE, RESTORE_REFUSED)                           \
    X(STATE_TERMINATED, RESTORE_REFUSED, STATE_TERMINATED, STATE_TERMINATED)

#define AS_ENUM(call, states) CALL_##call,
typedef enum { FMU_CALLS(AS_ENUM) N_CALLS } Call;
#undef AS_ENUM

/* The states in which `call` is allowed (a mask of MachineState). */
int allowed_states(Call call);
const char *call_name(Call call);
const char *state_name(MachineState state);
/* "instantiated, initializationMode" or "no state (this FMU does not provide it)" */
void describe_states(int mask, char *text, size_t n);
/* The instance's state after setting, in state `current`, an FMU state taken in state `taken`
 * (FMU_STATE_RESTORES); RESTORE_REFUSED where that is refused, or `taken` is no state. */
int restored_state(MachineState current, int taken);
/* The states in which an FMU state taken in `taken` can be set (a mask; 0: `taken` is no state). */
int restorable_in(int taken);

#endif
