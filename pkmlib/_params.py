"""Loading of the papers' parameter files in ``data/params/`` (one JSON file per paper)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

#: The repository's data folder (pkmlib is used from its source tree; see README).
DATA_DIR = Path(__file__).resolve().parents[1] / "data"


def load_params(name_or_path: str | Path) -> dict[str, Any]:
    """Read ``data/params/<name>.json`` (or a given path). Keys carry their units (``l_C2D_m``).

    ``name_or_path`` is a name such as ``"p1"`` or a path ending in ``.json``. Raises
    ``ValueError`` naming ``name_or_path`` when it is neither, ``FileNotFoundError`` with the path
    (and the available names) when there is no such file, and ``ValueError`` with the file's path
    when it is not valid JSON or its top level is not an object. The values themselves are checked
    by each mechanism's ``from_dict``.
    """
    if isinstance(name_or_path, bool) or not isinstance(name_or_path, (str, Path)) or not str(name_or_path):
        raise ValueError(
            f"name_or_path must be a parameter file name such as 'p1' or a path to a .json file, got {name_or_path!r}"
        )
    p = Path(name_or_path)
    if p.suffix != ".json":
        p = DATA_DIR / "params" / f"{name_or_path}.json"
    if not p.is_file():
        available = sorted(f.stem for f in (DATA_DIR / "params").glob("*.json"))
        raise FileNotFoundError(
            f"parameter file {p} not found (name_or_path={str(name_or_path)!r}; "
            f"available names: {', '.join(available)})"
        )
    try:
        with open(p, encoding="utf-8") as f:
            data = json.load(f)
    except json.JSONDecodeError as e:
        raise ValueError(f"parameter file {p}: invalid JSON at line {e.lineno}, column {e.colno}: {e.msg}") from None
    except UnicodeDecodeError as e:
        raise ValueError(f"parameter file {p}: not UTF-8 text ({e.reason})") from None
    if not isinstance(data, dict):
        raise ValueError(f"parameter file {p}: the top level must be a JSON object, got {type(data).__name__}")
    return data
