"""P4: beam-element stiffness (textbook beams, condensation, assembly) and the five-bar model
(Jacobians vs finite differences, stiffness vs compliance and a planar hand formula)."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import pkmlib as pk
from pkmlib import _stiffness as st
from pkmlib.mechanisms import five_bar as fb
from conftest import assert_close, central_difference

SECTION = pk.stiffness.BeamSection.create(E=68900.0, G=25900.0, A=160.0, I_y=3410.0, I_z=1330.0, I_p=3260.0)


@pytest.fixture(scope="module")
def p4():
    return fb.FiveBarParams.from_dict(pk.load_params("p4"))


@pytest.fixture(scope="module")
def pose(p4):
    """``fb.pose_stiffness`` at one point for T_max = 2000 N mm, compiled once."""
    return jax.jit(lambda x: fb.pose_stiffness(x, p4, 2000.0))


@pytest.fixture(scope="module")
def poses(p4, pose):
    """Random poses in the working mode, above the actuator axis, away from the type-2 curve."""
    rng = np.random.default_rng(4)
    out = []
    while len(out) < 12:
        x = np.array([rng.uniform(-150.0, 250.0), rng.uniform(20.0, 320.0)])
        r = pose(jnp.asarray(x))
        if np.isfinite(r["k_min"]) and abs(float(r["det_A"])) > 2e3:
            out.append(x)
    return np.array(out)


# --- elements and frames against textbook beams ----------------------------------------------


def straight_beam(direction, L, n_el):
    d = np.asarray(direction, dtype=np.float64) / np.linalg.norm(direction)
    nodes = np.outer(np.linspace(0.0, L, n_el + 1), d)
    return nodes, tuple((i, i + 1) for i in range(n_el))


def test_cantilever_tip_deflections_and_rotations_match_textbook():
    L, n_el = 400.0, 4
    nodes, elements = straight_beam((1.0, 0.3, 2.0), L, n_el)  # an oblique beam in 3-D
    frame = pk.stiffness.Frame(n_nodes=n_el + 1, elements=elements, fixed_dofs=pk.stiffness.node_dofs(0))
    R = np.asarray(pk.stiffness.element_rotation(nodes[0], nodes[-1]))  # rows: local x, y, z in global
    ex, ey, ez = R
    s = SECTION
    P, T = 7.0, 1.0e3
    cases = [  # (force, moment, expected tip translation along, expected tip rotation about)
        (P * ey, 0 * ex, P * L**3 / (3 * s.E * s.I_z) * ey, P * L**2 / (2 * s.E * s.I_z) * ez),
        (P * ez, 0 * ex, P * L**3 / (3 * s.E * s.I_y) * ez, -P * L**2 / (2 * s.E * s.I_y) * ey),
        (P * ex, 0 * ex, P * L / (s.E * s.A) * ex, 0 * ex),
        (0 * ex, T * ex, 0 * ex, T * L / (s.G * s.I_p) * ex),
    ]
    solve = jax.jit(lambda loads: frame.solve(nodes, s, loads))
    for force, moment, u_tip, theta_tip in cases:
        loads = np.zeros((n_el + 1, 6))
        loads[-1, :3], loads[-1, 3:] = force, moment
        d = np.asarray(solve(loads))
        assert_close(d[-1, :3], u_tip, rtol=1e-9, atol=1e-11)
        assert_close(d[-1, 3:], theta_tip, rtol=1e-9, atol=1e-13)


def test_simply_supported_beam_midspan_deflection_matches_textbook():
    L, P = 600.0, 50.0
    nodes, elements = straight_beam((1.0, 0.0, 0.0), L, 2)
    pin = (
        pk.stiffness.node_dofs(0)[0],
        pk.stiffness.node_dofs(0)[1],
        pk.stiffness.node_dofs(0)[2],
        pk.stiffness.node_dofs(0)[3],
    )  # u, theta_x
    roller = (pk.stiffness.node_dofs(2)[1], pk.stiffness.node_dofs(2)[2])  # u_y, u_z
    frame = pk.stiffness.Frame(n_nodes=3, elements=elements, fixed_dofs=pin + roller)
    solve = jax.jit(lambda loads: frame.solve(nodes, SECTION, loads))
    for k, I in ((st.U_Z, SECTION.I_y), (st.U_Y, SECTION.I_z)):
        loads = np.zeros((3, 6))
        loads[1, k] = -P
        d = np.asarray(solve(loads))
        assert_close(d[1, k], -P * L**3 / (48 * SECTION.E * I), rtol=1e-10)
        end_rotation = P * L**2 / (16 * SECTION.E * I)
        k_rot = st.THETA_Y if k == st.U_Z else st.THETA_Z
        assert_close(abs(d[0, k_rot]), end_rotation, rtol=1e-10)


def test_simply_supported_beam_from_hinged_elements():
    """The same beam as a fixed-hinge element (hinge at the support end) and a clamp-free middle:
    a propped cantilever under a midspan load, 7 P L^3 / (768 E I) (textbook)."""
    L, P = 600.0, 50.0
    nodes, elements = straight_beam((1.0, 0.0, 0.0), L, 2)
    # node 0 clamped, node 2 on a roller; the element 1-2 released at node 2 (its theta_y)
    frame = pk.stiffness.Frame(
        n_nodes=3,
        elements=elements,
        releases=((), pk.stiffness.FIXED_HINGE_Y),
        fixed_dofs=pk.stiffness.node_dofs(0)
        + (
            st.node_dof(2, st.U_X),
            st.node_dof(2, st.U_Y),
            st.node_dof(2, st.U_Z),
            st.node_dof(2, st.THETA_X),
            st.node_dof(2, st.THETA_Z),
        ),
        empty_dofs=(st.node_dof(2, st.THETA_Y),),
    )
    loads = np.zeros((3, 6))
    loads[1, st.U_Z] = -P
    d = np.asarray(jax.jit(frame.solve)(nodes, SECTION, loads))
    assert_close(d[1, st.U_Z], -7 * P * L**3 / (768 * SECTION.E * SECTION.I_y), rtol=1e-10)


def test_condensation_equals_the_analytic_hinged_elements():
    L, s = 175.0, SECTION
    K = np.asarray(pk.stiffness.frame_element_local(L, s))
    N = np.asarray(pk.stiffness.hinged_element_local(L, s, pk.stiffness.FIXED_HINGE_Y))
    H = np.asarray(pk.stiffness.hinged_element_local(L, s, pk.stiffness.HINGE_HINGE_Y))
    xz = [2, 4, 8, 10]  # u_z1, theta_y1, u_z2, theta_y2
    # fixed-pinned beam (hinge at node 2): 3EI/L^3 [[1, -L, -1, 0], [-L, L^2, L, 0], [-1, L, 1, 0], 0]
    fixed_pinned = 3 * s.E * s.I_y / L**3 * np.array([[1, -L, -1, 0], [-L, L**2, L, 0], [-1, L, 1, 0], [0, 0, 0, 0]])
    assert_close(N[np.ix_(xz, xz)], fixed_pinned, rtol=1e-12, atol=1e-9)
    assert_close(H[np.ix_(xz, xz)], np.zeros((4, 4)), atol=1e-9)  # a pin-jointed bar in x-z
    others = [i for i in range(12) if i not in xz]
    for Kc in (N, H):  # axial, torsion and bending in x-y are untouched
        assert_close(Kc[np.ix_(others, others)], K[np.ix_(others, others)], rtol=1e-14)
        assert_close(Kc[np.ix_(others, xz)], np.zeros((len(others), 4)), atol=1e-9)


def test_condensation_gives_the_papers_N_and_H_up_to_the_listed_misprints():
    L, s = 175.0, SECTION
    scale = s.E / L**3
    ours = {
        "M": pk.stiffness.frame_element_local(L, s),
        "N": pk.stiffness.hinged_element_local(L, s, pk.stiffness.FIXED_HINGE_Y),
        "H": pk.stiffness.hinged_element_local(L, s, pk.stiffness.HINGE_HINGE_Y),
    }
    misprints = {"M": {(8, 11), (11, 8), (9, 11), (11, 9)}, "N": {(12, 12)}, "H": {(12, 12)}}
    for name, K in ours.items():
        printed, _ = fb.printed_matrix(name, L, s)
        diff = np.abs(np.asarray(K) / scale - printed) > 1e-6 * np.abs(printed).max()
        assert {(int(i) + 1, int(j) + 1) for i, j in np.argwhere(diff)} == misprints[name], name


def test_element_rotation_is_the_papers_R_in_the_xz_plane():
    for a in np.linspace(-3.0, 3.0, 7):
        p2 = 175.0 * np.array([np.cos(a), 0.0, np.sin(a)])
        assert_close(pk.stiffness.element_rotation(np.zeros(3), p2), st.rotation_xz(a), rtol=1e-13, atol=1e-15)
    R = np.asarray(pk.stiffness.element_rotation(np.zeros(3), np.array([1.0, 2.0, 3.0])))
    assert_close(R @ R.T, np.eye(3), atol=1e-14)
    assert_close(np.linalg.det(R), 1.0)


def rigid_body_modes(nodes):
    """The six rigid-body displacement fields u = t + w x r, theta = w, as (6 n, 6) columns."""
    cols = []
    for k in range(6):
        v = np.zeros(6)
        v[k] = 1.0
        t, w = v[:3], v[3:]
        cols.append(np.concatenate([np.concatenate([t + np.cross(w, r), w]) for r in nodes]))
    return np.stack(cols, axis=1)


def test_global_matrix_symmetric_psd_with_the_right_rigid_body_modes(p4):
    x = jnp.array([50.0, 150.0])
    nodes = np.asarray(fb.frame_nodes(x, fb.mechanism.inverse(x, p4), p4))
    K = np.asarray(fb.FRAME.global_matrix(nodes, p4.section))
    scale = np.abs(K).max()
    assert_close(K, K.T, rtol=0, atol=1e-12 * scale)
    ev = np.linalg.eigvalsh(K)
    assert ev[0] > -1e-12 * ev[-1]
    # 6 rigid-body modes + 3 hinge mechanism modes in the plane + 3 empty hinge rows = 12
    assert np.sum(ev < 1e-12 * ev[-1]) == 12 and ev[12] > 1e-8 * ev[-1]
    assert_close(K @ rigid_body_modes(nodes), np.zeros((30, 6)), atol=1e-9 * scale)
    assert st.find_empty_dofs(K) == fb.FRAME.empty_dofs
    # the same frame with rigid joints has only the six rigid-body modes
    rigid = pk.stiffness.Frame(n_nodes=5, elements=fb.FRAME.elements)
    ev = np.linalg.eigvalsh(np.asarray(rigid.global_matrix(nodes, p4.section)))
    assert np.sum(ev < 1e-12 * ev[-1]) == 6
    # single elements: 6, 7 (N) and 8 (H) zero modes
    for released, n0 in (((), 6), (pk.stiffness.FIXED_HINGE_Y, 7), (pk.stiffness.HINGE_HINGE_Y, 8)):
        ev = np.linalg.eigvalsh(np.asarray(pk.stiffness.hinged_element_local(175.0, p4.section, released)))
        assert np.sum(ev < 1e-12 * ev[-1]) == n0
    # clamped and reduced: the paper's 15 x 15, positive definite
    Kr = np.asarray(fb.stiffness_matrix(x, p4))
    assert Kr.shape == (15, 15) and np.linalg.eigvalsh(Kr)[0] > 0


def test_stiffness_is_the_inverse_of_the_compliance_from_unit_loads(p4, poses, pose):
    stiffness = jax.jit(lambda x: fb.output_stiffness(x, p4))
    compliance_of = jax.jit(lambda x: fb.output_compliance(x, p4))
    for x in poses:
        K_C = np.asarray(stiffness(jnp.asarray(x)))
        compliance = np.asarray(compliance_of(jnp.asarray(x)))
        assert_close(K_C, np.linalg.inv(compliance), rtol=1e-8, atol=1e-9 * np.abs(K_C).max())
        assert_close(pose(jnp.asarray(x))["K_C"], K_C, rtol=1e-10, atol=1e-10)


def test_output_stiffness_matches_a_planar_hand_formula(p4, poses, pose):
    """In the plane each chain is a clamped-hinged beam A_iB_i (axial EA/l, transverse 3EI_y/l^3
    at B_i) in series with a pin-jointed bar B_iC (axial EA/l): K_C = sum_i u_i u_i^T / c_i with
    c_i = l/(EA) + u_i^T K_Bi^-1 u_i and u_i the unit vector B_i -> C."""
    s = p4.section
    k_a, k_t = s.E * s.A / 175.0, 3 * s.E * s.I_y / 175.0**3
    for x in poses:
        q = np.asarray(fb.mechanism.inverse(jnp.asarray(x), p4))
        pts = {k: np.asarray(v) for k, v in fb.joint_points(x, q, p4).items()}
        K_hand = np.zeros((2, 2))
        for A, B in (("A1", "B1"), ("A2", "B2")):
            e = (pts[B] - pts[A]) / 175.0
            n = np.array([-e[1], e[0]])
            K_B = k_a * np.outer(e, e) + k_t * np.outer(n, n)
            u = (pts["C"] - pts[B]) / 175.0
            c = 1 / k_a + u @ np.linalg.solve(K_B, u)
            K_hand += np.outer(u, u) / c
        assert_close(pose(jnp.asarray(x))["K_C"], K_hand, rtol=1e-9, atol=1e-9 * np.abs(K_hand).max())


def test_jacobians_match_finite_differences_of_the_inverse_position(p4, poses, pose):
    for x in poses:
        q = fb.mechanism.inverse(jnp.asarray(x), p4)
        assert_close(fb.mechanism.constraints(jnp.asarray(x), q, p4), np.zeros(2), atol=1e-9)
        J_inv_fd = central_difference(lambda z: fb.mechanism.inverse(jnp.asarray(z), p4), x, h=1e-5)
        J_inv = pk.inverse_jacobian(fb.mechanism, jnp.asarray(x), q, p4)
        assert_close(J_inv, J_inv_fd, rtol=1e-6, atol=1e-10)
        assert_close(pose(jnp.asarray(x))["J"], np.linalg.inv(J_inv_fd), rtol=1e-5)


def test_worst_direction_maximises_the_actuator_torque_brute_force(p4, poses, pose):
    angles = np.linspace(0.0, np.pi, 36001)
    U = np.stack([np.cos(angles), np.sin(angles)])  # unit forces, (2, m)
    T_max = 2000.0
    for x in poses:
        r = {k: np.asarray(v) for k, v in pose(jnp.asarray(x)).items()}
        T = -r["J"].T @ U  # P4 eq (1): T = -J^T P
        for i in range(2):
            assert_close(np.abs(T[i]).max(), r["torque_per_force"][i], rtol=1e-7)
            best = U[:, np.argmax(np.abs(T[i]))]
            assert abs(abs(best @ r["directions"][:, i]) - 1) < 1e-7
        k = int(np.argmax(r["torque_per_force"]))
        assert abs(abs(r["worst_direction"] @ r["directions"][:, k]) - 1) < 1e-12
        # the worst direction: the smallest force that saturates an actuator, over all directions
        assert_close(T_max / np.abs(T).max(), T_max / r["torque_per_force"].max(), rtol=1e-7)
        # every parallelogram corner needs T_max in both actuators
        corners = np.asarray(
            fb.force_parallelogram(pk.inverse_jacobian(fb.mechanism, jnp.asarray(x), r["q"], p4), T_max)
        )
        assert_close(np.abs(-r["J"].T @ corners.T), np.full((2, 4), T_max), rtol=1e-9)
        # directional stiffness: 1 / (u^T C u), the minimum over directions is k_min
        C = np.linalg.inv(r["K_C"])
        assert_close(r["k_worst"], 1 / (r["worst_direction"] @ C @ r["worst_direction"]), rtol=1e-10)
        assert_close(r["k_min"], (1 / np.einsum("im,ij,jm->m", U, C, U)).min(), rtol=1e-6)
        assert_close(pk.stiffness.directional_stiffness(r["K_C"], r["worst_direction"]), r["k_worst"], rtol=1e-10)


def test_stiffness_vanishes_at_the_type2_singularity(pose):
    z_s = np.sqrt(175.0**2 - (175.0 - 50.0) ** 2)  # B1, C, B2 on one horizontal line at x_C = 50
    at = pose(jnp.array([50.0, z_s]))
    away = pose(jnp.array([50.0, 200.0]))
    assert abs(float(at["det_A"])) < 1e-6 * abs(float(away["det_A"]))
    assert float(at["k_worst"]) < 1e-6 * float(away["k_worst"])
    assert float(away["k_min"]) > 1.0


def test_sweep_equals_pointwise_and_gives_nan_outside(p4, pose):
    grid = pk.Grid.from_ranges(x_C=(-300.0, 100.0, 100.0), z_C=(50.0, 350.0, 150.0))
    maps = pk.sweep(lambda pt: fb.pose_stiffness(pt, p4, 2000.0)["k_worst"], grid)
    pts = grid.points()
    expected = np.array(
        [[float(pose(jnp.asarray(pts[i, j]))["k_worst"]) for j in range(grid.shape[1])] for i in range(grid.shape[0])]
    )
    assert np.isnan(maps[0, 2]) and np.isnan(expected[0, 2])  # (-300, 350) is out of reach
    finite = np.isfinite(expected)
    assert finite.sum() >= 6
    assert_close(maps[finite], expected[finite], rtol=1e-10)


def test_parameters_are_checked_by_name(p4):
    d = pk.load_params("p4")
    bad = {**d, "mechanism": {k: v for k, v in d["mechanism"].items() if k != "l_B1C_mm"}}
    with pytest.raises(ValueError, match="l_B1C_mm"):
        fb.FiveBarParams.from_dict(bad)
    with pytest.raises(ValueError, match="l_A1A2"):
        fb.FiveBarParams.create(l_A1A2=-1.0, l_A1B1=1, l_B1C=1, l_A2B2=1, l_B2C=1, section=SECTION)
    with pytest.raises(ValueError, match="I_y"):
        fb.FiveBarParams.from_dict({**d, "section_rectangle": {"b_mm": 10.0, "h_mm": 15.0}})
    with pytest.raises(ValueError, match="E"):
        pk.stiffness.BeamSection.create(E=0.0, G=1.0, A=1.0, I_y=1.0, I_z=1.0, I_p=1.0)
    with pytest.raises(ValueError, match="elements"):
        pk.stiffness.Frame(n_nodes=2, elements=((0, 2),))
    assert p4.section.A == 160.0
    r = pk.stiffness.rectangle_section(10.0, 16.0)
    for name in ("I_y", "I_z", "I_p"):
        assert_close(r[name], d["section"][f"{name}_mm4"], rtol=5e-3)
    assert len(jax.tree_util.tree_leaves(p4)) == 11
