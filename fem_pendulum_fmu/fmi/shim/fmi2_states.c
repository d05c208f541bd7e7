/* The six FMI 2.0 FMU state functions: fmu_state_calls.c under their FMI 2.0 names. */
#include "fmi2Functions.h"
#include "fmu_state_calls.h"

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *s) { return state_get(c, CALL_fmi2GetFMUstate, s); }

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate s) { return state_set(c, CALL_fmi2SetFMUstate, s); }

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *s) { return state_free(c, CALL_fmi2FreeFMUstate, s); }

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate s, size_t *size) {
    return state_size(c, CALL_fmi2SerializedFMUstateSize, s, size);
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate s, fmi2Byte out[], size_t size) {
    return state_serialize(c, CALL_fmi2SerializeFMUstate, s, out, size);
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte bytes[], size_t size, fmi2FMUstate *s) {
    return state_deserialize(c, CALL_fmi2DeSerializeFMUstate, bytes, size, s);
}
