"""The interactive figures' data files: a manifest and one lazily loaded file per control position.

Every file is a small JavaScript file, ``pkExplore.manifest(id, {...})`` or
``pkExplore.data(id, key, {...})``, loaded by a ``<script>`` element: that works over HTTP and from
``file://`` (where Chromium blocks ``fetch()`` of local files). Arrays are float32, little
endian, byte-shuffled, gzip-compressed (``mtime=0``, so the same values give the same bytes) and base64-encoded;
the page decompresses them with the browser's own ``DecompressionStream``. NaN (outside the
workspace) stays NaN.
"""

from __future__ import annotations

import base64
import gzip
import json
from pathlib import Path

import numpy as np

from .._atomic import atomic_write_text


def encode(values) -> str:
    """float32, little endian, row-major, byte-shuffled (the n first bytes of every value, then
    the n second bytes, ...: smooth maps compress about a fifth better), gzip (level 9, mtime 0),
    base64."""
    a = np.ascontiguousarray(np.asarray(values, dtype="<f4")).reshape(-1)
    shuffled = a.view(np.uint8).reshape(-1, 4).T.tobytes()
    return base64.b64encode(gzip.compress(shuffled, compresslevel=9, mtime=0)).decode("ascii")


def decode(text: str, shape=None) -> np.ndarray:
    """The inverse of :func:`encode` (float32 values; for the tests)."""
    b = np.frombuffer(gzip.decompress(base64.b64decode(text)), dtype=np.uint8)
    a = b.reshape(4, -1).T.copy().view("<f4").reshape(-1)
    return a if shape is None else a.reshape(shape)


def colormap(name: str, n: int = 256) -> list[str]:
    """The Matplotlib colour map ``name`` as ``n`` hex colours (the static figures' colours)."""
    import matplotlib

    cmap = matplotlib.colormaps[name].resampled(n)
    return [matplotlib.colors.to_hex(cmap(i)) for i in range(n)]


def _js(call: str, *args) -> str:
    body = ", ".join(json.dumps(a, separators=(",", ":"), allow_nan=False) for a in args)
    return f"pkExplore.{call}({body});\n"


def _finite(x):
    """JSON has no NaN: None for a non-finite float."""
    x = float(x)
    return x if np.isfinite(x) else None


def write_figure(out: Path, fig_id: str, manifest: dict, chunks: dict[str, dict]) -> list[Path]:
    """Write ``<out>/<fig_id>/manifest.js`` and one ``<key>.js`` per control position.

    ``chunks[key]`` maps each field name to a dict with ``values`` (array shaped like the
    manifest's grid, or any shape the figure's kind expects) and optional ``vmin``/``vmax``.
    """
    folder = Path(out) / fig_id
    folder.mkdir(parents=True, exist_ok=True)
    written = []
    for key, fields in chunks.items():
        payload = {}
        for name, f in fields.items():
            entry = {"data": encode(f["values"]), "shape": list(np.shape(f["values"]))}
            for k in ("vmin", "vmax"):
                if k in f:
                    entry[k] = _finite(f[k])
            entry.update({k: v for k, v in f.items() if k not in ("values", "vmin", "vmax")})
            payload[name] = entry
        path = folder / f"{key}.js"
        atomic_write_text(path, _js("data", fig_id, key, payload))
        written.append(path)
    manifest = {"id": fig_id, "keys": sorted(chunks)} | manifest
    path = folder / "manifest.js"
    atomic_write_text(path, _js("manifest", fig_id, manifest))
    written.append(path)
    return written


def control(
    name: str, label: str, unit: str, values, paper, *, param: str | None = None, digits: int = 4, kind: str = "slider"
) -> dict:
    """One control: ``values`` it takes (the precomputed positions), the paper's value, and the
    notebook parameter it sets (``param``, for the re-run command; ``None`` if it sets none)."""
    values = [float(v) if not isinstance(v, str) else v for v in values]
    if paper not in values:
        raise ValueError(f"control {name}: the paper's value {paper!r} is not among the values {values!r}")
    return {
        "name": name,
        "label": label,
        "unit": unit,
        "values": values,
        "paper": paper,
        "param": param if param is not None else name,
        "digits": digits,
        "kind": kind,
    }


def field_control(fields, label: str = "map") -> dict:
    """The control that picks the field shown: one value per field, its ``figure``; it sets no
    notebook parameter."""
    return {
        "name": "field",
        "label": label,
        "kind": "select",
        "values": [f["figure"] for f in fields],
        "paper": None,
        "param": None,
        "field": True,
    }


def fields_manifest(fields, default_colors=None) -> list[dict]:
    """The manifest's copy of ``fields``: a field's ``cmap`` (a matplotlib name) becomes its
    ``colors`` (:func:`colormap`); a field without one keeps its own ``colors`` or, given
    ``default_colors``, takes those."""
    out = []
    for f in fields:
        f = dict(f)
        if f.get("cmap"):
            f["colors"] = colormap(f.pop("cmap"))
        elif default_colors is not None:
            f["colors"] = list(default_colors)
        out.append(f)
    return out


def map_axis(name: str, unit: str, start, step, n, *, digits: int) -> dict:
    """One map axis of a manifest: the coordinate ``name`` (also its label) in ``unit``, its first
    node ``start``, ``step`` and node count ``n``, and the ``digits`` the readout shows."""
    return {"name": name, "label": name, "unit": unit, "start": start, "step": step, "n": n, "digits": digits}


def grid_axes(grid, unit: str, digits) -> dict:
    """The ``"x"`` and ``"y"`` axes of a manifest from a 2-D :class:`pkmlib.Grid` (its axis names,
    both in ``unit``); ``digits`` is one number for both axes or a pair."""
    dx, dy = digits if isinstance(digits, tuple) else (digits, digits)
    return {
        key: map_axis(grid.names[i], unit, grid.starts[i], grid.steps[i], grid.counts[i], digits=d)
        for i, (key, d) in enumerate((("x", dx), ("y", dy)))
    }


def key_of(indices) -> str:
    """The file key of one control position: its indices joined by ``_``."""
    return "_".join(str(int(i)) for i in indices)


def read_js(path) -> list:
    """The arguments of the one ``pkExplore.<call>(...)`` in a data file (for the tests)."""
    text = Path(path).read_text(encoding="utf-8")
    start, end = text.index("(") + 1, text.rindex(")")
    return json.loads("[" + text[start:end] + "]")


def read_chunk(folder, key) -> dict[str, np.ndarray]:
    """Decoded arrays of one control position's file (for the tests)."""
    _, _, payload = read_js(Path(folder) / f"{key}.js")
    return {k: decode(v["data"], v["shape"]) for k, v in payload.items()} | {
        "_ranges": {k: {r: v.get(r) for r in ("vmin", "vmax")} for k, v in payload.items()}
    }
