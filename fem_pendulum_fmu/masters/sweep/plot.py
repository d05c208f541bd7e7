"""The sweep's summary plot: figures of the results table against one or two swept parameters (PNG),
one panel per figure.

An open-loop sweep's figures are figures.py's; a loop sweep's are the loop's metrics
(masters/control/metrics.py), whose units LOOP_UNITS gives. A metric that is infinite (a settling
time that never settles) is drawn as a triangle at the top of its panel, not left off. Against two
parameters a panel colours the figure over the plane, or (`curves`, as a loop sweep's plot has it
when the second parameter takes few values, such as set-points) draws one curve per value of the second.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from ...fmi import interface
from ..control.metrics import METRIC_NAMES, METRIC_UNITS
from .figures import UNITS, Figures

FIGURES = (*(f.name for f in dataclasses.fields(Figures)), "wall_time")  # what --plot may show
FIGURE_UNITS = {**UNITS, "wall_time": "s"}
LOOP_FIGURES = (*METRIC_NAMES, "wall_time")  # what --plot may show for a loop sweep
LOOP_UNITS = {**METRIC_UNITS, "overshoot": "fraction of the step", "impacts": "count", "wall_time": "s"}


def label(name: str, units: Mapping[str, str] = FIGURE_UNITS) -> str:
    """A figure or a parameter with its unit: `max_contact_force (N)`, `pendulum.E (Pa)`; an enumeration,
    a controller parameter, a signal or a parameter without a unit as it is."""
    if name in units:
        return f"{name} ({units[name]})" if units[name] else name
    try:
        unit = interface.load().by_name(name).unit
    except KeyError:
        unit = None
    return f"{name} ({unit})" if unit else name


def _numeric(column: pd.Series) -> tuple[np.ndarray, list[str] | None]:
    """Values to plot and, for a column of names (enumerations, set-points), the tick labels."""
    if pd.api.types.is_numeric_dtype(column):
        return column.to_numpy(float), None
    labels = sorted(column.astype(str).unique())
    return column.astype(str).map(labels.index).to_numpy(float), labels


def summary_plot(
    table: pd.DataFrame,
    figure: str | Sequence[str],
    x: str,
    y: str | None,
    path: Path,
    units: Mapping[str, str] = FIGURE_UNITS,
    curves: bool = False,
) -> Path:
    """Write summary_figure to the PNG `path`."""
    from ..plots import save_figure

    return save_figure(summary_figure(table, figure, x, y, units, curves), path)


def summary_figure(
    table: pd.DataFrame,
    figure: str | Sequence[str],
    x: str,
    y: str | None,
    units: Mapping[str, str] = FIGURE_UNITS,
    curves: bool = False,
) -> Any:
    """Each of `figure` (a name or several, one panel each) against parameter `x` (a curve), or against `x`
    and `y` (colour, or with `curves` one curve per value of `y`); failed samples as red crosses; every
    axis with its unit (`label`, from `units`).

    A logarithmic axis is used for a parameter whose values span more than two decades (moduli, stiffnesses)."""
    from ..plots import _pyplot

    plt = _pyplot()
    names = [figure] if isinstance(figure, str) else list(figure)
    fig, axes = plt.subplots(len(names), 1, figsize=(7, 1.0 + 3.5 * len(names)), squeeze=False)
    for ax, name in zip(axes[:, 0], names, strict=True):
        if y is not None and curves:
            _curves(ax, table, name, x, y, units)
        else:
            _panel(fig, ax, table, name, x, y, units)
    fig.tight_layout()
    return fig


def _panel(
    fig: Any, ax: Any, table: pd.DataFrame, figure: str, x: str, y: str | None, units: Mapping[str, str]
) -> None:
    """One figure's panel (summary_figure)."""
    ok = (table["status"] == "ok").to_numpy()
    values = table[figure].to_numpy(float)
    never = ok & np.isposinf(values)
    shown = ok & ~never
    xs, xlabels = _numeric(table[x])
    top = ax.get_xaxis_transform()  # x in data, y in axes: the top edge at y = 1
    if y is None:
        order = np.argsort(xs[shown], kind="stable")
        ax.plot(xs[shown][order], values[shown][order], "o-")
        ax.plot(xs[~ok], np.zeros((~ok).sum()), "rx", label="failed")
        if never.any():  # (an empty line drawn unclipped would defeat tight_layout)
            ax.plot(xs[never], np.ones(never.sum()), "k^", transform=top, clip_on=False, label="inf")
        ax.set_ylabel(label(figure, units))
    else:
        ys, ylabels = _numeric(table[y])
        dots = ax.scatter(xs[shown], ys[shown], c=values[shown], s=80)
        fig.colorbar(dots, ax=ax, label=label(figure, units))
        ax.plot(xs[~ok], ys[~ok], "rx", label="failed")
        ax.plot(xs[never], ys[never], "k^", ms=9, label="inf")
        _axis(ax.set_yscale, ax.set_yticks, ys[ok], ylabels)
        ax.set_ylabel(label(y, units))
    _axis(ax.set_xscale, ax.set_xticks, xs[ok], xlabels)
    ax.set_xlabel(label(x, units))
    ax.set_title(f"{figure}: {ok.sum()} ok, {(~ok).sum()} failed")
    if (~ok).any() or never.any():
        ax.legend()


def _curves(ax: Any, table: pd.DataFrame, figure: str, x: str, y: str, units: Mapping[str, str]) -> None:
    """One figure's panel against `x`, one curve per value of `y` (summary_figure)."""
    ok = (table["status"] == "ok").to_numpy()
    values = table[figure].to_numpy(float)
    xs, xlabels = _numeric(table[x])
    top = ax.get_xaxis_transform()
    for level in sorted(table[y].unique(), key=str):
        mine = (table[y] == level).to_numpy() & ok
        shown, never = mine & ~np.isposinf(values), mine & np.isposinf(values)
        order = np.argsort(xs[shown], kind="stable")
        (line,) = ax.plot(xs[shown][order], values[shown][order], "o-", label=f"{y} = {level}")
        if never.any():  # (an empty line drawn unclipped would defeat tight_layout)
            ax.plot(xs[never], np.ones(never.sum()), "^", color=line.get_color(), transform=top, clip_on=False)
    ax.plot(xs[~ok], np.zeros((~ok).sum()), "rx", label="failed" if (~ok).any() else None)
    _axis(ax.set_xscale, ax.set_xticks, xs[ok], xlabels)
    ax.set_xlabel(label(x, units))
    ax.set_ylabel(label(figure, units))
    infinite = int((ok & np.isposinf(values)).sum())
    never = f", {infinite} inf (triangles)" if infinite else ""
    ax.set_title(f"{figure}: {ok.sum()} ok, {(~ok).sum()} failed{never}")
    ax.legend(fontsize="small")


def _axis(
    set_scale: Callable[[str], object], set_ticks: Callable[..., object], values: np.ndarray, labels: list[str] | None
) -> None:
    """Names as ticks; a log scale when the successful samples' values are positive and span two decades
    (failed samples at values <= 0, such as an invalid modulus, are then left off the plot, not off the title)."""
    if labels is not None:
        set_ticks(range(len(labels)), labels)
    elif len(values) and (values > 0).all() and values.max() > 100 * values.min():
        set_scale("log")
