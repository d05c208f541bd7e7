/* FMU state handles that a host cannot misuse.
 *
 * A handle is an address inside a block of address space this binary reserves and never maps
 * (PROT_NONE): no host object can live there, so a pointer can be recognised as a handle, live or
 * stale, without reading through it. Each instance keeps the handles it handed out with what they
 * stand for; a handle of another instance, a freed one or any other pointer is not found. */
#ifndef FEM_PENDULUM_FMU_STATES_H
#define FEM_PENDULUM_FMU_STATES_H

#include <stddef.h>

typedef struct {
    void *handle;
    void *python_state;      /* the slave's state object (a new reference) */
    void *serialised;        /* its bytes once serialised (a new reference), or NULL */
    double time;             /* the FMU's time when the state was taken */
    int mode;                /* the instance's MachineState when it was taken (state_machine.h) */
} SavedState;

typedef struct {
    SavedState *items;
    size_t n, capacity;
} StateRegistry;

/* 1 when `p` lies in the reserved block: a handle of some instance, live or not. */
int is_handle(const void *p);
/* A new entry with a fresh handle, or NULL (out of memory or no reserved block). */
SavedState *registry_add(StateRegistry *registry);
/* The live entry of `handle` in this registry, or NULL. */
SavedState *registry_find(StateRegistry *registry, const void *handle);
/* Forget an entry (the caller has released its Python references). */
void registry_remove(StateRegistry *registry, SavedState *entry);
void registry_clear(StateRegistry *registry);

#endif
