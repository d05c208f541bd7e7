"""Messages that agree with themselves: the help names no file of the package, a bad value of a kind is
refused in one wording wherever it is given, and the advice after a stopped run does not contradict the
FMU's message it follows."""

from __future__ import annotations

import argparse
import re
from pathlib import Path

import pytest

from fem_pendulum_fmu.cli import parser
from fem_pendulum_fmu.masters.failures import UsageError, what_to_try
from fem_pendulum_fmu.masters.open_loop import parse_start_values
from fem_pendulum_fmu.masters.sweep import samples
from fem_pendulum_fmu.physics.protocol import NO_SHORTER_STEP

PACKAGE = Path(__file__).resolve().parents[1] / "fem_pendulum_fmu"


def help_texts() -> dict[str, str]:
    """`fem-pendulum --help` and each subcommand's, as the parser prints them."""
    top = parser()
    (sub,) = [a for a in top._actions if isinstance(a, argparse._SubParsersAction)]
    return {"": top.format_help(), **{name: verb.format_help() for name, verb in sub.choices.items()}}


def test_no_help_names_a_python_file_a_package_folder_or_a_file_of_the_package():
    folders = {p.name for p in PACKAGE.rglob("*") if p.is_dir() and p.name != "__pycache__"}
    files = {p.name for p in PACKAGE.rglob("*") if p.is_file() and "__pycache__" not in p.parts}
    assert {"fmi", "masters", "physics"} <= folders and "modelDescription.template.xml" in files
    for command, text in help_texts().items():
        flat = " ".join(text.split())  # argparse wraps lines anywhere a space is
        assert not re.search(r"\w\.py\b", flat), (command, flat)
        assert not re.search(r"fem_pendulum_fmu[./]\w", flat), (command, flat)
        assert not [f for f in folders if re.search(rf"(?<![\w.-]){re.escape(f)}/", flat)], (command, flat)
        assert not [f for f in files if f in flat], (command, flat)


@pytest.mark.parametrize(
    ("name", "text", "clause"),
    [
        ("theta0", "abc", "it must be a number"),
        ("model.order", "1.5", "it must be an integer"),
        ("model.compute_stress", "maybe", "it must be true or false"),
        ("wall.kind", "soft", "choose one of rigid, deformable, none (or their numbers 1 to 3)"),
    ],
)
def test_a_bad_parameter_value_is_refused_in_one_wording_by_run_control_and_sweep(name, text, clause):
    said = f"parameter {name} = {text!r} is not allowed: {clause}"
    with pytest.raises(UsageError) as run:
        parse_start_values([f"{name}={text}"])  # fem-pendulum run and control --set
    assert str(run.value) == f"--set {name}={text}: {said}"
    with pytest.raises(ValueError) as sweep:
        samples.parse_value(name, text)  # fem-pendulum sweep --param, --set and --table
    assert str(sweep.value) == said


def test_an_item_without_values_is_named_once():
    with pytest.raises(ValueError) as err:
        samples.parse_param("theta0=")
    assert str(err.value) == "expected NAME=VALUE1,VALUE2,..."


def test_the_advice_after_a_stopped_run_offers_a_shorter_step_only_where_it_can_help():
    helps = "the advance to t = 1 s needs more than solver.max_substeps = 5 internal steps; retry with a shorter step"
    assert what_to_try(helps, "a smaller torque").endswith("or a shorter --step")
    cannot = f"the nonlinear solve failed down to the smallest step 1e-09 s at t = 0.5 s; {NO_SHORTER_STEP}: ..."
    advice = what_to_try(cannot, "a smaller torque")
    assert advice == "Try a smaller torque, a stiffer material or a finer mesh (model.mesh_size)"
