"""The build of the compiled core: run by setup.py (cffi_modules) when the package is built, never at run time.

cffi's API mode compiles the C sources of this folder, with femp_core.h as the one declaration of what
Python may call, into the extension module fem_pendulum_fmu.physics.core._femp_core. The header is both
the C sources' include and cffi's declarations (its preprocessor lines left out), so the two cannot
disagree. Floating-point contraction is off: every multiply and add is rounded as written, the same
bits on every build of the same compiler.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

from cffi import FFI

HERE = Path(__file__).resolve().parent
SOURCES = (
    "fem_elastic.c",
    "fem_rigid_contact.c",
    "fem_start_iterate.c",
    "fem_mass_moments.c",
    "reduced_step.c",
    "stepping.c",
    "reduced_advance.c",
    "rigid_model.c",
    "rigid_advance.c",
)
HEADER = HERE / "femp_core.h"


def declarations(header: str) -> str:
    """The header without its preprocessor lines, which cffi's parser does not take."""
    return "\n".join(line for line in header.splitlines() if not line.lstrip().startswith("#"))


def compile_args() -> list[str]:
    if sys.platform == "win32" and "GCC" not in sys.version:
        return ["/O2", "/fp:precise"]
    # -fno-wrapv after Python's own -fwrapv: with wrapping signed indices the compiler can neither vectorise
    # nor strength-reduce the loops over arrays (the reduced strain's sums ran at half speed)
    return ["-O3", "-ffp-contract=off", "-fno-wrapv", "-std=c99"]


ffibuilder = FFI()
ffibuilder.cdef(declarations(HEADER.read_text()))
# the callbacks into Python: an advance's `stop` (physics/protocol.py, StopAt) as a femp_stop_fn, and the functions
# of a model in Python as a struct femp_steppable's (physics/compiled_advance.py)
ffibuilder.cdef(
    """
    extern "Python" int femp_python_stop(void *, double, double, double);
    extern "Python" int femp_python_step(void *, const double *, double, double, double *);
    extern "Python" void femp_python_gap_and_rate(void *, const double *, double *, double *);
    extern "Python" void femp_python_contact_scales(void *, const double *, double *, double *);
    extern "Python" double femp_python_contact_force(void *, const double *);
    extern "Python" void femp_python_contact_impulse(void *, const double *, const double *, double, double *);
    """
)
ffibuilder.set_source(
    "fem_pendulum_fmu.physics.core._femp_core",
    '#include "femp_core.h"',
    sources=[os.path.relpath(HERE / name) for name in SOURCES],  # setuptools takes the sources' paths relative
    include_dirs=[os.path.relpath(HERE)],
    extra_compile_args=compile_args(),
    libraries=[] if sys.platform == "win32" else ["m"],
)

if __name__ == "__main__":
    ffibuilder.compile(verbose=True)
