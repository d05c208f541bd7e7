"""Prints the environment a C/C++ FMI host needs to run the FemPendulum FMU.

pythonfmu's binary does not link libpython: a Python host (fmpy, libcosimpy)
has it loaded already, a C/C++ host must preload it and point Python at the
environment where ngsolve and numpy are installed.

    fem-pendulum-host-env            # shell lines to eval: eval "$(fem-pendulum-host-env)"
"""
from __future__ import annotations

import os
import sys
import sysconfig
from pathlib import Path


def host_environment() -> dict[str, str]:
    libdir = sysconfig.get_config_var("LIBDIR") or ""
    ldlibrary = sysconfig.get_config_var("LDLIBRARY") or ""
    paths = sysconfig.get_paths()
    site = dict.fromkeys([paths["purelib"], paths["platlib"]])  # the venv's site-packages, once each
    return {
        "LD_PRELOAD": str(Path(libdir) / ldlibrary),
        "PYTHONHOME": sys.base_prefix,
        "PYTHONPATH": os.pathsep.join(site),
        "PATH": os.pathsep.join([str(Path(sys.executable).parent), "$PATH"]),
    }


def main() -> None:
    for key, value in host_environment().items():
        print(f'export {key}="{value}"')


if __name__ == "__main__":
    main()
