"""Where the slave's messages go: the package's log records to the FMI logger, refused input to the binary.

The package logger has one handler, the router, which forwards each record to
the handler of the instance whose call is running; a doStep only pushes and
pops its handler. A handler holds a log callable, not the slave, so that the
slave (which holds its handler) and its model are freed at their last
reference, without the garbage collector (tests/test_fmu_memory.py).

`ErrorReport` reaches fem_pendulum_report_error of the FMU's binary (shim/),
which makes the FMI call in progress answer fmi2Error and logs the message
whether or not debug logging is on.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

from pythonfmu.enums import Fmi2Status

LOG = logging.getLogger("fem_pendulum_fmu")
LogCall = Callable[[str, Fmi2Status, "str | None"], Any]  # Fmi2Slave.log's (message, status, category)


class FmiLogHandler(logging.Handler):
    """Forwards log records to one instance's FMI log: errors and warnings with their status, the rest
    as fmi2OK under the category logAll."""

    def __init__(self, log: LogCall) -> None:
        super().__init__(logging.DEBUG)
        self.log = log

    def emit(self, record: logging.LogRecord) -> None:
        if record.levelno >= logging.ERROR:
            status = Fmi2Status.error
        elif record.levelno >= logging.WARNING:
            status = Fmi2Status.warning
        else:
            status = Fmi2Status.ok
        try:
            self.log(record.getMessage(), status, None if status != Fmi2Status.ok else "logAll")
        except ReferenceError:  # the log's instance is gone: nobody to tell
            pass


class _LogRouter(logging.Handler):
    """The package logger's one handler: forwards each record to the innermost running call's handler
    (`active[-1]`). Outside calls it does what the logging module does for a logger without handlers:
    warnings and worse go to logging.lastResort, unless some other handler up the hierarchy takes them."""

    def __init__(self) -> None:
        super().__init__(logging.DEBUG)
        self.active: list[FmiLogHandler] = []

    def emit(self, record: logging.LogRecord) -> None:
        if self.active:
            self.active[-1].emit(record)
        elif not self._others_handle() and logging.lastResort is not None:
            if record.levelno >= logging.lastResort.level:
                logging.lastResort.handle(record)

    def _others_handle(self) -> bool:
        logger: logging.Logger | None = LOG
        while logger is not None:
            if any(h is not self for h in logger.handlers):
                return True
            logger = logger.parent if logger.propagate else None
        return False


_ROUTER = _LogRouter()


def route_to(handler: FmiLogHandler) -> None:
    """Send the package's records to `handler` until `unroute()`: a push and a pop, cheaper at every
    doStep than a context manager's generator."""
    if _ROUTER not in LOG.handlers:
        LOG.addHandler(_ROUTER)
    if LOG.level == logging.NOTSET or LOG.level > logging.DEBUG:
        LOG.setLevel(logging.DEBUG)
    _ROUTER.active.append(handler)


def unroute() -> None:
    """End the innermost `route_to`."""
    _ROUTER.active.pop()


@contextmanager
def routed(handler: FmiLogHandler) -> Iterator[None]:
    """The package's records go to `handler` while the block runs."""
    route_to(handler)
    try:
        yield
    finally:
        unroute()


BINARY_FOLDERS = ("linux64", "x86_64-linux")  # where the FMI 2.0 and the FMI 3.0 FMU keep the Linux binary


class ErrorReport:
    """fem_pendulum_report_error of the FMU's binary (binaries/linux64/FemPendulum.so), looked up at the
    first report. Without it (pythonfmu's binary: Windows) `report` answers False and the caller queues
    the message itself. Each instance opens the library for itself and closes it at `close`: a table kept
    per resources folder kept a deleted library loaded for every run of fmpy's simulate_fmu, which
    extracts the FMU into a new folder each time."""

    def __init__(self, resources: str | None) -> None:
        self.resources = resources
        self._found: tuple[int, Callable[[bytes], Any]] | None = None  # library handle, function
        self._looked = False

    def report(self, message: str) -> bool:
        """Report `message` to the binary; False when there is no binary to report to."""
        if not self._looked:
            self._looked, self._found = True, _find_report(self.resources)
        if self._found is None:
            return False
        self._found[1](message.encode("utf-8", "replace"))
        return True

    def close(self) -> None:
        """dlclose the library opened to find the function (the host's own handle keeps it loaded)."""
        found, self._found, self._looked = self._found, None, False
        if found is not None:
            try:
                _close_library(found[0])
            except OSError as exc:  # dlclose refused: the handle stays open, nothing else is lost
                LOG.debug("release: the binary's library handle was not closed (%s)", exc)


def _find_report(resources: str | None) -> tuple[int, Callable[[bytes], Any]] | None:
    """The binary's library handle and its fem_pendulum_report_error, or None."""
    if not resources:
        return None
    import ctypes
    from pathlib import Path

    # the FMI 2.0 FMU's folder, else the FMI 3.0 FMU's
    binaries = Path(resources).parent / "binaries"
    binary = next((b for b in (binaries / p / "FemPendulum.so" for p in BINARY_FOLDERS) if b.is_file()), None)
    if binary is None:
        return None
    try:
        library = ctypes.CDLL(str(binary))
    except OSError:
        return None
    try:
        report = library.fem_pendulum_report_error
    except AttributeError:  # another binary (pythonfmu's alone): nothing to report to
        _close_library(library._handle)
        return None
    report.argtypes = [ctypes.c_char_p]
    return library._handle, report


def find_binary_function(resources: str | None, name: str) -> tuple[int, Callable[..., int]] | None:
    """The FMI 3.0 binary's library handle and its exported `name` (int f(double, int)), or None. The caller
    closes the handle (close_library) when its instance goes, as ErrorReport does."""
    if not resources:
        return None
    import ctypes
    from pathlib import Path

    binary = Path(resources).parent / "binaries" / BINARY_FOLDERS[1] / "FemPendulum.so"
    try:
        library = ctypes.CDLL(str(binary))
    except OSError:
        return None
    try:
        function = getattr(library, name)
    except AttributeError:
        _close_library(library._handle)
        return None
    function.argtypes, function.restype = [ctypes.c_double, ctypes.c_int], ctypes.c_int
    return library._handle, function


def close_library(handle: int) -> None:
    """dlclose a handle of find_binary_function; a refusal is logged, nothing else is lost."""
    try:
        _close_library(handle)
    except OSError as exc:
        LOG.debug("release: the binary's library handle was not closed (%s)", exc)


def _close_library(handle: int) -> None:
    """dlclose a library opened by ctypes, which never closes one itself."""
    import _ctypes

    _ctypes.dlclose(handle)
