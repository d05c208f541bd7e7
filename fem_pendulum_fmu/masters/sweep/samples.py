"""The samples of a sweep: a grid or a table of parameter values, each with an id that survives a restart.

A sample's values are kept as the user wrote them, with enumerations by item
name (`model.fidelity=rigid`), so that the results table reads like the
command line; `start_values` turns them into what fmi2SetReal/Integer/Boolean
take. The id is a hash of the values and the torque profile's content, not
of the row's position: a grid that grows, or a table whose rows are
reordered, still finds the samples a folder already holds.
"""

from __future__ import annotations

import csv
import hashlib
import itertools
import json
from dataclasses import dataclass, field
from pathlib import Path

from ...fmi import interface

Value = float | int | bool | str  # a parameter value as the user wrote it (enumerations by item name)


@dataclass(frozen=True)
class Sample:
    """One run of the FMU: its parameter values and the torque profile it is driven by ("" for none)."""

    sample_id: str
    values: dict[str, Value] = field(hash=False)
    torque: str = ""


def _problem_free(problems: list[str], what: str) -> None:
    """Raise one ValueError listing every problem (a user with three mistakes needs one try, not three)."""
    if problems:
        raise ValueError(f"{what}:\n  " + "\n  ".join(problems))


def parse_value(name: str, text: str) -> Value:
    """Text from a grid or a table -> the value of parameter `name`, by its declared type; ValueError naming
    the parameter and what it allows."""
    return interface.parse_text(interface.parameter(interface.load(), name), text.strip())


def parse_param(item: str, form: str = "NAME=VALUE1,VALUE2,...") -> tuple[str, list[Value]]:
    """`NAME=V1,V2,...` (a grid axis) -> (NAME, values); ValueError saying the `form` expected (the caller
    names the option and the item, once)."""
    name, eq, values = item.partition("=")
    if not eq or not values.strip():
        raise ValueError(f"expected {form}")
    return name.strip(), [parse_value(name.strip(), text) for text in values.split(",")]


def grid(axes: list[tuple[str, list[Value]]]) -> list[dict[str, Value]]:
    """The product of the axes, the last axis varying fastest (as nested loops in the order given)."""
    names = [name for name, _ in axes]
    return [dict(zip(names, combo, strict=True)) for combo in itertools.product(*(values for _, values in axes))]


def read_table(path: Path) -> list[dict[str, str]]:
    """A CSV, one row a sample, columns FMU parameter names (and optionally `torque`, a CSV path relative
    to the table's folder). Values stay text here; `samples` parses them."""
    with open(path, newline="") as handle:
        rows = list(csv.DictReader(handle))
    if not rows:
        raise ValueError(f"{path}: no rows")
    for row in rows:
        if row.get("torque"):
            row["torque"] = str((path.parent / row["torque"]).resolve())
    return rows


def file_digest(path: str | Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def sample_id(values: dict[str, Value], torque_digest: str) -> str:
    """12 hex digits of a hash of the values (normalised by type) and the torque file's content."""
    text = json.dumps({"values": sorted(values.items()), "torque": torque_digest}, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:12]


def samples(rows: list[dict], torque: Path | None = None) -> list[Sample]:
    """Rows (from `grid` or `read_table`) -> samples. A row's `torque` entry overrides `torque`, the profile
    of every sample. Every unreadable value is reported at once."""
    problems: list[str] = []
    out: list[Sample] = []
    digests: dict[str, str] = {}
    seen: dict[str, int] = {}
    for number, row in enumerate(rows, 1):
        values: dict[str, Value] = {}
        for name, raw in row.items():
            if name == "torque" or raw is None or raw == "":
                continue
            try:
                values[name] = parse_value(name, raw) if isinstance(raw, str) else raw
            except ValueError as exc:
                problems.append(f"sample {number}: {exc}")
        path = row.get("torque") or (str(torque.resolve()) if torque else "")
        if path and path not in digests:
            if not Path(path).is_file():
                problems.append(f"sample {number}: torque file {path} does not exist")
                continue
            digests[path] = file_digest(path)
        sample = Sample(sample_id(values, digests.get(path, "")), values, path)
        if sample.sample_id in seen:
            problems.append(f"sample {number} repeats sample {seen[sample.sample_id]}")
        seen.setdefault(sample.sample_id, number)
        out.append(sample)
    _problem_free(problems, "cannot read the samples")
    return out


def start_values(values: dict[str, Value]) -> dict[str, Value]:
    """A sample's values as the FMU takes them: enumerations by number (1, 2, ...)."""
    ifc = interface.load()
    out: dict[str, Value] = {}
    for name, value in values.items():
        var = ifc.by_name(name)
        out[name] = var.item_number(value) if var.items and isinstance(value, str) else value
    return out
