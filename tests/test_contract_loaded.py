"""The mechanism contract over every *loaded* mechanism: each description file of data/mechanisms/
(pkmlib.load_mechanism) and each Extended-URDF model of tests/data/ (pkmlib.load_urdf_mechanism),
found by globbing, so a new file is covered without editing this one.

The properties are those of tests/test_contract.py (which runs them over the hand-written paper
modules), here on the numerical inverse position (pkmlib._positions) of a mechanism generated from
its joints:

- A = dF/dx and B = dF/dq (autodiff) against central differences of F;
- J^-1 against central differences of the numerical inverse position, and J J^-1 = I on every
  branch that reaches the pose (where det(A) and det(B) are clear of 0);
- inverse then forward is the identity on every branch: each branch (every sign pattern of
  dF_i/dq_i) that reaches the pose has those signs and F = 0 there, and pk.forward_position from a
  perturbed guess returns the pose; a branch that does not reach it is NaN in every actuator;
- NaN outside the workspace, on every branch, never an exception;
- det(A) changes sign across the singular curves: along lines through the pose (one per output
  coordinate) the sign changes of det(A) are refined by multisection to 1e-10 of the line, and A is
  singular there (smallest singular value, independent of det).

The pose of each mechanism comes from the mechanism itself: a description that names a paper takes
the pose of tests/test_contract.py's case for the registered paper mechanism with the same output
coordinates (inside its workspace on the paper's branch); any other the best-conditioned of 64
seeded random poses (in the scale of its parameters) that some branch reaches. The far pose moves
every length coordinate by ten times the largest parameter.

Cost (compilation dominates): every call runs on one batch of BATCH poses (padded), so each
mechanism compiles its numerical inverse (with residuals), F, and A, B by jax.jacfwd of F once (the
many poses of the singular-curve search); pkmlib's own A_matrix, B_matrix, inverse_jacobian and
matrix_inverse run once per mechanism, eagerly (compiled they cost P5 alone ten seconds), and are
checked against central differences and against the jacfwd A and B.
"""

from __future__ import annotations

import functools
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from test_contract import CASES as PAPER_CASES

import pkmlib as pk
from pkmlib._papers import PAPERS
from pkmlib.mechanisms import sign_branches

DESC = pk.DATA_DIR / "mechanisms"
DATA = Path(__file__).resolve().parent / "data"

#: Every description file and every Extended-URDF model (a folder with robot.urdf and robot.yaml).
SOURCES = [("description", p) for p in sorted(DESC.glob("*.yaml"))] + [
    ("urdf", p.parent) for p in sorted(DATA.glob("*/robot.urdf")) if (p.parent / "robot.yaml").is_file()
]
IDS = [p.stem if kind == "description" else f"urdf-{p.name}" for kind, p in SOURCES]

#: Poses per compiled call (padded): one shape, so one compilation per mechanism and function.
BATCH = 64


def load(kind, path):
    if kind == "description":
        return pk.load_mechanism(path)
    return pk.load_urdf_mechanism(path / "robot.urdf", path / "robot.yaml")


def paper_pose(mech):
    """The pose of tests/test_contract.py's case for the registered mechanism of the description's
    paper with the same output coordinates, or None (no paper)."""
    paper = mech.description.paper
    if paper is None:
        return None
    module = PAPERS[paper].mechanism_module()
    keys = [k for k, m in module.MECHANISMS.items() if m.output_names == mech.output_names]
    assert len(keys) == 1, f"{mech.name}: no single mechanism of {paper} has the outputs {mech.output_names}"
    return np.asarray(PAPER_CASES[paper, keys[0]]["x"], dtype=np.float64)


class Case:
    """A loaded mechanism, its pose and home branch, and its maps, each compiled once on BATCH poses:
    F, the numerical inverse (pk.inverse_positions) and A, B by jax.jacfwd of F (the references for
    the many poses of the singular-curve search; the A and B of pkmlib equal them, tested)."""

    def __init__(self, kind, path):
        self.mech = m = load(kind, path)
        self.p = m.params
        self.n, self.n_x = m.n_actuators, m.n_outputs
        self.angle = np.array([u == "rad" for u in m.output_units])
        #: the largest parameter: the length scale of the description (in its unit)
        self.L = max(abs(float(v)) for v in m.params.values())
        self.branches = sign_branches(self.n)
        self._F = jax.jit(lambda x, q, p: m.constraints(x, q, p))
        self._AB = jax.jit(
            jax.vmap(
                lambda x, q, p: (jax.jacfwd(m.constraints, 0)(x, q, p), jax.jacfwd(m.constraints, 1)(x, q, p)),
                in_axes=(1, 1, None),
            )
        )
        x = paper_pose(m)
        if x is None:
            x, b = self.search_pose()
        else:
            b = m.default_branch
        self.x, self.branch = x, tuple(float(s) for s in b)
        self.q = self.inverse(self.x[None], self.branch)[0]
        assert np.all(np.isfinite(self.q)), f"{m.name}: the pose {x} is outside the workspace of {self.branch}"

    # every call on m <= BATCH poses (rows), padded with the last one to one shape (n, BATCH)
    @staticmethod
    def _pad(X):
        X = np.asarray(X, dtype=np.float64)
        assert 0 < len(X) <= BATCH
        return jnp.asarray(np.concatenate([X, np.repeat(X[-1:], BATCH - len(X), axis=0)]).T)

    def solve(self, X, branch):
        """pk.inverse_positions on ``branch`` at the poses X (m, n_x): q (m, n) and the residual
        max |F| (m,) (always with residuals: one compilation)."""
        sol = pk.inverse_positions(self.mech, self._pad(X), self.p, branch, residuals=True)
        return np.asarray(sol.q).T[: len(X)], np.asarray(sol.residual)[: len(X)]

    def inverse(self, X, branch):
        return self.solve(X, branch)[0]

    def F(self, X, Q):
        return np.asarray(self._F(self._pad(X), self._pad(Q), self.p)).T[: len(X)]

    def AB(self, X, Q):
        """A (m, n, n_x), B (m, n, n) and det(A) (m,), by jax.jacfwd of F."""
        A, B = (np.asarray(v)[: len(X)] for v in self._AB(self._pad(X), self._pad(Q), self.p))
        with np.errstate(invalid="ignore"):  # NaN outside the workspace
            return A, B, np.linalg.det(A)

    def pk_matrices(self, X, Q):
        """pk.A_matrix, pk.B_matrix, pk.inverse_jacobian and J = pk.matrix_inverse(J^-1) (what
        pk.jacobian returns), each (m, rows, cols), at the poses X: once per test, so evaluated
        eagerly (compiling them costs P5 ten seconds)."""
        x, q = self._pad(X), self._pad(Q)
        J_inv = pk.inverse_jacobian(self.mech, x, q, self.p)
        out = {
            "A": pk.A_matrix(self.mech, x, q, self.p),
            "B": pk.B_matrix(self.mech, x, q, self.p),
            "J_inv": J_inv,
            "J": pk.matrix_inverse(J_inv),
        }
        return {k: np.moveaxis(np.asarray(v), -1, 0)[: len(X)] for k, v in out.items()}

    def random_poses(self):
        """BATCH seeded random poses: lengths in [-L, L], angles in [-pi, pi]."""
        half = np.where(self.angle, np.pi, self.L)
        return np.random.default_rng(0).uniform(-half, half, (BATCH, self.n_x))

    def search_pose(self):
        """The best-conditioned (the smaller reciprocal condition number of A and B) of the random
        poses, on the description's default branch, or where it has none on every branch."""
        X = self.random_poses()
        best, found = -1.0, None
        for b in self.branches if self.mech.default_branch is None else (self.mech.default_branch,):
            Q = self.inverse(X, b)
            ok = np.all(np.isfinite(Q), axis=1)
            if not ok.any():
                continue
            A, B, _ = self.AB(X[ok], Q[ok])
            rcond = np.minimum(1.0 / np.linalg.cond(A), 1.0 / np.linalg.cond(B))
            k = int(np.argmax(rcond))
            if rcond[k] > best:
                best, found = rcond[k], (X[ok][k], b)
        assert found is not None, f"{self.mech.name}: no branch reaches any of {BATCH} random poses"
        return found


@functools.lru_cache(maxsize=None)
def case(index):
    return Case(*SOURCES[index])


PARAMS = pytest.mark.parametrize("index", range(len(SOURCES)), ids=IDS)


def steps(v):
    return 1e-6 * np.maximum(np.abs(np.asarray(v)), 1.0)


def central(f, z, h):
    """d f / d z by central differences (step h_k): ``f`` maps points (m, k) to values (m, r);
    returns (r, k)."""
    E = np.diag(h)
    values = f(np.concatenate([z + E, z - E]))
    k = len(z)
    return ((values[:k] - values[k:]) / (2.0 * h[:, None])).T


@functools.lru_cache(maxsize=None)
def reached(index):
    """Every branch that reaches the pose: ``{branch: q}`` (one inverse call per branch; every other
    branch is NaN in every actuator), and pkmlib's matrices at each (pose, q), in that order."""
    c = case(index)
    sols = {}
    for b in c.branches:
        q = c.inverse(c.x[None], b)[0]
        assert np.all(np.isnan(q)) or np.all(np.isfinite(q)), (b, q)
        if np.all(np.isfinite(q)):
            sols[b] = q
    Q = np.stack(list(sols.values()))
    return sols, c.pk_matrices(np.broadcast_to(c.x, (len(Q), c.n_x)), Q)


# --- the sources ------------------------------------------------------------------------------------


def test_every_description_and_urdf_model_is_a_source():
    assert len([s for s in SOURCES if s[0] == "description"]) == len(list(DESC.glob("*.yaml"))) >= 8
    assert any(kind == "urdf" for kind, _ in SOURCES)


# --- the properties ---------------------------------------------------------------------------------


@PARAMS
def test_A_and_B_against_central_differences(index):
    c = case(index)
    x, q = c.x, c.q
    sols, m = reached(index)
    home = list(sols).index(c.branch)
    A_fd = central(lambda z: c.F(z, np.broadcast_to(q, (len(z), c.n))), x, steps(x))
    B_fd = central(lambda z: c.F(np.broadcast_to(x, (len(z), c.n_x)), z), q, steps(q))
    for M, M_fd in ((m["A"][home], A_fd), (m["B"][home], B_fd)):
        assert M.shape == M_fd.shape
        np.testing.assert_allclose(M, M_fd, rtol=1e-6, atol=1e-7 * np.max(np.abs(M_fd)))
    # the A and B of jax.jacfwd (used for det(A) and the branch rule below) are pkmlib's
    A, B, _ = c.AB(np.broadcast_to(x, (len(sols), c.n_x)), np.stack(list(sols.values())))
    np.testing.assert_allclose(A, m["A"], rtol=1e-12, atol=1e-12 * np.max(np.abs(A)))
    np.testing.assert_allclose(B, m["B"], rtol=1e-12, atol=1e-12 * np.max(np.abs(B)))


@PARAMS
def test_inverse_jacobian_is_the_derivative_of_the_numerical_inverse_and_J_inverts_it(index):
    c = case(index)
    sols, m = reached(index)
    home = list(sols).index(c.branch)
    J_inv_fd = central(lambda z: c.inverse(z, c.branch), c.x, steps(c.x))
    np.testing.assert_allclose(m["J_inv"][home], J_inv_fd, rtol=1e-6, atol=1e-7 * np.max(np.abs(J_inv_fd)))
    # J J^-1 = I on every branch where det(A) and det(B) are clear of 0
    scale = lambda M: np.max(np.abs(M), axis=(1, 2))  # noqa: E731
    clear = (np.abs(np.linalg.det(m["A"])) > 1e-8 * scale(m["A"]) ** c.n_x) & (
        np.abs(np.linalg.det(m["B"])) > 1e-8 * scale(m["B"]) ** c.n
    )
    assert clear[home]
    eye = np.eye(c.n)
    np.testing.assert_allclose(m["J"][clear] @ m["J_inv"][clear], np.broadcast_to(eye, m["J"][clear].shape), atol=1e-10)
    np.testing.assert_allclose(m["J_inv"][clear] @ m["J"][clear], np.broadcast_to(eye, m["J"][clear].shape), atol=1e-10)


@PARAMS
def test_inverse_then_forward_is_the_identity_on_every_branch(index):
    c = case(index)
    sols, _ = reached(index)
    assert c.branch in sols
    Q = np.stack(list(sols.values()))
    X = np.broadcast_to(c.x, Q.shape[:1] + c.x.shape)
    scale = max(1.0, float(np.max(np.abs(c.x)))) ** 2
    assert np.max(np.abs(c.F(X, Q))) < 1e-12 * scale
    # the branch rule: sign(dF_i/dq_i) at the solution is the branch
    B = c.AB(X, Q)[1]
    assert np.array_equal(np.sign(np.diagonal(B, axis1=1, axis2=2)), np.asarray(list(sols)))
    guess = c.x + 1e-4 * np.maximum(np.abs(c.x), 1e-2)
    for b, q in sols.items():
        x_back = pk.forward_position(c.mech, jnp.asarray(q), c.p, jnp.asarray(guess), tol=1e-13 * scale)
        np.testing.assert_allclose(x_back, c.x, rtol=1e-10, atol=1e-10, err_msg=str(b))
        np.testing.assert_allclose(c.inverse(np.asarray(x_back)[None], b)[0], q, rtol=1e-9, atol=1e-9, err_msg=str(b))


@PARAMS
def test_nan_outside_the_workspace_on_every_branch(index):
    """q and the residual are NaN at a far pose on every branch (A, or B, need not be: the 3-RPR's
    A does not depend on q, nor does P5's B)."""
    c = case(index)
    far = np.where(c.angle, c.x, c.x + 10.0 * c.L)
    for b in c.branches:
        q, residual = c.solve(far[None], b)
        assert np.all(np.isnan(q)) and np.all(np.isnan(residual)), b


def refine(c, a, z):
    """Multisection of det(A) on the home branch between the poses a and z (opposite signs):
    BATCH points a pass, until the bracket is 1e-10 of its first length. Returns the bracket, or
    None where the inverse is NaN inside it (a gap of the workspace between the samples)."""
    length = np.linalg.norm(z - a)
    t = np.linspace(0.0, 1.0, BATCH)[:, None]
    while np.linalg.norm(z - a) > 1e-10 * length:
        X = a + t * (z - a)
        Q = c.inverse(X, c.branch)
        if not np.all(np.isfinite(Q)):
            return None
        d = c.AB(X, Q)[2]
        k = int(np.flatnonzero(np.sign(d[1:]) != np.sign(d[:-1]))[0])
        a, z = X[k], X[k + 1]
    return a, z


def segments(c):
    """Segments from the pose: along each output coordinate (+-L, +-pi for an angle), then to each
    random pose of the other sign of det(A) on the home branch."""
    for k in range(c.n_x):
        d = np.zeros(c.n_x)
        d[k] = np.pi if c.angle[k] else c.L
        yield c.x - d, c.x + d
    X = c.random_poses()
    Q = c.inverse(X, c.branch)
    ok = np.all(np.isfinite(Q), axis=1)
    d = c.AB(X, Q)[2]
    s0 = np.sign(c.AB(c.x[None], c.q[None])[2][0])
    for j in np.flatnonzero(ok & (np.sign(d) == -s0)):
        yield c.x, X[j]


@PARAMS
def test_det_A_changes_sign_across_the_refined_singular_curves(index):
    c = case(index)
    roots = []
    t = np.linspace(0.0, 1.0, BATCH)[:, None]
    for a, z in segments(c):
        X = a + t * (z - a)
        Q = c.inverse(X, c.branch)
        d = c.AB(X, Q)[2]
        for j in np.flatnonzero(np.isfinite(d[1:]) & np.isfinite(d[:-1]) & (d[1:] * d[:-1] < 0.0)):
            bracket = refine(c, X[j], X[j + 1])
            if bracket is not None:
                roots.append(bracket)
        if len(roots) >= 4:
            break
    roots = roots[:8]
    assert roots, f"{c.mech.name}: no segment from {c.x} crosses a singular curve inside the workspace"
    lo, hi = np.stack([r[0] for r in roots]), np.stack([r[1] for r in roots])
    mid = 0.5 * (lo + hi)
    P = np.concatenate([lo, hi, mid])
    A, _, det = c.AB(P, c.inverse(P, c.branch))
    n = len(roots)
    assert np.all(det[:n] * det[n : 2 * n] < 0.0)
    s = np.linalg.svd(A[2 * n :], compute_uv=False)
    assert np.all(s[:, -1] < 1e-6 * s[:, 0]), f"{c.mech.name}: A is not singular at the refined roots ({s})"
