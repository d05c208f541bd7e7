"""The Python environment a native (C/C++) FMI host needs to run this project's FMUs.

pythonfmu's binary does not link libpython. A Python host (fmpy, libcosimpy)
provides one; in any other host the FMU's binary (fmi/shim) loads the
libpython and starts the interpreter recorded when the FMU was built
(resources/python_environment.txt). On another machine or environment, set
FEM_PENDULUM_LIBPYTHON and FEM_PENDULUM_PYTHON; `fem-pendulum host-env`
prints both for the environment it runs in:

    eval "$(fem-pendulum host-env)"
"""

from __future__ import annotations

import sys
import sysconfig
from pathlib import Path


def python_environment() -> dict[str, str]:
    """{"libpython": path of the shared libpython, "executable": this environment's python}."""
    libdir = sysconfig.get_config_var("LIBDIR") or ""
    ldlibrary = sysconfig.get_config_var("LDLIBRARY") or ""
    return {"libpython": str(Path(libdir) / ldlibrary), "executable": sys.executable}


def host_environment() -> dict[str, str]:
    """The environment variables that point an FMU's binary at this Python environment."""
    env = python_environment()
    return {"FEM_PENDULUM_LIBPYTHON": env["libpython"], "FEM_PENDULUM_PYTHON": env["executable"]}


def main(argv: list[str] | None = None) -> None:
    for key, value in host_environment().items():
        print(f'export {key}="{value}"')


if __name__ == "__main__":
    main()
