"""P4's analyses in the library (five_bar): the symmetric singular point, the refined type-2
singular curve against det(A) and the collinearity of B1, C, B2, and the figures' text sizes."""

import jax.numpy as jnp
import numpy as np
import pytest

import pkmlib as pk
from pkmlib.mechanisms import five_bar as fb
from pkmlib.plotting import plt, smallest_text_pt


@pytest.fixture(scope="module")
def p4():
    return fb.FiveBarParams.from_dict(pk.load_params("p4"))


def test_symmetric_singular_height_is_a_zero_of_det_A(p4):
    z = fb.symmetric_singular_height(p4)
    assert abs(z - np.sqrt(175.0**2 - 125.0**2)) < 1e-12
    d = lambda zz: float(fb.det_A_at(jnp.array([50.0, zz]), p4, fb.PAPER_BRANCH))  # noqa: E731
    assert d(z - 0.5) * d(z + 0.5) < 0.0  # det(A) changes sign across it
    assert abs(d(z)) < 1e-9 * max(abs(d(z - 0.5)), abs(d(z + 0.5))) * 1e3


def test_singular_curve_lies_where_B1_C_B2_are_collinear(p4):
    grid = pk.Grid.from_ranges(x_C=(-250.0, 350.0, 10.0), z_C=(5.0, 350.0, 10.0))
    maps = fb.stiffness_map(grid, p4, 2000.0, fb.PAPER_BRANCH, keys=("det_A",))
    roots, sin_max, length = fb.singular_curve(grid, maps["det_A"], p4, fb.PAPER_BRANCH)
    assert len(roots) > 20 and np.all(np.diff(roots[:, 0]) >= 0)
    assert sin_max < 1e-6  # collinear at every refined root
    dets = np.array([abs(float(fb.det_A_at(jnp.asarray(r), p4, fb.PAPER_BRANCH))) for r in roots[::5]])
    scale = np.nanmax(np.abs(maps["det_A"]))
    assert np.all(dets < 1e-6 * scale)
    on_axis = roots[np.abs(roots[:, 0] - 50.0) < 5.0]
    assert np.any(np.abs(on_axis[:, 1] - fb.symmetric_singular_height(p4)) < 1e-6)
    assert 100.0 < length < 2000.0


def test_figures_text_is_at_least_095_pt_per_inch_of_width(p4):
    x = jnp.array([50.0, 150.0])
    r = fb.pose_stiffness_jit(x, p4, 2000.0, fb.PAPER_BRANCH)
    J_inv = pk.inverse_jacobian(fb.mechanism, x, r["q"], p4)
    corners = fb.force_parallelogram(J_inv, 2000.0)
    diag_u, diag_len = fb.shorter_diagonal(corners)
    grid = pk.Grid.from_ranges(x_C=(-250.0, 350.0, 20.0), z_C=(5.0, 350.0, 20.0))
    maps = fb.stiffness_map(grid, p4, 2000.0, fb.PAPER_BRANCH, keys=("det_A", "torque_per_force", "directions"))
    inside = np.isfinite(maps["det_A"])
    roots = np.array([[0.0, 100.0], [10.0, 110.0]])
    figs = [
        fb.scheme_figure(x, p4, fb.PAPER_BRANCH, "title")[0],
        fb.parallelogram_figure(x, p4, fb.PAPER_BRANCH, corners, diag_u, diag_len, r["directions"], 2000.0, "title"),
        fb.worst_directions_figure(grid, maps, inside, roots, x, p4, 40.0, "title")[0],
    ]
    for fig in figs:
        assert smallest_text_pt(fig) >= 0.95 * fig.get_size_inches()[0]
        plt.close(fig)


def test_clipped_inverse_and_the_worst_stiffness_at_given_angles(p4):
    rng = np.random.default_rng(3)
    x = jnp.asarray(np.stack([rng.uniform(-300.0, 400.0, 400), rng.uniform(-100.0, 500.0, 400)]))
    q_nan = np.asarray(fb.inverse_position(x, p4, jnp.array(fb.PAPER_BRANCH, dtype=jnp.float64)))
    q, cos_g = (
        np.asarray(v) for v in fb.inverse_position_clipped(x, p4, jnp.array(fb.PAPER_BRANCH, dtype=jnp.float64))
    )
    inside = np.all(np.isfinite(q_nan), axis=0)
    assert 0.1 < inside.mean() < 0.9 and np.all(np.isfinite(q))
    assert np.array_equal(inside, np.all(np.abs(cos_g) <= 1.0, axis=0))  # the margin 1 - |cos| says who reaches
    np.testing.assert_allclose(q[:, inside], q_nan[:, inside], rtol=0, atol=1e-9)
    # inside, the worst stiffness at the clipped angles is pose_stiffness's k_worst (P4 eq (5))
    for pose in np.asarray(x)[:, inside][:, :5].T:
        k = fb.pose_stiffness_jit(jnp.asarray(pose), p4)
        qq = fb.inverse_position_clipped(jnp.asarray(pose), p4, jnp.array(fb.PAPER_BRANCH, dtype=jnp.float64))[0]
        np.testing.assert_allclose(float(fb.worst_stiffness(jnp.asarray(pose), qq, p4)), float(k["k_worst"]), rtol=1e-9)
