"""Benchmark P1: the maximum-carriage-velocity map (eq (6)) and all seven maps of
``gripper_4prr.pose_criteria`` (q, det A, det B, eq (6), eq (8), eq (13) without and with load),
pkmlib against a numba per-point loop in the same run; and the same 2-million-point velocity map on
a (2, 1e6) and a (1e6, 2) grid (``sweep`` chunks both; issue 12 item 4).

- ``*_pkmlib_batched``: ``sweep(..., batched=True)``: J^-1 row by row from forward-mode JVPs,
  structure of arrays, closed-form 4x4 inverse and determinant (``pkmlib._small_matrices``);
- ``*_pkmlib_vmap``: ``sweep`` of the per-point function;
- ``*_numba``: hand-differentiated P1 eq (1), one point at a time in a ``numba.njit(parallel=True)``
  loop (both cores), with the same 4x4 cofactor formulas: the best hand-written alternative.

Sizes are points per axis of an N x N grid over the paper's range (x_D 0.2..1.2 m, y_D
-0.25..0.25 m, phi = 20 deg, s = 0.14 m). Run: ``python benchmarks/p1.py`` (or ``make benchmark``).
"""

from __future__ import annotations

import math
import os
import sys
from pathlib import Path

import numba
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _bench import main, ops_per_point, rate  # noqa: E402

PHI, S = float(np.deg2rad(20.0)), 0.14
SPEEDS = (1.0, 1.0, 1.0)
LOADS = (1.0, 1.0, 1.0)
F_PR = 100.0
EXTERNAL = (10.0, 5.0, 1.0)
X_RANGE, Y_RANGE = (0.2, 1.2), (-0.25, 0.25)
MAP_KEYS = (
    "q",
    "det_A",
    "det_B",
    "max_carriage_velocity",
    "max_carriage_force",
    "max_gripper_force_no_load",
    "max_gripper_force_with_load",
)


def _params():
    import pkmlib as pk
    from pkmlib.mechanisms import gripper_4prr as m

    return m.Gripper4PRRParams.from_dict(pk.load_params("p1")["mechanism"])


def _grid(n):
    import pkmlib as pk

    return pk.Grid(
        ("x_D", "y_D"),
        (X_RANGE[0], Y_RANGE[0]),
        ((X_RANGE[1] - X_RANGE[0]) / (n - 1), (Y_RANGE[1] - Y_RANGE[0]) / (n - 1)),
        (n, n),
    )


# ---------------------------------------------------------------- pkmlib (module-level functions)
def velocity(pts, p, phi, s):
    from pkmlib.mechanisms import gripper_4prr as m

    return m.max_carriage_velocity(m.pose(pts[0], pts[1], phi, s), p, SPEEDS)


def velocity_swapped(pts, p, phi, s):  # the (1e6, 2) grid has y_D first
    return velocity(pts[::-1], p, phi, s)


def maps7(pts, p, phi, s):
    from pkmlib.mechanisms import gripper_4prr as m

    return m.pose_criteria(
        m.pose(pts[0], pts[1], phi, s), p, speeds=SPEEDS, loads=LOADS, F_pr=F_PR, external_load=EXTERNAL
    )


def _pkmlib_case(fn, batched, grid_of=_grid, chunk_size="auto", transpose=False):
    def make(n):
        import pkmlib as pk

        grid = grid_of(n)
        args = (_params(), PHI, S)
        run = lambda: pk.sweep(fn, grid, args=args, batched=batched, progress=False, chunk_size=chunk_size)  # noqa: E731
        return run, grid.size, lambda out: out if isinstance(out, dict) else {"v": out.T if transpose else out}

    return make


# ---------------------------------------------------------------- numba per-point loops
@numba.njit(parallel=True, cache=True, error_model="numpy")
def velocity_nb(starts, steps, counts, phi, s, L, l_C2D, BR, lo, hi, v, out):
    """P1 eq (6) per point: rows of J^-1 from the hand-differentiated eq (1); NaN outside.
    Nested loops (no index division), no early exit, so the inner loop can be vectorised."""
    c, sn = math.cos(phi), math.sin(phi)
    for i in numba.prange(counts[0]):
        x = starts[0] + i * steps[0]
        for j in range(counts[1]):
            y = starts[1] + j * steps[1]
            best = 0.0
            ok = True
            for k in range(4):
                r = -s if k < 2 else l_C2D
                cx, cy = x + r * c, y + r * sn
                u = BR[k] * np.sqrt(L[k] * L[k] - cy * cy)  # NaN when the link cannot reach
                q = cx + u
                ok = ok and (q >= lo) and (q <= hi)  # False for NaN too
                # J^-1 row k = -(dF/dx)/(dF/dq), F = (q - C_x)^2 + C_y^2 - l^2, C = D + r e
                j1 = -cy / u
                j2 = -r * sn - cy * r * c / u
                j3 = (-c + cy * sn / u) if k < 2 else 0.0
                val = np.sqrt(1.0 + j1 * j1) * v[0] + abs(j2) * v[1] + abs(j3) * v[2]
                best = max(best, val)
            out[i * counts[1] + j] = best if ok else math.nan


@numba.njit(inline="always")
def inv4(a, b):
    s0 = a[0, 0] * a[1, 1] - a[1, 0] * a[0, 1]
    s1 = a[0, 0] * a[1, 2] - a[1, 0] * a[0, 2]
    s2 = a[0, 0] * a[1, 3] - a[1, 0] * a[0, 3]
    s3 = a[0, 1] * a[1, 2] - a[1, 1] * a[0, 2]
    s4 = a[0, 1] * a[1, 3] - a[1, 1] * a[0, 3]
    s5 = a[0, 2] * a[1, 3] - a[1, 2] * a[0, 3]
    c5 = a[2, 2] * a[3, 3] - a[3, 2] * a[2, 3]
    c4 = a[2, 1] * a[3, 3] - a[3, 1] * a[2, 3]
    c3 = a[2, 1] * a[3, 2] - a[3, 1] * a[2, 2]
    c2 = a[2, 0] * a[3, 3] - a[3, 0] * a[2, 3]
    c1 = a[2, 0] * a[3, 2] - a[3, 0] * a[2, 2]
    c0 = a[2, 0] * a[3, 1] - a[3, 0] * a[2, 1]
    det = s0 * c5 - s1 * c4 + s2 * c3 + s3 * c2 - s4 * c1 + s5 * c0
    r = 1.0 / det
    b[0, 0] = (a[1, 1] * c5 - a[1, 2] * c4 + a[1, 3] * c3) * r
    b[0, 1] = (-a[0, 1] * c5 + a[0, 2] * c4 - a[0, 3] * c3) * r
    b[0, 2] = (a[3, 1] * s5 - a[3, 2] * s4 + a[3, 3] * s3) * r
    b[0, 3] = (-a[2, 1] * s5 + a[2, 2] * s4 - a[2, 3] * s3) * r
    b[1, 0] = (-a[1, 0] * c5 + a[1, 2] * c2 - a[1, 3] * c1) * r
    b[1, 1] = (a[0, 0] * c5 - a[0, 2] * c2 + a[0, 3] * c1) * r
    b[1, 2] = (-a[3, 0] * s5 + a[3, 2] * s2 - a[3, 3] * s1) * r
    b[1, 3] = (a[2, 0] * s5 - a[2, 2] * s2 + a[2, 3] * s1) * r
    b[2, 0] = (a[1, 0] * c4 - a[1, 1] * c2 + a[1, 3] * c0) * r
    b[2, 1] = (-a[0, 0] * c4 + a[0, 1] * c2 - a[0, 3] * c0) * r
    b[2, 2] = (a[3, 0] * s4 - a[3, 1] * s2 + a[3, 3] * s0) * r
    b[2, 3] = (-a[2, 0] * s4 + a[2, 1] * s2 - a[2, 3] * s0) * r
    b[3, 0] = (-a[1, 0] * c3 + a[1, 1] * c1 - a[1, 2] * c0) * r
    b[3, 1] = (a[0, 0] * c3 - a[0, 1] * c1 + a[0, 2] * c0) * r
    b[3, 2] = (-a[3, 0] * s3 + a[3, 1] * s1 - a[3, 2] * s0) * r
    b[3, 3] = (a[2, 0] * s3 - a[2, 1] * s1 + a[2, 2] * s0) * r
    return det


@numba.njit(parallel=True, cache=True)
def maps7_nb(starts, steps, counts, phi, s, L, l_C2D, BR, lo, hi, v, loads, F_pr, ext, out):
    c, sn = math.cos(phi), math.sin(phi)
    n1 = counts[1]
    n = counts[0] * n1
    block = 1024
    for blk in numba.prange((n + block - 1) // block):
        A = np.empty((4, 4))
        Ji = np.empty((4, 4))
        J = np.empty((4, 4))
        Ad = np.empty((4, 4))
        q = np.empty(4)
        b = np.empty(4)
        for idx in range(blk * block, min(n, (blk + 1) * block)):
            i, j = idx // n1, idx % n1
            x, y = starts[0] + i * steps[0], starts[1] + j * steps[1]
            ok = True
            for k in range(4):
                r = -s if k < 2 else l_C2D
                cx, cy = x + r * c, y + r * sn
                rad = L[k] * L[k] - cy * cy
                if rad < 0.0:
                    ok = False
                    break
                u = BR[k] * math.sqrt(rad)
                q[k] = cx + u
                if q[k] < lo or q[k] > hi:
                    ok = False
                # dF/dx_j = -2u dC_x/dx_j + 2 C_y dC_y/dx_j; dF/dq = 2u
                A[k, 0] = -2.0 * u
                A[k, 1] = 2.0 * cy
                A[k, 2] = -2.0 * u * (-r * sn) + 2.0 * cy * r * c
                A[k, 3] = (-2.0 * u * (-c) + 2.0 * cy * (-sn)) if k < 2 else 0.0
                b[k] = 2.0 * u
            if not ok:
                for t in range(out.shape[0]):
                    out[t, idx] = math.nan
                continue
            for k in range(4):
                for jj in range(4):
                    Ji[k, jj] = -A[k, jj] / b[k]
            for k in range(4):
                for jj in range(4):
                    Ad[k, jj] = A[k, jj]
            det_A = inv4(Ad, J)  # det(A) (J overwritten below)
            inv4(Ji, J)
            vel, force = -1.0, -1.0
            f0, f1 = math.inf, math.inf
            for k in range(4):
                vel = max(
                    vel, math.sqrt(Ji[k, 0] ** 2 + Ji[k, 1] ** 2) * v[0] + abs(Ji[k, 2]) * v[1] + abs(Ji[k, 3]) * v[2]
                )
                # rows of J^T: J[:, k]
                force = max(
                    force,
                    math.sqrt(J[0, k] ** 2 + J[1, k] ** 2) * loads[0]
                    + abs(J[2, k]) * loads[1]
                    + abs(J[3, k]) * loads[2],
                )
                e_hat = abs(J[3, k])
                e_ext = -(J[0, k] * ext[0] + J[1, k] * ext[1] + J[2, k] * ext[2])
                f0 = min(f0, F_pr / e_hat)
                f1 = min(f1, (F_pr - abs(e_ext)) / e_hat)
            for k in range(4):
                out[k, idx] = q[k]
            out[4, idx] = det_A
            out[5, idx] = b[0] * b[1] * b[2] * b[3]
            out[6, idx] = vel
            out[7, idx] = force
            out[8, idx] = f0 if f0 >= 0.0 else math.nan
            out[9, idx] = f1 if f1 >= 0.0 else math.nan


def _numba_case(which):
    def make(n):
        p = _params()
        kern = velocity_nb if which == "velocity" else maps7_nb
        grid = _grid(n)
        starts, steps = np.array(grid.starts), np.array(grid.steps)
        counts = np.array(grid.shape, dtype=np.int64)
        L = np.array([p.l_B11C1, p.l_B12C1, p.l_B21C2, p.l_B22C2])
        BR = np.array([-1.0, 1.0, -1.0, 1.0])
        common = (starts, steps, counts, PHI, S, L, p.l_C2D, BR, p.x_A_min, p.x_A_max, np.array(SPEEDS))
        if which == "velocity":

            def run():
                out = np.empty(grid.size)
                kern(*common, out)
                return out.reshape(grid.shape)

            return run, grid.size, lambda out: {"v": out}

        def run():
            out = np.empty((10, grid.size))
            kern(*common, np.array(LOADS), F_PR, np.array(EXTERNAL), out)
            return out

        def values(out):
            o = out.reshape((10,) + grid.shape)
            return {
                "q": np.moveaxis(o[:4], 0, -1),
                "det_A": o[4],
                "det_B": o[5],
                "max_carriage_velocity": o[6],
                "max_carriage_force": o[7],
                "max_gripper_force_no_load": o[8],
                "max_gripper_force_with_load": o[9],
            }

        return run, grid.size, values

    return make


def _wide(n):
    import pkmlib as pk

    return pk.Grid(("x_D", "y_D"), (0.5, -0.2), (0.4, 0.4 / (n - 1)), (2, n))


def _tall(n):
    import pkmlib as pk

    return pk.Grid(("y_D", "x_D"), (-0.2, 0.5), (0.4 / (n - 1), 0.4), (n, 2))


CASES = {
    "velocity_pkmlib_batched": _pkmlib_case(velocity, True),
    "velocity_pkmlib_vmap": _pkmlib_case(velocity, False),
    "velocity_numba": _numba_case("velocity"),
    "maps7_pkmlib_batched": _pkmlib_case(maps7, True),
    "maps7_pkmlib_vmap": _pkmlib_case(maps7, False),
    "maps7_numba": _numba_case("maps7"),
    "velocity_grid_2_by_n": _pkmlib_case(velocity, True, _wide),
    "velocity_grid_n_by_2": _pkmlib_case(velocity_swapped, True, _tall, transpose=True),
}

SMALL, LARGE = 201, 2001
PLAN = [
    ("velocity_pkmlib_batched", [SMALL, LARGE], 5),
    ("velocity_pkmlib_vmap", [SMALL, LARGE], 5),
    ("velocity_numba", [SMALL, LARGE], 5),
    ("maps7_pkmlib_batched", [SMALL, 1001], 3),
    ("maps7_pkmlib_vmap", [SMALL, 1001], 3),
    ("maps7_numba", [SMALL, 1001], 3),
    ("velocity_grid_2_by_n", [1_000_000], 3),
    ("velocity_grid_n_by_2", [1_000_000], 3),
]


#: Interleaved in one process until the ratio is stable (``_bench.interleaved``): the issue-22
#: targets, every map within 2x of numba; the eq (6) map also with 512-bit vectors.
INTERLEAVE = [
    ("velocity_2001x2001", ["velocity_numba", "velocity_pkmlib_batched", "velocity_pkmlib_vmap"], LARGE),
    (
        "velocity_2001x2001_xla_cpu_prefer_vector_width_512",
        ["velocity_numba", "velocity_pkmlib_batched"],
        LARGE,
        {"XLA_FLAGS": (os.environ.get("XLA_FLAGS", "") + " --xla_cpu_prefer_vector_width=512").strip()},
    ),
    ("maps7_1001x1001", ["maps7_numba", "maps7_pkmlib_batched", "maps7_pkmlib_vmap"], 1001),
]


#: Per point in the numba kernels as written: one loop; the square roots (the four inverse
#: positions, then the row and column norms of eq (6) and (8)) and the divisions (velocity: the
#: ten J^-1 entries that divide by u; seven maps: J^-1 entry by entry, 1 / det in the two 4x4
#: inverses, eq (12) twice per actuator).
NUMBA_OPS = {
    "velocity": {"fused_loops": 1, "sqrt": 8, "divide": 10},
    "maps7": {"fused_loops": 1, "sqrt": 12, "divide": 26},
}


def _pkmlib_ops():
    """Per point in pkmlib's compiled batched maps (the functions the batched cases sweep)."""
    import jax.numpy as jnp

    pts = jnp.stack([jnp.linspace(0.35, 1.0, 1000), jnp.zeros(1000)])
    args = (_params(), jnp.float64(PHI), jnp.float64(S))
    return {name: ops_per_point(fn, pts, *args) for name, fn in (("velocity", velocity), ("maps7", maps7))}


def _summary(cases, inter):
    vel = {k: rate(cases, f"velocity_{k}") for k in ("pkmlib_batched", "pkmlib_vmap", "numba")}
    m7 = {k: rate(cases, f"maps7_{k}") for k in ("pkmlib_batched", "pkmlib_vmap", "numba")}
    best_vel = max(vel["pkmlib_batched"], vel["pkmlib_vmap"])
    best_m7 = max(m7["pkmlib_batched"], m7["pkmlib_vmap"])
    wide, tall = cases["velocity_grid_2_by_n"][0], cases["velocity_grid_n_by_2"][0]

    def numba_over_best(label):
        """numba's rate over the best pkmlib route's, interleaved (wall time): the 2x target."""
        r = inter[label]["items_per_s"]
        return r[inter[label]["cases"][0]] / max(v for k, v in r.items() if "pkmlib" in k)

    return {
        "summary": {
            "velocity_interleaved_numba_over_best_pkmlib": numba_over_best("velocity_2001x2001"),
            "velocity_interleaved_numba_over_best_pkmlib_vector_width_512": numba_over_best(
                "velocity_2001x2001_xla_cpu_prefer_vector_width_512"
            ),
            "target_velocity_within_2x_of_numba (interleaved, wall)": numba_over_best("velocity_2001x2001") <= 2.0,
            "seven_maps_interleaved_numba_over_best_pkmlib": numba_over_best("maps7_1001x1001"),
            "target_seven_maps_within_2x_of_numba (interleaved, wall)": numba_over_best("maps7_1001x1001") <= 2.0,
            "velocity_map_points_per_s": vel,
            "velocity_numba_over_best_pkmlib_separate_processes": vel["numba"] / best_vel,
            "seven_maps_points_per_s": m7,
            "seven_maps_numba_over_best_pkmlib": m7["numba"] / best_m7,
            "target_seven_maps_1e7_points_per_s": best_m7 >= 1e7,
            "batched_over_vmap": {
                "velocity": vel["pkmlib_batched"] / vel["pkmlib_vmap"],
                "seven_maps": m7["pkmlib_batched"] / m7["pkmlib_vmap"],
            },
            "ops_per_point": {"pkmlib_batched": _pkmlib_ops(), "numba": NUMBA_OPS},
            "grid_shape_2x1e6_vs_1e6x2": {
                "first_call_s": [wide["first_call_s"], tall["first_call_s"]],
                "points_per_s": [wide["items_per_s"], tall["items_per_s"]],
                "peak_rss_mib": [wide["peak_rss_mib"], tall["peak_rss_mib"]],
                "before_this_change (issue 12)": "42 s and 1165 MiB on (2, 1e6) against 4.1 s and 301 MiB on (1e6, 2)",
            },
        }
    }


if __name__ == "__main__":
    main(
        "p1",
        CASES,
        PLAN,
        reference={
            "velocity_pkmlib_vmap": "velocity_pkmlib_batched",
            "velocity_numba": "velocity_pkmlib_batched",
            "maps7_pkmlib_vmap": "maps7_pkmlib_batched",
            "maps7_numba": "maps7_pkmlib_batched",
            "velocity_grid_n_by_2": "velocity_grid_2_by_n",
        },
        extra=_summary,
        rtol=1e-8,
        interleave=INTERLEAVE,
        smoke_sizes={
            "velocity_grid_2_by_n": 1000,
            "velocity_grid_n_by_2": 1000,
            "velocity_pkmlib_batched": 51,
            "velocity_pkmlib_vmap": 51,
            "velocity_numba": 51,
            "maps7_pkmlib_batched": 51,
            "maps7_pkmlib_vmap": 51,
            "maps7_numba": 51,
        },
        notes={
            "sizes": "points per axis of an N x N grid (grid_* cases: N x 2 and 2 x N points)",
            "first_call_s": "includes JAX import of the model, tracing and XLA compilation (numba: its "
            "compilation, cached on disk after the first run)",
            "why_seven_maps_lag": "numba evaluates the seven maps in one loop over the points. XLA's CPU fusion "
            "makes a fused loop per map and per intermediate it keeps (summary.ops_per_point.fused_loops, read "
            "off the compiled HLO); each reads its inputs from memory and writes its output, and each recomputes "
            "the producers XLA does not judge expensive (the inverse positions' square roots: summary.ops_per_point "
            "sqrt). An optimization barrier does not stop it (XLA's CPU pipeline removes barriers before fusion) "
            "and this XLA has no multi-output fusion flag. Measured, not adopted: dividing each J^-1 entry "
            "(-a_ij / b_ii) instead of multiplying by -1 / b_ii leaves the seven maps as they are, and interleaved "
            "runs (2026-12-03) put the velocity map at 2.66-2.89x numba's time against 1.75-1.93x with the division "
            "per row (benchmarks/p2.py's notes); it also moves the last bits of every stored result.",
            "calls_and_copies": "2026-12-07, AMD EPYC with AVX2 (no AVX-512), 2 cores: sweep keeps up to "
            "pkmlib._sweep.FETCH_WINDOW_BYTES of compiled calls dispatched ahead of its host copies (one call "
            "ahead before; eq (6): 2.3x -> 1.9x numba's time in scratch runs), and chunk_size='auto' keeps "
            "temporaries under 16 MiB (4 MiB before): the seven maps ran at 3.9x numba's time with the 8192-point "
            "chunks the old budget chose, at 2.9x with 32768 (each compiled call costs more than its points: at "
            "8192 points XLA's loops ran on one core, 94 ns per point, at 32768 on both, 54 ns).",
        },
    )
