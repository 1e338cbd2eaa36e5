"""YAML written by a person (a re-run's ``-y`` text, ``-f`` file), read with limits.

:func:`load` accepts plain YAML data only and refuses, with a one-line message naming the input,
the problem and its line:

- more than :data:`MAX_BYTES` bytes, text that is not UTF-8 (a binary file) or holds NUL bytes;
- more than :data:`MAX_NODES` values once anchors and aliases are expanded (a "billion laughs"
  file of nested aliases is refused after a few thousand nodes, in milliseconds), deeper nesting
  than :data:`MAX_DEPTH`, and a value that contains itself (``&a [*a]``);
- a key given twice in one mapping (``phi_deg: 25`` then ``phi_deg: 30``), naming the key;
- anything but numbers, text, ``true``/``false``, ``null``, lists and mappings: explicit tags
  (``!!python/object``, ``!!set``, ``!!binary``, ``!!timestamp``, ``!custom``), merge keys
  (``<<``), lists or mappings used as keys;
- an empty value (``phi_deg:`` with nothing after it): reported as empty, never read as ``null``
  (write ``null`` to mean null).

Dates are not converted: ``2024-01-01`` is the text ``'2024-01-01'``, as on a command line. Unlike
plain YAML 1.1, ``2.5e-5`` and ``1e3`` are numbers (YAML 1.1 reads them as text).
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import yaml

#: Largest input accepted, in bytes (a parameters file is a few hundred).
MAX_BYTES = 100_000
#: Most values (scalars, lists, mappings) after anchors and aliases are expanded.
MAX_NODES = 10_000
#: Deepest nesting of lists and mappings (after expansion).
MAX_DEPTH = 32

_CORE = "tag:yaml.org,2002:"
#: The tags plain data resolves to; any other tag is refused.
ALLOWED_TAGS = frozenset(_CORE + t for t in ("str", "int", "float", "bool", "null", "seq", "map"))
_NULL = _CORE + "null"
_MERGE = _CORE + "merge"

_FLOAT = re.compile(
    r"""^(?:[-+]?(?:[0-9][0-9_]*)\.[0-9_]*(?:[eE][-+]?[0-9]+)?
                    |[-+]?(?:[0-9][0-9_]*)(?:[eE][-+]?[0-9]+)
                    |\.[0-9_]+(?:[eE][-+]?[0-9]+)?
                    |[-+]?\.(?:inf|Inf|INF)
                    |\.(?:nan|NaN|NAN))$""",
    re.VERBOSE,
)


class YamlError(ValueError):
    """YAML that is refused: the message names the input, the problem and where."""


class _Refused(Exception):
    def __init__(self, problem: str, node_or_mark=None):
        mark = getattr(node_or_mark, "start_mark", node_or_mark)
        where = f" (line {mark.line + 1})" if mark is not None else ""
        super().__init__(problem + where)


def _resolvers() -> dict:
    """SafeLoader's implicit resolvers without timestamps and ``=`` (the 'value' tag), with
    exponent-only floats."""
    dropped = {_CORE + "timestamp", _CORE + "value"}
    return {
        first: [(tag, regexp) for tag, regexp in entries if tag not in dropped]
        for first, entries in yaml.SafeLoader.yaml_implicit_resolvers.items()
    }


class _Loader(yaml.SafeLoader):
    """SafeLoader with a nesting limit while composing and duplicate keys refused while building."""

    def __init__(self, stream):
        super().__init__(stream)
        self._depth = 0

    def compose_node(self, parent, index):
        self._depth += 1
        try:
            if self._depth > MAX_DEPTH:
                raise _Refused(f"nested deeper than {MAX_DEPTH} levels", self.peek_event().start_mark)
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1

    def construct_mapping(self, node, deep=False):
        seen: dict[Any, int] = {}
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=True)
            line = key_node.start_mark.line + 1
            if key in seen:
                raise _Refused(f"duplicate key {key!r} (lines {seen[key]} and {line}): give each key once")
            seen[key] = line
        return super().construct_mapping(node, deep)


_Loader.yaml_implicit_resolvers = _resolvers()
_Loader.add_implicit_resolver(_CORE + "float", _FLOAT, list("-+0123456789."))


def _short_tag(tag: str) -> str:
    return "!!" + tag[len(_CORE) :] if tag.startswith(_CORE) else tag


def _children(node) -> list:
    if isinstance(node, yaml.SequenceNode):
        return list(node.value)
    if isinstance(node, yaml.MappingNode):
        return [n for pair in node.value for n in pair]
    return []


def check_nodes(root) -> None:
    """Refuse what :func:`load` does not accept, on the composed node graph (before any value is
    built): tags, merge keys, complex keys, empty values, size and depth after alias expansion,
    values that contain themselves. One pass, no recursion (aliases make the graph a DAG)."""
    size: dict[int, int] = {}
    depth: dict[int, int] = {}
    state: dict[int, int] = {}  # 1: on the current path, 2: done
    stack = [(root, False)]
    while stack:
        node, finished = stack.pop()
        key = id(node)
        if finished:
            kids = _children(node)
            size[key] = 1 + sum(size[id(k)] for k in kids)
            depth[key] = 1 + max((depth[id(k)] for k in kids), default=0)
            state[key] = 2
            if size[key] > MAX_NODES:
                raise _Refused(f"more than {MAX_NODES} values once its aliases (*name) are expanded", node)
            if depth[key] > MAX_DEPTH:
                raise _Refused(f"nested deeper than {MAX_DEPTH} levels once its aliases (*name) are expanded", node)
            continue
        if state.get(key) == 2:
            continue
        if state.get(key) == 1:
            raise _Refused("a value that contains itself (an alias inside its own anchor)", node)
        state[key] = 1
        if node.tag not in ALLOWED_TAGS:
            raise _Refused(
                f"the tag {_short_tag(node.tag)} is not accepted: only numbers, text, true/false, "
                f"null, lists and mappings",
                node,
            )
        if isinstance(node, yaml.ScalarNode) and node.tag == _NULL and node.value == "" and node.style is None:
            raise _Refused("an empty value: write the value (or null), or leave the key out", node)
        if isinstance(node, yaml.MappingNode):
            for key_node, _ in node.value:
                if key_node.tag == _MERGE:
                    raise _Refused("a merge key (<<) is not accepted: write the keys out", key_node)
                if not isinstance(key_node, yaml.ScalarNode):
                    raise _Refused("a list or mapping used as a key", key_node)
        stack.append((node, True))
        stack.extend((k, False) for k in reversed(_children(node)))


def _empty_key(root) -> str | None:
    """The key of the first empty value directly in a top-level mapping (for a clearer message)."""
    if isinstance(root, yaml.MappingNode):
        for key_node, value_node in root.value:
            if (
                isinstance(value_node, yaml.ScalarNode)
                and value_node.tag == _NULL
                and value_node.value == ""
                and value_node.style is None
            ):
                return key_node.value
    return None


def _yaml_message(e: yaml.YAMLError) -> str:
    problem = getattr(e, "problem", None)
    mark = getattr(e, "problem_mark", None)
    if problem is None:
        text = str(e).splitlines()[0] if str(e) else type(e).__name__
        return text[:200]
    where = f" (line {mark.line + 1}, column {mark.column + 1})" if mark is not None else ""
    return f"{problem}{where}"[:200]


def _decode(data: bytes, what: str) -> str:
    if len(data) > MAX_BYTES:
        raise YamlError(f"{what}: larger than {MAX_BYTES} bytes (parameters take a few hundred)")
    if b"\0" in data:
        raise YamlError(f"{what}: a binary file, not YAML text (it holds NUL bytes)")
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        raise YamlError(
            f"{what}: not UTF-8 text (byte 0x{data[e.start]:02x} at offset {e.start}): a binary file?"
        ) from None


def load(data: str | bytes, what: str) -> Any:
    """Read YAML ``data`` (text, or bytes decoded as UTF-8) under the limits above.

    Returns plain Python values (``dict``, ``list``, ``str``, ``int``, ``float``, ``bool``,
    ``None``), or ``None`` for a document with no value in it (empty, or comments only). Raises
    :class:`YamlError` starting with ``what`` (e.g. ``"-f params.yaml"``); its ``syntax``
    attribute is True when the text is not YAML at all (rather than YAML that is refused).
    """
    text = _decode(data, what) if isinstance(data, bytes) else data
    if len(text) > MAX_BYTES or len(text.encode("utf-8", "surrogatepass")) > MAX_BYTES:
        raise YamlError(f"{what}: larger than {MAX_BYTES} bytes (parameters take a few hundred)")
    loader = None
    try:
        try:
            loader = _Loader(text)
            root = loader.get_single_node()
            if root is None:
                return None
            empty = _empty_key(root)
            if empty is not None:
                raise YamlError(
                    f"{what}: {empty!r} has an empty value (line {_line_of(root, empty)}): "
                    f"write its value, or leave {empty!r} out for the paper's value"
                )
            check_nodes(root)
            return loader.construct_document(root)
        except _Refused as e:
            raise YamlError(f"{what}: {e}") from None
        except yaml.YAMLError as e:
            error = YamlError(f"{what}: not valid YAML: {_yaml_message(e)}")
            error.syntax = True
            raise error from None
        except RecursionError:
            raise YamlError(f"{what}: nested too deeply") from None
    finally:
        if loader is not None:
            loader.dispose()


def _line_of(root, key: str) -> int:
    for key_node, _value_node in root.value:
        if key_node.value == key:
            return key_node.start_mark.line + 1
    return 0


def read_file(path: str | Path, what: str) -> bytes:
    """The bytes of a YAML file given by a person: refused, naming it, when it is missing, not a
    regular file, unreadable or larger than :data:`MAX_BYTES` (read no further than that)."""
    path = Path(path)
    if not path.exists():
        raise YamlError(f"{what}: no such file")
    if path.is_dir():
        raise YamlError(f"{what}: a folder, not a file")
    if not path.is_file():
        raise YamlError(f"{what}: not a regular file")
    try:
        with open(path, "rb") as f:
            data = f.read(MAX_BYTES + 1)
    except OSError as e:
        raise YamlError(f"{what}: cannot read it ({e.strerror or e})") from None
    if len(data) > MAX_BYTES:
        raise YamlError(f"{what}: larger than {MAX_BYTES} bytes (parameters take a few hundred)")
    return data


YamlError.syntax = False

__all__ = ["ALLOWED_TAGS", "MAX_BYTES", "MAX_DEPTH", "MAX_NODES", "YamlError", "load", "read_file"]
