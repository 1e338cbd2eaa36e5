"""The constraint equations of a described mechanism: sides, connecting elements, loops, mobility.

Generation follows ``data/mechanisms/README.md`` ("How the constraints are generated"):

1. Bodies reached from the base through actuated and fixed joints have poses known from ``q``
   (the *base side*); bodies reached from the output body through fixed joints and the output's
   joints have poses known from ``x`` (the *output side*).
2. Every other body belongs to a *connecting element* between one base-side point joint and one
   output-side point joint: one link, or two links joined by an actuated prismatic along the line
   of the two centres (an RPR or UPS leg).
3. Each loop (a path of joints from the base to the output side through one element) gives
   ``F_k = |P_out(x) - P_base(q)|^2 - L_k^2``: the squared-distance closure of P1 eq (1),
   P2 eq (1), P4's chains and P3 section 2.3.1 (``f_i`` of mechanism A). A second link between
   the same bodies that gives the same equation for every ``x`` and ``q`` (a parallelogram's
   twin) is in no loop and gives no equation.
4. The Gruebler-Kutzbach mobility ``M = lambda (N - 1 - j) + sum f_i - idle + overconstraints``
   must equal the number of output coordinates, and the equations must number the actuators.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import jax.numpy as jnp
import numpy as np

from . import _kinematics as kin
from ._format import BASE, POINT_JOINTS, Description, Joint

Array = Any


@dataclasses.dataclass(frozen=True)
class Element:
    """A connecting element: its links, its two end joints and its actuated prismatic (if any)."""

    links: tuple[str, ...]
    base_joint: Joint
    out_joint: Joint
    base_body: str
    out_body: str
    prismatic: Joint | None

    @property
    def joint_names(self) -> tuple[str, ...]:
        mid = (self.prismatic.name,) if self.prismatic is not None else ()
        return (self.base_joint.name, *mid, self.out_joint.name)

    @property
    def label(self) -> str:
        return "the element " + " - ".join(self.links) + f" (joints {', '.join(self.joint_names)})"


def _centre_in(joint: Joint, body: str):
    """The joint centre in ``body``'s frame (``at`` in the parent, ``child_at`` or origin in the child)."""
    if body == joint.parent:
        return joint.at
    return joint.child_at


def _vec(exprs, env, dim):
    if exprs is None:
        return (0.0,) * dim
    return tuple(kin.const(e(env)) for e in exprs)


class Closure:
    """The analysed description: which body is on which side, the elements, the equations."""

    def __init__(self, desc: Description):
        self.desc = desc
        d = desc
        self.dim = d.dim
        self.compose = kin.planar_compose if d.space == "planar" else kin.spatial_compose
        self.point = kin.planar_point if d.space == "planar" else kin.spatial_point
        self.joint_frame = kin.planar_joint if d.space == "planar" else kin.spatial_joint
        self.identity = kin.planar_identity() if d.space == "planar" else kin.spatial_identity()
        env = d.parameter_env(d.parameters)
        self._numeric_env = env
        touched = {b: [] for b in d.bodies}
        for j in d.joints:
            touched[j.parent].append(j)
            touched[j.child].append(j)
        for b, js in touched.items():
            if not js:
                raise ValueError(f"body {b!r}: connected by no joint (every body in 'bodies' needs one)")

        # 1. sides
        self.side: dict[str, str] = {BASE: "base", d.output.body: "output"}
        self.tree: dict[str, Joint] = {}
        out_vars = set(d.output.joints)
        for j in d.joints:
            if j.variable in out_vars and j.actuated:
                raise ValueError(
                    f"joint {j.name!r}: its variable {j.variable!r} is an output coordinate, so it cannot be actuated"
                )
        changed = True
        while changed:
            changed = False
            for j in d.joints:
                s = self.side.get(j.parent)
                if s == "base" and (j.actuated or j.type == "fixed"):
                    grows = "base"
                elif s == "output" and (j.type == "fixed" or j.variable in out_vars):
                    grows = "output"
                else:
                    continue
                if j.name in (t.name for t in self.tree.values()):
                    continue
                if j.child in self.side:
                    raise ValueError(
                        f"joint {j.name!r}: body {j.child!r} is already on the {self.side[j.child]} side "
                        f"(through another joint or the output); a body is reached from the base or "
                        f"the output once"
                    )
                self.side[j.child] = grows
                self.tree[j.child] = j
                changed = True
        for c in d.output.joints:
            j = next(jj for jj in d.joints if jj.variable == c)
            if self.tree.get(j.child) is not j:
                raise ValueError(
                    f"output.joints: the joint {j.name!r} of {c!r} must have its parent on the output "
                    f"side (the output body or a body fixed to it); its parent is {j.parent!r}"
                )
        if d.output.point:
            for j in touched[d.output.body]:
                if any(abs(float(v)) > 0 for v in _vec(_centre_in(j, d.output.body), env, self.dim)):
                    raise ValueError(
                        f"joint {j.name!r}: a point output (output.point) has all its joints at its origin"
                    )

        for j in d.joints:
            if {self.side.get(j.parent), self.side.get(j.child)} == {"base", "output"}:
                raise ValueError(
                    f"joint {j.name!r}: it joins the base-side body "
                    f"{j.parent if self.side[j.parent] == 'base' else j.child!r} directly to the "
                    f"output side; a closure needs a connecting element between them (is a joint "
                    f"before it wrongly actuated?)"
                )

        # 2. connecting elements
        unknown = [b for b in d.bodies if b not in self.side]
        comp_of: dict[str, int] = {}
        comps: list[list[str]] = []
        for b in unknown:
            if b in comp_of:
                continue
            stack, comp = [b], []
            comp_of[b] = len(comps)
            while stack:
                u = stack.pop()
                comp.append(u)
                for j in touched[u]:
                    v = j.child if j.parent == u else j.parent
                    if v not in self.side and v not in comp_of:
                        comp_of[v] = len(comps)
                        stack.append(v)
            comps.append(comp)
        self.elements: list[Element] = []
        for comp in comps:
            self.elements.append(self._element(comp, touched))
        for j in d.joints:
            if j.actuated and self.tree.get(j.child) is not j and not any(e.prismatic is j for e in self.elements):
                raise ValueError(
                    f"joint {j.name!r}: an actuated joint must move a base-side body (its parent on the "
                    f"base side) or be the prismatic of an RPR/UPS element"
                )

        # actuators, in the order of the joints
        self.actuators = tuple(j for j in d.joints if j.actuated)
        self.actuator_index = {j.variable: i for i, j in enumerate(self.actuators)}

        # 3. loops
        elem_of_joint = {n: e for e in self.elements for n in e.joint_names}
        looped: list[Element] = []
        for k, lp in enumerate(d.loops):
            where = f"loops[{k}] ({' -> '.join(lp)})"
            body = BASE
            for jn in lp:
                j = d.joint(jn)
                if body not in (j.parent, j.child):
                    raise ValueError(
                        f"{where}: the loop does not close: joint {jn!r} (between {j.parent!r} and "
                        f"{j.child!r}) does not touch {body!r}, where the path from the base has "
                        f"arrived; a loop is a connected path of joints from the base to the output side"
                    )
                body = j.child if j.parent == body else j.parent
            if self.side.get(body) != "output":
                out_bodies = [b for b, s in self.side.items() if s == "output"]
                raise ValueError(
                    f"{where}: the loop does not close: it ends at body {body!r}, which is not on the "
                    f"output side ({', '.join(out_bodies)})"
                )
            es = [e for e in self.elements if set(e.joint_names) <= set(lp)]
            partial = {elem_of_joint[jn].links for jn in lp if jn in elem_of_joint} - {e.links for e in es}
            if partial or len(es) != 1:
                raise ValueError(
                    f"{where}: a loop must pass through exactly one connecting element, all its joints; "
                    f"it passes through {len(es)} whole and {len(partial)} partial element(s)"
                )
            if es[0] in looped:
                raise ValueError(f"{where}: {es[0].label} is already in another loop")
            looped.append(es[0])
        self.twins = []
        for e in self.elements:
            if e in looped:
                continue
            twin = next((f for f in looped if (f.base_body, f.out_body) == (e.base_body, e.out_body)), None)
            if twin is None or not self._same_equation(e, twin):
                raise ValueError(
                    f"{e.label}: it is in no loop, and it is not the parallel twin of an element in a loop "
                    f"(same bodies, same equation for every x and q, as in a parallelogram); add its loop"
                )
            self.twins.append((e, twin))
        self.looped = looped

        # 4. mobility and counts
        if len(looped) != len(self.actuators):
            raise ValueError(
                f"loops: {len(looped)} loop equation(s) for {len(self.actuators)} actuator(s) "
                f"({', '.join(j.name for j in self.actuators)}); a description needs one loop per actuator"
            )
        self.mobility, self.gruebler_terms = self._mobility()
        n_x = len(d.output.coordinates)
        if self.mobility != n_x:
            t = self.gruebler_terms
            raise ValueError(
                f"Gruebler-Kutzbach mobility M = {t['lambda']} ({t['N']} - 1 - {t['j']}) + {t['sum_f']} - "
                f"{t['idle']} (idle) + {t['overconstraints']} (overconstraints) = {self.mobility} disagrees "
                f"with the {n_x} output coordinate(s) {list(d.output.coordinates)}; check the joints, "
                f"or declare 'overconstraints' with its 'why'"
            )
        if n_x != len(self.actuators):
            raise ValueError(
                f"{n_x} output coordinates but {len(self.actuators)} actuators: pkmlib's mechanisms have "
                f"as many actuators as output coordinates (square A and B)"
            )

        # equation order: chainwise when each equation involves one actuator, one-to-one
        deps = [self._dependencies(e) for e in looped]
        self.chainwise = all(len(s) == 1 for s in deps) and len({next(iter(s)) for s in deps}) == len(deps)
        if self.chainwise:
            order = sorted(range(len(looped)), key=lambda k: next(iter(deps[k])))
            self.equations = [looped[k] for k in order]
        else:
            self.equations = looped
        self.dependencies = [self._dependencies(e) for e in self.equations]

    # ---------------------------------------------------------------- structure
    def _element(self, comp: list[str], touched) -> Element:
        d = self.desc
        inner, boundary = [], []
        for b in comp:
            for j in touched[b]:
                other = j.child if j.parent == b else j.parent
                if other in comp:
                    if j not in inner:
                        inner.append(j)
                else:
                    boundary.append(j)
        label = f"bodies {', '.join(comp)}"
        accepted = (
            "a connecting element is one link with point joints (revolute; spatial: also universal, "
            "spherical) to one base-side and one output-side body, or two links joined by an actuated "
            "prismatic along the line of their two end centres"
        )
        sides = sorted(self.side.get(j.child if j.parent in comp else j.parent) for j in boundary)
        if len(boundary) != 2 or sides != ["base", "output"]:
            names = ", ".join(f"{j.name} ({j.parent}-{j.child})" for j in boundary)
            raise ValueError(
                f"{label}: not a connecting element: its joints to known bodies are [{names}] "
                f"(sides: {sides}); {accepted}. A body is known when reached from the base by actuated "
                f"or fixed joints, or from the output by fixed joints and output.joints"
            )
        for j in boundary:
            if j.type not in POINT_JOINTS or j.actuated:
                raise ValueError(
                    f"joint {j.name!r}: the end of a connecting element must be a passive point joint "
                    f"({', '.join(POINT_JOINTS) if d.space == 'spatial' else 'revolute'}), got "
                    f"{'an actuated ' if j.actuated else ''}{j.type}"
                )
        bj, oj = sorted(boundary, key=lambda j: self.side.get(j.child if j.parent in comp else j.parent) != "base")
        base_body = bj.child if bj.parent in comp else bj.parent
        out_body = oj.child if oj.parent in comp else oj.parent
        if len(comp) == 1 and not inner:
            return Element(tuple(comp), bj, oj, base_body, out_body, None)
        if len(comp) == 2 and len(inner) == 1 and inner[0].type == "prismatic" and inner[0].actuated:
            p = inner[0]
            link_b = bj.child if bj.parent == base_body else bj.parent
            if p.parent != link_b:
                raise ValueError(
                    f"joint {p.name!r}: the prismatic of {label} must have as parent the link on the base "
                    f"side ({link_b!r}), got {p.parent!r}"
                )
            e = Element((link_b, p.child), bj, oj, base_body, out_body, p)
            self._prismatic_line(e)
            return e
        raise ValueError(
            f"{label}: not a connecting element ({len(comp)} link(s), inner joints "
            f"{[j.name for j in inner]}); {accepted}"
        )

    def _prismatic_line(self, e: Element):
        """``s0``: the centre-to-centre distance of an RPR/UPS element is ``s0 + q + offset``
        (``ValueError`` when the prismatic is not along the line of the two centres)."""
        return self._prismatic_terms(e, self._numeric_env)[0]

    def _prismatic_terms(self, e: Element, env):
        """``(s0, offset)`` of an RPR/UPS element: the base-end centre ``cA`` (in the first link) and the
        output-end centre ``cB`` (in the second) are ``d0 + v u`` apart at prismatic value ``v``,
        ``u`` the prismatic's unit axis in the first link; ``s0 = d0 . u`` and ``d0`` must be along
        ``u`` (checked for concrete geometry)."""
        p = e.prismatic
        dim = self.dim
        cA = _vec(_centre_in(e.base_joint, e.links[0]), env, dim)
        cB = _vec(_centre_in(e.out_joint, e.links[1]), env, dim)
        zero_frame = self.joint_frame(
            _vec(p.at, env, dim),
            _vec(p.rpy, env, len(p.rpy)),
            _vec(p.axis, env, dim),
            p.child_at and _vec(p.child_at, env, dim),
            "prismatic",
            0.0,
        )
        one_frame = self.joint_frame(
            _vec(p.at, env, dim),
            _vec(p.rpy, env, len(p.rpy)),
            _vec(p.axis, env, dim),
            p.child_at and _vec(p.child_at, env, dim),
            "prismatic",
            1.0,
        )
        end0 = self.point(zero_frame, cB)
        end1 = self.point(one_frame, cB)
        u = tuple(kin.sub(a, b) for a, b in zip(end1, end0))
        d0 = tuple(kin.sub(a, b) for a, b in zip(end0, cA))
        s0 = kin.add(*(kin.mul(a, b) for a, b in zip(d0, u)))
        if all(isinstance(v, float) for v in (*d0, *u)):
            perp = np.asarray(d0) - s0 * np.asarray(u)
            scale = max(1.0, float(np.linalg.norm(d0)))
            if np.linalg.norm(perp) > 1e-9 * scale:
                raise ValueError(
                    f"joint {p.name!r}: the prismatic of {e.label} is not along the line of the two end "
                    f"centres (off the line by {np.linalg.norm(perp):.3g} {self.desc.length_unit}); "
                    f"only such RPR/UPS legs are accepted"
                )
        off = p.offset(env) if p.offset is not None else 0.0
        return s0, off

    def _same_equation(self, e: Element, f: Element) -> bool:
        rng = np.random.default_rng(0)
        for _ in range(3):
            x = rng.uniform(-1.0, 1.0, len(self.desc.output.coordinates))
            q = rng.uniform(-1.0, 1.0, len(self.actuators))
            a = float(self._row(e, x, q, self._numeric_env))
            b = float(self._row(f, x, q, self._numeric_env))
            if not abs(a - b) <= 1e-9 * max(1.0, abs(a), abs(b)):
                return False
        return True

    def _dependencies(self, e: Element) -> set[int]:
        out = set()
        body = e.base_body
        while body != BASE:
            j = self.tree[body]
            if j.actuated:
                out.add(self.actuator_index[j.variable])
            body = j.parent
        if e.prismatic is not None:
            out.add(self.actuator_index[e.prismatic.variable])
        return out

    def _mobility(self):
        d = self.desc
        idle = 0
        if d.space == "spatial":
            idle += sum(
                1 for e in self.elements if e.base_joint.type == "spherical" and e.out_joint.type == "spherical"
            )
        if d.output.point:
            idle += 1 if d.space == "planar" else 3
        N, j = len(d.bodies), len(d.joints)
        sum_f = sum(jt.freedom for jt in d.joints)
        M = d.lam * (N - 1 - j) + sum_f - idle + d.overconstraints
        return M, {"lambda": d.lam, "N": N, "j": j, "sum_f": sum_f, "idle": idle, "overconstraints": d.overconstraints}

    # ---------------------------------------------------------------- poses
    def _joint_child_frame(self, j: Joint, value, env):
        dim = self.dim
        if j.offset is not None and j.type in ("revolute", "prismatic"):
            value = kin.add(value, kin.const(j.offset(env)))
        return self.joint_frame(
            _vec(j.at, env, dim),
            _vec(j.rpy, env, len(j.rpy)),
            None if j.axis is None else _vec(j.axis, env, dim),
            None if j.child_at is None else _vec(j.child_at, env, dim),
            j.type,
            value,
        )

    def output_frame(self, xenv, env):
        o = self.desc.output
        penv = {**env, **xenv}
        pos = tuple(kin.const(e(penv)) for e in o.position)
        if self.desc.space == "planar":
            theta = 0.0 if o.rotation is None else kin.const(o.rotation(penv))
            return (theta, pos)
        R = kin.IDENTITY3
        for axis, angle in o.rotation or ():
            R = kin.matmul(R, kin.axis_rotation(axis, kin.const(angle(penv))))
        return (R, pos)

    def body_frame(self, body: str, xenv, qenv, env, cache):
        if body in cache:
            return cache[body]
        if body == BASE:
            f = self.identity
        elif body == self.desc.output.body:
            f = self.output_frame(xenv, env)
        else:
            j = self.tree[body]
            parent = self.body_frame(j.parent, xenv, qenv, env, cache)
            if j.type == "fixed":
                value = 0.0
            elif self.side[body] == "base":
                value = qenv[j.variable]
            else:
                value = xenv[j.variable]
            f = self.compose(parent, self._joint_child_frame(j, value, env))
        cache[body] = f
        return f

    def joint_centre(self, j: Joint, body: str, xenv, qenv, env, cache):
        """World position of joint ``j``'s centre, through the known ``body`` it connects."""
        return self.point(self.body_frame(body, xenv, qenv, env, cache), _vec(_centre_in(j, body), env, self.dim))

    def _row(self, e: Element, x, q, env, cache=None):
        xenv = {c: x[k] for k, c in enumerate(self.desc.output.coordinates)}
        qenv = {a.variable: q[k] for k, a in enumerate(self.actuators)}
        return self.row(e, xenv, qenv, env, {} if cache is None else cache)

    def row(self, e: Element, xenv, qenv, env, cache):
        """``F_k = |P_out - P_base|^2 - L_k^2`` for element ``e`` (see the module docstring)."""
        pb = self.joint_centre(e.base_joint, e.base_body, xenv, qenv, env, cache)
        po = self.joint_centre(e.out_joint, e.out_body, xenv, qenv, env, cache)
        d2 = kin.add(*((a - b) ** 2 for a, b in zip(po, pb)))
        if e.prismatic is None:
            c1 = _vec(_centre_in(e.base_joint, e.links[0]), env, self.dim)
            c2 = _vec(_centre_in(e.out_joint, e.links[0]), env, self.dim)
            L2 = kin.add(*(kin.mul(kin.sub(a, b), kin.sub(a, b)) for a, b in zip(c1, c2)))
        else:
            s0, off = self._prismatic_terms(e, env)
            L = kin.add(s0, kin.const(off), qenv[e.prismatic.variable])
            L2 = L * L
        return d2 - L2

    # ---------------------------------------------------------------- JAX functions
    def constraints(self, x, q, params):
        """``F(x, q, params) -> (n, *batch)``; ``x`` and ``q`` are only indexed."""
        env = self.desc.parameter_env(params)
        xenv = {c: x[k] for k, c in enumerate(self.desc.output.coordinates)}
        qenv = {a.variable: q[k] for k, a in enumerate(self.actuators)}
        cache: dict = {}
        rows = [self.row(e, xenv, qenv, env, cache) for e in self.equations]
        return jnp.stack(jnp.broadcast_arrays(*rows))

    def chain_constraint(self, i, x, q_i, params):
        """``F_i(i, x, q_i, params)``: equation ``i``, which involves actuator ``i`` only."""
        env = self.desc.parameter_env(params)
        xenv = {c: x[k] for k, c in enumerate(self.desc.output.coordinates)}
        qenv = {self.actuators[i].variable: q_i}
        return self.row(self.equations[i], xenv, qenv, env, {})

    def joint_points(self, x, q, params) -> dict[str, Array]:
        """Every joint centre, ``{joint name: (dim, *batch)}``, at the pose ``x`` and actuators ``q``."""
        env = self.desc.parameter_env(params)
        xenv = {c: x[k] for k, c in enumerate(self.desc.output.coordinates)}
        qenv = {a.variable: q[k] for k, a in enumerate(self.actuators)}
        cache: dict = {}
        pts = {}
        for j in self.desc.joints:
            # a prismatic's point is on its moving side (the carriage), a point joint's its centre
            for body in (j.child, j.parent) if j.type == "prismatic" else (j.parent, j.child):
                if body in self.side:
                    pts[j.name] = self.joint_centre(j, body, xenv, qenv, env, cache)
                    break
        for e in self.elements:
            if e.prismatic is not None:  # on the line of centres, at its distance from the base end
                pb = pts[e.base_joint.name]
                po = pts[e.out_joint.name]
                cA = _vec(_centre_in(e.base_joint, e.links[0]), env, self.dim)
                at = _vec(e.prismatic.at, env, self.dim)
                s = jnp.sqrt(sum((a - b) ** 2 for a, b in zip(at, cA)))
                dist = jnp.sqrt(sum((a - b) ** 2 for a, b in zip(po, pb)))
                pts[e.prismatic.name] = tuple(b + (a - b) * s / dist for a, b in zip(po, pb))
        return {k: jnp.stack(jnp.broadcast_arrays(*v)) for k, v in pts.items()}
