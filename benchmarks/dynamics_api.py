"""Benchmark: compile once for the dynamics (issue 14 item 1) and the integrators' accuracy at the
P5 notebook's step (issue 12 item 7). Ratios in one run, not absolute times.

- P3 inverse dynamics (virtual work and Lagrange, mechanism A, 201 samples as in the notebook):
  ``per_call_fresh_closure``: every call passes a new closure, so it compiles anew (what the old
  ``jax.jit(jax.vmap(...))`` around closures did on every call); ``per_call_compiled_once``: the
  :class:`DynamicsModel` and :func:`sinusoidal_trajectory` (``jax.tree_util.Partial``), after one
  warm-up call, each call with a new amplitude and a new number of samples (the first call of
  those values included).
- P5 ``simulate`` (600 steps of 0.5 ms): ``eager_scan``: the same integrator run as an eager
  ``lax.scan`` (the jitted function's ``__wrapped__``, what the old ``integrate`` did);
  ``compiled_once``: the module-level jit, new forces on each call.
- Accuracy at h = 0.5 ms over 0.3 s (the notebook's run, free tumbling platform): largest error in
  omega against a reference RKMK4 run at h / 16, for both methods.

Writes ``benchmarks/results/dynamics_api.json``. Run:
``PYTHONPATH=. JAX_PLATFORMS=cpu python benchmarks/dynamics_api.py``.
"""

from __future__ import annotations

import json
import os
import platform
import time
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

import pkmlib as pk
from pkmlib import _rigid_body
from pkmlib.mechanisms import decoupled_6dof as p5m
from pkmlib.mechanisms import two_t_one_r as p3m

OUT = Path(__file__).resolve().parent / "results" / "dynamics_api.json"


def _time(f, repeat):
    out = []
    for k in range(repeat):
        t0 = time.perf_counter()
        jax.block_until_ready(f(k))
        out.append(time.perf_counter() - t0)
    return out


def p3_inverse_dynamics(repeat_fresh=2, repeat_once=10):
    P = pk.load_params("p3")
    mo = P["motion"]
    pa = p3m.ParamsA.from_dict(P)
    model = p3m.dynamics_model_a(pa, 1.0, P["masses_A_kg"], P["inertia_A_table3"])
    rho, amp, om = np.array(mo["rho_mm"]), np.array(mo["amplitude_mm"]), mo["omega_rad_s"]
    n = 201
    res = {}
    for method in ("virtual_work", "lagrange"):

        def fresh(k):
            m2 = p3m.DynamicsModel(
                jax.tree_util.Partial(lambda q, p=pa: p3m.body_poses_a(q, p, 1.0)),
                model.masses,
                model.inertias,
                model.platform_index,
            )
            return p3m.actuator_forces(
                m2,
                p3m.sinusoidal_trajectory(rho, amp, om),
                np.linspace(0.0, 5.0, n),
                method=method,
                payload_N=P["payload_N"],
            )

        def once(k):
            return p3m.actuator_forces(
                model,
                p3m.sinusoidal_trajectory(rho, amp * (1.0 + 0.01 * k), om),
                np.linspace(0.0, 5.0, n - k),
                method=method,
                payload_N=P["payload_N"],
            )

        once(-1)  # warm-up of this model
        t_fresh = _time(fresh, repeat_fresh)
        t_once = _time(once, repeat_once)
        res[method] = {
            "samples_per_call": n,
            "per_call_fresh_closure_steps_per_s": n / float(np.median(t_fresh)),
            "per_call_compiled_once_steps_per_s": n / float(np.median(t_once)),
            "per_call_compiled_once_worst_steps_per_s": (n - repeat_once) / float(np.max(t_once)),
            "speedup": float(np.median(t_fresh) / np.median(t_once)),
        }
    return res


def p5_simulate(repeat=5):
    p = p5m.Decoupled6DofParams.from_dict(pk.load_params("p5"))
    R = pk.rotation_matrix(*np.deg2rad([30.0, 30.0, 30.0]))
    s0 = pk.dynamics.RigidBodyState(jnp.array([0.1, 0.15, 0.2]), jnp.zeros(3), R, jnp.array([3.0, 2.0, 1.0]))
    n, dt = 600, 5e-4
    res = {}
    for method in ("splitting", "rkmk4"):
        forces = lambda k: jnp.array([1.0, 1.5, 2.0, 2.0, 3.0, 2.5]) * (1.0 + 0.1 * k)  # noqa: E731

        def compiled(k):
            return p5m.simulate(s0, forces(k), p, dt, n, method=method)

        def eager(k):
            return _rigid_body._integrate_compiled.__wrapped__(
                s0,
                p5m.motor_wrench,
                (forces(k), p),
                jnp.asarray(p.mass),
                p.inertia,
                jnp.asarray(dt),
                jnp.asarray(0.0),
                n,
                method,
            )

        compiled(-1)
        t_c = _time(compiled, repeat)
        t_e = _time(eager, 2)
        res[method] = {
            "steps": n,
            "eager_scan_steps_per_s": n / float(np.median(t_e)),
            "compiled_once_steps_per_s": n / float(np.median(t_c)),
            "speedup": float(np.median(t_e) / np.median(t_c)),
        }
    # accuracy at the notebook's step
    ref = p5m.simulate(s0, jnp.zeros(6), p, dt / 16, 16 * n, method="rkmk4")
    err = {
        k: float(
            np.max(
                np.abs(
                    np.asarray(p5m.simulate(s0, jnp.zeros(6), p, dt, n, method=k).omega) - np.asarray(ref.omega[::16])
                )
            )
        )
        for k in ("splitting", "rkmk4")
    }
    res["max_omega_error_rad_s_at_notebook_step"] = err
    res["accuracy_ratio_splitting_over_rkmk4"] = err["splitting"] / err["rkmk4"]
    return res


def main():
    out = {
        "machine": {
            "processor": platform.processor() or platform.machine(),
            "cpus": os.cpu_count(),
            "jax": jax.__version__,
            "backend": jax.default_backend(),
            "load_average": os.getloadavg(),
        },
        "p3_inverse_dynamics_A": p3_inverse_dynamics(),
        "p5_simulate": p5_simulate(),
    }
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text(json.dumps(out, indent=2) + "\n")
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
