"""Benchmark P5: the platform simulation under constant motor forces (P5 eq 8, sign-corrected;
``decoupled_6dof.simulate``: symplectic splitting with exact free-rotor flows, ``lax.scan``), as the
notebook calls it (each call traces the scan) and compiled once (``jax.jit`` with the step count
static, reused), against a numba loop of the same scheme and the same wrench in the same run.

Sizes: time steps of 0.5 ms from the notebook's initial state (alpha = beta = gamma = 30 deg,
O_m = (0.1, 0.15, 0.2) m, omega = (3, 2, 1) rad/s, forces (1, 1.5, 2, 2, 3, 2.5) N).
Run: ``python benchmarks/p5.py`` (or ``make benchmark``).
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numba
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _bench import main, rate  # noqa: E402

DT = 0.0005
ANGLES_DEG = (30.0, 30.0, 30.0)
POSITION = (0.1, 0.15, 0.2)
OMEGA = (3.0, 2.0, 1.0)
FORCES = (1.0, 1.5, 2.0, 2.0, 3.0, 2.5)


def _setup():
    import jax.numpy as jnp
    import pkmlib as pk
    from pkmlib.mechanisms import decoupled_6dof as m

    p = m.Decoupled6DofParams.from_dict(pk.load_params("p5")["mechanism"])
    R = pk.rotation_matrix(*np.deg2rad(ANGLES_DEG))
    state = pk.dynamics.RigidBodyState(jnp.asarray(POSITION), jnp.zeros(3), R, jnp.asarray(OMEGA))
    return p, state, jnp.asarray(FORCES)


def _values(traj):
    return {
        "position": np.asarray(traj.position),
        "rotation": np.asarray(traj.rotation),
        "omega": np.asarray(traj.omega),
        "velocity": np.asarray(traj.velocity),
    }


def _as_called(n):
    from pkmlib.mechanisms import decoupled_6dof as m

    p, state, forces = _setup()
    return (lambda: _values(m.simulate(state, forces, p, DT, n))), n, lambda o: o


def _compiled_once(n):
    import jax
    from pkmlib.mechanisms import decoupled_6dof as m

    p, state, forces = _setup()
    sim = jax.jit(m.simulate, static_argnums=(4,))
    return (lambda: _values(sim(state, forces, p, DT, n))), n, lambda o: o


@numba.njit(cache=True)
def rot(k, th):
    c, s = math.cos(th), math.sin(th)
    Q = np.eye(3)
    i, j = (1, 2) if k == 0 else ((2, 0) if k == 1 else (0, 1))
    Q[i, i], Q[i, j], Q[j, i], Q[j, j] = c, -s, s, c
    return Q


@numba.njit(cache=True)
def moment_body(pos, R, A_body, r, P):
    # moment about O_m of the forces P_i r_i through A_i = R A_i^m + pos, in the moving frame:
    # M_l = R[:, l] . sum_i P_i (R A_i^m) x r_i  (P5 eq 6 and 8)
    tot = np.zeros(3)
    for i in range(6):
        a = R @ A_body[i]
        tot += P[i] * np.cross(a, r[i])
    return R.T @ tot


@numba.njit(cache=True)
def run_sim(pos, vel, R, omega, J, mass, F, A_body, r, P, h, n, out_pos, out_R, out_om, out_vel):
    pos, vel, R = pos.copy(), vel.copy(), R.copy()
    pi = J * omega
    for step in range(n):
        M = moment_body(pos, R, A_body, r, P)
        vel = vel + 0.5 * h * F / mass
        pi = pi + 0.5 * h * M
        for k, frac in ((0, 0.5), (1, 0.5), (2, 1.0), (1, 0.5), (0, 0.5)):
            Q = rot(k, frac * h * pi[k] / J[k])
            R = R @ Q
            pi = Q.T @ pi
        pos = pos + h * vel
        M = moment_body(pos, R, A_body, r, P)
        vel = vel + 0.5 * h * F / mass
        pi = pi + 0.5 * h * M
        out_pos[step], out_R[step], out_om[step], out_vel[step] = pos, R, pi / J, vel


def _numba(n):
    from pkmlib.mechanisms import decoupled_6dof as m

    p, state, forces = _setup()
    A_body = p.a * m.PLATFORM_POINTS_UNIT
    r = m.FORCE_DIRECTIONS
    P = np.asarray(forces)
    F = P @ r  # base frame, constant

    args = (
        np.asarray(state.position),
        np.asarray(state.velocity),
        np.asarray(state.rotation),
        np.asarray(state.omega),
        np.asarray(p.inertia),
        float(p.mass),
        F,
        A_body,
        r,
        P,
        DT,
        n,
    )

    def go():
        out = (np.empty((n, 3)), np.empty((n, 3, 3)), np.empty((n, 3)), np.empty((n, 3)))
        run_sim(*args, *out)
        # pk.dynamics.integrate returns the initial state too (n + 1 states, t0 + k dt): the same here
        first = (args[0], args[2], args[3], args[1])
        out = tuple(np.concatenate([np.asarray(f)[None], o]) for f, o in zip(first, out))
        return {"position": out[0], "rotation": out[1], "omega": out[2], "velocity": out[3]}

    return go, n, lambda o: o


CASES = {"simulate_as_called": _as_called, "simulate_compiled_once": _compiled_once, "simulate_numba": _numba}
PLAN = [
    ("simulate_as_called", [600, 6000], 2),
    ("simulate_compiled_once", [600, 6000, 60000], 3),
    ("simulate_numba", [600, 6000, 60000], 3),
]


def _summary(cases):
    called = cases["simulate_as_called"][0]
    return {
        "summary": {
            "steps_per_s_600_steps": {
                k: rate(cases, f"simulate_{k}", 600) for k in ("as_called", "compiled_once", "numba")
            },
            "steps_per_s_largest": {k: rate(cases, f"simulate_{k}") for k in ("as_called", "compiled_once", "numba")},
            "as_called_first_call_steps_per_s": called["items"] / called["first_call_s"],
            "numba_over_compiled_once_largest": rate(cases, "simulate_numba") / rate(cases, "simulate_compiled_once"),
        }
    }


if __name__ == "__main__":
    main(
        "p5",
        CASES,
        PLAN,
        reference={"simulate_compiled_once": "simulate_as_called", "simulate_numba": "simulate_as_called"},
        extra=_summary,
        rtol=1e-9,
        notes={"sizes": "time steps of 0.5 ms", "items": "time steps"},
    )
