/* The checks of variables.h over the generated table. */
#include <stdio.h>

#include "variables.h"

static const Variable variables[] = {
#include "fmu_variables.h"
};
static const size_t n_variables = sizeof variables / sizeof variables[0];

#ifdef FMI3_BINARY
static const char *const kind_names[] = {"Float64", "Int32", "Boolean", "String", "Int64 (Enumeration)"};
#else
static const char *const kind_names[] = {"Real", "Integer", "Boolean", "String", "Int64"};
#endif

static const Variable *find(fmi2ValueReference vr, Kind kind) {
    if (vr < n_variables && variables[vr].vr == vr && variables[vr].kind == kind) return &variables[vr]; /* dense */
    for (size_t k = 0; k < n_variables; k++)
        if (variables[k].vr == vr && variables[k].kind == kind) return &variables[k];
    return NULL;
}

static const Variable *find_any(fmi2ValueReference vr) {
    for (size_t k = 0; k < n_variables; k++)
        if (variables[k].vr == vr) return &variables[k];
    return NULL;
}

const char *variables_problem(const fmi2ValueReference vr[], size_t n, Kind kind, int setting, MachineState state,
                              char *why, size_t size) {
    for (size_t k = 0; k < n; k++) {
        const Variable *var = find(vr[k], kind);
        if (var == NULL) {
            const Variable *other = find_any(vr[k]);
            if (other == NULL)
                snprintf(why, size, "value reference %u is no variable of this FMU (see modelDescription.xml)", vr[k]);
            else
                snprintf(why, size, "%s (value reference %u) is of type %s, not %s", other->name, vr[k],
                         kind_names[other->kind], kind_names[kind]);
            return why;
        }
        if (setting && !(var->settable & state)) {
            if (var->settable == 0)
                snprintf(why, size, "%s (value reference %u) is %s and cannot be set", var->name, vr[k], var->what);
            else
                snprintf(why, size, "%s (value reference %u) is %s and cannot be set in state %s", var->name,
                         vr[k], var->what, state_name(state));
            return why;
        }
    }
    return NULL;
}

const char *derivatives_problem(const fmi2ValueReference vr[], size_t n, const fmi2Integer order[], Role role,
                                int max_order, char *why, size_t size) {
    char wanted[64];
    snprintf(wanted, sizeof wanted, "a continuous %s %s", kind_names[KIND_REAL], role == ROLE_INPUT ? "input" : "output");
    for (size_t k = 0; k < n; k++) {
        const Variable *var = find_any(vr[k]);
        if (var == NULL) {
            snprintf(why, size, "value reference %u is no variable of this FMU (see modelDescription.xml)", vr[k]);
            return why;
        }
        if (var->role != role) {
            snprintf(why, size, "%s (value reference %u) is %s, not %s: only those have time derivatives here",
                     var->name, vr[k], var->what, wanted);
            return why;
        }
        if (order[k] < 1 || order[k] > max_order) {
            snprintf(why, size, "order %d of %s (value reference %u) is not allowed: the orders are 1 to %d",
                     (int)order[k], var->name, vr[k], max_order);
            return why;
        }
    }
    return NULL;
}

const char *count_problem(const fmi2ValueReference vr[], size_t n, size_t n_values, char *why, size_t size) {
    size_t total = 0;
    for (size_t k = 0; k < n; k++) {
        const Variable *var = find_any(vr[k]);
        total += var ? var->size : 1;
    }
    if (total == n_values) return NULL;
    snprintf(why, size, "nValues is %zu, the %zu variables have %zu elements", n_values, n, total);
    return why;
}
