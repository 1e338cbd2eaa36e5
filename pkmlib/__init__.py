"""pkmlib: velocity, force and singularity analysis of parallel kinematic mechanisms in JAX.

A mechanism is its constraint equations F(x, q) = 0 plus its position solutions
(:class:`Mechanism`); A = dF/dx, B = dF/dq, J^-1, J, det(A), det(B) come from automatic
differentiation, and any pointwise quantity is swept over a workspace grid with ``jit`` +
``vmap`` (:func:`sweep`). Importing pkmlib turns on float64 in JAX.
"""

from . import _config  # noqa: F401  (float64 before anything else)
from ._criteria import (
    actuator_efforts,
    load_reserve,
    max_actuator_effort,
    max_actuator_velocity,
    max_gripper_force,
    row_group_norms,
)
from ._design import DesignResult, atlas, exact_area, latin_hypercube_starts, maximise, maximise_derivative_free, maximise_min, near_singularity, penalised_min, soft_area, soft_indicator, soft_max, soft_min
from ._grid import Grid
from ._inverse_dynamics import inverse_dynamics_lagrange, inverse_dynamics_virtual_work, state_trajectory
from ._jacobians import A_matrix, B_diagonal, B_matrix, det_A, det_B, inverse_jacobian, inverse_jacobian_rows, jacobian, matrix_inverse
from ._mechanism import Mechanism, within_limits
from .description import LoadedMechanism, load_mechanism
from ._memory import MemoryBudgetError, check_memory, memory_budget
from ._notebook_parameters import ParameterSpec, check_parameter, check_parameters, choice, flag, number, numbers, signs, text
from ._notebook_parameters import ParameterRule, less, not_all_zero
from ._params import DATA_DIR, load_params
from ._reference import claim_reference, compare_reference, load_reference_file, paper_value, reference_row
from ._tables import markdown_table, markdown_table_text
from ._position import ForwardSolution, forward_position, solve_forward_position
from ._positions import ForwardPositions, InverseSolution, detect_structure, forward_positions, inverse_positions
from ._results import NOT_PAPER_PARAMETERS, claim, compare, format_table, summary, write_results
from ._rigid_body import (
    INTEGRATION_METHODS,
    RigidBodyState,
    angular_momentum,
    angular_velocity_from_angle_rates,
    box_inertia,
    check_inertia,
    euler_coefficients,
    integrate,
    kinetic_energy,
    newton_euler,
    newton_euler_as_printed,
    rotation_error,
)
from ._screws import (
    exp_so3,
    homogeneous_transform,
    line,
    moment_about_origin,
    relative_moment,
    rot_x,
    rot_y,
    rot_z,
    rotation_matrix,
    shift_reference,
    skew,
    transform_points,
    unit_screw,
)
from ._stiffness import (
    FIXED_HINGE_Y,
    HINGE_HINGE_Y,
    BeamSection,
    Frame,
    canonical_sign,
    condense,
    directional_stiffness,
    element_global,
    element_rotation,
    extremal_stiffness,
    find_empty_dofs,
    frame_element_local,
    hinged_element_local,
    node_dof,
    node_dofs,
    rectangle_section,
    release,
    schur_complement,
    transformation_matrix,
)
from ._singular import cluster_levels, null_direction, refine_roots, sign_change_segments, singular_crossings
from ._singular import Crossings, Refinement, classify_crossings, refine_brackets, zero_nodes
from ._sweep import sweep
from ._sweep import chunk_size_for
from ._small_matrices import det_small, inverse_small, solve_small

__version__ = "0.1.0"

__all__ = [
    # notebook parameters and the size guard
    "MemoryBudgetError",
    "NOT_PAPER_PARAMETERS",
    "ParameterSpec",
    "ParameterRule",
    "less",
    "not_all_zero",
    "check_memory",
    "check_parameter",
    "check_parameters",
    "choice",
    "flag",
    "memory_budget",
    "number",
    "numbers",
    "signs",
    "text",
    # the papers' printed values and report tables
    "load_reference_file",
    "markdown_table",
    "markdown_table_text",
    "paper_value",
    "reference_row",
    "compare_reference",
    "claim_reference",
    "A_matrix",
    "B_diagonal",
    "B_matrix",
    "DATA_DIR",
    "ForwardSolution",
    "Grid",
    "Mechanism",
    "LoadedMechanism",
    "load_mechanism",
    "actuator_efforts",
    "claim",
    "cluster_levels",
    "compare",
    "det_A",
    "det_B",
    "format_table",
    "forward_position",
    "forward_positions",
    "ForwardPositions",
    "InverseSolution",
    "detect_structure",
    "inverse_positions",
    "inverse_dynamics_lagrange",
    "inverse_dynamics_virtual_work",
    "inverse_jacobian",
    "inverse_jacobian_rows",
    "jacobian",
    "load_params",
    "load_reserve",
    "max_actuator_effort",
    "max_actuator_velocity",
    "max_gripper_force",
    "null_direction",
    "matrix_inverse",
    "refine_roots",
    "row_group_norms",
    "sign_change_segments",
    "singular_crossings",
    "solve_forward_position",
    "state_trajectory",
    "summary",
    "sweep",
    "chunk_size_for",
    "det_small",
    "inverse_small",
    "solve_small",
    "within_limits",
    "write_results",
    # design synthesis and atlases
    "DesignResult",
    "atlas",
    "exact_area",
    "latin_hypercube_starts",
    "maximise",
    "maximise_derivative_free",
    "maximise_min",
    "near_singularity",
    "penalised_min",
    "soft_area",
    "soft_indicator",
    "soft_max",
    "soft_min",
    # singular curves: roots told from poles and jumps, suspected double roots
    "Crossings",
    "Refinement",
    "classify_crossings",
    "refine_brackets",
    "zero_nodes",
    # screws and rigid-body dynamics (P5)
    "INTEGRATION_METHODS",
    "RigidBodyState",
    "angular_momentum",
    "angular_velocity_from_angle_rates",
    "box_inertia",
    "check_inertia",
    "euler_coefficients",
    "exp_so3",
    "homogeneous_transform",
    "integrate",
    "kinetic_energy",
    "line",
    "moment_about_origin",
    "newton_euler",
    "newton_euler_as_printed",
    "relative_moment",
    "rot_x",
    "rot_y",
    "rot_z",
    "rotation_error",
    "rotation_matrix",
    "shift_reference",
    "skew",
    "transform_points",
    "unit_screw",
    # structural stiffness from beam elements (P4)
    "BeamSection",
    "FIXED_HINGE_Y",
    "Frame",
    "HINGE_HINGE_Y",
    "canonical_sign",
    "condense",
    "directional_stiffness",
    "element_global",
    "element_rotation",
    "extremal_stiffness",
    "find_empty_dofs",
    "frame_element_local",
    "hinged_element_local",
    "node_dof",
    "node_dofs",
    "rectangle_section",
    "release",
    "schur_complement",
    "transformation_matrix",
]
