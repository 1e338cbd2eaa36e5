"""The interactive figures (pkmlib/explore, site/explore/pk-explore.js) in headless Chromium.

Each control is driven as a reader drives it (arrow keys on a slider, a click on an option);
the test asserts the title, the numbers and the re-run command change, and that at >= 3 positions
per control the hover readout at grid poses equals pkmlib's own value there (computed here by
the mechanism module, not read from the data files) to the displayed precision; at the paper's
parameters the summary equals the static figure's numbers (data/results/<paper>.json, written by
the notebook); the page logs no console error of its own. Skips, saying why, without _site/
(bash scripts/render_site.sh), Chromium, chromedriver or Selenium.
"""

from __future__ import annotations

import functools
import json
import math
import re
import time
from pathlib import Path

import numpy as np
import pytest
from _browser import browser, site_url  # noqa: F401  (pytest fixtures: one Chromium, the site served)
from _site import SITE, wait_for_render

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def explore_url(site_url):  # noqa: F811
    """The served site, which must hold the interactive figures."""
    if not (SITE / "site" / "explore" / "pk-explore.js").exists():
        pytest.skip("_site/ is not rendered with the interactive figures (bash scripts/render_site.sh; needs Quarto)")
    return site_url


@pytest.fixture
def driver(browser):  # noqa: F811
    """The shared Chromium's WebDriver, its viewport 1280 x 1000 px."""
    browser.viewport(1280, 1000)
    return browser.driver


def own_errors(d) -> list:
    """Console errors of the page itself: failed requests to other hosts (the offline browser
    resolves none; the site's CDN scripts are issue 20's) and the missing favicon are not ours."""
    out = []
    for e in d.get_log("browser"):
        if e["level"] != "SEVERE":
            continue
        msg = e["message"]
        if e.get("source") == "network" and ("127.0.0.1" not in msg.split(" ")[0] or "favicon.ico" in msg):
            continue
        out.append(msg)
    return out


# ------------------------------------------------------------------ page helpers


def open_page(d, url):
    d.get(url)
    d.get_log("browser")  # (kept: errors are read after the page settled)


def figure(d, fig_id, timeout=30.0):
    """The figure's element, scrolled into view and loaded."""
    el = d.find_element("css selector", f'.pk-explore[data-src$="/{fig_id}"]')
    d.execute_script("arguments[0].scrollIntoView({block: 'center'})", el)
    wait_loaded(d, el, timeout)
    return el


def wait_loaded(d, el, timeout=30.0):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if d.execute_script("return arguments[0].dataset.loading === 'false' && !!arguments[0].pkFigure", el):
            return
        time.sleep(0.05)
    raise AssertionError(f"figure {el.get_attribute('data-src')} did not load in {timeout} s")


def text(el, cls):
    return el.find_element("css selector", "." + cls).text


#: The figure's state in one WebDriver round trip (each round trip costs about 40 ms): the text a
#: reader sees of the title, the summary, the re-run command and the banner (empty when hidden).
_STATE = """
const e = arguments[0], q = (c) => e.querySelector('.' + c), seen = (c) => q(c) ? q(c).innerText.trim() : '';
const b = q('pk-banner');
return {title: seen('pk-title'), stats: seen('pk-stats'), rerun: seen('pk-rerun-command'),
        banner: b.hidden ? '' : b.textContent, key: e.getAttribute('data-key')};
"""


def state(d, el):
    return d.execute_script(_STATE, el)


def move_slider(d, el, name, index):
    """Arrow keys on the slider until it is at ``index`` (a reader's keyboard), sent at once."""
    from selenium.webdriver.common.keys import Keys

    s = el.find_element("css selector", f'input[name="{name}"]')
    now = int(s.get_attribute("value"))
    if now != index:
        s.send_keys((Keys.ARROW_RIGHT if index > now else Keys.ARROW_LEFT) * abs(index - now))
    assert int(s.get_attribute("value")) == index
    wait_loaded(d, el)


def choose(d, el, name, label):
    """A click on the option ``label`` of the select ``name`` (what Selenium's Select does, in
    two round trips instead of about six)."""
    option = d.execute_script(
        "return Array.from(arguments[0].querySelectorAll('select[name=\"' + arguments[1] + '\"] option'))"
        ".find(o => o.textContent.trim() === arguments[2]) || null",
        el,
        name,
        label,
    )
    assert option is not None, (name, label)
    option.click()
    wait_loaded(d, el)


#: Scrolls the figure's canvas into view and returns the viewport pixel of the grid node nearest
#: (x, y), or null where it is not in the plotted range: one round trip.
_NODE_PIXEL = """
const c = arguments[0].querySelector('canvas');
c.scrollIntoView({block: 'center'});
const r = c.getBoundingClientRect(), p = arguments[0].pkFigure.pixelFor(arguments[1], arguments[2]);
return p && [r.left + p[0], r.top + p[1]];
"""


def hover(d, el, x, y):
    """Move the mouse over the grid node nearest (x, y); returns (x, y, displayed value text)."""
    from selenium.webdriver.common.action_chains import ActionBuilder

    at = d.execute_script(_NODE_PIXEL, el, x, y)
    if at is None:
        return None  # not in the plotted y range at these parameters
    cx, cy = at
    action = ActionBuilder(d, duration=0)  # one mousemove at the node (Selenium's default glides for 250 ms)
    action.pointer_action.move_to_location(round(cx), round(cy))
    action.perform()
    readout = d.execute_script("return arguments[0].querySelector('.pk-readout').innerText.trim()", el)
    m = re.match(r"(\S+) = (-?[0-9.]+)\S* \S+, (\S+) = (-?[0-9.]+)\S* \S+: (.*)", readout)
    assert m, readout
    return float(m.group(2)), float(m.group(4)), m.group(5)


def displayed_number(value_text, symbol):
    m = re.search(re.escape(symbol) + r" = (-?[0-9.]+(?:e[-+]?[0-9]+)?)", value_text)
    return None if m is None else float(m.group(1))


def assert_shown(displayed, true, digits=4, scale=0.0):
    """``displayed`` (4 significant digits) is pkmlib's float64 ``true`` to that precision. A
    difference of two values of size ``scale`` that cancel (``|true| <= 1e-12 scale``) is zero to
    rounding: the page (data from ``make report``) and this process (the unit tests' compile
    settings, conftest.py) may hold different last bits of it, 0.0 against -2.8e-14."""
    if not np.isfinite(true):
        assert displayed is None, (displayed, true)
        return
    assert displayed is not None, true
    if abs(true) <= 1e-12 * scale:
        assert abs(displayed) <= 1e-12 * scale, (displayed, true, scale)
        return
    stored = float(np.float32(true))  # the data files hold float32
    assert displayed == float(f"{stored:.{digits}g}"), (displayed, true)
    e = math.floor(math.log10(abs(true))) if true else 0
    assert abs(displayed - true) <= 0.5 * 10 ** (e - digits + 1) * (1 + 1e-6) + abs(true) * 2**-23, (displayed, true)


def assert_stats_equal(stats_el, lo, hi, digits=4):
    got_lo, got_hi = float(stats_el.get_attribute("data-min")), float(stats_el.get_attribute("data-max"))
    for got, want in ((got_lo, lo), (got_hi, hi)):
        assert got == pytest.approx(want, rel=2**-23), (got, want)
    shown = re.findall(r"from (-?[0-9.e+-]+) to (-?[0-9.e+-]+)", stats_el.text)
    assert shown, stats_el.text
    assert float(shown[0][0]) == float(f"{np.float32(lo):.{digits}g}")
    assert float(shown[0][1]) == float(f"{np.float32(hi):.{digits}g}")


# ------------------------------------------------------------------ pkmlib's own values


@functools.cache
def _p1():
    import pkmlib as pk
    from pkmlib.mechanisms import gripper_4prr as m

    return m, m.Gripper4PRRParams.from_dict(pk.load_params("p1")["mechanism"])


def p1_values(x, y, phi_deg=20.0, s=0.14, load=(1.0, 1.0, 0.1)):
    """P1's maps at the poses (x_D, y_D) by gripper_4prr.pose_criteria with the notebook's other values."""
    m, p = _p1()
    x = m.pose(np.asarray(x, float), np.asarray(y, float), np.deg2rad(phi_deg), s)
    out = m.pose_criteria(
        x, p, speeds=(1.0, 1.0, 1.0), loads=(1.0, 1.0, 1.0), F_pr=100.0, external_load=load, branch=(-1, 1, -1, 1)
    )
    return {k: np.asarray(v) for k, v in out.items()}


P1_FIELDS = {
    "Fig 2": ("max_carriage_velocity", "|ẋ_A|max"),
    "Fig 4": ("max_carriage_force", "|F_A|max"),
    "Fig 5": ("det_A", "det(A)"),
    "Fig 6a": ("max_gripper_force_no_load", "|F_s|max"),
}
#: poses probed by hover (grid nodes; some outside the workspace at some parameters)
P1_POSES = [(0.7, 0.03), (0.5, -0.05), (0.9, 0.09), (0.45, 0.0475)]


def check_p1_hover(d, el, field, symbol, **params):
    values = p1_values([p[0] for p in P1_POSES], [p[1] for p in P1_POSES], **params)[field]
    finite = 0
    for (x, y), want in zip(P1_POSES, values):
        got = hover(d, el, x, y)
        if got is None:
            assert not np.isfinite(want), (x, y, want)  # only poses outside the workspace may be off the plot
            continue
        gx, gy, shown = got
        assert (gx, gy) == pytest.approx((x, y), abs=1e-9), (gx, gy, x, y)
        assert_shown(displayed_number(shown, symbol), float(want))
        finite += bool(np.isfinite(want))
    assert finite >= 1, params


# ------------------------------------------------------------------ tests

P1_PAGE = "notebooks/p1_gripper_4prr.html"


def test_p1_paper_parameters_show_the_static_figures(driver, explore_url):
    open_page(driver, explore_url + P1_PAGE)
    el = figure(driver, "p1_maps")
    results = json.loads((ROOT / "data" / "results" / "p1.json").read_text())
    assert el.get_attribute("data-paper") == "true"
    assert state(driver, el)["banner"] == ""
    assert state(driver, el)["rerun"] == 'make rerun NB=p1_gripper_4prr PARAMS="-p phi_deg 20 -p s_m 0.14"'
    stats = el.find_element("css selector", ".pk-stats")
    for label, key in (
        ("Fig 2", "max_carriage_velocity_m_s"),
        ("Fig 4", "max_carriage_force_N"),
        ("Fig 6a", "max_gripper_force_N_no_load"),
    ):
        choose(driver, el, "field", label)
        assert stats.get_attribute("data-count") == str(results["workspace_points"])
        assert_stats_equal(stats, results[key]["min"], results[key]["max"])
        assert label in text(el, "pk-title")
        field, symbol = P1_FIELDS[label]
        check_p1_hover(driver, el, field, symbol)
    el6 = figure(driver, "p1_fig6b")
    s6 = el6.find_element("css selector", ".pk-stats")
    want = results["max_gripper_force_N_with_load"]
    assert_stats_equal(s6, want["min"], want["max"])
    assert s6.get_attribute("data-gap") == str(results["gripper_load_gap_points"])
    assert own_errors(driver) == []


@pytest.mark.parametrize(
    "control, positions",
    [
        ("phi_deg", [(1, 5.0), (5, 25.0), (8, 40.0)]),
        ("s_m", [(0, 0.06), (5, 0.16), (8, 0.22)]),
    ],
)
def test_p1_controls_move_the_maps(driver, explore_url, control, positions):
    open_page(driver, explore_url + P1_PAGE)
    el = figure(driver, "p1_maps")
    before = state(driver, el)
    params = {"phi_deg": 20.0, "s": 0.14}
    for index, value in positions:
        move_slider(driver, el, control, index)
        now = state(driver, el)
        assert now["title"] != before["title"] and now["stats"] != before["stats"], (before, now)
        assert "Not the paper's parameters" in now["banner"]
        params["phi_deg" if control == "phi_deg" else "s"] = value
        want_cmd = f'make rerun NB=p1_gripper_4prr PARAMS="-p phi_deg {params["phi_deg"]:g} -p s_m {params["s"]:g}"'
        assert now["rerun"] == want_cmd
        for label in ("Fig 2", "Fig 5"):
            choose(driver, el, "field", label)
            check_p1_hover(driver, el, *P1_FIELDS[label], phi_deg=params["phi_deg"], s=params["s"])
        choose(driver, el, "field", "Fig 2")
        before = state(driver, el)
    assert own_errors(driver) == []


@pytest.mark.parametrize(
    "control, positions",
    [
        ("F_x_N", [(0, -2.0), (2, 0.0), (4, 2.0)]),
        ("F_y_N", [(0, -2.0), (2, 0.0), (4, 2.0)]),
        ("T_ext_N_m", [(0, -0.1), (1, 0.0), (2, 0.1)]),
    ],
)
def test_p1_fig6b_load_controls(driver, explore_url, control, positions):
    open_page(driver, explore_url + P1_PAGE)
    el = figure(driver, "p1_fig6b")
    load = {"F_x_N": 1.0, "F_y_N": 1.0, "T_ext_N_m": 0.1}
    before = state(driver, el)
    for index, value in positions:
        move_slider(driver, el, control, index)
        now = state(driver, el)
        assert now["title"] != before["title"] and now["rerun"] != before["rerun"]
        load[control] = value
        assert now["rerun"] == (
            'make rerun NB=p1_gripper_4prr PARAMS="' + " ".join(f"-p {k} {v:g}" for k, v in load.items()) + '"'
        )
        assert ("Not the paper's parameters" in now["banner"]) == (
            load != {"F_x_N": 1.0, "F_y_N": 1.0, "T_ext_N_m": 0.1}
        )
        want = p1_values([p[0] for p in P1_POSES], [p[1] for p in P1_POSES], load=tuple(load.values()))
        for (x, y), g, inside in zip(P1_POSES, want["max_gripper_force_with_load"], np.isfinite(want["det_A"])):
            _, _, shown = hover(driver, el, x, y)  # phi and s fixed: every probe is on the plot
            if inside and not np.isfinite(g):
                assert shown.startswith("gap"), shown
            else:
                assert_shown(displayed_number(shown, "|F_s|max"), float(g))
        before = now
    assert own_errors(driver) == []


def test_p1_works_from_file_url(driver):
    """From file:// (no server): the data files are <script> files, which Chromium loads there."""
    wait_for_render()
    page = SITE / P1_PAGE
    if not page.exists():
        pytest.skip("_site/ is not rendered")
    open_page(driver, page.as_uri())
    el = figure(driver, "p1_maps")
    results = json.loads((ROOT / "data" / "results" / "p1.json").read_text())
    want = results["max_carriage_velocity_m_s"]
    assert_stats_equal(el.find_element("css selector", ".pk-stats"), want["min"], want["max"])


# ------------------------------------------------------------------ P5: accelerations over the forces

P5_PAGE = "notebooks/p5_decoupled_6dof_dynamics.html"
P5_PAPER_FORCES = [1.0, 1.0, 2.0, 2.0, 3.0, 3.0]


def p5_shown(el):
    cells = el.find_elements("css selector", "table.pk-values td.pk-value")
    return [float(c.text) for c in cells]


def assert_fixed(shown, want, decimals=4):
    for got, w in zip(shown, want):
        assert got == pytest.approx(round(float(w), decimals), abs=0.5 * 10**-decimals + 1e-12), (shown, want)
        assert abs(got - w) <= 0.5 * 10**-decimals * (1 + 1e-9), (shown, want)


def test_p5_paper_forces_show_the_table(driver, explore_url):
    from pkmlib.explore import p5

    open_page(driver, explore_url + P5_PAGE)
    el = figure(driver, "p5_accelerations")
    r = json.loads((ROOT / "data" / "results" / "p5.json").read_text())
    assert el.get_attribute("data-paper") == "true" and state(driver, el)["banner"] == ""
    assert_fixed(p5_shown(el), r["linear_acceleration_m_s2"] + r["angular_acceleration_rad_s2"])
    assert_fixed(p5_shown(el), p5.accelerations(P5_PAPER_FORCES))
    assert state(driver, el)["rerun"] == (
        "make rerun NB=p5_decoupled_6dof_dynamics PARAMS='-p forces_N \"[1, 1, 2, 2, 3, 3]\"'"
    )
    assert own_errors(driver) == []


@pytest.mark.parametrize("motor", range(6))
def test_p5_each_force_moves_the_accelerations(driver, explore_url, motor):
    from selenium.webdriver.common.keys import Keys

    from pkmlib.explore import p5

    open_page(driver, explore_url + P5_PAGE)
    el = figure(driver, "p5_accelerations")
    slider = el.find_element("css selector", f'input[name="P_{motor + 1}"]')
    forces = list(P5_PAPER_FORCES)
    before = state(driver, el), p5_shown(el)
    for presses, key in ((3, Keys.ARROW_RIGHT), (10, Keys.ARROW_LEFT), (2, Keys.ARROW_LEFT)):
        slider.send_keys(key * presses)
        forces[motor] += 0.25 * presses * (1 if key == Keys.ARROW_RIGHT else -1)
        assert float(slider.get_attribute("value")) == pytest.approx(forces[motor])
        now = state(driver, el), p5_shown(el)
        assert now[0]["title"] != before[0]["title"] and now[1] != before[1]
        assert "Not the paper's parameters" in now[0]["banner"]
        assert_fixed(now[1], p5.accelerations(forces))  # pkmlib's forward_dynamics at these forces
        words = ", ".join(f"{v:g}" for v in forces)
        assert now[0]["rerun"] == f"make rerun NB=p5_decoupled_6dof_dynamics PARAMS='-p forces_N \"[{words}]\"'"
        before = now
    assert own_errors(driver) == []


# ------------------------------------------------------------------ P4: Figs 5-6 over the length ratio

P4_PAGE = "notebooks/p4_five_bar_stiffness.html"
P4_POSES = [(50.0, 150.0), (0.0, 200.0), (150.0, 100.0), (-100.0, 250.0)]


def p4_values(ratio):
    from pkmlib.explore import p4
    from pkmlib.mechanisms import five_bar as fb

    p = fb.FiveBarParams.from_dict(p4.raw_params(ratio))
    out = fb.pose_stiffness_jit(np.array(P4_POSES), p, 2000.0, (1, -1))
    ts = np.asarray(out["torque_per_force"])
    return {
        "k_worst": np.asarray(out["k_worst"]),
        "load_difference": ts[:, 0] - ts[:, 1],
        "load_difference_scale": np.max(np.abs(ts), axis=1),  # zero to rounding at the symmetric pose
    }


def check_p4_hover(d, el, ratio):
    want = p4_values(ratio)
    for label, field, symbol in (("Fig 6", "k_worst", "k"), ("Fig 5", "load_difference", "|j₁| − |j₂|")):
        choose(d, el, "field", label)
        scales = want.get(field + "_scale", np.zeros(len(P4_POSES)))
        for (x, y), w, scale in zip(P4_POSES, want[field], scales):
            got = hover(d, el, x, y)
            assert got is not None and got[:2] == pytest.approx((x, y)), got
            assert_shown(displayed_number(got[2], symbol), float(w), scale=float(scale))


def test_p4_paper_ratio_shows_fig6(driver, explore_url):
    open_page(driver, explore_url + P4_PAGE)
    el = figure(driver, "p4_maps")
    r = json.loads((ROOT / "data" / "results" / "p4.json").read_text())
    stats = el.find_element("css selector", ".pk-stats")
    assert stats.get_attribute("data-count") == str(r["workspace_points"])
    assert_stats_equal(stats, r["k_worst_N_mm"]["min"], r["k_worst_N_mm"]["max"])
    assert state(driver, el)["banner"] == ""
    check_p4_hover(driver, el, 1.0)
    assert own_errors(driver) == []


def test_p4_ratio_moves_the_maps(driver, explore_url):
    from pkmlib.explore import p4

    open_page(driver, explore_url + P4_PAGE)
    el = figure(driver, "p4_maps")
    before = state(driver, el)
    for index in (1, 3, 7):
        ratio = p4.RATIOS[index]
        choose(driver, el, "field", "Fig 6")
        move_slider(driver, el, "ratio", index)
        now = state(driver, el)
        assert now["title"] != before["title"] and now["stats"] != before["stats"]
        assert "Not the paper's parameters" in now["banner"]
        assert now["rerun"] == p4.rerun_command(ratio) and "params_file ../runs/p4_lengths.json" in now["rerun"]
        check_p4_hover(driver, el, ratio)
        before = state(driver, el)
    assert own_errors(driver) == []


# ------------------------------------------------------------------ P2: Figs 2-4 over the open choices

P2_PAGE = "notebooks/p2_three_rrr_singularity_proximity.html"
P2_POSES = [(0.2, 0.115), (0.15, 0.09), (0.25, 0.15), (0.3, 0.05)]  # grid nodes
P2_FIELDS = {
    "Fig 2a": ("max_joint_velocity", "max(q̇)"),
    "Fig 3a": ("max_actuator_torque", "max(e)"),
    "Fig 4a": ("delta_q", "Δq"),
    "Fig 4b": ("delta_e", "Δe"),
}


def p2_values(phi_deg=0.0, l3_is="circumradius", branch=(1, 1, 1)):
    from pkmlib.explore import p2
    from pkmlib.mechanisms import three_rrr as t

    xs, ys = (np.array(v) for v in zip(*P2_POSES))
    out = t.pose_criteria(t.pose(xs, ys, np.deg2rad(phi_deg)), p2.params(l3_is), V=0.1, force=10.0, branch=branch)
    return {k: np.asarray(v) for k, v in out.items()}


def check_p2_hover(d, el, labels=("Fig 2a", "Fig 3a", "Fig 4b"), **params):
    want = p2_values(**params)
    for label in labels:
        field, symbol = P2_FIELDS[label]
        choose(d, el, "field", label)
        finite = 0
        for (x, y), w in zip(P2_POSES, want[field]):
            got = hover(d, el, x, y)
            assert got is not None and got[:2] == pytest.approx((x, y)), got
            assert_shown(displayed_number(got[2], symbol), float(w), digits=4)
            finite += bool(np.isfinite(w))
        assert finite >= 2, params


def test_p2_paper_choices_show_the_static_figures(driver, explore_url):
    open_page(driver, explore_url + P2_PAGE)
    el = figure(driver, "p2_maps")
    r = json.loads((ROOT / "data" / "results" / "p2.json").read_text())
    stats = el.find_element("css selector", ".pk-stats")
    assert state(driver, el)["banner"] == ""
    for label, key in (("Fig 2a", "max_joint_velocity_rad_s"), ("Fig 3a", "max_actuator_torque_N_m")):
        choose(driver, el, "field", label)
        assert stats.get_attribute("data-count") == str(r["workspace_points"])
        assert_stats_equal(stats, r[key]["min"], r[key]["max"])
    choose(driver, el, "field", "Fig 4a")
    assert float(stats.get_attribute("data-min")) == pytest.approx(r["delta_q_min"], rel=1e-6)
    check_p2_hover(driver, el, labels=tuple(P2_FIELDS))
    assert own_errors(driver) == []


def test_p2_each_choice_moves_the_maps(driver, explore_url):
    open_page(driver, explore_url + P2_PAGE)
    el = figure(driver, "p2_maps")
    params = {"phi_deg": 0.0, "l3_is": "circumradius", "branch": (1, 1, 1)}
    steps = [
        ("phi_deg", 0, -15.0),
        ("phi_deg", 2, 15.0),
        ("phi_deg", 1, 0.0),
        ("l3_is", "side", "side"),
        ("l3_is", "circumradius", "circumradius"),
        ("l3_is", "side", "side"),
        ("branch", "[1, 1, -1]", (1, 1, -1)),
        ("branch", "[1, -1, 1]", (1, -1, 1)),
        ("branch", "[-1, 1, 1]", (-1, 1, 1)),
    ]
    before = state(driver, el)
    for name, position, value in steps:
        choose(driver, el, "field", "Fig 2a")
        if name == "phi_deg":
            move_slider(driver, el, name, position)
        else:
            choose(driver, el, name, position)
        params[name] = value
        now = state(driver, el)
        assert now["title"] != before["title"] and now["key"] != before["key"]
        paper = params == {"phi_deg": 0.0, "l3_is": "circumradius", "branch": (1, 1, 1)}
        assert ("Not the paper's parameters" in now["banner"]) == (not paper)
        words = f"-p phi_deg {params['phi_deg']:g} -p l3_is {params['l3_is']} -p branch '{list(params['branch'])}'"
        assert now["rerun"] == f'make rerun NB=p2_three_rrr_singularity_proximity PARAMS="{words}"'
        check_p2_hover(driver, el, labels=("Fig 2a", "Fig 3a"), **params)
        before = state(driver, el)
    assert own_errors(driver) == []


# ------------------------------------------------------------------ P3: the workspace sections over their level

P3_PAGE = "notebooks/p3_two_t_one_r.html"


@functools.cache
def p3_cloud(name, label):
    """pkmlib's platform-centre cloud of one branch (the forward solution and the centre of
    pkmlib.mechanisms.two_t_one_r, by vmap over the actuator box at the notebook's 5 mm step;
    not the data files' pk.sweep)."""
    import jax
    import jax.numpy as jnp

    from pkmlib import load_params
    from pkmlib.mechanisms import two_t_one_r as m

    P = load_params("p3")
    if name == "A":
        p, fw, ce, br = m.ParamsA.from_dict(P["mechanism_A"]), m.forward_a, m.platform_centre_a, float(label[2] + "1")
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


def p3_slab(name, label, axis, level, manifest):
    """Points of the slab |c[axis] - level| <= 2.5 mm (the notebook's section_figure) and their
    count per 5 mm cell [k - 1/2, k + 1/2) of the page's grid, keyed by the cell centre."""
    c = p3_cloud(name, label)
    sel = np.abs(c[axis] - level) <= 2.5
    others = [i for i in range(3) if i != axis]
    cells = {}
    for u, v in zip(c[others[0], sel], c[others[1], sel]):
        k = (
            manifest["x"]["start"] + 5.0 * math.floor((u - manifest["x"]["start"]) / 5.0 + 0.5),
            manifest["y"]["start"] + 5.0 * math.floor((v - manifest["y"]["start"]) / 5.0 + 0.5),
        )
        cells[k] = cells.get(k, 0) + 1
    return int(sel.sum()), cells


def check_p3(d, el, name, axis, level):
    """Each branch at ``level``: the total is the slab's points, and the hover readout at the
    three fullest cells and at an empty one is pkmlib's count there."""
    m = d.execute_script("return arguments[0].pkFigure.m", el)
    for f in m["fields"]:
        label = f["figure"].split("branch ")[1]
        choose(d, el, "field", f["figure"])
        total, cells = p3_slab(name, label, axis, level, m)
        stats = el.find_element("css selector", ".pk-stats")
        assert stats.get_attribute("data-total") == str(total), (f["figure"], level)
        assert f"{total} points in all" in stats.text, stats.text
        assert state(d, el)["title"].endswith(f"at section {'xyz'[axis]} = {level:g} mm"), state(d, el)["title"]
        full = sorted(cells, key=lambda k: (-cells[k], k))[:3]
        empty = [(m["x"]["start"], m["y"]["start"])] if (m["x"]["start"], m["y"]["start"]) not in cells else []
        for x, y in full + empty:
            got = hover(d, el, x, y)
            assert got is not None and got[:2] == pytest.approx((x, y)), got
            if (x, y) in cells:
                assert displayed_number(got[2], "n") == cells[(x, y)], (got, cells[(x, y)])
            else:
                assert got[2].startswith("no point of this branch in the slab"), got


@pytest.mark.parametrize("name,axis", [("A", 2), ("B", 1), ("A", 0)])
def test_p3_sections_over_their_level(driver, explore_url, name, axis):
    from pkmlib.explore import p3

    open_page(driver, explore_url + P3_PAGE)
    el = figure(driver, p3.fig_id(name, axis))
    c = driver.execute_script("return arguments[0].pkFigure.m.controls[0]", el)
    paper = c["paper"]
    assert state(driver, el)["banner"] == ""
    check_p3(driver, el, name, axis, paper)  # the static figure's legend counts
    paper_rerun = state(driver, el)["rerun"]
    assert paper_rerun == 'make rerun NB=p3_two_t_one_r PARAMS="-p params_file p3"'
    n = len(c["values"])
    before = state(driver, el)
    for index in sorted({1, n // 2, n - 2} - {c["values"].index(paper)}):
        move_slider(driver, el, "level", index)
        now = state(driver, el)
        assert now["title"] != before["title"] and now["key"] != before["key"]
        assert "Not the paper's parameters" in now["banner"] and f"(paper {paper:g} mm)" in now["banner"]
        assert now["rerun"] == paper_rerun  # the level is not a notebook parameter
        check_p3(driver, el, name, axis, c["values"][index])
        before = state(driver, el)
    assert own_errors(driver) == []


# ------------------------------------------------------------------ the design page: the P2 atlas's picker

DESIGN_PAGE = "notebooks/design_studies.html"
#: atlas poses (x_P, y_P), m, grid nodes of its 5 mm grid; some outside the workspace at some designs
DESIGN_POSES = [(0.15, 0.1), (0.2, 0.11), (0.25, 0.09), (0.2, 0.15), (0.17, 0.06)]
DESIGN_SIGN = "sign(bound − max(e))"


def check_design(d, el, a, r_p, static=None):
    """At the design (a, r_p): the indicator's area is pk.design.atlas's value there (the atlas figure's)
    and the hover readouts are three_rrr's torque and the atlas indicator at DESIGN_POSES; with
    ``static`` (the before/after figure's map on its check grid), the torque readouts are its values."""
    import test_explore as te

    title = state(d, el)["title"]
    assert f"a = l1 / (l1 + l2) = {a:g}, r_p = {r_p:g} m" in title, title
    xs, ys = (np.array(v) for v in zip(*DESIGN_POSES))
    torque = te.design_torque(a, r_p, xs, ys)
    choose(d, el, "field", "atlas indicator")
    stats = el.find_element("css selector", ".pk-stats")
    area = te.design_atlas_value(a, r_p) * 1e4  # cm^2
    assert float(stats.get_attribute("data-area")) == pytest.approx(area, rel=1e-9), (stats.text, area)
    assert f"area under the bound {round(area, 6):g} cm²" in stats.text, (stats.text, area)
    finite = 0
    for (x, y), w in zip(DESIGN_POSES, torque):
        got = hover(d, el, x, y)
        if got is None:
            assert not np.isfinite(w), (x, y, w)
            continue
        assert got[:2] == pytest.approx((x, y), abs=1e-9), got
        shown = displayed_number(got[2], DESIGN_SIGN)
        if np.isfinite(w):
            bound = float(d.execute_script("return arguments[0].pkFigure.m.bound_N_m", el))
            assert shown == (1.0 if w <= bound else -1.0), (x, y, w, bound, got)
            assert ("(under the bound)" if w <= bound else "(over the bound)") in got[2], got
    choose(d, el, "field", "torque map")
    for (x, y), w in zip(DESIGN_POSES, torque):
        got = hover(d, el, x, y)
        if got is None:
            continue
        assert_shown(displayed_number(got[2], "max(e)"), float(w))
        assert got[2].startswith("max(e) = ") and " N m" in got[2] or not np.isfinite(w), got
        if static is not None and np.isfinite(w):
            i, j = round((x + 0.25) / 0.0025), round((y + 0.25) / 0.0025)
            assert_shown(displayed_number(got[2], "max(e)"), float(static[i, j]))
        finite += bool(np.isfinite(w))
    assert finite >= 2, (a, r_p)


def test_design_picker_at_the_paper_design_shows_the_static_figures(driver, explore_url):
    import test_explore as te

    from pkmlib.explore import design

    open_page(driver, explore_url + DESIGN_PAGE)
    el = figure(driver, "design_p2_atlas")
    assert el.get_attribute("data-paper") == "true" and state(driver, el)["banner"] == ""
    assert state(driver, el)["rerun"] == design.local_command(0.5, 0.08)
    assert "No notebook parameter selects one design" in text(el, "pk-rerun")
    check_design(driver, el, 0.5, 0.08, static=te._design_study().info["torque_paper"])
    assert own_errors(driver) == []


@pytest.mark.parametrize("control, positions", [("a", (1, 6, 7)), ("r_p_m", (0, 2, 9))])
def test_design_picker_moves_the_map(driver, explore_url, control, positions):
    from pkmlib.explore import design

    open_page(driver, explore_url + DESIGN_PAGE)
    el = figure(driver, "design_p2_atlas")
    a_values, r_values = (v.tolist() for v in design.picker_values())
    at = {"a": 0.5, "r_p_m": 0.08}
    before = state(driver, el)
    for index in positions:
        move_slider(driver, el, control, index)
        at[control] = (a_values if control == "a" else r_values)[index]
        now = state(driver, el)
        assert now["title"] != before["title"] and now["key"] != before["key"] and now["rerun"] != before["rerun"]
        assert "Not the paper's parameters" in now["banner"], now["banner"]
        assert now["rerun"] == design.local_command(at["a"], at["r_p_m"])
        check_design(driver, el, at["a"], at["r_p_m"])
        before = state(driver, el)
    assert own_errors(driver) == []


@pytest.mark.parametrize("page, fig_id", [(DESIGN_PAGE, "design_p2_atlas"), (P2_PAGE, "p2_maps"), (P4_PAGE, "p4_maps")])
def test_figures_fit_a_phone(browser, explore_url, page, fig_id):  # noqa: F811
    """At 390 px: the page does not scroll sideways, the figure and its canvas fit the column, and
    the colour bar's label is inside the canvas, for each map of the figure."""
    browser.viewport(390, 900)
    d = browser.driver
    try:
        open_page(d, explore_url + page)
        el = figure(d, fig_id)
        assert d.execute_script("return document.documentElement.scrollWidth") <= 390
        m = d.execute_script("return arguments[0].pkFigure.m", el)
        for label in next(c for c in m["controls"] if c.get("field"))["values"]:
            choose(d, el, "field", label)
            box = d.execute_script(
                "const e = arguments[0], c = e.querySelector('canvas').getBoundingClientRect(), r = e.getBoundingClientRect();"
                "return {fig: [r.left, r.right], canvas: [c.left, c.right], label: e.pkFigure.view.colorbarLabel,"
                " scroll: e.scrollWidth - e.clientWidth}",
                el,
            )
            assert box["scroll"] <= 0 and box["canvas"][1] <= box["fig"][1] + 0.5, (label, box)
            lab = box["label"]
            assert 0 <= lab["left"] and lab["right"] <= lab["width"], (label, lab)
            assert 0 <= lab["top"] and lab["bottom"] <= lab["height"], (label, lab)
        assert d.execute_script("return document.documentElement.scrollWidth") <= 390
        assert own_errors(d) == []
    finally:
        browser.viewport(1280, 1000)
