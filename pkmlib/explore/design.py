"""Design studies: the P2 atlas (study b of ``notebooks/design_studies.ipynb``) with a design
picker, showing that design's map.

The notebook's atlas is the exact area under the torque bound over 41 x 37 designs
(``a = l1 / (l1 + l2)`` 0.3 to 0.7 step 0.01, ``r_p`` 0.03 to 0.12 m step 2.5 mm, ``L = 0.36`` m),
each the sum of a per-pose indicator over the atlas's poses (x_P -0.25 to 0.65 m, y_P -0.25 to
0.6 m, step 5 mm). The page picks one of 9 x 10 of those designs (every 5th ``a``, every 4th
``r_p``: 0.3, 0.35, ..., 0.7 and 0.03, 0.04, ..., 0.12 m; the paper's ``a = 0.5``, ``r_p =
0.08`` m among them) and shows, on the atlas's poses:

* the largest actuator torque for a 10 N force in any direction (``ds.p2_torque_map``, P2 eq (6),
  (8); the colour range of the notebook's before/after figure: the paper design's map, min to max,
  on the check grid);
* the atlas's own per-pose indicator (``ds.p2_atlas_indicator``: in the workspace and under the
  bound, the notebook's median of the paper design's torque map on the 2.5 mm check grid), NaN
  where a chain does not reach. Its count times the cell area is the atlas's value at the design.

The design values are the notebook's atlas axes' own floats (``Grid.axes``), so every number is
the notebook's at the same design and pose.
"""

from __future__ import annotations

from functools import partial

import jax
import jax.numpy as jnp
import numpy as np

from .. import _params
from ..design import studies as ds
from .._grid import Grid
from ..mechanisms import three_rrr as t
from ._store import control, field_control, fields_manifest, grid_axes, key_of, write_figure

NOTEBOOK = "design_studies"
#: The notebook's study conditions (its parameters cell) that the atlas depends on.
PAPER = {
    "force_N": 10.0,
    "bound_quantile": 0.5,
    "check_step_m": 0.0025,
    "L_m": 0.36,  # L_atlas: the gradient optimum's L, at its upper bound 0.36 m
    "a": (0.3, 0.7, 0.01),
    "r_p_m": (0.03, 0.12, 0.0025),
    "x_P": (-0.25, 0.65, 0.005),
    "y_P": (-0.25, 0.6, 0.005),
}
#: Every how many atlas designs the picker has one: along a, along r_p.
EVERY = (5, 4)


def atlas_designs() -> Grid:
    """The notebook's atlas design grid (a, r_p)."""
    return Grid.from_ranges(a=PAPER["a"], r_p_m=PAPER["r_p_m"])


def atlas_poses() -> Grid:
    """The notebook's atlas pose grid (x_P, y_P), step 5 mm."""
    return Grid.from_ranges(x_P=PAPER["x_P"], y_P=PAPER["y_P"])


def picker_values() -> tuple[np.ndarray, np.ndarray]:
    """The picker's a and r_p values: every 5th and every 4th of the atlas's axes (their floats)."""
    a, r = atlas_designs().axes
    return a[:: EVERY[0]], r[:: EVERY[1]]


def study() -> ds.DesignStudy:
    """Study b at the notebook's default conditions (its ``bound`` and the paper's design)."""
    P = t.ThreeRRRParams.from_dict(_params.load_params("p2")["mechanism"])
    return ds.p2_torque_area_study(
        P, force=PAPER["force_N"], bound_quantile=PAPER["bound_quantile"], check_step_m=PAPER["check_step_m"]
    )


def _criterion(a_rp, xy, L, log_bound, base, force):
    """Per pose: the atlas's indicator (``ds.p2_atlas_indicator``) where every chain reaches
    (the workspace margin of ``ds.p2_torque_margins`` >= 0), NaN elsewhere."""
    ind = ds.p2_atlas_indicator(a_rp, xy, L, log_bound, base, force=force)
    ws, _ = ds.p2_torque_margins(jnp.stack([a_rp[0], L, a_rp[1]]), xy, base, force=force, log_bound=log_bound)
    return jnp.where(ws >= 0, ind, jnp.nan)


def indicator_maps(designs: np.ndarray, bound: float, base) -> np.ndarray:
    """The atlas's per-pose indicator (1 under the bound, 0 over, NaN outside the workspace) for
    each ``(a, r_p)`` of ``designs`` (``(n, 2)``) on :func:`atlas_poses`: ``(n, n_x, n_y)``. The
    poses in the structure-of-arrays form :func:`pkmlib.design.atlas` gives its criterion; one design at a
    time (``lax.map``), every pose at once."""
    poses = atlas_poses()
    xy = jnp.asarray(poses.points().reshape(-1, poses.ndim).T)
    one = partial(_criterion, base=base, force=PAPER["force_N"])
    L, lb = jnp.float64(PAPER["L_m"]), jnp.float64(np.log(bound))
    run = jax.jit(lambda d: jax.lax.map(lambda x: one(x, xy, L, lb), d))
    return np.asarray(run(jnp.asarray(designs, dtype=jnp.float64))).reshape((len(designs),) + poses.shape)


def torque_map(a: float, r_p: float, base) -> np.ndarray:
    """``ds.p2_torque_map`` of the design ``(a, L, r_p)`` on :func:`atlas_poses` (N m, NaN outside)."""
    return np.asarray(ds.p2_torque_map([a, PAPER["L_m"], r_p], atlas_poses(), base, force=PAPER["force_N"]))


def local_command(a: float, r_p: float) -> str:
    """A shell command that computes this design's torque map with pkmlib and prints its range and
    point count (no notebook parameter selects one design of the atlas)."""
    return (
        '.venv/bin/python -c "import numpy as np, pkmlib as pk; from pkmlib.design import studies as ds; '
        "from pkmlib.mechanisms import three_rrr as t; "
        "P = t.ThreeRRRParams.from_dict(pk.load_params('p2')['mechanism']); "
        f"g = pk.Grid.from_ranges(x_P={PAPER['x_P']!r}, y_P={PAPER['y_P']!r}); "
        f"m = ds.p2_torque_map([{a!r}, {PAPER['L_m']!r}, {r_p!r}], g, P.base, force={PAPER['force_N']!r}); "
        'print(np.nanmin(m), np.nanmax(m), np.isfinite(m).sum())"'
    )


FIELDS = [
    {
        "name": "torque",
        "figure": "torque map",
        "label": "largest actuator torque for a 10 N force in any direction (log scale)",
        "symbol": "max(e)",
        "unit": "N m",
        "scale": "log",
        "cmap": "viridis",
        "digits": 4,
    },
    {
        "name": "under_bound",
        "figure": "atlas indicator",
        "label": "in the workspace and under the torque bound (what the atlas sums)",
        "symbol": "sign(bound − max(e))",
        "unit": "",
        "scale": "sign",
        "digits": 1,
        "colors": ["#c6dbef", "#fdae6b"],
        "sign_labels": ["over the bound", "under the bound"],
    },
]


def write(out) -> list:
    """The design page's figure into ``out/design_p2_atlas``."""
    s = study()
    base, bound, paper = s.info["base"], s.info["bound"], s.design_paper
    torque_paper = s.info["torque_paper"]
    a_values, r_values = picker_values()
    designs = np.array([[a, r] for a in a_values for r in r_values])
    indicator = indicator_maps(designs, bound, base)
    poses = atlas_poses()
    vrange = {"vmin": float(np.nanmin(torque_paper)), "vmax": float(np.nanmax(torque_paper))}
    chunks, local, areas = {}, {}, {}
    for n, (a, r) in enumerate(designs):
        i, j = divmod(n, len(r_values))
        key = key_of((i, j))
        ind = indicator[n]
        sign = np.where(np.isnan(ind), np.nan, 2.0 * ind - 1.0)  # +1 under the bound, -1 over
        chunks[key] = {
            "torque": {"values": torque_map(a, r, base).T, **vrange},
            "under_bound": {"values": sign.T},
        }
        local[key] = local_command(float(a), float(r))
        areas[key] = float(np.nansum(ind) * poses.cell_area * 1e4)  # cm^2: the atlas's value
    fields = fields_manifest(FIELDS)
    fields[1]["area"] = {"cell": poses.cell_area * 1e4, "unit": "cm²", "label": "area under the bound"}
    controls = [
        control("a", "a = l1 / (l1 + l2)", "", [float(v) for v in a_values], float(paper[0]), digits=4),
        control("r_p_m", "r_p", "m", [float(v) for v in r_values], float(paper[2]), digits=4),
        field_control(FIELDS),
    ]
    for c in controls[:2]:
        c["param"] = None  # no notebook parameter selects one design: `local` gives the command
    manifest = {
        "title": "Design study b, P2 3-RRR, L = 0.36 m, {figure}: {label}",
        "notebook": NOTEBOOK,
        "controls": controls,
        "fields": fields,
        "equal_aspect": True,
        "crop_y": 0.02,
        "bound_N_m": bound,
        "areas_cm2": areas,
        "local": local,
        "local_label": "No notebook parameter selects one design of the atlas; this design's map with pkmlib: ",
        **grid_axes(poses, "m", digits=3),
        "resolution": "the atlas's poses: x_P -0.25 to 0.65 m, y_P -0.25 to 0.6 m, step 5 mm (the notebook's "
        "before/after figure uses the 2.5 mm check grid; these are every other of its nodes); "
        f"{len(designs)} of the atlas's 41 x 37 designs: a {', '.join(f'{v:.4g}' for v in a_values)} and "
        f"r_p {', '.join(f'{v:.4g}' for v in r_values)} m",
        "fixed": f"L = l1 + l2 = {PAPER['L_m']:g} m, φ = 0, the paper's base and working mode, force "
        f"{PAPER['force_N']:g} N, torque bound {bound:.4f} N m (the median of the paper design's map on the "
        "check grid); the torque colours span the paper design's map, as the before/after figure",
    }
    return write_figure(out, "design_p2_atlas", manifest, chunks)
