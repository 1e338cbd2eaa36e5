"""Rewrite the names that left ``pkmlib.*`` (issue 22; ``pkmlib/_moved.py``) to their new homes:
``pk.condense`` -> ``pk.stiffness.condense``, ``pkmlib.summary`` -> ``pkmlib.tools.summary``, ...,
and the old module paths: ``from pkmlib import design_studies`` -> ``from pkmlib.design import
studies``, ``pkmlib.rerun`` -> ``pkmlib.tools.rerun``, ...

    python scripts/rename_moved_names.py [--markdown] FILE...

A ``.ipynb`` has only the sources of its code cells rewritten (with ``--markdown``, its Markdown
cells' too); outputs and metadata stay byte for byte: re-execute it afterwards. Any other file is
rewritten as text. Prints
each file changed and how many names; a file that needs nothing is left untouched."""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from pkmlib._moved import MOVED, MOVED_MODULES  # noqa: E402

# `pk.NAME` or `pkmlib.NAME` as a whole word, not already qualified (`pk.tools.NAME`, `x.pk.NAME`)
PATTERN = re.compile(r"(?<![\w.])(pk|pkmlib)\.(" + "|".join(sorted(MOVED, key=len, reverse=True)) + r")\b(?!\.py)")


# `from pkmlib import rerun` / `pkmlib.rerun` (the old module paths, pkmlib/_moved.py MOVED_MODULES)
MODULE_IMPORT = re.compile(r"\bfrom pkmlib import (" + "|".join(o.split(".")[1] for o in MOVED_MODULES) + r")\b")
MODULE_PATH = re.compile(r"(?<![\w.])pkmlib\.(" + "|".join(o.split(".")[1] for o in MOVED_MODULES) + r")\b")


def _new_module(old: str) -> str:
    return MOVED_MODULES[f"pkmlib.{old}"]


def rewrite(text: str) -> tuple[str, int]:
    text, n = PATTERN.subn(lambda m: f"{m[1]}.{MOVED[m[2]].removeprefix('pkmlib.')}.{m[2]}", text)
    text, k = MODULE_IMPORT.subn(lambda m: "from {} import {}".format(*_new_module(m[1]).rsplit(".", 1)), text)
    text, j = MODULE_PATH.subn(lambda m: _new_module(m[1]), text)
    return text, n + k + j


def rewrite_notebook(raw: str, kinds: tuple[str, ...] = ("code",)) -> tuple[str, int]:
    nb = json.loads(raw)
    total = 0
    for cell in nb["cells"]:
        if cell["cell_type"] not in kinds:
            continue
        source = cell["source"]
        joined = "".join(source) if isinstance(source, list) else source
        new, n = rewrite(joined)
        if n:
            total += n
            cell["source"] = new.splitlines(keepends=True) if isinstance(source, list) else new
    if not total:
        return raw, 0
    return json.dumps(nb, indent=1, ensure_ascii=False) + "\n", total


def main(paths: list[str]) -> int:
    kinds = ("code", "markdown") if "--markdown" in paths else ("code",)
    for name in [p for p in paths if p != "--markdown"]:
        path = Path(name)
        raw = path.read_text()
        new, n = rewrite_notebook(raw, kinds) if path.suffix == ".ipynb" else rewrite(raw)
        if n:
            path.write_text(new)
            print(f"{path}: {n} names rewritten")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
