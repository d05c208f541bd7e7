/* The Python C API as this project's FMU binary uses it: every function looked up with dlsym
 * (python_runtime.c), so that the binary loads in a process that has no libpython and binds to
 * whichever libpython the host or python_runtime.c brought in. Python.h is included for the types
 * only; its macros that reference symbols (Py_DECREF, PyFloat_Check, ...) are not used. */
#ifndef FEM_PENDULUM_PYTHON_API_H
#define FEM_PENDULUM_PYTHON_API_H

#include <Python.h>

typedef struct {
    /* the interpreter's life */
    int (*IsInitialized)(void);
    int (*IsFinalizing)(void); /* NULL where the libpython has neither spelling */
    const char *(*GetVersion)(void);
    void (*ConfigInitPythonConfig)(PyConfig *);
    PyStatus (*ConfigSetBytesString)(PyConfig *, wchar_t **, const char *);
    PyStatus (*InitializeFromConfig)(const PyConfig *);
    void (*ConfigClear)(PyConfig *);
    int (*StatusException)(PyStatus);
    PyThreadState *(*EvalSaveThread)(void);
    PyGILState_STATE (*GILStateEnsure)(void);
    void (*GILStateRelease)(PyGILState_STATE);
    /* objects */
    PyObject *(*ImportModule)(const char *);
    PyObject *(*CallMethod)(PyObject *, const char *, const char *, ...);
    PyObject *(*CallFunction)(PyObject *, const char *, ...);
    PyObject *(*Call)(PyObject *, PyObject *, PyObject *);
    PyObject *(*GetAttrString)(PyObject *, const char *);
    int (*HasAttrString)(PyObject *, const char *);
    int (*IsSubclass)(PyObject *, PyObject *);
    int (*IsTrue)(PyObject *);
    PyObject *(*ObjectStr)(PyObject *);
    void (*IncRef)(PyObject *);
    void (*DecRef)(PyObject *);
    PyObject *(*DictNew)(void);
    int (*DictSetItemString)(PyObject *, const char *, PyObject *);
    PyObject *(*DictGetItemString)(PyObject *, const char *);
    int (*DictNext)(PyObject *, Py_ssize_t *, PyObject **, PyObject **);
    PyObject *(*TupleNew)(Py_ssize_t);
    PyObject *(*ListNew)(Py_ssize_t);
    int (*ListSetItem)(PyObject *, Py_ssize_t, PyObject *);
    PyObject *(*ListGetItem)(PyObject *, Py_ssize_t);
    Py_ssize_t (*ListSize)(PyObject *);
    int (*ListInsert)(PyObject *, Py_ssize_t, PyObject *);
    int (*SequenceContains)(PyObject *, PyObject *);
    PyObject *(*SysGetObject)(const char *);
    PyObject *(*LongFromUnsignedLong)(unsigned long);
    PyObject *(*LongFromLong)(long);
    long (*LongAsLong)(PyObject *);
    PyObject *(*FloatFromDouble)(double);
    double (*FloatAsDouble)(PyObject *);
    PyObject *(*BoolFromLong)(long);
    PyObject *(*UnicodeFromString)(const char *);
    const char *(*UnicodeAsUTF8)(PyObject *);
    PyObject *(*BytesFromStringAndSize)(const char *, Py_ssize_t);
    int (*BytesAsStringAndSize)(PyObject *, char **, Py_ssize_t *);
    PyObject *None; /* the object None (_Py_NoneStruct) */
    /* errors */
    PyObject *(*ErrOccurred)(void);
    void (*ErrFetch)(PyObject **, PyObject **, PyObject **);
    void (*ErrClear)(void);
} PythonApi;

extern PythonApi py;

#endif
