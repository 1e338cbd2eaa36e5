"""P3 (Shen 2023, 2T1R mechanisms A and B): the workspace sections of Figs 9 and 11 over the section's position.

The clouds are the notebook's: the platform centre (``two_t_one_r.platform_centre_a`` /
``platform_centre_b``) of the forward solution (``forward_a`` / ``forward_b``) swept with
``pk.sweep`` over the actuator box of ``data/params/p3.json`` at the notebook's ``step_mm`` = 5 mm,
on every forward branch, as in ``notebooks/p3_two_t_one_r.ipynb``. A section is the slab
``|c[axis] - level| <= section_halfwidth_mm`` (2.5 mm) the static figure draws. The static figure
scatters the slab's points; the page bins them into 5 mm cells of the section plane and shows the
number of points per cell (NaN where none), so the number of points of each branch in the slab,
the count in the static figure's legend, is the sum over the map. The slider moves ``level`` in
steps of ``LEVEL_STEP_MM`` through the cloud's range, the paper's level (the static figure's)
among them. The section level is not a notebook parameter: the re-run command is the paper's run.
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

from .. import _grid, _params, _sweep
from ..mechanisms import two_t_one_r as m
from ._store import colormap, control, field_control, key_of, map_axis, write_figure

NOTEBOOK = "p3_two_t_one_r"
STEP_MM = 5.0  # the notebook's step_mm
HALFWIDTH_MM = 2.5  # the notebook's section_halfwidth_mm
CELL_MM = 5.0  # the cells the slab's points are counted in
#: (mechanism, static figure, axis, the static figure's level in mm, slider step in mm)
SECTIONS = (
    ("A", "Fig 9", 0, 60.0, 20.0),
    ("A", "Fig 9", 1, -85.0, 5.0),
    ("A", "Fig 9", 2, 300.0, 20.0),
    ("B", "Fig 11", 0, 50.0, 20.0),
    ("B", "Fig 11", 1, 82.5, 1.0),
    ("B", "Fig 11", 2, 385.0, 20.0),
)
AXES = "xyz"


def branches(name: str) -> list[tuple[object, str]]:
    """The forward branches and the notebook's labels (``m=+1``; ``n=+1,m=+1``)."""
    if name == "A":
        return [(mm, f"m={mm:+.0f}") for mm in m.TABLE1_BRANCHES_A]
    return [(jnp.array(br), f"n={br[0]:+.0f},m={br[1]:+.0f}") for br in m.FK_BRANCHES_B]


def clouds(name: str, step: float = STEP_MM) -> dict[str, np.ndarray]:
    """The platform-centre cloud ``(3, n)`` (mm) of each branch of mechanism ``name``, the
    notebook's ``sweep_centres`` with its real points kept."""
    P = _params.load_params("p3")
    forward, centre, p = (
        (m.forward_a, m.platform_centre_a, m.ParamsA.from_dict(P["mechanism_A"]))
        if name == "A"
        else (m.forward_b, m.platform_centre_b, m.ParamsB.from_dict(P["mechanism_B"]))
    )
    grid = _grid.Grid.from_ranges(
        x1=(p.x1_min, p.x1_max, step), x2=(p.x2_min, p.x2_max, step), x3=(p.x3_min, p.x3_max, step)
    )
    out = {}
    for br, label in branches(name):

        def fn(q, br=br):
            x = forward(q, p, br)
            return jnp.concatenate([centre(x, p), x])

        v = np.asarray(_sweep.sweep(fn, grid, progress=False)).reshape(-1, 6).T
        ok = np.all(np.isfinite(v[3:]), axis=0)
        out[label] = v[:3, ok]
    return out


def levels(cloud: dict[str, np.ndarray], axis: int, paper: float, step: float) -> list[float]:
    """Slider positions: ``paper + k step`` within the clouds' range along ``axis``."""
    allc = np.concatenate(list(cloud.values()), axis=1)[axis]
    lo, hi = float(allc.min()), float(allc.max())
    k0, k1 = int(np.ceil((lo - paper) / step)), int(np.floor((hi - paper) / step))
    return [round(paper + k * step, 6) for k in range(min(k0, 0), max(k1, 0) + 1)]


def cell_grid(cloud: dict[str, np.ndarray], axis: int) -> tuple[list[int], list[float], list[int]]:
    """The section plane's two axes, their first cell centres and cell counts (``CELL_MM`` cells
    covering every branch's cloud)."""
    others = [i for i in range(3) if i != axis]
    allc = np.concatenate(list(cloud.values()), axis=1)
    starts, counts = [], []
    for i in others:
        lo, hi = np.floor(allc[i].min() / CELL_MM) * CELL_MM, np.ceil(allc[i].max() / CELL_MM) * CELL_MM
        starts.append(float(lo))
        counts.append(round(float(hi - lo) / CELL_MM) + 1)
    return others, starts, counts


def section_counts(c: np.ndarray, axis: int, level: float, others, starts, counts) -> np.ndarray:
    """Points of ``c`` in the slab ``|c[axis] - level| <= HALFWIDTH_MM`` per cell, ``(n_y, n_x)``
    (rows: the plane's second axis), NaN in a cell with none."""
    sel = np.abs(c[axis] - level) <= HALFWIDTH_MM
    # cell k holds start + (k - 1/2) CELL_MM <= v < start + (k + 1/2) CELL_MM
    ix, iy = (np.floor((c[i, sel] - s) / CELL_MM + 0.5).astype(int) for i, s in zip(others, starts))
    h = np.zeros((counts[1], counts[0]))
    np.add.at(h, (iy, ix), 1.0)
    h[h == 0] = np.nan
    return h


def fig_id(name: str, axis: int) -> str:
    return f"p3_{name}_{AXES[axis]}_section"


def write_section(out, cloud, name, figure, axis, paper, step) -> list:
    others, starts, counts = cell_grid(cloud, axis)
    lv = levels(cloud, axis, paper, step)
    labels = [lb for _, lb in branches(name)]
    chunks = {}
    for i, level in enumerate(lv):
        chunks[key_of((i,))] = {}
        for j, lb in enumerate(labels):
            h = section_counts(cloud[lb], axis, level, others, starts, counts)
            # colour scale 0 to this slab's fullest cell (counts differ by orders between levels)
            top = float(np.nanmax(h)) if np.isfinite(h).any() else 1.0
            chunks[key_of((i,))][f"branch{j}"] = {"values": h, "vmin": 0.0, "vmax": top}
    plane = AXES[axis]
    fields = [
        {
            "name": f"branch{j}",
            "figure": f"{figure}, branch {lb}",
            "symbol": "n",
            "unit": "points",
            "label": f"platform-centre points in the slab per {CELL_MM:g} mm cell",
            "scale": "linear",
            "colors": colormap("viridis"),
            "digits": 4,
            "total": True,
            "over": "cells",
            "empty": "no point of this branch in the slab",
        }
        for j, lb in enumerate(labels)
    ]
    controls = [
        control("level", f"section {plane}", "mm", lv, paper, param=None, digits=5),
        field_control(fields, label="branch"),
    ]
    controls[0]["param"] = None  # the level is not a notebook parameter
    centre = "C3D" if name == "A" else "DE"
    manifest = {
        "title": "P3 {figure}: {label}",
        "notebook": NOTEBOOK,
        "controls": controls,
        "fields": fields,
        "equal_aspect": True,
        "x": map_axis(AXES[others[0]], "mm", starts[0], CELL_MM, counts[0], digits=1),
        "y": map_axis(AXES[others[1]], "mm", starts[1], CELL_MM, counts[1], digits=1),
        "rerun": {key_of((i,)): f'make rerun NB={NOTEBOOK} PARAMS="-p params_file p3"' for i in range(len(lv))},
        "resolution": (
            f"the notebook's sweep of mechanism {name} (actuator step 5 mm, every forward branch, "
            f"platform centre at the midpoint of {centre}), slabs |{plane} − level| ≤ 2.5 mm, "
            f"points counted in {CELL_MM:g} mm cells; level in steps of {step:g} mm"
        ),
        "fixed": "the geometry and actuator box of data/params/p3.json (the level is not a notebook parameter: "
        "the re-run command is the paper's run)",
    }
    return write_figure(out, fig_id(name, axis), manifest, chunks)


def write(out) -> list:
    """The six P3 section figures into ``out/p3_<A|B>_<x|y|z>_section``."""
    written, cache = [], {}
    for name, figure, axis, paper, step in SECTIONS:
        if name not in cache:
            cache[name] = clouds(name)
        written += write_section(out, cache[name], name, figure, axis, paper, step)
    return written
