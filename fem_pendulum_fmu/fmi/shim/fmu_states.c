/* The handles of fmu_states.h. */
#define _GNU_SOURCE
#include <stdint.h>
#include <stdlib.h>
#include <sys/mman.h>

#include "fmu_states.h"

#define HANDLE_SPACE ((size_t)1 << 30) /* reserved, never backed: 2^26 handles before they repeat */
#define HANDLE_STRIDE 16

static char *space = NULL;
static uint64_t next_handle = 0;

static char *reserved_space(void) {
    char *current = __atomic_load_n(&space, __ATOMIC_ACQUIRE);
    if (current != NULL) return current;
    void *block = mmap(NULL, HANDLE_SPACE, PROT_NONE, MAP_PRIVATE | MAP_ANONYMOUS | MAP_NORESERVE, -1, 0);
    if (block == MAP_FAILED) return NULL;
    char *expected = NULL;
    if (!__atomic_compare_exchange_n(&space, &expected, (char *)block, 0, __ATOMIC_ACQ_REL, __ATOMIC_ACQUIRE)) {
        munmap(block, HANDLE_SPACE); /* another thread reserved first */
        return expected;
    }
    return (char *)block;
}

int is_handle(const void *p) {
    const char *base = __atomic_load_n(&space, __ATOMIC_ACQUIRE);
    return base != NULL && (const char *)p >= base && (const char *)p < base + HANDLE_SPACE;
}

SavedState *registry_add(StateRegistry *registry) {
    char *base = reserved_space();
    if (base == NULL) return NULL;
    if (registry->n == registry->capacity) {
        size_t capacity = registry->capacity ? 2 * registry->capacity : 8;
        SavedState *grown = realloc(registry->items, capacity * sizeof *grown);
        if (grown == NULL) return NULL;
        registry->items = grown;
        registry->capacity = capacity;
    }
    uint64_t k = __atomic_fetch_add(&next_handle, 1, __ATOMIC_RELAXED) % (HANDLE_SPACE / HANDLE_STRIDE - 1) + 1;
    SavedState *entry = &registry->items[registry->n++];
    *entry = (SavedState){.handle = base + k * HANDLE_STRIDE};
    return entry;
}

SavedState *registry_find(StateRegistry *registry, const void *handle) {
    if (!is_handle(handle)) return NULL;
    for (size_t k = 0; k < registry->n; k++)
        if (registry->items[k].handle == handle) return &registry->items[k];
    return NULL;
}

void registry_remove(StateRegistry *registry, SavedState *entry) {
    *entry = registry->items[--registry->n];
}

void registry_clear(StateRegistry *registry) {
    free(registry->items);
    *registry = (StateRegistry){0};
}
