"""Benchmark P2: all maps of ``three_rrr.pose_criteria`` (theta, det A, det B, eq (4)/(7) max joint
velocity, eq (6)/(8) max torque, and eq (9)'s Delta q and Delta e) over the notebook's grid
(x_P -0.15..0.55 m, y_P -0.15..0.5 m, phi = 0), pkmlib against a numba per-point loop with the
hand-differentiated constraint equations and the same 3x3 cofactor inverse, in the same run.

Sizes: the grid step is 2.5 mm / size (size 1: the notebook's 281 x 261 grid; 4: 1121 x 1041).
Run: ``python benchmarks/p2.py`` (or ``make benchmark``).
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numba
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _bench import main, ops_per_point, rate, wrapped_angles  # noqa: E402

V, FORCE, PHI = 0.1, 10.0, 0.0
STEP = 0.0025
KEYS = ("q", "det_A", "det_B", "max_joint_velocity", "max_actuator_torque", "delta_q", "delta_e")


def _params():
    import pkmlib as pk
    from pkmlib.mechanisms import three_rrr as t

    return t.ThreeRRRParams.from_dict(pk.load_params("p2")["mechanism"])


def _grid(k):
    import pkmlib as pk

    return pk.Grid.from_ranges(x_P=(-0.15, 0.55, STEP / k), y_P=(-0.15, 0.5, STEP / k))


def maps(pts, p, phi):
    from pkmlib.mechanisms import three_rrr as t

    return t.pose_criteria(t.pose(pts[0], pts[1], phi), p, V=V, force=FORCE)


def _pkmlib_case(batched):
    def make(k):
        import pkmlib as pk

        grid = _grid(k)
        args = (_params(), PHI)
        run = lambda: pk.sweep(maps, grid, args=args, batched=batched, progress=False)  # noqa: E731
        return run, grid.size, _as_compared

    return make


def _as_compared(values):
    """The maps as the methods are compared: the joint angles wrapped (``_bench.wrapped_angles``).
    Where a chain's d_i points along -x (a grid row of the smallest size does), the y-difference
    is a rounding residual of either sign and atan2 gives pi or -pi: the same joint position, 2 pi
    apart (88 points with the unit tests' compile settings, -O0 and XLA's older CPU emitters,
    tests/conftest.py)."""
    return {k: wrapped_angles(v) if k == "q" else np.asarray(v) for k, v in values.items()}


@numba.njit(parallel=True, cache=True)
def kernel(starts, steps, counts, phi, l1, l2, r_p, base, gamma, br, V, force, out):
    n1 = counts[1]
    n = counts[0] * n1
    block = 1024
    for blk in numba.prange((n + block - 1) // block):
        Ji = np.empty((3, 3))
        A = np.empty((3, 3))
        th = np.empty(3)
        b = np.empty(3)
        for idx in range(blk * block, min(n, (blk + 1) * block)):
            i, j = idx // n1, idx % n1
            x, y = starts[0] + i * steps[0], starts[1] + j * steps[1]
            ok = True
            for k in range(3):
                a = gamma[k] + phi
                ca, sa = math.cos(a), math.sin(a)
                cx, cy = x + r_p * ca, y + r_p * sa
                dx, dy = cx - base[k, 0], cy - base[k, 1]
                rho = math.sqrt(dx * dx + dy * dy)
                c = (rho * rho + l1 * l1 - l2 * l2) / (2.0 * l1 * rho)
                if not abs(c) <= 1.0:  # this chain cannot reach: its angle is NaN, the maps too
                    ok = False
                    th[k] = math.nan
                    continue
                th[k] = math.atan2(dy, dx) + br[k] * math.acos(c)
                ct, st = math.cos(th[k]), math.sin(th[k])
                ex, ey = cx - (base[k, 0] + l1 * ct), cy - (base[k, 1] + l1 * st)
                # F = |C - B|^2 - l2^2: dF/dx_P, dF/dy_P, dF/dphi; dF/dtheta
                A[k, 0] = 2.0 * ex
                A[k, 1] = 2.0 * ey
                A[k, 2] = 2.0 * ex * (-r_p * sa) + 2.0 * ey * (r_p * ca)
                b[k] = 2.0 * ex * (l1 * st) - 2.0 * ey * (l1 * ct)
            if not ok:
                for t in range(out.shape[0]):
                    out[t, idx] = th[t] if t < 3 else math.nan
                continue
            for k in range(3):
                for m in range(3):
                    Ji[k, m] = -A[k, m] / b[k]
            det_A = (
                A[0, 0] * (A[1, 1] * A[2, 2] - A[1, 2] * A[2, 1])
                - A[0, 1] * (A[1, 0] * A[2, 2] - A[1, 2] * A[2, 0])
                + A[0, 2] * (A[1, 0] * A[2, 1] - A[1, 1] * A[2, 0])
            )
            c00 = Ji[1, 1] * Ji[2, 2] - Ji[1, 2] * Ji[2, 1]
            c01 = Ji[1, 2] * Ji[2, 0] - Ji[1, 0] * Ji[2, 2]
            c02 = Ji[1, 0] * Ji[2, 1] - Ji[1, 1] * Ji[2, 0]
            r = 1.0 / (Ji[0, 0] * c00 + Ji[0, 1] * c01 + Ji[0, 2] * c02)
            # first two rows of J = adj(J^-1) / det (the linear group only)
            J00, J01, J02 = (
                c00 * r,
                (Ji[0, 2] * Ji[2, 1] - Ji[0, 1] * Ji[2, 2]) * r,
                (Ji[0, 1] * Ji[1, 2] - Ji[0, 2] * Ji[1, 1]) * r,
            )
            J10, J11, J12 = (
                c01 * r,
                (Ji[0, 0] * Ji[2, 2] - Ji[0, 2] * Ji[2, 0]) * r,
                (Ji[0, 2] * Ji[1, 0] - Ji[0, 0] * Ji[1, 2]) * r,
            )
            qmax = (
                max(
                    math.sqrt(Ji[0, 0] ** 2 + Ji[0, 1] ** 2),
                    math.sqrt(Ji[1, 0] ** 2 + Ji[1, 1] ** 2),
                    math.sqrt(Ji[2, 0] ** 2 + Ji[2, 1] ** 2),
                )
                * V
            )
            emax = (
                max(
                    math.sqrt(J00 * J00 + J10 * J10), math.sqrt(J01 * J01 + J11 * J11), math.sqrt(J02 * J02 + J12 * J12)
                )
                * force
            )
            qx = max(abs(Ji[0, 0] * V), abs(Ji[1, 0] * V), abs(Ji[2, 0] * V))
            ex_ = max(abs(J00 * force), abs(J01 * force), abs(J02 * force))
            for k in range(3):
                out[k, idx] = th[k]
            out[3, idx] = det_A
            out[4, idx] = b[0] * b[1] * b[2]
            out[5, idx] = qmax
            out[6, idx] = emax
            out[7, idx] = qmax - qx
            out[8, idx] = emax - ex_


def _numba_case(k):
    from pkmlib.mechanisms import three_rrr as t

    p = _params()
    grid = _grid(k)
    kern = kernel
    args = (
        np.array(grid.starts),
        np.array(grid.steps),
        np.array(grid.shape, dtype=np.int64),
        PHI,
        p.l1,
        p.l2,
        p.r_p,
        np.array(p.base),
        np.asarray(t.GAMMA, dtype=np.float64),
        np.array(t.PAPER_BRANCH, float),
        V,
        FORCE,
    )

    def run():
        out = np.empty((9, grid.size))
        kern(*args, out)
        return out

    def values(out):
        o = out.reshape((9,) + grid.shape)
        return _as_compared({"q": np.moveaxis(o[:3], 0, -1), **{k_: o[3 + i] for i, k_ in enumerate(KEYS[1:])}})

    return run, grid.size, values


CASES = {"maps_pkmlib_batched": _pkmlib_case(True), "maps_pkmlib_vmap": _pkmlib_case(False), "maps_numba": _numba_case}
PLAN = [("maps_pkmlib_batched", [1, 4], 3), ("maps_pkmlib_vmap", [1, 4], 3), ("maps_numba", [1, 4], 3)]


#: Interleaved in one process until the ratio is stable (issue 22: within 2x of numba, >= 1e7 pts/s).
INTERLEAVE = [("maps_1121x1041", ["maps_numba", "maps_pkmlib_batched", "maps_pkmlib_vmap"], 4)]


#: Per point in :func:`kernel` as written: one loop; per chain atan2 and acos (theta_i), cos and
#: sin of theta_i (B_i) and of gamma_i + phi (C_i); the square roots (|d_i|, the row and column
#: norms of eq (4) and (6)) and the divisions (cos of the acos, J^-1 entry by entry, 1 / det).
NUMBA_OPS = {"fused_loops": 1, "atan2": 3, "acos": 3, "cosine": 6, "sine": 6, "sqrt": 9, "divide": 13}


def _pkmlib_ops():
    """Per point in pkmlib's compiled batched map (the function the batched case sweeps)."""
    import jax.numpy as jnp

    return ops_per_point(maps, jnp.zeros((2, 1000)), _params(), jnp.float64(PHI))


def _summary(cases, inter):
    r = {k: rate(cases, f"maps_{k}") for k in ("pkmlib_batched", "pkmlib_vmap", "numba")}
    best = max(r["pkmlib_batched"], r["pkmlib_vmap"])
    ri = inter["maps_1121x1041"]["items_per_s"]
    best_i = max(ri["maps_pkmlib_batched"], ri["maps_pkmlib_vmap"])
    return {
        "summary": {
            "all_maps_points_per_s": r,
            "numba_over_best_pkmlib_separate_processes": r["numba"] / best,
            "interleaved_points_per_s": ri,
            "interleaved_numba_over_best_pkmlib": ri["maps_numba"] / best_i,
            "target_within_2x_of_numba (interleaved, wall)": ri["maps_numba"] / best_i <= 2.0,
            "target_all_maps_1e7_points_per_s (interleaved)": best_i >= 1e7,
            "batched_over_vmap": r["pkmlib_batched"] / r["pkmlib_vmap"],
            "ops_per_point": {
                "pkmlib_batched (acos as atan2)": _pkmlib_ops(),
                "numba": NUMBA_OPS,
            },
        }
    }


if __name__ == "__main__":
    main(
        "p2",
        CASES,
        PLAN,
        reference={"maps_pkmlib_vmap": "maps_pkmlib_batched", "maps_numba": "maps_pkmlib_batched"},
        extra=_summary,
        rtol=1e-7,
        interleave=INTERLEAVE,
        notes={
            "sizes": "grid step = 2.5 mm / size over x_P -0.15..0.55, y_P -0.15..0.5 m",
            "transcendentals": "per point, numba's single loop evaluates 3 atan2, 3 acos, 3 sin + 3 cos of theta "
            "(the inverse position and B_i) and sin/cos of gamma_i + phi once each. Until 2026-12-07 pkmlib "
            "evaluated sin and cos of theta about nine times per point (28 each in the batched route): XLA's "
            "CPU fusion recomputes them inside every fused loop that reads them, and the maps ran at 2.3-3x "
            "numba's time. three_rrr.pose_criteria now takes each proximal link's direction (cos theta_i, "
            "sin theta_i) from the closed-form solve, algebraically, and JAX differentiates F_i through it "
            "(three_rrr._on_unit_circle): no sine or cosine per point (summary.ops_per_point), the atan2 and "
            "acos of q once each, and the maps run at numba's rate.",
            "lever_measured_not_taken": "XLA does not duplicate a division into its consumers. Writing each entry of "
            "J^-1 as -a_ij / b_ii (pkmlib divides once per row, a_ij * (-1 / b_ii)) keeps the nine entries in memory: "
            "19 sin and 19 cos per point instead of 28, and 1.65x the points per second on this map (1.45e6 against "
            "8.8e5, separate runs). Not adopted this round: it moves the last bits of every stored result "
            "(tests/test_regenerate.py compares them exactly), so it needs a full regeneration of data/results "
            "and the notebooks' outputs, and a P1 measurement, where the division once per row was chosen. "
            "Measured again interleaved (2026-12-03, this machine): it takes the batched route from 5.8x numba's "
            "time to 3.15x, but the vmap route, pkmlib's best, stays at 3.1x, so the best ratio does not move; "
            "on P1's eq (6) map two interleaved runs minutes apart gave numba over pkmlib 1.75-1.93x with the "
            "division per row and 2.66-2.89x per entry (numba itself 4.4e7 and 6.1e7 pts/s): not taken.",
        },
    )
