"""The compiled physics core (femp_core.h), built with the package, and how Python hands it arrays.

`lib` holds the C functions femp_core.h declares, `ffi` makes their structs. `pointer` gives the C view
of a numpy array without a copy: the array must be C-contiguous with the element type the declaration
takes (float64 for double, int32 for int), and stay alive as long as C may read the pointer.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ._femp_core import ffi, lib

C_TYPES = {np.dtype(np.float64): "double[]", np.dtype(np.int32): "int[]"}


def pointer(array: np.ndarray) -> Any:
    """The C view of `array` (a cffi cdata of double[] or int[], passed where the core takes double * or
    int *): its memory, not a copy, held alive by the view."""
    ctype = C_TYPES.get(array.dtype)
    if ctype is None or not array.flags.c_contiguous:
        raise TypeError(f"the core reads C-contiguous float64 or int32 arrays, not {array.dtype} {array.shape}")
    return ffi.from_buffer(ctype, array)


def fields(struct: str) -> tuple[str, ...]:
    """The struct's field names in the header's order, e.g. fields("struct femp_csr")."""
    return tuple(name for name, _ in ffi.typeof(struct).fields)


def fill(struct: Any, names: tuple[str, ...], values: tuple) -> None:
    """Set a struct's fields by name (cffi structs are filled by name, never by position)."""
    if len(names) != len(values):
        raise ValueError(f"{len(values)} values for the {len(names)} fields {names}")
    for name, value in zip(names, values, strict=True):
        setattr(struct, name, value)


__all__ = ["ffi", "fields", "fill", "lib", "pointer"]
