"""What a mechanism is, for pkmlib: constraint equations plus position solutions.

A mechanism with output coordinates ``x`` (n_x values) and actuated coordinates ``q``
(n values) is described by its constraint function ``F(x, q, params) -> R^n`` (one equation per
kinematic chain, P1 eq (1), P2 eq (1)), its inverse position solution with an explicit branch
choice, and its actuator limits. Everything else (A, B, J^-1, J, det(A), det(B), the criteria)
is derived from these by automatic differentiation in :mod:`pkmlib._jacobians`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

import jax.numpy as jnp
import numpy as np

from . import _config  # noqa: F401  (float64)
from ._validation import check_array, check_branch, check_callable, check_text, concrete, nan_unless_signs

Array = Any


@dataclasses.dataclass(frozen=True, kw_only=True)
class Mechanism:
    """A parallel mechanism given by its constraint equations.

    Give either ``chain_constraint`` (a "fully parallel" mechanism, where each equation
    involves one actuated coordinate) or ``constraints`` (any mechanism).

    Attributes:
        name: human-readable name.
        chain_constraint: ``F_i(i, x, q_i, params)`` for chain ``i`` (a Python int); zero when
            the pose ``x`` and the actuated coordinate ``q_i`` are compatible. ``x`` may be an
            array or a tuple of per-coordinate arrays and is only indexed, ``x[0]``, ``x[1]``...;
            with arrays of points the result is an array of points. Giving it makes the
            mechanism chainwise (B diagonal): pkmlib then builds J^-1 row by row (P2 eq (3)) and
            never forms or factors a general B.
        constraints: ``F(x, q, params) -> (n,)``; derived from ``chain_constraint`` when that
            is given.
        inverse_position: ``q(x, params, branch) -> (n,)``; NaN where ``x`` is outside the
            workspace (no real solution, or an actuator out of its limits). Never raises.
            None for a mechanism without a closed form (e.g. one loaded from a description):
            :meth:`inverse` then solves ``F(x, q) = 0`` numerically.
        actuator_limits: ``params -> (q_min, q_max)``, each ``(n,)``.
        output_names: names of the output coordinates ``x`` (the papers' symbols).
        output_units: units of the output coordinates.
        actuator_names: names of the actuated coordinates ``q``.
        actuator_units: units of the actuated coordinates.
        default_branch: the branch used when none is given: a tuple of signs, each +1 or -1
            (one per +- of the closed-form inverse solution: one per chain for P1, P2, P4; (u, v)
            for P3's mechanism A), or None for a mechanism with one inverse position solution.
            Every branch given to :meth:`inverse` must have its length.
        params: optional parameter values of the mechanism (for a mechanism loaded from a
            description, :func:`pkmlib.load_mechanism`: ``{symbol: value}`` as read from
            ``data/params/<paper>.json``), so that ``pk.det_A(m, x, q, m.params)`` works; None when
            the parameters are given separately. Not compared or hashed.
    """

    name: str
    actuator_limits: Callable[[Any], tuple[Array, Array]]
    output_names: tuple[str, ...]
    output_units: tuple[str, ...]
    actuator_names: tuple[str, ...]
    actuator_units: tuple[str, ...]
    chain_constraint: Callable[..., Array] | None = None
    constraints: Callable[..., Array] | None = None
    default_branch: tuple[int, ...] | None = None
    inverse_position: Callable[..., Array] | None = None
    params: Any = dataclasses.field(default=None, compare=False)

    def __post_init__(self):
        self._check_fields()
        if self.chain_constraint is not None and getattr(self.constraints, "_derived_from_chains", False):
            object.__setattr__(self, "constraints", None)  # dataclasses.replace() passes it back
        if (self.chain_constraint is None) == (self.constraints is None):
            raise ValueError(f"{self.name}: give exactly one of chain_constraint and constraints")
        if self.chain_constraint is not None:
            chain = self.chain_constraint
            n = len(self.actuator_names)

            def constraints(x, q, params):
                return jnp.stack([chain(i, x, q[i], params) for i in range(n)])

            constraints._derived_from_chains = True
            object.__setattr__(self, "constraints", constraints)
        if self.default_branch is not None:
            try:
                n = len(self.default_branch)
            except TypeError:
                raise ValueError(
                    f"{self.name}: default_branch must be a sequence of signs (+1 or -1) or None, "
                    f"got {self.default_branch!r}"
                ) from None
            object.__setattr__(
                self, "default_branch", check_branch(self.default_branch, n, f"{self.name}: default_branch")
            )

    def _check_fields(self):
        """``ValueError`` naming the field unless: ``name`` a non-empty string; the functions
        callable; ``output_names``/``actuator_names`` at least one name each, ``output_units``/
        ``actuator_units`` one unit per name (non-empty strings; lists are stored as tuples)."""
        check_text("Mechanism: name", self.name)
        check_callable(f"{self.name}: actuator_limits", self.actuator_limits, "a function params -> (q_min, q_max)")
        for field, accepted in (
            ("chain_constraint", "a function (i, x, q_i, params) -> F_i, or None"),
            ("constraints", "a function (x, q, params) -> F, or None"),
            ("inverse_position", "a function (x, params, branch) -> q, or None"),
        ):
            value = getattr(self, field)
            if value is not None:
                check_callable(f"{self.name}: {field}", value, accepted)
        for names, units in (("output_names", "output_units"), ("actuator_names", "actuator_units")):
            n = None
            for field in (names, units):
                value = getattr(self, field)
                if isinstance(value, (str, bytes)) or not isinstance(value, (tuple, list)):
                    raise ValueError(f"{self.name}: {field} must be a tuple of strings, got {value!r}")
                if not value or not all(isinstance(v, str) and v for v in value):
                    raise ValueError(
                        f"{self.name}: {field} must be a tuple of one or more non-empty strings, got {value!r}"
                    )
                if n is not None and len(value) != n:
                    raise ValueError(
                        f"{self.name}: {field} must have one unit per name of {names} ({n}), got {value!r}"
                    )
                if field == names and len(set(value)) != len(value):
                    raise ValueError(f"{self.name}: {field} must be different names, got {value!r}")
                n = len(value)
                object.__setattr__(self, field, tuple(value))

    def general(self) -> Mechanism:
        """The same mechanism on the general (non-chainwise) Jacobian path: its full F, the full
        B = dF/dq and a linear solve for J^-1 (P1 eq (3)-(4)) instead of the row-by-row fast path.
        For checking the fast path, or for timing both."""
        return dataclasses.replace(
            self, chain_constraint=None, constraints=self.constraints, name=f"{self.name} (general path)"
        )

    @property
    def chainwise(self) -> bool:
        """True when each ``F_i`` involves ``q_i`` only (B diagonal; P1 eq (2), P2 eq (2))."""
        return self.chain_constraint is not None

    @property
    def branch_size(self) -> int:
        """Number of signs in a branch (``len(default_branch)``; 0 when there is none)."""
        return 0 if self.default_branch is None else len(self.default_branch)

    @property
    def n_outputs(self) -> int:
        return len(self.output_names)

    @property
    def n_actuators(self) -> int:
        return len(self.actuator_names)

    def inverse(self, x: Array, params: Any, branch: Array | None = None) -> Array:
        """Inverse position solution on ``branch`` (default: ``default_branch``).

        ``branch`` holds one sign per actuator, each +1 or -1 (the choice of the paper's +- in
        the closed-form solution, e.g. P1 after eq (1)). A concrete branch of the wrong length or
        with other entries raises ``ValueError`` naming ``branch``; a branch traced by
        ``jit``/``vmap`` is checked for its length, and the result is NaN where its entries are not
        +-1 (no exception can be raised from traced values).

        Without a closed form (``inverse_position=None``) this is
        :func:`pkmlib.inverse_positions`: ``branch`` is then the sign of ``dF_i/dq_i`` at the
        solution for each actuator (the default: ``default_branch``).
        """
        if self.inverse_position is None:
            from ._positions import (
                inverse_positions,  # numerical: F(x, q) = 0 on the sign rule
            )

            return inverse_positions(self, x, params, branch)
        shape = (len(x),) if isinstance(x, tuple) else getattr(x, "shape", None)
        if shape is None:
            shape = check_array("x", x).shape
        if not shape or shape[0] != self.n_outputs:  # a 3-vector for a planar pose was read as its first two
            raise ValueError(
                f"x must hold {self.n_outputs} coordinates {tuple(self.output_names)} of {self.name} on its "
                f"first axis (then batch axes), got shape {tuple(shape)}"
            )
        if branch is None:
            branch = self.default_branch
        if self.default_branch is None:
            if branch is not None:
                raise ValueError(
                    f"{self.name}: branch must be None (this mechanism has a single inverse "
                    f"position solution; no default_branch), got {branch!r}"
                )
            return self.inverse_position(x, params, None)
        branch = check_branch(branch, self.branch_size)
        if isinstance(branch, tuple):
            return self.inverse_position(x, params, jnp.asarray(branch, dtype=jnp.float64))
        branch = jnp.asarray(branch, dtype=jnp.float64)
        return nan_unless_signs(self.inverse_position(x, params, branch), branch)


def within_limits(q: Array, q_min: Array, q_max: Array) -> Array:
    """Return ``q`` where every actuator is inside ``[q_min, q_max]``, else all-NaN.

    Used by inverse position solutions so that a pose outside the workspace gives NaN, never an
    exception (the check works under ``jit`` and ``vmap``). ``q`` may be ``(n,)`` or
    ``(n, *batch)``; the limits are scalars or ``(n,)`` (infinite for no limit).

    Limits known now (not traced) must not be NaN and must have ``q_min <= q_max`` (``ValueError``
    naming ``q_min``/``q_max`` otherwise); traced limits with ``q_min > q_max`` or NaN give NaN
    (no ``q`` is inside them). Shapes are checked in both cases.
    """
    q = check_array("q", q, min_ndim=1, what="actuated coordinates (n, *batch)")
    n = q.shape[0]
    q_min = check_array("q_min", q_min)
    q_max = check_array("q_max", q_max)
    for name, v in (("q_min", q_min), ("q_max", q_max)):
        if v.shape not in ((), (n,)):
            raise ValueError(f"{name} must be one number or ({n},) (one per actuator), got shape {v.shape}")
    lo, hi = concrete(q_min), concrete(q_max)
    if lo is not None and hi is not None:
        if np.any(np.isnan(lo)) or np.any(np.isnan(hi)):
            raise ValueError(
                f"q_min and q_max must be numbers (-inf/inf for no limit), got {lo.tolist()}, {hi.tolist()}"
            )
        if np.any(lo > hi):
            raise ValueError(
                f"q_min must be <= q_max for every actuator, got q_min {lo.tolist()} and q_max {hi.tolist()}"
            )
    if q_min.ndim:
        q_min = q_min.reshape(q_min.shape + (1,) * (q.ndim - 1))
    if q_max.ndim:
        q_max = q_max.reshape(q_max.shape + (1,) * (q.ndim - 1))
    inside = jnp.all((q >= q_min) & (q <= q_max), axis=0)
    return jnp.where(inside, q, jnp.nan)
