"""Plots shared by the notebooks: maps over a workspace grid with units and colour bars."""

from __future__ import annotations

from pathlib import Path
from typing import Sequence

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.colors import ListedColormap, LogNorm
from mpl_toolkits.axes_grid1 import make_axes_locatable

from ._atomic import atomic_write_with
from ._grid import Grid


def _colorbar(ax, mesh, **kwargs):
    """A colour bar as tall as the (equal-aspect) axes."""
    cax = make_axes_locatable(ax).append_axes("right", size="3%", pad=0.1)
    return ax.figure.colorbar(mesh, cax=cax, **kwargs)


def _axis_labels(ax, grid: Grid, units: Sequence[str]):
    ax.set_xlabel(f"${grid.names[0]}$, {units[0]}")
    ax.set_ylabel(f"${grid.names[1]}$, {units[1]}")


def plot_map(ax, grid: Grid, values: np.ndarray, *, label: str, units: Sequence[str] = ("m", "m"),
             log: bool = False, cmap: str = "viridis", vmin: float | None = None, vmax: float | None = None):
    """Colour map of ``values`` (shaped like the 2-D ``grid``) with a labelled colour bar.

    NaN (outside the workspace) is left blank. ``log=True`` uses a logarithmic colour scale.
    The axes get equal aspect (both coordinates in the same unit).
    """
    ax.set_aspect("equal")
    x, y = grid.axes[:2]
    Z = np.asarray(values, dtype=float).T
    norm = LogNorm(vmin=vmin or np.nanmin(Z), vmax=vmax or np.nanmax(Z)) if log else None
    mesh = ax.pcolormesh(x, y, Z, shading="nearest", cmap=cmap, norm=norm,
                         **({} if log else {"vmin": vmin, "vmax": vmax}))
    _colorbar(ax, mesh, label=label)
    _axis_labels(ax, grid, units)
    return mesh


def plot_sign_map(ax, grid: Grid, values: np.ndarray, *, label: str, units: Sequence[str] = ("m", "m")):
    """Map of the sign of ``values`` (negative / positive) with a two-entry colour bar."""
    ax.set_aspect("equal")
    x, y = grid.axes[:2]
    S = np.sign(np.asarray(values, dtype=float)).T
    cmap = ListedColormap(["tab:blue", "tab:orange"])
    mesh = ax.pcolormesh(x, y, S, shading="nearest", cmap=cmap, vmin=-1, vmax=1)
    cb = _colorbar(ax, mesh, ticks=[-0.5, 0.5], label=label)
    cb.ax.set_yticklabels(["< 0", "> 0"])
    _axis_labels(ax, grid, units)
    return mesh


def plot_workspace_outline(ax, grid: Grid, inside: np.ndarray, **kwargs):
    """Outline of the region where ``inside`` is true (e.g. finite values)."""
    x, y = grid.axes[:2]
    kw = {"colors": "k", "linewidths": 0.8} | kwargs
    return ax.contour(x, y, np.asarray(inside, dtype=float).T, levels=[0.5], **kw)


def save_figure(fig, path: str | Path, *, source: str) -> Path:
    """Save ``fig`` as PNG, recording in its metadata the notebook that made it.

    The write is atomic (a temporary PNG in the same folder, then a rename): an interrupted run
    never leaves a truncated figure behind.
    """
    return atomic_write_with(path, lambda tmp: fig.savefig(tmp, format="png", dpi=150, bbox_inches="tight",
                                                           metadata={"Source": source}))


__all__ = ["plot_map", "plot_sign_map", "plot_workspace_outline", "save_figure", "plt"]
