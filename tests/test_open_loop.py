"""The open-loop master's --set parsing: enumerations by item name, Booleans, clear refusals."""

from __future__ import annotations

import pytest

from fem_pendulum_fmu.masters.failures import UsageError
from fem_pendulum_fmu.masters.open_loop import parse_start_values


def test_enumerations_take_item_names_or_numbers_and_numbers_keep_their_type():
    values = parse_start_values(
        ["model.fidelity=auto", "wall.kind=3", "model.compute_stress=true", "pendulum.E=1e6", "model.order=3"]
    )
    assert values == {
        "model.fidelity": 1,
        "wall.kind": 3,
        "model.compute_stress": True,
        "pendulum.E": 1e6,
        "model.order": 3,
    }
    assert parse_start_values(["model.fidelity=fem"])["model.fidelity"] == 4
    assert parse_start_values(["output.vtk_folder=out/fields 1"]) == {"output.vtk_folder": "out/fields 1"}


@pytest.mark.parametrize(
    "item, words",
    [
        ("model.fidelity=fast", ["'fast'", "auto, rigid, reduced, fem"]),
        ("pendulum.E", ["NAME=VALUE"]),
        ("no.such=1", ["no.such", "not a variable"]),
    ],
)
def test_bad_items_are_refused_naming_what_is_allowed(item, words):
    with pytest.raises(UsageError) as err:
        parse_start_values([item])
    assert all(w in str(err.value) for w in words)
