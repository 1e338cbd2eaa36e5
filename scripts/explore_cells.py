"""Add (or update) the one markdown cell per notebook that shows its interactive figures.

    python scripts/explore_cells.py            # every notebook in CELLS
    python scripts/explore_cells.py --check    # exit 1 if a notebook lacks its cell or it differs

The cell (id ``pk-explore``) goes right after the code cell whose source contains the anchor
(the static figure's file name), holds raw HTML (``<div class="pk-explore" data-src=...>`` and the
script), and is the only cell this script touches: the other cells, their outputs included, are
written back byte for byte (nbformat's JSON layout: indent 1, non-ASCII kept).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
CELL_ID = "pk-explore"

#: notebook -> (anchor in the source of the static figure's cell, intro line, figure ids)
CELLS = {
    "p1_gripper_4prr": (
        "p1_extra_gripper_force_cost_of_load.png",
        (
            "**Explore Figs 2 and 4–6.** The maps above at other angles $\\varphi$ and openings $s$, "
            "and Fig 6b under other external loads, precomputed by `pkmlib.explore` on the paper's grid "
            "(hover for the pose and the value; at the paper's values they are the figures above)."
        ),
        ["p1_maps", "p1_fig6b"],
    ),
    "p2_three_rrr_singularity_proximity": (
        "p2_fig4b_delta_e.png",
        (
            "**Explore Figs 2–4.** The maps above for the choices the paper leaves "
            "open: the platform orientation $\\varphi$, the reading of $l_3$ "
            "(circumradius or side) and the working mode, precomputed by "
            "`pkmlib.explore` on the notebook's grid (at the paper's reading they "
            "are Figs 2a, 3a, 4a and 4b)."
        ),
        ["p2_maps"],
    ),
    "p3_two_t_one_r": (
        "p3_fig11_B_sections.png",
        (
            "**Explore Figs 9 and 11.** The workspace sections above at other positions of the section "
            "plane, for each branch: the notebook's platform-centre clouds, the points of the slab "
            "(±2.5 mm) counted in 5 mm cells, precomputed by `pkmlib.explore` (at the paper's levels the "
            "totals are the points of the static figures' legends)."
        ),
        [f"p3_{n}_{a}_section" for n in "AB" for a in "xyz"],
    ),
    "p4_five_bar_stiffness": (
        "p4_fig6_stiffness_map.png",
        (
            "**Explore Figs 5–6.** The stiffness map and the zones of Fig 5 for other ratios "
            "$\\lambda$ of the proximal to the distal link length (the chain's length kept at "
            "350 mm), precomputed by `pkmlib.explore` on the notebook's grid. $T_{max}$ is not a "
            "control: it scales Fig 4's forces only."
        ),
        ["p4_maps"],
    ),
    "p5_decoupled_6dof_dynamics": (
        "tbl-p5-accelerations",
        (
            "**Explore the accelerations.** The six accelerations of the table above for "
            "other motor forces at the example's pose and angular velocity. They are affine "
            "in the forces, so the page computes them exactly from the matrix exported by "
            "`pkmlib.explore` (at the paper's forces they are the table's values)."
        ),
        ["p5_accelerations"],
    ),
    "design_studies": (
        "design_p2_atlas.png",
        (
            "**Explore the atlas.** Pick a design of the atlas above (every 5th $a$, every 4th $r_p$: "
            "90 of its 41 × 37 designs, $L$ = 0.36 m) and see its map on the atlas's 5 mm poses: the "
            "largest actuator torque, and the indicator the atlas sums (in the workspace and under the "
            "torque bound), whose area is the atlas's value at that design; precomputed by "
            "`pkmlib.explore` (at the paper's design, the red dot, they are the static figures' values)."
        ),
        ["design_p2_atlas"],
    ),
}


def cell_source(intro: str, ids: list[str]) -> str:
    divs = "\n".join(f'<div class="pk-explore" data-src="../site/explore/data/{i}"></div>' for i in ids)
    return (
        f'{intro}\n\n```{{=html}}\n<link rel="stylesheet" href="../site/explore/pk-explore.css">\n{divs}\n'
        '<script src="../site/explore/pk-explore.js"></script>\n```'
    )


def updated(nb: dict, anchor: str, source: str) -> dict:
    cells = [c for c in nb["cells"] if c.get("id") != CELL_ID]
    at = [i for i, c in enumerate(cells) if c["cell_type"] == "code" and anchor in "".join(c["source"])]
    if len(at) != 1:
        raise ValueError(f"anchor {anchor!r}: found in {len(at)} code cells, expected exactly one")
    lines = source.splitlines(keepends=True)
    cells.insert(at[0] + 1, {"cell_type": "markdown", "id": CELL_ID, "metadata": {}, "source": lines})
    return nb | {"cells": cells}


def main(argv: list[str]) -> int:
    check = "--check" in argv
    bad = 0
    for name, (anchor, intro, ids) in CELLS.items():
        path = ROOT / "notebooks" / f"{name}.ipynb"
        text = path.read_text(encoding="utf-8")
        nb = json.loads(text)
        new = json.dumps(updated(nb, anchor, cell_source(intro, ids)), indent=1, ensure_ascii=False) + "\n"
        if new != text:
            if check:
                print(f"{path}: the interactive-figure cell is missing or differs")
                bad += 1
            else:
                path.write_text(new, encoding="utf-8")
                print(f"{path}: interactive-figure cell written")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
