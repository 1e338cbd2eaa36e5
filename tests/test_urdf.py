"""Extended-URDF import (pkmlib.load_urdf_mechanism) of the 5-bar linkage of Gepetto's
example-parallel-robots (tests/data/example_parallel_robots_5bar/, BSD 3-Clause), against pkmlib's
own five-bar (pkmlib.mechanisms.five_bar, P4) at the URDF's dimensions.

The two describe one mechanism in two frames:
- URDF: plane coordinates (u, v) in m (e1 = base y, e2 = base z); motors mot1 at u = +0.15 and
  mot2 at u = -0.15, v = 0.042 m; q = the motors' URDF angles, zero with the cranks along -e2.
- five_bar: (x_C, z_C) in mm from A1; A1 = mot2, A2 = mot1, phi_i from the x axis.
So x_C = 1000 (u + 0.15), z_C = 1000 (v - v_A), phi_1 = q_mot2 - pi/2, phi_2 = q_mot1 - pi/2.
The mechanism's points (x, q) come from five_bar's closed-form inverse position (elbows out);
the URDF mechanism's F, J^-1, J and det(A) are generated from its joints alone.
"""

from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import yourdfpy

import pkmlib as pk
from pkmlib import load_urdf_mechanism
from pkmlib.description import urdf_description
from pkmlib.mechanisms import five_bar as fb

DATA = Path(__file__).resolve().parent / "data" / "example_parallel_robots_5bar"
URDF, YAML = DATA / "robot.urdf", DATA / "robot.yaml"
BRANCH = fb.PAPER_BRANCH


@pytest.fixture(scope="module")
def urdf_mech():
    return load_urdf_mechanism(URDF, YAML)


@pytest.fixture(scope="module")
def fb_params(urdf_mech):
    P = urdf_mech.params
    base = 1000.0 * (P["mot1_u"] - P["mot2_u"])
    lengths = {
        k: 1000.0 * float(np.hypot(P[f"{j}_u"], P[f"{j}_v"]))
        for k, j in (("l_A1B1", "free2"), ("l_B1C", "closedloop1_B"), ("l_A2B2", "free1"), ("l_B2C", "closedloop1_A"))
    }
    return fb.FiveBarParams.create(l_A1A2=base, **lengths, section=fb.load_params().section)


def to_urdf(x_fb, q_fb, P):
    """(x, q) of five_bar (mm, rad) -> the URDF mechanism's (m, rad); batched over the last axis."""
    u = x_fb[0] / 1000.0 + P["mot2_u"]
    v = x_fb[1] / 1000.0 + P["mot2_v"]
    return jnp.stack([u, v]), jnp.stack([q_fb[1] + jnp.pi / 2, q_fb[0] + jnp.pi / 2])


#: Swapping the actuators (URDF's order is mot1, mot2 = five_bar's A2, A1).
SWAP = np.array([[0.0, 1.0], [1.0, 0.0]])


def test_the_shipped_model_is_the_repository_file_with_its_licence():
    assert "BSD 3-Clause" in (DATA / "LICENSE").read_text()
    readme = (DATA / "README.md").read_text()
    assert "52e64b31c2ef122feffa571b78134d4529f9050a" in readme and "Gepetto/example-parallel-robots" in readme
    model = yourdfpy.URDF.load(
        str(URDF),
        load_meshes=False,
        build_scene_graph=False,
        build_collision_scene_graph=False,
        load_collision_meshes=False,
    )
    assert {j.name for j in model.robot.joints} >= {"mot1", "mot2", "free1", "free2", "closedloop1_A", "closedloop1_B"}


def test_dimensions_read_from_the_urdf(urdf_mech, fb_params):
    assert urdf_mech.output_names == ("u", "v") and urdf_mech.actuator_names == ("q_mot1", "q_mot2")
    assert urdf_mech.n_actuators == 2 and urdf_mech.mobility == 2
    assert fb_params.l_A1A2 == pytest.approx(300.0, abs=1e-9)
    for k in ("l_A1B1", "l_B1C", "l_A2B2", "l_B2C"):
        assert getattr(fb_params, k) == pytest.approx(460.0, abs=1e-9), k
    assert urdf_mech.params["mot1_v"] == pytest.approx(urdf_mech.params["mot2_v"], abs=1e-12)


def grid_points(fb_params):
    xs, zs = np.meshgrid(np.linspace(20.0, 280.0, 9), np.linspace(120.0, 600.0, 9), indexing="ij")
    x = jnp.asarray(np.stack([xs.ravel(), zs.ravel()]))
    q = fb.mechanism.inverse(x, fb_params, BRANCH)
    keep = np.all(np.isfinite(np.asarray(q)), axis=0)
    assert keep.sum() > 40
    return x[:, keep], q[:, keep]


def test_jacobians_agree_with_the_five_bar(urdf_mech, fb_params):
    """F = 0 at five_bar's solutions; J^-1_urdf = 1000 SWAP J^-1_fb (x in m vs mm), J likewise, and
    det(A_urdf) / det(A_fb) is one constant (-1e-6: squared lengths in m^2 vs mm^2, rows swapped)."""
    P = urdf_mech.params
    x_fb, q_fb = grid_points(fb_params)
    x_u, q_u = to_urdf(x_fb, q_fb, P)

    def urdf_maps(x, q):
        return (
            urdf_mech.constraints(x, q, P),
            pk.inverse_jacobian(urdf_mech, x, q, P),
            pk.jacobian(urdf_mech, x, q, P),
            pk.det_A(urdf_mech, x, q, P),
        )

    def fb_maps(x, q):
        return (
            pk.inverse_jacobian(fb.mechanism, x, q, fb_params),
            pk.jacobian(fb.mechanism, x, q, fb_params),
            pk.det_A(fb.mechanism, x, q, fb_params),
        )

    F, Jinv_u, J_u, det_u = (np.asarray(v) for v in jax.jit(jax.vmap(urdf_maps, in_axes=(1, 1)))(x_u, q_u))
    Jinv_f, J_f, det_f = (np.asarray(v) for v in jax.jit(jax.vmap(fb_maps, in_axes=(1, 1)))(x_fb, q_fb))
    assert np.max(np.abs(F)) < 1e-12
    assert np.allclose(Jinv_u, 1000.0 * SWAP @ Jinv_f, rtol=1e-9, atol=1e-9 * np.max(np.abs(Jinv_u)))
    assert np.allclose(J_u, J_f @ SWAP / 1000.0, rtol=1e-9, atol=1e-9 * np.max(np.abs(J_u)))
    ratio = det_u / det_f
    assert np.allclose(ratio, -1e-6, rtol=1e-8), ratio


def test_singular_curve_agrees_with_the_five_bar(urdf_mech, fb_params):
    """det(A) = 0 refined on the same grid (mm for five_bar, m for the URDF) gives the same points."""
    P = urdf_mech.params
    grid_f = pk.Grid.from_ranges(x_C=(50.0, 250.0, 10.0), z_C=(250.0, 450.0, 10.0))
    grid_u = pk.Grid(
        names=("u", "v"),
        starts=(grid_f.starts[0] / 1000.0 + P["mot2_u"], grid_f.starts[1] / 1000.0 + P["mot2_v"]),
        steps=tuple(s / 1000.0 for s in grid_f.steps),
        counts=grid_f.counts,
    )

    def det_f(point):
        return fb.det_A_at(point, fb_params, BRANCH)

    def det_u(point):
        x_fb = jnp.stack([(point[0] - P["mot2_u"]) * 1000.0, (point[1] - P["mot2_v"]) * 1000.0])
        x, q = to_urdf(x_fb, fb.mechanism.inverse(x_fb, fb_params, BRANCH), P)
        return pk.det_A(urdf_mech, x, q, P)

    roots = {}
    for name, grid, fn in (("fb", grid_f, det_f), ("urdf", grid_u, det_u)):
        pts = np.stack(np.meshgrid(*grid.axes, indexing="ij"), axis=-1).reshape(-1, 2)
        values = np.asarray(jax.jit(jax.vmap(fn))(jnp.asarray(pts))).reshape(grid.shape)
        r, axis = pk.singular_crossings(fn, grid, values, tol=1e-12 if name == "urdf" else 1e-9)
        if name == "urdf":  # to five_bar's frame, mm
            r = np.stack([(r[:, 0] - P["mot2_u"]) * 1000.0, (r[:, 1] - P["mot2_v"]) * 1000.0], -1)
        roots[name] = r[np.lexsort((np.round(r[:, 1], 3), np.round(r[:, 0], 3), axis))]
    assert len(roots["fb"]) >= 10 and len(roots["fb"]) == len(roots["urdf"])
    assert np.max(np.abs(roots["urdf"] - roots["fb"])) < 1e-6  # mm
    # the symmetric crossing of P4's formula, z_C = sqrt(l^2 - (l - b/2)^2) on x_C = b/2
    on_axis = roots["fb"][np.isclose(roots["fb"][:, 0], 150.0)]
    assert np.allclose(on_axis[:, 1], np.sqrt(460.0**2 - 310.0**2), atol=1e-6)


def test_output_frame_and_bad_closures_are_errors_naming_what_is_accepted():
    assert urdf_description(URDF, YAML, "closedloop1_A")["output"]["body"] == "C"
    with pytest.raises(ValueError, match="output_frame: 'effector' is not the closure point"):
        urdf_description(URDF, YAML, "effector")
    with pytest.raises(ValueError, match="name_mot: 'mot9' is not a joint"):
        urdf_description(
            URDF, {"closed_loop": [["closedloop1_A", "closedloop1_B"]], "type": ["6d"], "name_mot": ["mot9"]}
        )
    with pytest.raises(ValueError, match="closed_loop: 'nowhere' is neither a joint nor a link"):
        urdf_description(
            URDF, {"closed_loop": [["nowhere", "closedloop1_B"]], "type": ["6d"], "name_mot": ["mot1", "mot2"]}
        )
    with pytest.raises(ValueError, match="type"):
        urdf_description(
            URDF, {"closed_loop": [["closedloop1_A", "closedloop1_B"]], "type": ["9d"], "name_mot": ["mot1"]}
        )


def test_a_loop_that_cannot_close_along_the_axis_is_an_error(tmp_path):
    text = URDF.read_text().replace(
        '<origin xyz="-5.5511151231257827021e-17 -0.45999999999999985345 0.050000000000000002776"',
        '<origin xyz="-5.5511151231257827021e-17 -0.45999999999999985345 0.07"',
    )
    assert text != URDF.read_text()
    bad = tmp_path / "robot.urdf"
    bad.write_text(text)
    with pytest.raises(ValueError, match="the loop cannot close"):
        urdf_description(bad, YAML)
