"""Every name exported by pkmlib checks what it is given, or says it takes anything.

``BAD_CALLS`` maps each exported name to bad calls and the argument each must name: every call
must raise ``ValueError`` whose message names that argument (and so what is accepted), never
return a finite wrong number. ``TAKES_ANYTHING`` lists the names that take no argument to check
(constants, result records, exceptions), each with the reason. ``test_every_exported_name_is_covered``
walks ``pkmlib.__all__`` and the ``__all__`` of each subpackage (``pkmlib.stiffness``,
``pkmlib.dynamics``, ``pkmlib.design``, ``pkmlib.tools``; one name, one home) and fails for a name
in neither table, telling how to add it.

Traced values (inside ``jit``/``vmap``) are checked by ``equinox.error_if`` where a call runs
once (``pk.dynamics.integrate``'s time step and mass: the error is raised when the compiled call runs, as
JAX's runtime error carrying the same message), or give NaN where the check would sit in a
per-pose map (the speeds and loads of the criteria): see the tests at the end.
"""

from __future__ import annotations

import functools
import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import pkmlib as pk
from pkmlib.mechanisms import five_bar as fb
from pkmlib.mechanisms import decoupled_6dof as p5
from pkmlib.mechanisms import gripper_4prr as p1
from pkmlib.mechanisms import three_rrr as p2
from pkmlib.mechanisms import two_t_one_r as p3


# --- fixtures: small, valid inputs, built once --------------------------------------------------


@functools.lru_cache(maxsize=None)
def _p4():
    return fb.FiveBarParams.from_dict(pk.load_params("p4"))


URDF = "tests/data/example_parallel_robots_5bar/robot.urdf"
ROBOT_YAML = "tests/data/example_parallel_robots_5bar/robot.yaml"
X4 = jnp.array([50.0, 200.0])  # a pose of P4's five-bar inside its workspace, mm


def _q4():
    return fb.mechanism.inverse(X4, _p4(), fb.PAPER_BRANCH)


@functools.lru_cache(maxsize=None)
def _p1():
    return p1.load_params()


@functools.lru_cache(maxsize=None)
def _p2():
    return p2.load_params()


@functools.lru_cache(maxsize=None)
def _p3(which):
    return p3.load_params(which)


@functools.lru_cache(maxsize=None)
def _p5():
    return p5.load_params()


J2 = jnp.array([[1.0, 0.5], [0.2, 2.0]])
J4 = jnp.eye(4) + 0.1
GROUPS = ((0, 1), (2,), (3,))
GRID = pk.Grid.from_ranges(x=(0.0, 1.0, 0.5), y=(0.0, 1.0, 0.5))
SECTION_VALUES = dict(E=2e5, G=8e4, A=100.0, I_y=1e3, I_z=1e3, I_p=2e3)
SECTION = pk.stiffness.BeamSection(**SECTION_VALUES)
STATE = pk.dynamics.RigidBodyState(position=jnp.zeros(3), velocity=jnp.zeros(3), rotation=jnp.eye(3), omega=jnp.ones(3))
INERTIA = jnp.array([1.0, 2.0, 3.0])
BOUNDS = [(0.0, 1.0), (0.0, 1.0)]
K2 = jnp.array([[2.0, 0.5], [0.5, 1.0]])


def _objective(d):
    return -jnp.sum((d - 0.3) ** 2)


def _no_wrench(t, state):
    return jnp.zeros(3), jnp.zeros(3)


def _fn(p):
    return p[0] - 0.5


def _slider_pose(q):
    """One body translating along x with the actuator: centres (1, 3), orientations (1, 3, 3)."""
    return jnp.stack([q[0], 0.0 * q[0], 0.0 * q[0]])[None], jnp.eye(3)[None]


SLIDER = dict(
    pose=_slider_pose,
    masses=jnp.array([2.0]),
    inertias=jnp.eye(3)[None],
    gravity=jnp.array([0.0, 0.0, -9.81]),
    forces=jnp.zeros((1, 3)),
    trajectory=pk.dynamics.state_trajectory(jnp.zeros(1), jnp.zeros(1), jnp.ones(1)),
    t=jnp.zeros(1),
)
ASYMMETRIC = jnp.array([[[1.0, 0.2, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]])
INDEFINITE = jnp.diag(jnp.array([1.0, -1.0, 1.0]))[None]
COUPLED = jnp.array([[[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]])  # zero diagonal, not semidefinite


def _dynamics_calls(name):
    f = getattr(pk.dynamics, name)
    return [
        (lambda: f(**(SLIDER | {"masses": jnp.array([-1.0])})), "masses"),
        (lambda: f(**(SLIDER | {"masses": jnp.array([jnp.nan])})), "masses"),
        (lambda: f(**(SLIDER | {"masses": 2.0})), "masses"),
        (lambda: f(**(SLIDER | {"inertias": ASYMMETRIC})), "inertias"),
        (lambda: f(**(SLIDER | {"inertias": INDEFINITE})), "inertias"),
        (lambda: f(**(SLIDER | {"inertias": COUPLED})), "inertias"),
        (lambda: f(**(SLIDER | {"inertias": jnp.eye(3)})), "inertias"),
        (lambda: f(**(SLIDER | {"gravity": jnp.zeros(2)})), "gravity"),
        (lambda: f(**(SLIDER | {"forces": jnp.full((1, 3), jnp.inf)})), "forces"),
        (lambda: f(**(SLIDER | {"t": jnp.zeros(0)})), "t"),
        (lambda: f(**(SLIDER | {"t": jnp.array([0.0, jnp.nan])})), "t"),
        (lambda: f(**(SLIDER | {"pose": "slider"})), "pose"),
    ]


_TOY = dict(
    name="toy",
    chain_constraint=lambda i, x, q, p: x[0] - q,
    actuator_limits=lambda p: (jnp.zeros(1), jnp.ones(1)),
    output_names=("x",),
    output_units=("m",),
    actuator_names=("q",),
    actuator_units=("m",),
)


# --- the table: name -> [(bad call, the argument its message names)] ---------------------------

BAD_CALLS = {
    "load_mechanism": [
        (lambda: pk.load_mechanism(3), "path_or_dict"),
        (lambda: pk.load_mechanism("no/such/file.yaml"), "path_or_dict"),
        (lambda: pk.load_mechanism(None), "path_or_dict"),
        (lambda: pk.load_mechanism({"name": "x"}), "missing key"),
    ],
    "load_urdf_mechanism": [
        (lambda: pk.load_urdf_mechanism("no/such/robot.urdf", "robot.yaml"), "urdf"),
        (lambda: pk.load_urdf_mechanism(URDF, "no/such/robot.yaml"), "closures_yaml"),
        (lambda: pk.load_urdf_mechanism(URDF, ROBOT_YAML, "no_such_frame"), "output_frame"),
        (lambda: pk.load_urdf_mechanism(URDF, ROBOT_YAML, name=3), "name"),
        (lambda: pk.load_urdf_mechanism(URDF, ROBOT_YAML, coordinates=("u",)), "coordinates"),
        (lambda: pk.load_urdf_mechanism(URDF, ROBOT_YAML, coordinates=("u", "u")), "coordinates"),
        (lambda: pk.load_urdf_mechanism(URDF, ROBOT_YAML, coordinates="uv"), "coordinates"),
        (lambda: pk.load_urdf_mechanism(3, ROBOT_YAML), "urdf"),
        (lambda: pk.load_urdf_mechanism(None, ROBOT_YAML), "urdf"),
        (lambda: pk.load_urdf_mechanism(URDF, 3), "closures_yaml"),
        (lambda: pk.load_urdf_mechanism(URDF, None), "closures_yaml"),
    ],
    "inverse_positions": [
        (lambda: pk.inverse_positions(fb.mechanism, X4, _p4(), (2, 1)), "branch"),
        (lambda: pk.inverse_positions(fb.mechanism, jnp.ones(3), _p4()), "x"),
        (lambda: pk.inverse_positions(fb.mechanism, X4, _p4(), samples=-1), "samples"),
        (lambda: pk.inverse_positions(fb.mechanism, X4, _p4(), iterations=0), "iterations"),
        (lambda: pk.inverse_positions(fb.mechanism, X4, _p4(), structure="upper"), "structure"),
        (lambda: pk.inverse_positions(fb.mechanism, X4, _p4(), search_interval=[[1, 0], [0, 1]]), "search_interval"),
        (lambda: pk.inverse_positions(fb.mechanism, X4, _p4(), starts_per_axis=0), "starts_per_axis"),
        (lambda: pk.inverse_positions("five_bar", X4, _p4()), "mech"),
        (lambda: pk.inverse_positions(None, X4, _p4()), "mech"),
        (lambda: pk.inverse_positions(fb.mechanism, X4, _p4(), residuals="yes"), "residuals"),
        # a huge samples or starts_per_axis was compiled and allocated (no check_memory)
        (lambda: pk.inverse_positions(fb.mechanism, X4, _p4(), samples=10**12), "samples", pk.MemoryBudgetError),
        (
            lambda: pk.inverse_positions(fb.mechanism, X4, _p4(), structure="general", starts_per_axis=10**7),
            "starts_per_axis",
            pk.MemoryBudgetError,
        ),
    ],
    "forward_positions": [
        (lambda: pk.forward_positions(fb.mechanism, _q4(), _p4(), "x"), "box"),
        (lambda: pk.forward_positions(fb.mechanism, _q4(), _p4(), [[-500, 500], [-500, 500]], tol=float("nan")), "tol"),
        (
            lambda: pk.forward_positions(fb.mechanism, _q4(), _p4(), [[-500, 500], [-500, 500]], max_modes=0),
            "max_modes",
        ),
        (lambda: pk.forward_positions(fb.mechanism, _q4(), _p4(), [[500.0, 500.0], [-500.0, -500.0]]), "box"),
        (lambda: pk.forward_positions(fb.mechanism, jnp.ones(3), _p4(), [[-500.0, -500.0], [500.0, 500.0]]), "q"),
        (
            lambda: pk.forward_positions(fb.mechanism, _q4(), _p4(), [[-500.0, -500.0], [500.0, 500.0]], dedup_tol=0),
            "dedup_tol",
        ),
        (
            lambda: pk.forward_positions(
                fb.mechanism, _q4(), _p4(), [[-500.0, -500.0], [500.0, 500.0]], iterations=1.5
            ),
            "iterations",
        ),
        (
            lambda: pk.forward_positions(
                fb.mechanism, _q4(), _p4(), [[-500.0, -500.0], [500.0, 500.0]], starts_per_axis=0
            ),
            "starts_per_axis",
        ),
        (lambda: pk.forward_positions("five_bar", _q4(), _p4(), [[-500.0, -500.0], [500.0, 500.0]]), "mech"),
        (lambda: pk.forward_positions(None, _q4(), _p4(), [[-500.0, -500.0], [500.0, 500.0]]), "mech"),
        (
            lambda: pk.forward_positions(
                fb.mechanism, _q4(), _p4(), [[-500.0, -500.0], [500.0, 500.0]], starts_per_axis=10**4
            ),
            "starts_per_axis",
            pk.MemoryBudgetError,
        ),
    ],
    "within_limits": [
        (lambda: pk.within_limits(jnp.ones(2), jnp.array([1.0, 2.0]), jnp.array([2.0, 1.0])), "q_min"),
        (lambda: pk.within_limits(jnp.ones(2), jnp.nan, 1.0), "q_min"),
        (lambda: pk.within_limits(jnp.ones(2), jnp.zeros(3), 1.0), "q_min"),
        (lambda: pk.within_limits(jnp.ones(2), 0.0, jnp.ones((2, 2))), "q_max"),
        (lambda: pk.within_limits("q", 0.0, 1.0), "q"),
    ],
    "Mechanism": [
        (lambda: p3.sinusoidal_inputs(0.0, jnp.zeros(3), jnp.zeros(2), 1.0), "amplitude"),
        (lambda: p3.sinusoidal_inputs(0.0, jnp.zeros(4), jnp.zeros(3), 1.0), "rho"),
        (lambda: p3.sinusoidal_trajectory(jnp.zeros(3), jnp.zeros(2), 1.0)(0.0), "amplitude"),
        (lambda: p5.printed_digits(0.5, -1), "decimals"),
        (lambda: p5.printed_digits(0.5, 1.5), "decimals"),
        (lambda: pk.Mechanism(**(_TOY | {"name": ""})), "name"),
        (lambda: pk.Mechanism(**(_TOY | {"output_units": ("m", "m")})), "output_units"),
        (lambda: pk.Mechanism(**(_TOY | {"actuator_names": "q"})), "actuator_names"),
        (lambda: pk.Mechanism(**(_TOY | {"actuator_names": (), "actuator_units": ()})), "actuator_names"),
        (lambda: pk.Mechanism(**(_TOY | {"actuator_limits": (0.0, 1.0)})), "actuator_limits"),
        (lambda: pk.Mechanism(**(_TOY | {"inverse_position": 3})), "inverse_position"),
        (lambda: pk.Mechanism(**(_TOY | {"chain_constraint": "x - q"})), "chain_constraint"),
        (lambda: pk.Mechanism(**(_TOY | {"default_branch": (2,)})), "default_branch"),
        (lambda: pk.Mechanism(**(_TOY | {"output_names": ("x", "x"), "output_units": ("m", "m")})), "output_names"),
        # Mechanism.inverse: a pose of 3 numbers for a planar one was read as its first two (a finite wrong q)
        (lambda: fb.mechanism.inverse(jnp.ones(3), _p4(), fb.PAPER_BRANCH), "x"),
        (lambda: fb.mechanism.inverse(jnp.ones((3, 4)), _p4(), fb.PAPER_BRANCH), "x"),
        (lambda: fb.mechanism.inverse(1.0, _p4(), fb.PAPER_BRANCH), "x"),
        (lambda: fb.stiffness_matrix(jnp.ones(3), _p4()), "x"),
        # five_bar's force limit: a negative T_max gave a mirrored parallelogram (finite, wrong)
        (lambda: fb.force_parallelogram(jnp.eye(2), -1.0), "T_max"),
        (lambda: fb.force_parallelogram(jnp.eye(3), 1.0), "J_inv"),
        (lambda: fb.pose_stiffness(X4, _p4(), T_max=-1.0), "T_max"),
        (lambda: fb.pose_stiffness_jit(X4, _p4(), T_max=float("nan")), "T_max"),
        (lambda: fb.stiffness_map(GRID, _p4(), T_max=-1.0), "T_max"),
        (lambda: fb.printed_matrix("Q", 100.0, SECTION), "name"),  # was a KeyError
        (lambda: fb.printed_matrix("M", -100.0, SECTION), "L"),  # was a finite matrix
        (lambda: fb.printed_matrix("M", 100.0, "steel"), "s"),
        (lambda: fb.joint_points(X4, jnp.ones(3), _p4()), "q"),  # was read as its first two angles
        (lambda: fb.frame_nodes(jnp.ones(3), _q4(), _p4()), "x"),
        # P1 (gripper_4prr): a 3-vector pose was read as (x_D, y_D, phi, s) with s = x[3] missing
        # (an IndexError) and a 5-vector as its first four (finite, wrong); chain 7 was an IndexError
        (lambda: p1.joint_points(jnp.ones(5), _p1()), "x"),
        (lambda: p1.joint_points(jnp.ones(3), _p1()), "x"),
        (lambda: p1.inverse_position(jnp.ones(5), _p1(), p1.PAPER_BRANCH), "x"),
        (lambda: p1.chain_constraint(7, jnp.ones(4), 0.1, _p1()), "i"),
        (lambda: p1.lambda_link_angle_deg(0.1, (-1.0, 1.0)), "lengths"),  # was a finite angle
        (lambda: p1.type2_line_crossings(np.ones(3), 0.5, atol=-1.0), "atol"),
        (lambda: p1.force_peak_offsets(np.ones((3, 3)), np.ones((3, 3), bool), np.arange(3.0), {}, band=-1.0), "band"),
        (lambda: p1.force_peak_rows(np.arange(3.0), np.ones(3), {}, band=float("nan")), "band"),
        # P2 (three_rrr): a chain index past 3 was an IndexError, a 4-vector pose read as its first three
        (lambda: p2.platform_joint(5, jnp.zeros(3), _p2()), "i"),
        (lambda: p2.elbow(-4, 0.0, _p2()), "i"),
        (lambda: p2.platform_joint(0, jnp.zeros(4), _p2()), "x"),
        (lambda: p2.inverse_position(jnp.ones(4), _p2(), p2.PAPER_BRANCH), "x"),
        # P3 (two_t_one_r): 2-vector inputs or poses gave finite wrong numbers, a 4-sign branch was
        # read as its first two, a negative voxel gave a negative volume, a 2-vector q passed check_assembly_b
        (lambda: p3.forward_a(jnp.ones(2), _p3("A"), 1.0), "q"),
        (lambda: p3.inverse_a(jnp.ones(2), _p3("A"), jnp.ones(2)), "x"),
        (lambda: p3.inverse_a(p3.pose(0.0, 300.0, 0.0), _p3("A"), (1, 1, 1, 1)), "branch"),
        (lambda: p3.inverse_b(jnp.ones(4), _p3("B"), jnp.ones(3)), "x"),
        (lambda: p3.forward_b(jnp.ones(3), _p3("B"), jnp.ones(3)), "branch"),
        (lambda: p3.constraints_a(jnp.ones(2), jnp.ones(3), _p3("A")), "x"),
        (lambda: p3.joint_points_a(p3.pose(0.0, 300.0, 0.0), jnp.ones(2), _p3("A")), "q"),
        (lambda: p3.discriminant_a(jnp.ones(2), _p3("A")), "q"),
        (lambda: p3.voxel_volume(np.ones((3, 3)), -1.0), "voxel_mm"),
        (lambda: p3.output_velocity(_p3("A"), p3.pose(0.0, 300.0, 0.0), jnp.ones(3), jnp.ones(2)), "qd"),
        (lambda: p3.check_assembly_b(jnp.ones(2), _p3("B")), "inputs_B_mm"),
        (lambda: p3.inverse_solutions_b(jnp.ones(2), _p3("B")), "x"),
        # P5 (decoupled_6dof): a 5-vector pose was read as its first entries (finite, wrong); a
        # 2-vector position, a 2x2 rotation or 5 forces were raw broadcasting TypeErrors
        (lambda: p5.position_rotation(jnp.zeros(5)), "x"),
        (lambda: p5.inverse_position(jnp.zeros(5), _p5()), "x"),
        (lambda: p5.platform_points_base(jnp.zeros(2), jnp.eye(3), _p5()), "position"),
        (lambda: p5.platform_points_base(jnp.zeros(3), jnp.eye(2), _p5()), "rotation"),
        (lambda: p5.axis_screws(jnp.zeros(2), jnp.eye(3)), "position"),
        (lambda: p5.wrench_jacobian(jnp.zeros(3), jnp.eye(2), _p5()), "rotation"),
        (lambda: p5.platform_wrench(jnp.zeros(3), jnp.eye(3), jnp.ones(5), _p5()), "forces"),
        (lambda: p5.potential_energy(jnp.zeros(3), jnp.eye(3), jnp.ones(5), _p5()), "forces"),
        (lambda: p5.translation_closed_form(jnp.zeros(3), jnp.ones(5), _p5(), jnp.zeros(2)), "forces"),
    ],
    "forward_position": [
        (lambda: pk.forward_position(fb.mechanism, _q4(), _p4(), X4, tol=float("nan")), "tol"),
        (lambda: pk.forward_position(fb.mechanism, _q4(), _p4(), X4, tol=0.0), "tol"),
        (lambda: pk.forward_position(fb.mechanism, _q4(), _p4(), X4, max_iter=0), "max_iter"),
        (lambda: pk.forward_position(fb.mechanism, _q4(), _p4(), X4, max_iter=2.5), "max_iter"),
        (lambda: pk.forward_position(fb.mechanism, jnp.zeros(3), _p4(), X4), "q"),
        (lambda: pk.forward_position(fb.mechanism, _q4(), _p4(), jnp.zeros(3)), "x0"),
        (lambda: pk.forward_position("five_bar", _q4(), _p4(), X4), "mech"),
    ],
    "solve_forward_position": [
        (lambda: pk.solve_forward_position(fb.mechanism, _q4(), _p4(), X4, tol=-1.0), "tol"),
        (lambda: pk.solve_forward_position(fb.mechanism, _q4(), _p4(), X4, tol=float("inf")), "tol"),
        (lambda: pk.solve_forward_position(fb.mechanism, _q4(), _p4(), X4, max_iter=-1), "max_iter"),
        (lambda: pk.solve_forward_position(fb.mechanism, _q4(), _p4(), X4, max_iter=1.5), "max_iter"),
        (lambda: pk.solve_forward_position(fb.mechanism, _q4(), _p4(), jnp.zeros(3)), "x0"),
        (lambda: pk.solve_forward_position(fb.mechanism, jnp.zeros((2, 2)), _p4(), X4), "q"),
        (lambda: pk.solve_forward_position(None, _q4(), _p4(), X4), "mech"),
    ],
    "inverse_dynamics_virtual_work": _dynamics_calls("inverse_dynamics_virtual_work"),
    "inverse_dynamics_lagrange": _dynamics_calls("inverse_dynamics_lagrange"),
    "detect_structure": [(lambda: pk.detect_structure("not a mechanism", _p4()), "mech")],
    # notebook parameters and the size guard
    "ParameterSpec": [(lambda: pk.tools.ParameterSpec(kind="colour", paper=1), "kind")],
    "ParameterRule": [
        (lambda: pk.tools.ParameterRule(names="a", test=lambda a: True, accepted=""), "names"),
        (lambda: pk.tools.ParameterRule(names=("a",), test=1, accepted=""), "test"),
    ],
    "less": [(lambda: pk.tools.less(1, "b"), "smaller"), (lambda: pk.tools.less("a", None), "larger")],
    "not_all_zero": [(lambda: pk.tools.not_all_zero(), "names"), (lambda: pk.tools.not_all_zero("a", 2), "names")],
    "check_memory": [
        (lambda: pk.check_memory(-1.0, what="x"), "nbytes"),
        (lambda: pk.check_memory("1e9", what="x"), "nbytes"),
        (lambda: pk.check_memory(10.0, what="x", budget=-1), "budget"),
        (lambda: pk.check_memory(float("nan"), what="x"), "nbytes"),
        (lambda: pk.check_memory(-5, what="x"), "nbytes"),
        (lambda: pk.check_memory(-1e-3, what="x"), "nbytes"),
        (lambda: pk.check_memory(10.0, what="x", budget=float("inf")), "budget"),
        (lambda: pk.check_memory(10.0, what="x", parameter=3), "parameter"),
    ],
    "check_parameter": [
        (lambda: pk.tools.check_parameter("a", 1.0, "number"), "spec"),
        (lambda: pk.tools.check_parameter(3, 1.0, pk.tools.number(1.0)), "name"),
    ],
    "check_parameters": [
        (lambda: pk.tools.check_parameters([1], {}), "values"),
        (lambda: pk.tools.check_parameters({}, [1]), "spec"),
        (lambda: pk.tools.check_parameters({}, {}, rules=[1]), "rules"),
    ],
    "choice": [(lambda: pk.tools.choice("a"), "options"), (lambda: pk.tools.choice("c", "a", "b"), "paper")],
    "flag": [(lambda: pk.tools.flag("yes"), "paper")],
    "memory_budget": [
        (lambda: pk.memory_budget(-5), "budget"),
        (lambda: pk.memory_budget("1G"), "budget"),
        (lambda: pk.memory_budget(float("inf")), "budget"),
        (lambda: pk.memory_budget(float("nan")), "budget"),
    ],
    "number": [
        (lambda: pk.tools.number("1"), "paper"),
        (lambda: pk.tools.check_parameters({"a": 1.0}, {"a": pk.tools.number(1.0, min=2.0)}), "'a'"),
        (lambda: pk.tools.number(1.0, min=float("nan")), "min"),
    ],
    "numbers": [
        (lambda: pk.tools.numbers("abc"), "paper"),
        (lambda: pk.tools.check_parameters({"v": [1.0, 2.0]}, {"v": pk.tools.numbers([1.0, 2.0], shape=(3,))}), "'v'"),
        (lambda: pk.tools.numbers([1.0], shape="3"), "shape"),
        (lambda: pk.tools.numbers([1.0], shape=(1.5,)), "shape"),
        (lambda: pk.tools.numbers([1.0], min=2.0, max=0.0), "min"),
        (lambda: pk.tools.numbers([1.0], unit=None), "unit"),
    ],
    "signs": [(lambda: pk.tools.signs([1, 2]), "paper")],
    "text": [(lambda: pk.tools.text(1), "paper")],
    # the papers' printed values and report tables
    "load_reference_file": [
        (lambda: pk.tools.load_reference_file("p9"), "paper"),
        (lambda: pk.tools.load_reference_file(1), "paper"),
    ],
    "paper_value": [(lambda: pk.tools.paper_value("p1", "no such quantity"), "quantity")],
    "reference_row": [
        (lambda: pk.tools.reference_row("p1", "no such quantity"), "quantity"),
        (lambda: pk.tools.reference_row("p9", "x"), "paper"),
    ],
    "compare_reference": [(lambda: pk.tools.compare_reference("p1", "no such quantity", 1.0), "quantity")],
    "claim_reference": [(lambda: pk.tools.claim_reference("p1", "no such quantity", 1.0, True), "quantity")],
    "markdown_table": [
        (lambda: pk.tools.markdown_table([[1.0]], ["a"], digits=0), "digits"),
        (lambda: pk.tools.markdown_table([[1.0, 2.0]], ["a"]), "headers"),
    ],
    "markdown_table_text": [
        (lambda: pk.tools.markdown_table_text([[1.0]], ["a"], digits=-1), "digits"),
        (lambda: pk.tools.markdown_table_text([[1.0]], ["a"], align=["q"]), "align"),
        (lambda: pk.tools.markdown_table_text(None), "rows"),
        (lambda: pk.tools.markdown_table_text([[1.0], 2.0], ["a"]), "rows[1]"),
        (lambda: pk.tools.markdown_table_text([{"a": 1.0}, [2.0]]), "rows"),
        (lambda: pk.tools.markdown_table_text([[1.0]], "a"), "headers"),
    ],
    "claim": [
        (lambda: pk.tools.claim("q", "s", 1.0, "yes"), "holds"),
        (lambda: pk.tools.claim(1, "s", 1.0, True), "quantity"),
        (lambda: pk.tools.claim("q", "s", 1.0, True, source=None), "source"),
    ],
    "compare": [
        (lambda: pk.tools.compare("q", "1", 2.0), "paper"),
        (lambda: pk.tools.compare("q", 1.0, 1.0, rel_tol=-1.0), "rel_tol"),
        (lambda: pk.tools.compare("q", 1.0, 1.0, abs_tol=float("nan")), "abs_tol"),
        (lambda: pk.tools.compare("q", 1.0, 1.0, source=3), "source"),
        (lambda: pk.tools.compare("q", float("nan"), 1.0), "paper"),  # was a silent "differs" row
        (lambda: pk.tools.compare("q", float("inf"), 1.0), "paper"),
    ],
    "format_table": [
        (lambda: pk.tools.format_table([{"a": 1.0}], digits=0), "digits"),
        (lambda: pk.tools.format_table("rows"), "rows"),
        (lambda: pk.tools.format_table([{"quantity": "q"}]), "rows[0]"),
    ],
    "summary": [
        (lambda: pk.tools.summary(np.ones(3), stats=("mode",)), "stats"),
        (lambda: pk.tools.summary("abc"), "values"),
    ],
    "write_results": [
        (lambda: pk.tools.write_results("/nonexistent/x.json", "not a dict"), "results"),
        (lambda: pk.tools.write_results(3, {}), "path"),
        (lambda: pk.tools.write_results(None, {}), "path"),
        (lambda: pk.tools.write_results("", {}), "path"),
        (lambda: pk.tools.write_results("tests", {}), "path"),  # a folder
        (lambda: pk.tools.write_results("/nonexistent/x.json", {"rows": {1, 2}}), "results"),  # not JSON
        (lambda: pk.tools.write_results("/nonexistent/x.json", {"rows": [object()]}), "results"),
    ],
    "load_params": [
        (lambda: pk.load_params("p9"), "name_or_path", FileNotFoundError),  # a missing file, named
        (lambda: pk.load_params(3), "name_or_path"),
    ],
    # Jacobians of a mechanism: x and q must have the mechanism's numbers of coordinates
    **{
        name: [
            (lambda f=name: getattr(pk, f)(fb.mechanism, jnp.zeros(3), _q4(), _p4()), "x"),
            (lambda f=name: getattr(pk, f)(fb.mechanism, X4, jnp.zeros(5), _p4()), "q"),
            (lambda f=name: getattr(pk, f)("five_bar", X4, _q4(), _p4()), "mech"),
            (lambda f=name: getattr(pk, f)(fb.mechanism, "xz", _q4(), _p4()), "x"),
            (lambda f=name: getattr(pk, f)(fb.mechanism, X4, None, _p4()), "q"),
        ]
        for name in (
            "A_matrix",
            "B_diagonal",
            "B_matrix",
            "det_A",
            "det_B",
            "inverse_jacobian",
            "inverse_jacobian_rows",
            "jacobian",
        )
    },
    "matrix_inverse": [(lambda: pk.matrix_inverse(jnp.ones((2, 3))), "M")],
    "det_small": [(lambda: pk.det_small(jnp.ones((2, 3))), "M"), (lambda: pk.det_small(jnp.ones((5, 5))), "M")],
    "inverse_small": [(lambda: pk.inverse_small(jnp.ones((3, 2))), "M")],
    "solve_small": [
        (lambda: pk.solve_small(jnp.ones((2, 3)), jnp.ones((2, 1))), "B"),
        (lambda: pk.solve_small(jnp.eye(2), jnp.ones((3, 1))), "A"),
        (lambda: pk.solve_small(jnp.eye(2), jnp.ones(2)), "A"),  # a vector, not (n, m)
        (lambda: pk.solve_small(jnp.eye(2), 3.0), "A"),
        (lambda: pk.solve_small(jnp.eye(2), "ab"), "A"),
        (lambda: pk.solve_small(jnp.eye(2), [[1.0], [1.0, 2.0]]), "A"),
        (lambda: pk.solve_small(jnp.eye(2), jnp.ones((2, 0))), "A"),
        (lambda: pk.solve_small(jnp.ones((2, 2, 5)), jnp.ones((2, 1, 3))), "batch axes"),
    ],
    # criteria
    "actuator_efforts": [(lambda: pk.actuator_efforts(J2, jnp.ones(3)), "P")],
    "row_group_norms": [
        (lambda: pk.row_group_norms(J4, GROUPS, (1.0, 1.0)), "magnitudes"),
        (lambda: pk.row_group_norms(J4, ((0, 1), (2,), (7,)), (1.0, 1.0, 1.0)), "groups"),
        (lambda: pk.row_group_norms(J4, GROUPS, (1.0, -1.0, 1.0)), "magnitudes"),
        (lambda: pk.row_group_norms(J4, ((0, 1), (1,), (3,)), (1.0, 1.0, 1.0)), "groups"),  # overlap
        (lambda: pk.row_group_norms(J4, ((0, 0), (2,), (3,)), (1.0, 1.0, 1.0)), "groups"),  # a column twice
        (lambda: pk.row_group_norms(J4, ((0, 1), (-1,), (3,)), (1.0, 1.0, 1.0)), "groups"),
        (lambda: pk.row_group_norms(J4, ((0, 1), (4,), (3,)), (1.0, 1.0, 1.0)), "groups"),
        (lambda: pk.row_group_norms(jnp.ones(4), GROUPS, (1.0, 1.0, 1.0)), "M"),  # a vector, not a matrix
        (lambda: pk.row_group_norms("abcd", GROUPS, (1.0, 1.0, 1.0)), "M"),
        (lambda: pk.row_group_norms(J4, (), ()), "groups"),
    ],
    "max_actuator_velocity": [
        (lambda: pk.max_actuator_velocity(J4, GROUPS, (-0.1, 1.0, 0.01)), "speeds"),
        (lambda: pk.max_actuator_velocity(J4, ((0, 1), (2,), (4,)), (0.1, 1.0, 0.01)), "groups"),
        (lambda: pk.max_actuator_velocity(J4, ((0, 1), (2,), (2,)), (0.1, 1.0, 0.01)), "groups"),
        (lambda: pk.max_actuator_velocity(jnp.ones(4), GROUPS, (0.1, 1.0, 0.01)), "J_inv"),
    ],
    "max_actuator_effort": [
        (lambda: pk.max_actuator_effort(J4, GROUPS, (1.0, -1.0, 1.0)), "loads"),
        (lambda: pk.max_actuator_effort(J4, GROUPS, ("a", 1.0, 1.0)), "loads"),
    ],
    "max_gripper_force": [
        (lambda: pk.max_gripper_force(J4, 10.0, jnp.ones(4), 4), "gripper_index"),
        (lambda: pk.max_gripper_force(J4, 10.0, jnp.ones(4), 1.5), "gripper_index"),
        (lambda: pk.max_gripper_force(J4, -1.0, jnp.ones(4), 3), "F_pr"),
        (lambda: pk.max_gripper_force(J4, 10.0, jnp.ones(3), 3), "external_load"),
    ],
    "load_reserve": [
        (lambda: pk.load_reserve(J4, 10.0, jnp.ones(4), -1), "gripper_index"),
        (lambda: pk.load_reserve(J4, -2.0, jnp.ones(4), 3), "F_pr"),
    ],
    # singular curves
    "cluster_levels": [
        (lambda: pk.cluster_levels(np.ones(3), -1.0), "atol"),
        (lambda: pk.cluster_levels(np.ones(3), float("nan")), "atol"),
        (lambda: pk.cluster_levels(np.ones((3, 2)), 1e-6), "values"),  # was flattened: x and y pooled
        (lambda: pk.cluster_levels(np.array([0.1, np.nan]), 1e-6), "values"),  # was a NaN level
        (lambda: pk.cluster_levels("abc", 1e-6), "values"),
    ],
    "null_direction": [
        (lambda: pk.null_direction(np.ones(3)), "M"),
        (lambda: pk.null_direction(np.array([[np.nan, 1.0], [1.0, 1.0]])), "M"),
        (lambda: pk.null_direction(np.array([[np.inf, 1.0], [1.0, 1.0]])), "M"),
        (lambda: pk.null_direction(np.zeros((0, 2))), "M"),
    ],
    "refine_roots": [
        (lambda: pk.refine_roots(_fn, np.zeros((1, 2)), np.ones((1, 2)), tol=0.0), "tol"),
        (lambda: pk.refine_roots(_fn, np.zeros((1, 2)), np.ones((2, 2))), "p0"),
        (lambda: pk.refine_roots("fn", np.zeros((1, 2)), np.ones((1, 2))), "fn"),
        (lambda: pk.refine_roots(_fn, np.array([[np.nan, 0.0]]), np.ones((1, 2))), "p0"),  # was a NaN root
    ],
    "refine_brackets": [
        (lambda: pk.refine_brackets(_fn, np.zeros((1, 2)), np.ones((1, 2)), tol=float("nan")), "tol"),
        (lambda: pk.refine_brackets(None, np.zeros((1, 2)), np.ones((1, 2))), "fn"),
        (lambda: pk.refine_brackets(_fn, np.array([[np.nan, 0.0]]), np.ones((1, 2))), "p0"),  # was a RuntimeWarning
        (lambda: pk.refine_brackets(_fn, np.zeros((1, 2)), np.array([[1.0, np.inf]])), "p1"),
        (lambda: pk.refine_brackets(_fn, "ab", np.ones((1, 2))), "p0"),
    ],
    "sign_change_segments": [(lambda: pk.sign_change_segments(GRID, np.ones((2, 2))), "values")],
    "zero_nodes": [(lambda: pk.zero_nodes(GRID, np.ones(4)), "values")],
    "singular_crossings": [(lambda: pk.singular_crossings(_fn, GRID, np.ones(GRID.shape), tol=-1.0), "tol")],
    "classify_crossings": [
        (lambda: pk.classify_crossings(_fn, GRID, np.ones(GRID.shape), tol=float("inf")), "tol"),
        (lambda: pk.classify_crossings(_fn, GRID, np.ones(GRID.shape), touch_rtol=-1.0), "touch_rtol"),
        (lambda: pk.classify_crossings(_fn, GRID, np.ones(GRID.shape), suspects="yes"), "suspects"),
        (lambda: pk.classify_crossings(_fn, GRID, np.ones(GRID.shape), suspects=None), "suspects"),
    ],
    # grids and sweeps
    "Grid": [
        (lambda: pk.Grid(names=("x",), starts=(0.0,), steps=(0.0,), counts=(3,)), "step"),
        (lambda: pk.Grid(names=("x",), starts=(0.0,), steps=(1.0,), counts=(0,)), "count"),
        (lambda: pk.Grid(names=("x",), starts=(float("nan"),), steps=(1.0,), counts=(2,)), "start"),
    ],
    "sweep": [
        (lambda: pk.sweep(_fn, GRID, chunk_size=0), "chunk_size"),
        (lambda: pk.sweep(_fn, "grid"), "grid"),
        (lambda: pk.sweep(_fn, GRID, args=[1.0]), "args"),
        (lambda: pk.sweep(_fn, GRID, batched="yes"), "batched"),
        (lambda: pk.sweep(_fn, GRID, batched=1), "batched"),
        (lambda: pk.sweep(_fn, GRID, progress="yes"), "progress"),
        (lambda: pk.sweep(_fn, GRID, size_parameter=3), "parameter"),
    ],
    "chunk_size_for": [
        (lambda: pk.chunk_size_for(_fn, GRID, chunk_size=-3), "chunk_size"),
        (lambda: pk.chunk_size_for(_fn, "grid"), "grid"),
        (lambda: pk.chunk_size_for(_fn, GRID, batched="no"), "batched"),
        (lambda: pk.chunk_size_for("fn", GRID), "fn"),
    ],
    "check_inertia": [(lambda: pk.dynamics.check_inertia(jnp.array([1.0, -1.0, 1.0])), "inertia")],
    # design synthesis and atlases
    "exact_area": [
        (lambda: pk.design.exact_area(np.ones(3), "1"), "cell_area"),
        (lambda: pk.design.exact_area(np.ones(3), -1.0), "cell_area"),
    ],
    "soft_area": [
        (lambda: pk.design.soft_area(jnp.ones(3), -1.0, 0.1), "cell_area"),
        (lambda: pk.design.soft_area(jnp.ones(3), 1.0, 0.0), "width"),
        (lambda: pk.design.soft_area("abc", 1.0, 0.1), "g"),
    ],
    "soft_indicator": [
        (lambda: pk.design.soft_indicator(jnp.ones(3), 0.0), "width"),
        (lambda: pk.design.soft_indicator(["a", "b"], 0.1), "g"),  # was NumPy's message, naming no argument
    ],
    "soft_max": [
        (lambda: pk.design.soft_max(jnp.ones(3), -1.0), "width"),
        (lambda: pk.design.soft_max(jnp.zeros(0), 0.1), "v"),  # was NaN
        (lambda: pk.design.soft_max("abc", 0.1), "v"),
    ],
    "soft_min": [
        (lambda: pk.design.soft_min(jnp.ones(3), float("nan")), "width"),
        (lambda: pk.design.soft_min(jnp.zeros((2, 0)), 0.1), "v"),
        (lambda: pk.design.soft_min(None, 0.1), "v"),
    ],
    "near_singularity": [
        (lambda: pk.design.near_singularity(jnp.ones(3), -1.0, 0.1), "eps"),
        (lambda: pk.design.near_singularity(jnp.ones(3), 0.1, 0.0), "width"),
        (lambda: pk.design.near_singularity(["x"], 0.1, 0.1), "det"),
    ],
    "penalised_min": [
        (lambda: pk.design.penalised_min(jnp.ones(3), None, -1.0), "penalty"),
        (lambda: pk.design.penalised_min(jnp.ones(3), lambda d: d), "margins"),  # maximise_min's function form
        (lambda: pk.design.penalised_min(jnp.ones(3), "0.1"), "margins"),
        (lambda: pk.design.penalised_min(jnp.ones(3), [0.1, None]), "margins"),
        (lambda: pk.design.penalised_min(jnp.zeros(0), jnp.ones(2)), "values"),
        (lambda: pk.design.penalised_min("values"), "values"),
    ],
    "latin_hypercube_starts": [
        (lambda: pk.design.latin_hypercube_starts(BOUNDS, 0), "n"),
        (lambda: pk.design.latin_hypercube_starts(BOUNDS, 2, seed=-1), "seed"),
        (lambda: pk.design.latin_hypercube_starts([(1.0, 0.0)], 2), "bounds"),
        (lambda: pk.design.latin_hypercube_starts(BOUNDS, 10**12), "n", pk.MemoryBudgetError),  # was a raw MemoryError
    ],
    "maximise": [
        (lambda: pk.design.maximise(_objective, [0.5, 0.5], BOUNDS, max_iterations=-1), "max_iterations"),
        (lambda: pk.design.maximise(_objective, [0.5, 0.5], BOUNDS, tol=float("nan")), "tol"),
        (lambda: pk.design.maximise(_objective, [0.5, 2.0], BOUNDS), "x0"),
        (lambda: pk.design.maximise(_objective, [float("nan"), 0.5], BOUNDS), "x0"),  # ran to a NaN "optimum"
        (lambda: pk.design.maximise(_objective, np.zeros((0, 2)), BOUNDS), "x0"),
        (lambda: pk.design.maximise(_objective, "x0", BOUNDS), "x0"),
        (lambda: pk.design.maximise(_objective, [0.5, 0.5], BOUNDS, derivatives="central"), "derivatives"),
        (lambda: pk.design.maximise("objective", [0.5, 0.5], BOUNDS), "objective"),
        (lambda: pk.design.maximise(lambda d: d, [0.5, 0.5], BOUNDS, derivatives="forward"), "objective"),
    ],
    "maximise_min": [
        (lambda: pk.design.maximise_min(lambda d: d, [0.5, 0.5], BOUNDS, max_iterations=0), "max_iterations"),
        (lambda: pk.design.maximise_min(lambda d: d, [0.5, 0.5], BOUNDS, tol=-1.0), "tol"),
        (lambda: pk.design.maximise_min(lambda d: d, [0.5, 0.5], BOUNDS, margins=3), "margins"),
        (lambda: pk.design.maximise_min(lambda d: d[None, None], [0.5, 0.5], BOUNDS), "values"),
    ],
    "maximise_derivative_free": [
        (lambda: pk.design.maximise_derivative_free(_objective, BOUNDS, popsize=0), "popsize"),
        (lambda: pk.design.maximise_derivative_free(_objective, BOUNDS, tol=-0.1), "tol"),
        (lambda: pk.design.maximise_derivative_free(_objective, BOUNDS, max_generations=0), "max_generations"),
        (lambda: pk.design.maximise_derivative_free(_objective, BOUNDS, seed=1.5), "seed"),
        (lambda: pk.design.maximise_derivative_free(lambda d: d, BOUNDS), "objective"),
        (
            lambda: pk.design.maximise_derivative_free(_objective, BOUNDS, popsize=10**12),
            "popsize",
            pk.MemoryBudgetError,
        ),
    ],
    "atlas": [
        (lambda: pk.design.atlas(lambda d, p: p[0], GRID, GRID, chunk_designs=0), "chunk_designs"),
        (lambda: pk.design.atlas(lambda d, p: p[0], GRID, GRID, max_pairs_per_call=0), "max_pairs_per_call"),
        (lambda: pk.design.atlas(lambda d, p: p[0], "designs", GRID), "designs"),
        (lambda: pk.design.atlas(lambda d, p: p[0], GRID, GRID, args=[1.0]), "args"),
        (lambda: pk.design.atlas(lambda d, p: p[:1], GRID, GRID), "criterion"),
    ],
    # screws and rigid-body dynamics (P5)
    "skew": [(lambda: pk.skew(jnp.ones(2)), "v")],
    "exp_so3": [(lambda: pk.exp_so3(jnp.ones(2)), "v")],
    "rot_x": [(lambda: pk.rot_x("0.1"), "alpha")],
    "rot_y": [(lambda: pk.rot_y(None), "beta")],
    "rot_z": [(lambda: pk.rot_z("0"), "gamma")],
    "rotation_matrix": [(lambda: pk.rotation_matrix("0", 0.0, 0.0), "alpha")],
    "homogeneous_transform": [(lambda: pk.homogeneous_transform(0.0, 0.0, 0.0, jnp.ones(2)), "T")],
    "transform_points": [
        (lambda: pk.transform_points(jnp.eye(3), jnp.ones((2, 3))), "M"),
        (lambda: pk.transform_points(jnp.eye(4), jnp.ones((2, 2))), "points"),
    ],
    "moment_about_origin": [(lambda: pk.moment_about_origin(jnp.ones(3), jnp.ones(2)), "point")],
    "line": [(lambda: pk.line(jnp.ones(2), jnp.ones(3)), "direction")],
    "unit_screw": [
        (lambda: pk.unit_screw(jnp.ones(2), jnp.ones(3)), "direction"),
        (lambda: pk.unit_screw(jnp.ones(3), jnp.ones(3), pitch="0"), "pitch"),
    ],
    "relative_moment": [(lambda: pk.relative_moment(jnp.ones(5), jnp.ones(6)), "S1")],
    "shift_reference": [(lambda: pk.shift_reference(jnp.ones(6), jnp.ones(2)), "d")],
    "angular_momentum": [
        (lambda: pk.dynamics.angular_momentum(STATE, jnp.array([1.0, 2.0])), "inertia"),
        (lambda: pk.dynamics.angular_momentum(None, INERTIA), "state"),
    ],
    "kinetic_energy": [
        (lambda: pk.dynamics.kinetic_energy(STATE, -1.0, INERTIA), "mass"),
        (lambda: pk.dynamics.kinetic_energy("state", 1.0, INERTIA), "state"),
    ],
    "angular_velocity_from_angle_rates": [
        (lambda: pk.dynamics.angular_velocity_from_angle_rates(jnp.ones(2), jnp.ones(3)), "angles")
    ],
    "box_inertia": [
        (lambda: pk.dynamics.box_inertia(-1.0, jnp.ones(3)), "mass"),
        (lambda: pk.dynamics.box_inertia(1.0, jnp.array([1.0, -1.0, 1.0])), "edges"),
    ],
    "euler_coefficients": [
        (lambda: pk.dynamics.euler_coefficients(jnp.ones(2), jnp.ones(3)), "omega"),
        (lambda: pk.dynamics.euler_coefficients(jnp.ones(3), jnp.ones(3), printed_signs="yes"), "printed_signs"),
    ],
    "newton_euler": [
        (lambda: pk.dynamics.newton_euler(-1.0, INERTIA, jnp.ones(3), jnp.ones(3), jnp.ones(3)), "mass"),
        (lambda: pk.dynamics.newton_euler(1.0, INERTIA, jnp.ones(2), jnp.ones(3), jnp.ones(3)), "force"),
    ],
    "newton_euler_as_printed": [
        (lambda: pk.dynamics.newton_euler_as_printed(INERTIA, jnp.ones(2), jnp.ones(3)), "moment")
    ],
    "rotation_error": [(lambda: pk.dynamics.rotation_error(jnp.eye(2)), "rotation")],
    "integrate": [
        (lambda: pk.dynamics.integrate(STATE, _no_wrench, -1.0, INERTIA, 0.01, 3), "mass"),
        (lambda: pk.dynamics.integrate(STATE, _no_wrench, 1.0, INERTIA, 0.0, 3), "dt"),
        (lambda: pk.dynamics.integrate(STATE, _no_wrench, 1.0, INERTIA, -0.01, 3), "dt"),
        (lambda: pk.dynamics.integrate(STATE, _no_wrench, 1.0, INERTIA, 0.01, -1), "n_steps"),
        (lambda: pk.dynamics.integrate(STATE, _no_wrench, 1.0, INERTIA, 0.01, 3, t0=float("nan")), "t0"),
        (lambda: pk.dynamics.integrate(STATE, _no_wrench, 1.0, INERTIA, 0.01, 3, method="euler"), "method"),
        (lambda: pk.dynamics.integrate("state", _no_wrench, 1.0, INERTIA, 0.01, 3), "state"),
        (lambda: pk.dynamics.integrate(STATE._replace(omega="w"), _no_wrench, 1.0, INERTIA, 0.01, 3), "state"),
        (lambda: pk.dynamics.integrate(STATE, _no_wrench, 1.0, INERTIA, float("inf"), 3), "dt"),
        (lambda: pk.dynamics.integrate(STATE, _no_wrench, 1.0, jnp.array([1.0, -1.0, 1.0]), 0.01, 3), "inertia"),
        (lambda: pk.dynamics.integrate(STATE, _no_wrench, 1.0, INERTIA, 0.01, 10**12), "n_steps", pk.MemoryBudgetError),
    ],
    # structural stiffness (P4)
    "BeamSection": [
        (lambda: pk.stiffness.BeamSection.create(E=-1.0, G=8e4, A=100.0, I_y=1e3, I_z=1e3, I_p=2e3), "E"),
        (lambda: pk.stiffness.BeamSection.create(E=2e5, G="8e4", A=100.0, I_y=1e3, I_z=1e3, I_p=2e3), "G"),
        # built directly, not by create
        *[
            (lambda k=k, v=v: pk.stiffness.BeamSection(**(SECTION_VALUES | {k: v})), k)
            for k in SECTION_VALUES
            for v in (-1.0, 0.0, float("nan"), None, "1.0", True)
        ],
        (lambda: pk.stiffness.BeamSection(**(SECTION_VALUES | {"E": jnp.array([2e5, -1.0])})), "E"),
    ],
    "Frame": [
        (lambda: pk.stiffness.Frame(n_nodes=1, elements=()), "n_nodes"),
        (lambda: pk.stiffness.Frame(n_nodes=2, elements=((0, 2),)), "elements"),
        (lambda: pk.stiffness.Frame(n_nodes=2, elements=((0, 1),), up=(0, 0)), "up"),
        (lambda: pk.stiffness.Frame(n_nodes=2, elements=((0, 1),), up=(0, 0, 0)), "up"),
        (lambda: pk.stiffness.Frame(n_nodes=2, elements=((0, 1),), up=(0, float("nan"), 1)), "up"),
        (lambda: pk.stiffness.Frame(n_nodes=2, elements=((0, 1),), up="y"), "up"),
        (lambda: pk.stiffness.Frame(n_nodes="2", elements=((0, 1),)), "n_nodes"),
        (lambda: pk.stiffness.Frame(n_nodes=2.5, elements=((0, 1),)), "n_nodes"),
        # an enormous frame looped over its nodes in Python (a hang) before its matrix was allocated
        (lambda: pk.stiffness.Frame(n_nodes=10**12, elements=((0, 1),)), "n_nodes", pk.MemoryBudgetError),
        (lambda: pk.stiffness.Frame(n_nodes=2, elements=3), "elements"),
        (lambda: pk.stiffness.Frame(n_nodes=2, elements=((0, 1.5),)), "elements"),
        (lambda: pk.stiffness.Frame(n_nodes=2, elements=((0, 1, 1),)), "elements"),
        (lambda: pk.stiffness.Frame(n_nodes=2, elements=((0, 1),), releases=3), "releases"),
        (lambda: pk.stiffness.Frame(n_nodes=2, elements=((0, 1),), releases=((12,),)), "releases"),
        (lambda: pk.stiffness.Frame(n_nodes=2, elements=((0, 1),), fixed_dofs=5), "fixed_dofs"),
        (lambda: pk.stiffness.Frame(n_nodes=2, elements=((0, 1),), fixed_dofs=(1.5,)), "fixed_dofs"),
        (
            lambda: pk.stiffness.Frame(n_nodes=2, elements=((0, 1),), fixed_dofs=tuple(range(6))).solve(
                jnp.array([[0.0, 0.0, 0.0], [100.0, 0.0, 0.0]]), SECTION, jnp.ones(3)
            ),
            "loads",
        ),
    ],
    "canonical_sign": [
        (lambda: pk.stiffness.canonical_sign(jnp.ones(2), order=(5,)), "order"),
        (lambda: pk.stiffness.canonical_sign(jnp.ones(2), rtol=-1.0), "rtol"),
        (lambda: pk.stiffness.canonical_sign(jnp.ones(2), order=(0, 0)), "order"),  # was accepted
        (lambda: pk.stiffness.canonical_sign(jnp.ones(3), order=(1, 0, 1)), "order"),
    ],
    "condense": [
        (lambda: pk.stiffness.condense(jnp.eye(3), (3,)), "released"),
        (lambda: pk.stiffness.condense(jnp.ones((2, 3)), (1,)), "K"),
    ],
    "schur_complement": [(lambda: pk.stiffness.schur_complement(jnp.eye(3), (7,)), "kept")],
    "directional_stiffness": [
        (lambda: pk.stiffness.directional_stiffness(K2, jnp.ones(3)), "u"),
        (lambda: pk.stiffness.directional_stiffness(K2, jnp.zeros(2)), "u"),
    ],
    "element_global": [
        (lambda: pk.stiffness.element_global(jnp.eye(12), jnp.eye(2)), "R"),
        (lambda: pk.stiffness.element_global(jnp.eye(6), jnp.eye(3)), "K_local"),
    ],
    "element_rotation": [
        (lambda: pk.stiffness.element_rotation(jnp.ones(2), jnp.ones(3)), "p1"),
        (lambda: pk.stiffness.element_rotation(jnp.ones(3), jnp.ones(3)), "p2"),
        (lambda: pk.stiffness.element_rotation(jnp.ones(3), jnp.zeros(3), up=jnp.ones(2)), "up"),
        (lambda: pk.stiffness.element_rotation(jnp.ones(3), jnp.zeros(3), up=jnp.zeros(3)), "up"),
        (lambda: pk.stiffness.element_rotation(jnp.ones(3), jnp.zeros(3), up="y"), "up"),
    ],
    "extremal_stiffness": [(lambda: pk.stiffness.extremal_stiffness(jnp.eye(3)), "K")],
    "find_empty_dofs": [
        (lambda: pk.stiffness.find_empty_dofs(jnp.ones((2, 3))), "K"),
        (lambda: pk.stiffness.find_empty_dofs(jnp.eye(2), rtol=-1.0), "rtol"),
    ],
    "frame_element_local": [
        (lambda: pk.stiffness.frame_element_local(-1.0, SECTION), "L"),
        (lambda: pk.stiffness.frame_element_local(1.0, "steel"), "s"),
    ],
    "hinged_element_local": [
        (lambda: pk.stiffness.hinged_element_local(1.0, SECTION, (12,)), "released"),
        (lambda: pk.stiffness.hinged_element_local(0.0, SECTION), "L"),
    ],
    "node_dof": [(lambda: pk.stiffness.node_dof(-1, 0), "node"), (lambda: pk.stiffness.node_dof(0, 6), "k")],
    "node_dofs": [(lambda: pk.stiffness.node_dofs(-1), "nodes"), (lambda: pk.stiffness.node_dofs(1.5), "nodes")],
    "rectangle_section": [
        (lambda: pk.stiffness.rectangle_section(-1.0, 1.0), "b"),
        (lambda: pk.stiffness.rectangle_section(1.0, 1.0, n_terms=0), "n_terms"),
        (lambda: pk.stiffness.rectangle_section(1.0, 1.0, n_terms=10**12), "n_terms"),  # was a Python loop (a hang)
    ],
    "release": [(lambda: pk.stiffness.release(3), "ends"), (lambda: pk.stiffness.release(1, about="q"), "about")],
    "transformation_matrix": [(lambda: pk.stiffness.transformation_matrix(jnp.eye(2)), "R")],
}

#: Exported names with no argument to check, and why.
TAKES_ANYTHING = {
    "LoadedMechanism": "a dataclass built by pk.load_mechanism, which checks the description (tests/test_description_errors.py)",
    "InverseSolution": "a result record built by pk.inverse_positions",
    "ForwardPositions": "a result record built by pk.forward_positions",
    "NOT_PAPER_PARAMETERS": "a constant (the status text of a re-run with other parameters)",
    "DATA_DIR": "a constant (the path of data/)",
    "INTEGRATION_METHODS": "a constant (the names of pk.dynamics.integrate's methods and what each is)",
    "FIXED_HINGE_Y": "a constant (pk.stiffness.release's DOFs of a beam hinged at one end)",
    "HINGE_HINGE_Y": "a constant (pk.stiffness.release's DOFs of a beam hinged at both ends)",
    "MemoryBudgetError": "an exception type (raised by pk.check_memory, which checks its arguments)",
    "DesignResult": "a result record built by pk.design.maximise / maximise_min / maximise_derivative_free",
    "ForwardSolution": "a result record built by pk.solve_forward_position",
    "Crossings": "a result record built by pk.classify_crossings",
    "Refinement": "a result record built by pk.refine_brackets",
    "RigidBodyState": "a pytree container (JAX rebuilds it with placeholder leaves, so it cannot check them); "
    "pk.dynamics.integrate, kinetic_energy and angular_momentum check its fields' shapes",
    "state_trajectory": "a pytree constructor (q, qd, qdd of any consistent shapes), read by the inverse "
    "dynamics, which check the shapes they get",
}


SUBPACKAGES = (pk, pk.stiffness, pk.dynamics, pk.design, pk.tools)


def exported_names():
    names = [n for module in SUBPACKAGES for n in module.__all__]
    repeated = sorted({n for n in names if names.count(n) > 1})
    assert not repeated, f"exported from two places: {repeated}"
    return set(names)


def test_every_exported_name_is_covered():
    tables = set(BAD_CALLS) | set(TAKES_ANYTHING)
    exported = exported_names()
    missing = sorted(exported - tables)
    assert not missing, (
        f"pkmlib exports {missing}, which tests/test_public_api_validation.py does not cover: add each to "
        "BAD_CALLS (a bad call -> the argument its ValueError must name; make the function check its "
        "arguments with pkmlib/_validation.py) or, if it takes nothing to check, to TAKES_ANYTHING with the reason"
    )
    stale = sorted(tables - exported)
    assert not stale, f"no longer exported, remove from the tables: {stale}"
    both = sorted(set(BAD_CALLS) & set(TAKES_ANYTHING))
    assert not both, both


CASES = [
    pytest.param(case[0], case[1], case[2] if len(case) > 2 else ValueError, id=f"{name}-{i}-{case[1]}")
    for name, calls in BAD_CALLS.items()
    for i, case in enumerate(calls)
]


@pytest.mark.parametrize("call, argument, error", CASES)
def test_a_bad_argument_is_a_value_error_naming_it(call, argument, error):
    with pytest.raises(error) as info:
        call()
    message = str(info.value)
    assert argument in message, f"the message does not name {argument!r}: {message}"
    assert "Traceback" not in message and len(message) < 2000


# --- traced values: checked under jit / vmap, or NaN as documented --------------------------------


def test_integrate_refuses_a_traced_step_that_is_not_positive():
    @jax.jit
    def run(dt):
        return pk.dynamics.integrate(STATE, _no_wrench, 1.0, INERTIA, dt, 3).omega

    assert np.all(np.isfinite(np.asarray(run(0.01))))
    for dt in (0.0, -0.01, float("nan")):
        with pytest.raises(Exception, match="dt must be a finite positive number"):
            jax.block_until_ready(run(dt))


def test_integrate_refuses_traced_steps_and_inertias_under_vmap():
    run = jax.vmap(lambda dt: pk.dynamics.integrate(STATE, _no_wrench, 1.0, INERTIA, dt, 3).omega)
    assert np.all(np.isfinite(np.asarray(run(jnp.array([0.01, 0.02])))))
    for bad in (0.0, -0.01):
        with pytest.raises(Exception, match="dt must be a finite positive number"):
            jax.block_until_ready(run(jnp.array([0.01, bad])))
    by_inertia = jax.jit(lambda inertia: pk.dynamics.integrate(STATE, _no_wrench, 1.0, inertia, 0.01, 3).omega)
    assert np.all(np.isfinite(np.asarray(by_inertia(INERTIA))))
    assert np.all(np.isfinite(np.asarray(by_inertia(jnp.diag(INERTIA)))))
    for bad in (jnp.array([1.0, -1.0, 1.0]), jnp.array([[1.0, 0.3, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 3.0]])):
        with pytest.raises(Exception, match="inertia must be"):
            jax.block_until_ready(by_inertia(bad))


def test_integrate_refuses_a_traced_mass_that_is_not_positive():
    @jax.jit
    def run(mass):
        return pk.dynamics.integrate(STATE, _no_wrench, mass, INERTIA, 0.01, 3).position

    assert np.all(np.isfinite(np.asarray(run(2.0))))
    with pytest.raises(Exception, match="mass must be a finite positive number"):
        jax.block_until_ready(run(-1.0))


def test_traced_negative_speeds_and_loads_give_nan_not_a_number():
    f = jax.jit(lambda v: pk.max_actuator_velocity(J4, GROUPS, (v, 1.0, 0.01)))
    assert np.isfinite(f(0.1)) and np.isnan(f(-0.1))
    g = jax.jit(jax.vmap(lambda P: pk.max_actuator_effort(J4, GROUPS, (P, 1.0, 1.0))))
    out = np.asarray(g(jnp.array([1.0, -1.0])))
    assert np.isfinite(out[0]) and np.isnan(out[1])
    h = jax.jit(lambda F: pk.max_gripper_force(J4, F, jnp.ones(4), 3))
    assert np.isnan(h(-1.0))


def test_traced_width_of_a_smooth_measure_is_refused_when_traced():
    with pytest.raises(ValueError, match="width"):
        jax.jit(lambda w: pk.design.soft_indicator(jnp.ones(3), w))(0.1)


def test_p1_pose_criteria_refuse_negative_speeds():
    P = p1.Gripper4PRRParams.from_dict(pk.load_params("p1"))
    x = p1.pose(0.7, 0.5, 0.0, 0.05)
    good = dict(speeds=(0.1, 1.0, 0.01), loads=(1.0, 1.0, 1.0), F_pr=100.0, external_load=(1.0, 1.0, 0.0))
    p1.pose_criteria(x, P, **good)  # accepted
    for key, bad in (("speeds", (-0.1, 1.0, 0.01)), ("loads", (1.0, -1.0, 1.0)), ("F_pr", -5.0)):
        with pytest.raises(ValueError, match=key):
            p1.pose_criteria(x, P, **(good | {key: bad}))


def test_the_good_calls_of_the_table_still_work():
    # the checks refuse only what is wrong: the same functions with good arguments
    assert pk.design.exact_area(np.array([1.0, -1.0, np.nan]), 2.0) == 2.0
    assert np.isfinite(pk.max_gripper_force(J4, 10.0, jnp.ones(4), 3))
    assert pk.skew(jnp.ones(3)).shape == (3, 3)
    assert math.isfinite(float(pk.dynamics.kinetic_energy(STATE, 1.0, INERTIA)))
    r = pk.design.maximise(_objective, [0.5, 0.5], BOUNDS, max_iterations=5, derivatives="forward")
    assert np.all(np.abs(r.design - 0.3) < 1e-6)


def test_traced_limits_that_cross_give_nan():
    f = jax.jit(lambda lo, hi: pk.within_limits(jnp.array([0.5, 0.5]), lo, hi))
    assert np.all(np.isfinite(np.asarray(f(jnp.zeros(2), jnp.ones(2)))))
    assert np.all(np.isnan(np.asarray(f(jnp.array([0.0, 1.0]), jnp.array([1.0, 0.0])))))
    assert np.all(np.isnan(np.asarray(f(jnp.array([0.0, jnp.nan]), jnp.ones(2)))))


def test_solve_forward_position_refuses_a_traced_tolerance_or_count_that_is_not_accepted():
    def run(tol, max_iter):
        return pk.solve_forward_position(fb.mechanism, _q4(), _p4(), X4 + 1.0, tol=tol, max_iter=max_iter).x

    jitted = jax.jit(run)
    assert_x = np.asarray(jitted(1e-12, 50))
    np.testing.assert_allclose(assert_x, np.asarray(X4), rtol=0, atol=1e-9)
    for tol, max_iter, what in ((-1.0, 50, "tol"), (float("nan"), 50, "tol"), (1e-12, -1, "max_iter")):
        with pytest.raises(Exception, match=f"{what} must be"):
            jax.block_until_ready(jitted(tol, max_iter))
    batched = jax.vmap(run, in_axes=(0, None))
    assert np.all(np.isfinite(np.asarray(batched(jnp.array([1e-12, 1e-10]), 50))))
    with pytest.raises(Exception, match="tol must be"):
        jax.block_until_ready(batched(jnp.array([1e-12, -1.0]), 50))


@pytest.mark.parametrize("name", ["inverse_dynamics_virtual_work", "inverse_dynamics_lagrange"])
def test_inverse_dynamics_refuse_traced_masses_and_inertias_that_are_not_physical(name):
    f = getattr(pk.dynamics, name)
    # the good call: one slider of 2 kg accelerated at 1 along x needs 2 (gravity along z does no work)
    np.testing.assert_allclose(np.asarray(f(**SLIDER)), [[2.0]], rtol=0, atol=1e-12)
    by_mass = jax.jit(lambda m: f(**(SLIDER | {"masses": m})))
    np.testing.assert_allclose(np.asarray(by_mass(jnp.array([3.0]))), [[3.0]], rtol=0, atol=1e-12)
    with pytest.raises(Exception, match="masses must be finite and >= 0"):
        jax.block_until_ready(by_mass(jnp.array([-3.0])))
    batched = jax.vmap(lambda m: f(**(SLIDER | {"masses": m[None]})))
    np.testing.assert_allclose(np.asarray(batched(jnp.array([1.0, 2.0])))[:, 0, 0], [1.0, 2.0], rtol=0, atol=1e-12)
    with pytest.raises(Exception, match="masses must be finite and >= 0"):
        jax.block_until_ready(batched(jnp.array([1.0, -2.0])))
    by_inertia = jax.jit(lambda inertia: f(**(SLIDER | {"inertias": inertia})))
    assert np.all(np.isfinite(np.asarray(by_inertia(jnp.zeros((1, 3, 3))))))  # a body that does not rotate
    for bad in (ASYMMETRIC, INDEFINITE, COUPLED):
        with pytest.raises(Exception, match="inertias: each inertia tensor"):
            jax.block_until_ready(by_inertia(bad))
    # a gradient through the masses passes the check (P3's actuator_forces_at is differentiated in them)
    g = jax.grad(lambda m: f(**(SLIDER | {"masses": m}))[0, 0])(jnp.array([2.0]))
    np.testing.assert_allclose(np.asarray(g), [1.0], rtol=0, atol=1e-12)


def test_a_beam_section_built_directly_is_checked_but_jax_may_rebuild_it_with_any_leaves():
    def stiffness(s):
        return jnp.sum(pk.stiffness.frame_element_local(100.0, s))

    grad = jax.grad(stiffness)(SECTION)  # cotangents: zeros for G, A, I_p
    assert isinstance(grad, pk.stiffness.BeamSection) and float(grad.G) == 0.0
    assert float(jax.tree.map(lambda v: -v, SECTION).E) == -2e5  # a tree map is not a construction
    axes = jax.tree.map(lambda _: 0, SECTION)  # vmap's in_axes: zeros in every field
    stacked = jax.tree.map(lambda v: jnp.array([v, 2.0 * v]), SECTION)
    out = np.asarray(jax.vmap(stiffness, in_axes=(axes,))(stacked))
    doubled = pk.stiffness.BeamSection(**{k: 2.0 * v for k, v in SECTION_VALUES.items()})
    np.testing.assert_allclose(out, [float(stiffness(SECTION)), float(stiffness(doubled))], rtol=1e-12)
    # a section built under jit from a traced value that is not positive gives NaN, not a number
    by_E = jax.jit(lambda E: stiffness(pk.stiffness.BeamSection(**(SECTION_VALUES | {"E": E}))))
    assert float(by_E(2e5)) == float(stiffness(SECTION))
    assert np.isnan(float(by_E(-2e5))) and np.isnan(float(by_E(0.0)))


def test_a_frame_stores_its_checked_values():
    frame = pk.stiffness.Frame(n_nodes=3.0, elements=[(0, 1), (1, 2)], up=jnp.array([0.0, 1.0, 0.0]))
    assert frame.n_nodes == 3 and isinstance(frame.n_nodes, int) and frame.n_dofs == 18
    assert frame.up == (0.0, 1.0, 0.0) and hash(frame) == hash(pk.stiffness.Frame(n_nodes=3, elements=((0, 1), (1, 2))))


def test_the_good_calls_of_the_new_checks_still_work():
    assert float(pk.design.penalised_min(jnp.array([3.0, 1.0]), jnp.array([[0.5, -0.2]]), 10.0)) == pytest.approx(-1.0)
    B = jnp.stack([jnp.eye(2) * k for k in (1.0, 2.0, 4.0)], axis=-1)  # (2, 2, 3)
    np.testing.assert_allclose(np.asarray(pk.solve_small(B, jnp.ones((2, 1))))[:, 0, :], [[1.0, 0.5, 0.25]] * 2)
    assert pk.solve_small(jnp.eye(2), jnp.ones((2, 3, 4))).shape == (2, 3, 4)
    assert pk.solve_small(((1.0, 0.0), (0.0, 2.0)), ((1.0,), (1.0,))).shape == (2, 1)
    assert pk.sweep(_fn, GRID, batched=np.bool_(False), progress=False).shape == GRID.shape
    assert pk.null_direction(np.array([[1.0, 0.0], [0.0, 0.0]])).tolist() == [0.0, 1.0]
    assert pk.row_group_norms(J4, ((0, 1),), (1.0,)).shape == (4,)  # a group need not cover every column


def test_the_good_calls_of_the_leftover_checks_still_work():
    # summary pools a map over a grid (2-D values are legitimate); compare takes a NaN of ours
    assert pk.tools.summary(np.array([[1.0, np.nan], [3.0, np.inf]])) == {"min": 1.0, "median": 2.0, "max": 3.0}
    assert pk.tools.compare("q", 1.0, float("nan"))["status"] == "differs"
    np.testing.assert_allclose(pk.cluster_levels(np.array([0.3, 0.1, 0.1 + 1e-9]), 1e-6), [0.1 + 0.5e-9, 0.3])
    assert np.asarray(pk.stiffness.canonical_sign(jnp.array([-0.6, 0.8]), order=(1,))).tolist() == [-0.6, 0.8]
    assert pk.design.latin_hypercube_starts(BOUNDS, 3).shape == (3, 2)


def test_forward_positions_with_more_slots_than_starts_pads_them_with_nan():
    # 2 starts per axis: 4 starts on the five-bar's plane, so at most 4 modes; 8 slots was a raw reshape error
    box = [[-500.0, -500.0], [500.0, 500.0]]
    r4 = pk.forward_positions(fb.mechanism, _q4(), _p4(), box, starts_per_axis=2, max_modes=4)
    r8 = pk.forward_positions(fb.mechanism, _q4(), _p4(), box, starts_per_axis=2, max_modes=8)
    assert r8.x.shape == (8, 2) and r8.det_A_sign.shape == (8,) and r8.residual.shape == (8,)
    np.testing.assert_array_equal(np.asarray(r8.x[:4]), np.asarray(r4.x))
    np.testing.assert_array_equal(np.asarray(r8.det_A_sign[:4]), np.asarray(r4.det_A_sign))
    assert np.all(np.isnan(np.asarray(r8.x[4:]))) and np.all(np.isnan(np.asarray(r8.residual[4:])))
    assert int(r8.count) == int(r4.count) >= 1
    np.testing.assert_allclose(np.asarray(r8.x[0]), np.asarray(X4), rtol=0, atol=1e-9)  # the pose itself
