"""P3 dynamics: virtual work vs Lagrange (JAX energy) along the paper's motion, and both against a
textbook pendulum."""

import jax.numpy as jnp
import numpy as np
import pytest

import pkmlib as pk
from pkmlib.mechanisms import two_t_one_r as m
from conftest import assert_close

G = jnp.array([0.0, 0.0, -9.81])


def test_both_methods_match_the_pendulum_formula():
    """A rod (mass m, centre at r from a hinge on the y axis, inertia I about y at its centre)
    driven along q(t): tau = (I + m r^2) q'' + m g r cos(q) (textbook)."""
    mass, r, I_yy = 2.0, 0.3, 0.05

    def pose(q):
        u = jnp.stack([jnp.cos(q[0]), 0.0 * q[0], jnp.sin(q[0])])
        z, o = jnp.zeros_like(q[0]), jnp.ones_like(q[0])
        R = jnp.stack([jnp.stack([u[0], z, -u[2]]), jnp.stack([z, o, z]), jnp.stack([u[2], z, u[0]])])
        return (r * u)[None, :], R[None]

    traj = lambda t: jnp.stack([0.4 + 0.7 * jnp.sin(2.0 * t)])  # noqa: E731
    t = jnp.linspace(0.0, 3.0, 13)
    masses, inertias, F = jnp.array([mass]), jnp.diag(jnp.array([0.01, I_yy, 0.04]))[None], jnp.zeros((1, 3))
    q, qdd = 0.4 + 0.7 * np.sin(2.0 * np.asarray(t)), -2.8 * np.sin(2.0 * np.asarray(t))
    expected = (I_yy + mass * r**2) * qdd + mass * 9.81 * r * np.cos(q)
    for method in (pk.inverse_dynamics_virtual_work, pk.inverse_dynamics_lagrange):
        assert_close(method(pose, masses, inertias, G, F, traj, t)[:, 0], expected, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("which", ["A", "B"])
def test_virtual_work_and_lagrange_agree_along_the_paper_motion(which):
    P = pk.load_params("p3")
    mo = P["motion"]
    rho, amp = jnp.array(mo["rho_mm"]) / 1000.0, jnp.array(mo["amplitude_mm"]) / 1000.0
    traj = lambda t: m.sinusoidal_inputs(t, rho, amp, mo["omega_rad_s"])  # noqa: E731
    if which == "A":
        p = m.ParamsA.from_dict(P["mechanism_A"])
        pose, masses, inertias, ip = m.dynamics_model_a(p, 1.0, P["masses_A_kg"], P["inertia_A_table3"])
        t = jnp.linspace(0.0, 5.0, 41)
    else:
        p = m.ParamsB.from_dict(P["mechanism_B"])
        pose, masses, inertias, ip = m.dynamics_model_b(p, jnp.array([1.0, 1.0]), P["masses_B_kg"], P["inertia_B_table4"])
        t = jnp.linspace(0.0, 1.1, 23)  # B leaves its workspace at t = 1.164 s
    F = jnp.zeros((masses.shape[0], 3)).at[ip, 2].set(-P["payload_N"])
    vw = np.asarray(pk.inverse_dynamics_virtual_work(pose, masses, inertias, G, F, traj, t))
    lg = np.asarray(pk.inverse_dynamics_lagrange(pose, masses, inertias, G, F, traj, t))
    assert_close(lg, vw, rtol=0, atol=1e-6 * np.max(np.abs(vw)))
    # the payload is carried: the static part alone is tens of newtons
    assert np.max(np.abs(vw)) > 10.0
    # orientations are rotations
    _, R = pose(rho)
    assert_close(np.einsum("kij,kil->kjl", R, R), np.broadcast_to(np.eye(3), R.shape), rtol=0, atol=1e-12)
