"""Closed-form 1x1-4x4 determinants and inverses against jnp.linalg, and where pkmlib uses them."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import pkmlib as pk
from pkmlib._small_matrices import det_small, inverse_small, solve_small
from conftest import assert_close

EPS = np.finfo(np.float64).eps


def _random(n, batch, cond, seed, graded=True):
    """``batch`` random n x n matrices with condition number ``cond`` (SVD with chosen singular
    values: geometric from 1 to 1/cond when ``graded``, else all 1 but the last), as
    ``(n, n, batch)`` (structure of arrays) and ``(batch, n, n)``."""
    rng = np.random.default_rng(seed)
    U, _ = np.linalg.qr(rng.normal(size=(batch, n, n)))
    V, _ = np.linalg.qr(rng.normal(size=(batch, n, n)))
    s = np.geomspace(1.0, 1.0 / cond, n) if graded else np.r_[np.ones(n - 1), 1.0 / cond]
    s = s * rng.uniform(0.5, 2.0, size=(batch, 1))
    M = U @ (s[..., None] * V)
    return np.moveaxis(M, 0, -1), M, s


@pytest.mark.parametrize("n", [1, 2, 3, 4])
def test_well_conditioned_against_linalg(n):
    soa, aos, _ = _random(n, 500, 10.0, n)
    assert_close(det_small(soa), np.linalg.det(aos), rtol=1e-12, atol=0)
    assert_close(np.moveaxis(inverse_small(soa), -1, 0), np.linalg.inv(aos), rtol=1e-11, atol=1e-12)
    A = np.random.default_rng(9).normal(size=(n, 3, 500))
    X = solve_small(soa, A)
    assert_close(np.moveaxis(X, -1, 0), np.linalg.solve(aos, np.moveaxis(A, -1, 0)), rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize("n", [2, 3, 4])
@pytest.mark.parametrize("cond", [1e6, 1e10])
@pytest.mark.parametrize("graded", [False, True])
def test_near_singular_errors_are_bounded(n, cond, graded):
    """One small singular value (a singular pose: one lost direction): the inverse's and the
    determinant's relative errors are of the order of cond * eps, as LU's. Graded singular values
    (several small ones): the cofactor sums cancel more; the error is then bounded by
    eps * prod_i (s_1 / s_i), which for n = 2 is again cond * eps."""
    soa, aos, s = _random(n, 300, cond, 10 * n, graded)
    X = np.moveaxis(np.asarray(inverse_small(soa)), -1, 0)
    X_lu = np.linalg.inv(aos)
    rel = np.abs(X - X_lu).max(axis=(1, 2)) / np.abs(X_lu).max(axis=(1, 2))
    d, d_lu = np.asarray(det_small(soa)), np.linalg.det(aos)
    rel_det = np.abs(d - d_lu) / np.abs(d_lu)
    bound = 100 * EPS * (np.prod(s[:, :1] / s, axis=1) if graded else cond)
    assert np.all(rel < bound) and np.all(rel_det < bound)


def test_nan_propagates_and_singular_is_not_finite():
    soa, _, _ = _random(4, 3, 10.0, 1)
    soa = soa.copy()
    soa[2, 1, 0] = np.nan
    inv = np.asarray(inverse_small(soa))
    assert np.all(np.isnan(inv[..., 0])) and np.all(np.isfinite(inv[..., 1:]))
    assert np.isnan(det_small(soa)[0])
    singular = np.ones((3, 3))
    assert float(det_small(singular)) == 0.0
    assert not np.all(np.isfinite(inverse_small(singular)))


def test_unbatched_matrices_and_gradients():
    M = np.array([[2.0, 1.0, 0.5], [0.3, 3.0, 0.2], [0.1, 0.4, 1.5]])
    assert_close(inverse_small(M), np.linalg.inv(M), rtol=1e-13)
    # d det / dM = det * M^-T (Jacobi's formula), from autodiff of the closed form
    assert_close(jax.grad(det_small)(jnp.asarray(M)), np.linalg.det(M) * np.linalg.inv(M).T, rtol=1e-12)


def test_non_square_and_too_large_raise():
    with pytest.raises(ValueError, match="square"):
        det_small(np.zeros((2, 3)))
    with pytest.raises(ValueError, match="4x4"):
        inverse_small(np.eye(5))


def test_pkmlib_matrix_functions_use_closed_forms_and_agree_with_linalg(p1_params):
    from pkmlib.mechanisms import gripper_4prr as m

    rng = np.random.default_rng(3)
    x = m.pose(rng.uniform(0.4, 0.9, 64), rng.uniform(-0.1, 0.05, 64), np.deg2rad(20.0), 0.14)
    q = m.mechanism.inverse(x, p1_params)
    J_inv = pk.inverse_jacobian(m.mechanism, x, q, p1_params)
    ok = np.all(np.isfinite(np.asarray(J_inv)), axis=(0, 1))
    assert ok.sum() > 10
    J = np.asarray(pk.matrix_inverse(J_inv))[..., ok]
    ref = np.moveaxis(np.linalg.inv(np.moveaxis(np.asarray(J_inv)[..., ok], -1, 0)), 0, -1)
    assert_close(J, ref, rtol=1e-9, atol=1e-12)
    dA = np.asarray(pk.det_A(m.mechanism, x, q, p1_params))[ok]
    A = np.moveaxis(np.asarray(pk.A_matrix(m.mechanism, x, q, p1_params))[..., ok], -1, 0)
    assert_close(dA, np.linalg.det(A), rtol=1e-9, atol=1e-14)
    # no LAPACK call left in the compiled map
    hlo = (
        jax.jit(
            lambda x: pk.matrix_inverse(
                pk.inverse_jacobian(m.mechanism, x, m.mechanism.inverse(x, p1_params), p1_params)
            )
        )
        .lower(x)
        .as_text()
    )
    assert "lapack" not in hlo.lower() and "custom_call" not in hlo
