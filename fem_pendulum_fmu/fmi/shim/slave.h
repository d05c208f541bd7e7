/* One FMU instance and the calls into its Python slave object (slave.c). */
#ifndef FEM_PENDULUM_SLAVE_H
#define FEM_PENDULUM_SLAVE_H

#include "python_api.h"

#include "fmi2Functions.h"
#include "fmu_states.h"
#include "state_machine.h"

/* What an FMI 3.0 host gave fmi3InstantiateCoSimulation (fmi3_functions.c); unused by the FMI 2.0 binary,
 * whose logger is in `callbacks`. The FMI 3.0 binary puts an adapter there that calls `log_message`. */
typedef struct {
    void *environment;           /* instanceEnvironment, passed back to both callbacks */
    void (*log_message)(void);   /* fmi3LogMessageCallback, or NULL: no logging */
    void (*intermediate_update)(void); /* fmi3IntermediateUpdateCallback, or NULL */
    int event_mode_used;
    int early_return_allowed;
    int in_step;                 /* inside fmi3DoStep: only the callback's calls are answered */
} Fmi3Host;

typedef struct {
    PyObject *slave;     /* the Python slave object; NULL when it could not be rebuilt at fmi2Reset */
    PyObject *cls;       /* its class and keyword arguments, for fmi2Reset */
    PyObject *kwargs;
    PyObject *log_queue; /* the slave's list of pending log messages (pythonfmu's LogMsg) */
    PyObject *strings;   /* the last fmi2GetString answer, whose texts the host may still read */
    fmi2CallbackFunctions callbacks;
    char *name;
    MachineState state;
    double time;         /* the FMU's time: start time, end of the last successful step, restored state's */
    int restored;        /* an FMU state was set before initialisation: fmi2SetupExperiment keeps its time */
    int cannot_continue; /* the last doStep was discarded and no shorter one can succeed: fmi2Terminated */
    int logging_on;
    char **categories;
    size_t n_categories;
    StateRegistry states;
    Fmi3Host fmi3;
} Instance;

/* Log through the host's logger (the message is passed as a format string with each '%' doubled); without one on
 * stderr. Nothing at all once the process's Python has ended: the logger may be Python (python_runtime.h). */
void log_to_host(const fmi2CallbackFunctions *callbacks, const char *instance, fmi2Status status,
                 const char *category, const char *message);
void log_error(Instance *inst, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

/* With the GIL held: the slave class found in the entry module named in resources/slavemodule.txt,
 * a new instance of it and its log queue filled in; 0 on success, else 1 with the reason in `why`. */
int slave_create(Instance *inst, const char *resources, fmi2Boolean visible, char *why, size_t n);
/* With the GIL held: a new slave object from the same class and arguments (fmi2Reset). */
int slave_rebuild(Instance *inst, char *why, size_t n);
/* With the GIL held: release() the slave if it has that method, and drop every Python reference. */
void slave_release(Instance *inst);

/* With the GIL held: the status of a call whose Python result is `result` (a new reference or NULL),
 * after logging the pending exception, the slave's queued messages and an error it reported. */
fmi2Status slave_settle(Instance *inst, const char *call, PyObject *result, fmi2Status ok);
/* The text of the pending Python exception, cleared. */
void exception_message(char *text, size_t n);
/* The thread's error report from the slave (fem_pendulum_report_error), cleared; NULL if none. */
const char *take_reported_error(void);
void clear_reported_error(void);
/* 1 when the slave has reported an error during the current call (not cleared). */
int error_pending(void);

/* With the GIL held: the FMU's time after a call that may set it: the slave's `communication_time`
 * where it has one, else `fallback` (fmi2_functions.c). */
void take_slave_time(Instance *inst, double fallback);
/* The slave's attribute `name` as a truth value; 0 when it has none or it cannot be read. */
int slave_flag(Instance *inst, const char *name);

/* With the GIL held: drop the Python objects of every FMU state the instance still has (fmi2_states.c). */
void release_all_states(Instance *inst);

/* Python lists of value references and values. */
PyObject *references(const fmi2ValueReference vr[], size_t n);

#endif
