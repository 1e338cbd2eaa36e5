"""P1 (Ispolov et al. 2025, 4-PRR with gripper): Figs 2, 4, 5, 6a over phi and s; Fig 6b over the
external load. The same grid and the same function as ``notebooks/p1_gripper_4prr.ipynb``
(``gripper_4prr.pose_criteria`` swept over the paper's grid)."""

from __future__ import annotations

import itertools

import numpy as np

from .. import _grid, _params, _sweep
from ..mechanisms import gripper_4prr as m
from ._store import control, field_control, fields_manifest, grid_axes, key_of, write_figure

NOTEBOOK = "p1_gripper_4prr"
#: Control positions (the paper's value among them): phi from 0 to 50 deg in steps of 5 deg (the
#: workspace is empty from about 55 deg), s from 0.06 to 0.22 m in steps of 0.02 m.
PHI_DEG = tuple(range(0, 55, 5))
S_M = (0.06, 0.08, 0.10, 0.12, 0.14, 0.16, 0.18, 0.20, 0.22)
#: Fig 6b: F_x and F_y at -2, -1, 0, 1, 2 times the printed 1 N, T at -1, 0, 1 times the printed 0.1 N m.
F_X_N = (-2.0, -1.0, 0.0, 1.0, 2.0)
F_Y_N = (-2.0, -1.0, 0.0, 1.0, 2.0)
T_EXT_N_M = (-0.1, 0.0, 0.1)
#: The notebook's parameters cell (the paper's values).
PAPER = {
    "s_m": 0.14,
    "phi_deg": 20.0,
    "speeds": (1.0, 1.0, 1.0),
    "loads": (1.0, 1.0, 1.0),
    "F_pr_N": 100.0,
    "external_load": (1.0, 1.0, 0.1),
    "x_D": (0.2, 1.2, 0.005),
    "y_D": (-0.25, 0.25, 0.0025),
    "branch": (-1, 1, -1, 1),
}


def _grid_manifest(grid):
    return grid_axes(grid, "m", digits=(3, 4))


def _criteria(points, phi, s, external_load, p):
    # the notebook's `criteria` (cell after the parameters), phi and s as run-time arguments
    x = m.pose(points[0], points[1], phi, s)
    return m.pose_criteria(
        x,
        p,
        speeds=PAPER["speeds"],
        loads=PAPER["loads"],
        F_pr=PAPER["F_pr_N"],
        external_load=external_load,
        branch=PAPER["branch"],
    )


def maps(phi_deg: float, s_m: float, external_load=PAPER["external_load"]) -> dict[str, np.ndarray]:
    """The notebook's maps at (phi_deg, s_m, external load): arrays shaped like the grid ``(x_D, y_D)``."""
    p = m.Gripper4PRRParams.from_dict(_params.load_params("p1")["mechanism"])
    grid = _grid.Grid.from_ranges(x_D=PAPER["x_D"], y_D=PAPER["y_D"])
    out = _sweep.sweep(
        _criteria, grid, args=(np.deg2rad(phi_deg), float(s_m), np.asarray(external_load, float), p), batched=True
    )
    return {k: np.asarray(v) for k, v in out.items() if k != "q"}, grid


def _range(name, values):
    """The colour range of the static figure (notebook cells of Figs 2, 4, 5, 6a, 6b)."""
    finite = values[np.isfinite(values)]
    if finite.size == 0:
        return {}
    if name == "max_carriage_velocity":  # Fig 2: clipped at the 95th percentile
        return {"vmin": float(finite.min()), "vmax": float(np.percentile(finite, 95))}
    if name == "max_carriage_force":  # Fig 4: log scale over the positive values
        pos = finite[finite > 0]
        return {"vmin": float(pos.min()), "vmax": float(pos.max())} if pos.size else {}
    return {"vmin": float(finite.min()), "vmax": float(finite.max())}


FIELDS = [
    {
        "name": "max_carriage_velocity",
        "figure": "Fig 2",
        "label": "maximum carriage velocity |ẋ_A|max",
        "symbol": "|ẋ_A|max",
        "unit": "m/s",
        "scale": "linear",
        "clip": "95th percentile",
        "cmap": "viridis",
    },
    {
        "name": "max_carriage_force",
        "figure": "Fig 4",
        "label": "maximum carriage force |F_A|max (log scale)",
        "symbol": "|F_A|max",
        "unit": "N",
        "scale": "log",
        "cmap": "magma",
    },
    {
        "name": "det_A",
        "figure": "Fig 5",
        "label": "sign of det(A)",
        "symbol": "det(A)",
        "unit": "",
        "scale": "sign",
        "cmap": None,
    },
    {
        "name": "max_gripper_force_no_load",
        "figure": "Fig 6a",
        "label": "maximum gripper force |F_s|max, no load",
        "symbol": "|F_s|max",
        "unit": "N",
        "scale": "linear",
        "cmap": "cividis",
        "vmin_zero": True,
    },
]


def write(out) -> list:
    """Both P1 figures into ``out/p1_maps`` and ``out/p1_fig6b``."""
    written = []
    grid = None
    chunks = {}
    for (i, phi), (j, s) in itertools.product(enumerate(PHI_DEG), enumerate(S_M)):
        values, grid = maps(phi, s)
        chunk = {}
        for f in FIELDS:
            v = values[f["name"]].T  # rows of y_D, x_D fastest
            r = _range(f["name"], v)
            if f.get("vmin_zero") and r:
                r["vmin"] = 0.0
            chunk[f["name"]] = {"values": v, **r}
        chunks[key_of((i, j))] = chunk
    controls = [
        control("phi_deg", "φ", "deg", PHI_DEG, PAPER["phi_deg"], digits=3),
        control("s_m", "s", "m", S_M, PAPER["s_m"], digits=3),
        field_control(FIELDS),
    ]
    manifest = {
        "title": "P1 {figure}: {label}",
        "notebook": NOTEBOOK,
        "controls": controls,
        "fields": fields_manifest(FIELDS, ["#1f77b4", "#ff7f0e"]),
        "crop_y": 0.02,
        **_grid_manifest(grid),
        "resolution": "the paper's grid: x_D 0.2 to 1.2 m by 0.005 m, y_D -0.25 to 0.25 m by 0.0025 m; "
        f"phi {PHI_DEG[0]} to {PHI_DEG[-1]} deg by 5 deg, s {S_M[0]} to {S_M[-1]} m by 0.02 m",
    }
    written += write_figure(out, "p1_maps", manifest, chunks)

    chunks = {}
    for (i, fx), (j, fy), (k, t) in itertools.product(enumerate(F_X_N), enumerate(F_Y_N), enumerate(T_EXT_N_M)):
        values, grid = maps(PAPER["phi_deg"], PAPER["s_m"], (fx, fy, t))
        v = values["max_gripper_force_with_load"].T
        # Fig 6b: the colour scale of Fig 6a (0 to the largest no-load gripper force)
        chunks[key_of((i, j, k))] = {
            "max_gripper_force_with_load": {
                "values": v,
                "vmin": 0.0,
                "vmax": float(np.nanmax(values["max_gripper_force_no_load"])),
            },
            # the workspace (finite det(A)): NaN inside it is the gap, drawn red as in Fig 6b
            "inside": {"values": np.isfinite(values["det_A"].T).astype(np.float32)},
        }
    f6 = [
        {
            "name": "max_gripper_force_with_load",
            "figure": "Fig 6b",
            "label": "maximum gripper force |F_s|max under the external load",
            "symbol": "|F_s|max",
            "unit": "N",
            "scale": "linear",
            "cmap": "cividis",
            "gap": True,
        }
    ]
    controls = [
        control("F_x_N", "F_x", "N", F_X_N, 1.0, digits=3),
        control("F_y_N", "F_y", "N", F_Y_N, 1.0, digits=3),
        control("T_ext_N_m", "T", "N m", T_EXT_N_M, 0.1, digits=3),
    ]
    manifest = {
        "title": "P1 {figure}: {label}",
        "notebook": NOTEBOOK,
        "controls": controls,
        "fields": fields_manifest(f6, ["#1f77b4", "#ff7f0e"]),
        "crop_y": 0.02,
        **_grid_manifest(grid),
        "resolution": "the paper's grid at phi = 20 deg, s = 0.14 m; F_x and F_y from -2 to 2 N by 1 N, "
        "T from -0.1 to 0.1 N m by 0.1 N m",
        "fixed": "φ = 20°, s = 0.14 m, F_pr = 100 N",
    }
    written += write_figure(out, "p1_fig6b", manifest, chunks)
    return written
