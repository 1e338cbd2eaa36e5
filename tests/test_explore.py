"""pkmlib.explore: the interactive figures' data files (committed under site/explore/data/).

Checks the encoding round trip, that the committed files hold the paper figures' numbers at the
paper's parameters (data/results/<paper>.json, written by the notebooks), that the values away
from them are pkmlib's own (recomputed here at a few poses by the mechanism module), that every
re-run command the page can show passes the notebook's own parameter checks, and the size budget.
"""

from __future__ import annotations

import functools
import itertools
import json
import shlex
from pathlib import Path

import nbformat
import numpy as np
import pytest

from pkmlib.tools import rerun
from pkmlib.explore import _store
from _site import wait_for_render

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "site" / "explore" / "data"
RESULTS = ROOT / "data" / "results"


def manifest(fig_id):
    call_id, m = _store.read_js(DATA / fig_id / "manifest.js")
    assert call_id == fig_id
    return m


def paper_key(m):
    return _store.key_of(c["values"].index(c["paper"]) for c in m["controls"] if not c.get("field"))


def figure_ids():
    return sorted(p.name for p in DATA.iterdir() if (p / "manifest.js").exists())


def test_encode_round_trip_keeps_nan_and_float32_values():
    a = np.array([[1.0, np.nan, -2.5e-7], [3.25, 1e30, 0.1]])
    text = _store.encode(a)
    assert np.array_equal(_store.decode(text, a.shape), a.astype(np.float32), equal_nan=True)
    assert _store.encode(a) == text  # deterministic bytes (gzip mtime 0)


def test_control_needs_the_papers_value_among_its_positions():
    with pytest.raises(ValueError, match="phi_deg.*paper's value 20"):
        _store.control("phi_deg", "φ", "deg", [10, 30], 20.0)


def test_every_manifest_lists_its_files_and_the_papers_position():
    for fig_id in figure_ids():
        m = manifest(fig_id)
        if m.get("kind") == "linear":
            assert m["keys"] == [] and len(m["G"]) == len(m["c"]) == len(m["outputs"]), fig_id
            continue
        controls = [c for c in m["controls"] if not c.get("field")]
        n = int(np.prod([len(c["values"]) for c in controls]))
        keys = {_store.key_of(ix) for ix in itertools.product(*(range(len(c["values"])) for c in controls))}
        assert set(m["keys"]) == keys and len(keys) == n, fig_id
        assert all((DATA / fig_id / f"{k}.js").exists() for k in keys), fig_id
        assert paper_key(m) in keys


def test_p1_paper_position_holds_the_static_figures_numbers():
    r = json.loads((RESULTS / "p1.json").read_text())
    m = manifest("p1_maps")
    chunk = _store.read_chunk(DATA / "p1_maps", paper_key(m))
    assert chunk["max_carriage_velocity"].shape == (m["y"]["n"], m["x"]["n"])
    assert np.isfinite(chunk["det_A"]).sum() == r["workspace_points"]
    for field, key in (
        ("max_carriage_velocity", "max_carriage_velocity_m_s"),
        ("max_carriage_force", "max_carriage_force_N"),
        ("max_gripper_force_no_load", "max_gripper_force_N_no_load"),
    ):
        v = chunk[field]
        assert np.nanmin(v) == np.float32(r[key]["min"]) and np.nanmax(v) == np.float32(r[key]["max"]), field
        assert np.nanmedian(v.astype(float)) == pytest.approx(r[key]["median"], rel=1e-6)
    six = _store.read_chunk(DATA / "p1_fig6b", paper_key(manifest("p1_fig6b")))
    g = six["max_gripper_force_with_load"]
    assert np.nanmax(g) == np.float32(r["max_gripper_force_N_with_load"]["max"])
    assert int(((six["inside"] > 0) & np.isnan(g)).sum()) == r["gripper_load_gap_points"]


def test_p1_away_from_the_paper_the_values_are_pkmlibs():
    import pkmlib as pk
    from pkmlib.mechanisms import gripper_4prr as gm

    p = gm.Gripper4PRRParams.from_dict(pk.load_params("p1")["mechanism"])
    m = manifest("p1_maps")
    phi_c, s_c = m["controls"][0], m["controls"][1]
    i, j = phi_c["values"].index(30.0), s_c["values"].index(0.1)
    chunk = _store.read_chunk(DATA / "p1_maps", _store.key_of((i, j)))
    ix, iy = np.array([40, 100, 150]), np.array([85, 100, 117])  # grid nodes (x_D, y_D) off the singular lines
    x = m["x"]["start"] + ix * m["x"]["step"]
    y = m["y"]["start"] + iy * m["y"]["step"]
    want = gm.pose_criteria(
        gm.pose(x, y, np.deg2rad(30.0), 0.1),
        p,
        speeds=(1.0, 1.0, 1.0),
        loads=(1.0, 1.0, 1.0),
        F_pr=100.0,
        external_load=(1.0, 1.0, 0.1),
    )
    for field in ("max_carriage_velocity", "max_carriage_force", "det_A", "max_gripper_force_no_load"):
        got = chunk[field][iy, ix]
        assert np.isfinite(want[field]).all()
        np.testing.assert_allclose(got, np.asarray(want[field]), rtol=2e-7, err_msg=field)


def _commands(m):
    """Every parameter set the page's re-run line can show (each control at each of its values,
    the others at the paper's), as ``-p name value`` words the page writes."""
    if "rerun" in m:  # the figure writes its commands itself: their PARAMS
        for command in m["rerun"].values():
            yield shlex.split(command.split("PARAMS=", 1)[1])[0].split()
        return
    if m.get("kind") == "linear":  # one list parameter: each slider at its ends and the paper's value
        for c in m["controls"]:
            for v in (c["min"], c["max"]):
                values = [other["paper"] if other is not c else v for other in m["controls"]]
                yield ["-p", m["param"], "[" + ", ".join(_js_number(x, c["digits"]) for x in values) + "]"]
        return
    controls = [c for c in m["controls"] if c.get("param")]
    for c in controls:
        for v in c["values"]:
            words = []
            for other in controls:
                value = v if other is c else other["paper"]
                # a string (a choice, or a list such as "[1, 1, -1]") is one shell word, as the page quotes it
                words += [
                    "-p",
                    other["param"],
                    value if isinstance(value, str) else _js_number(value, other.get("digits", 4)),
                ]
            yield words


def _js_number(v, digits):
    """What the page's fmtControl writes: Number(v.toPrecision(digits)).toString()."""
    x = float(f"{float(v):.{digits}g}")
    return str(int(x)) if x == int(x) and abs(x) < 1e21 else repr(x)


@pytest.mark.parametrize("fig_id", figure_ids())
def test_rerun_commands_pass_the_notebooks_checks(fig_id):
    m = manifest(fig_id)
    nb_path = rerun.resolve_notebook(m["notebook"], cwd=ROOT)
    nb = nbformat.read(nb_path, as_version=4)
    defaults = rerun.notebook_parameters(nb)
    for words in _commands(m):
        given = rerun.given_parameters(rerun.parse_arguments([m["notebook"], *words]))
        rerun.check_names(list(given), defaults, m["notebook"])
        assert rerun.precheck(nb, defaults | given), words
        for name, word in zip(words[1::3], words[2::3]):
            if name != "params_file" and word[0] in "-0123456789[":
                assert given[name] == pytest.approx(json.loads(word)), (name, word)


def _explore_cells():
    import importlib.util

    spec = importlib.util.spec_from_file_location("explore_cells", ROOT / "scripts" / "explore_cells.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_size_budget():
    """At most 10 MB of interactive data per page (the figures of the page's cell, for every page
    with one: the five papers and the design page), every figure on a page, 50 MB in all (the rest
    of the 150 MB is the site's)."""
    cells = _explore_cells().CELLS
    assert {"design_studies", "p1_gripper_4prr", "p5_decoupled_6dof_dynamics"} <= set(cells)
    per_page = {}
    for notebook, (_, _, ids) in cells.items():
        per_page[notebook] = sum(f.stat().st_size for i in ids for f in (DATA / i).iterdir())
        assert all(manifest(i)["notebook"] == notebook for i in ids), notebook
    assert sorted(i for _, _, ids in cells.values() for i in ids) == figure_ids()  # none left out
    assert max(per_page.values()) <= 10e6, per_page
    assert per_page["design_studies"] > 0
    assert sum(per_page.values()) <= 50e6, per_page


def test_rendered_site_within_150_mb():
    """The whole rendered site (_site/, when rendered) at most 150 MB, each page's data as committed."""
    wait_for_render()
    site = ROOT / "_site"
    if not (site / "index.html").exists():
        pytest.skip("_site/ is not rendered (bash scripts/render_site.sh)")
    total = sum(f.stat().st_size for f in site.rglob("*") if f.is_file())
    assert total <= 150e6, total
    for i in figure_ids():
        served = site / "site" / "explore" / "data" / i
        assert sorted(f.name for f in served.iterdir()) == sorted(f.name for f in (DATA / i).iterdir()), i


def test_p5_exported_map_is_forward_dynamics():
    """G P + c (what the page computes) against decoupled_6dof.forward_dynamics, at the paper's
    forces (the table's values, data/results/p5.json) and at others."""
    from pkmlib.explore import p5

    m = manifest("p5_accelerations")
    G, c = np.array(m["G"]), np.array(m["c"])
    r = json.loads((RESULTS / "p5.json").read_text())
    paper = [ctl["paper"] for ctl in m["controls"]]
    np.testing.assert_allclose(
        G @ paper + c, r["linear_acceleration_m_s2"] + r["angular_acceleration_rad_s2"], rtol=1e-12, atol=1e-12
    )
    rng = np.random.default_rng(0)
    for P in rng.uniform(-5, 5, size=(3, 6)):
        np.testing.assert_allclose(G @ P + c, p5.accelerations(P), rtol=1e-12, atol=1e-12)


def test_p4_paper_ratio_is_the_notebooks_map_and_the_rerun_file_has_the_lengths(tmp_path):
    from pkmlib.explore import p4

    r = json.loads((RESULTS / "p4.json").read_text())
    m = manifest("p4_maps")
    k = _store.read_chunk(DATA / "p4_maps", paper_key(m))["k_worst"]
    assert np.isfinite(k).sum() == r["workspace_points"]
    assert np.nanmin(k) == np.float32(r["k_worst_N_mm"]["min"]) and np.nanmax(k) == np.float32(r["k_worst_N_mm"]["max"])
    assert np.nanmean(k.astype(float)) == pytest.approx(r["k_worst_N_mm"]["mean"], rel=1e-6)
    assert p4.raw_params(1.0) == json.loads((ROOT / "data" / "params" / "p4.json").read_text())
    for ratio in p4.RATIOS:
        L = p4.lengths(ratio)
        assert L["l_A1B1_mm"] / L["l_B1C_mm"] == pytest.approx(ratio, rel=1e-6)
        assert L["l_A1B1_mm"] + L["l_B1C_mm"] == pytest.approx(350.0)
    # the command's Python one-liner writes the geometry of the ratio (run here, into tmp_path)
    import subprocess
    import sys

    cmd = p4.rerun_command(0.8)
    code = cmd.split('-c "', 1)[1].split('" && make', 1)[0]
    (tmp_path / "data" / "params").mkdir(parents=True)
    (tmp_path / "runs").mkdir()
    (tmp_path / "data" / "params" / "p4.json").write_text((ROOT / "data" / "params" / "p4.json").read_text())
    subprocess.run([sys.executable, "-c", code], cwd=tmp_path, check=True)
    written = json.loads((tmp_path / "runs" / "p4_lengths.json").read_text())
    assert written == p4.raw_params(0.8)


def test_p2_paper_position_is_the_notebooks_map():
    r = json.loads((RESULTS / "p2.json").read_text())
    m = manifest("p2_maps")
    chunk = _store.read_chunk(DATA / "p2_maps", paper_key(m))
    v = chunk["max_joint_velocity"]
    assert np.isfinite(v).sum() == r["workspace_points"]
    for field, key in (
        ("max_joint_velocity", "max_joint_velocity_rad_s"),
        ("max_actuator_torque", "max_actuator_torque_N_m"),
    ):
        a = chunk[field].astype(float)
        assert np.nanmin(a) == pytest.approx(r[key]["min"], rel=2**-23)
        assert np.nanmax(a) == pytest.approx(r[key]["max"], rel=2**-23)
        assert np.nanmedian(a) == pytest.approx(r[key]["median"], rel=1e-6)


def _p3_centres(name, label):
    """The platform-centre cloud of one branch, recomputed here by vmap over the actuator box
    (not by pk.sweep, as pkmlib.explore.p3 does)."""
    import jax
    import jax.numpy as jnp

    from pkmlib import load_params
    from pkmlib.mechanisms import two_t_one_r as m

    P = load_params("p3")
    if name == "A":
        p, fw, ce = m.ParamsA.from_dict(P["mechanism_A"]), m.forward_a, m.platform_centre_a
        br = {"m=+1": 1.0, "m=-1": -1.0}[label]
    else:
        p, fw, ce = m.ParamsB.from_dict(P["mechanism_B"]), m.forward_b, m.platform_centre_b
        br = jnp.array([float(label[2] + "1"), float(label[7] + "1")])
    axes = [
        np.arange(lo, hi + 1e-9, 5.0) for lo, hi in ((p.x1_min, p.x1_max), (p.x2_min, p.x2_max), (p.x3_min, p.x3_max))
    ]
    q = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    x = np.asarray(jax.jit(jax.vmap(lambda qq: fw(qq, p, br)))(q))
    c = np.asarray(jax.vmap(lambda xx: ce(xx, p))(jnp.asarray(x)))
    return c[np.all(np.isfinite(x), axis=1)].T


@pytest.mark.parametrize("name,axis", [("A", 2), ("A", 0), ("B", 1)])
def test_p3_sections_are_the_notebooks_slabs(name, axis):
    """At the static figure's level and at others: the per-cell counts are the slab's points of
    an independent sweep binned here, and their sum is the static figure's legend count."""
    from pkmlib.explore import p3

    fig = p3.fig_id(name, axis)
    m = manifest(fig)
    level = m["controls"][0]
    paper = next(s[3] for s in p3.SECTIONS if s[0] == name and s[2] == axis)
    assert level["paper"] == paper and level["param"] is None
    labels = [f["figure"].split("branch ")[1] for f in m["fields"]]
    clouds = {lb: _p3_centres(name, lb) for lb in labels}
    others = [i for i in range(3) if i != axis]
    n = len(level["values"])
    for index in sorted({level["values"].index(paper), 0, n // 3, (2 * n) // 3, n - 1}):
        lv = level["values"][index]
        chunk = _store.read_chunk(DATA / fig, _store.key_of((index,)))
        for j, lb in enumerate(labels):
            c = clouds[lb]
            sel = np.abs(c[axis] - lv) <= 2.5  # the notebook's section_figure slab
            got = chunk[f"branch{j}"]
            assert np.nansum(got) == sel.sum(), (lb, lv)
            ix = np.floor((c[others[0], sel] - m["x"]["start"]) / 5.0 + 0.5).astype(int)  # cells [k - 1/2, k + 1/2)
            iy = np.floor((c[others[1], sel] - m["y"]["start"]) / 5.0 + 0.5).astype(int)
            want = np.zeros((m["y"]["n"], m["x"]["n"]))
            np.add.at(want, (iy, ix), 1.0)
            want[want == 0] = np.nan
            np.testing.assert_array_equal(got, want, err_msg=f"{fig} {lb} level {lv}")
    if name == "A" and axis == 2:  # z = 300 mm: only on branch m = -1 (the notebook's finding)
        chunk = _store.read_chunk(DATA / fig, paper_key(m))
        assert np.isfinite(chunk["branch0"]).sum() == 0 and np.nansum(chunk["branch1"]) > 0


# ------------------------------------------------------------------ the design page: the P2 atlas


@functools.cache
def _design_study():
    from pkmlib.explore import design

    return design.study()


def design_atlas_value(a, r_p):
    """pk.design.atlas (the notebook's call: p2_atlas_indicator, reduce = sum times the cell area) at the
    one design (a, r_p), m^2."""
    import jax.numpy as jnp

    import pkmlib as pk
    from pkmlib.design import studies as ds
    from pkmlib.explore import design

    s = _design_study()
    poses = design.atlas_poses()
    one = pk.Grid(("a", "r_p_m"), (float(a), float(r_p)), (0.01, 0.0025), (1, 1))
    v = pk.design.atlas(
        functools.partial(ds.p2_atlas_indicator, base=s.info["base"], force=10.0),
        one,
        poses,
        args=(jnp.float64(0.36), jnp.float64(np.log(s.info["bound"]))),
        reduce=lambda x: jnp.sum(x) * poses.cell_area,
        progress=False,
    )
    return float(np.asarray(v).reshape(-1)[0])


def design_torque(a, r_p, xs, ys):
    """The largest actuator torque (N m) at the poses by three_rrr.pose_criteria (not a sweep)."""
    from pkmlib.design import studies as ds
    from pkmlib.mechanisms import three_rrr as t

    s = _design_study()
    p = ds.p2_params(np.array([a, 0.36, r_p]), s.info["base"])
    x = t.pose(np.asarray(xs, float), np.asarray(ys, float), 0.0)
    return np.asarray(t.pose_criteria(x, p, V=1.0, force=10.0, branch=t.PAPER_BRANCH)["max_actuator_torque"])


def test_design_picker_is_the_notebooks_atlas():
    """The picker's designs are atlas designs (the paper's among them); at each of four designs the
    indicator's area is pk.design.atlas's value there and the torque map is three_rrr's; at the paper's
    design the torque map is the before/after figure's (the 2.5 mm check grid) at every other node."""
    from pkmlib.explore import design

    m = manifest("design_p2_atlas")
    a_c, r_c = m["controls"][0], m["controls"][1]
    full_a, full_r = design.atlas_designs().axes
    assert set(a_c["values"]) <= set(full_a.tolist()) and set(r_c["values"]) <= set(full_r.tolist())
    assert (a_c["paper"], r_c["paper"]) == (0.5, 0.08) and len(a_c["values"]) * len(r_c["values"]) == 90
    poses = design.atlas_poses()
    ix, iy = np.array([80, 90, 100, 90, 84]), np.array([70, 72, 68, 80, 62])  # grid nodes (x_P, y_P)
    xs, ys = poses.axes[0][ix], poses.axes[1][iy]
    paper = paper_key(m)
    for key in (paper, "1_2", "6_8", "3_0"):
        i, j = (int(k) for k in key.split("_"))
        a, r = a_c["values"][i], r_c["values"][j]
        chunk = _store.read_chunk(DATA / "design_p2_atlas", key)
        sign = chunk["under_bound"]
        area = design_atlas_value(a, r)
        assert np.sum(sign > 0) * poses.cell_area == pytest.approx(area, rel=1e-12), key
        assert m["areas_cm2"][key] == pytest.approx(area * 1e4, rel=1e-12), key
        want = design_torque(a, r, xs, ys)
        assert np.isfinite(want).sum() >= 2, key
        np.testing.assert_allclose(chunk["torque"][iy, ix], want.astype(np.float32), rtol=3e-7, err_msg=key)
        # the indicator's workspace is the torque map's (both: every chain reaches), but for a few boundary poses
        assert np.sum(np.isfinite(sign) != np.isfinite(chunk["torque"])) <= 0.002 * sign.size, key
    static = _design_study().info["torque_paper"][::2, ::2].T  # the check grid at the atlas's poses
    got = _store.read_chunk(DATA / "design_p2_atlas", paper)["torque"]
    assert got.shape == static.shape
    np.testing.assert_array_equal(np.isfinite(got), np.isfinite(static))
    np.testing.assert_allclose(got, static.astype(np.float32), rtol=3e-7)
    t = m["fields"][0]
    chunk = _store.read_chunk(DATA / "design_p2_atlas", paper)
    # the notebook's range (stored by make report) against this process's map (the unit tests'
    # compile settings, conftest.py): the maximum, next to a singular pose, moves in its 7th digit
    assert chunk["_ranges"]["torque"] == pytest.approx(
        {
            "vmin": float(np.nanmin(_design_study().info["torque_paper"])),
            "vmax": float(np.nanmax(_design_study().info["torque_paper"])),
        },
        rel=1e-5,
    )
    # the bound, a torque the study computes, likewise stored by make report: its last bits
    assert t["scale"] == "log" and m["bound_N_m"] == pytest.approx(_design_study().info["bound"], rel=1e-12)


def test_design_local_command_prints_the_pages_map(tmp_path):
    """The page's command for one design, run (with this Python), prints that design's range and count."""
    import subprocess
    import sys

    m = manifest("design_p2_atlas")
    cmd = m["local"]["6_8"]
    code = cmd.split('-c "', 1)[1].rsplit('"', 1)[0]
    env = {**__import__("os").environ, "PYTHONPATH": str(ROOT), "JAX_PLATFORMS": "cpu"}
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, env=env, check=True, capture_output=True, text=True)
    lo, hi, n = out.stdout.split()
    v = _store.read_chunk(DATA / "design_p2_atlas", "6_8")["torque"]
    assert (np.float32(float(lo)), np.float32(float(hi)), int(n)) == (np.nanmin(v), np.nanmax(v), np.isfinite(v).sum())


def test_field_control_and_fields_manifest():
    from pkmlib.explore._store import colormap, field_control, fields_manifest

    fields = [{"name": "a", "figure": "Fig 1", "cmap": "viridis"}, {"name": "b", "figure": "Fig 2", "cmap": None}]
    c = field_control(fields, label="branch")
    assert c["values"] == ["Fig 1", "Fig 2"] and c["label"] == "branch" and c["field"] is True and c["param"] is None
    out = fields_manifest(fields, ["#000000", "#ffffff"])
    assert out[0]["colors"] == colormap("viridis") and "cmap" not in out[0]
    assert out[1]["colors"] == ["#000000", "#ffffff"]
    assert "colors" not in fields_manifest(fields)[1] and fields[0]["cmap"] == "viridis"  # the input is not changed
