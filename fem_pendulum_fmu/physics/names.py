"""The one naming rule: Python uses the FMU's names, each '.' written '_' where a dot cannot stand.

An output is `energy.total` in the FMU and `Outputs.energy_total` in Python; a parameter is
`pendulum.E` in the FMU, in `Scene.with_values` and on the command line, and `pendulum_E` as a
keyword of the presets (`steel(pendulum_E=1e9)`). The names used before this rule keep working,
each with a DeprecationWarning naming its successor: the Outputs fields' old names as read-only
properties and dictionary keys (`RenamedKeys`), the presets' old names, and the keywords' '__'.
"""

from __future__ import annotations

import warnings
from collections.abc import Iterable, Mapping
from typing import Any

# the Outputs fields' names before the rule -> their names now
OLD_OUTPUT_NAMES = {
    "kinetic": "energy_kinetic",
    "potential": "energy_potential",
    "strain": "energy_strain",
    "contact": "energy_contact",
    "total": "energy_total",
    "torque_work": "energy_torque_work",
    "von_mises_max": "stress_von_mises_max",
    "substeps": "solver_substeps",
    "min_gap": "gap_min",
}


def python_name(fmi_name: str) -> str:
    """An FMU variable's name where Python cannot write a dot (a field, a keyword): 'energy.total' -> 'energy_total'."""
    return fmi_name.replace(".", "_")


def warn_renamed(old: str, new: str, what: str) -> None:
    """The DeprecationWarning of an old name, raised where the caller's caller used it."""
    warnings.warn(f"{what} {old!r} is deprecated: it is now {new!r}", DeprecationWarning, stacklevel=3)


class RenamedKeys(dict[str, Any]):
    """A dict keyed by new names that still answers the old ones (`old_names`, with a DeprecationWarning
    naming the new): the dictionaries users index by output name were keyed by the old names."""

    old_names: Mapping[str, str] = OLD_OUTPUT_NAMES
    what = "the output name"

    def __missing__(self, key: str) -> Any:
        new = self.old_names.get(key)
        if new is None or not dict.__contains__(self, new):
            raise KeyError(key)
        warn_renamed(key, new, self.what)
        return self[new]

    def __contains__(self, key: object) -> bool:
        # `key in d` as d[key] answers it (argparse's choices ask so): an old name too, without a warning
        return dict.__contains__(self, key) or dict.__contains__(self, self.old_names.get(str(key), key))

    def get(self, key: str, default: Any = None) -> Any:
        return self[key] if key in self else default


def dotted_keywords(values: Mapping[str, Any], known: Iterable[str], stacklevel: int = 3) -> dict[str, Any]:
    """Keywords of FMU parameter names (pendulum_E=..., each '.' written '_') -> the dotted names
    (pendulum.E=...). The old form with '__' (pendulum__E) is read too, with a DeprecationWarning at
    `stacklevel` (that of warnings.warn, counted from here); a keyword that names no parameter is kept
    as written, for the caller to refuse."""
    by_keyword = {python_name(name): name for name in known}
    dotted: dict[str, Any] = {}
    for key, value in values.items():
        if "__" in key:
            new = python_name(key.replace("__", "."))
            warnings.warn(f"the keyword {key!r} is deprecated: it is now {new!r}", DeprecationWarning, stacklevel)
            key = new
        dotted[by_keyword.get(key, key)] = value
    return dotted
