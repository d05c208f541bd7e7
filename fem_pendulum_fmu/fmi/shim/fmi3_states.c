/* The six FMI 3.0 FMU state functions: fmu_state_calls.c under their FMI 3.0 names. */
#include "fmi3Functions.h"
#include "fmu_state_calls.h"

fmi3Status fmi3GetFMUState(fmi3Instance instance, fmi3FMUState *s) {
    return (fmi3Status)state_get(instance, CALL_fmi3GetFMUState, s);
}

fmi3Status fmi3SetFMUState(fmi3Instance instance, fmi3FMUState s) {
    return (fmi3Status)state_set(instance, CALL_fmi3SetFMUState, s);
}

fmi3Status fmi3FreeFMUState(fmi3Instance instance, fmi3FMUState *s) {
    return (fmi3Status)state_free(instance, CALL_fmi3FreeFMUState, s);
}

fmi3Status fmi3SerializedFMUStateSize(fmi3Instance instance, fmi3FMUState s, size_t *size) {
    return (fmi3Status)state_size(instance, CALL_fmi3SerializedFMUStateSize, s, size);
}

fmi3Status fmi3SerializeFMUState(fmi3Instance instance, fmi3FMUState s, fmi3Byte out[], size_t size) {
    return (fmi3Status)state_serialize(instance, CALL_fmi3SerializeFMUState, s, (fmi2Byte *)out, size);
}

fmi3Status fmi3DeserializeFMUState(fmi3Instance instance, const fmi3Byte bytes[], size_t size, fmi3FMUState *s) {
    return (fmi3Status)state_deserialize(instance, CALL_fmi3DeserializeFMUState, (const fmi2Byte *)bytes, size, s);
}
