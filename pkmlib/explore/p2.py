"""P2 (Laryushkin 2019, 3-RRR): Figs 2a, 3a, 4a, 4b over the choices the paper leaves open, the
platform orientation phi, the reading of l3 (circumradius or side) and the working mode.

The maps are ``three_rrr.pose_criteria`` swept over the notebook's grid (x_P -0.15 to 0.55 m,
y_P -0.15 to 0.5 m, step 2.5 mm) with ``V = 0.1`` m/s and a 10 N force, as in
``notebooks/p2_three_rrr_singularity_proximity.ipynb``.
"""

from __future__ import annotations

import itertools

import numpy as np

from .. import _grid, _params, _sweep
from ..mechanisms import three_rrr as t
from ._store import control, field_control, fields_manifest, grid_axes, key_of, write_figure

NOTEBOOK = "p2_three_rrr_singularity_proximity"
#: platform orientation, deg (the notebook accepts -180 to 180); three positions keep the page under 10 MB
PHI_DEG = (-15.0, 0.0, 15.0)
L3_IS = ("circumradius", "side")
#: working modes: the elbow sign of each chain ((-1, -1, -1) is (1, 1, 1) mirrored, so it is left out)
BRANCHES = ((1, 1, 1), (1, 1, -1), (1, -1, 1), (-1, 1, 1))
PAPER = {
    "V_m_s": 0.1,
    "force_N": 10.0,
    "phi_deg": 0.0,
    "l3_is": "circumradius",
    "branch": (1, 1, 1),
    "base_origin": "A1",
    "x_P": (-0.15, 0.55, 0.0025),
    "y_P": (-0.15, 0.5, 0.0025),
}


def params(l3_is: str) -> t.ThreeRRRParams:
    g = _params.load_params("p2")["mechanism"]
    return t.ThreeRRRParams.create(
        l1=g["l1_m"],
        l2=g["l2_m"],
        l3=g["l3_m"],
        base_side=g["base_side_m"],
        l3_is=l3_is,
        base_origin=PAPER["base_origin"],
    )


def _criteria(points, phi, p, branch):
    # the notebook's `criteria`, with phi, the geometry and the working mode as run-time arguments
    return t.pose_criteria(
        t.pose(points[0], points[1], phi), p, V=PAPER["V_m_s"], force=PAPER["force_N"], branch=branch
    )


def maps(phi_deg: float, l3_is: str, branch) -> tuple[dict[str, np.ndarray], _grid.Grid]:
    """The notebook's maps at (phi_deg, l3_is, branch): arrays shaped like the grid ``(x_P, y_P)``."""
    grid = _grid.Grid.from_ranges(x_P=PAPER["x_P"], y_P=PAPER["y_P"])
    out = _sweep.sweep(
        _criteria, grid, args=(np.deg2rad(phi_deg), params(l3_is), np.asarray(branch, float)), batched=True
    )
    return {k: np.asarray(v) for k, v in out.items() if k != "q"}, grid


FIELDS = [
    {
        "name": "max_joint_velocity",
        "figure": "Fig 2a",
        "label": "maximum joint velocity max(q̇), V = 0.1 m/s",
        "symbol": "max(q̇)",
        "unit": "rad/s",
        "scale": "log",
        "cmap": "viridis",
    },
    {
        "name": "max_actuator_torque",
        "figure": "Fig 3a",
        "label": "maximum actuator torque max(e), force 10 N (log scale)",
        "symbol": "max(e)",
        "unit": "N m",
        "scale": "log",
        "cmap": "magma",
    },
    {
        "name": "delta_q",
        "figure": "Fig 4a",
        "label": "excess Δq over a velocity along x (log scale)",
        "symbol": "Δq",
        "unit": "rad/s",
        "scale": "log",
        "cmap": "cividis",
        "floor": 1e-6,
    },
    {
        "name": "delta_e",
        "figure": "Fig 4b",
        "label": "excess Δe over a force along x (log scale)",
        "symbol": "Δe",
        "unit": "N m",
        "scale": "log",
        "cmap": "cividis",
        "floor": 1e-6,
    },
]


def _range(f, v):
    """The static figures' colour range: plot_map(log=True) spans the map's min to max (Figs 4a-b
    after drawing values below 1e-6 at 1e-6)."""
    finite = v[np.isfinite(v)]
    if "floor" in f:
        finite = np.maximum(finite, f["floor"])
    return {"vmin": float(finite.min()), "vmax": float(finite.max())} if finite.size else {}


def write(out) -> list:
    """The P2 figure into ``out/p2_maps``."""
    chunks = {}
    grid = None
    for (i, phi), (j, l3), (k, br) in itertools.product(enumerate(PHI_DEG), enumerate(L3_IS), enumerate(BRANCHES)):
        values, grid = maps(phi, l3, br)
        chunks[key_of((i, j, k))] = {
            f["name"]: {"values": values[f["name"]].T, **_range(f, values[f["name"]])} for f in FIELDS
        }
    fields = fields_manifest(FIELDS)
    controls = [
        control("phi_deg", "φ", "deg", PHI_DEG, PAPER["phi_deg"], digits=3),
        control("l3_is", "l3 is the platform's", "", L3_IS, PAPER["l3_is"], kind="select"),
        control(
            "branch", "working mode", "", [str(list(b)) for b in BRANCHES], str(list(PAPER["branch"])), kind="select"
        ),
        field_control(FIELDS),
    ]
    manifest = {
        "title": "P2 {figure}: {label}",
        "notebook": NOTEBOOK,
        "controls": controls,
        "fields": fields,
        "equal_aspect": True,
        **grid_axes(grid, "m", digits=4),
        "resolution": "the notebook's grid: x_P -0.15 to 0.55 m, y_P -0.15 to 0.5 m, step 2.5 mm; "
        f"φ {', '.join(f'{v:g}' for v in PHI_DEG)} deg; both readings of l3; the working modes "
        + ", ".join(str(list(b)) for b in BRANCHES),
        "fixed": "V = 0.1 m/s, force 10 N, base_origin A1",
    }
    return write_figure(out, "p2_maps", manifest, chunks)
