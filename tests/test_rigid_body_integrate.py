"""The rigid-body integrator's API and accuracy: the wrench callback ``(t, state, *args)`` in the
base frame, full inertia tensors, trajectories that start at t = 0, the two methods' orders of
convergence, and one compilation per wrench function.

Independent checks: closed-form motions (momentum balance dL/dt = M and m dv/dt = F in the base
frame, exponential damping, a time-dependent force integrated by hand), the same body described in
two body frames, and the error-versus-step slopes.
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from conftest import assert_close

import pkmlib as pk
from pkmlib import _rigid_body
from pkmlib.mechanisms import decoupled_6dof as m

J_FULL = jnp.array([[0.020, 0.003, -0.001], [0.003, 0.015, 0.002], [-0.001, 0.002, 0.008]])
MASS = 1.5
R0 = pk.rotation_matrix(0.3, -0.2, 0.5)
STATE0 = pk.dynamics.RigidBodyState(
    jnp.array([0.1, 0.0, -0.2]), jnp.array([0.0, 0.3, 0.1]), R0, jnp.array([3.0, -2.0, 1.0])
)


def general_wrench(t, s, k):
    """Depends on time, pose and both velocities; the moment in the base frame."""
    F = -k * s.position - 0.3 * s.velocity + jnp.stack([jnp.sin(3.0 * t), 0.0 * t, 1.0 + 0.0 * t])
    M = -0.01 * (s.rotation @ s.omega) + 0.02 * jnp.stack([jnp.cos(2.0 * t), jnp.sin(t), 0.5 + 0.0 * t])
    return F, M


def constant_wrench(t, s, F, M):
    return F, M


def damping(t, s, c):
    return -c * s.velocity, jnp.zeros(3)


def final_error(method, n, ref):
    tr = pk.dynamics.integrate(STATE0, general_wrench, MASS, J_FULL, 1.0 / n, n, args=(2.0,), method=method)
    return max(
        float(np.max(np.abs(tr.omega[-1] - ref.omega[-1]))),
        float(np.max(np.abs(tr.rotation[-1] - ref.rotation[-1]))),
        float(np.max(np.abs(tr.position[-1] - ref.position[-1]))),
        float(np.max(np.abs(tr.velocity[-1] - ref.velocity[-1]))),
    )


def test_orders_of_convergence():
    """Error at t = 1 s against a fine RKMK4 run, for a full inertia tensor and a wrench that
    depends on time, pose and velocities: slope 2 for the splitting, 4 for RKMK4."""
    ref = pk.dynamics.integrate(STATE0, general_wrench, MASS, J_FULL, 1.0 / 2048, 2048, args=(2.0,), method="rkmk4")
    for method, order in (("splitting", 2), ("rkmk4", 4)):
        errs = np.array([final_error(method, n, ref) for n in (16, 32, 64)])
        slopes = np.log2(errs[:-1] / errs[1:])
        assert np.all(np.abs(slopes - order) < 0.15), (method, errs, slopes)
    assert pk.dynamics.INTEGRATION_METHODS == {"splitting": 2, "rkmk4": 4}


def test_rkmk4_is_far_more_accurate_at_the_p5_notebook_step():
    """At the P5 notebook's step (0.5 ms, 0.3 s) and its free tumbling platform, RKMK4's angular
    velocity error is at least 1e3 times smaller than the splitting's."""
    p = m.Decoupled6DofParams.from_dict(pk.load_params("p5"))
    s0 = pk.dynamics.RigidBodyState(jnp.array([0.1, 0.15, 0.2]), jnp.zeros(3), R0, jnp.array([3.0, 2.0, 1.0]))
    ref = m.simulate(s0, jnp.zeros(6), p, 0.3 / 4800, 4800, method="rkmk4")
    err = {
        k: float(np.max(np.abs(m.simulate(s0, jnp.zeros(6), p, 5e-4, 600, method=k).omega[-1] - ref.omega[-1])))
        for k in ("splitting", "rkmk4")
    }
    assert err["rkmk4"] * 1e3 < err["splitting"], err


def test_trajectory_starts_with_the_initial_state_at_t0():
    for method in pk.dynamics.INTEGRATION_METHODS:
        tr = pk.dynamics.integrate(STATE0, general_wrench, MASS, J_FULL, 1e-2, 5, args=(2.0,), method=method)
        assert tr.position.shape == (6, 3) and tr.rotation.shape == (6, 3, 3)
        for a, b in zip(tr, STATE0):
            np.testing.assert_array_equal(np.asarray(a[0]), np.asarray(b))


def test_time_dependent_wrench_sees_the_time_and_t0():
    """F = (sin t, 0, 0) from t0: v(t) = v0 + (cos t0 - cos t) / m, integrated by hand."""

    def wrench(t, s):
        return jnp.stack([jnp.sin(t), 0.0 * t, 0.0 * t]), jnp.zeros(3)

    t0, dt, n = 0.7, 0.01, 100
    t = t0 + dt * np.arange(n + 1)
    for method, tol in (("splitting", 1e-5), ("rkmk4", 1e-10)):
        tr = pk.dynamics.integrate(STATE0, wrench, MASS, J_FULL, dt, n, t0=t0, method=method)
        assert_close(tr.velocity[:, 0], STATE0.velocity[0] + (np.cos(t0) - np.cos(t)) / MASS, rtol=0, atol=tol)


def test_velocity_dependent_wrench_damps_exponentially():
    """F = -c v: v(t) = v0 exp(-c t / m); both methods converge at their order."""
    c, T = 3.0, 1.0
    exact = np.asarray(STATE0.velocity) * np.exp(-c * T / MASS)
    for method, order in (("splitting", 2), ("rkmk4", 4)):
        errs = [
            float(
                np.max(
                    np.abs(
                        pk.dynamics.integrate(
                            STATE0, damping, MASS, J_FULL, T / n, n, args=(c,), method=method
                        ).velocity[-1]
                        - exact
                    )
                )
            )
            for n in (20, 40)
        ]
        assert abs(np.log2(errs[0] / errs[1]) - order) < 0.2, (method, errs)


@pytest.mark.parametrize("method", sorted(pk.dynamics.INTEGRATION_METHODS))
def test_wrench_is_in_the_base_frame(method):
    """A constant base-frame force and moment: m v = m v0 + F t and L = R J omega = L0 + M t in the
    base frame for any body (momentum balance). The old convention (moment in the body frame) fails
    this as soon as the body turns."""
    F, M = jnp.array([0.3, -0.2, 0.5]), jnp.array([0.02, -0.01, 0.03])
    dt, n = 1e-3, 400
    tr = pk.dynamics.integrate(STATE0, constant_wrench, MASS, J_FULL, dt, n, args=(F, M), method=method)
    t = dt * np.arange(n + 1)
    assert_close(tr.velocity, STATE0.velocity[None] + np.asarray(F)[None] * t[:, None] / MASS, rtol=0, atol=1e-13)
    L = np.asarray(pk.dynamics.angular_momentum(tr, J_FULL))
    L0 = np.asarray(pk.dynamics.angular_momentum(STATE0, J_FULL))
    atol = 1e-15 if method == "splitting" else 1e-9  # the splitting's kicks are exact
    assert_close(L, L0[None] + np.asarray(M)[None] * t[:, None], rtol=0, atol=atol)
    assert float(np.max(pk.dynamics.rotation_error(tr.rotation))) < 1e-13


@pytest.mark.parametrize("method", sorted(pk.dynamics.INTEGRATION_METHODS))
def test_full_inertia_tensor_equals_the_principal_description(method):
    """The same body in two body frames: principal axes (J = diag(d)) and axes turned by Q
    (J' = Q^T diag(d) Q, R' = R Q, omega' = Q^T omega). The base-frame motion is the same."""
    d = jnp.array([0.007, 0.013, 0.02])  # ascending, the order eigh returns: the same splitting
    Q = pk.rotation_matrix(0.4, 1.1, -0.7)
    J_turned = Q.T @ jnp.diag(d) @ Q
    s_p = STATE0
    s_q = STATE0._replace(rotation=STATE0.rotation @ Q, omega=Q.T @ STATE0.omega)
    a = pk.dynamics.integrate(s_p, general_wrench, MASS, d, 1e-3, 300, args=(2.0,), method=method)
    b = pk.dynamics.integrate(s_q, general_wrench, MASS, J_turned, 1e-3, 300, args=(2.0,), method=method)
    assert_close(b.position, a.position, rtol=0, atol=1e-12)
    assert_close(b.rotation, a.rotation @ Q[None], rtol=0, atol=1e-12)
    assert_close(b.omega, np.einsum("ji,nj->ni", np.asarray(Q), np.asarray(a.omega)), rtol=0, atol=1e-11)
    assert_close(pk.dynamics.kinetic_energy(b, MASS, J_turned), pk.dynamics.kinetic_energy(a, MASS, d), rtol=1e-12)


def test_newton_euler_with_a_full_tensor():
    eps_full = pk.dynamics.newton_euler(MASS, J_FULL, jnp.zeros(3), jnp.array([0.1, 0.2, -0.1]), STATE0.omega)[1]
    w, Mv = np.asarray(STATE0.omega), np.array([0.1, 0.2, -0.1])
    Jn = np.asarray(J_FULL)
    assert_close(eps_full, np.linalg.solve(Jn, Mv - np.cross(w, Jn @ w)), rtol=1e-13)


def test_integrate_compiles_once_per_wrench_function():
    """Another state, step, time, forces or parameters reuse the compiled function."""
    traces = []

    def counting_wrench(t, s, F, M):
        traces.append(1)  # runs only when JAX traces the function
        return F, M

    for k in range(3):
        pk.dynamics.integrate(
            STATE0._replace(omega=STATE0.omega * (k + 1)),
            counting_wrench,
            MASS + k,
            J_FULL,
            1e-3 * (k + 1),
            10,
            args=(jnp.ones(3) * k, jnp.ones(3)),
            t0=0.1 * k,
        )
    n_first = len(traces)
    assert n_first > 0
    pk.dynamics.integrate(STATE0, counting_wrench, 2.0, J_FULL, 1e-2, 10, args=(jnp.zeros(3), jnp.zeros(3)))
    assert len(traces) == n_first


def test_integrate_inside_a_users_jit_with_traced_step_and_inertia():
    f = jax.jit(
        lambda dt, J: pk.dynamics.integrate(STATE0, general_wrench, MASS, J, dt, 7, args=(2.0,), method="rkmk4")
    )
    a = f(1e-2, J_FULL)
    b = pk.dynamics.integrate(STATE0, general_wrench, MASS, J_FULL, 1e-2, 7, args=(2.0,), method="rkmk4")
    assert_close(a.rotation, b.rotation, rtol=0, atol=1e-15)


def test_p5_simulate_compiles_once():
    p = m.Decoupled6DofParams.from_dict(pk.load_params("p5"))
    s0 = pk.dynamics.RigidBodyState(jnp.array([0.1, 0.15, 0.2]), jnp.zeros(3), R0, jnp.array([3.0, 2.0, 1.0]))
    m.simulate(s0, jnp.ones(6), p, 1e-3, 50)
    size = _rigid_body._integrate_compiled._cache_size()
    for k in range(3):
        m.simulate(s0._replace(velocity=jnp.ones(3) * k), jnp.arange(6.0) * k, p, 1e-3 * (k + 1), 50)
    assert _rigid_body._integrate_compiled._cache_size() == size


def test_integrate_rejects_bad_arguments():
    ok = dict(args=(jnp.zeros(3), jnp.zeros(3)))
    cases = [
        (dict(inertia=jnp.array([1.0, -1.0, 1.0])), "inertia"),
        (dict(inertia=jnp.array([[1.0, 0.5, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])), "symmetric"),
        (dict(inertia=-jnp.eye(3)), "positive definite"),
        (dict(inertia=jnp.ones(4)), "shape"),
        (dict(inertia="abc"), "inertia"),
        (dict(method="rk45"), "method"),
        (dict(n_steps=0), "n_steps"),
        (dict(n_steps=2.5), "n_steps"),
        (dict(dt=-1e-3), "dt"),
        (dict(dt=None), "dt"),
    ]
    for override, match in cases:
        kw = dict(inertia=J_FULL, dt=1e-3, n_steps=3, method="splitting")
        kw.update(override)
        with pytest.raises(ValueError, match=match):
            pk.dynamics.integrate(
                STATE0, constant_wrench, MASS, kw["inertia"], kw["dt"], kw["n_steps"], method=kw["method"], **ok
            )
    with pytest.raises(ValueError, match="state.rotation"):
        pk.dynamics.integrate(STATE0._replace(rotation=jnp.eye(2)), constant_wrench, MASS, J_FULL, 1e-3, 3, **ok)
    with pytest.raises(ValueError, match="args"):
        pk.dynamics.integrate(STATE0, constant_wrench, MASS, J_FULL, 1e-3, 3, args=[jnp.zeros(3), jnp.zeros(3)])


def test_exp_so3_is_rodrigues_with_finite_gradients_at_zero():
    rng = np.random.default_rng(1)
    for v in [rng.normal(size=3), 1e-3 * rng.normal(size=3), 1e-9 * rng.normal(size=3)]:
        th = np.linalg.norm(v)
        K = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]]) / th
        assert_close(
            pk.exp_so3(jnp.asarray(v)), np.eye(3) + np.sin(th) * K + (1 - np.cos(th)) * K @ K, rtol=0, atol=1e-15
        )
    jac0 = jax.jacfwd(pk.exp_so3)(jnp.zeros(3))
    assert_close(jac0, np.stack([pk.skew(jnp.eye(3)[k]) for k in range(3)], -1), rtol=0, atol=1e-15)
    g = jax.grad(lambda v: jnp.sum(pk.exp_so3(v) * jnp.arange(9.0).reshape(3, 3)))(jnp.zeros(3))
    assert np.all(np.isfinite(np.asarray(g)))
