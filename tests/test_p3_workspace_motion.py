"""P3 workspace volume estimate, singular conditions and the platform motion (JAX time
derivatives vs finite differences, the exit of B from its workspace)."""

import jax.numpy as jnp
import numpy as np
import pytest

import pkmlib as pk
from pkmlib.mechanisms import two_t_one_r as m
from conftest import assert_close


@pytest.fixture(scope="module")
def P():
    return pk.load_params("p3")


def test_voxel_volume_of_a_sampled_box_is_exact():
    g = np.arange(0.5, 30.0, 1.0)  # points in the middle of 1 mm voxels of a 30 x 30 x 10 mm box
    X, Y, Z = np.meshgrid(g, g, g[:10], indexing="ij")
    pts = np.stack([X.ravel(), Y.ravel(), Z.ravel()])
    assert m.voxel_volume(pts, 1.0) == 9000.0
    assert m.voxel_volume(np.concatenate([pts, np.full((3, 5), np.nan)], axis=1), 10.0) == 9000.0


# voxels per spread: 20 (an occupancy grid) and 5000 (a box of ~1e13 voxels: the sorted voxels)
@pytest.mark.parametrize("per_spread", [20, 5000])
def test_voxel_volume_counts_the_distinct_voxels_of_a_random_cloud(per_spread):
    spread = 100.0
    rng = np.random.default_rng(7)
    pts = rng.normal(scale=spread, size=(3, 20000)) - 0.3 * spread  # negative coordinates too
    pts[:, :500] = pts[:, 500:1000]  # repeated points share their voxel
    voxel = spread / per_spread
    distinct = {tuple(v) for v in np.floor(pts / voxel).astype(np.int64).T}  # the definition, by hand
    assert m.voxel_volume(pts, voxel) == len(distinct) * voxel**3


def test_output_singularity_of_A_is_where_the_branches_meet(P):
    """f33 = 0 (P3 section 2.3.1 case 3, alpha = arctan((z - l1)/(y_C3 - a))) exactly where the
    discriminant of eq (13) vanishes: follow x3 to the edge of the real region and check both."""
    pa = m.ParamsA.from_dict(P["mechanism_A"])
    x1, x2 = -106.09, 181.67
    disc = lambda x3: float(m.discriminant_a(jnp.array([x1, x2, x3]), pa))  # noqa: E731
    lo, hi = -70.29, -300.0  # real at x3 = -70.29; |x_C - x3| > 273.6 mm has no real alpha
    assert disc(lo) > 0 and disc(hi) < 0
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if disc(mid) > 0 else (lo, mid)
    q = jnp.array([x1, x2, lo])
    xp, xm = m.forward_a(q, pa, 1.0), m.forward_a(q, pa, -1.0)
    assert abs(float(xp[2] - xm[2])) < 1e-5  # the two branches meet
    z, al = float(xp[1]), float(xp[2])
    # the paper's condition, tan(alpha) = (z - l1) / (y_C3 - a) with y_C3 = -a
    assert abs(np.tan(al) - (z - pa.l1) / (-pa.a - pa.a)) < 1e-5
    detA = float(pk.det_A(m.mechanism_a, xp, q, pa))
    detA_inside = float(
        pk.det_A(m.mechanism_a, m.forward_a(jnp.array([x1, x2, -70.29]), pa, 1.0), jnp.array([x1, x2, -70.29]), pa)
    )
    assert abs(detA) < 1e-4 * abs(detA_inside)


def test_platform_velocity_and_acceleration_match_finite_differences(P):
    pa = m.ParamsA.from_dict(P["mechanism_A"])
    mo = P["motion"]
    h = 1e-4
    t0 = np.array([0.3, 1.7, 3.2])
    t = jnp.asarray(np.concatenate([t0 - h, t0, t0 + h]))
    r = m.platform_motion(
        m.forward_a,
        m.platform_centre_a,
        pa,
        1.0,
        t,
        jnp.array(mo["rho_mm"]),
        jnp.array(mo["amplitude_mm"]),
        mo["omega_rad_s"],
    )
    x = np.asarray(r["position"]).reshape(3, 3, 3)  # (minus/centre/plus, time, xyz)
    assert_close(np.asarray(r["velocity"])[3:6], (x[2] - x[0]) / (2 * h), rtol=1e-6, atol=1e-6)
    assert_close(np.asarray(r["acceleration"])[3:6], (x[2] - 2 * x[1] + x[0]) / h**2, rtol=1e-4, atol=1e-3)
    # x of the platform centre is (x1 + x2)/2: its velocity is known in closed form
    assert_close(np.asarray(r["velocity"])[3:6, 0], 5.0 * np.pi * np.cos(np.pi * t0), rtol=1e-12)


def test_motion_stays_in_A_and_leaves_B(P):
    pa = m.ParamsA.from_dict(P["mechanism_A"])
    pb = m.ParamsB.from_dict(P["mechanism_B"])
    mo = P["motion"]
    args = (jnp.array(mo["rho_mm"]), jnp.array(mo["amplitude_mm"]), mo["omega_rad_s"])
    t = jnp.linspace(0.0, 5.0, 501)
    rA = m.platform_motion(m.forward_a, m.platform_centre_a, pa, 1.0, t, *args)
    assert np.all(np.isfinite(np.asarray(rA["acceleration"])))
    rB = m.platform_motion(m.forward_b, m.platform_centre_b, pb, jnp.array([1.0, 1.0]), t, *args)
    inside = np.all(np.isfinite(np.asarray(rB["pose"])), axis=1)
    first_out = float(np.asarray(t)[~inside][0])
    assert 1.16 < first_out <= 1.17
    d = float(m.discriminant_b(m.sinusoidal_inputs(1.1644, *args), pb, 1.0))
    d0 = float(m.discriminant_b(args[0], pb, 1.0))
    assert abs(d) < 1e-3 * d0


def test_combined_singularity_of_A_and_reachable_f32_singularity_of_B(P):
    """Against the paper's text: A has a real pose where det J_o = det J_i = 0 (five-bar stretched and
    x3 = x_C); B reaches z_E = l1 (f32 = 0) at a real pose."""
    pa = m.ParamsA.from_dict(P["mechanism_A"])
    pb = m.ParamsB.from_dict(P["mechanism_B"])
    q = jnp.array([-200.0, 200.0, 0.0])
    x = m.forward_a(q, pa, 1.0)
    assert np.all(np.isfinite(np.asarray(x)))
    scale = float(
        abs(
            pk.det_A(
                m.mechanism_a,
                m.forward_a(jnp.array([-100.0, 100.0, 0.0]), pa, 1.0),
                jnp.array([-100.0, 100.0, 0.0]),
                pa,
            )
        )
    )
    assert abs(float(pk.det_A(m.mechanism_a, x, q, pa))) < 1e-12 * scale
    assert abs(float(pk.det_B(m.mechanism_a, x, q, pa))) < 1e-9
    q = jnp.array([-100.0, 200.0, -270.0])
    x = m.forward_b(q, pb, jnp.array([1.0, 1.0]))
    assert np.all(np.isfinite(np.asarray(x)))
    assert abs(float(x[1]) - pb.l1) < 1e-9
    assert abs(float(pk.det_A(m.mechanism_b, x, q, pb))) < 1e-6
