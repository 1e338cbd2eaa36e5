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
import math
from typing import Any

import jax.numpy as jnp
import numpy as np

from . import _kinematics as kin
from ._format import BASE, POINT_JOINTS, Description, Joint

Array = Any


@dataclasses.dataclass(frozen=True)
class NodeLink:
    """A link at a node: its joint at the node and its joint to a known (base- or output-side) body."""

    link: str
    node: str
    node_joint: Joint
    known_joint: Joint
    known_body: str

    @property
    def has_plane(self) -> bool:
        """A spatial revolute at the known end keeps the link in a plane across its axis."""
        return self.known_joint.type == "revolute"


@dataclasses.dataclass(frozen=True)
class NodeEquation:
    """One equation of a node: a constraint of one of its links that does not locate it."""

    node: str
    link: NodeLink
    kind: str  # "distance" or "plane"

    @property
    def label(self) -> str:
        return f"the constraint {self.link.link}.{self.kind} of node {self.node!r}"


@dataclasses.dataclass(frozen=True)
class Element:
    """A connecting element: its links, its two end joints and its actuated prismatic (if any)."""

    links: tuple[str, ...]
    base_joint: Joint
    out_joint: Joint
    base_body: str
    out_body: str
    prismatic: Joint | None
    #: ``"distance"`` (one link, or an RPR/UPS leg) or ``"plane"`` (an R-P arm: revolute, then a
    #: passive prismatic across its axis; P5's P R P S chains)
    kind: str = "distance"

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


def _dot(a, b):
    return kin.add(*(kin.mul(x, y) for x, y in zip(a, b)))


def _cross(a, b):
    return (
        kin.sub(kin.mul(a[1], b[2]), kin.mul(a[2], b[1])),
        kin.sub(kin.mul(a[2], b[0]), kin.mul(a[0], b[2])),
        kin.sub(kin.mul(a[0], b[1]), kin.mul(a[1], b[0])),
    )


def _div(a, b):
    if isinstance(a, float) and a == 0.0:
        return 0.0
    if isinstance(b, float) and b == 1.0:
        return a
    return a / b


def _sqrt(a):
    """Square root, NaN (not an error) for a negative radicand: a node that does not exist."""
    if isinstance(a, float):
        return math.sqrt(a) if a >= 0.0 else math.nan
    return jnp.sqrt(a)


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
        self.node_links: dict[str, list[NodeLink]] = {n.name: [] for n in d.nodes}
        node_of_joint = {jn: n for n in d.nodes for jn in n.joints}
        for comp in comps:
            inner_nodes = {node_of_joint[j.name].name for b in comp for j in touched[b] if j.name in node_of_joint}
            if inner_nodes:
                self._node_component(comp, touched, node_of_joint)
            else:
                self.elements.append(self._element(comp, touched))
        for n in d.nodes:
            if not self.node_links[n.name]:
                raise ValueError(f"node {n.name!r}: its joints join no links between known bodies")
        self.node_equations: dict[str, list[NodeEquation]] = {}
        self.dependent: list[NodeEquation] = []
        for n in d.nodes:
            self._node_constraints(n)
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
        looped: list = []
        node_link_of = {nl.link: nl for links in self.node_links.values() for nl in links}
        for k, lp in enumerate(d.loops):
            where = f"loops[{k}] ({' -> '.join(lp)})"
            body = BASE
            visited = []
            for jn in lp:
                j = d.joint(jn)
                if body not in (j.parent, j.child):
                    raise ValueError(
                        f"{where}: the loop does not close: joint {jn!r} (between {j.parent!r} and "
                        f"{j.child!r}) does not touch {body!r}, where the path from the base has "
                        f"arrived; a loop is a connected path of joints from the base to the output side"
                    )
                body = j.child if j.parent == body else j.parent
                visited.append(body)
            at_nodes = [b for b in visited if b in node_link_of]
            if at_nodes:
                looped.extend(self._node_loop(where, lp, visited, body, node_link_of, elem_of_joint, looped))
                continue
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
        for eqs in self.node_equations.values():
            for eq in eqs:
                if eq not in looped:
                    raise ValueError(
                        f"{eq.label} is in no loop (and not identically satisfied once the node is located); "
                        f"add the loop from the base through the node and the link {eq.link.link!r} to its "
                        f"joint {eq.link.known_joint.name!r}"
                    )
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
        if len(comp) == 2 and len(inner) == 1 and inner[0].type == "prismatic" and not inner[0].actuated:
            return self._plane_element(comp, bj, oj, base_body, out_body, inner[0], label)
        ends = {bj.child if bj.parent == base_body else bj.parent, oj.child if oj.parent == out_body else oj.parent}
        if (
            len(comp) == 2
            and len(ends) == 2
            and len(inner) == 1
            and inner[0].type == "revolute"
            and not inner[0].actuated
        ):
            raise ValueError(
                f"{label}: a two-link arm with the passive revolute {inner[0].name!r} between them is not accepted: "
                f"its end is bound by its reach (|l1 - l2| <= distance <= l1 + l2), an inequality, besides a "
                f"plane when both revolute axes are parallel (P5's P R R S chains), and the format generates "
                f"equations only, so a pose out of reach would not be NaN. Describe such a chain by its "
                f"equation: a revolute then a passive prismatic across its axis (an R-P arm, P5's P R P S), "
                f"whose end moves over the whole plane"
            )
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

    # ---------------------------------------------------------------- nodes
    def _node_component(self, comp: list[str], touched, node_of_joint) -> None:
        """The links of one node (README, "Nodes"): each link has the node's joint(s) and one point
        joint to a known body; its centres at the node coincide."""
        d = self.desc
        env = self._numeric_env
        nodes = {node_of_joint[j.name].name for b in comp for j in touched[b] if j.name in node_of_joint}
        label = f"bodies {', '.join(comp)}"
        if len(nodes) != 1:
            raise ValueError(
                f"{label}: they meet at more than one node ({', '.join(sorted(nodes))}); one node per group"
            )
        node = next(n for n in d.nodes if n.name in nodes)
        for b in comp:
            js = touched[b]
            at_node = [j for j in js if j.name in node.joints]
            others = [j for j in js if j.name not in node.joints]
            inner = [j for j in others if (j.child if j.parent == b else j.parent) in comp]
            if inner or len(others) != 1 or not at_node:
                raise ValueError(
                    f"body {b!r}: a link at node {node.name!r} has the node's joints "
                    f"({', '.join(node.joints)}) and exactly one joint to a known body (base or output side); "
                    f"it has {len(at_node)} joint(s) at the node and "
                    f"{[j.name for j in others]} besides"
                )
            kj = others[0]
            known = kj.child if kj.parent == b else kj.parent
            if known not in self.side:
                raise ValueError(f"joint {kj.name!r}: the other end of link {b!r} at node {node.name!r} must be known")
            if kj.type not in POINT_JOINTS or kj.actuated:
                raise ValueError(
                    f"joint {kj.name!r}: the known end of a link at a node must be a passive point joint "
                    f"({', '.join(POINT_JOINTS)}), got {'an actuated ' if kj.actuated else ''}{kj.type}"
                )
            centres = [np.asarray(_vec(_centre_in(j, b), env, 3), dtype=float) for j in at_node]
            for j, c in zip(at_node[1:], centres[1:]):
                if np.linalg.norm(c - centres[0]) > 1e-9 * max(1.0, float(np.linalg.norm(centres[0]))):
                    raise ValueError(
                        f"node {node.name!r}: the centres of joints {at_node[0].name!r} and {j.name!r} in link "
                        f"{b!r} differ ({centres[0]} and {c}); a node's joints share one centre"
                    )
            self.node_links[node.name].append(NodeLink(b, node.name, at_node[0], kj, known))
        for jn in node.joints:
            j = d.joint(jn)
            if j.parent not in comp or j.child not in comp:
                raise ValueError(
                    f"node {node.name!r}: joint {jn!r} joins {j.parent!r} and {j.child!r}; a node's joints join "
                    f"two of its links"
                )

    def _locate_set(self, node: str) -> set[tuple[str, str]]:
        return set(next(n for n in self.desc.nodes if n.name == node).locate)

    def _node_constraints(self, node) -> None:
        links = {nl.link: nl for nl in self.node_links[node.name]}
        for m, (link, kind) in enumerate(node.locate):
            where = f"node {node.name!r}: locate[{m}] {link}.{kind}"
            if link not in links:
                raise ValueError(f"{where}: {link!r} is not a link at the node (its links: {', '.join(links)})")
            if kind == "plane" and not links[link].has_plane:
                raise ValueError(
                    f"{where}: link {link!r} has no plane: its joint {links[link].known_joint.name!r} to "
                    f"{links[link].known_body!r} is a {links[link].known_joint.type}, and only a revolute there "
                    f"keeps the link in a plane across its axis"
                )
        self._check_node_located(node)
        eqs = []
        for nl in self.node_links[node.name]:
            for kind in ("distance", "plane"):
                if (nl.link, kind) in node.locate or (kind == "plane" and not nl.has_plane):
                    continue
                eq = NodeEquation(node.name, nl, kind)
                (self.dependent if self._identically_zero(eq) else eqs).append(eq)
        self.node_equations[node.name] = eqs

    def _random_envs(self, count: int, seed: int = 0):
        rng = np.random.default_rng(seed)
        for _ in range(count):
            x = rng.uniform(-1.0, 1.0, len(self.desc.output.coordinates))
            q = rng.uniform(-1.0, 1.0, sum(1 for j in self.desc.joints if j.actuated))
            xenv = {c: x[k] for k, c in enumerate(self.desc.output.coordinates)}
            acts = [j for j in self.desc.joints if j.actuated]
            qenv = {a.variable: q[k] for k, a in enumerate(acts)}
            yield xenv, qenv

    def _check_node_located(self, node) -> None:
        """The two planes must cross in a line, and ``toward`` must not be across it (checked at
        random poses)."""
        for xenv, qenv in self._random_envs(3, seed=1):
            info = self._node_geometry(node.name, xenv, qenv, self._numeric_env, {})
            if not np.all(np.isfinite(np.asarray(info["uu"], dtype=float))) or float(info["uu"]) < 1e-12:
                raise ValueError(
                    f"node {node.name!r}: the planes of locate ({', '.join(f'{a}.{b}' for a, b in node.locate)}) "
                    f"are parallel, so they do not give a line; locate by two planes that cross"
                )
            if abs(float(info["side"])) < 1e-9:
                raise ValueError(
                    f"node {node.name!r}.toward: across the line of the two planes, so it does not pick one of "
                    f"the two points; give a direction along that line"
                )

    def _identically_zero(self, eq: NodeEquation) -> bool:
        """True when the constraint holds for every x and q once the node is located (a duplicate
        plane, as in P3 B's five-bar, whose two rods turn in the plane y = -a), checked at random
        poses where the node exists."""
        finite = 0
        for xenv, qenv in self._random_envs(40, seed=2):
            v = float(self._node_row(eq, xenv, qenv, self._numeric_env, {}))
            if not np.isfinite(v):
                continue
            if abs(v) > 1e-9:
                return False
            finite += 1
            if finite == 3:
                return True
        return False

    def _node_loop(self, where, lp, visited, end, node_link_of, elem_of_joint, looped):
        """The equations of a loop through a node: those of the link it leaves the node by."""
        if any(jn in elem_of_joint for jn in lp):
            raise ValueError(f"{where}: a loop through a node passes through no other connecting element")
        at = [b for b in visited if b in node_link_of]
        first, last = node_link_of[at[0]], node_link_of[at[-1]]
        if first.link == last.link:
            raise ValueError(f"{where}: a loop through node {first.node!r} enters and leaves it by two different links")
        i_last = max(i for i, b in enumerate(visited) if b == last.link)
        after = visited[i_last + 1 :]
        if (
            i_last + 1 >= len(lp)
            or lp[i_last + 1] != last.known_joint.name
            or any(self.side.get(b) is None for b in after)
        ):
            raise ValueError(
                f"{where}: the loop does not close: after node {last.node!r} it must end at the known body "
                f"{last.known_body!r} of link {last.link!r}, through its joint {last.known_joint.name!r}"
            )
        eqs = [eq for eq in self.node_equations[last.node] if eq.link.link == last.link]
        if not eqs:
            raise ValueError(
                f"{where}: the loop closes no constraint: the constraints of link {last.link!r} all locate node "
                f"{last.node!r} or hold identically; write the loop the other way (leaving the node by another link)"
            )
        for eq in eqs:
            if eq in looped:
                raise ValueError(f"{where}: {eq.label} is already in another loop")
        return eqs

    def _node_link_terms(self, nl: NodeLink, xenv, qenv, env, cache):
        """``(P_known, L^2, n, delta)`` of a link at a node: the known end's centre, the squared length,
        and (revolute known end) the plane ``n . (P - P_known) = delta``, else ``n = None``."""
        P_known = self.joint_centre(nl.known_joint, nl.known_body, xenv, qenv, env, cache)
        c_node = _vec(_centre_in(nl.node_joint, nl.link), env, 3)
        c_known = _vec(_centre_in(nl.known_joint, nl.link), env, 3)
        diff = tuple(kin.sub(a, b) for a, b in zip(c_node, c_known))
        L2 = kin.add(*(kin.mul(a, a) for a in diff))
        if not nl.has_plane:
            return P_known, L2, None, 0.0
        kj = nl.known_joint
        axis = kin.unit(_vec(kj.axis, env, 3))
        R_J = kin.rpy_matrix(_vec(kj.rpy, env, 3))
        frame = self.body_frame(nl.known_body, xenv, qenv, env, cache)
        if nl.known_body == kj.parent:  # the link is the child: the axis is `axis` in its frame
            n = kin.matvec(frame[0], kin.matvec(R_J, axis))
            a_link = axis
        else:  # the link is the parent: the axis is R_J axis in its frame
            n = kin.matvec(frame[0], axis)
            a_link = kin.matvec(R_J, axis)
        delta = _dot(diff, a_link)
        return P_known, L2, n, delta

    def _node_geometry(self, node: str, xenv, qenv, env, cache):
        """The node's centre from its ``locate``: the line where the two planes ``n_k . P = d_k`` cross,
        ``P0 + t e`` with ``e = u / |u|``, ``u = n_1 x n_2``,
        ``P0 = (d_1 (n_2 x u) + d_2 (u x n_1)) / |u|^2``; on it the two points at the distance ``L``
        from the centre ``c`` of the distance's link, ``P = P0 - b e +- sqrt(L^2 - |w - b e|^2) e``
        (``w = P0 - c``, ``b = e . w``), the one further along ``toward``. NaN where the line misses
        the sphere."""
        key = ("node", node)
        if key in cache:
            return cache[key]
        nd = next(n for n in self.desc.nodes if n.name == node)
        links = {nl.link: nl for nl in self.node_links[node]}
        planes, sphere = [], None
        for link, kind in nd.locate:
            P_k, L2, n, delta = self._node_link_terms(links[link], xenv, qenv, env, cache)
            if kind == "plane":
                planes.append((n, kin.add(_dot(n, P_k), delta)))
            else:
                sphere = (P_k, L2)
        (n1, d1), (n2, d2) = planes
        u = _cross(n1, n2)
        uu = _dot(u, u)
        num = tuple(kin.add(kin.mul(d1, a), kin.mul(d2, b)) for a, b in zip(_cross(n2, u), _cross(u, n1)))
        P0 = tuple(_div(a, uu) for a in num)
        norm = _sqrt(uu)
        e = tuple(_div(a, norm) for a in u)
        c, L2 = sphere
        w = tuple(kin.sub(a, b) for a, b in zip(P0, c))
        b = _dot(e, w)
        perp = tuple(kin.sub(a, kin.mul(b, ek)) for a, ek in zip(w, e))
        disc = kin.sub(L2, _dot(perp, perp))
        toward = tuple(kin.const(t(env)) for t in nd.toward)
        side = _dot(e, toward)
        sign = (1.0 if side >= 0 else -1.0) if isinstance(side, float) else jnp.where(side >= 0.0, 1.0, -1.0)
        root = kin.mul(sign, _sqrt(disc))
        P = tuple(kin.add(kin.sub(p0, kin.mul(b, ek)), kin.mul(root, ek)) for p0, ek in zip(P0, e))
        out = {"P": P, "uu": uu, "side": side}
        cache[key] = out
        return out

    def node_point(self, node: str, xenv, qenv, env, cache):
        """World position of a node's centre (README, "Nodes")."""
        return self._node_geometry(node, xenv, qenv, env, cache)["P"]

    def _node_row(self, eq: NodeEquation, xenv, qenv, env, cache):
        """``|P - P_known|^2 - L^2`` (distance) or ``n . (P - P_known) - delta`` (plane) at the located node."""
        P = self.node_point(eq.node, xenv, qenv, env, cache)
        P_k, L2, n, delta = self._node_link_terms(eq.link, xenv, qenv, env, cache)
        diff = tuple(kin.sub(a, b) for a, b in zip(P, P_k))
        if eq.kind == "distance":
            return kin.sub(kin.add(*(a * a if not isinstance(a, float) else a * a for a in diff)), L2)
        return kin.sub(_dot(n, diff), delta)

    def _plane_element(self, comp, bj, oj, base_body, out_body, p: Joint, label) -> Element:
        """An R-P arm (README, "How the constraints are generated"): the base end is a revolute (its
        parent the base-side body, its child the first link), the passive prismatic ``p`` (parent:
        that link) slides across the revolute's axis, so the output-end centre keeps its offset
        ``d`` along the axis: ``F = n . (P_base - P_out) + d``."""
        if self.desc.space != "spatial":
            raise ValueError(
                f"{label}: a revolute then a passive prismatic is a plane joint pair in the plane: it constrains "
                f"nothing; accepted in a spatial description only"
            )
        if bj.type != "revolute" or bj.parent != base_body:
            raise ValueError(
                f"joint {bj.name!r}: the base end of an R-P arm ({label}, passive prismatic {p.name!r}) must be a "
                f"revolute whose parent is the base-side body {base_body!r}, got a {bj.type} with parent {bj.parent!r}"
            )
        link_b = bj.child
        if p.parent != link_b:
            raise ValueError(
                f"joint {p.name!r}: the prismatic of {label} must have as parent the link on the base side "
                f"({link_b!r}), got {p.parent!r}"
            )
        e = Element((link_b, p.child), bj, oj, base_body, out_body, p, kind="plane")
        env = self._numeric_env
        u, _ = self._arm_terms(e, env)
        axis = kin.unit(_vec(bj.axis, env, 3))
        if all(isinstance(v, float) for v in (*u, *axis)) and abs(float(_dot(u, axis))) > 1e-9:
            raise ValueError(
                f"joint {p.name!r}: the prismatic of the R-P arm {label} must slide across the axis of the "
                f"revolute {bj.name!r} (u . n = {float(_dot(u, axis)):.3g}, not 0), so that its end stays in a plane"
            )
        return e

    def _arm_terms(self, e: Element, env):
        """``(u, d)`` of an R-P arm, in the first link's frame: the prismatic's unit direction and the
        offset ``d = (c_out(0) - c_base) . n`` along the revolute axis ``n`` of the output-end centre
        (at prismatic value 0) from the base-end centre."""
        p = e.prismatic
        dim = self.dim
        cA = _vec(_centre_in(e.base_joint, e.links[0]), env, dim)
        cB = _vec(_centre_in(e.out_joint, e.links[1]), env, dim)
        frames = [
            self.joint_frame(
                _vec(p.at, env, dim),
                _vec(p.rpy, env, len(p.rpy)),
                _vec(p.axis, env, dim),
                p.child_at and _vec(p.child_at, env, dim),
                "prismatic",
                v,
            )
            for v in (0.0, 1.0)
        ]
        end0, end1 = (self.point(f, cB) for f in frames)
        u = tuple(kin.sub(a, b) for a, b in zip(end1, end0))
        axis = kin.unit(_vec(e.base_joint.axis, env, dim))
        d = _dot(tuple(kin.sub(a, b) for a, b in zip(end0, cA)), axis)
        return u, d

    def _plane_terms(self, e: Element, xenv, qenv, env, cache):
        """``(n, d)`` of an R-P arm: the revolute's axis in the world and the offset along it."""
        bj = e.base_joint
        axis = kin.unit(_vec(bj.axis, env, 3))
        frame = self.body_frame(e.base_body, xenv, qenv, env, cache)
        n = kin.matvec(frame[0], kin.matvec(kin.rpy_matrix(_vec(bj.rpy, env, 3)), axis))
        return n, self._arm_terms(e, env)[1]

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
        at, rpy, axis = _vec(p.at, env, dim), _vec(p.rpy, env, len(p.rpy)), _vec(p.axis, env, dim)
        child_at = p.child_at and _vec(p.child_at, env, dim)
        zero_frame, one_frame = (self.joint_frame(at, rpy, axis, child_at, "prismatic", v) for v in (0.0, 1.0))
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

    def _body_dependencies(self, body: str) -> set[int]:
        out = set()
        while self.side.get(body) == "base" and body != BASE:
            j = self.tree[body]
            if j.actuated:
                out.add(self.actuator_index[j.variable])
            body = j.parent
        return out

    def _dependencies(self, e) -> set[int]:
        if isinstance(e, NodeEquation):
            links = [
                nl
                for nl in self.node_links[e.node]
                if (nl.link, "plane") in self._locate_set(e.node) or (nl.link, "distance") in self._locate_set(e.node)
            ]
            out = set()
            for nl in (*links, e.link):
                out |= self._body_dependencies(nl.known_body)
            return out
        out = set()
        body = e.base_body
        while body != BASE:
            j = self.tree[body]
            if j.actuated:
                out.add(self.actuator_index[j.variable])
            body = j.parent
        if e.prismatic is not None and e.prismatic.actuated:
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
        """``F_k = |P_out - P_base|^2 - L_k^2`` for element ``e`` (see the module docstring); for an
        R-P arm ``F_k = n . (P_base - P_out) + d``; for a node's equation :meth:`_node_row`."""
        if isinstance(e, NodeEquation):
            return self._node_row(e, xenv, qenv, env, cache)
        pb = self.joint_centre(e.base_joint, e.base_body, xenv, qenv, env, cache)
        po = self.joint_centre(e.out_joint, e.out_body, xenv, qenv, env, cache)
        if e.kind == "plane":
            n, d = self._plane_terms(e, xenv, qenv, env, cache)
            return kin.add(_dot(n, tuple(kin.sub(a, b) for a, b in zip(pb, po))), d)
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
        for n in self.desc.nodes:
            P = self.node_point(n.name, xenv, qenv, env, cache)
            for jn in n.joints:
                pts[jn] = P
        for e in self.elements:
            if e.kind == "plane":  # the foot of the output end on the revolute's axis
                pb, po = pts[e.base_joint.name], pts[e.out_joint.name]
                nn, _ = self._plane_terms(e, xenv, qenv, env, cache)
                t = _dot(nn, tuple(kin.sub(a, b) for a, b in zip(po, pb)))
                pts[e.prismatic.name] = tuple(kin.add(b, kin.mul(t, c)) for b, c in zip(pb, nn))
            elif e.prismatic is not None:  # on the line of centres, at its distance from the base end
                pb = pts[e.base_joint.name]
                po = pts[e.out_joint.name]
                cA = _vec(_centre_in(e.base_joint, e.links[0]), env, self.dim)
                at = _vec(e.prismatic.at, env, self.dim)
                s = jnp.sqrt(sum((a - b) ** 2 for a, b in zip(at, cA)))
                dist = jnp.sqrt(sum((a - b) ** 2 for a, b in zip(po, pb)))
                pts[e.prismatic.name] = tuple(b + (a - b) * s / dist for a, b in zip(po, pb))
        return {k: jnp.stack(jnp.broadcast_arrays(*v)) for k, v in pts.items()}
