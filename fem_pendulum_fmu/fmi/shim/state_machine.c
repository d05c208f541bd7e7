/* The table of state_machine.h, and its names for log messages. */
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
