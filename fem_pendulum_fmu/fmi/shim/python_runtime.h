/* The Python an FMU of this project runs in: the host's, or one the FMU loads itself (python_runtime.c). */
#ifndef FEM_PENDULUM_PYTHON_RUNTIME_H
#define FEM_PENDULUM_PYTHON_RUNTIME_H

#include <stddef.h>

/* Makes sure an initialised Python is in the process, then runs resources/femp_preflight.py's
 * prepare(resources). Returns 0 when the FMU can be instantiated; otherwise 1 with the reason,
 * written for the user, in `why` (n bytes). */
int python_prepare(const char *resources, char *why, size_t n);

/* 1 while the process's Python can be called: initialised and not being finalised (a Python host's
 * exit-time destructors may call the FMU after its interpreter is gone). */
int python_alive(void);

/* 1 once a Python that ran in this process while this binary was loaded has been finalised or is being
 * finalised. The host's callbacks are then never called: in a Python host (fmpy, PyFMI) they are ctypes
 * callbacks into that Python, and calling one then dies in PyGILState_Ensure (docs/reference/fmi2.md, "Exit"). */
int python_ended(void);

#endif
