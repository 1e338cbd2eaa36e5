"""Parsing and validation of a mechanism description (``data/mechanisms/<name>.yaml``).

The format is specified in ``data/mechanisms/README.md``. :func:`parse_description` turns the
YAML text or its dict into a :class:`Description`: every key is checked, parameter values are
read from ``data/params/<paper>.json`` (never retyped), every expression is compiled
(:mod:`._expressions`), and every error is a ``ValueError`` that names the body, joint or key
at fault and what is accepted.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from .. import _safe_yaml

from .._params import load_params
from ._expressions import Expression, compile_expression

#: Joint types and their degrees of freedom (Gruebler-Kutzbach's f_i).
JOINT_FREEDOM = {"revolute": 1, "prismatic": 1, "universal": 2, "spherical": 3, "fixed": 0}
#: Joint types allowed in each space.
SPACE_JOINTS = {
    "planar": ("revolute", "prismatic", "fixed"),
    "spatial": ("revolute", "prismatic", "universal", "spherical", "fixed"),
}
#: Point joints (only their centre enters a closure).
POINT_JOINTS = ("revolute", "universal", "spherical")
LENGTH_UNITS = ("m", "mm")
ANGLE_UNITS = ("rad",)
BASE = "base"

_TOP_KEYS = {
    "name",
    "paper",
    "space",
    "units",
    "parameters",
    "derived",
    "bodies",
    "joints",
    "output",
    "loops",
    "overconstraints",
    "nodes",
    "default_branch",
    "branch_rule",
    "notes",
}
_REQUIRED_TOP = ("name", "space", "units", "parameters", "bodies", "joints", "output", "loops")
_JOINT_KEYS = {
    "name",
    "type",
    "parent",
    "child",
    "at",
    "rpy",
    "axis",
    "axes",
    "child_at",
    "actuated",
    "variable",
    "offset",
    "limits",
    "notes",
}
_NODE_KEYS = {"name", "joints", "locate", "toward", "notes"}
#: The constraints a link at a node imposes on the node's centre (README, "Nodes").
NODE_CONSTRAINTS = ("distance", "plane")
_OUTPUT_KEYS = {"body", "coordinates", "units", "position", "rotation", "point", "joints", "notes"}
_AXIS_NAMES = {"x": (1.0, 0.0, 0.0), "y": (0.0, 1.0, 0.0), "z": (0.0, 0.0, 1.0)}


@dataclasses.dataclass(frozen=True)
class Joint:
    """One joint of a description (see ``data/mechanisms/README.md``, "Joints")."""

    name: str
    type: str
    parent: str
    child: str
    at: tuple[Expression, ...]
    rpy: tuple[Expression, ...]
    axis: tuple[Expression, ...] | None
    child_at: tuple[Expression, ...] | None
    actuated: bool
    variable: str | None
    offset: Expression | None
    limits: tuple[Expression, Expression] | None

    @property
    def freedom(self) -> int:
        return JOINT_FREEDOM[self.type]


@dataclasses.dataclass(frozen=True)
class Output:
    """The output body and the coordinates ``x`` (README, "Output")."""

    body: str
    coordinates: tuple[str, ...]
    units: tuple[str, ...]
    position: tuple[Expression, ...]
    rotation: tuple[tuple[tuple[float, float, float], Expression], ...] | Expression | None
    point: bool
    joints: tuple[str, ...]


@dataclasses.dataclass(frozen=True)
class Node:
    """A point where several links meet (README, "Nodes"): the joints whose centres coincide there,
    the three constraints that locate it (``(link, "plane" | "distance")``) and the direction that
    picks one of the two points they leave."""

    name: str
    joints: tuple[str, ...]
    locate: tuple[tuple[str, str], ...]
    toward: tuple[Expression, ...]


@dataclasses.dataclass(frozen=True)
class Description:
    """A parsed, validated mechanism description."""

    name: str
    paper: str | None
    space: str
    length_unit: str
    angle_unit: str
    parameters: dict[str, float]
    parameter_keys: dict[str, str]
    derived: tuple[tuple[str, Expression], ...]
    bodies: tuple[str, ...]
    joints: tuple[Joint, ...]
    output: Output
    loops: tuple[tuple[str, ...], ...]
    overconstraints: int
    overconstraints_why: str
    nodes: tuple[Node, ...]
    default_branch: tuple[int, ...] | None
    branch_rule: str
    source: str

    @property
    def dim(self) -> int:
        """Coordinates of a point: 2 (planar) or 3 (spatial)."""
        return 2 if self.space == "planar" else 3

    @property
    def lam(self) -> int:
        """Gruebler-Kutzbach's lambda: 3 (planar) or 6 (spatial)."""
        return 3 if self.space == "planar" else 6

    def joint(self, name: str) -> Joint:
        return next(j for j in self.joints if j.name == name)

    def parameter_env(self, params: Mapping[str, Any]) -> dict[str, Any]:
        """Parameters plus derived values, ``{symbol: value}`` (derived in declaration order)."""
        env = dict(params)
        for name, expr in self.derived:
            env[name] = expr(env)
        return env


def read_description(path_or_dict: Any) -> tuple[dict, str]:
    """The description as a dict and a label for messages (the file path or ``"<dict>"``)."""
    if isinstance(path_or_dict, Mapping):
        return dict(path_or_dict), "<dict>"
    if isinstance(path_or_dict, (str, Path)) and not isinstance(path_or_dict, bool):
        p = Path(path_or_dict)
        if not p.is_file():
            raise ValueError(
                f"path_or_dict: no description file {str(p)!r} (give a path to a .yaml file of "
                f"data/mechanisms/ or a dict)"
            )
        # one YAML reader for the project: limits, duplicate keys, no tags (pkmlib._safe_yaml)
        data = _safe_yaml.load(_safe_yaml.read_file(p, str(p)), str(p))
        if not isinstance(data, dict):
            raise ValueError(f"{p}: the top level must be a mapping of the keys {sorted(_TOP_KEYS)}")
        return data, str(p)
    raise ValueError(
        f"path_or_dict must be a path to a description (.yaml) or a dict, got {type(path_or_dict).__name__}"
    )


def _check_keys(where: str, d: Any, allowed: set[str], required: tuple[str, ...] = ()) -> dict:
    if not isinstance(d, Mapping):
        raise ValueError(f"{where}: expected a mapping with the keys {sorted(allowed)}, got {d!r}")
    unknown = sorted(set(d) - allowed)
    if unknown:
        raise ValueError(f"{where}: unknown key(s) {unknown}; accepted: {sorted(allowed)}")
    missing = [k for k in required if k not in d]
    if missing:
        raise ValueError(f"{where}: missing key(s) {missing} (required: {list(required)})")
    return dict(d)


def _name(where: str, v: Any) -> str:
    if not isinstance(v, str) or not v.isidentifier():
        raise ValueError(f"{where}: expected a name (letters, digits and _, not starting with a digit), got {v!r}")
    return v


def _vector(where: str, v: Any, n: int, symbols) -> tuple[Expression, ...]:
    if not isinstance(v, (list, tuple)):
        raise ValueError(f"{where}: expected a list of {n} values (numbers or expressions), got {v!r}")
    if len(v) != n:
        raise ValueError(f"{where}: expected {n} values, got {len(v)} ({v!r})")
    return tuple(compile_expression(e, f"{where}[{k}]", symbols) for k, e in enumerate(v))


def _resolve_key(data: Mapping, dotted: str):
    node: Any = data
    for part in dotted.split("."):
        if not isinstance(node, Mapping) or part not in node:
            return None
        node = node[part]
    return node


def parse_description(path_or_dict: Any) -> Description:
    """Parse and check a description (a path to a YAML file or its dict); see the module docstring."""
    d, source = read_description(path_or_dict)
    pre = f"{source}: " if source != "<dict>" else ""
    try:
        return _parse(d, source)
    except ValueError as e:
        raise ValueError(f"{pre}{e}") from None


def _parse(d: dict, source: str) -> Description:
    d = _check_keys("description", d, _TOP_KEYS, _REQUIRED_TOP)
    name = d["name"]
    if not isinstance(name, str) or not name:
        raise ValueError(f"name: expected a non-empty string, got {name!r}")
    space = d["space"]
    if space not in SPACE_JOINTS:
        raise ValueError(f"space: expected 'planar' or 'spatial', got {space!r}")
    dim = 2 if space == "planar" else 3

    units = _check_keys("units", d["units"], {"length", "angle"}, ("length", "angle"))
    if units["length"] not in LENGTH_UNITS:
        raise ValueError(f"units.length: expected one of {list(LENGTH_UNITS)}, got {units['length']!r}")
    if units["angle"] not in ANGLE_UNITS:
        raise ValueError(f"units.angle: expected one of {list(ANGLE_UNITS)}, got {units['angle']!r}")

    # ---------------------------------------------------------------- parameters
    paper = d.get("paper")
    raw = d["parameters"]
    if not isinstance(raw, Mapping):
        raise ValueError(
            f"parameters: expected a mapping symbol: dotted.key (or symbol: number without a paper), got {raw!r}"
        )
    file = None
    if paper is not None:
        if not isinstance(paper, str):
            raise ValueError(f"paper: expected a paper key such as 'p1', got {paper!r}")
        try:
            file = load_params(paper)
        except FileNotFoundError as e:
            raise ValueError(f"paper: {e}") from None
    params: dict[str, float] = {}
    keys: dict[str, str] = {}
    for sym, spec in raw.items():
        _name(f"parameters.{sym}", sym)
        if sym == "pi":
            raise ValueError("parameters.pi: 'pi' is a constant and cannot be a parameter symbol")
        if file is not None:
            if not isinstance(spec, str):
                raise ValueError(
                    f"parameters.{sym}: with paper {paper!r} every value must be a dotted key into "
                    f"data/params/{paper}.json (such as 'mechanism.l1_m'), got {spec!r}; values are "
                    f"never retyped"
                )
            value = _resolve_key(file, spec)
            if value is None:
                raise ValueError(f"parameters.{sym}: the key {spec!r} is absent from data/params/{paper}.json")
            keys[sym] = spec
        else:
            value = spec
            if isinstance(spec, str):
                raise ValueError(
                    f"parameters.{sym}: {spec!r} is a key into a params file, but the description "
                    f"names no paper; give 'paper: pN' or a number"
                )
        if isinstance(value, bool) or not isinstance(value, numbers.Real) or not math.isfinite(float(value)):
            raise ValueError(f"parameters.{sym}: expected a finite number, got {value!r}")
        params[sym] = float(value)

    derived_raw = d.get("derived") or {}
    if not isinstance(derived_raw, Mapping):
        raise ValueError(f"derived: expected a mapping symbol: expression, got {derived_raw!r}")
    derived = []
    symbols = set(params)
    for sym, expr in derived_raw.items():
        _name(f"derived.{sym}", sym)
        if sym in symbols:
            raise ValueError(f"derived.{sym}: duplicate name: {sym!r} is already a parameter")
        derived.append((sym, compile_expression(expr, f"derived.{sym}", symbols)))
        symbols.add(sym)
    param_symbols = frozenset(symbols)

    # ---------------------------------------------------------------- bodies and joints
    bodies_raw = d["bodies"]
    if not isinstance(bodies_raw, list) or not bodies_raw:
        raise ValueError(f"bodies: expected a list of body names, got {bodies_raw!r}")
    bodies = [BASE]
    for k, b in enumerate(bodies_raw):
        _name(f"bodies[{k}]", b)
        if b == BASE:
            continue
        if b in bodies:
            raise ValueError(f"bodies[{k}]: duplicate body name {b!r}")
        if b in param_symbols:
            raise ValueError(f"bodies[{k}]: {b!r} is already a parameter symbol; names must be unique")
        bodies.append(b)

    joints_raw = d["joints"]
    if not isinstance(joints_raw, list) or not joints_raw:
        raise ValueError(f"joints: expected a list of joints, got {joints_raw!r}")
    joints: list[Joint] = []
    joint_names: set[str] = set()
    variables: dict[str, str] = {}
    for k, jd in enumerate(joints_raw):
        label = f"joints[{k}]"
        if isinstance(jd, Mapping) and isinstance(jd.get("name"), str):
            label = f"joint {jd['name']!r}"
        jd = _check_keys(label, jd, _JOINT_KEYS, ("name", "type", "parent", "child", "at"))
        jname = _name(f"{label}.name", jd["name"])
        if jname in joint_names:
            raise ValueError(f"{label}: duplicate joint name {jname!r}")
        if jname in bodies:
            raise ValueError(f"{label}: {jname!r} is already a body name; joints and bodies need unique names")
        joint_names.add(jname)
        jtype = jd["type"]
        if jtype not in JOINT_FREEDOM:
            raise ValueError(f"{label}.type: unknown joint type {jtype!r}; accepted: {', '.join(JOINT_FREEDOM)}")
        if jtype not in SPACE_JOINTS[space]:
            raise ValueError(
                f"{label}.type: {jtype!r} is not a {space} joint; accepted in a {space} mechanism: "
                f"{', '.join(SPACE_JOINTS[space])}"
            )
        for role in ("parent", "child"):
            if jd[role] not in bodies:
                raise ValueError(f"{label}.{role}: unknown body {jd[role]!r}; the bodies are {', '.join(bodies)}")
        if jd["parent"] == jd["child"]:
            raise ValueError(f"{label}: parent and child are the same body {jd['parent']!r}")
        if jd["child"] == BASE:
            raise ValueError(f"{label}.child: the base cannot be a joint's child (write the joint the other way)")
        at = _vector(f"{label}.at", jd["at"], dim, param_symbols)
        n_rpy = 1 if space == "planar" else 3
        rpy_raw = jd.get("rpy", [0.0] * n_rpy)
        if space == "planar" and not isinstance(rpy_raw, (list, tuple)):
            rpy_raw = [rpy_raw]
        rpy = _vector(f"{label}.rpy", rpy_raw, n_rpy, param_symbols)
        axis = None
        if jtype in ("revolute", "prismatic"):
            if space == "planar" and jtype == "revolute":
                if "axis" in jd and list(jd["axis"]) not in ([0, 0, 1], [0.0, 0.0, 1.0]):
                    raise ValueError(f"{label}.axis: a planar revolute turns about z; give [0, 0, 1] or omit it")
            else:
                if "axis" not in jd:
                    raise ValueError(
                        f"{label}: missing key 'axis' (a {jtype} needs its axis in the joint frame, {dim} values)"
                    )
                axis = _vector(f"{label}.axis", jd["axis"], dim, param_symbols)
        elif "axis" in jd:
            raise ValueError(f"{label}.axis: a {jtype} joint has no axis (accepted for revolute and prismatic)")
        if "axes" in jd and jtype != "universal":
            raise ValueError(f"{label}.axes: only a universal joint takes 'axes'")
        if "axes" in jd:
            axes = jd["axes"]
            if not isinstance(axes, list) or len(axes) != 2:
                raise ValueError(f"{label}.axes: expected two axes (each 3 values), got {axes!r}")
            for a_k, a in enumerate(axes):
                _vector(f"{label}.axes[{a_k}]", a, 3, param_symbols)
        child_at = _vector(f"{label}.child_at", jd["child_at"], dim, param_symbols) if "child_at" in jd else None
        actuated = jd.get("actuated", False)
        if not isinstance(actuated, bool):
            raise ValueError(f"{label}.actuated: expected true or false, got {actuated!r}")
        if actuated and jtype not in ("revolute", "prismatic"):
            raise ValueError(f"{label}.actuated: only a revolute or prismatic joint can be actuated, not a {jtype}")
        variable = jd.get("variable")
        if variable is not None:
            _name(f"{label}.variable", variable)
            if jtype not in ("revolute", "prismatic"):
                raise ValueError(f"{label}.variable: a {jtype} joint has no single variable")
            if variable in variables:
                raise ValueError(
                    f"{label}.variable: duplicate name {variable!r} (also the variable of joint "
                    f"{variables[variable]!r})"
                )
            if variable in param_symbols or variable in bodies or variable in joint_names:
                raise ValueError(f"{label}.variable: {variable!r} is already a parameter, body or joint name")
            variables[variable] = jname
        if actuated and variable is None:
            raise ValueError(f"{label}: an actuated joint needs a 'variable' (the name of its q)")
        offset = compile_expression(jd["offset"], f"{label}.offset", param_symbols) if "offset" in jd else None
        limits = None
        if "limits" in jd:
            if not actuated:
                raise ValueError(f"{label}.limits: only an actuated joint has limits")
            lim = _vector(f"{label}.limits", jd["limits"], 2, param_symbols)
            limits = (lim[0], lim[1])
        joints.append(
            Joint(jname, jtype, jd["parent"], jd["child"], at, rpy, axis, child_at, actuated, variable, offset, limits)
        )

    # ---------------------------------------------------------------- output
    od = _check_keys("output", d["output"], _OUTPUT_KEYS, ("body", "coordinates", "units", "position"))
    if od["body"] not in bodies or od["body"] == BASE:
        raise ValueError(f"output.body: expected one of the moving bodies {', '.join(bodies[1:])}, got {od['body']!r}")
    coords = od["coordinates"]
    if not isinstance(coords, list) or not coords:
        raise ValueError(f"output.coordinates: expected a list of names, got {coords!r}")
    seen: set[str] = set()
    for k, c in enumerate(coords):
        _name(f"output.coordinates[{k}]", c)
        if c in seen:
            raise ValueError(f"output.coordinates[{k}]: duplicate coordinate {c!r}")
        if c in param_symbols or c in bodies or c in joint_names:
            raise ValueError(f"output.coordinates[{k}]: {c!r} is already a parameter, body or joint name")
        seen.add(c)
    out_joints = tuple(od.get("joints") or ())
    for c in coords:
        if c in variables and c not in out_joints:
            raise ValueError(
                f"output.coordinates: {c!r} is also the variable of joint {variables[c]!r}; list it in "
                f"output.joints if that joint is an output joint, else rename one of them"
            )
    ounits = od["units"]
    if not isinstance(ounits, list) or len(ounits) != len(coords):
        raise ValueError(f"output.units: expected one unit per coordinate ({len(coords)}: {coords}), got {ounits!r}")
    for c, u in zip(coords, ounits):
        if u not in (units["length"], units["angle"]):
            raise ValueError(
                f"output.units: the unit of {c!r} must be the file's length unit {units['length']!r} "
                f"or angle unit {units['angle']!r}, got {u!r}"
            )
    for c in out_joints:
        if c not in coords:
            raise ValueError(f"output.joints: {c!r} is not an output coordinate ({', '.join(coords)})")
        if c not in variables:
            raise ValueError(f"output.joints: no joint has the variable {c!r} (give it as that joint's 'variable')")
        if d_joint(joints, variables[c]).actuated:
            raise ValueError(f"output.joints: {c!r} is the variable of an actuated joint")
    pose_symbols = param_symbols | {c for c in coords if c not in out_joints}
    position = _vector("output.position", od["position"], dim, pose_symbols)
    point = od.get("point", False)
    if not isinstance(point, bool):
        raise ValueError(f"output.point: expected true or false, got {point!r}")
    rotation: Any
    if "rotation" not in od:
        if not point:
            raise ValueError(
                "output: missing key 'rotation' (planar: an angle expression; spatial: a list like "
                "[{axis: x, angle: alpha}]; [] or 0 for a constant orientation), or 'point: true' "
                "for a point output"
            )
        rotation = None
    else:
        if point:
            raise ValueError("output: a point output ('point: true') has no rotation")
        r = od["rotation"]
        if space == "planar":
            rotation = compile_expression(r, "output.rotation", pose_symbols)
        else:
            if not isinstance(r, list):
                raise ValueError(
                    f"output.rotation: expected a list of {{axis: x|y|z, angle: expression}} "
                    f"(applied in order, each about the moving axis; [] for a constant orientation), "
                    f"got {r!r}"
                )
            rot = []
            for k, item in enumerate(r):
                item = _check_keys(f"output.rotation[{k}]", item, {"axis", "angle"}, ("axis", "angle"))
                if item["axis"] not in _AXIS_NAMES:
                    raise ValueError(f"output.rotation[{k}].axis: expected x, y or z, got {item['axis']!r}")
                rot.append(
                    (
                        _AXIS_NAMES[item["axis"]],
                        compile_expression(item["angle"], f"output.rotation[{k}].angle", pose_symbols),
                    )
                )
            rotation = tuple(rot)
    used = set().union(*(e.names for e in position))
    if isinstance(rotation, Expression):
        used |= rotation.names
    elif rotation:
        used |= set().union(*(e.names for _, e in rotation))
    for c in coords:
        if c not in used and c not in out_joints:
            raise ValueError(
                f"output.coordinates: {c!r} is used neither by output.position nor by output.rotation "
                f"nor listed in output.joints; every output coordinate must move the output"
            )
    output = Output(od["body"], tuple(coords), tuple(ounits), position, rotation, point, out_joints)

    # ---------------------------------------------------------------- loops, counts, branch
    loops_raw = d["loops"]
    if not isinstance(loops_raw, list) or not loops_raw:
        raise ValueError(f"loops: expected a list of loops, each a list of joint names, got {loops_raw!r}")
    loops = []
    for k, lp in enumerate(loops_raw):
        if not isinstance(lp, list) or not lp:
            raise ValueError(f"loops[{k}]: expected a list of joint names, got {lp!r}")
        for jn in lp:
            if jn not in joint_names:
                raise ValueError(f"loops[{k}]: unknown joint {jn!r}; the joints are {', '.join(sorted(joint_names))}")
        if len(set(lp)) != len(lp):
            raise ValueError(f"loops[{k}]: a joint appears twice in {lp}")
        loops.append(tuple(lp))
    oc = d.get("overconstraints", 0)
    why = ""
    if isinstance(oc, Mapping):
        oc = _check_keys("overconstraints", oc, {"count", "why"}, ("count", "why"))
        why = oc["why"]
        oc = oc["count"]
    if isinstance(oc, bool) or not isinstance(oc, int):
        raise ValueError(f"overconstraints: expected an integer (or {{count: n, why: text}}), got {oc!r}")
    if oc != 0 and not (isinstance(why, str) and why.strip()):
        raise ValueError("overconstraints: a non-zero count needs its 'why' ({count: n, why: text})")
    nodes = _parse_nodes(d.get("nodes"), space, bodies, joints, param_symbols)
    branch = d.get("default_branch")
    if branch is not None:
        if not isinstance(branch, list) or any(b not in (1, -1) or isinstance(b, bool) for b in branch):
            raise ValueError(
                f"default_branch: expected a list of signs, each 1 or -1 (one per actuator), got {branch!r}"
            )
        branch = tuple(int(b) for b in branch)
    rule = d.get("branch_rule", "")
    if not isinstance(rule, str):
        raise ValueError(f"branch_rule: expected text, got {rule!r}")
    return Description(
        name=name,
        paper=paper,
        space=space,
        length_unit=units["length"],
        angle_unit=units["angle"],
        parameters=params,
        parameter_keys=keys,
        derived=tuple(derived),
        bodies=tuple(bodies),
        joints=tuple(joints),
        output=output,
        loops=tuple(loops),
        overconstraints=oc,
        overconstraints_why=why,
        nodes=nodes,
        default_branch=branch,
        branch_rule=rule,
        source=source,
    )


def d_joint(joints, name: str) -> Joint:
    return next(j for j in joints if j.name == name)


def _parse_nodes(raw, space: str, bodies, joints, param_symbols) -> tuple[Node, ...]:
    """``nodes``: a list of ``{name, joints, locate, toward}`` (README, "Nodes"); spatial only."""
    if raw is None:
        return ()
    if not isinstance(raw, list) or not raw:
        raise ValueError(f"nodes: expected a list of nodes ({{name, joints, locate, toward}}), got {raw!r}")
    if space != "spatial":
        raise ValueError(
            "nodes: only a spatial description has nodes (a node is located by two planes and one distance)"
        )
    names = {j.name for j in joints}
    by_name = {j.name: j for j in joints}
    out: list[Node] = []
    used: dict[str, str] = {}
    for k, nd in enumerate(raw):
        label = f"nodes[{k}]"
        if isinstance(nd, Mapping) and isinstance(nd.get("name"), str):
            label = f"node {nd['name']!r}"
        nd = _check_keys(label, nd, _NODE_KEYS, ("name", "joints", "locate", "toward"))
        name = _name(f"{label}.name", nd["name"])
        if name in bodies or name in names or name in param_symbols or any(n.name == name for n in out):
            raise ValueError(f"{label}.name: {name!r} is already a body, joint, parameter or node name")
        js = nd["joints"]
        if not isinstance(js, list) or not js:
            raise ValueError(
                f"{label}.joints: expected a list of joint names (the joints centred at the node), got {js!r}"
            )
        for jn in js:
            if jn not in names:
                raise ValueError(f"{label}.joints: unknown joint {jn!r}; the joints are {', '.join(sorted(names))}")
            if jn in used:
                raise ValueError(f"{label}.joints: joint {jn!r} is already a joint of node {used[jn]!r}")
            j = by_name[jn]
            if j.type not in POINT_JOINTS or j.actuated:
                raise ValueError(
                    f"{label}.joints: joint {jn!r} must be a passive point joint ({', '.join(POINT_JOINTS)}), "
                    f"got {'an actuated ' if j.actuated else ''}{j.type}"
                )
            used[jn] = name
        loc = nd["locate"]
        accepted = (
            "three constraints 'link.plane' or 'link.distance' of the node's links: two planes and one "
            "distance (the node is on the line of the two planes, at the distance from the link's other end)"
        )
        if not isinstance(loc, list) or len(loc) != 3:
            raise ValueError(f"{label}.locate: expected {accepted}, got {loc!r}")
        locate = []
        for m, c in enumerate(loc):
            if not isinstance(c, str) or c.count(".") != 1 or c.split(".")[1] not in NODE_CONSTRAINTS:
                raise ValueError(f"{label}.locate[{m}]: expected 'link.plane' or 'link.distance', got {c!r}")
            link, kind = c.split(".")
            if link not in bodies:
                raise ValueError(f"{label}.locate[{m}]: unknown body {link!r}; the bodies are {', '.join(bodies)}")
            if (link, kind) in locate:
                raise ValueError(f"{label}.locate[{m}]: {c!r} is listed twice")
            locate.append((link, kind))
        kinds = sorted(kind for _, kind in locate)
        if kinds != ["distance", "plane", "plane"]:
            raise ValueError(
                f"{label}.locate: expected {accepted}, got {kinds.count('plane')} plane(s) and "
                f"{kinds.count('distance')} distance(s)"
            )
        toward = _vector(f"{label}.toward", nd["toward"], 3, param_symbols)
        out.append(Node(name, tuple(js), tuple(locate), toward))
    return tuple(out)
