"""Benchmark the numerical positions of any mechanism (``pkmlib.inverse_positions``,
``pkmlib.forward_positions``; issue 19 item 7), each against the closed form in the same run.

- ``inverse_<paper>_numerical`` / ``inverse_<paper>_closed``: batched inverse position of P1
  (4-PRR, the notebook's pose: phi = 20 deg, s = 0.14 m, an N x N grid of x_D 0.2..1.2 m, y_D
  -0.25..0.25 m), P2 (3-RRR, phi = 0, x_P -0.15..0.55, y_P -0.15..0.5 m), P4 (five-bar,
  x_C -250..350, z_C 2.5..350 mm) and P3's mechanism A (the poses of the FK branch m = +1 over
  an N x N x N grid of the actuator box); the closed forms are the modules' own
  ``mechanism.inverse`` (P1 after eq (1), P2 and P4 atan2 + acos, P3 eq (14)), jitted; the
  numerical one never uses them. Items: poses.
- The values compared (each numerical case against its closed form, at its first size): P3 A's
  poses are the forward image of a grid over the actuator box, so whole planes of them lie on the
  workspace boundary of the branch within rounding: the box's faces, and x3 = x_C (a double root
  of f3, dF_3/dx3 = 0) wherever q3 = (q1 + q2) / 2 on the grid. There either answer is right (in or
  out is the last bit; x3 is fixed only to ~sqrt(eps) l4 = 5e-6 mm, by the closed form's sqrt of a
  rounding-size radicand as by the fit), so each side's value is NaN on the poses its own solution
  puts there (``on_boundary``, the criteria of tests/test_positions.py), and x_i is compared as
  x_i - x_i,min (``_p3a_prepare``).
- The numerical P1, P2 and P4 are the descriptions ``data/mechanisms/p1_gripper_4prr.yaml``,
  ``p2_three_rrr.yaml``, ``p4_five_bar.yaml`` loaded by ``pk.load_mechanism`` (their
  default_branch); P3's A is its module's ``mechanism_a``.
- ``eq6_p1_handwritten`` / ``eq6_p1_loaded`` / ``eq6_p1_loaded_eager``: P1 eq (6) over the P1
  grid, each one jitted function of the poses and parameters: the hand-written map
  ``gripper_4prr.max_carriage_velocity`` (closed-form inverse); the loaded description's
  ``pk.inverse_positions`` (numerical, traced inside the same jit: each chain's F_i is found to be
  quadratic in its carriage and solved by the quadratic formula) with the rows of J^-1 by JVPs and
  ``pk.max_actuator_velocity``; and the same with ``pk.inverse_positions`` called outside the jit.
  Timed interleaved (``_bench.interleaved``: the three back to back, round after round, until the
  ratio of their best times is stable; the load of every round kept) at each planar size; target:
  the loaded map within 1.5x of the hand-written one's time.
- ``inverse_delta_numerical``: the Delta of ``data/mechanisms/delta.yaml`` (loaded, branch
  ``DELTA_BRANCH = (-1, -1, -1)``, elbows out, the yaml's default_branch) over an N x N x N grid of
  platform positions.
- ``forward_delta_all_modes``: every assembly mode (``forward_positions``, 4^3 Newton starts in a
  box, de-duplicated and ordered) at each input of an N x N x N grid of actuator angles; items:
  inputs (poses with all their modes), set beside CUIK's ~30 s per Delta pose (all modes).

Run: ``python benchmarks/mechanisms.py`` (writes ``benchmarks/results/mechanisms.json``) or
``python benchmarks/mechanisms.py --smoke`` (each case once at its smallest size, in one process,
values checked against the closed forms; nothing written).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _bench
from _bench import main, rate, wrapped_angles

#: At least this many interleaved rounds (best time of each case so far): on the shared 2-core
#: machine the first rounds' ratios move by 2x with the load; the ratio of the best times settles later.
_bench.INTERLEAVED_MIN_ROUNDS = 20
CUIK_S_PER_DELTA_POSE = 30.0  # issue 19: the CUIK suite, all modes of one Delta pose
ROOT = Path(__file__).resolve().parents[1]
DELTA_BOX = ((-0.6, -0.6, -0.8), (0.6, 0.6, 0.8))


def delta_mechanism():
    """The Delta of ``data/mechanisms/delta.yaml`` (three RSS chains with parallelogram forearms),
    loaded by ``pk.load_mechanism``: no equation written here."""
    import pkmlib as pk

    return pk.load_mechanism(ROOT / "data" / "mechanisms" / "delta.yaml")


#: The Delta's branch, chosen explicitly: the yaml's default_branch, elbows out (dF_i/dtheta_i < 0).
DELTA_BRANCH = (-1, -1, -1)


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


#: The planar paper mechanisms solved numerically from their descriptions (their default_branch
#: is the closed form's PAPER_BRANCH / default_branch); P3's A by its module's mechanism_a.
LOADED = {"p1": "p1_gripper_4prr.yaml", "p2": "p2_three_rrr.yaml", "p4": "p4_five_bar.yaml"}


def _eq6_case(kind):
    """P1 eq (6) (maximum carriage velocity, speeds (1, 1, 1)) over the N x N grid, as one jitted
    function of the poses and the parameters: ``"handwritten"``, the map
    ``gripper_4prr.max_carriage_velocity`` (closed-form inverse); ``"loaded"``, the loaded
    description's ``pk.inverse_positions`` (numerical, traced inside the jit), then
    ``pk.inverse_jacobian_rows`` and ``pk.max_actuator_velocity``, nothing of the module but its
    output groups; ``"loaded_eager"``, the same with ``pk.inverse_positions`` called outside the
    jit (its own compiled calls) and only the rows and eq (6) jitted."""

    def make(n):
        import jax

        import pkmlib as pk
        from pkmlib.mechanisms import gripper_4prr as m

        _, p, x, *_ = _papers("p1", n)
        x = jax.block_until_ready(x)
        speeds = (1.0, 1.0, 1.0)
        if kind == "handwritten":
            f = jax.jit(lambda x_, p_: m.max_carriage_velocity(x_, p_, speeds))
            run = lambda: jax.block_until_ready(f(x, p))  # noqa: E731
        else:
            mech = pk.load_mechanism(ROOT / "data" / "mechanisms" / LOADED["p1"])

            def eq6(x_, q_, p_):
                return pk.max_actuator_velocity(pk.inverse_jacobian_rows(mech, x_, q_, p_), m.OUTPUT_GROUPS, speeds)

            if kind == "loaded":
                f = jax.jit(lambda x_, p_: eq6(x_, pk.inverse_positions(mech, x_, p_), p_))
                run = lambda: jax.block_until_ready(f(x, mech.params))  # noqa: E731
            else:
                rows = jax.jit(eq6)
                run = lambda: jax.block_until_ready(rows(x, pk.inverse_positions(mech, x, mech.params), mech.params))  # noqa: E731
        return run, int(np.prod(x.shape[1:])), lambda out: {"v": np.asarray(out)}

    return make


#: Within rounding of a branch's workspace boundary (as ``at_limit`` and ``double_root`` of
#: tests/test_positions.py): an actuator this fraction of its travel from a limit, or a chain whose
#: |dF_i/dq_i| is this fraction of its largest value on the grid (a double root).
LIMIT_RTOL, DOUBLE_ROOT_RTOL = 1e-9, 1e-6


def on_boundary(mech, x, q, p):
    """Poses whose solution ``q`` (``(n, *grid)`` at the poses ``x``) lies on its branch's workspace
    boundary within rounding: an actuator at a limit (inside or outside is decided by the last bit)
    or a double root of a chain (the type-1 boundary, ``dF_i/dq_i = 0``, where ``q_i`` is fixed
    only to ~sqrt(eps) of its scale by any method: the radicand of a closed form's sqrt is rounding
    there). False where ``q`` is NaN. P3 A's grid (the forward image of a grid over the actuator
    box) has whole planes of such poses: the box's faces, and ``x3 = x_C`` wherever
    ``q3 = (q1 + q2) / 2`` on the grid."""
    import jax.numpy as jnp

    import pkmlib as pk

    q = np.asarray(q, dtype=np.float64)
    shape = (q.shape[0],) + (1,) * (q.ndim - 1)
    lo, hi = (np.asarray(v, dtype=np.float64).reshape(shape) for v in mech.actuator_limits(p))
    B = np.asarray(pk.B_matrix(mech, jnp.asarray(x), jnp.asarray(q), p))
    d = np.abs(np.stack([B[i, i] for i in range(q.shape[0])]))
    with np.errstate(invalid="ignore"):
        edge = (np.abs(q - lo) <= LIMIT_RTOL * (hi - lo)) | (np.abs(q - hi) <= LIMIT_RTOL * (hi - lo))
        double = d <= DOUBLE_ROOT_RTOL * np.nanmax(d.reshape(d.shape[0], -1), axis=1).reshape(shape)
    return np.any(edge | double, axis=0)


def _values(periodic, prepare=None):
    """The saved values: ``q`` (``prepare(q)`` when given) with one NaN convention (the whole pose)."""

    def values(out):
        q = np.array(out) if prepare is None else prepare(np.array(out))
        q[:, np.any(np.isnan(q), axis=0)] = np.nan  # one NaN convention: the whole pose
        return {"q": wrapped_angles(q) if periodic else q}

    return values


def _p3a_prepare(mech, x, p):
    """P3 A's saved values: NaN on the poses that its own solution puts on the boundary
    (:func:`on_boundary`: there either answer is right, so neither side is compared), and each
    carriage's position from the start of its travel, ``q_i - q_i,min`` (mm), so that a relative
    difference is relative to a distance along the rail: x3 = 0 is an interior point of its rail,
    where the comparison's relative measure (floored at 1e-6 of the largest value, 3e-4 mm) would
    read the ~1e-12 mm rounding of a pose near x3 = x_C as 1e-8."""
    q_min = np.asarray(mech.actuator_limits(p)[0], dtype=np.float64)

    def prepare(q):
        boundary = on_boundary(mech, x, q, p)
        q = q - q_min.reshape((-1,) + (1,) * (q.ndim - 1))
        q[:, boundary] = np.nan
        return q

    return prepare


def _inverse_case(paper, numerical):
    def make(n):
        import jax

        import pkmlib as pk

        mech, p, x, periodic, b_num, b_closed = _papers(paper, n)
        x = jax.block_until_ready(x)
        if numerical and paper in LOADED:
            loaded = pk.load_mechanism(ROOT / "data" / "mechanisms" / LOADED[paper])
            run = lambda: jax.block_until_ready(pk.inverse_positions(loaded, x, loaded.params))  # noqa: E731
        elif numerical:
            run = lambda: jax.block_until_ready(pk.inverse_positions(mech, x, p, b_num))  # noqa: E731
        else:
            f = jax.jit(lambda x_, p_: mech.inverse(x_, p_, b_closed))
            run = lambda: jax.block_until_ready(f(x, p))  # noqa: E731
        # P3 A's poses lie on its box's faces and on x3 = x_C by construction (on_boundary)
        return run, int(np.prod(x.shape[1:])), _values(periodic, _p3a_prepare(mech, x, p) if paper == "p3a" else None)

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
    run = lambda: jax.block_until_ready(pk.inverse_positions(mech, x, mech.params, DELTA_BRANCH))  # noqa: E731
    return run, int(np.prod(x.shape[1:])), _values(True)


def forward_delta(n):
    import jax
    import jax.numpy as jnp

    import pkmlib as pk

    axes = [np.linspace(-0.3, 0.9, n)] * 3
    q = jnp.stack([jnp.asarray(g) for g in np.meshgrid(*axes, indexing="ij")])
    mech = delta_mechanism()

    def run():
        return jax.block_until_ready(pk.forward_positions(mech, q, mech.params, DELTA_BOX, max_modes=4))

    def values(out):
        return {"count": np.asarray(out.count, dtype=np.float64), "x": np.asarray(out.x)}

    return run, int(np.prod(q.shape[1:])), values


CASES = {
    **{
        f"inverse_{paper}_{kind}": _inverse_case(paper, kind == "numerical")
        for paper in ("p1", "p2", "p4", "p3a")
        for kind in ("numerical", "closed")
    },
    **{f"eq6_p1_{kind}": _eq6_case(kind) for kind in ("handwritten", "loaded", "loaded_eager")},
    "inverse_delta_numerical": inverse_delta,
    "forward_delta_all_modes": forward_delta,
}

FULL = {"planar": [201, 1001], "p3a": [21, 101], "delta": [21, 101], "forward": [6, 16]}
SMOKE = {"planar": [21], "p3a": [5], "delta": [5], "forward": [2]}


#: The eq (6) cases, interleaved in that order: the hand-written map is the baseline.
EQ6_KINDS = ("handwritten", "loaded", "loaded_eager")


def interleave(sizes):
    """``_bench.interleaved`` sets: the three eq (6) maps back to back in one process at each
    planar size, round after round until their time ratios are stable."""
    return [(f"eq6_p1_{n}x{n}", [f"eq6_p1_{kind}" for kind in EQ6_KINDS], n) for n in sizes["planar"]]


def plan(sizes):
    out = []
    for paper in ("p1", "p2", "p4", "p3a"):
        s = sizes["p3a" if paper == "p3a" else "planar"]
        out += [(f"inverse_{paper}_numerical", s, 3), (f"inverse_{paper}_closed", s, 3)]
    # eq (6) here at the smallest size only (values, first call, memory); its timing is interleaved
    out += [(f"eq6_p1_{kind}", sizes["planar"][:1], 3) for kind in EQ6_KINDS]
    return out + [("inverse_delta_numerical", sizes["delta"], 3), ("forward_delta_all_modes", sizes["forward"], 2)]


def extra(cases, inter):
    ratios = {}
    for paper in ("p1", "p2", "p4", "p3a"):
        num, closed = rate(cases, f"inverse_{paper}_numerical"), rate(cases, f"inverse_{paper}_closed")
        ratios[f"inverse_{paper}"] = {
            "numerical_poses_per_s": num,
            "closed_form_poses_per_s": closed,
            "closed_over_numerical": closed / num,
            "numerical_poses_per_cpu_s": rate(cases, f"inverse_{paper}_numerical", key="items_per_cpu_s"),
        }
    for label, r in inter.items():
        over, over_cpu = r["eq6_p1_handwritten_over"], {}
        cpu = r["items_per_cpu_s"]
        over_cpu = {k: cpu["eq6_p1_handwritten"] / cpu[k] for k in over}
        ratios[label] = {
            "loaded_time_over_handwritten": over["eq6_p1_loaded"],
            "loaded_time_over_handwritten_cpu": over_cpu["eq6_p1_loaded"],
            "loaded_eager_time_over_handwritten": over["eq6_p1_loaded_eager"],
            "loaded_eager_time_over_handwritten_cpu": over_cpu["eq6_p1_loaded_eager"],
            "points_per_s": r["items_per_s"],
            "points_per_cpu_s": cpu,
            "target": 1.5,
            "target_met (interleaved, wall and cpu)": max(over["eq6_p1_loaded"], over_cpu["eq6_p1_loaded"]) <= 1.5,
            "rounds": r["rounds"],
            "stable": r["stable"],
            "load_1min_range": r["load_1min_range"],
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
    # --first-size: every case at its first (smaller) full size only, when the shared machine
    # leaves no time for the largest grids (the results' notes say so)
    first_size = "--first-size" in sys.argv
    if first_size:
        sys.argv.remove("--first-size")
    # --smoke stays on the command line: _bench.main runs every case once, in this process, at the
    # SMOKE sizes, as every benchmark's smoke run does, and writes nothing
    reference = {f"inverse_{p}_numerical": f"inverse_{p}_closed" for p in ("p1", "p2", "p4", "p3a")}
    reference["eq6_p1_loaded"] = reference["eq6_p1_loaded_eager"] = "eq6_p1_handwritten"
    sizes = SMOKE if smoke else {k: v[:1] for k, v in FULL.items()} if first_size else FULL
    main(
        "mechanisms",
        CASES,
        plan(sizes),
        reference,
        extra=extra,
        interleave=interleave(sizes),
        rtol=1e-9,
        notes={
            "closed form": "each module's own mechanism.inverse (jitted), in the same run",
            "numerical": "pkmlib.inverse_positions: a chain whose F_i is, by its operations (the jaxpr), a "
            "polynomial of degree <= 2 in its actuator (P1's carriages) is solved by the quadratic formula on its "
            "Taylor coefficients at the middle of the stroke (no check, no fallback, no Newton step); the others "
            "(P2, P4, the Delta: revolute; P3 A: through a square root) by a 3-sample fit of F_i, one Newton step "
            "on the true F_i, bracketing fallback where the fit does not reproduce F_i (none of these grids)",
            "forward": "pkmlib.forward_positions: 4^3 Newton starts in the box, de-duplicated, ordered by "
            "sign det(A) then x; items are inputs with all their modes (2 for this Delta)",
            "CUIK": "about 30 s per Delta pose, all modes (issue 19)",
            "p3a agreement": "compared off the poses on the workspace boundary within rounding (on_boundary: an "
            "actuator at a box face, or x3 = x_C, a double root), each side NaN where its own solution is there, "
            "x_i from the start of its travel; including those poses, 21^3 gave max_rel_diff 2.4e-3 (7e-7 mm at "
            "x3 ~ 0 near x3 = x_C, against the measure's 3e-4 mm floor) and 1.9 % NaN mismatch, all of it there",
            "targets": "1e6 poses/s planar, 2e5 Delta (issue 19): summary inverse_* numerical_poses_per_s and "
            "_per_cpu_s at the largest size (the eager pk.inverse_positions, one call per grid)",
            "eq6": "summary eq6_p1_<N>x<N>: interleaved ratios of the best times (wall and CPU) of the loaded maps "
            "to the hand-written one. The loaded map, jitted whole, is one XLA loop over the poses: "
            "pk.inverse_positions applies the limits row by row and stacks its rows last, so the quadratic roots "
            "fuse with the rows of J^-1 and eq (6), every value the chains share (sin and cos of phi) computed once "
            "per pose. The hand-written map's closed form (within_limits on the stacked q) stores q, each chain's "
            "root in a loop of its own, the limits in another: it is slower than the loaded map for that reason "
            "alone (a hand-written map with its limits row by row measured ~1.5x faster than the loaded one, "
            "not part of this benchmark). The eager variant adds its own compiled calls and the transfer of q; "
            "at 201 x 201 the fixed cost per call dominates it",
            "load": "2 cores shared with other jobs: compare ratios in one run, not times; the per-CPU-second "
            "rates (time.process_time) move less with the load than the wall-time ones",
            "sizes": "first full size of each case only (--first-size)" if first_size else "full sizes",
        },
    )
