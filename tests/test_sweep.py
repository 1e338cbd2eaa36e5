"""Grids and sweeps: shapes, chunking, both call forms, NaN outside, and bad input."""

import jax
import jax.numpy as jnp
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

    one = jax.jit(vel)  # the oracle: one point per call (compiled once, not traced op by op per point)
    expected = np.array([[float(one(np.array([x, y]))) for y in grid.axes[1]] for x in grid.axes[0]])
    assert np.isnan(expected).any() and np.isfinite(expected).any()
    for chunk in (1, 7, 10, 1000):  # chunks of whole rows, smaller than, equal to and over the grid
        got = pk.sweep(vel, grid, chunk_size=chunk)
        np.testing.assert_array_equal(np.isnan(got), np.isnan(expected))
        assert_close(got[np.isfinite(got)], expected[np.isfinite(expected)], rtol=1e-12)
        got_b = pk.sweep(
            lambda pts: m.max_carriage_velocity(m.pose(pts[0], pts[1], PHI, S), p1_params, (1.0, 1.0, 1.0)),
            grid,
            chunk_size=chunk,
            batched=True,
        )
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


@pytest.mark.parametrize("batched", [False, True])
def test_leaves_split_per_number_come_back_in_their_places(batched):
    """Leaves of 2 to SPLIT_MAX_NUMBERS numbers per point are computed number by number and
    stacked again inside the compiled call: every number lands at its own index (a matrix, a tuple
    inside the tree, an integer and a boolean leaf), beside a scalar leaf and a leaf too large to
    split, in chunks that do not divide the grid."""
    big = pk._sweep.SPLIT_MAX_NUMBERS + 1
    grid = pk.Grid.from_ranges(a=(0.0, 1.0, 0.25), b=(-1.0, 1.0, 0.5))

    def fn(pt):
        a, b = pt[0], pt[1]
        M = jnp.stack([jnp.stack([a, b, a * b]), jnp.stack([a - b, 2.0 * a, jnp.sin(b)])])
        return {
            "M": M,
            "pair": (a + 1.0, jnp.stack([b, -b])),
            "n": jnp.stack([jnp.floor(4 * a), jnp.floor(2 * b)]).astype(jnp.int32),
            "pos": jnp.stack([a > 0.4, b > 0.0]),
            "big": a * jnp.arange(big, dtype=jnp.float64) + b,
            "s": a * b,
        }

    pts = grid.points().reshape(-1, 2)
    expected = jax.tree_util.tree_map(lambda v: np.asarray(v).reshape(grid.shape + v.shape[1:]), jax.vmap(fn)(pts))
    f = (lambda p: jax.tree_util.tree_map(lambda v: jnp.moveaxis(v, 0, -1), jax.vmap(fn, 1)(p))) if batched else fn
    for chunk in (3, 8, 1000):
        got = pk.sweep(f, grid, chunk_size=chunk, batched=batched)
        assert jax.tree_util.tree_structure(got) == jax.tree_util.tree_structure(expected)
        for g, e in zip(jax.tree_util.tree_leaves(got), jax.tree_util.tree_leaves(expected)):
            assert g.shape == e.shape and g.dtype == e.dtype
            np.testing.assert_array_equal(g, e)


@pytest.mark.parametrize("window_bytes", [1, 3 * 8 * 8, 1 << 30])
def test_windows_of_calls_give_the_same_values_and_progress(monkeypatch, capsys, window_bytes):
    """The calls in flight (FETCH_WINDOW_BYTES): one call at a time, three 8-point calls (a
    window that does not divide the 12 calls) and all of them at once give the grid's points in
    their places, and the progress bar counts every call."""
    monkeypatch.setattr(pk._sweep, "FETCH_WINDOW_BYTES", window_bytes)
    grid = pk.Grid.from_ranges(a=(0.0, 1.0, 0.011))  # 91 points: 12 calls of 8
    got = pk.sweep(lambda pt: pt[0] * 2.0, grid, chunk_size=8, progress=True)
    np.testing.assert_array_equal(got, grid.points()[:, 0] * 2.0)
    assert "12/12" in capsys.readouterr().err


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


@pytest.mark.parametrize("bad", ["abc", float("nan"), None, 0, -3, True, False, 2.5, float("inf"), [4]])
def test_bad_chunk_sizes_raise_value_errors_naming_chunk_size(bad):
    with pytest.raises(ValueError, match="chunk_size"):
        pk.sweep(lambda pt: pt[0], pk.Grid.from_ranges(a=(0.0, 1.0, 0.5)), chunk_size=bad)


def test_whole_number_chunk_sizes_are_accepted():
    grid = pk.Grid.from_ranges(a=(0.0, 1.0, 0.25))
    for ok in (np.int64(2), 3.0, "auto"):
        assert_close(pk.sweep(lambda pt: pt[0], grid, chunk_size=ok), grid.axes[0], atol=0)


def _vel(pt, p, phi, s):
    return m.max_carriage_velocity(m.pose(pt[0], pt[1], phi, s), p, (1.0, 1.0, 1.0))


def test_any_grid_shape_is_chunked_and_gives_the_same_values(p1_params):
    """The same points on a (2, n) and an (n, 2) grid: equal results, chunked by chunk_size
    whatever the shape (P1's map on one long inner axis used to be evaluated in one call)."""
    n = 4001
    xs, ys = (0.5, 0.9), (-0.2, 0.2 / (n - 1) * 2)
    wide = pk.Grid(("x_D", "y_D"), (xs[0], ys[0]), (xs[1] - xs[0], ys[1]), (2, n))
    tall = pk.Grid(("y_D", "x_D"), (ys[0], xs[0]), (ys[1], xs[1] - xs[0]), (n, 2))
    args = (p1_params, PHI, S)
    a = pk.sweep(_vel, wide, args=args, chunk_size=1000)
    b = pk.sweep(lambda pt, *r: _vel(pt[::-1], *r), tall, args=args, chunk_size=1000)
    assert np.isnan(a).any() and np.isfinite(a).any()
    np.testing.assert_array_equal(a, b.T)
    from pkmlib._sweep import chunk_size_for

    assert chunk_size_for(_vel, wide, args=args, chunk_size=1000) == 1000


def test_grid_points_are_bit_equal_to_grid_axes_in_any_chunking():
    grid = pk.Grid(("a", "b", "c"), (0.1, -2.0, 3.0), (0.3, 1e-3, 7.0), (5, 7, 3))
    for chunk in (1, 4, 7, 22, 105, 1000):
        got = pk.sweep(lambda pt: pt, grid, chunk_size=chunk)
        np.testing.assert_array_equal(got, grid.points())


def test_compiled_code_is_reused_across_grids_and_args(p1_params):
    from pkmlib._sweep import _compiled

    g1 = pk.Grid.from_ranges(x_D=(0.3, 1.1, 0.1), y_D=(-0.2, 0.2, 0.05))
    g2 = pk.Grid.from_ranges(x_D=(0.4, 1.0, 0.02), y_D=(-0.1, 0.1, 0.01))
    pk.sweep(_vel, g1, args=(p1_params, PHI, S), chunk_size=64)
    before = _compiled.cache_info()
    out = pk.sweep(_vel, g2, args=(p1_params, 0.3, 0.1), chunk_size=64)
    after = _compiled.cache_info()
    assert after.misses == before.misses and after.hits == before.hits + 1
    x = g2.points()[3, 4]
    assert_close(out[3, 4], _vel(x, p1_params, 0.3, 0.1), rtol=1e-13)


def test_auto_chunk_size_keeps_temporaries_under_the_budget(monkeypatch):
    import pkmlib._sweep as sw

    def heavy(pt):  # about 8 * 4096 bytes of temporaries per point
        v = jnp.outer(jnp.arange(64.0) + pt[0], jnp.arange(64.0) - pt[0])
        return jnp.sum(jnp.sin(v) @ jnp.cos(v))

    grid = pk.Grid.from_ranges(a=(0.0, 1.0, 1e-5))  # more points than DEFAULT_CHUNK
    monkeypatch.setattr(sw, "TEMP_BUDGET_BYTES", 4 * 2**20)
    chunk = sw.chunk_size_for(heavy, grid)
    assert sw.MIN_AUTO_CHUNK <= chunk < sw.DEFAULT_CHUNK
    assert sw.chunk_size_for(lambda pt: pt[0] * 2.0, grid) == sw.DEFAULT_CHUNK
    out = pk.sweep(heavy, pk.Grid.from_ranges(a=(0.0, 1.0, 0.25)))
    assert_close(out[1], heavy(jnp.array([0.25])), rtol=1e-12)
