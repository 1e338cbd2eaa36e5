"""P4 (issues 12 and 14): the stiffness API at its edges.

Node compliance in public, hinges declared as releases, the parameter file checked key by key,
canonical directions at ties (jitted == direct), NaN-free gradients against central differences
with respect to pose, link lengths and section sizes, and the unrolled structured condensation
against dense ``jnp.linalg``.
"""

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import pkmlib as pk
from pkmlib import _stiffness as st
from pkmlib.mechanisms import five_bar as fb
from conftest import assert_close, central_difference

T_MAX = 2000.0


@pytest.fixture(scope="module")
def raw():
    return pk.load_params("p4")


@pytest.fixture(scope="module")
def p4(raw):
    return fb.FiveBarParams.from_dict(raw)


@pytest.fixture(scope="module")
def interior(p4):
    """Random poses inside the workspace (working mode), away from the type-2 curve and from the
    symmetry line (where the two actuators tie)."""
    rng = np.random.default_rng(12)
    out = []
    while len(out) < 6:
        x = np.array([rng.uniform(-150.0, 250.0), rng.uniform(20.0, 320.0)])
        r = fb.pose_stiffness_jit(x, p4, T_MAX)
        n = np.asarray(r["torque_per_force"])
        if np.isfinite(r["k_min"]) and abs(float(r["det_A"])) > 2e3 and abs(n[0] - n[1]) > 1e-3 * n.max():
            out.append(x)
    return np.array(out)


# --- 1. API: node compliance, releases, the parameter file -----------------------------------


@jax.jit
def _dense_inverse(x, p):
    return jnp.linalg.inv(fb.stiffness_matrix(x, p))


def dense_reduced_inverse(x, p):
    """Inverse of the dense reduced 15 x 15 matrix by jnp.linalg (the reference)."""
    return np.asarray(_dense_inverse(jnp.asarray(x), p))


def test_node_compliance_is_public_and_equals_the_dense_inverse(p4, interior):
    assert pk.stiffness.node_dof(fb.C, st.U_Z) == 6 * fb.C + 2
    assert fb.FRAME.node_free_dofs(fb.C) == (st.U_X, st.U_Y, st.U_Z, st.THETA_X, st.THETA_Z)
    compliance = jax.jit(lambda x: fb.node_compliance(x, p4))
    for x in interior[:3]:
        Kinv = dense_reduced_inverse(x, p4)
        idx = [fb.FRAME.reduced_index(pk.stiffness.node_dof(fb.C, k)) for k in fb.FRAME.node_free_dofs(fb.C)]
        C5 = np.asarray(compliance(jnp.asarray(x)))
        assert C5.shape == (5, 5)
        assert_close(C5, Kinv[np.ix_(idx, idx)], rtol=1e-9, atol=1e-12 * np.abs(C5).max())
        # the in-plane block is the output compliance of the paper's route
        assert_close(C5[np.ix_([0, 2], [0, 2])], fb.output_compliance(jnp.asarray(x), p4), rtol=1e-9)
    # the generic route (element_rotation, no structural zeros) gives the same at B1
    x = jnp.asarray(interior[0])
    nodes = fb.frame_nodes(x, fb.mechanism.inverse(x, p4), p4)
    idx = [fb.FRAME.reduced_index(pk.stiffness.node_dof(fb.B1, k)) for k in fb.FRAME.node_free_dofs(fb.B1)]
    generic = jax.jit(fb.FRAME.node_compliance, static_argnums=2)
    assert_close(
        generic(nodes, p4.section, fb.B1),
        dense_reduced_inverse(interior[0], p4)[np.ix_(idx, idx)],
        rtol=1e-9,
        atol=1e-15,
    )
    with pytest.raises(ValueError, match="node"):
        fb.FRAME.node_free_dofs(7)
    with pytest.raises(ValueError, match="k must be"):
        pk.stiffness.node_dof(0, 6)


def test_hinges_are_declared_as_releases():
    assert (
        pk.stiffness.release(2) == pk.stiffness.FIXED_HINGE_Y
        and pk.stiffness.release(1, 2) == pk.stiffness.HINGE_HINGE_Y
    )
    assert pk.stiffness.release(1, about="z") == (st.THETA_Z,)
    for bad in ((), (3,), (0,)):
        with pytest.raises(ValueError, match="ends"):
            pk.stiffness.release(*bad)
    with pytest.raises(ValueError, match="about"):
        pk.stiffness.release(1, about="w")
    # the empty hinge rows follow from the releases: theta_y at B1, C, B2
    frame = pk.stiffness.Frame(
        n_nodes=5,
        elements=fb.FRAME.elements,
        releases=(
            pk.stiffness.release(2),
            pk.stiffness.release(1, 2),
            pk.stiffness.release(2),
            pk.stiffness.release(1, 2),
        ),
        fixed_dofs=pk.stiffness.node_dofs(fb.A1, fb.A2),
    )
    assert frame.empty_dofs == tuple(pk.stiffness.node_dof(n, st.THETA_Y) for n in (fb.B1, fb.C, fb.B2))
    assert len(frame.free_dofs) == 15 and frame == fb.FRAME
    # a node where one element keeps its rotation is not emptied; explicit empty_dofs still win
    partly = pk.stiffness.Frame(n_nodes=3, elements=((0, 1), (1, 2)), releases=(pk.stiffness.release(2), ()))
    assert partly.empty_dofs == ()
    assert pk.stiffness.Frame(
        n_nodes=3, elements=((0, 1), (1, 2)), releases=(pk.stiffness.release(2), ()), empty_dofs=(4,)
    ).empty_dofs == (4,)
    with pytest.raises(ValueError, match="up"):
        pk.stiffness.Frame(n_nodes=2, elements=((0, 1),), releases=(pk.stiffness.release(2),), up=(1.0, 1.0, 0.0))


def test_propped_cantilever_from_a_release_without_listing_empty_dofs():
    L, P = 600.0, 50.0
    s = pk.stiffness.BeamSection.create(E=68900.0, G=25900.0, A=160.0, I_y=3410.0, I_z=1330.0, I_p=3260.0)
    nodes = np.outer(np.linspace(0.0, L, 3), [1.0, 0.0, 0.0])
    roller = tuple(pk.stiffness.node_dof(2, k) for k in (st.U_X, st.U_Y, st.U_Z, st.THETA_X, st.THETA_Z))
    frame = pk.stiffness.Frame(
        n_nodes=3,
        elements=((0, 1), (1, 2)),
        releases=((), pk.stiffness.release(2)),
        fixed_dofs=pk.stiffness.node_dofs(0) + roller,
    )
    loads = np.zeros((3, 6))
    loads[1, st.U_Z] = -P
    d = np.asarray(jax.jit(frame.solve)(nodes, s, loads))
    assert_close(d[1, st.U_Z], -7 * P * L**3 / (768 * s.E * s.I_y), rtol=1e-10)
    # the node compliance gives the same midspan deflection
    C1 = np.asarray(frame.node_compliance(nodes, s, 1))
    assert_close(-P * C1[2, 2], d[1, st.U_Z], rtol=1e-10)


def without(d, group, key):
    return {**d, group: {k: v for k, v in d[group].items() if k != key}}


def with_value(d, group, key, value):
    return {**d, group: {**d[group], key: value}}


def test_from_dict_names_every_missing_or_bad_entry(raw):
    with pytest.raises(ValueError, match=r"section_rectangle\.b_mm"):
        fb.FiveBarParams.from_dict(without(raw, "section_rectangle", "b_mm"))
    with pytest.raises(ValueError, match=r"missing P4 parameter group.*material"):
        fb.FiveBarParams.from_dict({k: v for k, v in raw.items() if k != "material"})
    with pytest.raises(ValueError, match="load_params"):
        fb.FiveBarParams.from_dict([1, 2])
    # a negative I_y is a bad value, not a section mismatch
    with pytest.raises(ValueError, match=r"section\.I_y_mm4.*finite number > 0") as e:
        fb.FiveBarParams.from_dict(with_value(raw, "section", "I_y_mm4", -3410.0))
    assert "does not match" not in str(e.value)
    for group, key in (
        ("mechanism", "l_B1C_mm"),
        ("material", "E_MPa"),
        ("section", "I_p_mm4"),
        ("section_rectangle", "h_mm"),
    ):
        for bad in (None, [175.0], 175.0 + 0j, "abc", float("nan"), 0.0, True):
            with pytest.raises(ValueError, match=rf"{group}\.{key}.*finite number > 0") as e:
                fb.FiveBarParams.from_dict(with_value(raw, group, key, bad))
            assert not isinstance(e.value, (TypeError, KeyError))
    # the constructors check types too
    for bad in (None, "abc", [1.0], 1j):
        with pytest.raises(ValueError, match="E must be a finite positive number"):
            pk.stiffness.BeamSection.create(E=bad, G=1.0, A=1.0, I_y=1.0, I_z=1.0, I_p=1.0)
        with pytest.raises(ValueError, match="l_A1A2"):
            fb.FiveBarParams.create(l_A1A2=bad, l_A1B1=1, l_B1C=1, l_A2B2=1, l_B2C=1, section=p4_section(raw))
    with pytest.raises(ValueError, match="b must be"):
        pk.stiffness.rectangle_section("abc", 16.0)


def p4_section(raw):
    return fb.FiveBarParams.from_dict(raw).section


# --- 2. canonical directions at ties --------------------------------------------------------


def test_worst_direction_is_canonical_at_the_tie_on_the_symmetry_line(p4):
    for z in (120.0, 150.0):
        x = jnp.array([50.0, z])
        direct = fb.pose_stiffness(x, p4, T_MAX)
        jitted = fb.pose_stiffness_jit(x, p4, T_MAX)
        jitted_closure = jax.jit(lambda y: fb.pose_stiffness(y, p4, T_MAX))(x)
        n = np.asarray(direct["torque_per_force"])
        assert abs(n[0] - n[1]) < 1e-12 * n.max()  # the tie
        for key in ("worst_direction", "diagonal_direction", "k_worst", "k_diagonal"):
            assert_close(jitted[key], direct[key], rtol=1e-12, atol=1e-12, err_msg=key)
            assert_close(jitted_closure[key], direct[key], rtol=1e-12, atol=1e-12, err_msg=key)
        # actuator 1's direction, with z > 0
        u1 = np.asarray(direct["directions"])[:, 0]
        assert_close(direct["worst_direction"], u1 * np.sign(u1[1]), rtol=1e-14)
    # vmapped over a row of the map: the same
    pts = jnp.stack([jnp.full(5, 50.0), jnp.linspace(130.0, 300.0, 5)], axis=1)
    many = fb.pose_stiffness_jit(pts, p4, T_MAX)
    for i in range(5):
        one = fb.pose_stiffness_jit(pts[i], p4, T_MAX)
        assert_close(many["worst_direction"][i], one["worst_direction"], rtol=1e-12, atol=1e-12)
        assert float(one["worst_direction"][1]) > 0  # z up, actuator 1's line
        assert abs(abs(float(one["worst_direction"] @ one["directions"][:, 0])) - 1) < 1e-12


def test_canonical_sign():
    assert_close(pk.stiffness.canonical_sign(jnp.array([-0.6, 0.8])), [0.6, -0.8])
    assert_close(pk.stiffness.canonical_sign(jnp.array([-0.6, 0.8]), order=(1, 0)), [-0.6, 0.8])
    assert_close(pk.stiffness.canonical_sign(jnp.array([1e-17, -1.0])), [-1e-17, 1.0])  # x negligible: y positive
    assert_close(pk.stiffness.canonical_sign(jnp.array([-1e-17, 1.0])), [-1e-17, 1.0])
    u = jnp.array([[-1.0, 0.0, 2.0], [3.0, -1.0, -5.0]])  # columns
    assert_close(pk.stiffness.canonical_sign(u), [[1.0, 0.0, 2.0], [-3.0, 1.0, -5.0]])


# --- 3. gradients against central differences ---------------------------------------------


def quantities(r):
    return jnp.concatenate([jnp.stack([r["k_worst"], r["k_min"], r["k_diagonal"]]), r["K_C"].ravel()])


def test_gradients_with_respect_to_the_pose(p4, interior):
    f = jax.jit(lambda x: quantities(fb.pose_stiffness(x, p4, T_MAX)))
    jac = jax.jit(jax.jacrev(lambda x: quantities(fb.pose_stiffness(x, p4, T_MAX))))
    for x in interior:
        ad = np.asarray(jac(jnp.asarray(x)))
        fd = central_difference(lambda z: f(jnp.asarray(z)), x, h=1e-4)
        assert_close(ad, fd, rtol=2e-6, atol=1e-7 * np.abs(fd).max())


def params_from_vector(z, raw):
    """(l_A1A2, l_A1B1, l_B1C, l_A2B2, l_B2C, b, h) -> FiveBarParams, traceable."""
    r = pk.stiffness.rectangle_section(z[5], z[6])
    E, G = raw["material"]["E_MPa"], raw["material"]["G_MPa"]
    section = st.BeamSection(E=E, G=G, A=r["A"], I_y=r["I_y"], I_z=r["I_z"], I_p=r["I_p"])
    return fb.FiveBarParams(*(z[i] for i in range(5)), section=section)


def test_gradients_with_respect_to_lengths_and_section_sizes(raw, interior):
    m, rect = raw["mechanism"], raw["section_rectangle"]
    z0 = np.array(
        [m["l_A1A2_mm"], m["l_A1B1_mm"], m["l_B1C_mm"], m["l_A2B2_mm"], m["l_B2C_mm"], rect["b_mm"], rect["h_mm"]]
    )

    def g(z, x):
        return quantities(fb.pose_stiffness(x, params_from_vector(z, raw), T_MAX))

    f = jax.jit(g)
    jac = jax.jit(jax.jacrev(g))
    for x in interior[:4]:
        ad = np.asarray(jac(jnp.asarray(z0), jnp.asarray(x)))
        fd = central_difference(lambda z: f(jnp.asarray(z), jnp.asarray(x)), z0, h=1e-4)
        assert_close(ad, fd, rtol=2e-6, atol=1e-7 * np.abs(fd).max())
    # the pytree gradient of the parameters themselves is finite everywhere
    p = fb.FiveBarParams.from_dict(raw)
    grads = jax.jit(jax.grad(lambda q: fb.pose_stiffness(jnp.asarray(interior[0]), q, T_MAX)["k_worst"]))(p)
    assert all(np.isfinite(v) for v in jax.tree_util.tree_leaves(grads))


def test_gradients_are_finite_at_ties(p4):
    # the actuators' tie on the symmetry line: one-sided, finite
    grad = jax.jit(jax.grad(lambda x: fb.pose_stiffness(x, p4, T_MAX)["k_worst"]))(jnp.array([50.0, 150.0]))
    assert np.all(np.isfinite(grad))
    # isotropic stiffness (both extremal directions tie): the closed form's one-sided derivative
    K = jnp.array([[3.0, 0.0], [0.0, 3.0]])
    assert_close(pk.stiffness.extremal_stiffness(K), [3.0, 3.0])
    d = jax.grad(lambda M: pk.stiffness.extremal_stiffness(M)[0])(K)
    assert_close(d, 0.5 * np.eye(2))
    # elsewhere it equals eigvalsh and its derivative the eigenvector outer product
    M = jnp.array([[5.0, 1.5], [1.5, 2.0]])
    w, v = np.linalg.eigh(np.asarray(M))
    assert_close(pk.stiffness.extremal_stiffness(M), w, rtol=1e-14)
    assert_close(
        jax.grad(lambda A: pk.stiffness.extremal_stiffness(A)[0])(M), np.outer(v[:, 0], v[:, 0]), rtol=1e-12, atol=1e-15
    )


# --- 4. the unrolled structured algebra against jnp.linalg ------------------------------------


def test_unrolled_condensation_and_inverse_match_jnp_linalg(p4, interior):
    rng = np.random.default_rng(5)
    for n, kept in ((4, [1, 3]), (9, [0, 4, 8]), (15, [3, 7])):
        A = rng.normal(size=(n, n))
        K = A @ A.T + n * np.eye(n)
        K[0, 1] = K[1, 0] = 0.0  # zeros stay numeric entries here
        entries = [[jnp.asarray(v) for v in row] for row in K]
        cond = [i for i in range(n) if i not in kept]
        ref = K[np.ix_(kept, kept)] - K[np.ix_(kept, cond)] @ np.asarray(
            jnp.linalg.solve(K[np.ix_(cond, cond)], K[np.ix_(cond, kept)])
        )
        assert_close(st._to_array(st._schur_entries(entries, kept)), ref, rtol=1e-12)
        assert_close(st._to_array(st._inverse_entries(entries)), jnp.linalg.inv(K), rtol=1e-10, atol=1e-14)
    # structural zeros: a block-diagonal matrix keeps its blocks apart
    blocks = [
        [jnp.asarray(2.0), jnp.asarray(1.0), 0],
        [jnp.asarray(1.0), jnp.asarray(3.0), 0],
        [0, 0, jnp.asarray(4.0)],
    ]
    inv = st._inverse_entries(blocks)
    assert inv[0][2] == 0 and inv[2][0] == 0
    assert_close(st._to_array(inv), np.linalg.inv([[2.0, 1.0, 0.0], [1.0, 3.0, 0.0], [0.0, 0.0, 4.0]]), rtol=1e-14)
    # the five-bar: unrolled output stiffness == dense Schur complement by jnp.linalg
    for x in interior:
        K15 = np.asarray(fb.stiffness_matrix(jnp.asarray(x), p4))
        kept = list(fb.C_PLANE)
        cond = [i for i in range(15) if i not in kept]
        ref = K15[np.ix_(kept, kept)] - K15[np.ix_(kept, cond)] @ np.asarray(
            jnp.linalg.solve(K15[np.ix_(cond, cond)], K15[np.ix_(cond, kept)])
        )
        assert_close(fb.output_stiffness(jnp.asarray(x), p4), ref, rtol=1e-9, atol=1e-9 * np.abs(ref).max())
    # and the generic element_rotation route of the frame agrees with P4's structural rotations
    x = jnp.asarray(interior[0])
    nodes = fb.frame_nodes(x, fb.mechanism.inverse(x, p4), p4)
    assert_close(
        fb.FRAME.condensed_stiffness(nodes, p4.section, fb.C_PLANE_DOFS), fb.output_stiffness(x, p4), rtol=1e-10
    )
    with pytest.raises(ValueError, match="kept"):
        fb.FRAME.condensed_stiffness(nodes, p4.section, (pk.stiffness.node_dof(fb.C, st.THETA_Y),))


# --- compile once: the map and the probes take the model as arguments ---------------------


def test_map_and_probes_compile_once_per_model(p4, raw):
    grid = pk.Grid.from_ranges(x_C=(-100.0, 200.0, 100.0), z_C=(60.0, 300.0, 80.0))
    keys = ("k_worst", "worst_direction", "det_A")
    maps = fb.stiffness_map(grid, p4, T_MAX, keys=keys)
    pts = grid.points().reshape(-1, 2)
    ref = fb.pose_stiffness_jit(pts, p4, T_MAX)
    for k in keys:
        a, b = maps[k].reshape((-1,) + maps[k].shape[2:]), np.asarray(ref[k])
        assert np.array_equal(np.isnan(a), np.isnan(b))
        assert_close(a[np.isfinite(a)], b[np.isfinite(b)], rtol=1e-12, atol=1e-12)
    assert np.isfinite(maps["k_worst"]).sum() >= 6
    # other parameters and loads: no new compilation
    stiffer = dataclasses.replace(p4, section=dataclasses.replace(p4.section, E=2 * p4.section.E))
    before = fb._pose_many._cache_size(), pk._sweep._compiled.cache_info().misses
    m2 = fb.stiffness_map(grid, stiffer, 1000.0, keys=keys)
    r2 = fb.pose_stiffness_jit(pts, stiffer, 1000.0)
    assert (fb._pose_many._cache_size(), pk._sweep._compiled.cache_info().misses) == before
    ok = np.isfinite(maps["k_worst"])
    assert_close(m2["k_worst"][ok], 2 * maps["k_worst"][ok], rtol=1e-12)
    assert_close(np.asarray(r2["k_worst"])[ok.ravel()], 2 * maps["k_worst"][ok], rtol=1e-12)
    with pytest.raises(ValueError, match="keys"):
        fb.stiffness_map(grid, p4, T_MAX, keys=("k_max",))
    with pytest.raises(ValueError, match="shape"):
        fb.pose_stiffness_jit(jnp.zeros(3), p4)
