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
:func:`pkmlib.sweep`) and differentiate. The topology (:class:`Frame`) is static.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, Sequence

import jax
import jax.numpy as jnp
import numpy as np

from . import _config  # noqa: F401  (float64)
from ._validation import check_positive

Array = Any

#: DOFs per node and their indices: ``(u_x, u_y, u_z, theta_x, theta_y, theta_z)`` (P4, ``M``).
DOF_PER_NODE = 6
U_X, U_Y, U_Z, THETA_X, THETA_Y, THETA_Z = range(DOF_PER_NODE)
#: Released local DOFs of a fixed-hinge element (rotation about local y at node 2): P4's ``N``.
FIXED_HINGE_Y = (DOF_PER_NODE + THETA_Y,)
#: Released local DOFs of a hinge-hinge element (rotation about local y at both ends): P4's ``H``.
HINGE_HINGE_Y = (THETA_Y, DOF_PER_NODE + THETA_Y)


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

    @classmethod
    def create(cls, *, E, G, A, I_y, I_z, I_p) -> "BeamSection":
        values = dict(E=E, G=G, A=A, I_y=I_y, I_z=I_z, I_p=I_p)
        return cls(**{k: check_positive(k, v) for k, v in values.items()})


jax.tree_util.register_dataclass(
    BeamSection, data_fields=[f.name for f in dataclasses.fields(BeamSection)], meta_fields=[]
)


def rectangle_section(b: float, h: float, n_terms: int = 50) -> dict[str, float]:
    """Area, second moments and torsion constant of a solid ``b x h`` rectangle.

    ``h`` is the side along local z, ``b`` along local y: ``A = b h``, ``I_y = b h^3 / 12``
    (bending in the local x-z plane), ``I_z = h b^3 / 12``, and the Saint-Venant torsion constant
    ``I_p = (a c^3 / 3) [1 - (192 / pi^5) (c / a) sum_{n odd} tanh(n pi a / (2 c)) / n^5]`` with
    ``a = max(b, h)``, ``c = min(b, h)`` (Timoshenko & Goodier, Theory of Elasticity, sec. 109).
    P4's table prints ``I_y, I_z, I_p`` but not the area; they are those of ``b = 10``, ``h = 16`` mm.
    """
    b = check_positive("b", b)
    h = check_positive("h", h)
    a, c = max(b, h), min(b, h)
    series = sum(math.tanh(n * math.pi * a / (2 * c)) / n**5 for n in range(1, 2 * n_terms, 2))
    I_p = a * c**3 / 3 * (1 - 192 / math.pi**5 * (c / a) * series)
    return {"A": b * h, "I_y": b * h**3 / 12, "I_z": h * b**3 / 12, "I_p": I_p}


def frame_element_local(L: Array, s: BeamSection) -> Array:
    """The 12 x 12 Euler-Bernoulli frame element with torsion in local coordinates, both ends fixed.

    ``K^0_local = E / l^3 M`` (P4, the matrix ``M`` after eq (7); Kassimali [8]):
    axial ``A l^2``, torsion ``G I_p l^2 / E``, bending in x-y with ``I_z`` (DOFs u_y, theta_z)
    and in x-z with ``I_y`` (DOFs u_z, theta_y, with the minus signs of a right-handed theta_y).
    """
    L = jnp.asarray(L, dtype=jnp.float64)
    A, Iy, Iz = s.A, s.I_y, s.I_z
    tors = s.G * s.I_p * L**2 / s.E
    # (row, col) 1-based as in P4, value; the lower triangle is filled by symmetry.
    upper = [
        ((1, 1), A * L**2), ((7, 7), A * L**2), ((1, 7), -A * L**2),
        ((2, 2), 12 * Iz), ((8, 8), 12 * Iz), ((2, 8), -12 * Iz),
        ((2, 6), 6 * L * Iz), ((2, 12), 6 * L * Iz), ((6, 8), -6 * L * Iz), ((8, 12), -6 * L * Iz),
        ((6, 6), 4 * L**2 * Iz), ((12, 12), 4 * L**2 * Iz), ((6, 12), 2 * L**2 * Iz),
        ((3, 3), 12 * Iy), ((9, 9), 12 * Iy), ((3, 9), -12 * Iy),
        ((3, 5), -6 * L * Iy), ((3, 11), -6 * L * Iy), ((5, 9), 6 * L * Iy), ((9, 11), 6 * L * Iy),
        ((5, 5), 4 * L**2 * Iy), ((11, 11), 4 * L**2 * Iy), ((5, 11), 2 * L**2 * Iy),
        ((4, 4), tors), ((10, 10), tors), ((4, 10), -tors),
    ]
    M = jnp.zeros((12, 12), dtype=jnp.float64)
    for (i, j), v in upper:
        M = M.at[i - 1, j - 1].set(v)
        M = M.at[j - 1, i - 1].set(v)
    return s.E / L**3 * M


def solve_spd(K: Array, B: Array) -> Array:
    """Solve ``K X = B`` for a symmetric positive definite ``K`` (n x n, n small and static).

    Gaussian elimination without pivoting (stable for SPD matrices, like Cholesky), unrolled in
    plain ``jnp`` operations. pkmlib uses it instead of ``jnp.linalg.solve`` in everything a
    sweep ``vmap``s: with jaxlib 0.10 on CPU, batched LAPACK triangular solves inside a ``vmap``-ed
    program were seen to deadlock (two ``ParallelBatchMap`` calls waiting on one thread pool).
    Singular ``K`` (a type-2 singularity) gives inf/NaN or huge entries, as any solver would.
    """
    n = K.shape[-1]
    vector = B.ndim == 1
    A = jnp.concatenate([K, B[:, None] if vector else B], axis=1)
    for k in range(n - 1):  # forward elimination
        factors = A[k + 1:, k] / A[k, k]
        A = A.at[k + 1:, :].add(-factors[:, None] * A[k, :][None, :])
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
    n = K.shape[-1]
    kept = [int(i) for i in kept]
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
    released = sorted({int(i) for i in released})
    n = K.shape[-1]
    kept = [i for i in range(n) if i not in released]
    return jnp.zeros_like(K).at[np.ix_(kept, kept)].set(schur_complement(K, kept))


def hinged_element_local(L: Array, s: BeamSection, released: Sequence[int] = ()) -> Array:
    """``frame_element_local`` with ``released`` end DOFs condensed out: ``E/l^3 N`` for
    ``FIXED_HINGE_Y`` and ``E/l^3 H`` for ``HINGE_HINGE_Y`` (P4, the matrices after ``M``)."""
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
    p1 = jnp.asarray(p1, dtype=jnp.float64)
    p2 = jnp.asarray(p2, dtype=jnp.float64)
    ex = (p2 - p1) / jnp.linalg.norm(p2 - p1)
    ez = jnp.cross(ex, jnp.asarray(up, dtype=jnp.float64))
    norm = jnp.linalg.norm(ez)
    ez = ez / jnp.where(norm > 0, norm, jnp.nan)
    ey = jnp.cross(ez, ex)
    return jnp.stack([ex, ey, ez])


def transformation_matrix(R: Array) -> Array:
    """``S = diag(R, R, R, R)`` (P4, after eq (7)): local = ``S`` global for the 12 element DOFs."""
    return jnp.kron(jnp.eye(4, dtype=jnp.float64), R)


def element_global(K_local: Array, R: Array) -> Array:
    """``K^j = S^T K^j_local S`` (P4 eq (7))."""
    S = transformation_matrix(R)
    return S.T @ K_local @ S


def node_dof(node: int, k: int) -> int:
    """Global index of DOF ``k`` (``U_X`` .. ``THETA_Z``) of ``node``."""
    return DOF_PER_NODE * int(node) + int(k)


def node_dofs(*nodes: int) -> tuple[int, ...]:
    """All six global DOFs of each of ``nodes`` (e.g. clamped nodes)."""
    return tuple(node_dof(n, k) for n in nodes for k in range(DOF_PER_NODE))


@dataclasses.dataclass(frozen=True)
class Frame:
    """Topology of a spatial frame (static, hashable): nodes, elements, releases, removed DOFs.

    Attributes:
        n_nodes: number of nodes; coordinates are passed as ``(n_nodes, 3)`` arrays.
        elements: ``(node_1, node_2)`` per element; local x runs from node 1 to node 2.
        releases: per element, the local DOFs (0..11) released by condensation (``()`` none,
            ``FIXED_HINGE_Y`` for P4's ``N``, ``HINGE_HINGE_Y`` for ``H``). Default: none.
        fixed_dofs: global DOFs held at zero (supports, clamps: :func:`node_dofs`).
        empty_dofs: global DOFs left without stiffness by the releases (a rotation about a hinge
            axis released in every element at the node), removed like P4's "empty rows".
        up: the reference vector of :func:`element_rotation` (P4: global y, the hinge axes).
    """

    n_nodes: int
    elements: tuple[tuple[int, int], ...]
    releases: tuple[tuple[int, ...], ...] = ()
    fixed_dofs: tuple[int, ...] = ()
    empty_dofs: tuple[int, ...] = ()
    up: tuple[float, float, float] = (0.0, 1.0, 0.0)

    def __post_init__(self):
        n = int(self.n_nodes)
        if n < 2:
            raise ValueError(f"n_nodes must be at least 2, got {self.n_nodes!r}")
        elements = tuple((int(a), int(b)) for a, b in self.elements)
        for a, b in elements:
            if not (0 <= a < n and 0 <= b < n) or a == b:
                raise ValueError(f"elements: ({a}, {b}) is not a pair of distinct nodes 0..{n - 1}")
        releases = tuple(tuple(int(i) for i in r) for r in self.releases) or ((),) * len(elements)
        if len(releases) != len(elements):
            raise ValueError(f"releases: {len(releases)} entries for {len(elements)} elements")
        if any(not 0 <= i < 2 * DOF_PER_NODE for r in releases for i in r):
            raise ValueError("releases: local DOF indices must be in 0..11")
        for name in ("fixed_dofs", "empty_dofs"):
            bad = [i for i in getattr(self, name) if not 0 <= int(i) < DOF_PER_NODE * n]
            if bad:
                raise ValueError(f"{name}: indices {bad} outside 0..{DOF_PER_NODE * n - 1}")
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
        P = jnp.asarray(loads, dtype=jnp.float64).reshape(self.n_dofs)[free]
        d = solve_spd(self.reduced_matrix(nodes, sections), P)
        return jnp.zeros(self.n_dofs, dtype=jnp.float64).at[free].set(d).reshape(self.n_nodes, DOF_PER_NODE)


def find_empty_dofs(K: Array, rtol: float = 1e-12) -> tuple[int, ...]:
    """Rows of ``K`` (one matrix, not traced) whose entries are all below ``rtol * max|K|``:
    the DOFs a frame leaves without stiffness (check for :attr:`Frame.empty_dofs`)."""
    K = np.abs(np.asarray(K, dtype=np.float64))
    return tuple(int(i) for i in np.flatnonzero(K.max(axis=1) <= rtol * K.max()))


def directional_stiffness(K: Array, u: Array) -> Array:
    """Stiffness along ``u`` of a load applied along ``u``: ``|P| / (d . u)`` with ``d = K^-1 P``,
    ``P = |P| u / |u|``, i.e. ``1 / (u^T K^-1 u)`` for unit ``u`` (P4 text before Fig 6: "the
    displacement in the direction of the external force and the corresponding stiffness")."""
    u = jnp.asarray(u, dtype=jnp.float64)
    u = u / jnp.linalg.norm(u)
    return 1.0 / (u @ solve_spd(K, u))
