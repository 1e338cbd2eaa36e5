"""Benchmark the numerical positions of any mechanism (``pkmlib.inverse_positions``,
``pkmlib.forward_positions``; issue 19 item 7), each against the closed form in the same run.

- ``inverse_<paper>_numerical`` / ``inverse_<paper>_closed``: batched inverse position of P1
  (4-PRR, the notebook's pose: phi = 20 deg, s = 0.14 m, an N x N grid of x_D 0.2..1.2 m, y_D
  -0.25..0.25 m), P2 (3-RRR, phi = 0, x_P -0.15..0.55, y_P -0.15..0.5 m), P4 (five-bar,
  x_C -250..350, z_C 2.5..350 mm) and P3's mechanism A (the poses of the FK branch m = +1 over
  an N x N x N grid of the actuator box); the closed forms are the modules' own
  ``mechanism.inverse`` (P1 after eq (1), P2 and P4 atan2 + acos, P3 eq (14)), jitted; the
  numerical one never uses them. Items: poses.
- ``inverse_delta_numerical``: a Delta (three RSS chains, squared-distance closures written as a
  plain ``pkmlib.Mechanism`` below; no closed form is used) over an N x N x N grid of platform
  positions.
- ``forward_delta_all_modes``: every assembly mode (``forward_positions``, 4^3 Newton starts in a
  box, de-duplicated and ordered) at each input of an N x N x N grid of actuator angles; items:
  inputs (poses with all their modes), set beside CUIK's ~30 s per Delta pose (all modes).

Run: ``python benchmarks/mechanisms.py`` (writes ``benchmarks/results/mechanisms.json``) or
``python benchmarks/mechanisms.py --smoke`` (smallest sizes, into ``build/benchmark_smoke/``; the
committed results stay as they are).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _bench
from _bench import main, rate

CUIK_S_PER_DELTA_POSE = 30.0  # issue 19: the CUIK suite, all modes of one Delta pose
DELTA = {"R": 0.2, "L": 0.2, "l": 0.45, "r": 0.05}
DELTA_BOX = ((-0.6, -0.6, -0.8), (0.6, 0.6, 0.8))


def delta_mechanism():
    """Delta: base radius R, arm L, forearm l, platform radius r; chain i at gamma_i = 2 pi i / 3,
    elbow B_i = (R + L cos t) e_i - L sin t z, platform joint C_i = P + r e_i,
    F_i = |C_i - B_i|^2 - l^2 (the same model as tests/test_positions.py)."""
    import jax.numpy as jnp

    import pkmlib as pk

    def chain(i, x, t, p):
        g = 2.0 * np.pi * i / 3.0
        c, s = np.cos(g), np.sin(g)
        rad = p["R"] + p["L"] * jnp.cos(t) - p["r"]
        return (x[0] - rad * c) ** 2 + (x[1] - rad * s) ** 2 + (x[2] + p["L"] * jnp.sin(t)) ** 2 - p["l"] ** 2

    return pk.Mechanism(
        name="Delta",
        chain_constraint=chain,
        actuator_limits=lambda p: (jnp.full(3, -jnp.inf), jnp.full(3, jnp.inf)),
        output_names=("x", "y", "z"),
        output_units=("m", "m", "m"),
        actuator_names=("theta_1", "theta_2", "theta_3"),
        actuator_units=("rad",) * 3,
        default_branch=(1, 1, 1),
    )


def _papers(paper, n):
    """(mechanism, params, poses (n_x, *grid), periodic actuators, numerical branch, closed branch)."""
    import jax.numpy as jnp

    import pkmlib as pk
    from pkmlib.mechanisms import five_bar, gripper_4prr, three_rrr, two_t_one_r

    if paper == "p1":
        p = gripper_4prr.Gripper4PRRParams.from_dict(pk.load_params("p1"))
        X, Y = np.meshgrid(np.linspace(0.2, 1.2, n), np.linspace(-0.25, 0.25, n), indexing="ij")
        return gripper_4prr.mechanism, p, gripper_4prr.pose(X, Y, np.deg2rad(20.0), 0.14), False, None, None
    if paper == "p2":
        p = three_rrr.ThreeRRRParams.from_dict(pk.load_params("p2"))
        X, Y = np.meshgrid(np.linspace(-0.15, 0.55, n), np.linspace(-0.15, 0.5, n), indexing="ij")
        return three_rrr.mechanism, p, three_rrr.pose(X, Y, 0.0), True, None, None
    if paper == "p4":
        p = five_bar.FiveBarParams.from_dict(pk.load_params("p4"))
        X, Z = np.meshgrid(np.linspace(-250.0, 350.0, n), np.linspace(2.5, 350.0, n), indexing="ij")
        return five_bar.mechanism, p, jnp.stack([jnp.asarray(X), jnp.asarray(Z)]), True, None, None
    if paper == "p3a":
        p = two_t_one_r.ParamsA.from_dict(pk.load_params("p3"))
        axes = [np.linspace(lo, hi, n) for lo, hi in ((p.x1_min, p.x1_max), (p.x2_min, p.x2_max), (p.x3_min, p.x3_max))]
        q = jnp.stack([jnp.asarray(g) for g in np.meshgrid(*axes, indexing="ij")])
        x = two_t_one_r.forward_a(q, p, 1.0)
        # (u, v) = (-1, -1) of P3 eq (14) is (u, -u, v) = (-1, 1, -1) in signs of dF_i/dq_i
        return two_t_one_r.mechanism_a, p, x, False, (-1, 1, -1), (-1, -1)
    raise ValueError(paper)


def _values(periodic):
    def values(out):
        q = np.array(out)
        q[:, np.any(np.isnan(q), axis=0)] = np.nan  # one NaN convention: the whole pose
        return {"q": np.angle(np.exp(1j * q)) if periodic else q}

    return values


def _inverse_case(paper, numerical):
    def make(n):
        import jax

        import pkmlib as pk

        mech, p, x, periodic, b_num, b_closed = _papers(paper, n)
        x = jax.block_until_ready(x)
        if numerical:
            run = lambda: jax.block_until_ready(pk.inverse_positions(mech, x, p, b_num))  # noqa: E731
        else:
            f = jax.jit(lambda x_, p_: mech.inverse(x_, p_, b_closed))
            run = lambda: jax.block_until_ready(f(x, p))  # noqa: E731
        return run, int(np.prod(x.shape[1:])), _values(periodic)

    return make


def _delta_poses(n):
    import jax.numpy as jnp

    X, Y, Z = np.meshgrid(
        np.linspace(-0.2, 0.2, n), np.linspace(-0.2, 0.2, n), np.linspace(-0.5, -0.25, n), indexing="ij"
    )
    return jnp.stack([jnp.asarray(X), jnp.asarray(Y), jnp.asarray(Z)])


def inverse_delta(n):
    import jax

    import pkmlib as pk

    mech, x = delta_mechanism(), _delta_poses(n)
    run = lambda: jax.block_until_ready(pk.inverse_positions(mech, x, DELTA, (1, 1, 1)))  # noqa: E731
    return run, int(np.prod(x.shape[1:])), _values(True)


def forward_delta(n):
    import jax
    import jax.numpy as jnp

    import pkmlib as pk

    axes = [np.linspace(-0.3, 0.9, n)] * 3
    q = jnp.stack([jnp.asarray(g) for g in np.meshgrid(*axes, indexing="ij")])
    mech = delta_mechanism()

    def run():
        return jax.block_until_ready(pk.forward_positions(mech, q, DELTA, DELTA_BOX, max_modes=4))

    def values(out):
        return {"count": np.asarray(out.count, dtype=np.float64), "x": np.asarray(out.x)}

    return run, int(np.prod(q.shape[1:])), values


CASES = {
    **{
        f"inverse_{paper}_{kind}": _inverse_case(paper, kind == "numerical")
        for paper in ("p1", "p2", "p4", "p3a")
        for kind in ("numerical", "closed")
    },
    "inverse_delta_numerical": inverse_delta,
    "forward_delta_all_modes": forward_delta,
}

FULL = {"planar": [201, 1001], "p3a": [21, 101], "delta": [21, 101], "forward": [6, 16]}
SMOKE = {"planar": [21], "p3a": [5], "delta": [5], "forward": [2]}


def plan(sizes):
    out = []
    for paper in ("p1", "p2", "p4", "p3a"):
        s = sizes["p3a" if paper == "p3a" else "planar"]
        out += [(f"inverse_{paper}_numerical", s, 3), (f"inverse_{paper}_closed", s, 3)]
    return out + [("inverse_delta_numerical", sizes["delta"], 3), ("forward_delta_all_modes", sizes["forward"], 2)]


def extra(cases):
    ratios = {}
    for paper in ("p1", "p2", "p4", "p3a"):
        num, closed = rate(cases, f"inverse_{paper}_numerical"), rate(cases, f"inverse_{paper}_closed")
        ratios[f"inverse_{paper}"] = {
            "numerical_poses_per_s": num,
            "closed_form_poses_per_s": closed,
            "closed_over_numerical": closed / num,
            "numerical_poses_per_cpu_s": rate(cases, f"inverse_{paper}_numerical", key="items_per_cpu_s"),
        }
    ratios["inverse_delta"] = {
        "numerical_poses_per_s": rate(cases, "inverse_delta_numerical"),
        "numerical_poses_per_cpu_s": rate(cases, "inverse_delta_numerical", key="items_per_cpu_s"),
    }
    per_pose = 1.0 / rate(cases, "forward_delta_all_modes")
    ratios["forward_delta_all_modes"] = {
        "s_per_pose": per_pose,
        "cuik_s_per_pose": CUIK_S_PER_DELTA_POSE,
        "cuik_over_pkmlib": CUIK_S_PER_DELTA_POSE / per_pose,
        "starts_per_pose": 64,
    }
    return {"summary": ratios}


if __name__ == "__main__":
    smoke = "--smoke" in sys.argv
    if smoke:
        sys.argv.remove("--smoke")
        _bench.RESULTS = _bench.ROOT / "build" / "benchmark_smoke"  # never overwrite the committed results
    reference = {f"inverse_{p}_numerical": f"inverse_{p}_closed" for p in ("p1", "p2", "p4", "p3a")}
    main(
        "mechanisms",
        CASES,
        plan(SMOKE if smoke else FULL),
        reference,
        extra=extra,
        rtol=1e-9,
        notes={
            "closed form": "each module's own mechanism.inverse (jitted), in the same run",
            "numerical": "pkmlib.inverse_positions: 3-sample fit of each chain's F_i, one Newton step on the true "
            "F_i, bracketing fallback where the fit does not reproduce F_i (none of these grids)",
            "forward": "pkmlib.forward_positions: 4^3 Newton starts in the box, de-duplicated, ordered by "
            "sign det(A) then x; items are inputs with all their modes (2 for this Delta)",
            "CUIK": "about 30 s per Delta pose, all modes (issue 19)",
            "load": "2 cores shared with other jobs: compare ratios in one run, not times",
        },
    )
