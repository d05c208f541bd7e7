"""Compiled inner loops (fem/elastic_kernel.c, fem/rigid_contact_kernel.c, fem/start_iterate_kernel.c,
fem/mass_moments_kernel.c, reduced/reduced_kernel.c): built once per machine, cached.

At the FE model's size (300-700 unknowns) a residual is a few hundred
thousand floating-point operations, which NGSolve's integrators and numpy
alike spend ten times over in per-call and per-element overhead (docs/fem.md,
"Profile and speed-up"); the reduced fidelity's whole step, 13 unknowns by
default, is a few ten thousand, which numpy spent in per-call overhead
(docs/reduced.md). The kernels are plain C loaded with ctypes: no Python
headers, no build step at install. Where there is no C compiler, or with
FEM_PENDULUM_KERNELS=numpy, `kernels()` is None and callers use their numpy
forms of the same computation (equal up to round-off; each run is
deterministic either way).
"""

from __future__ import annotations

import ctypes
import hashlib
import logging
import os
import platform
import shutil
import subprocess
import tempfile
from functools import lru_cache
from pathlib import Path

from .cache import cached_file

LOG = logging.getLogger("fem_pendulum_fmu")
SOURCES = tuple(
    Path(__file__).parent / name
    for name in (
        "fem/elastic_kernel.c",
        "fem/rigid_contact_kernel.c",
        "fem/start_iterate_kernel.c",
        "fem/mass_moments_kernel.c",
        "reduced/reduced_kernel.c",
    )
)
ENV = "FEM_PENDULUM_KERNELS"  # "numpy": never compile, use the numpy forms
# no -ffast-math and no contraction into fused multiply-adds: the same sums in the same order on every run
FLAGS = ("-O3", "-shared", "-fPIC", "-ffp-contract=off")

_P = ctypes.c_void_p
_I = ctypes.c_int
_D = ctypes.c_double
SIGNATURES = {
    "femp_deformation": (_I, _P, _P, _P, _I, _P, _P, _P),
    "femp_stress_residual": (_I, _P, _P, _P, _I, _P, _P, _P, _P, _D, _D, _I, _P, _P, _P),
    "femp_csr_axpy": (_I, _P, _P, _P, _D, _P, _P),
    "femp_lu_solve": (_I, _P, _P, _P, _P, _P, _P, _P, _P, _P, _P, _P, _P, _P, _P, _P, _P),
    "femp_turned_solve": (_I, _P, _P, _D, _D, _I, *(_P,) * 17, _I),
    "femp_update": (_I, _I, _P, _P),
    "femp_min_det": (_I, _P, _P, _P, _I, _P),
    "femp_strain_energy": (_I, _P, _P, _P, _I, _P, _P, _D, _D),
    "femp_strain_energy_of": (_I, _P, _P, _D, _D),
    "femp_lu_factor": (_I, _P, _P, _P, _P, _P, _P, _P, _P, _P, _P, _P, _P, _P, _P, _P, _D, _P),
    "femp_stress_tangent": (_I, _P, _P, _P, _I, _P, _P, _P, _P, _D, _D, _I, _P, _P, _P, _P, _P),
    "femp_iterate": (_P, _I, _I, _D, _D),
    "femp_rigid_contact": (_P, _P, _I, _P),
    "femp_rigid_contact_resultant": (_P, _P, _P, _P),
    "femp_rigid_contact_stiffness": (_P, _P, _I, _P, _P, _P),
    "femp_misses_record": (_I, _I, _P, _I, _P, _I, _I, _D, _D),
    "femp_misses_predict": (_I, _I, _P, _I, _I, _D, _D),
    "femp_mass_moments": (_I, _P, _P, _P, _P, _P, _P),
    "femp_reduced_strain_energy": (_P, _P),
    "femp_reduced_strain_gradient": (_P, _P, _P),
    "femp_reduced_strain_hessian": (_P, _P, _P),
    "femp_reduced_gap": (_P, _P),
    "femp_reduced_contact": (_P, _P, _P),
    "femp_reduced_step": (_P, _P, _P, _D, _D, _D, _P, _P, _P),
}
RESULTS = {
    **{
        name: ctypes.c_double
        for name in ("femp_update", "femp_min_det", "femp_deformation", "femp_strain_energy", "femp_lu_factor")
    },
    "femp_strain_energy_of": ctypes.c_double,
    "femp_iterate": ctypes.c_double,
    "femp_rigid_contact": ctypes.c_int,
    "femp_rigid_contact_stiffness": ctypes.c_int,
    "femp_misses_predict": ctypes.c_int,
    "femp_misses_record": ctypes.c_int,
    **{name: ctypes.c_double for name in ("femp_reduced_strain_energy", "femp_reduced_gap")},
    "femp_reduced_step": ctypes.c_int,
}


def _compiler() -> str | None:
    return os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc")


def _compile(compiler: str, output: Path) -> None:
    """Build the kernels; with a search path even where the process has none (a native FMU host started
    with an empty environment), since the compiler driver looks its linker up there."""
    command = [compiler, *FLAGS, "-o", str(output), *map(str, SOURCES), "-lm"]
    env = {**os.environ, "PATH": os.environ.get("PATH") or os.defpath}
    subprocess.run(command, check=True, capture_output=True, timeout=120, env=env)


@lru_cache(maxsize=1)
def kernels() -> ctypes.CDLL | None:
    """The compiled kernels, or None (no compiler, a failed build, or FEM_PENDULUM_KERNELS=numpy)."""
    if os.environ.get(ENV, "").lower() == "numpy":
        return None
    compiler = _compiler()
    if compiler is None:
        LOG.info("no C compiler found: the FE residual and the reduced step run in their numpy forms")
        return None
    source = b"".join(path.read_bytes() for path in SOURCES)
    # the compiler by its real path: /bin/cc (an empty PATH) and /usr/bin/cc are the same build
    key = {"source": hashlib.sha256(source).hexdigest(), "compiler": os.path.realpath(compiler), "flags": FLAGS}
    key["machine"] = platform.machine()
    try:
        path = cached_file("kernel", key, ".so", lambda out: _compile(compiler, out))
        if path is None:  # no cache: build into a private folder for this process
            path = Path(tempfile.mkdtemp(prefix="fem_pendulum_kernel")) / "elastic_kernel.so"
            _compile(compiler, path)
        lib = ctypes.CDLL(str(path))
    except (OSError, subprocess.SubprocessError) as exc:
        LOG.warning("the kernels did not build (%s): the FE residual and the reduced step run in numpy", exc)
        return None
    for name, args in SIGNATURES.items():
        fn = getattr(lib, name)
        fn.argtypes, fn.restype = args, RESULTS.get(name)
    return lib
