"""Grids and sweeps: shapes, chunking, both call forms, NaN outside, and bad input."""

import numpy as np
import pytest

import pkmlib as pk
from pkmlib.mechanisms import gripper_4prr as m
from conftest import assert_close

PHI, S = np.deg2rad(20), 0.14


def test_grid_matches_the_paper_grid():
    g = pk.Grid.from_ranges(x_D=(0.2, 1.2, 0.005), y_D=(-0.25, 0.25, 0.0025))
    assert g.shape == (201, 201)
    assert_close(g.axis("x_D")[[0, -1]], [0.2, 1.2], rtol=0, atol=1e-15)
    assert_close(g.axis("y_D")[[0, -1]], [-0.25, 0.25], rtol=0, atol=1e-15)
    assert g.points().shape == (201, 201, 2)


def test_sweep_equals_a_python_loop_over_points(p1_params):
    grid = pk.Grid.from_ranges(x_D=(0.3, 1.1, 0.1), y_D=(-0.2, 0.2, 0.05))

    def vel(pt):
        return m.max_carriage_velocity(m.pose(pt[0], pt[1], PHI, S), p1_params, (1.0, 1.0, 1.0))

    expected = np.array([[float(vel(np.array([x, y]))) for y in grid.axes[1]] for x in grid.axes[0]])
    assert np.isnan(expected).any() and np.isfinite(expected).any()
    for chunk in (1, 7, 10, 1000):  # chunks of whole rows, smaller than, equal to and over the grid
        got = pk.sweep(vel, grid, chunk_size=chunk)
        np.testing.assert_array_equal(np.isnan(got), np.isnan(expected))
        assert_close(got[np.isfinite(got)], expected[np.isfinite(expected)], rtol=1e-12)
        got_b = pk.sweep(lambda pts: m.max_carriage_velocity(m.pose(pts[0], pts[1], PHI, S), p1_params, (1.0, 1.0, 1.0)),
                         grid, chunk_size=chunk, batched=True)
        np.testing.assert_array_equal(np.isnan(got_b), np.isnan(expected))
        assert_close(got_b[np.isfinite(got_b)], expected[np.isfinite(expected)], rtol=1e-12)


def test_sweep_returns_pytrees_shaped_like_the_grid(p1_params):
    grid = pk.Grid.from_ranges(a=(0.0, 1.0, 0.25), b=(0.0, 2.0, 1.0), c=(0.0, 0.0, 1.0))
    out = pk.sweep(lambda pt: {"sum": pt.sum(), "vec": pt * 2.0}, grid, chunk_size=4)
    assert out["sum"].shape == (5, 3, 1)
    assert out["vec"].shape == (5, 3, 1, 3)
    pts = grid.points()
    assert_close(out["sum"], pts.sum(-1), atol=1e-15)
    assert_close(out["vec"], 2 * pts, atol=1e-15)


def test_progress_bar_on_request(capsys):
    grid = pk.Grid.from_ranges(a=(0.0, 1.0, 0.1))
    pk.sweep(lambda pt: pt[0], grid, progress=True, chunk_size=3)
    assert "sweep 11 points" in capsys.readouterr().err
    pk.sweep(lambda pt: pt[0], grid)
    assert capsys.readouterr().err == ""


@pytest.mark.parametrize(
    "axes, match",
    [
        ({}, "empty grid"),
        ({"x_D": (0.2, 1.2, 0.0)}, "x_D step"),
        ({"x_D": (0.2, 1.2, -0.1)}, "x_D step"),
        ({"y_D": (0.3, -0.3, 0.1)}, "y_D: min"),
        ({"y_D": (0.0, float("nan"), 0.1)}, "y_D"),
        ({"y_D": (0.0, 1.0)}, "y_D: expected"),
    ],
)
def test_bad_grids_raise_value_errors_naming_the_parameter(axes, match):
    with pytest.raises(ValueError, match=match):
        pk.Grid.from_ranges(**axes)


def test_bad_chunk_size():
    with pytest.raises(ValueError, match="chunk_size"):
        pk.sweep(lambda pt: pt[0], pk.Grid.from_ranges(a=(0.0, 1.0, 0.5)), chunk_size=0)
