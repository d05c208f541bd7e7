/* A native FMI 2.0 co-simulation host driven line by line: the executor of tests/fmi2_sequences.py.
 *
 * Build:  cc -I<fmpy>/c-code fmi2_sequence_host.c -ldl -o fmi2_sequence_host
 * Run:    the driver writes one command per line on stdin; the host answers one line per command on stdout,
 *         "@@ans <answer>" (flushed at once), and prints every message of the FMUs' logger on stderr, one per line:
 *         "[log <instance> <status> <category>] <message>".
 *
 * The host keeps what a master keeps: two loaded FMU binaries (libraries 0..1), two instances
 * (slots 0..1), 16 FMU state variables (state slots, each an fmi2FMUstate a master would hold) and
 * 8 byte buffers (serialised states). It judges nothing: tests/fmi2_sequences.py is the oracle.
 *
 * Commands (tokens separated by one space; a string token is percent-encoded, "@null" is NULL):
 *   load L FOLDER ID                 dlopen FOLDER/binaries/linux64/ID.so -> "ok" | "fail <why>"
 *   instantiate K L NAME GUID TYPE VISIBLE LOGGING CALLBACKS   CALLBACKS: full | nologger | null
 *                                    -> "ok" | "null"
 *   free K                           fmi2FreeInstance -> "done"
 *   debug K ON CAT...                fmi2SetDebugLogging with the remaining tokens as categories
 *   setup K TOLDEF TOL START STOPDEF STOP | enter K | exit K | terminate K | reset K | cancel K
 *   getreal|getint|getbool|getstring K N VR...         -> "<status> <value>..."
 *   setreal|setint|setbool|setstring K N VR... VALUE...
 *   dostep K T H NOSET
 *   status|realstatus|intstatus|boolstatus|stringstatus K KIND NULLVALUE   -> "<status> <value>"
 *   dirderiv K
 *   setinder K N VR... ORDER... VALUE...  fmi2SetRealInputDerivatives -> "<status>"
 *   getoutder K N VR... ORDER...          fmi2GetRealOutputDerivatives -> "<status> <value>..."
 *   getstate K J                     fmi2GetFMUstate(c, &slot[J])         -> "<status> <slot J after>"
 *   setstate K J                     fmi2SetFMUstate(c, slot[J])
 *   freestate K J MODE               MODE addr: &slot[J]; value: slot[J] itself where its address is due;
 *                                    null: NULL                          -> "<status> <slot J after>"
 *   size K J NULLOUT                 fmi2SerializedFMUstateSize           -> "<status> <n>"
 *   serialize K J MODE DELTA B       the size first, then fmi2SerializeFMUstate into a buffer of
 *                                    n (exact), n + DELTA (larger), n - DELTA (smaller) or NULL (nullbuf)
 *                                    -> "<size status> <n> <status> <untouched> <hash>": untouched is 1
 *                                    when no byte from n (smaller, nullbuf: from 0) to the end of the
 *                                    buffer and its guard of 64 bytes changed; on fmi2OK the first n
 *                                    bytes go to byte buffer B
 *   deser K J B MODE ARG             fmi2DeSerializeFMUstate(c, bytes, size, &slot[J]) of: real (buffer B),
 *                                    trunc (its first ARG bytes), magic (buffer B, first 4 bytes
 *                                    inverted), flip (buffer B, byte ARG xor 0x20), empty (size 0), nullbuf
 *                                    (NULL, 0), junk (ARG random bytes from seed B), nullout (buffer B,
 *                                    NULL state pointer)
 *                                    -> "<status> <slot J after>"
 *   slot OP J I                      host side only: copy (slot[I] = slot[J]), null, heap (a fresh
 *                                    readable block of junk), static (inside a static array of junk),
 *                                    small (the address 0x40) -> "<slot J>"
 *   version L | platform L           -> the string
 *   clear                            host side only: all state slots NULL, all byte buffers empty -> "ok"
 *   dump B                           byte buffer B in hex (empty: "-")
 *   ping                             -> "pong"
 *   quit                             frees what is left, exits 0
 * A pointer is printed as hex (0 for NULL); a Real with %.17g (nan, inf as C prints them).
 */
#include <dlfcn.h>
#include <inttypes.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "fmi2Functions.h"

#define N_LIBS 2
#define N_INSTANCES 2
#define N_STATES 16
#define N_BUFFERS 8
#define GUARD 64
#define MAX_TOKENS 256

typedef struct {
    void *handle;
    char resources[4200];
#define FIELD(name) name##TYPE *name;
    FIELD(fmi2GetTypesPlatform) FIELD(fmi2GetVersion) FIELD(fmi2SetDebugLogging) FIELD(fmi2Instantiate)
    FIELD(fmi2FreeInstance) FIELD(fmi2SetupExperiment) FIELD(fmi2EnterInitializationMode)
    FIELD(fmi2ExitInitializationMode) FIELD(fmi2Terminate) FIELD(fmi2Reset) FIELD(fmi2GetReal)
    FIELD(fmi2GetInteger) FIELD(fmi2GetBoolean) FIELD(fmi2GetString) FIELD(fmi2SetReal) FIELD(fmi2SetInteger)
    FIELD(fmi2SetBoolean) FIELD(fmi2SetString) FIELD(fmi2GetFMUstate) FIELD(fmi2SetFMUstate)
    FIELD(fmi2FreeFMUstate) FIELD(fmi2SerializedFMUstateSize) FIELD(fmi2SerializeFMUstate)
    FIELD(fmi2DeSerializeFMUstate) FIELD(fmi2GetDirectionalDerivative) FIELD(fmi2SetRealInputDerivatives)
    FIELD(fmi2GetRealOutputDerivatives) FIELD(fmi2DoStep) FIELD(fmi2CancelStep) FIELD(fmi2GetStatus)
    FIELD(fmi2GetRealStatus) FIELD(fmi2GetIntegerStatus) FIELD(fmi2GetBooleanStatus) FIELD(fmi2GetStringStatus)
#undef FIELD
} Library;

static Library libs[N_LIBS];
static fmi2Component instances[N_INSTANCES];
static int instance_lib[N_INSTANCES];
static fmi2FMUstate states[N_STATES];
static fmi2Byte *buffers[N_BUFFERS];
static size_t buffer_sizes[N_BUFFERS];
static unsigned char static_junk[N_STATES * 32];
static uint64_t junk_seed = 0x9E3779B97F4A7C15ull;

static void log_message(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status, fmi2String category,
                        fmi2String message, ...) {
    (void)env;
    char text[8192];
    va_list args;
    va_start(args, message);
    vsnprintf(text, sizeof text, message ? message : "(null)", args);
    va_end(args);
    for (char *p = text; *p; p++)
        if (*p == '\n') *p = ' ';
    fprintf(stderr, "[log %s %d %s] %s\n", name ? name : "(null)", (int)status, category ? category : "(null)", text);
    fflush(stderr);
}

static fmi2CallbackFunctions full_callbacks = {log_message, calloc, free, NULL, NULL};
static fmi2CallbackFunctions no_logger_callbacks = {NULL, calloc, free, NULL, NULL};

static uint64_t next_random(uint64_t *s) { /* xorshift64* */
    *s ^= *s >> 12;
    *s ^= *s << 25;
    *s ^= *s >> 27;
    return *s * 0x2545F4914F6CDD1Dull;
}

/* In place: "%41%42" -> "AB"; returns NULL for "@null". */
static char *decode(char *token) {
    if (strcmp(token, "@null") == 0) return NULL;
    char *out = token;
    for (char *in = token; *in; out++) {
        unsigned int byte;
        if (in[0] == '%' && in[1] && in[2] && sscanf(in + 1, "%2x", &byte) == 1) {
            *out = (char)byte;
            in += 3;
        } else {
            *out = *in++;
        }
    }
    *out = '\0';
    return token;
}

/* The answer to the command being executed, printed as one line "@@ans <answer>" when it is done: anything
 * else on stdout (an FMU that prints) is not mistaken for an answer. */
static char answer[1 << 21];
static size_t answer_len = 0;

static void out(const char *format, ...) {
    va_list args;
    va_start(args, format);
    int n = vsnprintf(answer + answer_len, sizeof answer - answer_len, format, args);
    va_end(args);
    if (n > 0) answer_len += (size_t)n < sizeof answer - answer_len ? (size_t)n : sizeof answer - answer_len - 1;
}

static void print_encoded(const char *s) {
    if (s == NULL) {
        out("@null");
        return;
    }
    if (*s == '\0') out("%%00"); /* an empty string: a token of its own */
    for (const unsigned char *p = (const unsigned char *)s; *p; p++) {
        if (*p <= ' ' || *p == '%' || *p >= 0x7f)
            out("%%%02X", *p);
        else
            out("%c", *p);
    }
}

static void print_pointer(const void *p) { out("%" PRIxPTR, (uintptr_t)p); }

static int load(int l, const char *folder, const char *id) {
    char path[4200];
    snprintf(path, sizeof path, "%s/binaries/linux64/%s.so", folder, id);
    snprintf(libs[l].resources, sizeof libs[l].resources, "file://%s/resources", folder);
    void *h = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (h == NULL) {
        out("fail cannot_load_%s", path);
        return 0;
    }
    libs[l].handle = h;
#define RESOLVE(name)                                       \
    libs[l].name = (name##TYPE *)dlsym(h, #name);           \
    if (libs[l].name == NULL) {                             \
        out("fail missing_%s", #name);                 \
        return 0;                                           \
    }
    RESOLVE(fmi2GetTypesPlatform) RESOLVE(fmi2GetVersion) RESOLVE(fmi2SetDebugLogging) RESOLVE(fmi2Instantiate)
    RESOLVE(fmi2FreeInstance) RESOLVE(fmi2SetupExperiment) RESOLVE(fmi2EnterInitializationMode)
    RESOLVE(fmi2ExitInitializationMode) RESOLVE(fmi2Terminate) RESOLVE(fmi2Reset) RESOLVE(fmi2GetReal)
    RESOLVE(fmi2GetInteger) RESOLVE(fmi2GetBoolean) RESOLVE(fmi2GetString) RESOLVE(fmi2SetReal)
    RESOLVE(fmi2SetInteger) RESOLVE(fmi2SetBoolean) RESOLVE(fmi2SetString) RESOLVE(fmi2GetFMUstate)
    RESOLVE(fmi2SetFMUstate) RESOLVE(fmi2FreeFMUstate) RESOLVE(fmi2SerializedFMUstateSize)
    RESOLVE(fmi2SerializeFMUstate) RESOLVE(fmi2DeSerializeFMUstate) RESOLVE(fmi2GetDirectionalDerivative)
    RESOLVE(fmi2SetRealInputDerivatives) RESOLVE(fmi2GetRealOutputDerivatives) RESOLVE(fmi2DoStep)
    RESOLVE(fmi2CancelStep) RESOLVE(fmi2GetStatus) RESOLVE(fmi2GetRealStatus) RESOLVE(fmi2GetIntegerStatus)
    RESOLVE(fmi2GetBooleanStatus) RESOLVE(fmi2GetStringStatus)
#undef RESOLVE
    out("ok");
    return 1;
}

static uint64_t fnv1a(const fmi2Byte *bytes, size_t n) {
    uint64_t h = 1469598103934665603ull;
    for (size_t k = 0; k < n; k++) {
        h ^= (unsigned char)bytes[k];
        h *= 1099511628211ull;
    }
    return h;
}

static int in_range(int value, int n) { return value >= 0 && value < n; }

/* One command; returns 0 on quit. */
static int execute(int argc, char **argv) {
    const char *cmd = argv[0];
    if (strcmp(cmd, "quit") == 0) return 0;
    if (strcmp(cmd, "ping") == 0) {
        out("pong");
        return 1;
    }
    if (strcmp(cmd, "dump") == 0 && argc == 2 && in_range(atoi(argv[1]), N_BUFFERS)) {
        int b = atoi(argv[1]);
        for (size_t i = 0; i < buffer_sizes[b]; i++) out("%02x", (unsigned char)buffers[b][i]);
        if (buffer_sizes[b] == 0) out("-");
        return 1;
    }
    if (strcmp(cmd, "clear") == 0) {
        for (int j = 0; j < N_STATES; j++) states[j] = NULL;
        for (int b = 0; b < N_BUFFERS; b++) {
            free(buffers[b]);
            buffers[b] = NULL;
            buffer_sizes[b] = 0;
        }
        out("ok");
        return 1;
    }
    if (strcmp(cmd, "load") == 0 && argc == 4 && in_range(atoi(argv[1]), N_LIBS)) {
        load(atoi(argv[1]), argv[2], argv[3]);
        return 1;
    }
    if ((strcmp(cmd, "version") == 0 || strcmp(cmd, "platform") == 0) && argc == 2) {
        int l = atoi(argv[1]);
        if (!in_range(l, N_LIBS) || libs[l].handle == NULL) {
            out("badcmd");
            return 1;
        }
        print_encoded(strcmp(cmd, "version") == 0 ? libs[l].fmi2GetVersion() : libs[l].fmi2GetTypesPlatform());
        return 1;
    }
    if (strcmp(cmd, "slot") == 0 && argc == 4) {
        int j = atoi(argv[2]), i = atoi(argv[3]);
        if (!in_range(j, N_STATES) || !in_range(i, N_STATES)) {
            out("badcmd");
            return 1;
        }
        const char *op = argv[1];
        if (strcmp(op, "copy") == 0) {
            states[i] = states[j];
        } else if (strcmp(op, "null") == 0) {
            states[j] = NULL;
        } else if (strcmp(op, "heap") == 0) {
            unsigned char *block = malloc(256); /* kept: a never-handed-out pointer stays readable */
            for (int k = 0; k < 256; k++) block[k] = (unsigned char)(next_random(&junk_seed) | 1);
            states[j] = block;
        } else if (strcmp(op, "static") == 0) {
            states[j] = &static_junk[32 * j + 8];
        } else if (strcmp(op, "small") == 0) {
            states[j] = (fmi2FMUstate)(uintptr_t)0x40;
        } else {
            out("badcmd");
            return 1;
        }
        print_pointer(states[j]);
        return 1;
    }
    if (argc < 2) {
        out("badcmd");
        return 1;
    }
    int k = atoi(argv[1]);
    if (!in_range(k, N_INSTANCES)) {
        out("badcmd");
        return 1;
    }
    if (strcmp(cmd, "instantiate") == 0 && argc == 9) {
        int l = atoi(argv[2]);
        if (!in_range(l, N_LIBS) || libs[l].handle == NULL || instances[k] != NULL) {
            out("badcmd");
            return 1;
        }
        const fmi2CallbackFunctions *callbacks = strcmp(argv[8], "full") == 0       ? &full_callbacks
                                                 : strcmp(argv[8], "nologger") == 0 ? &no_logger_callbacks
                                                                                    : NULL;
        char *name = decode(argv[3]), *guid = decode(argv[4]);
        instances[k] = libs[l].fmi2Instantiate(name, (fmi2Type)atoi(argv[5]), guid, libs[l].resources, callbacks,
                                               atoi(argv[6]) ? fmi2True : fmi2False,
                                               atoi(argv[7]) ? fmi2True : fmi2False);
        instance_lib[k] = l;
        out(instances[k] ? "ok" : "null");
        return 1;
    }
    fmi2Component c = instances[k];
    if (c == NULL) {
        out("badcmd");
        return 1;
    }
    Library *f = &libs[instance_lib[k]];
    fmi2Status s;
    if (strcmp(cmd, "free") == 0) {
        f->fmi2FreeInstance(c);
        instances[k] = NULL;
        out("done");
        return 1;
    }
    if (strcmp(cmd, "debug") == 0 && argc >= 3) {
        s = f->fmi2SetDebugLogging(c, atoi(argv[2]) ? fmi2True : fmi2False, (size_t)(argc - 3),
                                   (const fmi2String *)(argv + 3));
    } else if (strcmp(cmd, "setup") == 0 && argc == 7) {
        s = f->fmi2SetupExperiment(c, atoi(argv[2]) ? fmi2True : fmi2False, strtod(argv[3], NULL),
                                   strtod(argv[4], NULL), atoi(argv[5]) ? fmi2True : fmi2False,
                                   strtod(argv[6], NULL));
    } else if (strcmp(cmd, "enter") == 0) {
        s = f->fmi2EnterInitializationMode(c);
    } else if (strcmp(cmd, "exit") == 0) {
        s = f->fmi2ExitInitializationMode(c);
    } else if (strcmp(cmd, "terminate") == 0) {
        s = f->fmi2Terminate(c);
    } else if (strcmp(cmd, "reset") == 0) {
        s = f->fmi2Reset(c);
    } else if (strcmp(cmd, "cancel") == 0) {
        s = f->fmi2CancelStep(c);
    } else if (strcmp(cmd, "dostep") == 0 && argc == 5) {
        s = f->fmi2DoStep(c, strtod(argv[2], NULL), strtod(argv[3], NULL), atoi(argv[4]) ? fmi2True : fmi2False);
    } else if (strncmp(cmd, "get", 3) == 0 && argc >= 3 &&
               (strcmp(cmd, "getreal") == 0 || strcmp(cmd, "getint") == 0 || strcmp(cmd, "getbool") == 0 ||
                strcmp(cmd, "getstring") == 0)) {
        int n = atoi(argv[2]);
        if (n < 0 || n > 64 || argc != 3 + n) {
            out("badcmd");
            return 1;
        }
        fmi2ValueReference vr[64];
        for (int i = 0; i < n; i++) vr[i] = (fmi2ValueReference)strtoul(argv[3 + i], NULL, 10);
        fmi2Real reals[64];
        fmi2Integer ints[64];
        fmi2Boolean bools[64];
        fmi2String strings[64];
        char kind = cmd[3];
        if (kind == 'r')
            s = f->fmi2GetReal(c, vr, (size_t)n, reals);
        else if (kind == 'i')
            s = f->fmi2GetInteger(c, vr, (size_t)n, ints);
        else if (kind == 'b')
            s = f->fmi2GetBoolean(c, vr, (size_t)n, bools);
        else
            s = f->fmi2GetString(c, vr, (size_t)n, strings);
        out("%d", (int)s);
        for (int i = 0; i < n && s <= fmi2Warning; i++) {
            out(" ");
            if (kind == 'r')
                out("%.17g", reals[i]);
            else if (kind == 'i')
                out("%d", (int)ints[i]);
            else if (kind == 'b')
                out("%d", (int)bools[i]);
            else
                print_encoded(strings[i]);
        }
        return 1;
    } else if (strncmp(cmd, "set", 3) == 0 && argc >= 3 &&
               (strcmp(cmd, "setreal") == 0 || strcmp(cmd, "setint") == 0 || strcmp(cmd, "setbool") == 0 ||
                strcmp(cmd, "setstring") == 0)) {
        int n = atoi(argv[2]);
        if (n < 0 || n > 64 || argc != 3 + 2 * n) {
            out("badcmd");
            return 1;
        }
        fmi2ValueReference vr[64];
        fmi2Real reals[64];
        fmi2Integer ints[64];
        fmi2Boolean bools[64];
        fmi2String strings[64];
        for (int i = 0; i < n; i++) {
            vr[i] = (fmi2ValueReference)strtoul(argv[3 + i], NULL, 10);
            char *value = argv[3 + n + i];
            reals[i] = strtod(value, NULL);
            ints[i] = (fmi2Integer)strtol(value, NULL, 10);
            bools[i] = atoi(value) ? fmi2True : fmi2False;
            strings[i] = decode(value);
        }
        char kind = cmd[3];
        if (kind == 'r')
            s = f->fmi2SetReal(c, vr, (size_t)n, reals);
        else if (kind == 'i')
            s = f->fmi2SetInteger(c, vr, (size_t)n, ints);
        else if (kind == 'b')
            s = f->fmi2SetBoolean(c, vr, (size_t)n, bools);
        else
            s = f->fmi2SetString(c, vr, (size_t)n, strings);
    } else if (strstr(cmd, "status") != NULL && argc == 4) {
        fmi2StatusKind kind = (fmi2StatusKind)atoi(argv[2]);
        int null_value = atoi(argv[3]);
        fmi2Status status_value = fmi2OK;
        fmi2Real real_value = 0.0;
        fmi2Integer int_value = 0;
        fmi2Boolean bool_value = fmi2False;
        fmi2String string_value = NULL;
        if (strcmp(cmd, "status") == 0) {
            s = f->fmi2GetStatus(c, kind, null_value ? NULL : &status_value);
            out("%d %d", (int)s, (int)status_value);
        } else if (strcmp(cmd, "realstatus") == 0) {
            s = f->fmi2GetRealStatus(c, kind, null_value ? NULL : &real_value);
            out("%d %.17g", (int)s, real_value);
        } else if (strcmp(cmd, "intstatus") == 0) {
            s = f->fmi2GetIntegerStatus(c, kind, null_value ? NULL : &int_value);
            out("%d %d", (int)s, (int)int_value);
        } else if (strcmp(cmd, "boolstatus") == 0) {
            s = f->fmi2GetBooleanStatus(c, kind, null_value ? NULL : &bool_value);
            out("%d %d", (int)s, (int)bool_value);
        } else if (strcmp(cmd, "stringstatus") == 0) {
            s = f->fmi2GetStringStatus(c, kind, null_value ? NULL : &string_value);
            out("%d ", (int)s);
            print_encoded(s <= fmi2Warning ? string_value : NULL);
        } else {
            out("badcmd");
        }
        return 1;
    } else if (strcmp(cmd, "dirderiv") == 0) {
        fmi2ValueReference u[1] = {0}, z[1] = {1};
        fmi2Real dv[1] = {1.0}, dz[1] = {0.0};
        s = f->fmi2GetDirectionalDerivative(c, z, 1, u, 1, dv, dz);
    } else if ((strcmp(cmd, "setinder") == 0 || strcmp(cmd, "getoutder") == 0) && argc >= 3) {
        int n = atoi(argv[2]), setting = cmd[0] == 's';
        if (n < 0 || n > 64 || argc != 3 + (setting ? 3 : 2) * n) {
            out("badcmd");
            return 1;
        }
        fmi2ValueReference vr[64];
        fmi2Integer order[64];
        fmi2Real value[64];
        for (int i = 0; i < n; i++) {
            vr[i] = (fmi2ValueReference)strtoul(argv[3 + i], NULL, 10);
            order[i] = (fmi2Integer)strtol(argv[3 + n + i], NULL, 10);
            value[i] = setting ? strtod(argv[3 + 2 * n + i], NULL) : 0.0;
        }
        if (setting) {
            s = f->fmi2SetRealInputDerivatives(c, vr, (size_t)n, order, value);
        } else {
            s = f->fmi2GetRealOutputDerivatives(c, vr, (size_t)n, order, value);
            out("%d", (int)s);
            for (int i = 0; i < n && s <= fmi2Warning; i++) out(" %.17g", value[i]);
            return 1;
        }
    } else if (argc >= 3 && in_range(atoi(argv[2]), N_STATES) &&
               (strcmp(cmd, "getstate") == 0 || strcmp(cmd, "setstate") == 0 || strcmp(cmd, "freestate") == 0 ||
                strcmp(cmd, "size") == 0 || strcmp(cmd, "serialize") == 0 || strcmp(cmd, "deser") == 0)) {
        int j = atoi(argv[2]);
        if (strcmp(cmd, "getstate") == 0) {
            s = f->fmi2GetFMUstate(c, &states[j]);
        } else if (strcmp(cmd, "setstate") == 0) {
            s = f->fmi2SetFMUstate(c, states[j]);
            out("%d", (int)s);
            return 1;
        } else if (strcmp(cmd, "freestate") == 0 && argc == 4) {
            fmi2FMUstate *where = strcmp(argv[3], "addr") == 0    ? &states[j]
                                  : strcmp(argv[3], "value") == 0 ? (fmi2FMUstate *)states[j]
                                                                  : NULL;
            s = f->fmi2FreeFMUstate(c, where);
        } else if (strcmp(cmd, "size") == 0 && argc == 4) {
            size_t n = 0;
            s = f->fmi2SerializedFMUstateSize(c, states[j], atoi(argv[3]) ? NULL : &n);
            out("%d %zu", (int)s, n);
            return 1;
        } else if (strcmp(cmd, "serialize") == 0 && argc == 6) {
            size_t n = 0;
            fmi2Status size_status = f->fmi2SerializedFMUstateSize(c, states[j], &n);
            size_t reported = n;
            if (size_status > fmi2Warning) n = 64; /* a size to try all the same */
            size_t delta = (size_t)strtoul(argv[4], NULL, 10), size = n;
            const char *mode = argv[3];
            if (strcmp(mode, "larger") == 0) size = n + delta;
            if (strcmp(mode, "smaller") == 0) size = delta < n ? n - delta : 0;
            int b = atoi(argv[5]);
            if (!in_range(b, N_BUFFERS)) {
                out("badcmd");
                return 1;
            }
            fmi2Byte *buffer = malloc(size + GUARD);
            memset(buffer, 0xA5, size + GUARD);
            s = f->fmi2SerializeFMUstate(c, states[j], strcmp(mode, "nullbuf") == 0 ? NULL : buffer, size);
            int untouched = 1; /* a refused call writes nothing: then no byte of the buffer may change */
            size_t from = strcmp(mode, "smaller") == 0 || strcmp(mode, "nullbuf") == 0 ? 0 : n;
            for (size_t i = from; i < size + GUARD; i++)
                if ((unsigned char)buffer[i] != 0xA5) untouched = 0;
            uint64_t hash = fnv1a(buffer, n < size ? n : size);
            if (s <= fmi2Warning && size_status <= fmi2Warning && n <= size) {
                free(buffers[b]);
                buffers[b] = malloc(n ? n : 1);
                memcpy(buffers[b], buffer, n);
                buffer_sizes[b] = n;
            }
            free(buffer);
            out("%d %zu %d %d %016" PRIx64, (int)size_status, reported, (int)s, untouched, hash);
            return 1;
        } else if (strcmp(cmd, "deser") == 0 && argc == 6) {
            int b = atoi(argv[3]);
            const char *mode = argv[4];
            size_t arg = (size_t)strtoul(argv[5], NULL, 10);
            if (!in_range(b, N_BUFFERS)) {
                out("badcmd");
                return 1;
            }
            fmi2Byte *copy = NULL;
            size_t n = buffer_sizes[b];
            const fmi2Byte *bytes = buffers[b];
            fmi2FMUstate *target = &states[j];
            fmi2Byte empty[1] = {0};
            if (strcmp(mode, "trunc") == 0) {
                n = arg < n ? arg : n;
            } else if (strcmp(mode, "magic") == 0) {
                copy = malloc(n ? n : 1);
                if (n) memcpy(copy, buffers[b], n);
                for (size_t i = 0; i < 4 && i < n; i++) copy[i] = (fmi2Byte)~copy[i];
                bytes = copy;
            } else if (strcmp(mode, "flip") == 0) {
                copy = malloc(n ? n : 1);
                if (n) memcpy(copy, buffers[b], n);
                if (arg < n) copy[arg] = (fmi2Byte)(copy[arg] ^ 0x20);
                bytes = copy;
            } else if (strcmp(mode, "empty") == 0) {
                bytes = empty;
                n = 0;
            } else if (strcmp(mode, "nullbuf") == 0) {
                bytes = NULL;
                n = 0;
            } else if (strcmp(mode, "junk") == 0) {
                uint64_t seed = 0x5DEECE66Dull + (uint64_t)b * 7919u + arg;
                n = arg;
                copy = malloc(n ? n : 1);
                for (size_t i = 0; i < n; i++) copy[i] = (fmi2Byte)next_random(&seed);
                bytes = copy;
            } else if (strcmp(mode, "nullout") == 0) {
                target = NULL;
            } else if (strcmp(mode, "real") != 0) {
                out("badcmd");
                return 1;
            }
            if (bytes == NULL && strcmp(mode, "nullbuf") != 0) bytes = empty; /* a buffer never filled */
            s = f->fmi2DeSerializeFMUstate(c, bytes, n, target);
            free(copy);
        } else {
            out("badcmd");
            return 1;
        }
        out("%d ", (int)s);
        print_pointer(states[j]);
        return 1;
    } else {
        out("badcmd");
        return 1;
    }
    out("%d", (int)s);
    return 1;
}

/* The next line of stdin without its newline, or NULL at the end. Read with read(2), not stdio: a
 * Python started inside the process may set stdin unbuffered, which drops what stdio had buffered. */
static char *read_line(void) {
    static char buffer[1 << 16];
    static size_t filled = 0, start = 0;
    static char line[1 << 16];
    for (;;) {
        char *newline = memchr(buffer + start, '\n', filled - start);
        if (newline != NULL) {
            size_t n = (size_t)(newline - (buffer + start));
            memcpy(line, buffer + start, n);
            line[n] = '\0';
            start += n + 1;
            if (n > 0 && line[n - 1] == '\r') line[n - 1] = '\0';
            return line;
        }
        if (start > 0) {
            memmove(buffer, buffer + start, filled - start);
            filled -= start;
            start = 0;
        }
        if (filled == sizeof buffer) filled = 0; /* a line longer than the buffer: dropped */
        ssize_t got = read(0, buffer + filled, sizeof buffer - filled);
        if (got <= 0) return NULL;
        filled += (size_t)got;
    }
}

int main(void) {
    char *argv[MAX_TOKENS];
    for (size_t i = 0; i < sizeof static_junk; i++) static_junk[i] = (unsigned char)(0x5A ^ (i * 37));
    char *line;
    while ((line = read_line()) != NULL) {
        int argc = 0;
        for (char *tok = strtok(line, " "); tok != NULL && argc < MAX_TOKENS; tok = strtok(NULL, " "))
            argv[argc++] = tok;
        answer_len = 0;
        answer[0] = '\0';
        int go_on = argc > 0 ? execute(argc, argv) : (out("badcmd"), 1);
        if (!go_on) break;
        printf("@@ans %s\n", answer);
        fflush(stdout);
    }
    for (int k = 0; k < N_INSTANCES; k++)
        if (instances[k] != NULL) libs[instance_lib[k]].fmi2FreeInstance(instances[k]);
    for (int b = 0; b < N_BUFFERS; b++) free(buffers[b]);
    return 0;
}
