/* The FMU state functions of this project's FMUs (FMI 2.0, section 2.1.8; FMI 3.0, section 3.2.4), shared
 * by both binaries: fmi2_states.c and fmi3_states.c are their exported names (fmu_state_calls.h).
 *
 * A state is the slave's state object behind a handle of fmu_states.h, with the instance's state (mode) when it
 * was taken: a pointer that is not a live handle of this instance is refused without being read through.
 * Serialised, a state is a header of this binary (magic, format version, the mode, the FMU's GUID, the time)
 * followed by the slave's bytes, so fmi2DeSerializeFMUstate refuses another FMU's or a damaged state before the
 * slave sees it, and the slave (fmi/fmu_state.py) then checks that the state fits this instance's model. Setting
 * a state moves the instance to the state machine's FMU_STATE_RESTORES (state_machine.h). */
#include "python_api.h"

#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "call_frame.h"
#include "fmu_build.h"
#include "fmi2Functions.h"
#include "fmu_state_calls.h"
#include "slave.h"


#ifdef FMI3_BINARY
#define MAGIC "FEMPFMU3"
#define STATE_WORD "FMUState" /* the FMI 3.0 spelling of the functions and capability flags */
#define DESERIALIZE "Deserialize"
#else
#define MAGIC "FEMPFMU2"
#define STATE_WORD "FMUstate"
#define DESERIALIZE "DeSerialize"
#endif
#define FMI_PREFIX (MAGIC[7] == '3' ? "fmi3" : "fmi2")
#define FORMAT_VERSION 2u /* 2: the mode in the header (1 had a reserved word there) */

typedef struct {
    char magic[8];
    uint32_t version;
    uint32_t mode; /* the instance's MachineState when the state was taken */
    char guid[48];
    double time;
    uint64_t payload;
} Header; /* 80 bytes, native byte order */

static const char *const NOT_PROVIDED = "this FMU does not provide FMU states (canGetAndSet" STATE_WORD "=\"false\")";
static const char *const NOT_SERIALISABLE = "this FMU cannot serialise FMU states (canSerialize" STATE_WORD "=\"false\")";

/* Why `handle` is not a state of this instance. */
static const char *unknown_state(const void *handle) {
    if (handle == NULL) return "the state is NULL";
    if (is_handle(handle)) return "the state was freed, or is another instance's";
#ifdef FMI3_BINARY
    return "it is not an FMU state (take one with fmi3GetFMUState or fmi3DeserializeFMUState)";
#else
    return "it is not an FMU state (take one with fmi2GetFMUstate or fmi2DeSerializeFMUstate)";
#endif
}

/* The live state of this instance that `handle` stands for, or NULL after refusing the call. */
static SavedState *find_state(Instance *inst, Call call, const void *handle) {
    SavedState *entry = registry_find(&inst->states, handle);
    if (entry == NULL) refuse(inst, call, unknown_state(handle));
    return entry;
}

static void release_entry(SavedState *entry) {
    if (entry->python_state) py.DecRef((PyObject *)entry->python_state);
    if (entry->serialised) py.DecRef((PyObject *)entry->serialised);
    entry->python_state = entry->serialised = NULL;
}

void release_all_states(Instance *inst) {
    for (size_t k = 0; k < inst->states.n; k++) release_entry(&inst->states.items[k]);
}

/* Keep `object` (a new reference) as the state *s: in place when *s is a live state of this
 * instance (FMI 2.0: fmi2GetFMUstate into a state already handed out), else (*s is NULL, checked by
 * target_problem) under a new handle. */
static fmi2Status keep_state(Instance *inst, Call call, fmi2FMUstate *s, PyObject *object, PyObject *bytes,
                             double time, int mode) {
    SavedState *entry = registry_find(&inst->states, *s);
    if (entry != NULL) {
        release_entry(entry);
    } else if ((entry = registry_add(&inst->states)) == NULL) {
        py.DecRef(object);
        if (bytes) py.DecRef(bytes);
        return refuse(inst, call, "out of memory for another FMU state");
    }
    entry->python_state = object;
    entry->serialised = bytes;
    entry->time = time;
    entry->mode = mode;
    *s = entry->handle;
    return fmi2OK;
}

/* The common checks; the instance, or NULL after refusing. */
static Instance *state_call(fmi2Component c, Call call, int serialising) {
    Instance *inst = allowed(c, call);
    if (inst == NULL) return NULL;
    if (!FMU_CAN_GET_SET_STATE || (serialising && !FMU_CAN_SERIALIZE_STATE)) {
        refuse(inst, call, FMU_CAN_GET_SET_STATE ? NOT_SERIALISABLE : NOT_PROVIDED);
        return NULL;
    }
    return inst;
}

/* Why *s cannot receive a state, or NULL: FMI 2.0 wants NULL there (a new state) or a state this
 * instance handed out (replaced in place); anything else is refused rather than overwritten. */
static const char *target_problem(Instance *inst, fmi2FMUstate *s) {
    if (s == NULL) return "the address of the state is NULL";
    if (*s == NULL || registry_find(&inst->states, *s) != NULL) return NULL;
    return is_handle(*s) ? "*FMUstate holds a state that was freed, or is another instance's (set it to NULL first)"
                         : "*FMUstate is neither NULL nor a state of this instance (set it to NULL first)";
}

fmi2Status state_get(void *c, Call call, fmi2FMUstate *s) {
    Frame f;
    Instance *inst = state_call(c, call, 0);
    if (inst == NULL) return fmi2Error;
    const char *bad = target_problem(inst, s);
    if (bad != NULL) return refuse(inst, call, bad);
    if (!enter_python(inst, call, &f)) return fmi2Error;
    PyObject *object = py.CallMethod(inst->slave, "_get_fmu_state", NULL);
    if (object) py.IncRef(object); /* slave_settle drops one reference */
    fmi2Status status = slave_settle(inst, call_name(call), object, fmi2OK);
    if (status == fmi2OK) status = keep_state(inst, call, s, object, NULL, inst->time, (int)inst->state);
    else if (object) py.DecRef(object);
    return end(&f, status);
}

/* Why a state taken in `taken` cannot be set in the instance's state (FMU_STATE_RESTORES), or NULL. */
static const char *restore_problem(const Instance *inst, int taken, char *why, size_t n) {
    if (restored_state(inst->state, taken) != RESTORE_REFUSED) return NULL;
    char states[256];
    describe_states(restorable_in(taken), states, sizeof states);
    snprintf(why, n, "the state was taken in state %s, and a state taken there can be set in: %s (this instance is "
             "in state %s)", state_name((MachineState)taken), states, state_name(inst->state));
    return why;
}

fmi2Status state_set(void *c, Call call, fmi2FMUstate s) {
    Frame f;
    char why[512];
    Instance *inst = state_call(c, call, 0);
    SavedState *entry = inst ? find_state(inst, call, s) : NULL;
    if (entry == NULL) return fmi2Error;
    const char *bad = restore_problem(inst, entry->mode, why, sizeof why);
    if (bad != NULL) return refuse(inst, call, bad);
    if (!enter_python(inst, call, &f)) return fmi2Error;
    PyObject *r = py.CallMethod(inst->slave, "_set_fmu_state", "(O)", (PyObject *)entry->python_state);
    fmi2Status status = slave_settle(inst, call_name(call), r, fmi2OK);
    if (status == fmi2OK) {
        take_slave_time(inst, entry->time);
        inst->cannot_continue = 0;
        MachineState after = (MachineState)restored_state(inst->state, entry->mode);
        if (after == STATE_INSTANTIATED) inst->restored = 1;
        inst->state = after;
    }
    return end(&f, status);
}

fmi2Status state_free(void *c, Call call, fmi2FMUstate *s) {
    Frame f;
    Instance *inst = state_call(c, call, 0);
    if (inst == NULL) return fmi2Error;
    if (s == NULL) return fmi2OK; /* nothing to free */
    fmi2FMUstate handle = (fmi2FMUstate)s; /* a host may pass the state where its address is due */
    int by_value = is_handle(handle);
    if (!by_value) {
        handle = *s; /* s is not ours: the host's variable, read as FMI 2.0 says */
        if (handle == NULL) return fmi2OK;
    }
    SavedState *entry = find_state(inst, call, handle);
    if (entry == NULL) return fmi2Error;
    if (!python_usable()) { /* exiting: the state's Python objects are left to the process */
        registry_remove(&inst->states, entry);
    } else {
        if (!enter_python(inst, call, &f)) return fmi2Error;
        release_entry(entry);
        registry_remove(&inst->states, entry);
        end(&f, fmi2OK);
    }
    if (!by_value) *s = NULL;
    return fmi2OK;
}

/* The slave's bytes of a state (kept on the entry), or NULL after the call was refused. */
static PyObject *state_bytes(Instance *inst, Call call, SavedState *entry) {
    if (entry->serialised == NULL) {
        PyObject *bytes = py.CallMethod(inst->slave, "_fmu_state_to_bytes", "(O)", (PyObject *)entry->python_state);
        char *data;
        Py_ssize_t size;
        if (bytes != NULL && py.BytesAsStringAndSize(bytes, &data, &size) != 0) {
            py.DecRef(bytes);
            bytes = NULL;
        }
        if (bytes) py.IncRef(bytes); /* slave_settle drops one reference */
        if (slave_settle(inst, call_name(call), bytes, fmi2OK) != fmi2OK) {
            if (bytes) py.DecRef(bytes);
            return NULL;
        }
        entry->serialised = bytes;
    }
    return (PyObject *)entry->serialised;
}

static size_t serialised_size(PyObject *bytes) {
    char *data;
    Py_ssize_t size = 0;
    py.BytesAsStringAndSize(bytes, &data, &size);
    return sizeof(Header) + (size_t)size;
}

fmi2Status state_size(void *c, Call call, fmi2FMUstate s, size_t *size) {
    Frame f;
    Instance *inst = state_call(c, call, 1);
    if (inst == NULL) return fmi2Error;
    if (size == NULL) return refuse(inst, call, "the size pointer is NULL");
    SavedState *entry = find_state(inst, call, s);
    if (entry == NULL || !enter_python(inst, call, &f)) return fmi2Error;
    PyObject *bytes = state_bytes(inst, call, entry);
    if (bytes != NULL) *size = serialised_size(bytes);
    return end(&f, bytes ? fmi2OK : fmi2Error);
}

fmi2Status state_serialize(void *c, Call call, fmi2FMUstate s, fmi2Byte out[], size_t size) {
    Frame f;
    Instance *inst = state_call(c, call, 1);
    if (inst == NULL) return fmi2Error;
    if (out == NULL) return refuse(inst, call, "the buffer is NULL");
    SavedState *entry = find_state(inst, call, s);
    if (entry == NULL || !enter_python(inst, call, &f)) return fmi2Error;
    PyObject *bytes = state_bytes(inst, call, entry);
    if (bytes == NULL) return end(&f, fmi2Error);
    size_t need = serialised_size(bytes);
    if (size < need) {
        char why[256];
        snprintf(why, sizeof why, "the buffer has %zu bytes, the state needs %zu (%sSerialized" STATE_WORD "Size)", size,
                 need, FMI_PREFIX);
        return end(&f, refuse(inst, call, why));
    }
    Header header = {
        .version = FORMAT_VERSION, .mode = (uint32_t)entry->mode, .time = entry->time, .payload = need - sizeof(Header)};
    memcpy(header.magic, MAGIC, sizeof header.magic);
    snprintf(header.guid, sizeof header.guid, "%s", FMU_GUID);
    char *data;
    Py_ssize_t n;
    py.BytesAsStringAndSize(bytes, &data, &n);
    memcpy(out, &header, sizeof header);
    memcpy(out + sizeof header, data, (size_t)n);
    return end(&f, fmi2OK);
}

/* Why `bytes` are not a serialised state of this FMU, or NULL. */
static const char *bad_header(const fmi2Byte bytes[], size_t size, Header *header, char *why, size_t n) {
    if (size < sizeof(Header)) {
        snprintf(why, n, "%zu bytes are too few for a serialised state of this FMU (at least %zu)", size,
                 sizeof(Header));
        return why;
    }
    memcpy(header, bytes, sizeof *header);
    if (memcmp(header->magic, MAGIC, sizeof header->magic) != 0)
        return "the bytes are not a serialised state of this FMU (no " MAGIC " header)";
    if (header->version != FORMAT_VERSION) {
        snprintf(why, n, "the state's format version is %u, this FMU reads %u", header->version, FORMAT_VERSION);
        return why;
    }
    header->guid[sizeof header->guid - 1] = '\0';
    if (strcmp(header->guid, FMU_GUID) != 0) {
        snprintf(why, n, "the state is of the FMU with GUID %s, this one is %s", header->guid, FMU_GUID);
        return why;
    }
    if (header->payload != size - sizeof(Header)) {
        snprintf(why, n, "the state is truncated or padded: %zu bytes, its header says %zu", size,
                 (size_t)(header->payload + sizeof(Header)));
        return why;
    }
    if (restorable_in((int)header->mode) == 0) {
        snprintf(why, n, "the state is damaged: its mode %u is no state of this FMU", header->mode);
        return why;
    }
    return NULL;
}

fmi2Status state_deserialize(void *c, Call call, const fmi2Byte bytes[], size_t size, fmi2FMUstate *s) {
    Frame f;
    Instance *inst = state_call(c, call, 1);
    if (inst == NULL) return fmi2Error;
    const char *bad = target_problem(inst, s);
    if (bad != NULL) return refuse(inst, call, bad);
    if (bytes == NULL && size > 0) return refuse(inst, call, "the bytes are NULL");
    Header header;
    char why[512];
    bad = bad_header(bytes, size, &header, why, sizeof why);
    if (bad != NULL) return refuse(inst, call, bad);
    if (!enter_python(inst, call, &f)) return fmi2Error;
    PyObject *payload = py.BytesFromStringAndSize((const char *)bytes + sizeof header, (Py_ssize_t)header.payload);
    PyObject *object = payload ? py.CallMethod(inst->slave, "_fmu_state_from_bytes", "(O)", payload) : NULL;
    if (object) py.IncRef(object); /* slave_settle drops one reference */
    fmi2Status status = slave_settle(inst, call_name(call), object, fmi2OK);
    if (status == fmi2OK) {
        status = keep_state(inst, call, s, object, payload, header.time, (int)header.mode);
    } else {
        if (object) py.DecRef(object);
        if (payload) py.DecRef(payload);
    }
    return end(&f, status);
}
