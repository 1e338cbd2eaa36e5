"""The tutorial's claims (notebooks/tutorial_bring_your_own_mechanism.ipynb): mechanisms brought in
by description files alone (the planar 3-RPR and the Delta), their maps, det(A) and every
forward-position assembly mode, each checked against an independent method written here in
NumPy: a univariate polynomial in tan(phi/2) for the 3-RPR, three-sphere trilateration in closed
form for the Delta. Also the library guide's 2-RPR example (chain equations written by hand)."""

from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from conftest import assert_close
from numpy.polynomial import polynomial as P

import pkmlib as pk

ROOT = Path(__file__).resolve().parents[1]


# --------------------------------------------------------------------------- the library guide's 2-RPR
def chain(i, x, q_i, p):  # base joints at (0, 0) and (1, 0), leg lengths q
    bx = (0.0, 1.0)[i]
    return (x[0] - bx) ** 2 + x[1] ** 2 - q_i**2


def inverse(x, p, branch):
    return jnp.stack([jnp.hypot(x[0] - bx, x[1]) for bx in (0.0, 1.0)])


two_rpr = pk.Mechanism(
    name="2-RPR",
    chain_constraint=chain,
    inverse_position=inverse,
    actuator_limits=lambda p: (jnp.zeros(2), jnp.full(2, 2.0)),
    output_names=("x", "y"),
    output_units=("m", "m"),
    actuator_names=("q1", "q2"),
    actuator_units=("m", "m"),
)


def test_two_rpr_maps_match_the_leg_direction_formula():
    grid = pk.Grid.from_ranges(x=(-0.5, 1.5, 0.25), y=(0.05, 1.0, 0.25))
    vel = pk.sweep(
        lambda pt: pk.max_actuator_velocity(
            pk.inverse_jacobian(two_rpr, pt, two_rpr.inverse(pt, None), None), [(0, 1)], [1.0]
        ),
        grid,
    )
    # q_i' = u_i . x' with u_i the unit leg vector: the max over unit x' is 1 for every leg
    assert_close(vel, np.ones(grid.shape), rtol=1e-12)
    det = pk.sweep(lambda pt: pk.det_A(two_rpr, pt, two_rpr.inverse(pt, None), None), grid)
    pts = grid.points()
    # det A = 4 * det([[x, y], [x - 1, y]]) = 4 y
    assert_close(det, 4 * pts[..., 1], rtol=1e-12)


# --------------------------------------------------------------------------- the 3-RPR
RPR_BRANCH = (-1, -1, -1)
Q_FK = [0.81, 0.13, 0.88]  # the tutorial's input of the forward problem (4 real modes)


@pytest.fixture(scope="module")
def rpr():
    return pk.load_mechanism(ROOT / "data" / "mechanisms" / "planar_3rpr.yaml")


def rpr_geometry(m):
    p = {k: float(v) for k, v in m.params.items()}
    B = np.array([[p[f"xB{i}"], p[f"yB{i}"]] for i in (1, 2, 3)])
    a = np.array([[p[f"xa{i}"], p[f"ya{i}"]] for i in (1, 2, 3)])
    return B, a


def rot(phi):
    c, s = np.cos(phi), np.sin(phi)
    return np.array([[c, -s], [s, c]])


def rpr_modes_by_polynomial(B, a, q):
    """Every real (x, y, phi) with |(x, y) + R(phi) a_i - B_i| = q_i, i = 1..3, by elimination:
    eq_2 - eq_1 and eq_3 - eq_1 are linear in (x, y) (Cramer's rule), eq_1 then is a polynomial
    of degree 12 in t = tan(phi / 2) (every quantity linear in (cos, sin, 1) times 1 + t^2);
    numpy.roots, real roots, each checked by its residual."""
    one, c, s = np.array([1.0, 0, 1.0]), np.array([1.0, 0, -1.0]), np.array([0, 2.0, 0])

    def lin(k0, kc, ks):
        return k0 * one + kc * c + ks * s

    u = [lin(-B[i, 0], a[i, 0], -a[i, 1]) for i in range(3)]  # (R a_i - B_i)_x (1 + t^2)
    v = [lin(-B[i, 1], a[i, 1], a[i, 0]) for i in range(3)]

    def k(i):  # |a_i|^2 + |B_i|^2 - q_i^2 - 2 B_i . R a_i
        return lin(
            a[i] @ a[i] + B[i] @ B[i] - q[i] ** 2,
            -2 * (B[i, 0] * a[i, 0] + B[i, 1] * a[i, 1]),
            -2 * (B[i, 1] * a[i, 0] - B[i, 0] * a[i, 1]),
        )

    M = [[2 * (u[i] - u[0]), 2 * (v[i] - v[0])] for i in (1, 2)]
    r = [-(k(i) - k(0)) for i in (1, 2)]
    D = P.polysub(P.polymul(M[0][0], M[1][1]), P.polymul(M[0][1], M[1][0]))
    Nx = P.polysub(P.polymul(r[0], M[1][1]), P.polymul(M[0][1], r[1]))
    Ny = P.polysub(P.polymul(M[0][0], r[1]), P.polymul(r[0], M[1][0]))
    ex = P.polyadd(P.polymul(one, Nx), P.polymul(u[0], D))
    ey = P.polyadd(P.polymul(one, Ny), P.polymul(v[0], D))
    poly = P.polysub(
        P.polyadd(P.polymul(ex, ex), P.polymul(ey, ey)), q[0] ** 2 * P.polymul(P.polymul(one, one), P.polymul(D, D))
    )
    roots = np.roots(poly[::-1])
    out = []
    for t in roots[np.abs(roots.imag) < 1e-7 * (1 + np.abs(roots))].real:
        phi = 2 * np.arctan(t)
        Ra = a @ rot(phi).T
        Mn = np.array([2 * (Ra[i] - B[i] - Ra[0] + B[0]) for i in (1, 2)])
        kk = [Ra[i] @ Ra[i] + B[i] @ B[i] - q[i] ** 2 - 2 * B[i] @ Ra[i] for i in range(3)]
        xy = np.linalg.solve(Mn, [-(kk[1] - kk[0]), -(kk[2] - kk[0])])
        if np.abs(np.linalg.norm(xy + Ra - B, axis=1) - q).max() < 1e-8:
            out.append((xy[0], xy[1], phi))
    out = np.array(sorted(out, key=lambda p: p[2])).reshape(-1, 3)
    keep = np.r_[True, np.any(np.abs(np.diff(out, axis=0)) > 1e-9, axis=1)] if len(out) else []
    return out[keep]


def rpr_box(B, q_max, a):
    reach = q_max + np.max(np.hypot(a[:, 0], a[:, 1]))
    return (
        [B[:, 0].min() - reach, B[:, 1].min() - reach, -np.pi],
        [B[:, 0].max() + reach, B[:, 1].max() + reach, np.pi],
    )


def sort_by_phi(x):
    return x[np.argsort(x[:, 2])]


@pytest.mark.parametrize("q", [Q_FK, [0.5, 0.6, 0.45], [0.3, 0.75, 0.6]])
def test_rpr_forward_modes_are_every_real_root_of_the_polynomial(rpr, q):
    B, a = rpr_geometry(rpr)
    expected = rpr_modes_by_polynomial(B, a, np.asarray(q))
    modes = pk.forward_positions(rpr, jnp.asarray(q), rpr.params, rpr_box(B, 0.9, a), starts_per_axis=8)
    n = int(modes.count)
    assert n == len(expected) and n > 0, (n, expected)
    got = np.asarray(modes.x[:n])
    assert np.all(np.isnan(np.asarray(modes.x[n:])))
    np.testing.assert_allclose(sort_by_phi(got), expected, rtol=0, atol=1e-10)
    # the stated order: det(A) > 0 first; the sign is det(A)'s at each mode
    s = np.asarray(modes.det_A_sign[:n])
    assert np.all(np.diff(-s) >= 0)
    dets = [float(pk.det_A(rpr, jnp.asarray(x), jnp.asarray(q), rpr.params)) for x in got]
    np.testing.assert_array_equal(np.sign(dets), s)


def test_rpr_tutorial_input_has_four_modes(rpr):
    B, a = rpr_geometry(rpr)
    assert len(rpr_modes_by_polynomial(B, a, np.asarray(Q_FK))) == 4  # the tutorial says so


def test_rpr_numerical_inverse_is_the_leg_length_and_nan_outside_the_strokes(rpr):
    B, a = rpr_geometry(rpr)
    rng = np.random.default_rng(0)
    x = np.stack([rng.uniform(-0.1, 1.1, 400), rng.uniform(-0.3, 0.95, 400), rng.uniform(-1, 1, 400)])
    q = np.asarray(pk.inverse_positions(rpr, jnp.asarray(x), rpr.params, RPR_BRANCH))
    legs = np.stack(
        [
            np.linalg.norm(x[:2].T + a[i] @ np.stack([rot(p) for p in x[2]]).transpose(0, 2, 1) - B[i], axis=-1)
            for i in range(3)
        ]
    )
    inside = np.all((legs >= 0.1) & (legs <= 0.9), axis=0)
    assert 50 < inside.sum() < 400
    np.testing.assert_allclose(q[:, inside], legs[:, inside], rtol=1e-12)
    assert np.all(np.isnan(q[:, ~inside]))


def test_rpr_det_A_and_speed_bound_by_hand(rpr):
    """Row i of A is 2 (d_x, d_y, (R a_i) x d) with d = P_i - B_i; row i of J^-1 is
    (u_i, (R a_i) x u_i): |q'|max lies in [v, v + max|a_i| omega]."""
    B, a = rpr_geometry(rpr)
    phi = np.deg2rad(10.0)
    grid = pk.Grid.from_ranges(x=(-0.1, 1.1, 0.05), y=(-0.3, 0.95, 0.05))
    pts = grid.points().reshape(-1, 2)
    x = np.concatenate([pts, np.full((len(pts), 1), phi)], axis=1).T
    q = pk.inverse_positions(rpr, jnp.asarray(x), rpr.params, RPR_BRANCH)
    ok = np.all(np.isfinite(np.asarray(q)), axis=0)
    assert ok.sum() > 100
    Ra = a @ rot(phi).T
    rows = []
    for i in range(3):
        d = pts + Ra[i] - B[i]
        rows.append(2.0 * np.stack([d[:, 0], d[:, 1], Ra[i, 0] * d[:, 1] - Ra[i, 1] * d[:, 0]], axis=-1))
    by_hand = np.linalg.det(np.stack(rows, axis=1))
    det = np.asarray(pk.det_A(rpr, jnp.asarray(x), q, rpr.params))
    np.testing.assert_allclose(det[ok], by_hand[ok], rtol=0, atol=1e-12 * np.abs(by_hand).max())
    speed = np.asarray(
        pk.max_actuator_velocity(pk.inverse_jacobian(rpr, jnp.asarray(x), q, rpr.params), [(0, 1), (2,)], [1.0, 1.0])
    )[ok]
    assert np.all(speed >= 1.0 - 1e-12) and np.all(speed <= 1.0 + np.hypot(a[:, 0], a[:, 1]).max() + 1e-12)


# --------------------------------------------------------------------------- the Delta
THETA_FK = np.deg2rad([20.0, 35.0, 50.0])  # the tutorial's input


@pytest.fixture(scope="module")
def delta():
    return pk.load_mechanism(ROOT / "data" / "mechanisms" / "delta.yaml")


def sphere_centres(p, theta):
    """Centre of the sphere that the platform centre lies on for arm i: the elbow minus the
    platform offset, R_z(gamma_i) (R_b + L_a cos theta_i - r_p, 0, -L_a sin theta_i) (the
    parallelogram's half-width cancels); radius L_f."""
    g = np.array([0.0, 2 * np.pi / 3, 4 * np.pi / 3])
    rho = p["R_b"] + p["L_a"] * np.cos(theta) - p["r_p"]
    return np.stack([rho * np.cos(g), rho * np.sin(g), -p["L_a"] * np.sin(theta)], axis=1)


def trilateration(C, r):
    """Both intersections of three spheres of radius r, centres C (3, 3), in closed form."""
    ex = (C[1] - C[0]) / np.linalg.norm(C[1] - C[0])
    i = ex @ (C[2] - C[0])
    ey = C[2] - C[0] - i * ex
    ey /= np.linalg.norm(ey)
    ez = np.cross(ex, ey)
    d = np.linalg.norm(C[1] - C[0])
    j = ey @ (C[2] - C[0])
    # equal radii: x = d / 2, y = (i^2 + j^2 - 2 i x) / (2 j)
    x = d / 2
    y = (i**2 + j**2 - 2 * i * x) / (2 * j)
    z2 = r**2 - x**2 - y**2
    if z2 < 0:
        return np.empty((0, 3))
    base = C[0] + x * ex + y * ey
    return np.array([base + np.sqrt(z2) * ez, base - np.sqrt(z2) * ez])


@pytest.mark.parametrize("theta", [THETA_FK, np.deg2rad([0.0, 0.0, 0.0]), np.deg2rad([-10.0, 40.0, 70.0])])
def test_delta_forward_modes_are_the_three_sphere_intersections(delta, theta):
    p = {k: float(v) for k, v in delta.params.items()}
    expected = trilateration(sphere_centres(p, theta), p["L_f"])
    modes = pk.forward_positions(delta, jnp.asarray(theta), delta.params, ([-1.0] * 3, [1.0] * 3))
    n = int(modes.count)
    assert n == len(expected) == 2
    got = np.asarray(modes.x[:n])
    np.testing.assert_allclose(got[np.argsort(got[:, 2])], expected[np.argsort(expected[:, 2])], rtol=0, atol=1e-10)
    assert sorted(np.asarray(modes.det_A_sign[:n]).tolist()) == [-1.0, 1.0]


def test_delta_inverse_then_forward_recovers_the_pose(delta):
    x = np.array([[0.05, -0.1, 0.2], [-0.03, 0.08, -0.15], [-0.35, -0.4, -0.3]])  # three poses, columns
    theta = np.asarray(pk.inverse_positions(delta, jnp.asarray(x), delta.params, delta.default_branch))
    assert np.all(np.isfinite(theta))
    p = {k: float(v) for k, v in delta.params.items()}
    for k in range(3):
        both = trilateration(sphere_centres(p, theta[:, k]), p["L_f"])
        assert np.min(np.abs(both - x[:, k]).max(axis=1)) < 1e-10


def test_delta_section_maps_are_finite_inside_and_det_A_changes_sign(delta):
    """The tutorial's z = -0.2 m section: the arm speed is finite in the workspace and det(A)
    changes sign there (a section of the type-2 surface), and det(A) vanishes at the refined points."""
    z = -0.2
    grid = pk.Grid.from_ranges(x=(-0.45, 0.45, 0.03), y=(-0.45, 0.45, 0.03))
    pts = grid.points().reshape(-1, 2)
    x = jnp.asarray(np.concatenate([pts, np.full((len(pts), 1), z)], axis=1).T)
    q = pk.inverse_positions(delta, x, delta.params, delta.default_branch)
    det = np.asarray(pk.det_A(delta, x, q, delta.params)).reshape(grid.shape)
    ok = np.isfinite(det)
    assert ok.sum() > 200 and np.nanmin(det) < 0 < np.nanmax(det)

    def det_at(pt):
        xx = jnp.stack([pt[0], pt[1], jnp.asarray(z)])
        return pk.det_A(delta, xx, pk.inverse_positions(delta, xx, delta.params, delta.default_branch), delta.params)

    roots, _ = pk.singular_crossings(det_at, grid, det, tol=1e-9)
    assert len(roots) > 0
    assert np.max(np.abs(np.asarray(jax.vmap(det_at)(jnp.asarray(roots))))) < 1e-7 * np.nanmax(np.abs(det))
