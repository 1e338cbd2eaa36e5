"""``load_mechanism``: a :class:`pkmlib.Mechanism` from a description file (``data/mechanisms/``)."""

from __future__ import annotations

import dataclasses
from typing import Any

import jax.numpy as jnp

from .._mechanism import Mechanism
from ._closures import Closure
from ._format import Description, parse_description

Array = Any


@dataclasses.dataclass(frozen=True, kw_only=True)
class LoadedMechanism(Mechanism):
    """A :class:`pkmlib.Mechanism` built from a description, with what numerical solvers and
    drawings need besides ``F``.

    Attributes (besides :class:`pkmlib.Mechanism`'s):
        description: the parsed :class:`Description` (names, units, joints, loops, the paper).
        actuator_kinds: ``"revolute"`` or ``"prismatic"`` for each actuated coordinate ``q``. In a
            chainwise mechanism whose chain ``i`` has one actuated joint before its element,
            ``F_i`` is ``a cos(q_i) + b sin(q_i) + c`` (revolute: the base-side point turns on a
            circle) or a quadratic in ``q_i`` (prismatic, or an RPR leg's length), with ``a, b, c``
            functions of ``x``: a numerical inverse can find every root of each chain.
        closure: the analysed structure (:class:`Closure`: sides, connecting elements, the
            Gruebler-Kutzbach terms in ``closure.gruebler_terms``).
    """

    description: Description | None = dataclasses.field(default=None, compare=False, repr=False)
    closure: Closure | None = dataclasses.field(default=None, compare=False, repr=False)
    actuator_kinds: tuple[str, ...] = ()

    def joint_points(self, x: Array, q: Array, params: Any = None) -> dict[str, Array]:
        """Every joint centre at pose ``x`` and actuators ``q``: ``{joint name: (dim, *batch)}``
        (in the description's length unit; ``params`` defaults to :attr:`params`). The
        centres of an RPR leg's prismatic lie on the line of the leg, at their distance from its
        base end."""
        return self.closure.joint_points(x, q, self.params if params is None else params)

    @property
    def mobility(self) -> int:
        """The Gruebler-Kutzbach mobility of the description (equals ``n_outputs``)."""
        return self.closure.mobility


def load_mechanism(path_or_dict: Any) -> LoadedMechanism:
    """Load a mechanism description (a ``.yaml`` path or the same content as a dict) as a
    :class:`pkmlib.Mechanism` whose ``F(x, q, params)`` is generated from its joints and loops.

    The format is ``data/mechanisms/README.md``. Each loop gives the squared-distance closure
    ``|P_out(x) - P_base(q)|^2 - L^2`` of its connecting element (P1 eq (1), P2 eq (1), P3
    section 2.3.1); the Gruebler-Kutzbach mobility is checked against the output coordinates.
    The result:

    - ``params``: ``{symbol: value}`` as read from ``data/params/<paper>.json`` (or the numbers
      of a description without a paper); derived values are computed inside ``F`` from them, so
      ``jax.grad`` w.r.t. a length parameter flows through every placement.
    - chainwise (``chain_constraint``) when each equation involves one actuator, ordered so that
      equation ``i`` involves ``q_i``; otherwise ``constraints``.
    - ``inverse_position`` is None (positions are solved numerically by :meth:`Mechanism.inverse`).
    - ``default_branch``: the description's ``default_branch`` (the sign of ``dF_i/dq_i``, the
      diagonal of B, for each chain), or None.
    - ``actuator_limits`` from the joints' ``limits`` (else +-inf), names and units from the
      description (revolute actuators in its angle unit, prismatic in its length unit).

    Raises ``ValueError`` naming the body, joint or key for any description it does not accept.
    """
    desc = parse_description(path_or_dict)
    try:
        closure = Closure(desc)
    except ValueError as e:
        pre = f"{desc.source}: " if desc.source != "<dict>" else ""
        raise ValueError(f"{pre}{e}") from None
    acts = closure.actuators

    def actuator_limits(params):
        env = desc.parameter_env(params)
        lo = [jnp.asarray(a.limits[0](env) if a.limits else -jnp.inf, dtype=jnp.float64) for a in acts]
        hi = [jnp.asarray(a.limits[1](env) if a.limits else jnp.inf, dtype=jnp.float64) for a in acts]
        return jnp.stack(lo), jnp.stack(hi)

    kinds = tuple(a.type for a in acts)
    units = tuple(desc.angle_unit if k == "revolute" else desc.length_unit for k in kinds)
    chain = closure.chain_constraint if closure.chainwise else None
    cons = None if closure.chainwise else closure.constraints
    return LoadedMechanism(
        name=desc.name,
        chain_constraint=chain,
        constraints=cons,
        actuator_limits=actuator_limits,
        output_names=desc.output.coordinates,
        output_units=desc.output.units,
        actuator_names=tuple(a.variable for a in acts),
        actuator_units=units,
        default_branch=desc.default_branch,
        inverse_position=None,
        params=dict(desc.parameters),
        description=desc,
        closure=closure,
        actuator_kinds=kinds,
    )
