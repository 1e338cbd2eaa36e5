"""Extended-URDF import: a URDF tree plus a YAML file of closures and motors -> a description ->
:class:`pkmlib.Mechanism`.

The Extended URDF of Batto, de Matteis and Mansard (2025), the format of Gepetto's
example-parallel-robots: the URDF holds the mechanism's tree (every loop cut open at one joint
pair) and ``robot.yaml`` names the closures (``closed_loop``: pairs of frames that must coincide;
``type``: ``6d`` or ``3d`` for each) and the actuated joints (``name_mot``). The URDF is read
with `yourdfpy <https://github.com/clemense/yourdfpy>`_ (without meshes).

:func:`urdf_description` turns the two into a mechanism description (``data/mechanisms/README.md``)
and :func:`load_urdf_mechanism` loads that with :func:`pkmlib.load_mechanism`: the constraint
equations come from the one generator of pkmlib.description, never from a second one.

What is imported, and how:

- Planar mechanisms: every moving joint a revolute whose axis, at the zero configuration, is
  parallel to the first motor's (the normal ``n`` of the plane) and turns the same way. The plane
  coordinates ``(u, v)`` are along ``e1``, the base axis most nearly perpendicular to ``n``
  projected onto the plane, and ``e2 = n x e1``; lengths in m, angles in rad (URDF's units).
  Another kind of joint, or a skew axis, is a ``ValueError`` naming the joint.
- Every body's frame in the description is the URDF link's position at the zero configuration
  with the plane's axes, so each joint's placement is the projection of its centre and each joint
  value is the URDF joint value (a motor's ``q`` is its URDF angle).
- The output is the closure point: the two frames of a closure become one point body (``C``),
  where the two chains meet. A 6d closure of two revolute joints about ``n`` leaves their spins
  free, so it is the coincidence of the two centres in the plane, and their offsets along ``n``
  must agree (else ``ValueError``: the loop cannot close). Frames that are neither on a chain
  nor at a closure (5-bar: the ``effector`` frame, fixed to the link ``end_rod`` 0.0675 m beyond
  the closure) are left out: they ride on a connecting link, which a description cannot output.
- Geometry: the in-plane coordinates of each joint centre are named parameters
  ``<joint>_u, <joint>_v`` (m), so ``jax.grad`` over a design works as for any description.
"""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path
from typing import Any, Mapping

import numpy as np
import yaml

#: The joint types this import accepts (moving joints; ``fixed`` joints only off the loops).
MOVING_JOINTS = ("revolute", "continuous")
#: The closure types of ``robot.yaml`` (both are a point coincidence for a planar mechanism).
CLOSURE_TYPES = ("6d", "3d")
#: Tolerance (m, and on unit vectors) of the geometric checks: parallel axes, closure offsets.
GEOMETRY_TOL = 1e-9


@dataclasses.dataclass(frozen=True)
class _Tree:
    links: tuple[str, ...]
    joints: dict[str, Any]  # name -> yourdfpy Joint
    parent_joint: dict[str, str]  # link -> the joint into it
    root: str
    frames: dict[str, np.ndarray]  # link -> 4 x 4 pose at the zero configuration


def _read_tree(urdf: str | Path) -> _Tree:
    import yourdfpy

    path = Path(urdf)
    if not path.is_file():
        raise ValueError(f"urdf: no such file {str(path)!r}")
    try:
        model = yourdfpy.URDF.load(
            str(path),
            load_meshes=False,
            build_scene_graph=False,
            build_collision_scene_graph=False,
            load_collision_meshes=False,
        )
    except Exception as e:  # yourdfpy raises several kinds for a malformed file
        raise ValueError(f"urdf: {path} could not be read as URDF ({type(e).__name__}: {e})") from None
    robot = model.robot
    links = tuple(link.name for link in robot.links)
    joints = {j.name: j for j in robot.joints}
    parent_joint = {}
    for j in robot.joints:
        if j.child in parent_joint:
            raise ValueError(
                f"urdf: link {j.child!r} has two parent joints ({parent_joint[j.child]!r}, {j.name!r}); "
                "an Extended URDF is a tree"
            )
        parent_joint[j.child] = j.name
    roots = [name for name in links if name not in parent_joint]
    if len(roots) != 1:
        raise ValueError(f"urdf: expected one root link, found {roots}")
    frames = {roots[0]: np.eye(4)}
    pending = [roots[0]]
    while pending:
        parent = pending.pop()
        for j in robot.joints:
            if j.parent == parent:
                origin = np.eye(4) if j.origin is None else np.asarray(j.origin, dtype=np.float64)
                frames[j.child] = frames[parent] @ origin
                pending.append(j.child)
    return _Tree(links, joints, parent_joint, roots[0], frames)


def _read_closures(closures: str | Path | Mapping[str, Any]) -> tuple[list[tuple[str, str]], list[str], list[str]]:
    if isinstance(closures, Mapping):
        data = dict(closures)
    else:
        path = Path(closures)
        if not path.is_file():
            raise ValueError(f"closures_yaml: no such file {str(path)!r}")
        data = yaml.safe_load(path.read_text(encoding="utf-8"))
    if not isinstance(data, Mapping):
        raise ValueError(f"closures_yaml: expected a mapping with closed_loop, type and name_mot, got {data!r}")
    missing = [k for k in ("closed_loop", "name_mot") if k not in data]
    if missing:
        raise ValueError(
            f"closures_yaml: missing {', '.join(missing)} (an Extended-URDF robot.yaml has "
            "closed_loop, type and name_mot)"
        )
    loops = data["closed_loop"]
    if (
        not isinstance(loops, list)
        or not loops
        or not all(isinstance(p, (list, tuple)) and len(p) == 2 and all(isinstance(s, str) for s in p) for p in loops)
    ):
        raise ValueError(f"closures_yaml.closed_loop: expected a list of [frame, frame] pairs, got {loops!r}")
    types = data.get("type") or ["6d"] * len(loops)
    if not isinstance(types, list) or len(types) != len(loops) or any(t not in CLOSURE_TYPES for t in types):
        raise ValueError(
            f"closures_yaml.type: expected one of {list(CLOSURE_TYPES)} per closure ({len(loops)}), got {types!r}"
        )
    motors = data["name_mot"]
    if not isinstance(motors, list) or not motors or not all(isinstance(m, str) for m in motors):
        raise ValueError(f"closures_yaml.name_mot: expected a list of joint names, got {motors!r}")
    return [tuple(p) for p in loops], list(types), list(motors)


def _closure_link(tree: _Tree, frame: str) -> str:
    """The link a closure frame names: a joint's child link, or a link itself."""
    if frame in tree.joints:
        return tree.joints[frame].child
    if frame in tree.links:
        return frame
    raise ValueError(f"closures_yaml.closed_loop: {frame!r} is neither a joint nor a link of the URDF")


def _path(tree: _Tree, link: str) -> list[str]:
    """Joint names from the root to ``link``."""
    out = []
    while link != tree.root:
        j = tree.parent_joint[link]
        out.append(j)
        link = tree.joints[j].parent
    return out[::-1]


def urdf_description(
    urdf: str | Path,
    closures_yaml: str | Path | Mapping[str, Any],
    output_frame: str | None = None,
    *,
    coordinates: tuple[str, str] = ("u", "v"),
    name: str | None = None,
) -> dict[str, Any]:
    """The mechanism description (a dict of the ``data/mechanisms/README.md`` format) of an
    Extended-URDF model: ``urdf`` a ``.urdf`` path, ``closures_yaml`` its ``robot.yaml`` (path or
    dict). ``output_frame`` is None or one of the closure's frames (joint or link names): the
    output is the closure point (module docstring); any other frame is a ``ValueError``.
    ``coordinates`` names the two output coordinates along ``e1``, ``e2``."""
    if not isinstance(urdf, (str, os.PathLike)):
        raise ValueError(f"urdf must be the path (a str or pathlib.Path) of a .urdf file, got {urdf!r}")
    if not isinstance(closures_yaml, (str, os.PathLike, Mapping)):
        raise ValueError(
            f"closures_yaml must be the path (a str or pathlib.Path) of a robot.yaml file or a mapping, "
            f"got {closures_yaml!r}"
        )
    if (
        not isinstance(coordinates, (tuple, list))
        or len(coordinates) != 2
        or not all(isinstance(c, str) and c for c in coordinates)
        or coordinates[0] == coordinates[1]
    ):
        raise ValueError(
            f"coordinates must be two different names of the output coordinates along e1, e2 "
            f"(e.g. ('u', 'v')), got {coordinates!r}"
        )
    tree = _read_tree(urdf)
    loops, _types, motors = _read_closures(closures_yaml)
    if len(loops) != 1:
        raise ValueError(
            f"closures_yaml.closed_loop: this import takes one closure (a planar point output), got {len(loops)}"
        )
    frame_a, frame_b = loops[0]
    if output_frame is not None and output_frame not in (
        frame_a,
        frame_b,
        _closure_link(tree, frame_a),
        _closure_link(tree, frame_b),
    ):
        raise ValueError(
            f"output_frame: {output_frame!r} is not the closure point; accepted: None or one of the "
            f"closure's frames {[frame_a, frame_b]} (a frame on a connecting link, such as an "
            "effector fixed to it, cannot be the output of a description)"
        )
    for m in motors:
        if m not in tree.joints:
            raise ValueError(f"closures_yaml.name_mot: {m!r} is not a joint of the URDF")
    ends = [_closure_link(tree, f) for f in (frame_a, frame_b)]
    chains = [_path(tree, link) for link in ends]
    used = [j for chain in chains for j in chain]
    for jname in used:
        j = tree.joints[jname]
        if j.type not in MOVING_JOINTS:
            raise ValueError(
                f"urdf: joint {jname!r} is {j.type!r}; a planar import takes {list(MOVING_JOINTS)} joints on the loop"
            )
    for m in motors:
        if m not in used:
            raise ValueError(f"closures_yaml.name_mot: motor {m!r} is not on the loop {[frame_a, frame_b]}")

    # The plane: the joint axes in the base frame at the zero configuration.
    def axis(jname):
        j = tree.joints[jname]
        a = np.asarray(j.axis if j.axis is not None else (1.0, 0.0, 0.0), dtype=np.float64)
        w = tree.frames[j.child][:3, :3] @ (a / np.linalg.norm(a))
        return w

    n = axis(motors[0])
    for jname in used:
        w = axis(jname)
        if np.linalg.norm(np.cross(w, n)) > GEOMETRY_TOL:
            raise ValueError(
                f"urdf: joint {jname!r} turns about {w.round(6).tolist()}, not parallel to the first "
                f"motor's axis {n.round(6).tolist()}: the mechanism is not planar"
            )
        if w @ n < 0:
            raise ValueError(
                f"urdf: joint {jname!r} turns about {w.round(6).tolist()}, against the first motor's "
                f"axis {n.round(6).tolist()}; joints turning the other way are not supported"
            )
    e1 = np.eye(3)[int(np.argmin(np.abs(n)))]
    e1 = e1 - (e1 @ n) * n
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(n, e1)

    def centre(link):
        return tree.frames[link][:3, 3]

    def plane(p):
        return float(p @ e1), float(p @ e2)

    along = [float(centre(link) @ n) for link in ends]
    if abs(along[0] - along[1]) > GEOMETRY_TOL:
        raise ValueError(
            f"closures_yaml.closed_loop: the frames {frame_a!r} and {frame_b!r} lie {along[0]:.6g} m "
            f"and {along[1]:.6g} m along the joint axis: the loop cannot close"
        )

    output_body = "C"
    body_of = {tree.root: "base", ends[0]: output_body, ends[1]: output_body}
    bodies, joints, params = [], [], {}
    order = sorted(dict.fromkeys(used), key=lambda j: (j not in motors, motors.index(j) if j in motors else 0))
    for jname in order:
        j = tree.joints[jname]
        child = body_of.setdefault(j.child, j.child)
        if child != output_body:
            bodies.append(child)
        parent = body_of.get(j.parent, j.parent)
        u, v = np.subtract(plane(centre(j.child)), plane(centre(j.parent)))
        params[f"{jname}_u"], params[f"{jname}_v"] = float(u), float(v)
        entry = {
            "name": jname,
            "type": "revolute",
            "parent": parent,
            "child": child,
            "at": [f"{jname}_u", f"{jname}_v"],
        }
        if jname in motors:
            entry.update(actuated=True, variable=f"q_{jname}")
            limit = getattr(j, "limit", None)
            if limit is not None and limit.lower is not None and limit.upper is not None and j.type == "revolute":
                entry["limits"] = [float(limit.lower), float(limit.upper)]
        joints.append(entry)
    c_u, c_v = coordinates
    return {
        "name": name or f"{Path(urdf).parent.name or 'URDF'} (Extended URDF, closure point output)",
        "space": "planar",
        "units": {"length": "m", "angle": "rad"},
        "parameters": params,
        "bodies": [*dict.fromkeys(bodies), output_body],
        "joints": joints,
        "output": {
            "body": output_body,
            "point": True,
            "coordinates": [c_u, c_v],
            "units": ["m", "m"],
            "position": [c_u, c_v],
        },
        "loops": [list(chain) for chain in chains],
        "notes": (
            f"imported from {Path(urdf).name} + closures {loops[0]}: plane e1 = {e1.round(12).tolist()}, "
            f"e2 = {e2.round(12).tolist()} (base frame), normal {n.round(12).tolist()}"
        ),
    }


def load_urdf_mechanism(
    urdf: str | Path,
    closures_yaml: str | Path | Mapping[str, Any],
    output_frame: str | None = None,
    *,
    coordinates: tuple[str, str] = ("u", "v"),
    name: str | None = None,
):
    """An Extended-URDF model (Batto, de Matteis, Mansard 2025: a URDF tree plus ``robot.yaml`` with
    ``closed_loop``, ``type``, ``name_mot``; Gepetto's example-parallel-robots) as a
    :class:`pkmlib.Mechanism`: :func:`urdf_description` loaded by :func:`pkmlib.load_mechanism`.

    The output is the closure point, ``x = (u, v)`` in m along the plane axes ``e1, e2`` (see the
    module docstring for the plane and for what is left out); ``q`` are the motors' URDF joint
    angles (rad), in the order of ``name_mot``. Raises ``ValueError`` naming the joint, frame or
    key that the import does not accept."""
    from ._loader import load_mechanism

    return load_mechanism(urdf_description(urdf, closures_yaml, output_frame, coordinates=coordinates, name=name))
