"""Singular lines of P1 from det(A) sign changes, refined, against the analytic lines."""

import numpy as np
import pytest

import pkmlib as pk
from pkmlib.mechanisms import gripper_4prr as m
from conftest import assert_close


@pytest.mark.parametrize("phi_deg, s", [(20.0, 0.14), (25.0, 0.14), (10.0, 0.1)])
def test_refined_singular_lines_are_at_the_analytic_values(p1_params, phi_deg, s):
    p = p1_params
    phi = np.deg2rad(phi_deg)
    grid = pk.Grid.from_ranges(x_D=(0.2, 1.2, 0.05), y_D=(-0.25, 0.25, 0.0025))

    def det_at(pt):
        x = m.pose(pt[0], pt[1], phi, s)
        return pk.det_A(m.mechanism, x, m.mechanism.inverse(x, p), p)

    values = pk.sweep(det_at, grid)
    roots, along = pk.singular_crossings(det_at, grid, values, tol=1e-9)
    assert len(roots) > 0 and np.all(along == 1)  # horizontal lines: crossings along y_D only
    lines = pk.cluster_levels(roots[:, 1], atol=1e-6)
    expected = sorted(m.type2_lines_y(phi, s, p))
    assert len(lines) == 2
    assert_close(lines, expected, rtol=0, atol=1e-9)
    assert np.max(np.abs(np.sort(roots[:, 1])[:, None] - np.array(expected)[None]).min(axis=1)) <= 1e-9


def test_refine_roots_on_a_known_function():
    """Zeros of x^2 + y^2 - 2 on two segments: x = 1 at y = 1, and y = sqrt(2) at x = 0."""
    p0 = np.array([[0.0, 1.0], [0.0, 0.0]])
    p1 = np.array([[2.0, 1.0], [0.0, 2.0]])
    roots = pk.refine_roots(lambda pt: pt[0] ** 2 + pt[1] ** 2 - 2.0, p0, p1, tol=1e-12)
    assert_close(roots, [[1.0, 1.0], [0.0, np.sqrt(2.0)]], rtol=0, atol=1e-12)


def test_sign_changes_skip_nan_and_zero_crossings_are_reported_once():
    grid = pk.Grid.from_ranges(a=(0.0, 4.0, 1.0))
    values = np.array([1.0, -1.0, np.nan, -1.0, 1.0])
    p0, p1, axis = pk.sign_change_segments(grid, values)
    assert_close(p0[:, 0], [0.0, 3.0])
    assert_close(p1[:, 0], [1.0, 4.0])
    with pytest.raises(ValueError, match="shape"):
        pk.sign_change_segments(grid, values[:3])


def test_cluster_levels_and_null_direction():
    assert_close(
        pk.cluster_levels(np.array([0.3, 0.1, 0.1 + 1e-9, 0.3 - 1e-9]), atol=1e-6), [0.1 + 0.5e-9, 0.3 - 0.5e-9]
    )
    M = np.array([[1.0, 2.0], [2.0, 4.0]])
    v = pk.null_direction(M)
    assert_close(M @ v, np.zeros(2), atol=1e-14)
    assert_close(np.linalg.norm(v), 1.0)
