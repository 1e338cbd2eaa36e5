"""Stiffness of spatial frames from beam elements: element matrix, end releases, assembly, solve.

P4 (Erastova, BMSTU J. Mech. Eng. 2020 no. 8, "P4") models every link of a parallel mechanism as
a spatial Euler-Bernoulli beam element with torsion: the 12 x 12 matrix ``K^0_local = E/l^3 M``
printed after P4 eq (7) (from Kassimali [8]). Ends joined by a hinge get their rotation about the
hinge axis released by static condensation (P4, the four-step procedure after ``M``; the
fixed-hinge matrix ``N`` and the hinge-hinge matrix ``H``). Each element is rotated to the global
frame, ``K^j = S^T K^j_local S`` with ``S = diag(R, R, R, R)`` (P4 eq (7)), the elements are
assembled into the global matrix (P4 eq (6)), the clamped DOFs and the empty rows of the released
rotations are removed, and ``K d = P`` (P4 eq (3)) is solved for the displacements.

Conventions. Six DOFs per node in the order of P4's ``M``: ``(u_x, u_y, u_z, theta_x, theta_y,
theta_z)``; an element has its node 1's six DOFs, then node 2's (0-based indices 0..11 here,
P4 numbers them 1..12). Local ``x`` runs along the element from node 1 to node 2; ``I_y`` is the
second moment of area for bending in the local ``x-z`` plane (rotation about local ``y``), ``I_z``
for bending in the local ``x-y`` plane, ``I_p`` the torsion constant. Any consistent units (P4:
N, mm, MPa).

Everything is JAX and float64: a frame's reduced matrix and its solution are pure functions of
the node coordinates and section properties, so they ``jit``, ``vmap`` (e.g. with
:func:`pkmlib.sweep`) and differentiate. The topology (:class:`Frame`) is static; hinges are
declared as releases (:func:`release`), and the rows they empty follow from them. The stiffness
or compliance seen at any node (:meth:`Frame.node_stiffness`, :meth:`Frame.node_compliance`) or
any set of DOFs (:meth:`Frame.condensed_stiffness`) is public; given rotations with structural
zeros, it is computed by an unrolled elimination that skips them (fast under ``vmap``).
Directions of lines get a canonical sign (:func:`canonical_sign`); the extremal stiffness of a
2 x 2 matrix is in closed form with a NaN-free derivative (:func:`extremal_stiffness`).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, Sequence

import jax
import jax.numpy as jnp
import numpy as np

from . import _config  # noqa: F401  (float64)
from ._pytree import pytree_dataclass
from ._memory import check_memory
from ._validation import _is_tracer, check_positive, check_positive_values
from ._validation import (
    concrete,
    check_array,
    check_count,
    check_index,
    check_indices,
    check_nonnegative,
    check_square,
    positive_or_nan,
)

Array = Any

#: DOFs per node and their indices: ``(u_x, u_y, u_z, theta_x, theta_y, theta_z)`` (P4, ``M``).
DOF_PER_NODE = 6
U_X, U_Y, U_Z, THETA_X, THETA_Y, THETA_Z = range(DOF_PER_NODE)
#: Released local DOFs of a fixed-hinge element (rotation about local y at node 2): P4's ``N``.
FIXED_HINGE_Y = (DOF_PER_NODE + THETA_Y,)
#: Released local DOFs of a hinge-hinge element (rotation about local y at both ends): P4's ``H``.
HINGE_HINGE_Y = (THETA_Y, DOF_PER_NODE + THETA_Y)
_AXES = {"x": THETA_X, "y": THETA_Y, "z": THETA_Z}


def release(*ends: int, about: str = "y") -> tuple[int, ...]:
    """The local DOFs that release the rotation about the element's local axis ``about`` at its
    ``ends`` (1 = node 1, 2 = node 2): a hinge, declared as P4 declares it (the ``N`` matrix is
    "release the rotation about y at end 2", ``H`` at ends 1 and 2). Pass one per element as
    :class:`Frame`'s ``releases``; ``release(2) == FIXED_HINGE_Y``, ``release(1, 2) == HINGE_HINGE_Y``.

    With :class:`Frame`'s default ``empty_dofs=None``, a node whose every element releases the
    rotation about local y there loses that global rotation (about ``up``) from the system, as
    P4 removes the hinges' "empty rows".
    """
    if about not in _AXES:
        raise ValueError(f"release: about must be one of 'x', 'y', 'z', got {about!r}")
    if not ends or any(e not in (1, 2) for e in ends):
        raise ValueError(f"release: ends must be 1 (node 1) and/or 2 (node 2), got {ends!r}")
    return tuple(sorted({(e - 1) * DOF_PER_NODE + _AXES[about] for e in ends}))


@pytree_dataclass
@dataclasses.dataclass(frozen=True)
class BeamSection:
    """Material and cross-section of a beam element (P4 table). A JAX pytree.

    Attributes: ``E`` Young's modulus, ``G`` shear modulus, ``A`` area, ``I_y`` and ``I_z`` second
    moments of area about the local y and z axes, ``I_p`` torsion constant (P4's "polar moment").
    Build it with :meth:`create`, which checks that every value is finite and positive.
    """

    E: float
    G: float
    A: float
    I_y: float
    I_z: float
    I_p: float

    def __post_init__(self):
        # Built directly, BeamSection(E=..., ...) is checked as create checks, and a traced value
        # that is not positive becomes NaN; JAX's rebuilding of the pytree (placeholders,
        # gradients, vmap axes) skips __init__ (pytree_dataclass).
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if _is_tracer(v):
                object.__setattr__(self, f.name, positive_or_nan(f.name, v))
            else:
                check_positive_values(f.name, v)

    @classmethod
    def create(cls, *, E, G, A, I_y, I_z, I_p) -> "BeamSection":
        values = dict(E=E, G=G, A=A, I_y=I_y, I_z=I_z, I_p=I_p)
        return cls(**{k: positive_number(k, v) for k, v in values.items()})


def positive_number(name: str, value: Any) -> float:
    """``float(value)`` for a finite positive real number (int, float, NumPy or 0-d array);
    anything else (None, a string, a list, a complex number, a bool, NaN, <= 0) is a
    ``ValueError`` naming ``name`` and what is accepted."""
    real = isinstance(value, (int, float, np.integer, np.floating)) or (
        isinstance(value, (np.ndarray, jax.Array))
        and np.ndim(value) == 0
        and np.issubdtype(np.asarray(value).dtype, np.number)
        and not np.iscomplexobj(value)
    )
    if not real or isinstance(value, (bool, np.bool_)):
        raise ValueError(f"{name} must be a finite positive number, got {value!r}")
    return check_positive(name, value)


def rectangle_section(b: float, h: float, n_terms: int = 50) -> dict[str, float]:
    """Area, second moments and torsion constant of a solid ``b x h`` rectangle.

    ``h`` is the side along local z, ``b`` along local y: ``A = b h``, ``I_y = b h^3 / 12``
    (bending in the local x-z plane), ``I_z = h b^3 / 12``, and the Saint-Venant torsion constant
    ``I_p = (a c^3 / 3) [1 - (192 / pi^5) (c / a) sum_{n odd} tanh(n pi a / (2 c)) / n^5]`` with
    ``a = max(b, h)``, ``c = min(b, h)`` (Timoshenko & Goodier, Theory of Elasticity, sec. 109).
    P4's table prints ``I_y, I_z, I_p`` but not the area; they are those of ``b = 10``, ``h = 16`` mm.

    Concrete ``b``, ``h`` are checked (finite, positive) and give Python floats; JAX tracers
    (inside ``jax.grad``/``jit``, e.g. the stiffness's derivative with respect to the section
    sizes) give JAX scalars with the same formula.
    """
    # the series converges as 1/n^5: 10**6 terms are far past round-off, more only run a Python loop
    n_terms = check_count("n_terms", n_terms, minimum=1, maximum=10**6)
    if isinstance(b, jax.core.Tracer) or isinstance(h, jax.core.Tracer):
        tanh, pi, big, small = jnp.tanh, jnp.pi, jnp.maximum(b, h), jnp.minimum(b, h)
    else:
        b, h = positive_number("b", b), positive_number("h", h)
        tanh, pi, big, small = math.tanh, math.pi, max(b, h), min(b, h)
    a, c = big, small
    series = sum(tanh(n * pi * a / (2 * c)) / n**5 for n in range(1, 2 * n_terms, 2))
    I_p = a * c**3 / 3 * (1 - 192 / pi**5 * (c / a) * series)
    return {"A": b * h, "I_y": b * h**3 / 12, "I_z": h * b**3 / 12, "I_p": I_p}


def frame_element_local(L: Array, s: BeamSection) -> Array:
    """The 12 x 12 Euler-Bernoulli frame element with torsion in local coordinates, both ends fixed.

    ``K^0_local = E / l^3 M`` (P4, the matrix ``M`` after eq (7); Kassimali [8]):
    axial ``A l^2``, torsion ``G I_p l^2 / E``, bending in x-y with ``I_z`` (DOFs u_y, theta_z)
    and in x-z with ``I_y`` (DOFs u_z, theta_y, with the minus signs of a right-handed theta_y).
    """
    L = positive_or_nan("L", L, "a finite positive element length")
    if not isinstance(s, BeamSection):
        raise ValueError(
            f"s must be a pkmlib.stiffness.BeamSection (BeamSection.create(E=..., ...)), got {type(s).__name__}: {s!r}"
        )
    return _to_array(_element_local_entries(L, s))


def _element_local_entries(L: Array, s: BeamSection) -> list:
    """:func:`frame_element_local` as a 12 x 12 list of entries, structural zeros as ``0``."""
    L = jnp.asarray(L, dtype=jnp.float64)
    A, Iy, Iz = s.A, s.I_y, s.I_z
    tors = s.G * s.I_p * L**2 / s.E
    # (row, col) 1-based as in P4, value; the lower triangle is filled by symmetry.
    upper = [
        ((1, 1), A * L**2),
        ((7, 7), A * L**2),
        ((1, 7), -A * L**2),
        ((2, 2), 12 * Iz),
        ((8, 8), 12 * Iz),
        ((2, 8), -12 * Iz),
        ((2, 6), 6 * L * Iz),
        ((2, 12), 6 * L * Iz),
        ((6, 8), -6 * L * Iz),
        ((8, 12), -6 * L * Iz),
        ((6, 6), 4 * L**2 * Iz),
        ((12, 12), 4 * L**2 * Iz),
        ((6, 12), 2 * L**2 * Iz),
        ((3, 3), 12 * Iy),
        ((9, 9), 12 * Iy),
        ((3, 9), -12 * Iy),
        ((3, 5), -6 * L * Iy),
        ((3, 11), -6 * L * Iy),
        ((5, 9), 6 * L * Iy),
        ((9, 11), 6 * L * Iy),
        ((5, 5), 4 * L**2 * Iy),
        ((11, 11), 4 * L**2 * Iy),
        ((5, 11), 2 * L**2 * Iy),
        ((4, 4), tors),
        ((10, 10), tors),
        ((4, 10), -tors),
    ]
    scale = s.E / L**3
    K = [[0] * 12 for _ in range(12)]
    for (i, j), v in upper:
        K[i - 1][j - 1] = K[j - 1][i - 1] = scale * v
    return K


# --- Unrolled small-matrix algebra with structural zeros ------------------------------------------
# A matrix is a list of rows of entries; an entry is a JAX scalar (or a batch of them) or a Python
# number, a constant known when the program is traced (``0``: a structural zero). Products with a
# structural zero are skipped when tracing, so the sparsity of beam elements is used for free
# (in a planar frame the in-plane and out-of-plane DOFs never meet), and under ``vmap`` every
# operation is elementwise over the batch: no LAPACK call, no scatter, one fused loop (issue 14).


def _const(a) -> bool:
    return isinstance(a, (int, float))


def _zero(a) -> bool:
    return _const(a) and a == 0


def _mul(a, b):
    if _zero(a) or _zero(b):
        return 0
    if _const(a) and a == 1:
        return b
    if _const(b) and b == 1:
        return a
    return a * b


def _add(a, b):
    return b if _zero(a) else a if _zero(b) else a + b


def _sub(a, b):
    return a if _zero(b) else -b if _zero(a) else a - b


def _matmul(A: list, B: list) -> list:
    out = []
    for row in A:
        r = []
        for j in range(len(B[0])):
            acc = 0
            for k, a in enumerate(row):
                acc = _add(acc, _mul(a, B[k][j]))
            r.append(acc)
        out.append(r)
    return out


def _transpose(A: list) -> list:
    return [list(col) for col in zip(*A)]


def _schur_entries(K: list, kept: Sequence[int]) -> list:
    """``K_kk - K_kc K_cc^-1 K_ck`` by Gaussian elimination of the other DOFs in increasing order
    (no pivoting: ``K_cc`` symmetric positive definite), skipping structural zeros."""
    n = len(K)
    kept = [int(i) for i in kept]
    K = [list(row) for row in K]
    active = list(range(n))
    for c in [i for i in range(n) if i not in kept]:
        active.remove(c)
        pivot = K[c][c]
        row = [(j, K[c][j]) for j in active if not _zero(K[c][j])]
        for i in active:
            if _zero(K[i][c]):
                continue
            f = K[i][c] / pivot
            for j, kcj in row:
                K[i][j] = _sub(K[i][j], f * kcj)
    return [[K[i][j] for j in kept] for i in kept]


def _inverse_entries(K: list) -> list:
    """Inverse of a small nonsingular (here SPD) matrix by Gauss-Jordan elimination without
    pivoting, skipping structural zeros (a block-diagonal matrix gives a block-diagonal inverse)."""
    n = len(K)
    A = [list(row) + [1.0 if i == j else 0 for j in range(n)] for i, row in enumerate(K)]
    for c in range(n):
        pivot = A[c][c]
        A[c] = [0 if _zero(a) else a / pivot for a in A[c]]
        for i in range(n):
            if i == c or _zero(A[i][c]):
                continue
            f = A[i][c]
            A[i] = [_sub(a, _mul(f, b)) for a, b in zip(A[i], A[c])]
    return [row[n:] for row in A]


def _to_array(K: list) -> Array:
    """Stack a list-of-rows matrix into an array ``(n, m, *batch)``; constants are broadcast."""
    ref = next((a for row in K for a in row if not _const(a)), None)
    ref = jnp.zeros((), dtype=jnp.float64) if ref is None else jnp.zeros_like(ref)
    return jnp.stack([jnp.stack([ref + a if _const(a) else a for a in row]) for row in K])


def _from_array(M: Array) -> list:
    return [[M[i, j] for j in range(M.shape[1])] for i in range(M.shape[0])]


def _condense_entries(K: list, released: Sequence[int]) -> list:
    released = sorted({int(i) for i in released})
    if not released:
        return K
    n = len(K)
    kept = [i for i in range(n) if i not in released]
    S = _schur_entries(K, kept)
    out = [[0] * n for _ in range(n)]
    for a, i in enumerate(kept):
        for b, j in enumerate(kept):
            out[i][j] = S[a][b]
    return out


def _rotate_entries(K: list, R: list) -> list:
    """``S^T K S`` with ``S = diag(R, R, R, R)`` (P4 eq (7)), 3 x 3 block by block."""
    Rt = _transpose(R)
    out = [[0] * 12 for _ in range(12)]
    for a in range(4):
        for b in range(4):
            block = [row[3 * b : 3 * b + 3] for row in K[3 * a : 3 * a + 3]]
            if all(_zero(v) for r in block for v in r):
                continue
            G = _matmul(_matmul(Rt, block), R)
            for i in range(3):
                for j in range(3):
                    out[3 * a + i][3 * b + j] = G[i][j]
    return out


def solve_spd(K: Array, B: Array) -> Array:
    """Solve ``K X = B`` for a symmetric positive definite ``K`` (n x n, n small and static).

    Gaussian elimination without pivoting (stable for SPD matrices, like Cholesky), unrolled in
    plain ``jnp`` operations. pkmlib uses it instead of ``jnp.linalg.solve`` in everything a
    sweep ``vmap``s: with jaxlib 0.10 on CPU, batched LAPACK triangular solves inside a ``vmap``-ed
    program were seen to deadlock (two ``ParallelBatchMap`` calls waiting on one thread pool).
    Singular ``K`` (a type-2 singularity) gives inf/NaN or huge entries, as any solver would.
    Compiled as one program (inlined into a caller's ``jit``), not run as dozens of eager
    operations when called outside ``jit`` (under ``jax.grad``, say).
    """
    return _solve_spd(K, B)


@jax.jit
def _solve_spd(K: Array, B: Array) -> Array:
    n = K.shape[-1]
    vector = B.ndim == 1
    A = jnp.concatenate([K, B[:, None] if vector else B], axis=1)
    for k in range(n - 1):  # forward elimination
        factors = A[k + 1 :, k] / A[k, k]
        A = A.at[k + 1 :, :].add(-factors[:, None] * A[k, :][None, :])
    U, Y = A[:, :n], A[:, n:]
    X = jnp.zeros_like(Y)
    for k in reversed(range(n)):  # back substitution
        x_k = Y[k] / U[k, k]
        X = X.at[k].set(x_k)
        Y = Y - U[:, k][:, None] * x_k[None, :]
    return X[:, 0] if vector else X


def schur_complement(K: Array, kept: Sequence[int]) -> Array:
    """Static condensation of ``K`` onto the DOFs ``kept`` (the others carry no load):
    ``K_kk - K_kc K_cc^-1 K_ck``, shape ``(len(kept), len(kept))`` (P4, the procedure after ``M``:
    set the released force to zero, express its displacement, substitute)."""
    K = check_square("K", K)
    n = K.shape[-1]
    kept = list(check_indices("kept", kept, n, "a row of K"))
    if not kept or len(set(kept)) != len(kept):
        raise ValueError(f"kept must be distinct rows of K (0..{n - 1}), at least one, got {kept!r}")
    cond = [i for i in range(n) if i not in kept]
    Kkk = K[np.ix_(kept, kept)]
    if not cond:
        return Kkk
    Kkc = K[np.ix_(kept, cond)]
    Kcc = K[np.ix_(cond, cond)]
    return Kkk - Kkc @ solve_spd(Kcc, Kkc.T)


def condense(K: Array, released: Sequence[int]) -> Array:
    """Release the DOFs ``released`` of an element matrix by static condensation, keeping the size.

    The released rows and columns come back as zeros, as in P4's ``N`` (fixed-hinge, released
    ``FIXED_HINGE_Y``) and ``H`` (hinge-hinge, ``HINGE_HINGE_Y``): P4, the four-step procedure
    after the matrix ``M``.
    """
    K = check_square("K", K)
    n = K.shape[-1]
    released = sorted(set(check_indices("released", released, n, "a row of K")))
    kept = [i for i in range(n) if i not in released]
    return jnp.zeros_like(K).at[np.ix_(kept, kept)].set(schur_complement(K, kept))


def hinged_element_local(L: Array, s: BeamSection, released: Sequence[int] = ()) -> Array:
    """``frame_element_local`` with ``released`` end DOFs condensed out: ``E/l^3 N`` for
    ``FIXED_HINGE_Y`` and ``E/l^3 H`` for ``HINGE_HINGE_Y`` (P4, the matrices after ``M``)."""
    released = check_indices("released", released, 12, "a local DOF of the element")
    K = frame_element_local(L, s)
    return condense(K, released) if released else K


def rotation_xz(a: Array) -> Array:
    """P4's rotation matrix (after Fig 3) for an element at angle ``a`` in the global x-z plane:
    ``R = [[cos a, 0, sin a], [0, 1, 0], [-sin a, 0, cos a]]``; its rows are the local axes."""
    c, s = jnp.cos(a), jnp.sin(a)
    z, o = jnp.zeros_like(c), jnp.ones_like(c)
    return jnp.stack([jnp.stack([c, z, s]), jnp.stack([z, o, z]), jnp.stack([-s, z, c])])


def element_rotation(p1: Array, p2: Array, up: Sequence[float] = (0.0, 1.0, 0.0)) -> Array:
    """Rotation ``R`` from global to local coordinates of the element ``p1 -> p2`` (rows = local axes).

    Local x is along ``p2 - p1``; local z is ``x cross up`` normalised, local y ``z cross x``. For
    an element in the global x-z plane and ``up = (0, 1, 0)`` this is P4's ``R`` with
    ``a = atan2(z_2 - z_1, x_2 - x_1)`` (:func:`rotation_xz`). NaN if the element is along ``up``.
    """
    p1_in, p2_in = p1, p2
    p1 = check_array("p1", p1, (3,), ndim=1, what="a node position")
    p2 = check_array("p2", p2, (3,), ndim=1, what="a node position")
    a, b = concrete(p1_in), concrete(p2_in)
    if a is not None and b is not None and np.array_equal(a, b):
        raise ValueError(f"p2 must differ from p1 (an element of zero length has no direction), got {b.tolist()}")
    up = _check_up(up)
    ex = (p2 - p1) / jnp.linalg.norm(p2 - p1)
    ez = jnp.cross(ex, up)
    norm = jnp.linalg.norm(ez)
    ez = ez / jnp.where(norm > 0, norm, jnp.nan)
    ey = jnp.cross(ez, ex)
    return jnp.stack([ex, ey, ez])


def _check_up(up: Any) -> Array:
    """``up`` as a float64 3-vector; ``ValueError`` naming it unless it is 3 finite numbers, not all 0."""
    out = check_array("up", up, (3,), ndim=1, what="the reference vector of the local axes")
    a = concrete(up)
    if a is not None and (not np.all(np.isfinite(a)) or not np.any(a != 0)):
        raise ValueError(f"up must be a non-zero vector of 3 finite numbers, got {up!r}")
    return out


def transformation_matrix(R: Array) -> Array:
    """``S = diag(R, R, R, R)`` (P4, after eq (7)): local = ``S`` global for the 12 element DOFs."""
    R = check_array("R", R, (3, 3), ndim=2, what="a rotation, global to local")
    return jnp.kron(jnp.eye(4, dtype=jnp.float64), R)


def element_global(K_local: Array, R: Array) -> Array:
    """``K^j = S^T K^j_local S`` (P4 eq (7))."""
    K_local = check_array("K_local", K_local, (12, 12), ndim=2, what="an element matrix")
    S = transformation_matrix(R)
    return S.T @ K_local @ S


def node_dof(node: int, k: int) -> int:
    """Global index of DOF ``k`` (``U_X`` .. ``THETA_Z``, 0..5) of ``node``: ``6 node + k``."""
    k = check_index("k", k, DOF_PER_NODE, "a DOF, U_X .. THETA_Z")
    node = check_count("node", node, minimum=0)
    return DOF_PER_NODE * node + k


def node_dofs(*nodes: int) -> tuple[int, ...]:
    """All six global DOFs of each of ``nodes`` (e.g. clamped nodes)."""
    nodes = tuple(check_count("nodes", n, minimum=0) for n in nodes)
    return tuple(node_dof(n, k) for n in nodes for k in range(DOF_PER_NODE))


@dataclasses.dataclass(frozen=True)
class Frame:
    """Topology of a spatial frame (static, hashable): nodes, elements, releases, removed DOFs.

    Attributes:
        n_nodes: number of nodes; coordinates are passed as ``(n_nodes, 3)`` arrays.
        elements: ``(node_1, node_2)`` per element; local x runs from node 1 to node 2.
        releases: per element, the local DOFs (0..11) released by condensation, best declared
            as hinges with :func:`release` (``()`` none, ``release(2)`` = ``FIXED_HINGE_Y`` for
            P4's ``N``, ``release(1, 2)`` = ``HINGE_HINGE_Y`` for ``H``). Default: none.
        fixed_dofs: global DOFs held at zero (supports, clamps: :func:`node_dofs`).
        empty_dofs: global DOFs left without stiffness by the releases (a rotation about a hinge
            axis released in every element at the node), removed like P4's "empty rows".
            Default ``None``: derived from ``releases`` (:func:`release`): the rotation about
            ``up`` at every node where all its elements release the rotation about local y
            (which is ``up`` for elements perpendicular to ``up``, as in a planar frame).
        up: the reference vector of :func:`element_rotation` (P4: global y, the hinge axes).
    """

    n_nodes: int
    elements: tuple[tuple[int, int], ...]
    releases: tuple[tuple[int, ...], ...] = ()
    fixed_dofs: tuple[int, ...] = ()
    empty_dofs: tuple[int, ...] | None = None
    up: tuple[float, float, float] = (0.0, 1.0, 0.0)

    def __post_init__(self):
        n = check_count("n_nodes", self.n_nodes, minimum=2)
        object.__setattr__(self, "n_nodes", n)
        # the assembled (6 n_nodes)^2 global matrix of global_matrix / solve (and the Python loops
        # over the nodes and DOFs here): refused before anything runs when it cannot fit
        check_memory(
            8.0 * (DOF_PER_NODE * float(n)) ** 2,
            what=f"a frame's global stiffness matrix of {DOF_PER_NODE * n:.3g}^2 entries",
            parameter="n_nodes",
        )
        object.__setattr__(self, "up", tuple(float(u) for u in np.asarray(_check_up(self.up))))
        pairs = self.elements
        if isinstance(pairs, (str, bytes)) or not hasattr(pairs, "__iter__"):
            raise ValueError(f"elements must be a sequence of (node_1, node_2) pairs, got {pairs!r}")
        elements = []
        for pair in pairs:
            ab = check_indices("elements", pair, n, "a node") if hasattr(pair, "__iter__") else ()
            if len(ab) != 2 or ab[0] == ab[1]:
                raise ValueError(f"elements: {pair!r} is not a pair of distinct nodes 0..{n - 1}")
            elements.append(ab)
        elements = tuple(elements)
        if isinstance(self.releases, (str, bytes)) or not hasattr(self.releases, "__iter__"):
            raise ValueError(f"releases must be one sequence of local DOFs 0..11 per element, got {self.releases!r}")
        releases = tuple(check_indices("releases", r, 2 * DOF_PER_NODE, "a local DOF") for r in self.releases)
        releases = releases or ((),) * len(elements)
        if len(releases) != len(elements):
            raise ValueError(f"releases: {len(releases)} entries for {len(elements)} elements")
        if self.empty_dofs is None:
            object.__setattr__(self, "empty_dofs", _hinge_dofs(n, elements, releases, self.up))
        for name in ("fixed_dofs", "empty_dofs"):
            check_indices(name, getattr(self, name), DOF_PER_NODE * n, "a global DOF")
        object.__setattr__(self, "elements", elements)
        object.__setattr__(self, "releases", releases)
        object.__setattr__(self, "fixed_dofs", tuple(sorted({int(i) for i in self.fixed_dofs})))
        object.__setattr__(self, "empty_dofs", tuple(sorted({int(i) for i in self.empty_dofs})))

    @property
    def n_dofs(self) -> int:
        return DOF_PER_NODE * self.n_nodes

    @property
    def free_dofs(self) -> tuple[int, ...]:
        """Global DOFs kept in the reduced matrix, in increasing order."""
        removed = set(self.fixed_dofs) | set(self.empty_dofs)
        return tuple(i for i in range(self.n_dofs) if i not in removed)

    def reduced_index(self, global_dof: int) -> int:
        """Position of a global DOF in the reduced matrix (ValueError if it was removed)."""
        try:
            return self.free_dofs.index(int(global_dof))
        except ValueError:
            raise ValueError(f"DOF {global_dof} is removed (fixed or empty)") from None

    def _sections(self, sections) -> list[BeamSection]:
        if isinstance(sections, BeamSection):
            return [sections] * len(self.elements)
        sections = list(sections)
        if len(sections) != len(self.elements):
            raise ValueError(f"sections: {len(sections)} for {len(self.elements)} elements")
        return sections

    def element_matrices(self, nodes: Array, sections) -> list[Array]:
        """Each element's 12 x 12 matrix in the global frame: released ends condensed in local
        coordinates, then ``S^T K_local S`` (P4 eq (7)); the length comes from the nodes."""
        nodes = jnp.asarray(nodes, dtype=jnp.float64)
        out = []
        for (a, b), rel, s in zip(self.elements, self.releases, self._sections(sections)):
            L = jnp.linalg.norm(nodes[b] - nodes[a])
            R = element_rotation(nodes[a], nodes[b], self.up)
            out.append(element_global(hinged_element_local(L, s, rel), R))
        return out

    def global_matrix(self, nodes: Array, sections) -> Array:
        """Assembled ``(6 n_nodes, 6 n_nodes)`` stiffness matrix before any DOF is removed (P4 eq
        (6): each element's blocks ``K^j_11, K^j_12, K^j_21, K^j_22`` added at its nodes)."""
        K = jnp.zeros((self.n_dofs, self.n_dofs), dtype=jnp.float64)
        for (a, b), Ke in zip(self.elements, self.element_matrices(nodes, sections)):
            idx = np.array(node_dofs(a, b))
            K = K.at[np.ix_(idx, idx)].add(Ke)
        return K

    def reduced_matrix(self, nodes: Array, sections) -> Array:
        """The global matrix without the fixed and empty DOFs (P4: "the empty rows and columns and
        the first and last six rows and columns, of the clamps, are removed")."""
        free = np.array(self.free_dofs)
        return self.global_matrix(nodes, sections)[np.ix_(free, free)]

    def solve(self, nodes: Array, sections, loads: Array) -> Array:
        """Displacements ``d`` of ``K d = P`` (P4 eq (3)) under nodal ``loads`` ``(n_nodes, 6)``.

        Returns ``(n_nodes, 6)``, zero at removed DOFs (loads on removed DOFs are ignored).
        """
        free = np.array(self.free_dofs)
        loads = check_array("loads", loads, (self.n_nodes, DOF_PER_NODE), ndim=2, what="one row of 6 per node")
        P = loads.reshape(self.n_dofs)[free]
        d = solve_spd(self.reduced_matrix(nodes, sections), P)
        return jnp.zeros(self.n_dofs, dtype=jnp.float64).at[free].set(d).reshape(self.n_nodes, DOF_PER_NODE)

    # --- condensation onto loaded DOFs, unrolled (fast under vmap) ------------------------------

    def node_free_dofs(self, node: int) -> tuple[int, ...]:
        """The DOF indices ``k`` (0..5, ``U_X`` .. ``THETA_Z``) of ``node`` kept in the reduced
        system, in order: the rows and columns of :meth:`node_stiffness` and
        :meth:`node_compliance` (P4's node C: ``(U_X, U_Y, U_Z, THETA_X, THETA_Z)``)."""
        node = int(node)
        if not 0 <= node < self.n_nodes:
            raise ValueError(f"node must be in 0..{self.n_nodes - 1}, got {node!r}")
        free = set(self.free_dofs)
        return tuple(k for k in range(DOF_PER_NODE) if node_dof(node, k) in free)

    def _entries(self, nodes: Array, sections, rotations) -> list:
        """Reduced matrix as a list of entries (structural zeros ``0``), assembled unrolled."""
        nodes = jnp.asarray(nodes, dtype=jnp.float64)
        K = [[0] * self.n_dofs for _ in range(self.n_dofs)]
        for e, ((a, b), rel, s) in enumerate(zip(self.elements, self.releases, self._sections(sections))):
            L = jnp.sqrt(jnp.sum((nodes[b] - nodes[a]) ** 2))
            R = _from_array(element_rotation(nodes[a], nodes[b], self.up)) if rotations is None else rotations[e]
            Ke = _rotate_entries(_condense_entries(_element_local_entries(L, s), rel), R)
            idx = node_dofs(a, b)
            for i in range(12):
                for j in range(12):
                    K[idx[i]][idx[j]] = _add(K[idx[i]][idx[j]], Ke[i][j])
        free = self.free_dofs
        return [[K[i][j] for j in free] for i in free]

    def condensed_stiffness(self, nodes: Array, sections, kept: Sequence[int], rotations=None) -> Array:
        """Stiffness seen at the global DOFs ``kept`` when only they are loaded: the reduced matrix
        (:meth:`reduced_matrix`) statically condensed onto them, ``K_kk - K_kc K_cc^-1 K_ck``
        (P4 eq (3) solved for the other DOFs; same numbers as :func:`schur_complement` of
        :meth:`reduced_matrix`). Shape ``(len(kept), len(kept))`` in the order of ``kept``.

        ``rotations``: per-element 3 x 3 rotations as nested lists whose constant entries (``0``,
        ``1.0``) are structural (e.g. a planar frame's ``[[c, 0, s], [0, 1.0, 0], [-s, 0, c]]``,
        P4's ``R``). With them the assembly and condensation are unrolled with the structure
        known at trace time (no LAPACK, no scatter; in a planar frame the out-of-plane DOFs drop
        out): under ``vmap`` one fused elementwise program, over 10x faster than the dense
        route and with a few hundred bytes of temporaries per point (benchmarks/p4_stiffness_map.py).
        Without them (default) the dense route: :func:`element_rotation` of the nodes,
        :meth:`reduced_matrix` and :func:`schur_complement`.
        """
        kept = self._kept_positions(kept)
        if rotations is None:  # no structure known: the dense route (unrolling it would only compile longer)
            return schur_complement(self.reduced_matrix(nodes, sections), kept)
        return _to_array(_schur_entries(self._entries(nodes, sections, rotations), kept))

    def _kept_positions(self, kept: Sequence[int]) -> list[int]:
        free = self.free_dofs
        kept = [int(i) for i in kept]
        bad = [i for i in kept if i not in free]
        if bad or len(set(kept)) != len(kept) or not kept:
            raise ValueError(f"kept: global DOFs {bad or kept} are removed (fixed or empty), repeated or none")
        return [free.index(i) for i in kept]

    def node_stiffness(self, nodes: Array, sections, node: int, rotations=None) -> Array:
        """Stiffness ``(k, k)`` of ``node`` over its free DOFs (:meth:`node_free_dofs`), only
        that node loaded: :meth:`condensed_stiffness` onto them."""
        kept = [node_dof(node, k) for k in self.node_free_dofs(node)]
        return self.condensed_stiffness(nodes, sections, kept, rotations)

    def node_compliance(self, nodes: Array, sections, node: int, rotations=None) -> Array:
        """Compliance ``(k, k)`` of ``node`` over its free DOFs (:meth:`node_free_dofs`): column
        ``j`` is the node's displacement under a unit load on its ``j``-th free DOF (P4 eq (3),
        ``d = K^-1 P``), the inverse of :meth:`node_stiffness`. E.g. P4's node C: the full 5 x 5
        compliance over ``(u_x, u_y, u_z, theta_x, theta_z)``, mm/N, mm/(N mm), rad/N."""
        kept = self._kept_positions([node_dof(node, k) for k in self.node_free_dofs(node)])
        if rotations is None:  # dense route: unit loads on the node's DOFs, K d = P (P4 eq (3))
            K = self.reduced_matrix(nodes, sections)
            P = jnp.zeros((K.shape[0], len(kept)), dtype=jnp.float64).at[np.array(kept), np.arange(len(kept))].set(1.0)
            return solve_spd(K, P)[np.array(kept)]
        return _to_array(_inverse_entries(_schur_entries(self._entries(nodes, sections, rotations), kept)))


def _hinge_dofs(n_nodes, elements, releases, up) -> tuple[int, ...]:
    """Global DOFs emptied by the releases: the rotation about ``up`` at each node where every
    element releases its rotation about local y at that end (see :func:`release`)."""
    up = np.asarray(up, dtype=np.float64)
    axis = np.flatnonzero(up)
    out = []
    for node in range(n_nodes):
        ends = [(DOF_PER_NODE * e.index(node) + THETA_Y) in rel for e, rel in zip(elements, releases) if node in e]
        if ends and all(ends):
            if len(axis) != 1:
                raise ValueError(
                    f"empty_dofs: node {node} is hinged about up = {tuple(up)}, which is not a global "
                    "axis; pass empty_dofs explicitly"
                )
            out.append(node_dof(node, THETA_X + int(axis[0])))
    return tuple(out)


def find_empty_dofs(K: Array, rtol: float = 1e-12) -> tuple[int, ...]:
    """Rows of ``K`` (one matrix, not traced) whose entries are all below ``rtol * max|K|``:
    the DOFs a frame leaves without stiffness (check for :attr:`Frame.empty_dofs`)."""
    K = np.abs(np.asarray(check_square("K", K)))
    if K.ndim != 2:
        raise ValueError(f"K must be one square matrix (n, n), got shape {K.shape}")
    check_nonnegative("rtol", rtol)
    return tuple(int(i) for i in np.flatnonzero(K.max(axis=1) <= rtol * K.max()))


def canonical_sign(u: Array, order: Sequence[int] | None = None, rtol: float = 1e-9) -> Array:
    """``u`` or ``-u``, whichever has its first non-negligible component positive.

    A direction of a line (a worst force direction, a diagonal) has no sign of its own; this
    fixes one so that a stored direction does not depend on round-off or on the call path (jitted
    or not). Components are examined in ``order`` (default ``0, 1, ...``); the first with
    ``|u_k| > rtol |u|`` is made positive (all negligible: ``u`` unchanged). Works under
    ``jit``/``vmap``; its derivative is that of the chosen sign (piecewise constant). ``u`` may
    be ``(n,)`` or ``(n, *batch)`` (one direction per column).
    """
    u = check_array("u", u, min_ndim=1)
    order = (
        list(range(u.shape[0]))
        if order is None
        else list(check_indices("order", order, u.shape[0], "a component of u"))
    )
    if len(set(order)) != len(order):
        raise ValueError(f"order must list distinct components of u (indices 0..{u.shape[0] - 1}), got {tuple(order)}")
    check_nonnegative("rtol", rtol)
    tol = rtol * jnp.sqrt(jnp.sum(u * u, axis=0))
    sign = jnp.ones_like(u[0])
    for k in reversed(order):  # the first in order wins
        sign = jnp.where(jnp.abs(u[k]) > tol, jnp.where(u[k] < 0, -1.0, 1.0), sign)
    return u * sign[None]


def extremal_stiffness(K: Array) -> Array:
    """Smallest and largest stiffness over directions of a symmetric 2 x 2 stiffness ``K``:
    ``min/max_u u^T K u`` over unit ``u`` = its eigenvalues ``m -+ r``, ``m = (K_00 + K_11)/2``,
    ``r = sqrt(((K_00 - K_11)/2)^2 + K_01^2)``, in closed form (no eigen-decomposition).

    Returns ``(2, *batch)`` ascending. At an isotropic ``K`` (``r = 0``, a tie of the two
    directions) the eigenvalues are not differentiable; the derivative returned there is the
    one-sided choice ``d r = 0`` (that of ``m``), never NaN.
    """
    K = check_array("K", K, (2, 2), what="a 2 x 2 stiffness")
    m = 0.5 * (K[0, 0] + K[1, 1])
    r2 = (0.5 * (K[0, 0] - K[1, 1])) ** 2 + (0.5 * (K[0, 1] + K[1, 0])) ** 2
    positive = r2 > 0
    r = jnp.where(positive, jnp.sqrt(jnp.where(positive, r2, 1.0)), 0.0)
    return jnp.stack([m - r, m + r])


def directional_stiffness(K: Array, u: Array) -> Array:
    """Stiffness along ``u`` of a load applied along ``u``: ``|P| / (d . u)`` with ``d = K^-1 P``,
    ``P = |P| u / |u|``, i.e. ``1 / (u^T K^-1 u)`` for unit ``u`` (P4 text before Fig 6: "the
    displacement in the direction of the external force and the corresponding stiffness")."""
    K = check_square("K", K)
    u_in = concrete(u)
    u = check_array("u", u, (K.shape[0],), ndim=1, what="a direction")
    if u_in is not None and not np.any(u_in != 0.0):
        raise ValueError(f"u must be a nonzero direction, got {u_in.tolist()}")
    u = u / jnp.linalg.norm(u)
    return 1.0 / (u @ solve_spd(K, u))
