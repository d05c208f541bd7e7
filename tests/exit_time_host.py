"""The Python host of tests/test_exit_time_host.py: its C library (tests/exit_time_host.c, compiled by the test)
starts one instance of each FMU and frees them at exit, after this interpreter has been finalised.

    python tests/exit_time_host.py LIBRARY MODE PENDULUM_FOLDER PENDULUM_GUID PID_FOLDER PID_GUID VR_FIDELITY FIDELITY

prints "started" and what exit_time_host_start returned (0: both instances initialised and stepped), then
ends normally; the library's exit-time handler (MODE) prints its line to stderr.
"""

from __future__ import annotations

import ctypes
import sys


def main(argv: list[str]) -> None:
    library, mode, pendulum, pendulum_guid, pid, pid_guid, vr_fidelity, fidelity = argv
    lib = ctypes.CDLL(library)
    lib.exit_time_host_start.argtypes = [ctypes.c_char_p] * 5 + [ctypes.c_int, ctypes.c_int]
    names = [a.encode() for a in (mode, pendulum, pendulum_guid, pid, pid_guid)]
    print("started", lib.exit_time_host_start(*names, int(vr_fidelity), int(fidelity)), flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
