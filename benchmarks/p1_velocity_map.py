"""Benchmark: P1's maximum-carriage-velocity map (eq (6)) at the paper grid and at 2001 x 2001.

All methods run in one process on the same grid and formula:
- ``pkmlib``: ``sweep(..., batched=True)``, J^-1 row by row from forward-mode JVPs of the
  constraint equations (autodiff, no hand-written partials), structure of arrays;
- ``pkmlib_vmap``: ``sweep`` of the per-point function (``vmap``), for reference;
- ``numpy_vectorized``: hand-derived partials of P1 eq (1), whole-grid NumPy arrays;
- ``python_loop``: the same hand-derived formula, one point at a time in Python/NumPy (timed on
  the paper grid only: its rate does not depend on the grid size).
Compilation is excluded (each pkmlib sweep is run once before it is timed). Writes
``benchmarks/results/p1_velocity_map.json``. Run: ``make benchmark``.
"""

from __future__ import annotations

import json
import os
import platform
import time
from pathlib import Path

import jax
import numpy as np

import pkmlib as pk
from pkmlib.mechanisms import gripper_4prr as m

OUT = Path(__file__).resolve().parent / "results" / "p1_velocity_map.json"
PHI, S = np.deg2rad(20.0), 0.14
SPEEDS = (1.0, 1.0, 1.0)
GRIDS = {
    "paper_201x201": pk.Grid.from_ranges(x_D=(0.2, 1.2, 0.005), y_D=(-0.25, 0.25, 0.0025)),
    "fine_2001x2001": pk.Grid.from_ranges(x_D=(0.2, 1.2, 0.0005), y_D=(-0.25, 0.25, 0.00025)),
}
P = m.Gripper4PRRParams.from_dict(pk.load_params("p1")["mechanism"])


def _reset_peak():
    try:
        Path("/proc/self/clear_refs").write_text("5")  # Linux: reset VmHWM (peak resident memory)
    except OSError:
        pass


def _peak_mib() -> float:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) / 1024
    return float("nan")


def hand_rows(x_D, y_D, phi, s, p=P):
    """J^-1 rows from hand-differentiated P1 eq (1); works on scalars and on NumPy arrays."""
    c, sn = np.cos(phi), np.sin(phi)
    out = []
    for i, (l, r) in enumerate(((p.l_B11C1, -s), (p.l_B12C1, -s), (p.l_B21C2, p.l_C2D), (p.l_B22C2, p.l_C2D))):
        cx, cy = x_D + r * c, y_D + r * sn  # C = D + r e, e = (cos phi, sin phi)
        with np.errstate(invalid="ignore"):
            u = m.PAPER_BRANCH[i] * np.sqrt(l * l - cy * cy)  # x_A - C_x
        q = cx + u
        ok = (q >= p.x_A_min) & (q <= p.x_A_max)
        # dC/d(x_D, y_D, phi, s); only C1 = D - s e depends on s
        dcx = (1.0, 0.0, -r * sn, -c if i < 2 else 0.0)
        dcy = (0.0, 1.0, r * c, -sn if i < 2 else 0.0)
        # F = (x_A - C_x)^2 + C_y^2 - l^2: dF/dx = -2u dC_x/dx + 2 C_y dC_y/dx, dF/dx_A = 2u
        row = [-(-2 * u * a + 2 * cy * b) / (2 * u) for a, b in zip(dcx, dcy)]
        out.append((row, ok))
    return out


def velocity_numpy(x_D, y_D):
    rows = hand_rows(x_D, y_D, PHI, S)
    inside = np.logical_and.reduce([ok for _, ok in rows])
    v = np.max([np.hypot(r[0], r[1]) * SPEEDS[0] + np.abs(r[2]) * SPEEDS[1] + np.abs(r[3]) * SPEEDS[2]
                for r, _ in rows], axis=0)
    return np.where(inside, v, np.nan)


def velocity_loop(grid):
    out = np.empty(grid.shape)
    xs, ys = grid.axes
    for i, x in enumerate(xs):
        for j, y in enumerate(ys):
            out[i, j] = velocity_numpy(float(x), float(y))
    return out


def fast(points):
    return m.max_carriage_velocity(m.pose(points[0], points[1], PHI, S), P, SPEEDS)


def per_point(point):
    return m.max_carriage_velocity(m.pose(point[0], point[1], PHI, S), P, SPEEDS)


def timed(f, repeats):
    best = float("inf")
    for _ in range(repeats):
        t = time.perf_counter()
        out = f()
        best = min(best, time.perf_counter() - t)
    return best, out


def main():
    results = {"methods": {}, "agreement_max_abs_diff_m_s": {}}
    loop_rate = None
    for name, grid in GRIDS.items():
        res = {}
        X, Y = np.meshgrid(*grid.axes, indexing="ij")
        for method, run, repeats in (
            ("pkmlib", lambda: pk.sweep(fast, grid, batched=True, progress=False), 5),
            ("pkmlib_vmap", lambda: pk.sweep(per_point, grid, progress=False), 3),
            ("numpy_vectorized", lambda: velocity_numpy(X, Y), 3),
        ):
            if method.startswith("pkmlib"):
                run()  # compile
            _reset_peak()
            dt, values = timed(run, repeats)
            res[method] = {"seconds": dt, "points_per_s": grid.size / dt, "peak_rss_mib": _peak_mib()}
            res.setdefault("_values", {})[method] = values
        if loop_rate is None:
            _reset_peak()
            dt, loop_values = timed(lambda: velocity_loop(grid), 1)
            loop_rate = grid.size / dt
            res["python_loop"] = {"seconds": dt, "points_per_s": loop_rate, "peak_rss_mib": _peak_mib()}
            res["_values"]["python_loop"] = loop_values
        else:
            res["python_loop"] = {"seconds": grid.size / loop_rate, "points_per_s": loop_rate,
                                  "note": "rate measured on the paper grid"}
        ref = res["_values"]["pkmlib"]
        for method, values in res.pop("_values").items():
            np.testing.assert_array_equal(np.isnan(values), np.isnan(ref))
            results["agreement_max_abs_diff_m_s"][f"{name}/{method}"] = float(np.nanmax(np.abs(values - ref)))
        rate = res["pkmlib"]["points_per_s"]
        res["ratios"] = {f"pkmlib_over_{k}": rate / v["points_per_s"] for k, v in res.items() if k != "pkmlib"}
        res["points"] = grid.size
        results["methods"][name] = res
        print(f"{name}: " + ", ".join(f"{k} {v['points_per_s']:.3g} points/s" for k, v in res.items()
                                     if isinstance(v, dict) and "points_per_s" in v))
        print("   ratios: " + ", ".join(f"{k} {v:.1f}" for k, v in res["ratios"].items()))
    cpu = next((ln.split(":", 1)[1].strip() for ln in Path("/proc/cpuinfo").read_text().splitlines()
                if ln.startswith("model name")), platform.processor()) if Path("/proc/cpuinfo").exists() else platform.processor()
    results["machine"] = {"cpu": cpu, "cores": os.cpu_count(), "platform": platform.platform(),
                          "python": platform.python_version(), "jax": jax.__version__,
                          "numpy": np.__version__, "jax_devices": [str(d) for d in jax.devices()]}
    results["targets"] = {"pkmlib_points_per_s_4M_map": 3e7, "pkmlib_over_python_loop": 300}
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text(json.dumps(results, indent=2) + "\n")
    print(f"wrote benchmarks/results/{OUT.name}")


if __name__ == "__main__":
    main()
