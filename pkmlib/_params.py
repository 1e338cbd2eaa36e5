"""Loading of the papers' parameter files in ``data/params/`` (one JSON file per paper)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

#: The repository's data folder (pkmlib is used from its source tree; see README).
DATA_DIR = Path(__file__).resolve().parents[1] / "data"


def load_params(name_or_path: str | Path) -> dict[str, Any]:
    """Read ``data/params/<name>.json`` (or a given path). Keys carry their units (``l_C2D_m``)."""
    p = Path(name_or_path)
    if p.suffix != ".json":
        p = DATA_DIR / "params" / f"{name_or_path}.json"
    with open(p) as f:
        return json.load(f)
