"""P3 dynamics: virtual work vs Lagrange (JAX energy) along the paper's motion, both against a
textbook pendulum, the module's one unit convention (mm, kg, kg mm^2, N) against an SI model
built by hand, compilation once per model, and jax.grad of the driving forces against central
differences."""

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import pkmlib as pk
from pkmlib import _inverse_dynamics
from pkmlib.mechanisms import two_t_one_r as m
from conftest import assert_close, jvp_and_central_difference

G = jnp.array([0.0, 0.0, -9.81])
P = pk.load_params("p3")
MO = P["motion"]
RHO, AMP = np.array(MO["rho_mm"]), np.array(MO["amplitude_mm"])


def model(which):
    if which == "A":
        p = m.ParamsA.from_dict(P)
        return p, m.dynamics_model_a(p, 1.0, P["masses_A_kg"], P["inertia_A_table3"])
    p = m.ParamsB.from_dict(P)
    return p, m.dynamics_model_b(p, jnp.array([1.0, 1.0]), P["masses_B_kg"], P["inertia_B_table4"])


def T_END(which):
    return 5.0 if which == "A" else 1.1  # B leaves its workspace at t = 1.164 s


def test_both_methods_match_the_pendulum_formula():
    """A rod (mass m, centre at r from a hinge on the y axis, inertia I about y at its centre)
    driven along q(t): tau = (I + m r^2) q'' + m g r cos(q) (textbook). SI units, plain functions."""
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
    for method in (pk.dynamics.inverse_dynamics_virtual_work, pk.dynamics.inverse_dynamics_lagrange):
        out = method(pose, masses, inertias, G, F, traj, t)
        assert out.shape == (13, 1)
        assert_close(out[:, 0], expected, rtol=1e-12, atol=1e-12)
    # inside a user's jit (t traced: padded and sliced on the device)
    jitted = jax.jit(lambda tt: pk.dynamics.inverse_dynamics_virtual_work(pose, masses, inertias, G, F, traj, tt))
    assert_close(jitted(t)[:, 0], expected, rtol=1e-12, atol=1e-12)
    # at a state: tau(q, q', q'') from state_trajectory
    tau = pk.dynamics.inverse_dynamics_virtual_work(
        pose, masses, inertias, G, F, pk.dynamics.state_trajectory([0.3], [1.0], [2.0]), jnp.zeros(1)
    )
    assert_close(tau[0, 0], (I_yy + mass * r**2) * 2.0 + mass * 9.81 * r * np.cos(0.3), rtol=1e-13)


@pytest.mark.parametrize("which", ["A", "B"])
def test_virtual_work_and_lagrange_agree_along_the_paper_motion(which):
    p, mod = model(which)
    traj = m.sinusoidal_trajectory(RHO, AMP, MO["omega_rad_s"])
    # 101 samples (padded to 128), as in test_inverse_dynamics_compile_once_per_model: the same
    # compiled functions serve both tests
    t = jnp.linspace(0.0, T_END(which), 101)
    vw = np.asarray(m.actuator_forces(mod, traj, t, payload_N=P["payload_N"]))
    lg = np.asarray(m.actuator_forces(mod, traj, t, payload_N=P["payload_N"], method="lagrange"))
    assert vw.shape == (101, 3)
    assert_close(lg, vw, rtol=0, atol=1e-9 * np.max(np.abs(vw)))
    # the payload is carried: the static part alone is tens of newtons
    assert np.max(np.abs(vw)) > 10.0
    # orientations are rotations
    _, R = mod.pose(jnp.asarray(RHO))
    assert_close(np.einsum("kij,kil->kjl", R, R), np.broadcast_to(np.eye(3), R.shape), rtol=0, atol=1e-12)


@pytest.mark.parametrize("which", ["A", "B"])
def test_dynamics_use_the_kinematics_units(which):
    """The dynamics model takes q in mm like the kinematics and puts the platform centre where the
    kinematics do (mm), and its inertias are Tables 3-4 as printed (kg mm^2)."""
    p, mod = model(which)
    q = jnp.asarray(RHO)
    c, _ = mod.pose(q)
    if which == "A":
        centre = m.platform_centre_a(m.forward_a(q, p, 1.0), p)
        table = P["inertia_A_table3"]["platform"]
    else:
        centre = m.platform_centre_b(m.forward_b(q, p, jnp.array([1.0, 1.0])), p)
        table = P["inertia_B_table4"]["platform"]
    assert_close(c[mod.platform_index], centre, rtol=1e-14)
    assert_close(jnp.diag(mod.inertias[mod.platform_index]), table, rtol=1e-15)


@pytest.mark.parametrize("which", ["A", "B"])
def test_actuator_forces_in_newtons_equal_an_si_model(which):
    """The one conversion (mm, kg mm^2 -> N) against the same bodies rebuilt in SI by hand:
    q in m, centres in m, inertias in kg m^2, gravity m/s^2, payload N (the old call's units)."""
    p, mod = model(which)

    def pose_si(q_m):
        c, R = mod.pose(1000.0 * q_m)
        return c / 1000.0, R

    traj_si = lambda t: m.sinusoidal_inputs(t, RHO / 1000.0, AMP / 1000.0, MO["omega_rad_s"])  # noqa: E731
    F = jnp.zeros((mod.masses.shape[0], 3)).at[mod.platform_index, 2].set(-P["payload_N"])
    t = jnp.linspace(0.0, T_END(which), 101)  # ours: the compiled function of the tests above
    si = pk.dynamics.inverse_dynamics_virtual_work(pose_si, mod.masses, 1e-6 * mod.inertias, G, F, traj_si, t)
    ours = m.actuator_forces(mod, m.sinusoidal_trajectory(RHO, AMP, MO["omega_rad_s"]), t, payload_N=P["payload_N"])
    assert_close(ours, si, rtol=0, atol=1e-12 * float(np.max(np.abs(si))))


def test_the_old_four_tuple_call_fails_loudly():
    """dynamics_model_a now returns a DynamicsModel in mm; unpacking it as the old (pose, masses,
    inertias, index) in m raises instead of giving numbers in the wrong units."""
    p = m.ParamsA.from_dict(P)
    with pytest.raises(TypeError):
        pose, masses, inertias, ip = m.dynamics_model_a(p, 1.0, P["masses_A_kg"], P["inertia_A_table3"])  # noqa: F841


def test_inverse_dynamics_compile_once_per_model():
    """Other amplitudes, payloads, geometry values, branch signs and sample counts reuse the
    compiled function of the same mechanism and method."""
    _, modA = model("A")
    pB, modB = model("B")
    traj = m.sinusoidal_trajectory(RHO, AMP, MO["omega_rad_s"])
    for mod in (modA, modB):
        for method in ("virtual_work", "lagrange"):
            m.actuator_forces(mod, traj, jnp.linspace(0.0, 1.0, 101), method=method)
    size = _inverse_dynamics._compiled._cache_size()
    pB2 = dataclasses.replace(pB, l3=pB.l3 + 1.0)
    modB2 = m.dynamics_model_b(pB2, jnp.array([1.0, 1.0]), P["masses_B_kg"], P["inertia_B_table4"])
    for k, mod in enumerate((modA, modB, modB2)):
        for method in ("virtual_work", "lagrange"):
            out = m.actuator_forces(
                mod,
                m.sinusoidal_trajectory(RHO + k, 0.5 * AMP, 2.0),
                jnp.linspace(0.0, 1.0, 77 + k),
                payload_N=10.0 * k,
                method=method,
            )
            assert out.shape == (77 + k, 3)
    assert _inverse_dynamics._compiled._cache_size() == size


def test_actuator_forces_reject_bad_input():
    _, mod = model("A")
    traj = m.sinusoidal_trajectory(RHO, AMP, MO["omega_rad_s"])
    with pytest.raises(ValueError, match="method"):
        m.actuator_forces(mod, traj, jnp.zeros(3), method="adams")
    with pytest.raises(ValueError, match="gravity_m_s2"):
        m.actuator_forces(mod, traj, jnp.zeros(3), gravity_m_s2=9.81)
    with pytest.raises(ValueError, match="external_forces_N"):
        m.actuator_forces(mod, traj, jnp.zeros(3), external_forces_N=jnp.zeros(3))
    with pytest.raises(ValueError, match="t must be"):
        m.actuator_forces(mod, traj, jnp.zeros((2, 2)))
    with pytest.raises(ValueError, match="trajectory"):
        pk.dynamics.inverse_dynamics_lagrange(
            mod.pose, mod.masses, mod.inertias, G, jnp.zeros((9, 3)), "sin", jnp.zeros(2)
        )
    with pytest.raises(ValueError, match="inertias"):
        pk.dynamics.inverse_dynamics_lagrange(
            mod.pose, mod.masses, mod.inertias[:3], G, jnp.zeros((9, 3)), traj, jnp.zeros(2)
        )
    p = m.ParamsA.from_dict(P)
    bad = dict(P["masses_A_kg"])
    del bad["DB3"]
    with pytest.raises(ValueError, match="DB3"):
        m.dynamics_model_a(p, 1.0, bad, P["inertia_A_table3"])
    for value in (None, "abc", -1.0, [1.0], 1j):
        with pytest.raises(ValueError, match="C3D"):
            m.dynamics_model_a(p, 1.0, {**P["masses_A_kg"], "C3D": value}, P["inertia_A_table3"])
    with pytest.raises(ValueError, match="platform"):
        m.dynamics_model_a(p, 1.0, P["masses_A_kg"], {**P["inertia_A_table3"], "platform": 7000.0})
    with pytest.raises(ValueError, match="branch"):
        m.dynamics_model_b(m.ParamsB.from_dict(P), 1.0, P["masses_B_kg"], P["inertia_B_table4"])


# ---------------------------------------------------------------- gradients


def interior_states(which, n=3, seed=0):
    """Random states near the paper's motion (inside the workspace, forces finite)."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        q = RHO + rng.uniform(-8.0, 8.0, 3)
        qd = rng.uniform(-40.0, 40.0, 3)
        qdd = rng.uniform(-100.0, 100.0, 3)
        out.append((q, qd, qdd))
    return out


@pytest.mark.parametrize("which", ["A", "B"])
@pytest.mark.parametrize("method", ["virtual_work", "lagrange"])
def test_grad_of_forces_matches_central_differences(which, method):
    """Derivatives of the driving forces with respect to the state (q, q', q''), every length of
    the geometry, the masses and the inertias (kept in the model pytree: derivatives flow through
    the Partial's leaves), by both methods, against central differences along the same directions:
    3 random ones in the state, each length, 3 random ones in the masses and inertias. The JVPs and
    the shifted forces are one jitted program per model and method (``jvp_and_central_difference``;
    a full ``jax.jacrev`` compiled for 15-25 s per pair on 2 cores, 45-97 s beside the other test
    processes). Reverse mode, the transpose of the same JVP, is checked once per model on the
    virtual-work forces: ``w^T J`` from ``jax.vjp`` against ``w . (J v)`` along every direction."""
    p, mod = model(which)
    q, qd, qdd = interior_states(which, n=1, seed=3)[0]
    state0 = np.concatenate([q, qd, qdd])
    lengths = ("a", "l1", "l2", "l3", "l4") + (("l5",) if which == "B" else ())
    branch = 1.0 if which == "A" else jnp.array([1.0, 1.0])
    make = m.dynamics_model_a if which == "A" else m.dynamics_model_b
    masses_key, inertia_key = (
        ("masses_A_kg", "inertia_A_table3") if which == "A" else ("masses_B_kg", "inertia_B_table4")
    )
    K = mod.masses.shape[0]
    n_lengths = len(lengths)

    # the inertias as the symmetric part of z's tensors plus 1e-5 I (the library refuses a tensor
    # that is not symmetric positive semidefinite, and the model's zero tensors would turn
    # negative under the central differences' steps); the forces are linear in them, so the
    # derivatives are those at the model's own inertias. One flat input: state (9), lengths, z.
    def forces(x):
        state, v, z = x[:9], x[9 : 9 + n_lengths], x[9 + n_lengths :]
        pp = dataclasses.replace(p, **{k: v[i] for i, k in enumerate(lengths)})
        mm = make(pp, branch, P[masses_key], P[inertia_key])
        S = z[K:].reshape(K, 3, 3)
        inertias = 0.5 * (S + jnp.swapaxes(S, 1, 2)) + 1e-5 * jnp.eye(3)[None]
        mm = dataclasses.replace(mm, masses=z[:K], inertias=inertias)
        return m.actuator_forces_at(mm, state[:3], state[3:6], state[6:], payload_N=P["payload_N"], method=method)

    v0 = np.array([getattr(p, k) for k in lengths])
    z0 = np.concatenate([np.asarray(mod.masses), np.asarray(mod.inertias).ravel()])
    x0 = np.concatenate([state0, v0, z0])
    rng = np.random.default_rng(1)
    directions, steps, rows = [], [], []
    start = 0
    for n, h, random in ((9, 1e-4, True), (n_lengths, 1e-4, False), (10 * K, 1e-6, True)):
        d = rng.standard_normal((3, n)) if random else np.eye(n)
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        full = np.zeros((len(d), len(x0)))
        full[:, start : start + n] = d
        rows.append(slice(len(steps), len(steps) + len(d)))
        directions.append(full)
        steps += [h] * len(d)
        start += n
    directions = np.concatenate(directions)
    Jv, fd = jvp_and_central_difference(forces, x0, directions, np.array(steps))
    assert Jv.shape == fd.shape == (6 + n_lengths, 3)
    assert np.all(np.isfinite(Jv))
    for block in rows:
        assert np.max(np.abs(Jv[block])) > 0, "a block of derivatives is all zero"
        assert_close(Jv[block], fd[block], rtol=1e-6, atol=1e-7 * np.max(np.abs(fd[block])))
    if method == "virtual_work":
        w = np.array([0.3, -0.7, 0.5])
        (wJ,) = jax.jit(lambda x: jax.vjp(forces, x)[1](jnp.asarray(w)))(jnp.asarray(x0))
        assert_close(directions @ np.asarray(wJ), Jv @ w, rtol=1e-10, atol=1e-12 * np.max(np.abs(Jv @ w)))
