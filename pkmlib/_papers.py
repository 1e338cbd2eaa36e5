"""The registry of the reproduced papers: one entry per paper, read by the report, the site checks
and the tests instead of lists typed in each of them.

Each :class:`Paper` names its notebook (a page of the site), the title of that page in the site's
sidebar (``_quarto.yml``; ``tests/test_contract.py`` checks they agree), the short topic of the
home page's table, its mechanism module (which follows the contract of
:mod:`pkmlib.mechanisms`), its parameter and reference files, its citation key in
``references.bib`` and its DOI or URL.
"""

from __future__ import annotations

import dataclasses
import importlib
from pathlib import Path
from types import ModuleType

from ._params import DATA_DIR

#: The repository root (pkmlib is used from its source tree).
ROOT = DATA_DIR.parent


@dataclasses.dataclass(frozen=True, kw_only=True)
class Paper:
    """One reproduced paper. Paths are relative to the repository root.

    Attributes:
        key: ``"p1"`` .. ``"p5"``: the stem of its parameter, reference and results files.
        notebook: its notebook, ``notebooks/<key>_<name>.ipynb``.
        title: the notebook page's entry in the site's sidebar.
        topic: what the paper is about, for the home page's table (a reference file's
            ``"mechanism"`` field wins there).
        module: its mechanism module (``pkmlib.mechanisms.<name>``).
        citation_key: its key in ``references.bib``.
        doi_or_url: ``"doi:..."`` or ``"https://..."``; empty where the paper prints neither.
    """

    key: str
    notebook: str
    title: str
    topic: str
    module: str
    citation_key: str
    doi_or_url: str

    @property
    def params_file(self) -> str:
        """``data/params/<key>.json``: what :func:`pkmlib.load_params` reads for this paper."""
        return f"data/params/{self.key}.json"

    @property
    def reference_file(self) -> str:
        """``data/reference/<key>.json``: what the paper prints."""
        return f"data/reference/{self.key}.json"

    @property
    def results_file(self) -> str:
        """``data/results/<key>.json``: what its notebook computes."""
        return f"data/results/{self.key}.json"

    def mechanism_module(self) -> ModuleType:
        """The imported mechanism module."""
        return importlib.import_module(self.module)

    def path(self, name: str) -> Path:
        """An attribute path (``"notebook"``, ``"params_file"``, ...) as an absolute path."""
        return ROOT / getattr(self, name)


def _papers(*entries: Paper) -> dict[str, Paper]:
    return {p.key: p for p in entries}


#: The reproduced papers, by key, in their order on the site.
PAPERS: dict[str, Paper] = _papers(
    Paper(
        key="p1",
        notebook="notebooks/p1_gripper_4prr.ipynb",
        title="P1: redundant 4-PRR gripper",
        topic="4-PRR gripper: velocity, force",
        module="pkmlib.mechanisms.gripper_4prr",
        citation_key="ispolov2025",
        doi_or_url="https://elibrary.ru/nsuikj",
    ),
    Paper(
        key="p2",
        notebook="notebooks/p2_three_rrr_singularity_proximity.ipynb",
        title="P2: 3-RRR singularity proximity",
        topic="3-RRR: singularity proximity",
        module="pkmlib.mechanisms.three_rrr",
        citation_key="laryushkin2019",
        doi_or_url="doi:10.18698/0236-3941-2019-1-71-83",
    ),
    Paper(
        key="p3",
        notebook="notebooks/p3_two_t_one_r.ipynb",
        title="P3: 2T1R mechanisms A and B",
        topic="2T1R A and B: joint order",
        module="pkmlib.mechanisms.two_t_one_r",
        citation_key="shen2023",
        doi_or_url="doi:10.6041/j.issn.1000-1298.2023.07.041",
    ),
    Paper(
        key="p4",
        notebook="notebooks/p4_five_bar_stiffness.ipynb",
        title="P4: five-bar stiffness",
        topic="five-bar: stiffness",
        module="pkmlib.mechanisms.five_bar",
        citation_key="erastova2020",
        doi_or_url="doi:10.18698/0536-1044-2020-8-21-28",
    ),
    Paper(
        key="p5",
        notebook="notebooks/p5_decoupled_6dof_dynamics.ipynb",
        title="P5: 6-DOF decoupled dynamics",
        topic="6-DOF decoupled: dynamics",
        module="pkmlib.mechanisms.decoupled_6dof",
        citation_key="kheylo2022",
        doi_or_url="",
    ),
)


def paper_of_notebook(notebook: str | Path) -> Paper | None:
    """The paper whose notebook has this file name (``p1_gripper_4prr.ipynb`` or a path to it),
    or None for a notebook beyond the papers (the tutorial, the design studies)."""
    name = Path(notebook).name
    return next((p for p in PAPERS.values() if Path(p.notebook).name == name), None)
