"""Plots shared by the notebooks: maps over a workspace grid with units and colour bars."""

from __future__ import annotations

import zipfile
from pathlib import Path
from typing import Any, Mapping, Sequence

import matplotlib.pyplot as plt
import matplotlib.text
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


def plot_map(
    ax,
    grid: Grid,
    values: np.ndarray,
    *,
    label: str,
    units: Sequence[str] = ("m", "m"),
    log: bool = False,
    cmap: str = "viridis",
    vmin: float | None = None,
    vmax: float | None = None,
):
    """Colour map of ``values`` (shaped like the 2-D ``grid``) with a labelled colour bar.

    NaN (outside the workspace) is left blank. ``log=True`` uses a logarithmic colour scale.
    The axes get equal aspect (both coordinates in the same unit).
    """
    ax.set_aspect("equal")
    x, y = grid.axes[:2]
    Z = np.asarray(values, dtype=float).T
    norm = LogNorm(vmin=vmin or np.nanmin(Z), vmax=vmax or np.nanmax(Z)) if log else None
    mesh = ax.pcolormesh(
        x, y, Z, shading="nearest", cmap=cmap, norm=norm, **({} if log else {"vmin": vmin, "vmax": vmax})
    )
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


def smallest_text_pt(fig) -> float:
    """The smallest font size (points) of any visible text in ``fig``: titles, labels, tick labels,
    legends, annotations and colour-bar labels alike. 0.0 when the figure holds no text."""
    sizes = [t.get_fontsize() for t in fig.findobj(matplotlib.text.Text) if t.get_visible() and t.get_text().strip()]
    return float(min(sizes)) if sizes else 0.0


def _write_npz(path: Path, data: Mapping[str, np.ndarray]) -> None:
    """``np.savez_compressed`` with fixed zip timestamps, so that the same arrays give the same bytes
    (``make report`` regenerates every committed file identically; NumPy stamps the current time)."""
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED) as z:
        for key, a in data.items():
            info = zipfile.ZipInfo(f"{key}.npy", date_time=(1980, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            with z.open(info, "w") as f:
                np.lib.format.write_array(f, np.ascontiguousarray(a), allow_pickle=False)


def save_figure(fig, path: str | Path, *, source: str, arrays: Mapping[str, Any] | None = None) -> Path:
    """Save ``fig`` as PNG, recording in its metadata the notebook that made it.

    The PNG's metadata also records ``MinTextPx``: the height in image pixels of its smallest text
    (:func:`smallest_text_pt` at the saved resolution). The site's browser test divides it by the
    image's displayed scale to check that every figure's text is at least 10 px on the page.

    ``arrays`` (names to arrays, e.g. the grid axes and the mapped values with their units in the
    names, ``{"x_D_m": ..., "y_D_m": ..., "v_max_m_s": ...}``) are saved beside the PNG as a
    compressed ``.npz`` of the same name, which the site links under the figure. Each value must
    convert to a NumPy array of numbers (``ValueError`` naming the key otherwise).

    Both writes are atomic (a temporary file in the same folder, then a rename): an interrupted run
    never leaves a truncated figure or array file behind.
    """
    path = Path(path)
    data = {}
    if arrays is not None:
        if not isinstance(arrays, Mapping) or not arrays:
            raise ValueError(f"arrays: expected a non-empty mapping of names to arrays, got {arrays!r}")
        for key, value in arrays.items():
            if not isinstance(key, str) or not key.isidentifier():
                raise ValueError(f"arrays: keys must be identifiers, got {key!r}")
            a = np.asarray(value)
            if a.dtype.kind not in "biuf":
                raise ValueError(f"arrays[{key!r}]: expected numbers, got dtype {a.dtype}")
            data[key] = a
    dpi = 150
    metadata = {"Source": source, "MinTextPx": f"{smallest_text_pt(fig) * dpi / 72:.1f}"}
    atomic_write_with(path, lambda tmp: fig.savefig(tmp, format="png", dpi=dpi, bbox_inches="tight", metadata=metadata))
    if data:
        atomic_write_with(path.with_suffix(".npz"), lambda tmp: _write_npz(tmp, data))
    return path


__all__ = ["plot_map", "plot_sign_map", "plot_workspace_outline", "save_figure", "smallest_text_pt", "plt"]
