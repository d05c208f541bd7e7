/* The tables of state_machine.h, and its names for log messages. */
#include <stddef.h>
#include <stdio.h>
#include <string.h>

#include "state_machine.h"

#define AS_MASK(call, states) states,
#define AS_NAME(call, states) #call,
static const int masks[N_CALLS] = {FMU_CALLS(AS_MASK)};
static const char *const names[N_CALLS] = {FMU_CALLS(AS_NAME)};

int allowed_states(Call call) { return call < N_CALLS ? masks[call] : NO_STATE; }

const char *call_name(Call call) { return call < N_CALLS ? names[call] : "an unknown call"; }

const char *state_name(MachineState state) {
    switch (state) {
    case STATE_INSTANTIATED: return "instantiated";
    case STATE_INITIALIZATION_MODE: return "initializationMode";
#ifdef FMI3_BINARY
    case STATE_STEP_COMPLETE: return "stepMode";
#else
    case STATE_STEP_COMPLETE: return "stepComplete";
#endif
    case STATE_TERMINATED: return "terminated";
    case STATE_EVENT_MODE: return "eventMode";
    }
    return "unknown";
}

void describe_states(int mask, char *text, size_t n) {
    static const MachineState all[] = {STATE_INSTANTIATED, STATE_INITIALIZATION_MODE, STATE_STEP_COMPLETE,
#ifdef FMI3_BINARY /* the FMI 2.0 binary never enters event mode: its messages do not name it */
                                       STATE_EVENT_MODE,
#endif
                                       STATE_TERMINATED};
    size_t k = 0;
    text[0] = '\0';
    for (size_t s = 0; s < sizeof all / sizeof all[0] && k < n; s++)
        if (mask & all[s]) k += (size_t)snprintf(text + k, n - k, "%s%s", k ? ", " : "", state_name(all[s]));
    if (k == 0) snprintf(text, n, "no state: this FMU does not provide it (see modelDescription.xml)");
}

/* An FMU state's column of FMU_STATE_RESTORES: taken before initialisation, stepping or once terminated; -1 for
 * what is no state (a damaged header). */
static int restore_column(int taken) {
    switch (taken) {
    case STATE_INSTANTIATED:
    case STATE_INITIALIZATION_MODE: return 0;
    case STATE_STEP_COMPLETE:
    case STATE_EVENT_MODE: return 1;
    case STATE_TERMINATED: return 2;
    }
    return -1;
}

#define AS_RESTORE(current, before, stepping, terminated) {current, {before, stepping, terminated}},
static const struct {
    MachineState current;
    int after[3];
} restores[] = {FMU_STATE_RESTORES(AS_RESTORE)};
#define N_RESTORES (sizeof restores / sizeof restores[0])

int restored_state(MachineState current, int taken) {
    int column = restore_column(taken);
    for (size_t k = 0; column >= 0 && k < N_RESTORES; k++)
        if (restores[k].current == current) return restores[k].after[column];
    return RESTORE_REFUSED;
}

int restorable_in(int taken) {
    int column = restore_column(taken), mask = 0;
    for (size_t k = 0; column >= 0 && k < N_RESTORES; k++)
        if (restores[k].after[column] != RESTORE_REFUSED) mask |= restores[k].current;
    return mask;
}
