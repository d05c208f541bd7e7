"""Which value feeds which input in the loop: `--connect FROM=TO`, checked against both FMUs.

FROM is `pendulum.OUTPUT`, `setpoint` or `controller.OUTPUT`; TO is `controller.INPUT` or
`pendulum.torque`. Exactly one controller output drives `pendulum.torque` (through the drive,
loop.py); every controller input has at most one source. Without --connect the loop connects the
controller's inputs by name (an input called like a pendulum output, or `setpoint`; the project's
PID FMU's `measurement` takes theta) and its one output (or the one named `torque` or `u`) to the
torque: masters/pid's controller and any controller named that way need no --connect.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

from ..failures import UsageError

SETPOINT = "setpoint"
TORQUE = "pendulum.torque"
ALIASES = {"measurement": "pendulum.theta"}  # the project's PID FMU names its measured angle so


@dataclass(frozen=True)
class Connection:
    """One wire: `source` (`pendulum.X`, `setpoint`) into the controller input `target`, or the
    controller output `source` (`controller.X`) into the torque (`target` = pendulum.torque)."""

    source: str
    target: str


@dataclass(frozen=True)
class Wiring:
    """The loop's connections: what each controller input reads, and the output that is the torque."""

    inputs: tuple[Connection, ...]
    torque_from: str  # the controller output's name, without the `controller.` prefix

    def pendulum_outputs(self) -> tuple[str, ...]:
        """The pendulum outputs the controller reads, without the `pendulum.` prefix."""
        return tuple(c.source.removeprefix("pendulum.") for c in self.inputs if c.source.startswith("pendulum."))


def _listed(names: Iterable[str]) -> str:
    return ", ".join(sorted(names)) or "none"


def parse_connection(item: str) -> Connection:
    """`FROM=TO` as a Connection, or UsageError."""
    source, sep, target = (part.strip() for part in item.partition("="))
    if not sep or not source or not target:
        raise UsageError(f"--connect {item!r}: expected FROM=TO, such as pendulum.theta=controller.measurement")
    return Connection(source, target)


def check_wiring(
    connections: Sequence[Connection],
    controller_inputs: Sequence[str],
    controller_outputs: Sequence[str],
    pendulum_outputs: Sequence[str],
) -> Wiring:
    """The Wiring of `connections`, or UsageError naming the first wrong end and listing what exists."""
    inputs: list[Connection] = []
    torque: list[str] = []
    for c in connections:
        if c.target == TORQUE:
            name = _controller_name(c.source, "FROM", controller_outputs, "output")
            torque.append(name)
            continue
        if not c.target.startswith("controller."):
            raise UsageError(
                f"--connect {c.source}={c.target}: TO {c.target!r} must be controller.INPUT "
                f"(inputs: {_listed(controller_inputs)}) or {TORQUE}"
            )
        _controller_name(c.target, "TO", controller_inputs, "input")
        if c.source != SETPOINT:
            if not c.source.startswith("pendulum.") or c.source.removeprefix("pendulum.") not in pendulum_outputs:
                raise UsageError(
                    f"--connect {c.source}={c.target}: FROM {c.source!r} must be {SETPOINT} or pendulum.OUTPUT "
                    f"(outputs: {_listed(pendulum_outputs)})"
                )
        if any(other.target == c.target for other in inputs):
            raise UsageError(f"--connect: {c.target} is connected twice; an input takes one source")
        inputs.append(c)
    if len(torque) != 1:
        found = "none" if not torque else ", ".join(f"controller.{t}" for t in torque)
        raise UsageError(
            f"--connect: exactly one controller output must drive {TORQUE} (found {found}; "
            f"outputs: {_listed(controller_outputs)}), as in --connect controller.OUTPUT={TORQUE}"
        )
    return Wiring(tuple(inputs), torque[0])


def _controller_name(end: str, which: str, names: Sequence[str], kind: str) -> str:
    """The variable name of `controller.NAME`, or UsageError listing the controller's `kind`s."""
    name = end.removeprefix("controller.")
    if not end.startswith("controller.") or name not in names:
        raise UsageError(
            f"--connect: {which} {end!r} is not a controller {kind} (controller.X with X one of: {_listed(names)})"
        )
    return name


def default_connections(
    controller_inputs: Sequence[str], controller_outputs: Sequence[str], pendulum_outputs: Sequence[str]
) -> list[Connection]:
    """Connections by name (module docstring), or UsageError asking for --connect."""
    wires = []
    for name in controller_inputs:
        if name == SETPOINT:
            wires.append(Connection(SETPOINT, f"controller.{name}"))
        elif name in pendulum_outputs:
            wires.append(Connection(f"pendulum.{name}", f"controller.{name}"))
        elif name in ALIASES:
            wires.append(Connection(ALIASES[name], f"controller.{name}"))
    named = [o for o in controller_outputs if o in ("torque", "u")]
    torque = named if len(named) == 1 else list(controller_outputs)
    if len(torque) != 1 or not wires:
        raise UsageError(
            f"the controller's variables do not say how to connect it (inputs: {_listed(controller_inputs)}; "
            f"outputs: {_listed(controller_outputs)}): give --connect FROM=TO, such as "
            f"--connect pendulum.theta=controller.INPUT --connect controller.OUTPUT={TORQUE}"
        )
    return [*wires, Connection(f"controller.{torque[0]}", TORQUE)]
