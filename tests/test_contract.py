"""The mechanism contract (pkmlib.mechanisms) and the registry of the papers (pkmlib._papers).

As jaxlie's tests run every property over every group, these run the same properties over every
registered mechanism (each paper's ``MECHANISMS``):

- A = dF/dx and B = dF/dq (autodiff) against central differences of F;
- J^-1 against central differences of the closed-form inverse position, and J J^-1 = I;
- det(A) changes sign across the singular curves refined on a small grid (a slice of x through a
  pose of the paper), and A is singular there (smallest singular value, independent of det);
- inverse then forward is the identity on every branch (every sign pattern) that reaches the pose:
  pk.forward_position from a perturbed guess returns the pose, and F(x, q) = 0 there;
- NaN outside the workspace, on every branch.

Each case holds one pose of the paper (inside the workspace on the paper's branch), a pose
outside, and the slice of the singular-curve check; everything else comes from the module.
"""

import functools
import importlib
import re
import warnings
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import yaml

import pkmlib as pk
from pkmlib._papers import PAPERS, ROOT
from pkmlib.mechanisms import sign_branches

#: Per mechanism (paper, key): a pose inside the workspace on the paper's branch, a pose outside
#: (None: the model has no workspace limit), and a slice (two output coordinates, their
#: (min, max, step), the others as in the pose) that crosses det(A) = 0.
CASES = {
    ("p1", "4-PRR"): dict(
        x=(0.7, 0.0, np.deg2rad(20.0), 0.14),
        outside=(0.7, 0.4, np.deg2rad(20.0), 0.14),
        slice=(("x_D", 0.5, 0.9, 0.02), ("y_D", -0.12, 0.12, 0.006)),
    ),
    ("p2", "3-RRR"): dict(
        x=(0.2, 0.1155, 0.0), outside=(0.9, 0.9, 0.0), slice=(("x_P", 0.0, 0.4, 0.01), ("y_P", -0.1, 0.3, 0.01))
    ),
    ("p3", "A"): dict(
        x=(37.79, 238.9192053, -0.70973781),
        outside=(37.79, 600.0, -0.7),
        slice=(("z", 120.0, 295.0, 5.0), ("alpha", -1.5, 1.5, 0.05)),
    ),
    ("p3", "B"): dict(
        x=(37.79, 401.19547407, 1.40971341),
        outside=(37.79, 900.0, 1.4),
        slice=(("z_E", 200.0, 420.0, 5.0), ("alpha", 0.2, 2.9, 0.05)),
    ),
    ("p4", "five-bar"): dict(
        x=(50.0, 150.0), outside=(50.0, 400.0), slice=(("x_C", 0.0, 100.0, 2.5), ("z_C", 90.0, 160.0, 2.5))
    ),
    ("p5", "6-PRRS"): dict(
        x=(0.01, -0.02, 0.03, 0.1, 0.2, 0.3), outside=None, slice=(("beta", -2.0, 2.0, 0.1), ("gamma", -1.0, 1.0, 0.1))
    ),
}


def registered():
    """Every (paper, key) of every registered module's MECHANISMS."""
    return [(paper, key) for paper, entry in PAPERS.items() for key in entry.mechanism_module().MECHANISMS]


MECHANISMS = registered()
IDS = [f"{paper}-{key}" for paper, key in MECHANISMS]


def setup(paper, key):
    module = PAPERS[paper].mechanism_module()
    mech = module.MECHANISMS[key]
    params = module.load_params(key)
    x = jnp.asarray(CASES[paper, key]["x"], dtype=jnp.float64)
    return module, mech, params, x


@functools.lru_cache(maxsize=None)
def compiled(paper, key):
    """The mechanism's maps, each compiled once (the parameters and the branch are arguments)."""
    module, mech, p, x = setup(paper, key)

    def inverse(x, p, b):
        return mech.inverse(x, p, None if b is None else b)

    def matrices(x, p, b):
        q = inverse(x, p, b)
        return {
            "q": q,
            "A": pk.A_matrix(mech, x, q, p),
            "B": pk.B_matrix(mech, x, q, p),
            "J_inv": pk.inverse_jacobian(mech, x, q, p),
            "J": pk.jacobian(mech, x, q, p),
            "det_A": pk.det_A(mech, x, q, p),
        }

    def det(x, p, b):
        return pk.det_A(mech, x, inverse(x, p, b), p)

    return {
        "F": batched(jax.jit(jax.vmap(mech.constraints, in_axes=(0, 0, None)))),
        "inverse": batched(jax.jit(jax.vmap(inverse, in_axes=(0, None, None)))),
        "matrices": batched(jax.jit(jax.vmap(matrices, in_axes=(0, None, None)))),
        "det_A": jax.jit(jax.vmap(det, in_axes=(0, None, None))),
    }


#: Every batched call but the grid's runs on this many points (padded), so each compiles once.
BATCH = 16


def batched(f):
    """``f`` on batches padded to :data:`BATCH` points (its batched arguments lead, ``(m, n)``)."""

    def call(*args):
        m = len(args[0])
        assert m <= BATCH
        padded = [
            jnp.concatenate([a, jnp.broadcast_to(a[-1:], (BATCH - m,) + a.shape[1:])])
            if isinstance(a, jax.Array) and a.ndim == 2 and len(a) == m
            else a
            for a in args
        ]
        return jax.tree_util.tree_map(lambda v: v[:m], f(*padded))

    return call


def paper_branch(module, key):
    b = module.PAPER_BRANCH
    return b[key] if isinstance(b, dict) else b


def branches(mech):
    return sign_branches(mech.branch_size) if mech.branch_size else (None,)


def as_branch(b):
    return None if b is None else jnp.asarray(b, dtype=jnp.float64)


def central(f, z, h):
    """Columns d f / d z_k by central differences (step h_k): ``f`` maps a batch of points
    ``(m, n)`` to ``(m, ...)``."""
    z = np.asarray(z, dtype=np.float64)
    E = np.diag(h)
    values = np.asarray(f(jnp.asarray(np.concatenate([z + E, z - E]))))
    n = z.size
    return np.moveaxis(
        (values[:n] - values[n:]) / (2.0 * np.asarray(h)).reshape((n,) + (1,) * (values.ndim - 1)), 0, -1
    )


def steps(v):
    return 1e-6 * np.maximum(np.abs(np.asarray(v)), 1.0)


# --- the contract's names -------------------------------------------------------------------------


def test_every_case_is_registered_and_every_registered_mechanism_has_a_case():
    assert set(CASES) == set(MECHANISMS)


@pytest.mark.parametrize("paper", list(PAPERS))
def test_module_exposes_the_contract(paper):
    module = PAPERS[paper].mechanism_module()
    assert module.PAPER == paper
    assert isinstance(module.UNITS, dict) and module.UNITS["length"] in ("m", "mm") and module.UNITS["angle"] == "rad"
    assert module.MECHANISMS and all(isinstance(m, pk.Mechanism) for m in module.MECHANISMS.values())
    if len(module.MECHANISMS) == 1:
        assert module.mechanism is next(iter(module.MECHANISMS.values()))
    raw = pk.load_params(paper)
    for key, mech in module.MECHANISMS.items():
        p = module.load_params(key)
        assert type(p).from_dict(raw) == p  # from_dict takes the whole file
        assert (
            module.load_params(key, source=raw)
            == p
            == module.load_params(key, source=PAPERS[paper].path("params_file"))
        )
        assert set(mech.output_units) | set(mech.actuator_units) <= set(module.UNITS.values()), key
        assert mech.default_branch == (
            None if paper_branch(module, key) is None else tuple(float(s) for s in paper_branch(module, key))
        )
        x = CASES[paper, key]["x"]
        assert np.array_equal(np.asarray(module.pose(*x)), np.asarray(x, dtype=np.float64))
    for name in ("pose", "draw", "load_params"):
        assert callable(getattr(module, name)), name
    with pytest.raises(ValueError, match="key"):
        module.load_params("no such mechanism")


@pytest.mark.parametrize(
    ("module_name", "old", "new"),
    [
        ("three_rrr", "DEFAULT_BRANCH", lambda m: m.PAPER_BRANCH),
        ("five_bar", "WORKING_MODE", lambda m: m.PAPER_BRANCH),
        ("two_t_one_r", "TABLE1_ROW1_BRANCH_A", lambda m: m.FORWARD_BRANCHES["A"][0]),
        ("two_t_one_r", "TABLE1_BRANCHES_A", lambda m: m.FORWARD_BRANCHES["A"]),
        ("two_t_one_r", "TABLE2_BRANCHES_A", lambda m: m.INVERSE_BRANCHES["A"]),
        ("two_t_one_r", "FK_BRANCHES_B", lambda m: m.FORWARD_BRANCHES["B"]),
        ("two_t_one_r", "IK_BRANCHES_B", lambda m: m.INVERSE_BRANCHES["B"]),
    ],
)
def test_old_names_still_work_and_warn(module_name, old, new):
    module = importlib.import_module(f"pkmlib.mechanisms.{module_name}")
    with pytest.warns(DeprecationWarning, match=re.escape(old)):
        value = getattr(module, old)
    assert value == new(module)
    with pytest.raises(AttributeError):
        _ = module.NO_SUCH_NAME


def test_old_values_of_the_branch_constants():
    from pkmlib.mechanisms import five_bar, three_rrr, two_t_one_r as m3

    assert three_rrr.PAPER_BRANCH == (1, 1, 1) and five_bar.PAPER_BRANCH == (1, -1)
    assert m3.FORWARD_BRANCHES["A"] == (1.0, -1.0)
    assert m3.INVERSE_BRANCHES["A"] == ((1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0))
    assert m3.INVERSE_BRANCHES["B"] == sign_branches(3) and m3.FORWARD_BRANCHES["B"] == sign_branches(2)
    assert m3.PAPER_BRANCH == {"A": (-1.0, -1.0), "B": (-1.0, -1.0, -1.0)}


def test_p3_draw_from_a_pose_draws_the_joint_points_of_the_inverse_position():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from pkmlib.mechanisms import two_t_one_r as m3

    for key in ("A", "B"):
        p = m3.load_params(key)
        x = jnp.asarray(CASES["p3", key]["x"])
        fig = plt.figure()
        q = m3.draw(fig.add_subplot(projection="3d"), x, p)
        assert np.allclose(q, m3.MECHANISMS[key].inverse(x, p))
        with pytest.warns(DeprecationWarning, match="draw_points"):
            m3.draw(
                fig.add_subplot(projection="3d"),
                key,
                m3.joint_points_a(x, q, p) if key == "A" else m3.joint_points_b(x, q, p),
            )
        with pytest.raises(ValueError, match="outside the workspace"):
            m3.draw(fig.add_subplot(projection="3d"), jnp.asarray(CASES["p3", key]["outside"]), p)
        plt.close(fig)


def test_p5_mechanism_is_its_actuator_coordinates():
    """P5's constraint equations give the carriages of decoupled_6dof.actuator_coordinates, and its
    J^-1 maps to wrench_jacobian by the angle-rate map (independent route: jacfwd of R(I + [w]x))."""
    from pkmlib.mechanisms import decoupled_6dof as m5

    p = m5.load_params()
    x = jnp.asarray(CASES["p5", "6-PRRS"]["x"])
    position, rotation = m5.position_rotation(x)
    m = at_pose("p5", "6-PRRS", x)
    assert np.allclose(m["q"], m5.actuator_coordinates(position, rotation, p), rtol=0, atol=1e-15)
    J_inv = m["J_inv"]
    W = np.asarray(jax.jit(m5.wrench_jacobian)(position, rotation, p))
    assert np.allclose(J_inv[:, :3], W[:, :3], atol=1e-14)
    # d(angles) -> body angular velocity: R^T dR/d(angle_k), the vee of that skew matrix
    dR = jax.jacfwd(lambda a: pk.rotation_matrix(a[0], a[1], a[2]))(x[3:])  # (3, 3, 3)
    Omega = np.einsum("ji,jkl->ikl", np.asarray(rotation), np.asarray(dR))
    E = np.stack([Omega[2, 1], Omega[0, 2], Omega[1, 0]])  # (3 body axes, 3 angles)
    assert np.allclose(J_inv[:, 3:], W[:, 3:] @ E, atol=1e-14)


# --- the properties, over every registered mechanism -----------------------------------------------


def at_pose(paper, key, x, b=None):
    """Every matrix at one pose on branch ``b`` (default the paper's), through the compiled maps."""
    module, mech, p, _ = setup(paper, key)
    b = paper_branch(module, key) if b is None else b
    out = compiled(paper, key)["matrices"](jnp.asarray(x)[None], p, as_branch(b))
    return {k: np.asarray(v[0]) for k, v in out.items()}


@pytest.mark.parametrize(("paper", "key"), MECHANISMS, ids=IDS)
def test_A_and_B_against_central_differences(paper, key):
    module, mech, p, x = setup(paper, key)
    m = at_pose(paper, key, x)
    F = compiled(paper, key)["F"]
    q = m["q"]
    A_fd = central(lambda z: F(z, jnp.broadcast_to(q, (len(z), q.size)), p), x, steps(x))
    B_fd = central(lambda z: F(jnp.broadcast_to(x, (len(z), x.size)), z, p), q, steps(q))
    for M, M_fd in ((m["A"], A_fd), (m["B"], B_fd)):
        assert M.shape == M_fd.shape == (mech.n_actuators, M_fd.shape[1])
        assert np.allclose(M, M_fd, rtol=1e-6, atol=1e-7 * np.max(np.abs(M_fd)))


@pytest.mark.parametrize(("paper", "key"), MECHANISMS, ids=IDS)
def test_inverse_jacobian_is_the_derivative_of_the_inverse_position_and_J_inverts_it(paper, key):
    module, mech, p, x = setup(paper, key)
    m = at_pose(paper, key, x)
    inverse = compiled(paper, key)["inverse"]
    J_inv_fd = central(lambda z: inverse(z, p, as_branch(paper_branch(module, key))), x, steps(x))
    assert np.allclose(m["J_inv"], J_inv_fd, rtol=1e-6, atol=1e-7 * np.max(np.abs(J_inv_fd)))
    n = mech.n_actuators
    assert np.allclose(m["J"] @ m["J_inv"], np.eye(n), atol=1e-10)
    assert np.allclose(m["J_inv"] @ m["J"], np.eye(n), atol=1e-10)


@pytest.mark.parametrize(("paper", "key"), MECHANISMS, ids=IDS)
def test_det_A_changes_sign_across_the_refined_singular_curves(paper, key):
    module, mech, p, x0 = setup(paper, key)
    (name_u, *range_u), (name_v, *range_v) = CASES[paper, key]["slice"]
    iu, iv = mech.output_names.index(name_u), mech.output_names.index(name_v)
    grid = pk.Grid.from_ranges(**{name_u: tuple(range_u), name_v: tuple(range_v)})
    b = as_branch(paper_branch(module, key))
    maps = compiled(paper, key)["matrices"]

    def poses(points):
        points = jnp.atleast_2d(points)
        return jnp.broadcast_to(x0, (len(points), x0.size)).at[:, iu].set(points[:, 0]).at[:, iv].set(points[:, 1])

    def det(point):  # one point, for the bisection (vmapped there)
        x = x0.at[iu].set(point[0]).at[iv].set(point[1])
        return pk.det_A(mech, x, mech.inverse(x, p, None if b is None else b), p)

    points = np.stack(np.meshgrid(*grid.axes, indexing="ij"), axis=-1).reshape(-1, 2)
    values = np.asarray(compiled(paper, key)["det_A"](poses(points), p, b)).reshape(grid.shape)
    roots, axis = pk.singular_crossings(det, grid, values)
    roots, axis = roots[axis >= 0], axis[axis >= 0]
    assert len(roots) >= 3, f"{paper} {key}: the slice crosses no singular curve"
    every = max(1, len(roots) // 5)
    roots, axis = roots[::every][:5], axis[::every][:5]
    d = np.zeros_like(roots)
    d[np.arange(len(roots)), axis] = 1e-5 * np.asarray(grid.steps)[axis]
    lo = np.asarray(maps(poses(roots - d), p, b)["det_A"])
    hi = np.asarray(maps(poses(roots + d), p, b)["det_A"])
    assert np.all(lo * hi < 0), f"{paper} {key}: det(A) keeps its sign across {roots[lo * hi >= 0]}"
    s = np.linalg.svd(np.asarray(maps(poses(roots), p, b)["A"]), compute_uv=False)
    assert np.all(s[:, -1] < 1e-6 * s[:, 0]), f"{paper} {key}: A is not singular at the refined roots ({s})"


@pytest.mark.parametrize(("paper", "key"), MECHANISMS, ids=IDS)
def test_inverse_then_forward_is_the_identity_on_every_branch(paper, key):
    module, mech, p, x = setup(paper, key)
    inverse, F = compiled(paper, key)["inverse"], compiled(paper, key)["F"]
    assert np.all(np.isfinite(np.asarray(inverse(x[None], p, as_branch(paper_branch(module, key))))))
    guess = np.asarray(x) + 1e-4 * np.maximum(np.abs(np.asarray(x)), 1e-2)
    scale = max(1.0, float(jnp.max(jnp.abs(x)))) ** 2
    tested = 0
    for b in branches(mech):
        q = inverse(x[None], p, as_branch(b))
        if not np.all(np.isfinite(np.asarray(q))):
            continue  # this branch does not reach the pose
        tested += 1
        assert float(jnp.max(jnp.abs(F(x[None], q, p)))) < 1e-12 * scale, b
        x_back = pk.forward_position(mech, q[0], p, guess, tol=1e-13 * scale)
        assert np.allclose(x_back, x, rtol=1e-10, atol=1e-10), (b, x_back)
        assert np.allclose(inverse(jnp.asarray(x_back)[None], p, as_branch(b)), q, rtol=1e-9, atol=1e-9)
    assert tested >= (2 if mech.branch_size else 1)


@pytest.mark.parametrize(("paper", "key"), MECHANISMS, ids=IDS)
def test_nan_outside_the_workspace_on_every_branch(paper, key):
    module, mech, p, _ = setup(paper, key)
    outside = CASES[paper, key]["outside"]
    if outside is None:
        pytest.skip(f"{mech.name}: the paper gives no carriage travel, so every pose has its carriages")
    x = jnp.asarray(outside)
    for b in branches(mech):
        m = at_pose(paper, key, x, b)
        assert np.all(np.isnan(m["q"])) and np.isnan(m["det_A"]) and np.all(np.isnan(m["J_inv"])), (b, m["q"])


# --- the registry ----------------------------------------------------------------------------------


def test_registry_files_exist_and_every_paper_notebook_is_registered():
    for paper in PAPERS.values():
        for name in ("notebook", "params_file", "reference_file", "results_file"):
            assert paper.path(name).is_file(), (paper.key, name)
        assert Path(paper.notebook).name.startswith(f"{paper.key}_")
        assert re.fullmatch(r"(doi:10\.\S+|https://\S+|)", paper.doi_or_url), paper.doi_or_url
    notebooks = {f"notebooks/{nb.name}" for nb in (ROOT / "notebooks").glob("p[0-9]*_*.ipynb")}
    assert notebooks == {p.notebook for p in PAPERS.values()}
    bib = (ROOT / "references.bib").read_text(encoding="utf-8")
    for paper in PAPERS.values():
        assert f"@article{{{paper.citation_key}," in bib, paper.citation_key
        if paper.doi_or_url.startswith("doi:"):
            assert f"doi      = {{{paper.doi_or_url[4:]}}}" in bib, paper.key
        elif paper.doi_or_url:
            assert f"url      = {{{paper.doi_or_url}}}" in bib, paper.key


def test_quarto_papers_section_is_the_registry():
    """The site's sidebar section "Papers" lists exactly the registered notebooks, in order, with
    their titles."""
    sidebar = yaml.safe_load((ROOT / "_quarto.yml").read_text(encoding="utf-8"))["website"]["sidebar"]["contents"]
    section = next(item for item in sidebar if isinstance(item, dict) and item.get("section") == "Papers")
    assert [(e["href"], e["text"]) for e in section["contents"]] == [(p.notebook, p.title) for p in PAPERS.values()]


def test_reference_files_name_the_registered_notebooks():
    for paper in PAPERS.values():
        assert pk.tools.load_reference_file(paper.key)["notebook"] == paper.notebook


def test_contract_names_raise_no_warning():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for paper in PAPERS.values():
            module = paper.mechanism_module()
            for name in ("PAPER", "UNITS", "MECHANISMS", "PAPER_BRANCH", "pose", "draw", "load_params"):
                getattr(module, name)
