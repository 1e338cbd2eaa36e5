"""P3: two 2T1R parallel mechanisms, A and B, with the same joints in a different order.

Shen, Zhong, Li, Li, Trans. CSAM 2023, 54(7), 412-426 ("P3"), section 2.

Both mechanisms have three parallel rails along x: carriages ``A1 = (x1, -a, 0)``,
``A2 = (x2, -a, 0)``, ``A3 = (x3, a, 0)``, each carrying a post of height ``l1`` to
``B_i = A_i + (0, 0, l1)``. ``B1, B2`` drive a planar five-bar in the plane ``y = -a`` whose
coupler point is ``C = C1 = C2 = C3 = (x_C, -a, l1 + H)``, ``x_C = (x1 + x2)/2``,
``H = sqrt(l2^2 - ((x2 - x1)/2)^2)`` (P3 eq (11); the paper's assembly has C above ``B1B2``,
``H > 0``; the other assembly is available as ``h = -1``).

Mechanism A (P3 section 2.1.1, Fig 4): the platform ``C3 D`` (length ``l3``) turns about the x axis
at ``C3``: ``D = (x_C, -a + l3 cos(alpha), l1 + H + l3 sin(alpha))`` (P3 eq (12)); the link
``D B3`` has length ``l4``. Output ``(x, z, alpha)`` of ``C3`` (``y = -a`` is constant).

Mechanism B (P3 section 2.1.2, Fig 5): the link ``C3 D`` (length ``l3``) turns about the x axis at
``C3``, the platform ``D E`` (length ``l4``) ends at ``E = (x_C, a, z_E)``,
``D = E - l4 (0, sin(alpha), cos(alpha))``, and ``E B3`` has length ``l5``.
Output ``(x, z, alpha)`` of ``E`` (``y = a`` is constant).

Units: one convention for the whole module, kinematics and dynamics alike, the paper's: lengths
and actuator coordinates in mm (P3's tables and figures), angles in rad, time in s, masses in kg,
moments of inertia in kg mm^2 (P3 Tables 3-4 as printed), forces in N. The dynamics models take
``q`` in mm and give body centres in mm; the only conversion is inside :func:`actuator_forces`,
which states it. Every kinematic function broadcasts over trailing axes: ``q`` and ``x`` may be
``(3,)`` or ``(3, *batch)``. Positions outside the workspace give NaN.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from typing import Any, Mapping

import jax
import jax.numpy as jnp
import numpy as np
from jax.tree_util import Partial

from .. import _config  # noqa: F401  (float64)
from .._pytree import pytree_dataclass
from .._reference import claim_reference, compare_reference, load_reference_file, paper_value
from .._grid import Grid
from .._jacobians import A_matrix, B_matrix, det_A, det_B
from .._sweep import sweep
from .._inverse_dynamics import inverse_dynamics_lagrange, inverse_dynamics_virtual_work, state_trajectory
from .._mechanism import Mechanism, within_limits
from .._screws import rot_x
from .._notebook_parameters import check_parameter, number, numbers, text
from .._validation import check_first_axis, check_number, check_positive, check_range
from ._contract import deprecated_names, load_paper_params, stack_pose

Array = Any

#: The paper's key in the registry (:mod:`pkmlib._papers`).
PAPER = "p3"

#: The notebook's parameters with the paper's values and what each accepts
#: (``pk.tools.check_parameters(globals(), STUDY_PARAMETERS)``): the study conditions of P3 (its actuator
#: box sampled for the workspaces, the motion of section 3.1), B's input and the files.
STUDY_PARAMETERS = {
    "step_mm": number(5.0, min=0.0, min_open=True, unit="mm"),
    "voxel_mm": number(10.0, min=0.0, min_open=True, unit="mm"),
    "section_halfwidth_mm": number(2.5, min=0.0, min_open=True, unit="mm"),
    "t_end_s": number(5.0, min=0.0, min_open=True, max=1e3, unit="s"),
    "n_t": number(501, min=2, max=1e6, integer=True),
    "inputs_B_mm": numbers([-106.09, 181.67, -70.29], shape=(3,), min=-1e4, max=1e4, unit="mm"),
    "params_file": text("p3"),
    "results_path": text("../data/results/p3.json", output=True),
    "figures_dir": text("../figures", output=True),
}
#: The module's unit convention, the paper's (see the module docstring).
UNITS = {"length": "mm", "angle": "rad", "time": "s", "mass": "kg", "inertia": "kg mm^2", "force": "N"}
#: Inverse-position branches the paper's analysis uses, by mechanism: A's ``(u, v)`` of P3 eq (14)
#: is Table 2 row 4 (the set input of Table 1), B's ``(u, v, w)`` of eq (16)-(17) returns the
#: input of our Table 1 for B.
PAPER_BRANCH = {"A": (-1.0, -1.0), "B": (-1.0, -1.0, -1.0)}
#: Every inverse-position branch, by mechanism: A's four ``(u, v)`` of P3 eq (14) in the order of
#: Table 2 (rows 1-4), B's eight ``(u, v, w)`` of eq (16)-(17).
INVERSE_BRANCHES = {
    "A": ((1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)),
    "B": tuple((u, v, w) for u in (1.0, -1.0) for v in (1.0, -1.0) for w in (1.0, -1.0)),
}
#: Every branch of the closed-form forward positions, by mechanism: A's sign ``m`` of P3 eq (13)
#: in the order of Table 1 (row 1, ``m = +1``: alpha = -0.7097 rad, the configuration of Fig 6a
#: that the paper uses afterwards; row 2, ``m = -1``: alpha = 0.2547 rad), B's four ``(n, m)`` of
#: eq (15).
FORWARD_BRANCHES = {"A": (1.0, -1.0), "B": ((1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0))}


def _sqrt(r: Array) -> Array:
    """Square root that is NaN (not an error) for a negative radicand: outside the workspace."""
    return jnp.sqrt(jnp.where(r >= 0.0, r, jnp.nan))


def _half_angle(N1: Array, N2: Array, N3: Array, m: Array) -> Array:
    """Root of ``N1 sin(alpha) + N2 cos(alpha) = N3`` by the tangent half-angle substitution:
    ``alpha = 2 arctan((N1 + m sqrt(N1^2 + N2^2 - N3^2)) / (N2 + N3))`` (P3 eq (13) and (15))."""
    return 2.0 * jnp.arctan((N1 + m * _sqrt(N1**2 + N2**2 - N3**2)) / (N2 + N3))


# --------------------------------------------------------------------------- parameters
@dataclasses.dataclass(frozen=True)
class _Lengths:
    a: float
    l1: float
    l2: float
    l3: float
    l4: float


@dataclasses.dataclass(frozen=True)
class _LengthsB(_Lengths):
    l5: float


@dataclasses.dataclass(frozen=True)
class _ActuatorBox:
    """The actuator box (mm) after a mechanism's lengths, and the checked constructor."""

    x1_min: float
    x1_max: float
    x2_min: float
    x2_max: float
    x3_min: float
    x3_max: float

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]):
        """From ``data/params/p3.json`` as :func:`pkmlib.load_params` returns it (the whole file; its
        ``"mechanism_A"`` or ``"mechanism_B"`` object is used) or from that object itself
        (``<name>_mm`` keys). Every value is checked: ``ValueError`` names the key and what is
        accepted."""
        return cls(**_checked(cls, d, cls._SECTION))


@pytree_dataclass
@dataclasses.dataclass(frozen=True)
class ParamsA(_ActuatorBox, _Lengths):
    """Dimensions of mechanism A (mm) and the actuator box (mm). A JAX pytree.

    Lengths ``a, l1 .. l4``, then the box ``x1_min .. x3_max``. Build it with :meth:`from_dict`
    (``data/params/p3.json``, ``"mechanism_A"``), which checks it.
    """

    _SECTION = "mechanism_A"


@pytree_dataclass
@dataclasses.dataclass(frozen=True)
class ParamsB(_ActuatorBox, _LengthsB):
    """Dimensions of mechanism B (mm) and the actuator box (mm). A JAX pytree.

    Lengths ``a, l1 .. l5``, then the box ``x1_min .. x3_max``. Build it with :meth:`from_dict`
    (``data/params/p3.json``, ``"mechanism_B"``), which checks it.
    """

    _SECTION = "mechanism_B"


def _checked(cls, d: Mapping[str, Any], section: str) -> dict[str, float]:
    """Read ``<name>_mm`` keys from ``d[section]`` (the whole params file) or ``d`` (the section):
    lengths must be finite positive numbers, actuator limits finite numbers with ``min <= max``."""
    if not isinstance(d, Mapping):
        raise ValueError(
            f"P3 parameters must be a dict (data/params/p3.json as loaded, or its {section!r} "
            f"object), got {type(d).__name__}: {d!r}"
        )
    if section in d:
        d = d[section]
        if not isinstance(d, Mapping):
            raise ValueError(f"{section!r} must be a dict of P3 parameters, got {type(d).__name__}: {d!r}")
    names = [f.name for f in dataclasses.fields(cls)]
    missing = [f"{n}_mm" for n in names if f"{n}_mm" not in d]
    if missing:
        raise ValueError(
            f"missing P3 parameters: {', '.join(missing)} (expected the keys "
            f"{', '.join(n + '_mm' for n in names)} of {section!r})"
        )
    box = {f.name for f in dataclasses.fields(_ActuatorBox)}
    out = {n: check_number(f"{n}_mm", d[f"{n}_mm"], unit="mm", positive=True) for n in names if n not in box}
    for i in (1, 2, 3):
        lo = check_number(f"x{i}_min_mm", d[f"x{i}_min_mm"], unit="mm")
        hi = check_number(f"x{i}_max_mm", d[f"x{i}_max_mm"], unit="mm")
        out[f"x{i}_min"], out[f"x{i}_max"] = check_range(f"x{i}_mm", lo, hi)
    return out


def actuator_limits(p: ParamsA | ParamsB) -> tuple[Array, Array]:
    """The actuator box ``[x_i_min, x_i_max]`` (P3 section 2.2.1: -250..0, 0..250, -300..300 mm)."""
    return (jnp.array([p.x1_min, p.x2_min, p.x3_min]), jnp.array([p.x1_max, p.x2_max, p.x3_max]))


def _five_bar(q: Array, p: ParamsA | ParamsB, h: Array = 1.0) -> tuple[Array, Array]:
    """``x_C = (x1 + x2)/2`` and ``H = h sqrt(l2^2 - ((x2 - x1)/2)^2)`` of the five-bar
    ``B1 C B2`` (P3 eq (11); the paper takes ``h = +1``)."""
    check_first_axis("q", q, 3, "x1, x2, x3")
    x_C = 0.5 * (q[0] + q[1])
    return x_C, h * _sqrt(p.l2**2 - (0.5 * (q[1] - q[0])) ** 2)


def _stack(*c: Array) -> Array:
    return jnp.stack(jnp.broadcast_arrays(*c))


# --------------------------------------------------------------------------- mechanism A
def forward_a(q: Array, p: ParamsA, m: Array, h: Array = 1.0) -> Array:
    """Forward position of A: ``(x, z, alpha)`` of ``C3`` from ``q = (x1, x2, x3)`` (P3 eq (11)-(13)).

    ``x = (x1 + x2)/2``, ``z = l1 + H`` and ``alpha = 2 arctan((N1 + m sqrt(N1^2 + N2^2 - N3^2)) /
    (N2 + N3))`` with ``N1 = 2 H l3``, ``N2 = -4 a l3``, ``N3 = I - H^2 - l3^2 - 4 a^2``,
    ``I = l4^2 - (x - x3)^2`` (P3 eq (13)). ``m = +-1`` are the two branches; ``h`` is the
    five-bar assembly (paper: +1). NaN where no real solution exists.
    """
    x_C, H = _five_bar(q, p, h)
    I = p.l4**2 - (x_C - q[2]) ** 2
    N1, N2, N3 = 2.0 * H * p.l3, -4.0 * p.a * p.l3 * jnp.ones_like(H), I - H**2 - p.l3**2 - 4.0 * p.a**2
    return _stack(x_C, p.l1 + H, _half_angle(N1, N2, N3, m))


def inverse_a(x: Array, p: ParamsA, branch: Array) -> Array:
    """Inverse position of A (P3 eq (14)), without the actuator box; ``branch = (u, v)``:

    ``x1 = x + u sqrt(l2^2 - (z - l1)^2)``, ``x2 = 2 x - x1``,
    ``x3 = x + v sqrt(l4^2 - (l3 cos(alpha) - 2a)^2 - (l3 sin(alpha) + z - l1)^2)``.
    """
    check_first_axis("x", x, 3, "x, z, alpha")
    xc, zc, al = x[0], x[1], x[2]
    check_first_axis("branch", branch, 2, "(u, v), each +1 or -1")
    x1 = xc + branch[0] * _sqrt(p.l2**2 - (zc - p.l1) ** 2)
    x3 = xc + branch[1] * _sqrt(p.l4**2 - (p.l3 * jnp.cos(al) - 2.0 * p.a) ** 2 - (p.l3 * jnp.sin(al) + zc - p.l1) ** 2)
    return _stack(x1, 2.0 * xc - x1, x3)


def inverse_position_a(x: Array, p: ParamsA, branch: Array) -> Array:
    """:func:`inverse_a` with NaN where an actuator leaves its box (for :class:`pkmlib.Mechanism`)."""
    lo, hi = actuator_limits(p)
    return within_limits(inverse_a(x, p, branch), lo, hi)


def constraints_a(x: Array, q: Array, p: ParamsA) -> Array:
    """Loop-closure equations of A, ``f_i = 0`` (P3 section 2.3.1, rod lengths ``C1B1 = l2``,
    ``C2B2 = l2``, ``DB3 = l4``; squared lengths, mm^2):

    ``f1 = (x - x1)^2 + (z - l1)^2 - l2^2``, ``f2 = (x - x2)^2 + (z - l1)^2 - l2^2``,
    ``f3 = (x - x3)^2 + (l3 cos(alpha) - 2a)^2 + (z + l3 sin(alpha) - l1)^2 - l4^2``.
    Their derivatives are the paper's ``J_o`` (f_ij) and ``-J_i`` (g_ii) entries.
    """
    check_first_axis("x", x, 3, "x, z, alpha")
    xc, zc, al = x[0], x[1], x[2]
    f1 = (xc - q[0]) ** 2 + (zc - p.l1) ** 2 - p.l2**2
    f2 = (xc - q[1]) ** 2 + (zc - p.l1) ** 2 - p.l2**2
    f3 = (xc - q[2]) ** 2 + (p.l3 * jnp.cos(al) - 2.0 * p.a) ** 2 + (zc + p.l3 * jnp.sin(al) - p.l1) ** 2 - p.l4**2
    return jnp.stack([f1, f2, f3])


def _rail_points(q: Array, p: ParamsA | ParamsB, zero: Array) -> dict[str, Array]:
    """The carriages ``A_i`` and the tops ``B_i`` of their posts, common to A and B (P3 Figs 4-5)."""
    check_first_axis("q", q, 3, "x1, x2, x3")
    return {
        "A1": _stack(q[0], zero - p.a, zero),
        "A2": _stack(q[1], zero - p.a, zero),
        "A3": _stack(q[2], zero + p.a, zero),
        "B1": _stack(q[0], zero - p.a, zero + p.l1),
        "B2": _stack(q[1], zero - p.a, zero + p.l1),
        "B3": _stack(q[2], zero + p.a, zero + p.l1),
    }


def joint_points_a(x: Array, q: Array, p: ParamsA) -> dict[str, Array]:
    """Joint centres of A (each ``(3, *batch)``, mm) from the pose and the actuators (P3 Fig 4)."""
    check_first_axis("x", x, 3, "x, z, alpha")
    xc, zc, al = x[0], x[1], x[2]
    zero = jnp.zeros_like(q[0])
    pts = {
        **_rail_points(q, p, zero),
        "C": _stack(xc, zero - p.a, zc),
        "D": _stack(xc, p.l3 * jnp.cos(al) - p.a, zc + p.l3 * jnp.sin(al)),
    }
    return pts


def link_length_errors_a(x: Array, q: Array, p: ParamsA) -> Array:
    """``|B1C| - l2``, ``|B2C| - l2``, ``|DB3| - l4`` in mm (zero when the loops close)."""
    P = joint_points_a(x, q, p)
    d = lambda u, v: jnp.sqrt(jnp.sum((P[u] - P[v]) ** 2, axis=0))  # noqa: E731
    return jnp.stack([d("B1", "C") - p.l2, d("B2", "C") - p.l2, d("D", "B3") - p.l4])


def platform_centre_a(x: Array, p: ParamsA) -> Array:
    """Centre of the platform ``C3 D`` (assumed at its midpoint), ``(3, *batch)`` mm: the point whose
    workspace P3 Fig 8 shows ("动平台上质心", platform centre of mass)."""
    check_first_axis("x", x, 3, "x, z, alpha")
    xc, zc, al = x[0], x[1], x[2]
    return _stack(xc, -p.a + 0.5 * p.l3 * jnp.cos(al), zc + 0.5 * p.l3 * jnp.sin(al))


#: What A and B share: the three carriages and their box.
_ACTUATORS = {
    "actuator_limits": actuator_limits,
    "actuator_names": ("x1", "x2", "x3"),
    "actuator_units": ("mm", "mm", "mm"),
}

mechanism_a = Mechanism(
    name="P3 2T1R mechanism A",
    constraints=constraints_a,
    inverse_position=inverse_position_a,
    output_names=("x", "z", "alpha"),
    output_units=("mm", "mm", "rad"),
    default_branch=PAPER_BRANCH["A"],
    **_ACTUATORS,
)


# --------------------------------------------------------------------------- mechanism B
def forward_b(q: Array, p: ParamsB, branch: Array, h: Array = 1.0) -> Array:
    """Forward position of B: ``(x, z, alpha)`` of ``E`` (P3 eq (15)); ``branch = (n, m)``:

    ``x = (x1 + x2)/2``, ``z_E = l1 + n sqrt(l5^2 - (x - x3)^2)``,
    ``alpha = 2 arctan((N1 + m sqrt(N1^2 + N2^2 - N3^2)) / (N2 + N3))`` with ``N1 = 4 a l4``,
    ``N2 = 2 J l4``, ``N3 = l4^2 + J^2 + 4a^2 - l3^2``, ``J = z_E - l1 - H``. ``h`` is the
    five-bar assembly (paper: +1).
    """
    check_first_axis("branch", branch, 2, "(n, m), each +1 or -1")
    x_C, H = _five_bar(q, p, h)
    z_E = p.l1 + branch[0] * _sqrt(p.l5**2 - (x_C - q[2]) ** 2)
    J = z_E - p.l1 - H
    N1, N2, N3 = 4.0 * p.a * p.l4 * jnp.ones_like(J), 2.0 * J * p.l4, p.l4**2 + J**2 + 4.0 * p.a**2 - p.l3**2
    return _stack(x_C, z_E, _half_angle(N1, N2, N3, branch[1]))


def inverse_b(x: Array, p: ParamsB, branch: Array) -> Array:
    """Inverse position of B (P3 eq (16)-(17)), without the actuator box; ``branch = (u, v, w)``:

    ``x1 = x_E + u sqrt(l2^2 - K)``, ``x2 = 2 x_E - x1``, ``x3 = x_E + v sqrt(l5^2 - (z_E - l1)^2)``,
    ``K = (z_E - l4 cos(alpha) - l1 + w sqrt(l3^2 - (y_E - l4 sin(alpha) + a)^2))^2``, ``y_E = a``.
    """
    check_first_axis("x", x, 3, "x, z, alpha")
    xE, zE, al = x[0], x[1], x[2]
    check_first_axis("branch", branch, 3, "(u, v, w), each +1 or -1")
    H = zE - p.l4 * jnp.cos(al) - p.l1 + branch[2] * _sqrt(p.l3**2 - (2.0 * p.a - p.l4 * jnp.sin(al)) ** 2)
    x1 = xE + branch[0] * _sqrt(p.l2**2 - H**2)
    x3 = xE + branch[1] * _sqrt(p.l5**2 - (zE - p.l1) ** 2)
    return _stack(x1, 2.0 * xE - x1, x3)


def five_bar_height_b(x: Array, p: ParamsB, w: Array) -> Array:
    """``H = z_C - l1`` of B on IK branch ``w`` (the bracket of P3 eq (17)); its sign is the
    five-bar assembly ``h`` the forward solution needs to return to ``x``."""
    return x[1] - p.l4 * jnp.cos(x[2]) - p.l1 + w * _sqrt(p.l3**2 - (2.0 * p.a - p.l4 * jnp.sin(x[2])) ** 2)


def inverse_position_b(x: Array, p: ParamsB, branch: Array) -> Array:
    """:func:`inverse_b` with NaN where an actuator leaves its box (for :class:`pkmlib.Mechanism`)."""
    lo, hi = actuator_limits(p)
    return within_limits(inverse_b(x, p, branch), lo, hi)


def constraints_b(x: Array, q: Array, p: ParamsB) -> Array:
    """Loop-closure equations of B (P3 section 2.3.2: ``C1D = l3`` with ``C`` from ``B1C1 = l2``,
    ``C1B1 = C2B2``, ``EB3 = l5``; mm^2):

    ``f1 = (2a - l4 sin(alpha))^2 + (z_E - l4 cos(alpha) - l1 - sqrt(l2^2 - (x_E - x1)^2))^2 - l3^2``,
    ``f2 = (x_E - x2)^2 - (x_E - x1)^2``, ``f3 = (x_E - x3)^2 + (z_E - l1)^2 - l5^2``.
    ``f1`` couples ``x1`` into the first row, so ``J_i`` is lower triangular, as printed.
    """
    check_first_axis("x", x, 3, "x, z, alpha")
    xE, zE, al = x[0], x[1], x[2]
    H = _sqrt(p.l2**2 - (xE - q[0]) ** 2)
    f1 = (2.0 * p.a - p.l4 * jnp.sin(al)) ** 2 + (zE - p.l4 * jnp.cos(al) - p.l1 - H) ** 2 - p.l3**2
    f2 = (xE - q[1]) ** 2 - (xE - q[0]) ** 2
    f3 = (xE - q[2]) ** 2 + (zE - p.l1) ** 2 - p.l5**2
    return jnp.stack([f1, f2, f3])


def joint_points_b(x: Array, q: Array, p: ParamsB, h: Array = 1.0) -> dict[str, Array]:
    """Joint centres of B (each ``(3, *batch)``, mm) from the pose and the actuators (P3 Fig 5)."""
    check_first_axis("x", x, 3, "x, z, alpha")
    xE, zE, al = x[0], x[1], x[2]
    zero = jnp.zeros_like(q[0])
    _, H = _five_bar(q, p, h)
    return {
        **_rail_points(q, p, zero),
        "C": _stack(0.5 * (q[0] + q[1]), zero - p.a, p.l1 + H),
        "D": _stack(xE, p.a - p.l4 * jnp.sin(al), zE - p.l4 * jnp.cos(al)),
        "E": _stack(xE, zero + p.a, zE),
    }


def link_length_errors_b(x: Array, q: Array, p: ParamsB, h: Array = 1.0) -> Array:
    """``|B1C| - l2``, ``|B2C| - l2``, ``|CD| - l3``, ``|EB3| - l5`` and ``x_C - x_E`` in mm."""
    P = joint_points_b(x, q, p, h)
    d = lambda u, v: jnp.sqrt(jnp.sum((P[u] - P[v]) ** 2, axis=0))  # noqa: E731
    return jnp.stack(
        [d("B1", "C") - p.l2, d("B2", "C") - p.l2, d("C", "D") - p.l3, d("E", "B3") - p.l5, P["C"][0] - P["E"][0]]
    )


def platform_centre_b(x: Array, p: ParamsB) -> Array:
    """Centre of the platform ``D E`` (assumed at its midpoint), ``(3, *batch)`` mm (P3 Fig 10)."""
    check_first_axis("x", x, 3, "x, z, alpha")
    xE, zE, al = x[0], x[1], x[2]
    return _stack(xE, p.a - 0.5 * p.l4 * jnp.sin(al), zE - 0.5 * p.l4 * jnp.cos(al))


mechanism_b = Mechanism(
    name="P3 2T1R mechanism B",
    constraints=constraints_b,
    inverse_position=inverse_position_b,
    output_names=("x_E", "z_E", "alpha"),
    output_units=("mm", "mm", "rad"),
    default_branch=PAPER_BRANCH["B"],
    **_ACTUATORS,
)
#: The paper's mechanisms by key (the contract of :mod:`pkmlib.mechanisms`).
MECHANISMS = {"A": mechanism_a, "B": mechanism_b}


def load_params(key: str, source=None) -> ParamsA | ParamsB:
    """The checked dimensions of mechanism ``key`` (``"A"`` or ``"B"``) from ``data/params/p3.json``
    (or ``source``: another parameter file's name or path, or a dict of its layout)."""
    return load_paper_params(PAPER, {"A": ParamsA.from_dict, "B": ParamsB.from_dict}, key, source)


def pose(x, z, alpha) -> Array:
    """``x = (x, z, alpha)`` (mm, mm, rad) of ``C3`` (A) or ``E`` (B), ``(3,)`` or ``(3, *batch)``."""
    return stack_pose(x, z, alpha)


# --------------------------------------------------------------------------- drawing
_LINKS = {
    "A": (("A1", "B1"), ("A2", "B2"), ("A3", "B3"), ("B1", "C"), ("B2", "C"), ("D", "B3")),
    "B": (("A1", "B1"), ("A2", "B2"), ("A3", "B3"), ("B1", "C"), ("B2", "C"), ("C", "D"), ("E", "B3")),
}
_PLATFORM = {"A": ("C", "D"), "B": ("D", "E")}


def draw(
    ax, x, p: ParamsA | ParamsB, branch=None, *, h=None, rail=(-300.0, 300.0), title: str = "", a: float | None = None
):
    """Draw mechanism A (``p`` a :class:`ParamsA`) or B (a :class:`ParamsB`) at pose ``x`` on a
    3-D matplotlib axis, from the same model as the kinematics: the actuators from the inverse
    position on ``branch`` (default :data:`PAPER_BRANCH`), then the joint points (mm), drawn by
    :func:`draw_points`. For B, ``h`` is the five-bar assembly (default: the sign of
    :func:`five_bar_height_b` on the branch's ``w``). Raises ``ValueError`` outside the
    workspace. Returns ``q``. (``a`` belongs to the old form only.)

    The old form ``draw(ax, which, points, ...)`` still works (it warns): use :func:`draw_points`."""
    if isinstance(x, str):
        warnings.warn(
            "two_t_one_r.draw(ax, which, points, ...) is deprecated; use draw_points(ax, which, "
            "points, ...) or draw(ax, x, p, branch)",
            DeprecationWarning,
            stacklevel=2,
        )
        return draw_points(ax, x, p, rail=rail, a=300.0 if a is None else a, title=title)
    if not isinstance(p, (ParamsA, ParamsB)):
        raise ValueError(f"p must be the ParamsA or ParamsB of the mechanism to draw, got {type(p).__name__}")
    which = "A" if isinstance(p, ParamsA) else "B"
    x = jnp.asarray(x, dtype=jnp.float64)
    mech = MECHANISMS[which]
    branch = mech.default_branch if branch is None else branch
    q = mech.inverse(x, p, branch)
    if not np.all(np.isfinite(np.asarray(q))):
        raise ValueError(f"pose {np.asarray(x)} is outside the workspace of {which} on branch {tuple(branch)}")
    if which == "A":
        points = joint_points_a(x, q, p)
    else:
        h = jnp.sign(five_bar_height_b(x, p, branch[2])) if h is None else h
        points = joint_points_b(x, q, p, h)
    draw_points(ax, which, points, rail=rail, a=p.a, title=title)
    return np.asarray(q)


def draw_points(ax, which: str, points: dict[str, Array], *, rail=(-300.0, 300.0), a: float = 300.0, title: str = ""):
    """Draw mechanism ``which`` ("A" or "B") on a 3-D matplotlib axis from its joint points (mm):
    rails (grey), posts and links (blue), platform (red, thick)."""
    P = {k: np.asarray(v, dtype=float) for k, v in points.items()}
    for y in (-a, a):
        ax.plot(list(rail), [y, y], [0.0, 0.0], color="0.6", lw=1)
    for u, v in _LINKS[which]:
        ax.plot(*zip(P[u], P[v]), color="tab:blue", lw=2)
    u, v = _PLATFORM[which]
    ax.plot(*zip(P[u], P[v]), color="tab:red", lw=4)
    for name, pt in P.items():
        ax.scatter(*pt, color="k", s=8)
        ax.text(*pt, f" {name}", fontsize=10)
    ax.set_xlabel("x, mm")
    ax.set_ylabel("y, mm")
    ax.set_zlabel("z, mm")
    if title:
        ax.set_title(title, fontsize=10)


# --------------------------------------------------------------------------- workspace
def voxel_volume(points: np.ndarray, voxel_mm: float) -> float:
    """Volume (mm^3) of the set of cubic voxels of edge ``voxel_mm`` that contain at least one of
    the finite ``points`` (``(3, N)``): the occupancy estimate of a workspace volume from a point
    cloud swept by the forward solution (P3 section 2.2 gives only the clouds). Host-side NumPy."""
    voxel_mm = check_positive("voxel_mm", voxel_mm)
    P = np.asarray(points, dtype=np.float64).reshape(3, -1)
    P = P[:, np.all(np.isfinite(P), axis=0)]
    if P.shape[1] == 0:
        return 0.0
    idx = np.floor(P / float(voxel_mm)).astype(np.int64)
    idx -= idx.min(axis=1, keepdims=True)
    dims = tuple(int(d) for d in idx.max(axis=1) + 1)
    if math.prod(dims) <= 1 << 27:  # an occupancy grid of at most 128 MiB: one pass, no sort
        occupied = np.zeros(dims, dtype=bool)
        occupied[idx[0], idx[1], idx[2]] = True
        count = int(np.count_nonzero(occupied))
    else:  # a sparse cloud over a huge box: the distinct voxels, sorted
        count = np.unique(idx, axis=1).shape[1]
    return float(count) * float(voxel_mm) ** 3


def discriminant_a(q: Array, p: ParamsA, h: Array = 1.0) -> Array:
    """``N1^2 + N2^2 - N3^2`` of P3 eq (13): the two FK branches of A are real while it is >= 0 and
    meet (output singularity ``f33 = 0``, P3 section 2.3.1 case 3) where it vanishes."""
    x_C, H = _five_bar(q, p, h)
    I = p.l4**2 - (x_C - q[2]) ** 2
    return (2.0 * H * p.l3) ** 2 + (4.0 * p.a * p.l3) ** 2 - (I - H**2 - p.l3**2 - 4.0 * p.a**2) ** 2


def discriminant_b(q: Array, p: ParamsB, n: Array, h: Array = 1.0) -> Array:
    """``N1^2 + N2^2 - N3^2`` of P3 eq (15) on the ``z_E`` branch ``n`` (zero where the m branches of
    B meet: output singularity ``f13 = 0``, P3 section 2.3.2 case 3)."""
    x_C, H = _five_bar(q, p, h)
    J = p.l1 + n * _sqrt(p.l5**2 - (x_C - q[2]) ** 2) - p.l1 - H
    return (4.0 * p.a * p.l4) ** 2 + (2.0 * J * p.l4) ** 2 - (p.l4**2 + J**2 + 4.0 * p.a**2 - p.l3**2) ** 2


# --------------------------------------------------------------------------- motion
def sinusoidal_inputs(t: Array, rho: Array, amplitude: Array, omega: float) -> Array:
    """Actuator inputs ``x_i(t) = rho_i + A_i sin(omega t)`` (P3 section 3.1: A = (20, -10, 20) mm,
    omega = pi rad/s, rho = (-131.07, 181.55, -57.74) mm)."""
    check_first_axis("rho", rho, 3, "one offset per actuator, mm")
    check_first_axis("amplitude", amplitude, 3, "one amplitude per actuator, mm")
    return jnp.asarray(rho) + jnp.asarray(amplitude) * jnp.sin(omega * t)


def platform_motion(
    forward, centre, p, branch, t: Array, rho: Array, amplitude: Array, omega: float
) -> dict[str, Array]:
    """Position, velocity and acceleration of the platform centre (mm, mm/s, mm/s^2) and the pose
    along the sinusoidal inputs (P3 section 3.1, Figs 17 and 19).

    ``forward(q, p, branch)`` is :func:`forward_a` or :func:`forward_b` and ``centre(x, p)`` the
    matching platform centre; the time derivatives are forward-mode JAX derivatives of
    ``centre(forward(q(t)))`` in ``t`` (no finite differences), vectorised over ``t`` with ``vmap``.
    Each value has shape ``(len(t), 3)``; NaN where the motion has left the workspace.
    """

    def position(s):
        return centre(forward(sinusoidal_inputs(s, rho, amplitude, omega), p, branch), p)

    def velocity(s):
        return jax.jvp(position, (s,), (jnp.ones_like(s),))[1]

    def acceleration(s):
        return jax.jvp(velocity, (s,), (jnp.ones_like(s),))[1]

    def pose(s):
        return forward(sinusoidal_inputs(s, rho, amplitude, omega), p, branch)

    t = jnp.asarray(t, dtype=jnp.float64)
    return {
        name: jax.vmap(f)(t)
        for name, f in (("position", position), ("velocity", velocity), ("acceleration", acceleration), ("pose", pose))
    }


# --------------------------------------------------------------------------- dynamics model
def _frame_x_along_in_xz(u: Array) -> Array:
    """Rotation about y taking the body x axis to the unit vector ``u = (ux, 0, uz)``."""
    z, o = jnp.zeros_like(u[0]), jnp.ones_like(u[0])
    return jnp.stack([jnp.stack([u[0], z, -u[2]]), jnp.stack([z, o, z]), jnp.stack([u[2], z, u[0]])])


def _frame_z_along(u: Array) -> Array:
    """The smallest rotation taking the body z axis to the unit vector ``u`` (Rodrigues; no twist)."""
    z = jnp.zeros_like(u[0])
    V = jnp.stack([jnp.stack([z, z, u[0]]), jnp.stack([z, z, u[1]]), jnp.stack([-u[0], -u[1], z])])  # [e_z x u]_x
    return jnp.eye(3) + V + V @ V / (1.0 + u[2])


def _unit(v: Array) -> Array:
    return v / jnp.sqrt(jnp.sum(v * v))


#: Bodies of the dynamics models and what each assumes (P3 section 3.4 gives masses and the
#: inertia Tables 3-4 but no centres of mass or body frames). Centres at link midpoints; inertias
#: in kg mm^2 about the centre, in a body frame with the long axis along the axis of smallest
#: printed inertia; carriages and point masses do not rotate.
BODY_ASSUMPTIONS = {
    "A": (
        ("A1B1, A2B2, A3B3", "carriage + post, translate with x_i; centre at the post midpoint"),
        (
            "B1C1, B2C2",
            "rod in the plane y = -a, centre at its midpoint, body x along B->C (Table 3 Ixx smallest), Table 3 inertia",
        ),
        (
            "platform C3D",
            "rod turning about x by alpha, centre at its midpoint (the workspace point), body y along C3->D (Iyy smallest), Table 3 inertia",
        ),
        (
            "DB3",
            "rigid rod D-B3 (the parallelogram replaced by one link), centre at its midpoint, body z along D->B3 (Izz smallest) with no twist, Table 3 inertia",
        ),
        ("RaRb", "point mass at B3 (moves with carriage 3)"),
        ("RcRd", "point mass at D (moves with the platform end)"),
    ),
    "B": (
        ("A1B1, A2B2, A3B3", "carriage + post, translate with x_i; centre at the post midpoint"),
        ("B1C1, B2C2", "rod in the plane y = -a, centre at its midpoint, body x along B->C, Table 4 inertia"),
        (
            "C3D",
            "rod turning about x, centre at its midpoint, body y along C3->D; inertia: Table 4 row 'DB3' (B has no link DB3; its Iyy is the smallest)",
        ),
        (
            "platform DE",
            "rod turning about x, centre at its midpoint (the workspace point), body y along D->E, Table 4 platform inertia",
        ),
        (
            "EB3 = RaRb + RcRd",
            "the parallelogram as one rod E-B3 of mass m_RaRb + m_RcRd in the plane y = a, centre at its midpoint, slender-rod inertia m l5^2/12 about y and z",
        ),
    ),
}


@pytree_dataclass(meta_fields=("platform_index",))
@dataclasses.dataclass(frozen=True)
class DynamicsModel:
    """The rigid bodies of mechanism A or B for inverse dynamics (a JAX pytree; build it with
    :func:`dynamics_model_a` or :func:`dynamics_model_b`).

    ``pose``: ``pose(q) -> (c, R)``, the centres ``(K, 3)`` in mm and orientations ``(K, 3, 3)`` of
    the K bodies for actuator coordinates ``q`` (mm), a :class:`jax.tree_util.Partial` of
    :func:`body_poses_a` / :func:`body_poses_b` with the geometry and the branch as its
    arguments (so inverse dynamics compile once per mechanism, whatever the values);
    ``masses`` ``(K,)`` kg; ``inertias`` ``(K, 3, 3)`` kg mm^2 in the body frames;
    ``platform_index``: which body is the platform (where a payload acts).
    """

    pose: Partial
    masses: Array
    inertias: Array
    platform_index: int


def _table(d: Any, name: str, keys: tuple[str, ...], shape: tuple[int, ...], unit: str) -> dict[str, Array]:
    """Checked entries ``keys`` of the dict ``d`` (masses or inertia rows of P3 section 3.4)."""
    if not isinstance(d, Mapping):
        raise ValueError(f"{name} must be a dict with the keys {', '.join(keys)}, got {type(d).__name__}: {d!r}")
    missing = [k for k in keys if k not in d]
    if missing:
        raise ValueError(f"{name}: missing {', '.join(missing)} (expected the keys {', '.join(keys)})")
    spec = (
        numbers(None, shape=shape or None, min=0.0, unit=unit)
        if shape
        else number(None, min=0.0, min_open=True, unit=unit)
    )
    out = {}
    for k in keys:
        check_parameter(f"{name}[{k!r}]", d[k], spec)
        out[k] = jnp.asarray(d[k], dtype=jnp.float64)
    return out


def _shared_bodies(P: Mapping[str, Array]) -> tuple[list[Array], list[Array]]:
    """Centres and orientations of the five bodies A and B share, in :data:`BODY_ASSUMPTIONS`
    order: the carriages ``A_iB_i`` (post midpoints, not turning) and the rods ``B1C``, ``B2C``
    (midpoints, body x along B->C) of P3 Figs 2 and 5."""
    mid = lambda u, v: 0.5 * (P[u] + P[v])  # noqa: E731
    eye = jnp.eye(3)
    centres = [mid("A1", "B1"), mid("A2", "B2"), mid("A3", "B3"), mid("B1", "C"), mid("B2", "C")]
    frames = [
        eye,
        eye,
        eye,
        _frame_x_along_in_xz(_unit(P["C"] - P["B1"])),
        _frame_x_along_in_xz(_unit(P["C"] - P["B2"])),
    ]
    return centres, frames


def body_poses_a(q: Array, p: ParamsA, branch: Array) -> tuple[Array, Array]:
    """Centres ``(9, 3)`` (mm) and orientations ``(9, 3, 3)`` of A's bodies (order and assumptions:
    :data:`BODY_ASSUMPTIONS` ``["A"]``) for ``q`` (mm) on FK branch ``branch`` (P3 eq (11)-(13))."""
    x = forward_a(q, p, branch)
    P = joint_points_a(x, q, p)
    c, R = _shared_bodies(P)
    c = jnp.stack([*c, 0.5 * (P["C"] + P["D"]), 0.5 * (P["D"] + P["B3"]), P["B3"], P["D"]])
    eye = jnp.eye(3)
    R = jnp.stack([*R, rot_x(x[2]), _frame_z_along(_unit(P["B3"] - P["D"])), eye, eye])
    return c, R


def body_poses_b(q: Array, p: ParamsB, branch: Array) -> tuple[Array, Array]:
    """Centres ``(8, 3)`` (mm) and orientations ``(8, 3, 3)`` of B's bodies (:data:`BODY_ASSUMPTIONS`
    ``["B"]``) for ``q`` (mm) on FK branch ``branch = (n, m)`` (P3 eq (15))."""
    x = forward_b(q, p, branch)
    P = joint_points_b(x, q, p)
    c, R = _shared_bodies(P)
    c = jnp.stack([*c, 0.5 * (P["C"] + P["D"]), 0.5 * (P["D"] + P["E"]), 0.5 * (P["E"] + P["B3"])])
    u_cd = _unit(P["D"] - P["C"])
    R = jnp.stack(
        [
            *R,
            rot_x(jnp.arctan2(u_cd[2], u_cd[1])),
            rot_x(0.5 * jnp.pi - x[2]),
            _frame_x_along_in_xz(_unit(P["E"] - P["B3"])),
        ]
    )
    return c, R


_MASSES_A = ("A1B1", "A2B2", "A3B3", "B1C1", "B2C2", "C3D", "DB3", "RaRb", "RcRd")
_MASSES_B = ("A1B1", "A2B2", "A3B3", "B1C1", "B2C2", "C3D", "DE", "RaRb", "RcRd")
_INERTIA_ROWS = ("platform", "B1C1", "B2C2", "DB3")


def _shared_inertias(T: Mapping[str, Array]) -> list[Array]:
    """Body-frame inertias of the five bodies A and B share (:func:`_shared_bodies`): the carriages
    (point masses: zero) and the rods ``B1C1``, ``B2C2`` (Tables 3 and 4)."""
    zero = jnp.zeros((3, 3))
    return [zero, zero, zero, jnp.diag(T["B1C1"]), jnp.diag(T["B2C2"])]


def dynamics_model_a(
    p: ParamsA, branch: Array, masses_kg: Mapping[str, Any], inertia_kg_mm2: Mapping[str, Any]
) -> DynamicsModel:
    """The :class:`DynamicsModel` of A on FK branch ``branch`` (the sign m of P3 eq (13)):
    ``masses_kg`` as ``data/params/p3.json`` ``"masses_A_kg"``, ``inertia_kg_mm2`` the principal
    moments of Table 3 (``"inertia_A_table3"``), both checked. Units mm, kg, kg mm^2 (module
    docstring). Assumptions: :data:`BODY_ASSUMPTIONS` ``["A"]``."""
    M = _table(masses_kg, "masses_kg", _MASSES_A, (), "kg")
    T = _table(inertia_kg_mm2, "inertia_kg_mm2", _INERTIA_ROWS, (3,), "kg mm^2")
    masses = jnp.stack([M[k] for k in _MASSES_A])
    zero = jnp.zeros((3, 3))
    inertias = jnp.stack([*_shared_inertias(T), jnp.diag(T["platform"]), jnp.diag(T["DB3"]), zero, zero])
    return DynamicsModel(Partial(body_poses_a, p=p, branch=jnp.asarray(branch, dtype=jnp.float64)), masses, inertias, 5)


def dynamics_model_b(
    p: ParamsB, branch: Array, masses_kg: Mapping[str, Any], inertia_kg_mm2: Mapping[str, Any]
) -> DynamicsModel:
    """The :class:`DynamicsModel` of B on FK branch ``branch = (n, m)`` (P3 eq (15)), from
    ``"masses_B_kg"`` and Table 4 (``"inertia_B_table4"``); see :func:`dynamics_model_a`.
    Assumptions: :data:`BODY_ASSUMPTIONS` ``["B"]``."""
    M = _table(masses_kg, "masses_kg", _MASSES_B, (), "kg")
    T = _table(inertia_kg_mm2, "inertia_kg_mm2", _INERTIA_ROWS, (3,), "kg mm^2")
    branch = jnp.asarray(branch, dtype=jnp.float64)
    if branch.shape != (2,):
        raise ValueError(f"branch of B must be the two signs (n, m) of P3 eq (15), got {branch!r}")
    m_pa = M["RaRb"] + M["RcRd"]
    masses = jnp.stack([M["A1B1"], M["A2B2"], M["A3B3"], M["B1C1"], M["B2C2"], M["C3D"], M["DE"], m_pa])
    I_rod = m_pa * p.l5**2 / 12.0  # kg mm^2
    inertias = jnp.stack(
        [
            *_shared_inertias(T),
            jnp.diag(T["DB3"]),
            jnp.diag(T["platform"]),
            jnp.diag(jnp.stack([0.0 * I_rod, I_rod, I_rod])),
        ]
    )
    return DynamicsModel(Partial(body_poses_b, p=p, branch=branch), masses, inertias, 6)


def sinusoidal_trajectory(rho: Array, amplitude: Array, omega: float) -> Partial:
    """The inputs ``q(t) = rho + A sin(omega t)`` (mm; :func:`sinusoidal_inputs`, P3 section 3.1)
    as a :class:`jax.tree_util.Partial` for :func:`actuator_forces` (compiled once for any values)."""
    return Partial(
        sinusoidal_inputs,
        rho=jnp.asarray(rho, dtype=jnp.float64),
        amplitude=jnp.asarray(amplitude, dtype=jnp.float64),
        omega=jnp.asarray(omega, dtype=jnp.float64),
    )


#: kg -> t (tonne): with lengths in mm and time in s, masses in t and inertias in t mm^2 make a
#: consistent system (the mm-t-s system of FE codes) whose unit of force is exactly the newton.
KG_TO_T = 1e-3
#: m/s^2 -> mm/s^2.
M_TO_MM = 1e3

_METHODS = {"virtual_work": inverse_dynamics_virtual_work, "lagrange": inverse_dynamics_lagrange}


def _external_forces(model: DynamicsModel, payload_N: Array, external_forces_N: Array | None) -> Array:
    K = model.masses.shape[0]
    F = jnp.zeros((K, 3)).at[model.platform_index, 2].add(-jnp.asarray(payload_N, dtype=jnp.float64))
    if external_forces_N is not None:
        ext = jnp.asarray(external_forces_N, dtype=jnp.float64)
        if ext.shape != (K, 3):
            raise ValueError(f"external_forces_N must have shape ({K}, 3) (a force per body, N), got {ext.shape}")
        F = F + ext
    return F


def actuator_forces(
    model: DynamicsModel,
    trajectory,
    t: Array,
    *,
    method: str = "virtual_work",
    payload_N: Array = 0.0,
    gravity_m_s2: Array = (0.0, 0.0, -9.81),
    external_forces_N: Array | None = None,
) -> Array:
    """Actuator forces ``(len(t), 3)`` in N along the inputs ``q = trajectory(t)`` (mm), by
    ``method`` ``"virtual_work"`` (P3 eq (19)-(23), (30)-(31)) or ``"lagrange"`` (the independent
    check), with gravity ``gravity_m_s2`` (m/s^2), a payload of weight ``payload_N`` (N, along -z at
    the platform centre, P3 section 3.4) and optional constant forces ``external_forces_N``
    ``(K, 3)`` (N) at the body centres.

    The one unit conversion of the module: the model is in mm, kg, kg mm^2 and s; here the masses
    and inertias are multiplied by :data:`KG_TO_T` and gravity by :data:`M_TO_MM`, giving the
    mm-tonne-second system in which the generic routines of :mod:`pkmlib._inverse_dynamics`
    return forces in N (1 t mm/s^2 = 1 N) and take the external forces in N as they are. Compiled
    once per mechanism (A or B) and method; pass
    ``trajectory`` as :func:`sinusoidal_trajectory` (or any :class:`jax.tree_util.Partial`) so that
    new amplitudes reuse it too.
    """
    if method not in _METHODS:
        raise ValueError(f"method must be one of {sorted(_METHODS)}, got {method!r}")
    if not isinstance(model, DynamicsModel):
        raise ValueError(
            f"model must be a DynamicsModel (dynamics_model_a / dynamics_model_b), got {type(model).__name__}"
        )
    gravity = jnp.asarray(gravity_m_s2, dtype=jnp.float64)
    if gravity.shape != (3,):
        raise ValueError(f"gravity_m_s2 must be a 3-vector (m/s^2), got shape {gravity.shape}")
    F = _external_forces(model, payload_N, external_forces_N)
    return _METHODS[method](
        model.pose, KG_TO_T * model.masses, KG_TO_T * model.inertias, M_TO_MM * gravity, F, trajectory, t
    )


def forces_by_both_methods(model: DynamicsModel, trajectory, t: Array, **kwargs) -> dict[str, Any]:
    """:func:`actuator_forces` along ``trajectory`` at the times ``t`` by virtual work (P3 eq (19)-(23),
    (30)-(31)) and by Lagrange's equations (the independent check; same keywords):
    ``{"virtual_work": (len(t), 3) N, "lagrange": ..., "max_rel_difference": their largest
    difference relative to the largest virtual-work force}``."""
    vw, lg = (
        np.asarray(actuator_forces(model, trajectory, t, method=k, **kwargs)) for k in ("virtual_work", "lagrange")
    )
    return {
        "virtual_work": vw,
        "lagrange": lg,
        "max_rel_difference": float(np.max(np.abs(vw - lg)) / np.max(np.abs(vw))),
    }


def actuator_forces_at(model: DynamicsModel, q: Array, qd: Array, qdd: Array, **kwargs) -> Array:
    """Actuator forces ``(3,)`` in N at the state ``q`` (mm), ``q'`` (mm/s), ``q''`` (mm/s^2):
    :func:`actuator_forces` along :func:`pkmlib.dynamics.state_trajectory` at ``t = 0`` (same keywords).
    Differentiable in the state, the geometry, the masses and the inertias."""
    return actuator_forces(model, state_trajectory(q, qd, qdd), jnp.zeros(1), **kwargs)[0]


# --------------------------------------------------------------------------- analyses of section 2
def actuator_grid(p: ParamsA | ParamsB, step_mm: float) -> Grid:
    """The paper's actuator box (P3 section 2.2.1: -250 <= x1 <= 0, 0 <= x2 <= 250,
    -300 <= x3 <= 300 mm) sampled with step ``step_mm`` (mm), axes ``x1, x2, x3``."""
    return Grid.from_ranges(
        x1=(p.x1_min, p.x1_max, step_mm), x2=(p.x2_min, p.x2_max, step_mm), x3=(p.x3_min, p.x3_max, step_mm)
    )


def _parts(p: ParamsA | ParamsB):
    """``(forward, constraints, platform centre, mechanism)`` of A or B, by the type of ``p``."""
    if isinstance(p, ParamsA):
        return forward_a, constraints_a, platform_centre_a, mechanism_a
    if isinstance(p, ParamsB):
        return forward_b, constraints_b, platform_centre_b, mechanism_b
    raise ValueError(f"p must be the ParamsA or ParamsB of the mechanism, got {type(p).__name__}")


def _branch(p: ParamsA | ParamsB, branch) -> Array:
    """A forward branch as a float64 array: A's ``m`` (a scalar), B's ``(n, m)``."""
    b = jnp.asarray(branch, dtype=jnp.float64)
    if b.shape != (() if isinstance(p, ParamsA) else (2,)):
        raise ValueError(
            f"branch must be {'A' if isinstance(p, ParamsA) else 'B'}'s forward branch "
            f"({'m = +-1' if isinstance(p, ParamsA) else '(n, m), each +-1'}), got {branch!r}"
        )
    return b


def _cloud_point(q: Array, p, branch: Array) -> Array:
    forward, _, centre, _ = _parts(p)
    x = forward(q, p, branch)
    return jnp.concatenate([centre(x, p), x])


def workspace_cloud(p: ParamsA | ParamsB, branch, step_mm: float) -> tuple[np.ndarray, np.ndarray]:
    """The forward solution (P3 eq (13) for A, eq (15) for B) on ``branch`` swept over the actuator
    box (:func:`actuator_grid`): ``(centres (3, N), poses (3, N))`` in mm, mm and rad, NaN where the
    input has no real assembly. The centres are the platform centres (:func:`platform_centre_a`,
    :func:`platform_centre_b`), whose clouds are P3 Figs 8 and 10. Compiled once per mechanism."""
    out = sweep(
        _cloud_point, actuator_grid(p, step_mm), args=(p, _branch(p, branch)), progress=False, size_parameter="step_mm"
    )
    out = out.reshape(-1, 6).T
    return out[:3], out[3:]


def _determinant_point(q: Array, p, branch: Array) -> Array:
    forward, _, _, mech = _parts(p)
    x = forward(q, p, branch)
    return jnp.stack([det_A(mech, x, q, p), det_B(mech, x, q, p), *x])


def determinant_sweep(p: ParamsA | ParamsB, branch, step_mm: float) -> tuple[np.ndarray, np.ndarray]:
    """``det J_o``, ``det J_i`` (autodiff of the loop-closure equations, P3 section 2.3) and the pose
    at every point of the actuator box on ``branch``: ``(values (5, N), q (3, N))``, rows
    ``det J_o, det J_i, x, z, alpha``; NaN where the input has no real assembly."""
    grid = actuator_grid(p, step_mm)
    out = sweep(
        _determinant_point, grid, args=(p, _branch(p, branch)), progress=False, size_parameter="step_mm"
    ).reshape(-1, 5)
    q = np.stack([g.ravel() for g in np.meshgrid(*grid.axes, indexing="ij")])
    return out.T, q


def paper_determinants_a(x: Array, q: Array, p: ParamsA) -> tuple[Array, Array, Array]:
    """The paper's ``det J_o``, ``det J_i`` and ``f33`` of A (P3 section 2.3.1):
    ``det J_o = 4 (z - l1)(x2 - x1) f33`` with ``f33 = 2 l3 (2a sin(alpha) + (z - l1) cos(alpha))``,
    ``det J_i = -8 (x_C - x1)(x_C - x2)(x_C - x3)`` (``J_i = diag(-2 (x_C - x_i))``). Written by
    hand from the paper, an independent check of the autodiff :func:`pkmlib.det_A`, ``det_B``."""
    xp = np if isinstance(x, np.ndarray) else jnp  # NumPy in, NumPy out; traceable otherwise
    check_first_axis("x", x, 3, "x, z, alpha")
    xc, z, al = x[0], x[1], x[2]
    f33 = 2 * p.l3 * (2 * p.a * xp.sin(al) + (z - p.l1) * xp.cos(al))
    return 4 * (z - p.l1) * (q[1] - q[0]) * f33, -8 * (xc - q[0]) * (xc - q[1]) * (xc - q[2]), f33


def paper_determinants_b(x: Array, q: Array, p: ParamsB) -> tuple[Array, Array, Array]:
    """The paper's ``det J_o``, ``det J_i`` and ``f13`` of B (P3 section 2.3.2), with the five-bar
    height ``H = sqrt(l2^2 - (x_E - x1)^2)``: ``J_o`` has ``f22 = f23 = f33 = 0``, so
    ``det J_o = f21 f13 f32 = 2 (x1 - x2) f13 2 (z_E - l1)`` with
    ``f13 = -2 l4 (2a cos(alpha) + (l1 + H - z_E) sin(alpha))`` (the paper prints ``l3`` where the
    derivative gives ``l4``: the zero is the same); ``J_i`` is lower triangular,
    ``det J_i = g11 g22 g33`` with ``g11 = -2 (z_E - l4 cos(alpha) - l1 - H)(x_E - x1) / H``,
    ``g22 = -2 (x_E - x2)``, ``g33 = -2 (x_E - x3)``."""
    xp = np if isinstance(x, np.ndarray) else jnp  # NumPy in, NumPy out; traceable otherwise
    check_first_axis("x", x, 3, "x, z, alpha")
    xE, zE, al = x[0], x[1], x[2]
    H = xp.sqrt(p.l2**2 - (xE - q[0]) ** 2)
    f13 = -2 * p.l4 * ((p.a + p.a) * xp.cos(al) + (p.l1 + H - zE) * xp.sin(al))
    g11 = -2 * (zE - p.l4 * xp.cos(al) - p.l1 - H) * (xE - q[0]) / H
    return (2 * (q[0] - q[1])) * f13 * (2 * (zE - p.l1)), g11 * (-2 * (xE - q[1])) * (-2 * (xE - q[2])), f13


def agreeing_digits(paper: float, ours: float, decimals: int) -> int:
    """How many digits of the paper's printed value ours reproduces: both written with ``decimals``
    decimals, the digits of the common leading characters (P3 Table 1, "digits that agree")."""
    s_p, s_o = f"{paper:.{decimals}f}", f"{ours:.{decimals}f}"
    n = 0
    for a, b in zip(s_p, s_o):
        if a != b:
            break
        n += a.isdigit()
    return n


def sign_fractions(v: np.ndarray) -> list[float]:
    """Fractions (4 decimals) of ``v`` below ``-tol``, within ``tol`` and above ``tol``,
    ``tol = 1e-9 max|v|``: the zero class holds the grid points on a singular plane."""
    v = np.asarray(v)
    tol = 1e-9 * np.max(np.abs(v))
    return [
        round(float(np.mean(v < -tol)), 4),
        round(float(np.mean(np.abs(v) <= tol)), 4),
        round(float(np.mean(v > tol)), 4),
    ]


def singularity_summary(p: ParamsA | ParamsB, branch, step_mm: float) -> dict[str, Any]:
    """P3 section 2.3 on one forward branch, over the actuator box: the signs of ``det J_o`` and
    ``det J_i`` (autodiff, :func:`determinant_sweep`), their largest relative differences from the
    paper's formulas (:func:`paper_determinants_a`, :func:`paper_determinants_b`; for A also
    ``f33 = -m sqrt(N1^2 + N2^2 - N3^2)`` of eq (13), :func:`discriminant_a`), their largest
    magnitudes, the largest ``|x - (x1 + x2)/2|`` of the output point (the cases needing ``x1 = x2``)
    and the fraction of the workspace with ``x3`` beyond the output point (input case 3)."""
    d, Q = determinant_sweep(p, branch, step_mm)
    ok = np.isfinite(d[0])
    x, q = d[2:, ok], Q[:, ok]
    if isinstance(p, ParamsA):
        det_o, det_i, f = (np.asarray(v) for v in paper_determinants_a(x, q, p))
        disc = np.asarray(discriminant_a(jnp.asarray(q), p))
        err_f = {
            "max_rel_error_f33_vs_minus_m_sqrt_discriminant": float(
                np.max(np.abs(f + float(branch) * np.sqrt(disc))) / np.max(np.abs(f))
            )
        }
    else:
        det_o, det_i, _ = (np.asarray(v) for v in paper_determinants_b(x, q, p))
        err_f = {}
    return {
        "det_Jo_sign_fractions_neg_zero_pos": sign_fractions(d[0, ok]),
        "det_Ji_sign_fractions_neg_zero_pos": sign_fractions(d[1, ok]),
        "max_rel_error_det_Jo_vs_paper": float(np.max(np.abs(d[0, ok] - det_o) / np.max(np.abs(det_o)))),
        "max_rel_error_det_Ji_vs_paper": float(np.max(np.abs(d[1, ok] - det_i) / np.max(np.abs(det_i)))),
        **err_f,
        "det_scale": (float(np.max(np.abs(d[0, ok]))), float(np.max(np.abs(d[1, ok])))),
        "x_mid_error_mm": float(np.max(np.abs(x[0] - 0.5 * (q[0] + q[1])))),
        "x3_beyond_fraction": float(np.mean(q[2] > x[0])),
    }


def _jacobian_point(q: Array, p, branch: Array) -> Array:
    forward, constraints, _, _ = _parts(p)
    x = forward(q, p, branch)
    return jnp.concatenate([jax.jacfwd(lambda q_: forward(q_, p, branch))(q).ravel(), constraints(x, q, p)])


def forward_jacobian_sweep(p: ParamsA | ParamsB, branch, step_mm: float) -> tuple[np.ndarray, np.ndarray]:
    """``dX/dq`` of the closed-form forward solution (forward-mode autodiff of eq (13) or (15)) and
    the loop-closure residual :func:`constraints_a` / :func:`constraints_b` (mm^2) at the real poses
    of the actuator box on ``branch``: ``(J (N, 3, 3), residual (N, 3))``. P3 section 1 reads the
    degrees of freedom (the rank of ``J``), the partial decoupling (its entries zero everywhere) and
    the coupling degree 0 (the closed form solves the loops SKC by SKC: zero residual) from them."""
    out = sweep(
        _jacobian_point,
        actuator_grid(p, step_mm),
        args=(p, _branch(p, branch)),
        progress=False,
        size_parameter="step_mm",
    ).reshape(-1, 12)
    out = out[np.all(np.isfinite(out), axis=1)]
    return out[:, :9].reshape(-1, 3, 3), out[:, 9:]


def kinematics_summary(J: np.ndarray, residual: np.ndarray) -> dict[str, Any]:
    """From :func:`forward_jacobian_sweep`: the entries of ``dX/dq`` zero on the whole workspace
    (``<= 1e-12`` of the largest entry), the most frequent rank (tolerance ``1e-9`` of the largest
    entry), the fraction of rank 3, the largest constraint residual (mm^2) and the number of poses."""
    zero = np.max(np.abs(J), axis=0) <= 1e-12 * np.max(np.abs(J))
    ranks = np.linalg.matrix_rank(J, tol=1e-9 * np.max(np.abs(J)))
    return {
        "identically_zero_entries_dX_dq": [[bool(v) for v in r] for r in zero],
        "generic_rank": int(np.bincount(ranks).argmax()),
        "rank_3_fraction": float(np.mean(ranks == 3)),
        "max_constraint_residual_mm2": float(np.max(np.abs(residual))),
        "points": int(len(J)),
    }


def output_velocity(p: ParamsA | ParamsB, x: Array, q: Array, qd: Array) -> Array:
    """The output velocity of P3 eq (18), ``J_o X' + J_i rho' = 0``: ``X' = -J_o^-1 J_i rho'``,
    with ``J_o = dF/dX`` and ``J_i = dF/drho`` by autodiff of the loop-closure equations
    (:func:`pkmlib.A_matrix`, :func:`pkmlib.B_matrix`); ``x``, ``q``, ``qd`` of shape ``(3,)``."""
    check_first_axis("qd", qd, 3, "x1', x2', x3'")
    mech = _parts(p)[3]
    return -jnp.linalg.solve(A_matrix(mech, x, q, p), B_matrix(mech, x, q, p) @ qd)


def _rk4_scan(f, x0: Array, ts: Array) -> Array:
    """Classical fourth-order Runge-Kutta for ``x' = f(x, t)`` on the uniform times ``ts`` in one
    ``lax.scan``: the states at ``ts[1:]``. (pkmlib's other integrators, :func:`pkmlib.dynamics.integrate`,
    are for rigid bodies: Newton-Euler on SE(3); this one integrates a pose's first-order ODE.)"""
    h = ts[1] - ts[0]

    def step(x, s):
        k1 = f(x, s)
        k2 = f(x + 0.5 * h * k1, s + 0.5 * h)
        k3 = f(x + 0.5 * h * k2, s + 0.5 * h)
        k4 = f(x + h * k3, s + h)
        xn = x + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
        return xn, xn

    return jax.lax.scan(step, x0, ts[:-1])[1]


@jax.jit
def _eq18_errors(p, branch, ts, rho, amplitude, omega):
    forward = _parts(p)[0]

    def inputs(s):
        return sinusoidal_inputs(s, rho, amplitude, omega)

    def xdot(X, s):
        return output_velocity(p, X, inputs(s), jax.jacfwd(inputs)(s))

    X_closed = jax.vmap(lambda s: forward(inputs(s), p, branch))(ts)
    Xd_closed = jax.vmap(jax.jacfwd(lambda s: forward(inputs(s), p, branch)))(ts)
    X_int = _rk4_scan(xdot, X_closed[0], ts)
    Xd_18 = jax.vmap(xdot)(X_closed, ts)
    scale = jnp.max(jnp.abs(X_closed), axis=0)
    return jnp.max(jnp.abs(X_int - X_closed[1:]) / scale[None, :]), jnp.max(jnp.abs(Xd_18 - Xd_closed)) / jnp.max(
        jnp.abs(Xd_closed)
    )


def eq18_check(
    p: ParamsA | ParamsB, branch, t_end_s: float, rho: Array, amplitude: Array, omega: float, dt_s: float = 0.005
) -> tuple[float, float]:
    """A second method for the kinematics of P3 section 3 (in place of the paper's ADAMS runs):
    along the sinusoidal inputs (:func:`sinusoidal_inputs`) up to ``t_end_s`` (s), the output
    velocity of eq (18) (:func:`output_velocity`) against the time derivative of the closed-form
    forward solution, and its fourth-order Runge-Kutta integral (step about ``dt_s``) against the
    closed-form pose. Returns ``(position error, velocity error)``, both relative (position per
    coordinate to its largest magnitude, velocity to the largest closed-form velocity)."""
    ts = jnp.linspace(0.0, t_end_s, max(int(round(t_end_s / dt_s)), 2) + 1)
    f64 = lambda v: jnp.asarray(v, dtype=jnp.float64)  # noqa: E731
    ep, ev = _eq18_errors(p, _branch(p, branch), ts, f64(rho), f64(amplitude), f64(omega))
    return float(ep), float(ev)


def _disc_b_along(pt: Array, p: ParamsB, rho: Array, amplitude: Array, omega: Array) -> Array:
    return discriminant_b(sinusoidal_inputs(pt[0], rho, amplitude, omega), p, 1.0)


def exit_time_b(p: ParamsB, rho: Array, amplitude: Array, omega: float, t_end_s: float, n_t: int) -> float:
    """First time (s) at which the sinusoidal inputs take B out of its workspace: the first zero of
    the discriminant of eq (15) (:func:`discriminant_b`, ``n = +1``: output singularity
    ``f13 = 0``, P3 section 2.3.2 case 3) on ``n_t`` samples of ``[0, t_end_s]``, refined by
    bisection to 1e-12 s; NaN if the motion stays inside."""
    from .._singular import singular_crossings

    grid = Grid.from_ranges(t_s=(0.0, t_end_s, t_end_s / (n_t - 1)))
    f64 = lambda v: jnp.asarray(v, dtype=jnp.float64)  # noqa: E731
    fn = lambda pt: _disc_b_along(pt, p, f64(rho), f64(amplitude), f64(omega))  # noqa: E731
    exits, _ = singular_crossings(fn, grid, sweep(fn, grid), tol=1e-12)
    return float(exits[:, 0].min()) if len(exits) else float("nan")


def solution_counts_b(p: ParamsB, x: Array, step_mm: float = 25.0) -> dict[str, Any]:
    """The counts of P3 eq (15) (four forward solutions) and eq (16)-(17) (eight inverse solutions)
    where every branch is real: the first input of a ``step_mm`` grid of the actuator box with four
    real forward branches, its distinct forward solutions that satisfy :func:`constraints_b` to
    1e-6 mm^2, and the distinct real inverse solutions at the pose ``x``."""
    grid = actuator_grid(p, step_mm)
    every_fk = lambda q: jnp.stack([forward_b(q, p, jnp.array(br)) for br in FORWARD_BRANCHES["B"]])  # noqa: E731
    every = np.all(np.isfinite(sweep(every_fk, grid).reshape(-1, 4, 3)), axis=(1, 2))
    Q = np.stack([g.ravel() for g in np.meshgrid(*grid.axes, indexing="ij")], axis=1)
    q_all = jnp.asarray(Q[np.argmax(every)])
    xs = np.asarray(every_fk(q_all))
    res = np.max(np.abs(np.asarray(constraints_b(jnp.asarray(xs.T), q_all[:, None], p))), axis=0)
    n_forward = len({tuple(np.round(v, 6)) for v, r in zip(xs, res) if np.all(np.isfinite(v)) and r < 1e-6})
    qs = np.asarray(inverse_b(jnp.asarray(x)[:, None], p, jnp.array(INVERSE_BRANCHES["B"]).T)).T
    return {
        "forward": n_forward,
        "inverse": len({tuple(np.round(v, 6)) for v in qs}),
        "q_all_real_mm": np.asarray(q_all),
        "all_real_fraction": float(every.mean()),
    }


def combined_singularity_inputs_b(p: ParamsB, x_E: float = 50.0) -> np.ndarray:
    """Inputs (mm) at which B is output-singular (``z_E = l1``, ``f32 = 0``, P3 section 2.3.2) and
    input-singular (``z_D = z_C1``, ``g11 = 0``) at once, with ``E`` at ``x = x_E``: the link ``C3D``
    then lies along ``y``, so ``sin(alpha) = (2a - l3) / l4``, ``cos(alpha) = -H / l4``, which fixes
    the five-bar height ``H`` and ``x2 - x1``; ``x3 = x_E - l5`` puts ``E`` at ``z_E = l1``."""
    sin_c = (2 * p.a - p.l3) / p.l4
    H = p.l4 * np.sqrt(1.0 - sin_c**2)
    half = np.sqrt(p.l2**2 - H**2)
    return np.array([x_E - half, 2 * x_E - (x_E - half), x_E - p.l5])


def _zD_minus_zC(point: Array, p: ParamsB, x12: Array, branch: Array) -> Array:
    q = jnp.stack([x12[0], x12[1], point[0]])
    P = joint_points_b(forward_b(q, p, branch), q, p)
    return P["D"][2] - P["C"][2]


def input_singularity_4_b(
    p: ParamsB, x1: float, x2: float, branch=(1.0, -1.0), x3_range_mm=(-300.0, 300.0, 20.0)
) -> tuple[np.ndarray, float]:
    """Inputs ``(x1, x2, x3)`` (mm) of B's input singularity case 4 (P3 section 2.3.2, Fig 15):
    ``z_D = z_C1`` (the link ``C3D`` horizontal, ``g11 = 0``) at the given ``x1, x2``, the first
    zero of ``z_D - z_C`` along ``x3`` (a scan of ``x3_range_mm`` = (start, stop, step), refined by
    bisection to 1e-12 mm) on the forward ``branch``. Returns ``(q, |z_D - z_C|)``."""
    from .._singular import singular_crossings

    x12, b = jnp.array([x1, x2], dtype=jnp.float64), _branch(p, branch)
    fn = lambda pt: _zD_minus_zC(pt, p, x12, b)  # noqa: E731
    grid = Grid.from_ranges(x3_mm=tuple(x3_range_mm))
    roots, _ = singular_crossings(fn, grid, sweep(fn, grid), tol=1e-12)
    q = np.array([x1, x2, float(roots[0, 0])])
    return q, abs(float(fn(jnp.asarray(q[2:]))))


def motion_peaks(motion: Mapping[str, Mapping[str, Array]], t: np.ndarray, t_until: Mapping[str, float]) -> dict:
    """Per motion of :func:`platform_motion` (sampled at ``t``, s): whether it stays in the workspace,
    its first sample outside (s, or None), and the peak speed (mm/s) and acceleration (mm/s^2) of
    the platform centre up to ``t_until[key]`` (s; the whole run when absent)."""
    peaks = {}
    for key, r in motion.items():
        v = np.linalg.norm(np.asarray(r["velocity"]), axis=1)
        a = np.linalg.norm(np.asarray(r["acceleration"]), axis=1)
        inside = np.all(np.isfinite(np.asarray(r["pose"])), axis=1)
        before = t <= t_until.get(key, np.inf)
        peaks[key] = {
            "inside_whole_range": bool(inside.all()),
            "first_sample_outside_s": float(t[~inside][0]) if (~inside).any() else None,
            "peak_speed_mm_s": float(np.nanmax(v[before])),
            "peak_acceleration_mm_s2": float(np.nanmax(a[before])),
        }
    return peaks


def check_assembly_b(q: Array, p: ParamsB, name: str = "inputs_B_mm") -> None:
    """``ValueError`` naming the parameter ``name`` unless B has a real assembly at the inputs ``q``
    (mm) on at least one of its four forward branches (eq (15))."""
    check_first_axis(name, q, 3, "actuator inputs x1, x2, x3 in mm")
    q = jnp.asarray(q, dtype=jnp.float64)
    if not any(np.all(np.isfinite(np.asarray(forward_b(q, p, jnp.array(br))))) for br in FORWARD_BRANCHES["B"]):
        raise ValueError(
            f"parameter {name!r} = {np.asarray(q).tolist()!r}: expected actuator inputs (x1, x2, x3) in mm at which "
            "mechanism B has a real assembly (none of its four forward branches is real there)"
        )


def inverse_solutions_b(x: Array, p: ParamsB) -> np.ndarray:
    """B's eight inverse solutions (eq (16)-(17)) at the pose ``x`` (3,), in the order of
    :data:`INVERSE_BRANCHES` ``["B"]``: ``(8, 3)`` mm, NaN rows where a branch is not real."""
    check_first_axis("x", x, 3, "x_E, z_E, alpha")
    return np.asarray(inverse_b(jnp.asarray(x)[:, None], p, jnp.array(INVERSE_BRANCHES["B"]).T)).T


def workspace_summary(p: ParamsA | ParamsB, branch, step_mm: float, voxel_mm: float, fine: bool = False) -> dict:
    """One forward branch's workspace (P3 section 2.2): the real platform centres ``cloud`` and
    poses ``poses`` of :func:`workspace_cloud` (``(3, N)``), the ``volume`` (mm^3,
    :func:`voxel_volume`) and, with ``fine``, ``volume_fine`` from a grid of half the step (the
    sampling check), the ``extents`` of the centre (mm) and of alpha (rad), and ``real_fraction``,
    the fraction of the actuator box with a real pose."""
    c, x = workspace_cloud(p, branch, step_mm)
    ok = np.all(np.isfinite(x), axis=0)
    ext = {f"{k}_mm": [float(v.min()), float(v.max())] for k, v in zip("xyz", c[:, ok])}
    ext["alpha_rad"] = [float(x[2, ok].min()), float(x[2, ok].max())]
    volume = voxel_volume(c, voxel_mm)
    fine_volume = voxel_volume(workspace_cloud(p, branch, step_mm / 2)[0], voxel_mm) if fine else volume
    return {
        "cloud": c[:, ok],
        "poses": x[:, ok],
        "volume": volume,
        "volume_fine": fine_volume,
        "extents": ext,
        "real_fraction": float(ok.mean()),
    }


def combined_singularity_b(p: ParamsB, x_E: float = 50.0) -> tuple[np.ndarray, tuple, Array]:
    """The inputs of :func:`combined_singularity_inputs_b` with the forward branch on which the pose
    has ``sin(alpha) = (2a - l3) / l4`` (the combined singularity): ``(q mm, branch, pose)``."""
    q = jnp.asarray(combined_singularity_inputs_b(p, x_E))
    sin_c = (2 * p.a - p.l3) / p.l4

    def miss(br):
        x = forward_b(q, p, jnp.array(br))
        return abs(float(np.sin(x[2])) - sin_c) if np.all(np.isfinite(np.asarray(x))) else np.inf

    br = min(FORWARD_BRANCHES["B"], key=miss)
    return np.asarray(q), br, forward_b(q, p, jnp.array(br))


# --------------------------------------------------------------------------- the notebook's studies
# What the P3 notebook reports, computed here: its tables, the comparisons with the paper's
# printed values (:mod:`pkmlib._reference`) and the studies over both mechanisms.


def claim(quantity: str, ours: float, holds: bool, *, paper_run: bool = True, note: str | None = None) -> dict:
    """A statement of P3 checked on our number (:func:`pkmlib.tools.claim_reference`); ``note`` says why
    it fails and is kept only where it does not reproduce."""
    r = claim_reference(PAPER, quantity, float(ours), bool(holds), paper_run=paper_run)
    return r | ({"note": note} if note and r["status"] != "reproduced" else {})


def consistency(quantity: str, ours: float, holds: bool, *, paper_run: bool = True) -> dict:
    """Our own check (two methods of ours), not a reproduction: a :func:`claim` of kind
    ``"consistency"``, status ``"consistency check"`` where it holds (on the paper's parameters)."""
    r = claim(quantity, ours, holds, paper_run=paper_run) | {"kind": "consistency"}
    return r | ({"status": "consistency check" if holds else "differs"} if paper_run else {})


def _text(v: float, decimals: int = 4) -> str:
    return "nan" if not np.isfinite(v) else f"{v:.{decimals}f}"


def tables_a(q: Array, p: ParamsA, paper_run: bool = True) -> dict[str, Any]:
    """P3 Tables 1-2 of mechanism A beside the paper's printed values: ``table1`` (the forward
    solutions of eq (13) at the inputs ``q``, mm, one row per branch ``m``), ``table2`` (the four
    inverse solutions of eq (14) from Table 1 row 2 as printed, which the paper's Table 2 follows,
    with ``x3`` also from row 1 as printed and from the exact row 1), ``rows`` (their
    :func:`pkmlib.tools.compare_reference` rows, Table 1, then Table 2 with the row on the text's reading
    after Table 2's row 1), ``text_row`` (that row) and ``table1_text``, ``table2_text`` (the
    notebook's Markdown rows)."""
    from ..tools.report import status_link  # (the report imports the registry of the papers)

    ref = {r["quantity"]: r for r in load_reference_file(PAPER)["numbers"]}
    compare = lambda quantity, ours: compare_reference(PAPER, quantity, float(ours), paper_run=paper_run)  # noqa: E731
    rows, table1, table1_text = [], [], []
    for row, m in enumerate(FORWARD_BRANCHES["A"], start=1):
        x = np.asarray(forward_a(q, p, m))
        ours = (float(x[0]), -p.a, float(x[1]), float(x[2]))
        table1.append({"row": row, "m": m, "x_mm": ours[0], "y_mm": ours[1], "z_mm": ours[2], "alpha_rad": ours[3]})
        for name, ov, dec in zip(("x", "y", "z", "alpha"), ours, (2, 0, 4, 4)):
            r = compare(f"A Table 1 row {row} {name}", ov)
            rows.append(r)
            table1_text.append(
                (
                    f"{row} ($m = {m:+.0f}$)",
                    {"alpha": "$\\alpha$, rad"}.get(name, f"${name}$, mm"),
                    ref[r["quantity"]]["printed"],
                    f"{ov:.6f}",
                    f"{agreeing_digits(r['paper'], ov, dec)}",
                    status_link(PAPER, r["quantity"], r["status"]),
                )
            )
    row1, row2 = (
        jnp.array([paper_value(PAPER, f"A Table 1 row {k} {c}") for c in ("x", "z", "alpha")]) for k in (1, 2)
    )
    table2, table2_text = [], []
    for k, br in enumerate(INVERSE_BRANCHES["A"], start=1):
        q2, q1, q_exact = (np.asarray(inverse_a(x, p, jnp.array(br))) for x in (row2, row1, forward_a(q, p, 1.0)))
        table2.append(
            {
                "row": k,
                "u": br[0],
                "v": br[1],
                "x1_mm": float(q2[0]),
                "x2_mm": float(q2[1]),
                "x3_mm": float(q2[2]),
                "x3_mm_from_row1": float(q1[2]),
                "x3_mm_exact": float(q_exact[2]),
            }
        )
        rows.extend(compare(f"A Table 2 row {k} {name}", q2[j]) for j, name in enumerate(("x1", "x2", "x3")))
        table2_text.append(
            (
                f"{k} ({br[0]:+.0f}, {br[1]:+.0f})",
                *(ref[f"A Table 2 row {k} {n}"]["printed"] for n in ("x1", "x2", "x3")),
                f"{q2[0]:.2f}",
                f"{q2[1]:.2f}",
                f"{q2[2]:.4f}",
                f"{q1[2]:.4f}",
            )
        )
        if k == 1:  # the text says row 1: the four printed x3 disagree with it alike (one finding, one row)
            rows.append(text_row := compare("A Table 2 x3 from Table 1 row 1 (as the text says)", q1[2]))
    return {
        "table1": table1,
        "table2": table2,
        "rows": rows,
        "text_row": text_row,
        "table1_text": table1_text,
        "table2_text": table2_text,
    }


def solutions_b(q: Array, p: ParamsB) -> dict[str, Any]:
    """B's forward solutions (eq (15)) at the inputs ``q`` (mm) on its four branches ``(n, m)``
    (``table1``, NaN where not real), the ``real_branches``, B's eight inverse solutions (eq
    (16)-(17)) at the pose of each real branch (``table2``) and, per real branch, the distance of
    ``q`` from the nearest inverse solution (``round_trip_mm``, the forward-inverse round trip)."""
    table1 = []
    for br in FORWARD_BRANCHES["B"]:
        x = np.asarray(forward_b(q, p, jnp.array(br)))
        table1.append(
            {"n": br[0], "m": br[1], "x_mm": float(x[0]), "y_mm": p.a, "z_mm": float(x[1]), "alpha_rad": float(x[2])}
        )
    real = [br for br, r in zip(FORWARD_BRANCHES["B"], table1) if np.isfinite(r["alpha_rad"])]
    table2, round_trip = [], []
    for br in real:
        qs = inverse_solutions_b(forward_b(q, p, jnp.array(br)), p)
        table2.extend(
            {
                "pose_n": br[0],
                "pose_m": br[1],
                "u": ib[0],
                "v": ib[1],
                "w": ib[2],
                "x1_mm": float(s[0]),
                "x2_mm": float(s[1]),
                "x3_mm": float(s[2]),
            }
            for ib, s in zip(INVERSE_BRANCHES["B"], qs)
        )
        round_trip.append(float(np.nanmin(np.max(np.abs(qs - np.asarray(q)), axis=1))))
    return {"table1": table1, "real_branches": real, "table2": table2, "round_trip_mm": round_trip}


def forward_table_b(solutions: Mapping[str, Any], q) -> tuple[list, list]:
    """``(rows, headers)`` of the Markdown table of B's forward solutions (:func:`solutions_b`) at
    the inputs ``q`` (mm), named in the first heading."""
    rows = [
        (
            f"({r['n']:+.0f}, {r['m']:+.0f})",
            _text(r["x_mm"], 2),
            f"{r['y_mm']:.2f}",
            _text(r["z_mm"]),
            _text(r["alpha_rad"]),
        )
        for r in solutions["table1"]
    ]
    first = f"(n, m) at x = ({', '.join(f'{v:g}' for v in q)}) mm"
    return rows, [first, "$x_E$, mm", "$y_E$, mm", "$z_E$, mm", "$\\alpha$, rad"]


def inverse_table_b(solutions: Mapping[str, Any]) -> tuple[list, list]:
    """``(rows, headers)`` of the Markdown table of B's inverse solutions (:func:`solutions_b`): one
    row per inverse branch ``(u, v, w)``, one column per real forward pose ``(n, m)``."""
    real, n_inv = solutions["real_branches"], len(INVERSE_BRANCHES["B"])
    body = []
    for j, ib in enumerate(INVERSE_BRANCHES["B"]):
        cells = [f"({ib[0]:+.0f}, {ib[1]:+.0f}, {ib[2]:+.0f})"]
        for k in range(len(real)):
            r = solutions["table2"][k * n_inv + j]
            cells.append(", ".join(_text(r[c]) for c in ("x1_mm", "x2_mm", "x3_mm")))
        body.append(cells)
    return body, ["(u, v, w)"] + [f"at pose (n, m) = ({br[0]:+.0f}, {br[1]:+.0f})" for br in real]


def branch_label(name: str, branch) -> str:
    """The label of a forward branch in the notebook's tables and figures: ``m=+1`` (A), ``n=+1,m=-1`` (B)."""
    return f"m={branch:+.0f}" if name == "A" else f"n={branch[0]:+.0f},m={branch[1]:+.0f}"


def workspace_summaries(pa: ParamsA, pb: ParamsB, step_mm: float, voxel_mm: float) -> dict[tuple[str, str], dict]:
    """:func:`workspace_summary` of every forward branch of A and B, keyed ``(name, label)``
    (:func:`branch_label`), with the half-step volume check on A's ``m = +1`` and B's ``(+1, +1)``."""
    return {
        (name, label): workspace_summary(p, br, step_mm, voxel_mm, fine=label in ("m=+1", "n=+1,m=+1"))
        for name, p in (("A", pa), ("B", pb))
        for br in FORWARD_BRANCHES[name]
        for label in (branch_label(name, br),)
    }


def _array_name(label: str) -> str:
    """A branch label (:func:`branch_label`) or motion key as a name for the arrays saved beside a figure."""
    return label.replace(" ", "_").replace("=", "").replace(",", "_").replace("+", "p").replace("-", "m")


def cloud_arrays(clouds: Mapping[str, np.ndarray], every: int = 10) -> dict[str, np.ndarray]:
    """The clouds (mm) behind P3 Figs 8-11, every ``every``-th point of each branch, as named arrays."""
    return {f"{_array_name(label)}_{k}_mm": c[i, ::every] for label, c in clouds.items() for i, k in enumerate("xyz")}


def singularity_summaries(pa: ParamsA, pb: ParamsB, branches_b, step_mm: float) -> dict[str, dict]:
    """:func:`singularity_summary` of A's two forward branches and of B's ``branches_b`` (its real
    ones), keyed ``"A m=+1"``, ``"B n=+1,m=+1"``, ..."""
    return {
        f"{name} {branch_label(name, br)}": singularity_summary(p, br, step_mm)
        for name, p, brs in (("A", pa, FORWARD_BRANCHES["A"]), ("B", pb, branches_b))
        for br in brs
    }


def determinants_at(q: Array, p: ParamsA | ParamsB, branch) -> tuple[Array, float, float]:
    """``(pose, det J_o, det J_i)`` of A or B (by the type of ``p``) at the inputs ``q`` (mm) on the
    forward ``branch``; ``J_o``, ``J_i`` by autodiff of the loop equations (P3 section 2.3)."""
    forward, _, _, mech = _parts(p)
    x = forward(q, p, branch if isinstance(p, ParamsA) else jnp.array(branch))
    return x, float(det_A(mech, x, q, p)), float(det_B(mech, x, q, p))


def joint_points(x: Array, q: Array, p: ParamsA | ParamsB) -> dict[str, Array]:
    """:func:`joint_points_a` or :func:`joint_points_b`, by the type of ``p``."""
    return joint_points_a(x, q, p) if isinstance(p, ParamsA) else joint_points_b(x, q, p)


def forward_panels(q: Array, p: ParamsA | ParamsB) -> list[tuple[dict[str, Array], str]]:
    """The panels of P3 Fig 6 (A) and of its extra figure for B (:func:`configurations_figure`): the
    joint points at each real forward solution (eq (13), eq (15)) at the inputs ``q`` (mm), labelled
    with the branch and ``alpha``."""
    if isinstance(p, ParamsA):
        return [
            (joint_points_a(x := forward_a(q, p, m), q, p), f"({'ab'[k]}) row {k + 1}: alpha = {float(x[2]):.4f} rad")
            for k, m in enumerate(FORWARD_BRANCHES["A"])
        ]
    poses = [(br, forward_b(q, p, jnp.array(br))) for br in FORWARD_BRANCHES["B"]]
    return [
        (joint_points_b(x, q, p), f"(n, m) = ({br[0]:+.0f}, {br[1]:+.0f}): alpha = {float(x[2]):.4f} rad")
        for br, x in poses
        if np.isfinite(float(x[2]))
    ]


def inverse_panels(x: Array, p: ParamsA | ParamsB) -> list[tuple[dict[str, Array], str]]:
    """The panels of P3 Fig 7 (A, eq (14)) and of its extra figure for B (eq (16)-(17), each drawn
    with its own five-bar height ``H``): the joint points of every inverse solution at the pose
    ``x``, labelled with the branch (and, for A, ``x3``)."""
    if isinstance(p, ParamsA):
        return [
            (
                joint_points_a(x, q := inverse_a(x, p, jnp.array(br)), p),
                f"({'abcd'[k]}) u = {br[0]:+.0f}, v = {br[1]:+.0f}: x3 = {float(q[2]):.2f} mm",
            )
            for k, br in enumerate(INVERSE_BRANCHES["A"])
        ]
    return [
        (
            joint_points_b(x, inverse_b(x, p, jnp.array(ib)), p, jnp.sign(five_bar_height_b(x, p, ib[2]))),
            f"(u, v, w) = ({ib[0]:+.0f}, {ib[1]:+.0f}, {ib[2]:+.0f})",
        )
        for ib in INVERSE_BRANCHES["B"]
    ]


def paper_motions(pa: ParamsA, pb: ParamsB, branches_b, t: Array, rho: Array, amplitude: Array, omega: float) -> dict:
    """:func:`platform_motion` of A on both branches (keys ``"A"``, ``"A m=-1"``) and of B on each of
    ``branches_b`` (``"B n=+1,m=+1"``, ...) along the sinusoidal inputs of P3 section 3.1."""
    motion = {
        "A": platform_motion(forward_a, platform_centre_a, pa, 1.0, t, rho, amplitude, omega),
        "A m=-1": platform_motion(forward_a, platform_centre_a, pa, -1.0, t, rho, amplitude, omega),
    }
    for br in branches_b:
        motion[f"B {branch_label('B', br)}"] = platform_motion(
            forward_b, platform_centre_b, pb, jnp.array(br), t, rho, amplitude, omega
        )
    return motion


def motion_arrays(motion: Mapping[str, Mapping[str, Array]], t: np.ndarray, keys) -> dict[str, np.ndarray]:
    """The velocities (mm/s) and accelerations (mm/s^2) of the motions ``keys`` of :func:`paper_motions`
    sampled at ``t`` (s), as the named arrays behind P3 Figs 17 and 19."""
    return {"t_s": t} | {
        f"{q}_{_array_name(k)}_mm_s{'2' if q == 'acceleration' else ''}": np.asarray(motion[k][q])
        for k in keys
        for q in ("velocity", "acceleration")
    }


def force_ranges(
    dyn: Mapping[str, Mapping[str, np.ndarray]], t_dyn: Mapping[str, Array]
) -> tuple[np.ndarray, np.ndarray, float]:
    """The ranges (N) of A's and B's actuator forces (virtual work, :func:`forces_by_both_methods`,
    sampled at ``t_dyn``) over B's time span, and the largest ratio of the two, over the actuators."""
    common = np.asarray(t_dyn["A"]) <= float(t_dyn["B"][-1]) + 1e-12
    range_A = np.ptp(dyn["A"]["virtual_work"][common], axis=0)
    range_B = np.ptp(dyn["B"]["virtual_work"], axis=0)
    return range_A, range_B, float(np.max(np.maximum(range_B / range_A, range_A / range_B)))


def paper_dynamics(
    params: Mapping[str, Any], pa: ParamsA, pb: ParamsB, t: Mapping[str, Array], trajectory, gravity_m_s2: Array
) -> dict:
    """:func:`forces_by_both_methods` of A (branch ``m = +1``, masses of section 3.4 and Table 3) and
    of B (branch ``(+1, +1)``, Table 4) with the payload ``params["payload_N"]`` (N), sampled at
    ``t["A"]``, ``t["B"]`` (s) along ``trajectory`` (:func:`sinusoidal_trajectory`, mm)."""
    dyn = {}
    for name, model, p, br, inertia in (
        ("A", dynamics_model_a, pa, 1.0, "inertia_A_table3"),
        ("B", dynamics_model_b, pb, jnp.array([1.0, 1.0]), "inertia_B_table4"),
    ):
        dm = model(p, br, params[f"masses_{name}_kg"], params[inertia])
        dyn[name] = forces_by_both_methods(
            dm, trajectory, t[name], payload_N=params["payload_N"], gravity_m_s2=gravity_m_s2
        )
    return dyn


def force_arrays(t: Array, forces: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The arrays behind P3 Figs 21 and 23: the times ``t`` (s) and the actuator forces (N) of one
    entry of :func:`paper_dynamics` by virtual work and by Lagrange's equations."""
    return {"t_s": np.asarray(t), "f_virtual_work_N": forces["virtual_work"], "f_lagrange_N": forces["lagrange"]}


# --------------------------------------------------------------------------- figures
# Every figure is at most 10 in wide and uses no text below matplotlib's 10 pt: at the site's
# 800 px column that is >= 10 px (the rule: font pt >= 0.95 x figure width in inches).
#: Colours of the forward branches in the workspace figures, in the order of :data:`FORWARD_BRANCHES`.
BRANCH_COLOURS = ("tab:blue", "tab:orange", "tab:green", "tab:red")


def cloud_figure(clouds: Mapping[str, np.ndarray], title: str):
    """P3 Figs 8 and 10: the platform-centre clouds ``{branch label: (3, N) mm}`` of one mechanism,
    (a) in 3-D in true proportions, (b)-(d) projected on ``xOy``, ``yOz``, ``xOz``. A direction
    thinner than a fifth of the largest extent gets no ticks; its range goes into the title."""
    import matplotlib.pyplot as plt

    fig = plt.figure(figsize=(10, 8.4))
    ax = fig.add_subplot(2, 2, 1, projection="3d")
    items = [(label, c, col) for (label, c), col in zip(clouds.items(), BRANCH_COLOURS) if c.shape[1]]
    for label, c, col in items:
        ax.scatter(*c[:, :: max(1, c.shape[1] // 3000)], s=1, color=col, label=label)
    allc = np.concatenate([c for _, c, _ in items], axis=1)
    ax.set_box_aspect(np.maximum(np.ptp(allc, axis=1), 1.0), zoom=0.8)
    thin = []
    for k, axis in enumerate((ax.xaxis, ax.yaxis, ax.zaxis)):
        axis.set_major_locator(plt.MaxNLocator(3))
        axis.set_label_text(f"{'xyz'[k]}, mm")
        lo, hi = allc[k].min(), allc[k].max()
        if hi - lo < 0.2 * np.ptp(allc, axis=1).max():  # a thin direction: its range in the title
            axis.set_ticks([])
            axis.set_label_text("xyz"[k])
            thin.append(f"{'xyz'[k]} from {lo:.0f} to {hi:.0f} mm")
    ax.legend(markerscale=6, loc="upper left", bbox_to_anchor=(-0.25, 1.0))
    ax.set_title(f"(a) {title}" + (f"\n({', '.join(thin)})" if thin else ""))
    for k, (i, j, plane) in enumerate(((0, 1, "xOy"), (1, 2, "yOz"), (0, 2, "xOz"))):
        ax = fig.add_subplot(2, 2, k + 2)
        for label, c, col in items:
            s = c[:, :: max(1, c.shape[1] // 8000)]
            ax.scatter(s[i], s[j], s=0.5, color=col, label=label)
        ax.set_xlabel(f"{'xyz'[i]}, mm")
        ax.set_ylabel(f"{'xyz'[j]}, mm")
        ax.set_title(f"({'bcd'[k]}) projection on {plane}")
    fig.tight_layout(h_pad=2.0)
    return fig


def section_figure(clouds: Mapping[str, np.ndarray], planes, halfwidth_mm: float, title: str):
    """P3 Figs 9 and 11: the points of the clouds ``{branch label: (3, N) mm}`` within
    ``halfwidth_mm`` of each section plane ``(axis index, level mm)``, one panel per plane."""
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(planes), figsize=(10, 4.4))
    for ax, (axis, level) in zip(np.atleast_1d(axes), planes):
        others = [i for i in range(3) if i != axis]
        for (label, c), col in zip(clouds.items(), BRANCH_COLOURS):
            sel = np.abs(c[axis] - level) <= halfwidth_mm
            if sel.any():
                ax.scatter(c[others[0], sel], c[others[1], sel], s=1, color=col, label=f"{label} ({sel.sum()} pts)")
        ax.set_xlabel(f"{'xyz'[others[0]]}, mm")
        ax.set_ylabel(f"{'xyz'[others[1]]}, mm")
        ax.set_title(f"{'xyz'[axis]} = {level:g} mm")
        ax.locator_params(nbins=4)
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.2), markerscale=6, frameon=False)
    fig.suptitle(title)
    fig.tight_layout()
    return fig


_MOTION_STYLE = {
    "x": dict(color="tab:blue", ls="-", lw=1.6),
    "y": dict(color="tab:orange", ls="--", lw=1.6),
    "z": dict(color="tab:green", ls="-.", lw=1.6),
    "|.|": dict(color="k", ls=":", lw=2.2),
}


def motion_figure(
    motion: Mapping[str, Mapping[str, Array]],
    t: np.ndarray,
    t_max: float,
    title: str,
    clip_until: float | None = None,
    exit_s: float | None = None,
):
    """P3 Figs 17 and 19: velocity (top) and acceleration (bottom) of the platform centre along
    each motion of :func:`platform_motion` (columns, by key), sampled at ``t`` (s) up to ``t_max``;
    ``x, y, z`` and the magnitude told apart by line style. ``clip_until`` (s) clips the vertical
    axes to the values up to that time (a spike at a singular exit runs off the panel; its size goes
    into the panel's title); ``exit_s`` draws that time as a red line."""
    import matplotlib.pyplot as plt

    keys = list(motion)
    fig, axes = plt.subplots(2, len(keys), figsize=(10, 7.6), sharex=True, squeeze=False)
    sel = t <= t_max
    for col, key in enumerate(keys):
        for row, (q, unit) in enumerate((("velocity", "mm/s"), ("acceleration", "mm/s$^2$"))):
            ax = axes[row, col]
            vals = np.asarray(motion[key][q])[sel]
            mag = np.linalg.norm(vals, axis=1)
            for j, comp in enumerate("xyz"):
                ax.plot(t[sel], vals[:, j], label=f"${comp}$", **_MOTION_STYLE[comp])
            ax.plot(t[sel], mag, label="magnitude", **_MOTION_STYLE["|.|"])
            panel = f"{key}: {q}"
            if clip_until is not None:
                lim = 1.15 * np.nanmax(mag[t[sel] <= clip_until])
                ax.set_ylim(-lim, lim)
                panel += f"\n(clipped; {np.nanmax(mag):,.0f} {unit.replace('$^2$', '^2')} at the exit)"
            if exit_s is not None:
                ax.axvline(exit_s, color="r", lw=1)
            ax.set_title(panel)
            ax.set_ylabel(f"{q}, {unit}")
            ax.grid(alpha=0.3)
        axes[1, col].set_xlabel("t, s")
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, ncol=4, loc="lower center", frameon=False)
    fig.suptitle(title)
    fig.tight_layout(rect=(0, 0.05, 1, 1))
    return fig


def force_figure(t: np.ndarray, virtual_work: np.ndarray, lagrange: np.ndarray, title: str):
    """P3 Figs 21 and 23: the actuator forces ``(len(t), 3)`` (N) by virtual work (thick) and by
    Lagrange's equations (dotted) against ``t`` (s)."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(9, 5))
    for i, col in enumerate(("tab:blue", "tab:orange", "tab:green")):
        ax.plot(t, virtual_work[:, i], color=col, lw=2.5, alpha=0.6, label=f"f{i + 1}, virtual work")
        ax.plot(t, lagrange[:, i], "k:", lw=1, label=f"f{i + 1}, Lagrange" if i == 0 else None)
    ax.set_xlabel("t, s")
    ax.set_ylabel("actuator force, N")
    ax.legend(ncol=2)
    ax.set_title(title)
    fig.tight_layout()
    return fig


def configurations_figure(which: str, panels, title: str, ncols: int = 2, width_in: float = 10.0, a: float = 300.0):
    """Mechanism ``which`` ("A" or "B") drawn in one 3-D panel per ``(joint points, panel title)``
    of ``panels`` (:func:`joint_points_a` / :func:`joint_points_b`, mm), ``ncols`` to a row, under
    the figure title ``title``: P3 Figs 6-7 and 12-15."""
    import matplotlib.pyplot as plt

    nrows = -(-len(panels) // ncols)
    w = width_in / ncols
    fig = plt.figure(figsize=(width_in, nrows * 0.9 * w + 0.6))
    for k, (points, panel) in enumerate(panels):
        ax = fig.add_subplot(nrows, ncols, k + 1, projection="3d")
        draw_points(ax, which, points, a=a, title=panel)
        ax.set_box_aspect(None, zoom=0.82)  # room for the z label inside the panel
        for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
            axis.set_major_locator(plt.MaxNLocator(3))
    fig.suptitle(title)
    fig.tight_layout(rect=(0, 0, 1, 1 - 0.45 / fig.get_size_inches()[1]))  # room for the title
    return fig


#: Old names, kept for one release (each use warns).
__getattr__ = deprecated_names(
    __name__,
    {
        "TABLE1_ROW1_BRANCH_A": ('FORWARD_BRANCHES["A"][0]', lambda: FORWARD_BRANCHES["A"][0]),
        "TABLE1_BRANCHES_A": ('FORWARD_BRANCHES["A"]', lambda: FORWARD_BRANCHES["A"]),
        "TABLE2_BRANCHES_A": ('INVERSE_BRANCHES["A"]', lambda: INVERSE_BRANCHES["A"]),
        "FK_BRANCHES_B": ('FORWARD_BRANCHES["B"]', lambda: FORWARD_BRANCHES["B"]),
        "IK_BRANCHES_B": ('INVERSE_BRANCHES["B"]', lambda: INVERSE_BRANCHES["B"]),
    },
)
