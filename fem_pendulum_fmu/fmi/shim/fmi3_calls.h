/* The FMI 3.0 co-simulation state machine of the FMI 3.0 FMU (state_machine.h includes this when the
 * binary is built with FMI3_BINARY): which call is allowed in which state.
 *
 * The standard's co-simulation states, restricted to those this FMU can be in: instantiated,
 * initializationMode, eventMode (only for an instance made with eventModeUsed), stepMode (named
 * STATE_STEP_COMPLETE, shared with the FMI 2.0 table) and terminated. Not entered, as in FMI 2.0
 * (state_machine.h): configurationMode (no structural parameters), intermediateUpdateMode as a state
 * of its own (the host's callback runs inside fmi3DoStep, where only the calls the callback may make
 * are answered: fmi3_step.c), reconfigurationMode, error (a refused call changes nothing) and fatal.
 * docs/reference/fmi3.md has the table in words. */
#ifndef FEM_PENDULUM_FMI3_CALLS_H
#define FEM_PENDULUM_FMI3_CALLS_H

#define STEP_OR_EVENT (STATE_STEP_COMPLETE | STATE_EVENT_MODE)

/* X(call, states in which it is allowed) */
#define FMI3_CALLS(X)                                                     \
    X(fmi3SetDebugLogging, ANY_STATE)                                     \
    X(fmi3EnterInitializationMode, STATE_INSTANTIATED)                    \
    X(fmi3ExitInitializationMode, STATE_INITIALIZATION_MODE)              \
    X(fmi3EnterEventMode, STATE_STEP_COMPLETE)                            \
    X(fmi3UpdateDiscreteStates, STATE_EVENT_MODE)                         \
    X(fmi3EnterStepMode, STATE_EVENT_MODE)                                \
    X(fmi3Terminate, STEP_OR_EVENT)                                       \
    X(fmi3Reset, ANY_STATE)                                               \
    X(fmi3GetFloat64, INITIALISED)                                        \
    X(fmi3GetInt32, INITIALISED)                                          \
    X(fmi3GetInt64, INITIALISED)                                          \
    X(fmi3GetBoolean, INITIALISED)                                        \
    X(fmi3GetString, INITIALISED)                                         \
    X(fmi3SetFloat64, SETTABLE)                                           \
    X(fmi3SetInt32, SETTABLE)                                             \
    X(fmi3SetInt64, SETTABLE)                                             \
    X(fmi3SetBoolean, SETTABLE)                                           \
    X(fmi3SetString, SETTABLE)                                            \
    X(fmi3GetFMUState, ANY_STATE)                                         \
    X(fmi3SetFMUState, ANY_STATE) /* the state after: FMU_STATE_RESTORES */ \
    X(fmi3FreeFMUState, ANY_STATE)                                        \
    X(fmi3SerializedFMUStateSize, ANY_STATE)                              \
    X(fmi3SerializeFMUState, ANY_STATE)                                   \
    X(fmi3DeserializeFMUState, ANY_STATE)                                 \
    X(fmi3GetOutputDerivatives, FMU_MAX_OUTPUT_DERIVATIVE_ORDER > 0 ? (STATE_STEP_COMPLETE | STATE_TERMINATED) : NO_STATE) \
    X(fmi3DoStep, STATE_STEP_COMPLETE)

#endif
