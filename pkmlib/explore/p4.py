"""P4 (Erastova 2020, five-bar stiffness): Figs 5-6 over the proximal/distal length ratio.

The maps are ``five_bar.stiffness_map`` on the notebook's grid (x_C -250 to 350 mm, z_C 2.5 to
350 mm, step 2.5 mm, elbows out), as in ``notebooks/p4_five_bar_stiffness.ipynb``. The length
ratio lambda = l_A1B1 / l_B1C (= l_A2B2 / l_B2C) changes the four link lengths with their sum
kept at the paper's 350 mm per chain (the reach, and so the grid, stay the same). T_max is not a
control: it scales the force parallelogram of Fig 4 only, and Figs 5-6 do not depend on it (the
stiffness and the worst directions are per unit force; ``tests/test_notebook_parameters.py``
checks that twice the torque leaves the stiffness as it is).
"""

from __future__ import annotations

import copy

import numpy as np

from .. import _grid, _params
from ..mechanisms import five_bar as fb
from ._store import control, field_control, fields_manifest, grid_axes, key_of, write_figure

NOTEBOOK = "p4_five_bar_stiffness"
#: lambda = proximal / distal link length, the paper's 1 among them
RATIOS = (0.6, 0.7, 0.8, 0.9, 1.0, 1.1, 1.25, 1.4, 1.6)
PAPER = {
    "T_max_N_mm": 2000.0,
    "working_mode": (1, -1),
    "x_C": (-250.0, 350.0, 2.5),
    "z_C": (2.5, 350.0, 2.5),
    "k_colour_max_N_mm": 300.0,
}
CHAIN_MM = 350.0  # l_A1B1 + l_B1C at the paper's lengths


def lengths(ratio: float) -> dict[str, float]:
    """The four link lengths (mm) at lambda = ``ratio`` with proximal + distal = 350 mm."""
    prox = round(CHAIN_MM * ratio / (1.0 + ratio), 6)
    dist = round(CHAIN_MM - prox, 6)
    return {"l_A1B1_mm": prox, "l_A2B2_mm": prox, "l_B1C_mm": dist, "l_B2C_mm": dist}


def raw_params(ratio: float) -> dict:
    """``data/params/p4.json`` with the link lengths of ``ratio`` (the paper's file at 1)."""
    raw = copy.deepcopy(_params.load_params("p4"))
    if ratio != 1.0:
        raw["mechanism"].update(lengths(ratio))
    return raw


def rerun_command(ratio: float) -> str:
    """The shell command that re-runs the notebook at lambda = ``ratio``: the geometry is not a
    notebook parameter but a file (``params_file``), so the command first writes one into runs/."""
    if ratio == 1.0:
        return f'make rerun NB={NOTEBOOK} PARAMS="-p params_file p4"'
    update = ", ".join(f"{k}={v!r}" for k, v in lengths(ratio).items())
    return (
        "mkdir -p runs && .venv/bin/python -c \"import json; d = json.load(open('data/params/p4.json')); "
        f"d['mechanism'].update({update}); json.dump(d, open('runs/p4_lengths.json', 'w'), indent=2)\" && "
        f'make rerun NB={NOTEBOOK} PARAMS="-p params_file ../runs/p4_lengths.json"'
    )


def maps(ratio: float) -> tuple[dict[str, np.ndarray], _grid.Grid]:
    """The notebook's Fig 5-6 maps at lambda = ``ratio``: arrays shaped like the grid ``(x_C, z_C)``."""
    p = fb.FiveBarParams.from_dict(raw_params(ratio))
    grid = _grid.Grid.from_ranges(x_C=PAPER["x_C"], z_C=PAPER["z_C"])
    out = fb.stiffness_map(
        grid, p, PAPER["T_max_N_mm"], PAPER["working_mode"], keys=("det_A", "k_worst", "torque_per_force")
    )
    return {k: np.asarray(v) for k, v in out.items()}, grid


FIELDS = [
    {
        "name": "k_worst",
        "figure": "Fig 6",
        "label": "stiffness in the worst force direction",
        "symbol": "k",
        "unit": "N/mm",
        "scale": "linear",
        "cmap": "viridis",
        "digits": 4,
        "clip": "top of the notebook's colour bar",
    },
    {
        "name": "load_difference",
        "figure": "Fig 5",
        "label": "actuator loaded more per unit force, |j₁| − |j₂|",
        "symbol": "|j₁| − |j₂|",
        "unit": "N mm/N",
        "scale": "sign",
        "digits": 4,
        "colors": ["#fcbba1", "#c6dbef"],
        "sign_labels": ["actuator 2", "actuator 1"],
    },
]


def write(out) -> list:
    """The P4 figure into ``out/p4_maps``."""
    chunks = {}
    grid = None
    for i, ratio in enumerate(RATIOS):
        values, grid = maps(ratio)
        ts = values["torque_per_force"]
        chunks[key_of((i,))] = {
            # Fig 6: colour scale 0 to k_colour_max_N_mm (clipped), as the notebook
            "k_worst": {"values": values["k_worst"].T, "vmin": 0.0, "vmax": PAPER["k_colour_max_N_mm"]},
            # Fig 5 background: blue where actuator 1 is loaded more (|j1| > |j2|), red where actuator 2 is
            "load_difference": {"values": (ts[..., 0] - ts[..., 1]).T},
        }
    fields = fields_manifest(FIELDS)
    controls = [
        control("ratio", "λ = l_A1B1 / l_B1C", "", RATIOS, 1.0, param="params_file", digits=3),
        field_control(FIELDS),
    ]
    manifest = {
        "title": "P4 {figure}: {label}",
        "notebook": NOTEBOOK,
        "controls": controls,
        "fields": fields,
        "equal_aspect": True,
        **grid_axes(grid, "mm", digits=1),
        "lengths": {key_of((i,)): lengths(r) for i, r in enumerate(RATIOS)},
        "rerun": {key_of((i,)): rerun_command(r) for i, r in enumerate(RATIOS)},
        "resolution": "the notebook's grid: x_C -250 to 350 mm, z_C 2.5 to 350 mm, step 2.5 mm, elbows out; "
        f"λ = {', '.join(f'{r:g}' for r in RATIOS)} with l_A1B1 + l_B1C = 350 mm",
        "fixed": "T_max = 2000 N mm (Figs 5-6 do not depend on it: stiffness and directions are per unit "
        "force); the section and the material of data/params/p4.json",
    }
    return write_figure(out, "p4_maps", manifest, chunks)
