"""Benchmark the design studies of ``notebooks/design_studies.ipynb`` (issue 13's targets): the
gradient method against SciPy's differential evolution (DE) on the same study, in the same run.

Per study (:mod:`pkmlib.design.studies`, the notebook's default parameters):

- the cost of one objective value, one value-and-gradient by forward mode and by reverse mode
  (best of 20 calls after compilation), so the cost ratio behind every timing is on record;
- the gradient method from the paper's design (``pk.design.maximise``, L-BFGS-B, for the two area
  studies with the derivative mode and tolerance the notebook uses, and again at SciPy's default
  tolerance; ``pk.design.maximise_min``, SLSQP on the epigraph form, for the max-min variant), run
  ``REPEATS`` times (it is deterministic): median seconds;
- DE (``pk.design.maximise_derivative_free``, SciPy defaults) with seeds ``SEEDS``: median seconds,
  evaluations and exact objective over the seeds; and DE with ``vectorized=True`` (one compiled
  ``vmap`` call per generation) with seeds ``VECTORIZED_SEEDS``;
- the ratio of median seconds (DE / gradient) and of exact objectives (gradient / DE median), and
  whether the target holds: at least the baseline's objective within 1 % in at least 10x fewer
  seconds;
- the P2 atlas (the notebook's: 1517 designs x 30951 poses): (design, pose) pairs per second,
  best of 3 after compilation (target 1e7 on 2 cores).

Compilation is outside every timing (each method's is recorded as its ``setup_seconds``). Writes
``benchmarks/results/design.json``. Run: ``python benchmarks/design.py`` (about 1 minute).
``--smoke`` (CI): each study once on coarse grids (the gradient method once, DE once with a small
population and few generations, the atlas on a coarse grid), the gradient optimum checked to
score at least the paper's design it starts from (on coarse grids it may stop short of DE's), nothing written,
no timing judged. Public API only.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from functools import partial
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _bench import RESULTS, machine  # noqa: E402

REPEATS = 5
SEEDS = range(5)
VECTORIZED_SEEDS = range(3)
NOTEBOOK_DERIVATIVES = {"p2_torque_area": "forward", "p4_effective_workspace": "reverse"}
NOTEBOOK_TOL = 1e-5  # the notebook's gradient_tol
SCIPY_DEFAULT_TOL = 1e7 * 2.220446049250313e-16  # L-BFGS-B's default ftol (factr 1e7 times the machine epsilon)


def derivative_costs(study) -> dict:
    """Seconds of one value, and of value-and-gradient by forward and by reverse mode (best of 20
    calls after compilation; :func:`pkmlib.design.studies.derivative_costs`)."""
    from pkmlib.design import studies as ds

    t = ds.derivative_costs(study.objective, study.design_paper, repeats=20)
    return {
        "value_ms": t["value"] * 1e3,
        "forward_value_and_gradient_ms": t["forward"] * 1e3,
        "reverse_value_and_gradient_ms": t["reverse"] * 1e3,
        "forward_over_value": t["forward"] / t["value"],
        "reverse_over_value": t["reverse"] / t["value"],
    }


def gradient_method(study, tol=NOTEBOOK_TOL):
    import pkmlib as pk

    if study.values is not None:
        return pk.design.maximise_min(study.values, study.design_paper, study.bounds, margins=study.margins)
    return pk.design.maximise(
        study.objective, study.design_paper, study.bounds, derivatives=NOTEBOOK_DERIVATIVES[study.key], tol=tol
    )


def run_study(study) -> dict:
    import pkmlib as pk

    out = {"design_names": list(study.design_names), "derivative_costs": derivative_costs(study)}
    runs = [gradient_method(study) for _ in range(REPEATS)]
    g = runs[0]
    out["gradient"] = {
        "method": "maximise_min (SLSQP, epigraph)" if study.values is not None else "maximise (L-BFGS-B)",
        "derivatives": g.derivatives,
        "evaluations": g.evaluations,
        "seconds": [r.seconds for r in runs],
        "median_seconds": statistics.median(r.seconds for r in runs),
        "setup_seconds": g.setup_seconds,
        "design": g.design.tolist(),
        "objective_exact": study.exact(g.design),
        "tol": None if study.values is not None else NOTEBOOK_TOL,
    }
    if study.values is None:  # L-BFGS-B at SciPy's default tolerance, for the record
        runs = [gradient_method(study, SCIPY_DEFAULT_TOL) for _ in range(REPEATS)]
        out["gradient_scipy_default_tol"] = {
            "tol": SCIPY_DEFAULT_TOL,
            "evaluations": runs[0].evaluations,
            "median_seconds": statistics.median(r.seconds for r in runs),
            "objective_exact": study.exact(runs[0].design),
        }
    for key, vectorized, seeds in (("baseline", False, SEEDS), ("baseline_vectorized", True, VECTORIZED_SEEDS)):
        de = [
            pk.design.maximise_derivative_free(study.baseline_objective, study.bounds, seed=s, vectorized=vectorized)
            for s in seeds
        ]
        exact = [study.exact(r.design) for r in de]
        out[key] = {
            "seeds": list(seeds),
            "evaluations": [r.evaluations for r in de],
            "seconds": [r.seconds for r in de],
            "objective_exact": exact,
            "median_seconds": statistics.median(r.seconds for r in de),
            "median_evaluations": statistics.median(r.evaluations for r in de),
            "median_objective_exact": statistics.median(exact),
            "setup_seconds": de[0].setup_seconds,
        }
    gr, base = out["gradient"], out["baseline"]
    out["seconds_ratio"] = base["median_seconds"] / gr["median_seconds"]
    if "gradient_scipy_default_tol" in out:
        out["seconds_ratio_scipy_default_tol"] = (
            base["median_seconds"] / out["gradient_scipy_default_tol"]["median_seconds"]
        )
    out["seconds_ratio_vs_vectorized"] = out["baseline_vectorized"]["median_seconds"] / gr["median_seconds"]
    out["evaluations_ratio"] = base["median_evaluations"] / gr["evaluations"]
    out["objective_ratio"] = gr["objective_exact"] / base["median_objective_exact"]
    out["objective_ratio_vs_best_seed"] = gr["objective_exact"] / max(base["objective_exact"])
    out["target_met"] = bool(out["seconds_ratio"] >= 10.0 and out["objective_ratio"] >= 0.99)
    return out


def p2_atlas(study, *, design_steps=(0.01, 0.0025), pose_step=0.005, repeats=3) -> dict:
    import jax.numpy as jnp
    import numpy as np

    import pkmlib as pk
    from pkmlib.design import studies as ds

    designs = pk.Grid.from_ranges(a=(0.3, 0.7, design_steps[0]), r_p_m=(0.03, 0.12, design_steps[1]))
    poses = pk.Grid.from_ranges(x_P=(-0.25, 0.65, pose_step), y_P=(-0.25, 0.6, pose_step))
    crit = partial(ds.p2_atlas_indicator, base=study.info["base"], force=study.info["force"])
    args = (jnp.float64(0.36), jnp.float64(np.log(study.info["bound"])))

    def run():
        return pk.design.atlas(
            crit, designs, poses, args=args, reduce=lambda v: jnp.sum(v) * poses.cell_area, progress=False
        )

    t = time.perf_counter()
    run()
    first = time.perf_counter() - t
    best = float("inf")
    for _ in range(repeats):
        t = time.perf_counter()
        run()
        best = min(best, time.perf_counter() - t)
    pairs = designs.size * poses.size
    return {
        "designs": designs.size,
        "poses": poses.size,
        "first_call_s": first,
        "best_s": best,
        "pairs_per_s": pairs / best,
        "target_met": pairs / best >= 1e7,
    }


def studies(*, smoke: bool = False) -> list:
    """The notebook's three studies at its default parameters (``smoke``: on coarse grids)."""
    import pkmlib as pk
    from pkmlib.design import studies as ds
    from pkmlib.mechanisms import five_bar as fb
    from pkmlib.mechanisms import three_rrr as p2

    P = p2.ThreeRRRParams.from_dict(pk.load_params("p2")["mechanism"])
    p4 = fb.FiveBarParams.from_dict(pk.load_params("p4"))
    if not smoke:
        return [ds.p2_torque_area_study(P), ds.p4_effective_workspace_study(p4), ds.p4_task_study(p4)]
    return [
        ds.p2_torque_area_study(P, step_m=0.04, check_step_m=0.02),
        ds.p4_effective_workspace_study(p4, step_mm=40.0, check_step_mm=20.0),
        ds.p4_task_study(p4, task_step_mm=50.0, check_step_mm=25.0),
    ]


def smoke() -> None:
    """Each study once on coarse grids, the atlas on a coarse grid; nothing written."""
    import numpy as np

    import pkmlib as pk

    t_start = time.perf_counter()
    for study in studies(smoke=True):
        costs = derivative_costs(study)
        g = gradient_method(study)
        de = pk.design.maximise_derivative_free(
            study.baseline_objective, study.bounds, seed=0, popsize=5, max_generations=5
        )
        ours, theirs = study.exact(g.design), study.exact(de.design)
        start = study.exact(study.design_paper)  # the gradient method starts from the paper's design
        ok = bool(np.isfinite(ours) and np.isfinite(theirs) and ours >= start * (1 - 1e-9))
        print(
            f"design smoke {study.key:24s}: gradient {g.evaluations} evals, exact {ours:.6g}; DE {de.evaluations} "
            f"evals, exact {theirs:.6g}; value+gradient / value fwd {costs['forward_over_value']:.1f}",
            flush=True,
        )
        if not ok:
            raise SystemExit(
                f"design smoke: {study.key}: the gradient optimum scores {ours}, the paper's design {start}"
            )
    a = p2_atlas(studies(smoke=True)[0], design_steps=(0.1, 0.03), pose_step=0.05, repeats=1)
    print(f"design smoke p2 atlas: {a['designs']} designs x {a['poses']} poses", flush=True)
    print(f"design smoke: 3 studies and the atlas ran ({time.perf_counter() - t_start:.0f} s)")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--smoke", action="store_true", help="each study once on coarse grids, nothing written")
    if ap.parse_args(argv).smoke:
        smoke()
        return
    t_start = time.perf_counter()
    studies_ = studies()
    results = {"studies": {}}
    for study in studies_:
        r = run_study(study)
        results["studies"][study.key] = r
        print(
            f"{study.key:24s} gradient {r['gradient']['evaluations']:4d} evals {r['gradient']['median_seconds']:.3f} s "
            f"(exact {r['gradient']['objective_exact']:.6g}); DE median {r['baseline']['median_evaluations']:.0f} evals "
            f"{r['baseline']['median_seconds']:.3f} s (exact {r['baseline']['median_objective_exact']:.6g}); "
            f"DE vectorized {r['baseline_vectorized']['median_seconds']:.3f} s; seconds ratio {r['seconds_ratio']:.1f}, "
            f"objective ratio {r['objective_ratio']:.4f}, target met: {r['target_met']}",
            flush=True,
        )
    results["p2_atlas"] = p2_atlas(studies_[0])
    print(f"P2 atlas: {results['p2_atlas']['pairs_per_s']:.3g} pairs/s", flush=True)
    results["machine"] = machine()
    results["benchmark_wall_s"] = time.perf_counter() - t_start
    RESULTS.mkdir(parents=True, exist_ok=True)
    out = RESULTS / "design.json"
    out.write_text(json.dumps(results, indent=2) + "\n")
    print(f"wrote benchmarks/results/design.json in {results['benchmark_wall_s']:.0f} s")


if __name__ == "__main__":
    main()
