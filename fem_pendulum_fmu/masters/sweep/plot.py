"""The sweep's summary plot: one figure of the results table against one or two swept parameters (PNG)."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from ...fmi import interface
from .figures import UNITS, Figures

FIGURES = (*(f.name for f in dataclasses.fields(Figures)), "wall_time")  # what --plot may show
FIGURE_UNITS = {**UNITS, "wall_time": "s"}


def label(name: str) -> str:
    """A figure or a parameter with its unit: `max_contact_force (N)`, `pendulum.E (Pa)`; an enumeration
    or a parameter without a unit as it is."""
    if name in FIGURE_UNITS:
        return f"{name} ({FIGURE_UNITS[name]})"
    try:
        unit = interface.load().by_name(name).unit
    except KeyError:
        unit = None
    return f"{name} ({unit})" if unit else name


def _numeric(column: pd.Series) -> tuple[np.ndarray, list[str] | None]:
    """Values to plot and, for a column of names (enumerations), the tick labels."""
    if pd.api.types.is_numeric_dtype(column):
        return column.to_numpy(float), None
    labels = sorted(column.astype(str).unique())
    return column.astype(str).map(labels.index).to_numpy(float), labels


def summary_plot(table: pd.DataFrame, figure: str, x: str, y: str | None, path: Path) -> Path:
    """Write summary_figure to the PNG `path`."""
    from ..plots import save_figure

    return save_figure(summary_figure(table, figure, x, y), path)


def summary_figure(table: pd.DataFrame, figure: str, x: str, y: str | None) -> Any:
    """`figure` against parameter `x` (a curve), or against `x` and `y` (colour); failed samples as red crosses;
    every axis with its unit (`label`).

    A logarithmic axis is used for a parameter whose values span more than two decades (moduli, stiffnesses)."""
    from ..plots import _pyplot

    plt = _pyplot()
    ok = table["status"] == "ok"
    xs, xlabels = _numeric(table[x])
    fig, ax = plt.subplots(figsize=(7, 4.5))
    if y is None:
        order = np.argsort(xs[ok.to_numpy()], kind="stable")
        ax.plot(xs[ok.to_numpy()][order], table.loc[ok, figure].to_numpy(float)[order], "o-")
        ax.plot(xs[~ok.to_numpy()], np.zeros((~ok).sum()), "rx", label="failed")
        ax.set_ylabel(label(figure))
    else:
        ys, ylabels = _numeric(table[y])
        dots = ax.scatter(xs[ok.to_numpy()], ys[ok.to_numpy()], c=table.loc[ok, figure].to_numpy(float), s=80)
        fig.colorbar(dots, ax=ax, label=label(figure))
        ax.plot(xs[~ok.to_numpy()], ys[~ok.to_numpy()], "rx", label="failed")
        _axis(ax.set_yscale, ax.set_yticks, ys[ok.to_numpy()], ylabels)
        ax.set_ylabel(label(y))
    _axis(ax.set_xscale, ax.set_xticks, xs[ok.to_numpy()], xlabels)
    ax.set_xlabel(label(x))
    ax.set_title(f"{figure}: {ok.sum()} ok, {(~ok).sum()} failed")
    if (~ok).any():
        ax.legend()
    fig.tight_layout()
    return fig


def _axis(
    set_scale: Callable[[str], object], set_ticks: Callable[..., object], values: np.ndarray, labels: list[str] | None
) -> None:
    """Names as ticks; a log scale when the successful samples' values are positive and span two decades
    (failed samples at values <= 0, such as an invalid modulus, are then left off the plot, not off the title)."""
    if labels is not None:
        set_ticks(range(len(labels)), labels)
    elif len(values) and (values > 0).all() and values.max() > 100 * values.min():
        set_scale("log")
