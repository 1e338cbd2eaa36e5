"""Singular-curve refinement that tells roots from poles and jumps, finds zeros at grid nodes and
lists suspected double roots (pkmlib._singular); P2's false type-2 crossings at the folded chains."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import pkmlib as pk
from pkmlib.mechanisms import three_rrr as t
from conftest import assert_close

LINE = pk.Grid.from_ranges(x=(0.0, 1.0, 0.1))


def _on(grid, f):
    return np.array([float(f(jnp.asarray(pt))) for pt in grid.points().reshape(-1, grid.ndim)]).reshape(grid.shape)


def root_pole_jump(pt):
    """A simple root at 0.25, a pole at 0.55 and a jump at 0.85 (each a sign change)."""
    x = pt[0]
    return jnp.where(x < 0.4, x - 0.25, jnp.where(x < 0.7, 1.0 / (0.55 - x), jnp.where(x < 0.85, -1.0, 1.0) * (1 + x)))


def test_poles_and_jumps_are_not_roots():
    values = _on(LINE, root_pole_jump)
    p0, p1, _ = pk.sign_change_segments(LINE, values)
    assert len(p0) == 3  # today's refinement reports all three as roots
    c = pk.classify_crossings(root_pole_jump, LINE, values, tol=1e-12)
    assert_close(c.roots[:, 0], [0.25], rtol=0, atol=1e-12)
    assert sorted(zip(c.rejected_kind, np.round(c.rejected[:, 0], 9))) == [("jump", 0.85), ("pole", 0.55)]
    roots, axis = pk.singular_crossings(root_pole_jump, LINE, values, tol=1e-12)
    assert_close(roots, c.roots, atol=0) and list(axis) == [0]
    # refine_brackets classifies segment by segment
    ref = pk.refine_brackets(root_pole_jump, p0, p1, tol=1e-10)
    assert list(ref.kind) == ["root", "pole", "jump"]
    assert ref.shrink[0] < 2.0**-8 and ref.shrink[1] > 100 and 0.5 < ref.shrink[2] < 2
    # refine_roots keeps its old contract: every segment's midpoint, no classification
    assert len(pk.refine_roots(root_pole_jump, p0, p1, tol=1e-10)) == 3


def test_roots_of_higher_order_and_steep_roots_pass():
    """x^3 (triple root) and a root between a steep and a flat branch are roots, not jumps."""
    for f, r in (
        (lambda pt: (pt[0] - 0.33) ** 3, 0.33),
        (lambda pt: jnp.where(pt[0] < 0.47, 1e6 * (pt[0] - 0.47), 1e-6 * (pt[0] - 0.47)), 0.47),
    ):
        values = _on(LINE, f)
        roots, _ = pk.singular_crossings(f, LINE, values, tol=1e-12)
        assert_close(roots[:, 0], [r], rtol=0, atol=1e-9)


def test_exact_zeros_at_grid_nodes_are_found():
    grid = pk.Grid.from_ranges(x=(0.0, 1.0, 0.25), y=(0.0, 1.0, 0.25))

    def f(pt):  # the line x = y through the nodes, and a sign change elsewhere
        return (pt[0] - pt[1]) * (pt[0] + 0.1)

    values = _on(grid, f)
    assert np.sum(values == 0.0) == 5
    c = pk.classify_crossings(f, grid, values)
    nodes = c.roots[c.axis == -1]
    assert_close(np.sort(nodes[:, 0]), [0.0, 0.25, 0.5, 0.75, 1.0], atol=0)
    assert_close(nodes[:, 0], nodes[:, 1], atol=0)
    roots, axis = pk.singular_crossings(f, grid, values)
    assert np.sum(axis == -1) == 5 and len(roots) == len(c.roots)
    assert_close(pk.zero_nodes(grid, values), c.roots[c.axis == -1], atol=0)


def test_two_roots_in_one_segment_and_a_touching_curve_are_suspects():
    def two(pt):
        return (pt[0] - 0.51) * (pt[0] - 0.53)

    def touch(pt):
        return (pt[0] - 0.537) ** 2

    def near_miss(pt):
        return (pt[0] - 0.537) ** 2 + 1e-3

    for f, kind, where in ((two, "two_roots", 0.52), (touch, "touching", 0.537)):
        values = _on(LINE, f)
        assert len(pk.sign_change_segments(LINE, values)[0]) == 0  # no sign change on the grid
        c = pk.classify_crossings(f, LINE, values, tol=1e-12)
        assert len(c.roots) == 0
        assert list(c.suspect_kind) == [kind]
        assert_close(c.suspects[:, 0], [where], rtol=0, atol=1e-5 if kind == "two_roots" else 1e-9)
    c = pk.classify_crossings(near_miss, LINE, _on(LINE, near_miss), tol=1e-12)
    assert len(c.suspects) == 0 and "none" in c.summary()


@pytest.mark.parametrize("tol", [0, 0.0, -1e-9, float("nan"), float("inf"), "1e-9", None, 1j])
def test_bad_tolerances_are_value_errors_naming_tol(tol):
    values = _on(LINE, root_pole_jump)
    p0, p1, _ = pk.sign_change_segments(LINE, values)
    for call in (
        lambda: pk.refine_roots(root_pole_jump, p0, p1, tol=tol),
        lambda: pk.refine_brackets(root_pole_jump, p0, p1, tol=tol),
        lambda: pk.singular_crossings(root_pole_jump, LINE, values, tol=tol),
        lambda: pk.classify_crossings(root_pole_jump, LINE, values, tol=tol),
    ):
        with pytest.raises(ValueError, match="tol"):
            call()


@pytest.fixture(scope="module")
def p2():
    return t.ThreeRRRParams.from_dict(pk.load_params("p2")["mechanism"])


def test_p2_folded_chain_sign_changes_are_jumps_not_type2_roots(p2):
    """The P2 notebook's 2.5 mm grid has det(A) sign changes on the three segments through the
    points where a chain folds onto its base joint (C_i = A_i, :func:`folded_chain_centres`); det(A)
    jumps there (|det A| up to 4.3e-3), so they are rejected, while a true crossing stays."""

    @jax.jit
    def det_A_at(pt):
        return t.pose_criteria(t.pose(pt[0:1], pt[1:2], 0.0), p2, V=0.1, force=10.0)["det_A"][0]

    p0 = np.array([[0.0675, 0.04], [0.33, 0.04], [0.2, 0.265], [0.07, 0.0375]])
    p1 = np.array([[0.07, 0.04], [0.3325, 0.04], [0.2, 0.2675], [0.07, 0.04]])
    f0 = np.array([float(det_A_at(jnp.asarray(p))) for p in p0])
    f1 = np.array([float(det_A_at(jnp.asarray(p))) for p in p1])
    assert np.all(f0 * f1 < 0)
    ref = pk.refine_brackets(det_A_at, p0, p1, tol=1e-9)
    assert list(ref.kind) == ["jump", "jump", "jump", "root"]
    assert_close(ref.x[:3], t.folded_chain_centres(0.0, p2), rtol=0, atol=1e-9)
    assert np.all(np.abs(ref.f_x[:3]) > 1e-3) and abs(ref.f_x[3]) < 1e-9
    # and through classify_crossings on a small window of the notebook's grid around fold 1
    grid = pk.Grid.from_ranges(x_P=(0.06, 0.08, 0.0025), y_P=(0.03, 0.05, 0.0025))
    values = np.asarray(
        t.pose_criteria(t.pose(*np.moveaxis(grid.points(), -1, 0), 0.0), p2, V=0.1, force=10.0)["det_A"]
    )
    c = pk.classify_crossings(det_A_at, grid, values)
    assert len(c.rejected) == 1 and c.rejected_kind[0] == "jump"
    assert_close(c.rejected[0], t.folded_chain_centres(0.0, p2)[0], rtol=0, atol=1e-9)
    assert len(c.roots) > 0
    assert np.max(np.abs([float(det_A_at(jnp.asarray(r))) for r in c.roots])) < 1e-9
