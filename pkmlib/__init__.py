"""pkmlib: velocity, force and singularity analysis of parallel kinematic mechanisms in JAX.

A mechanism is its constraint equations F(x, q) = 0 plus its position solutions
(:class:`Mechanism`); A = dF/dx, B = dF/dq, J^-1, J, det(A), det(B) come from automatic
differentiation, and any pointwise quantity is swept over a workspace grid with ``jit`` +
``vmap`` (:func:`sweep`). Importing pkmlib turns on float64 in JAX.

``pkmlib.*`` holds the kinematics: mechanisms and their descriptions, position solutions,
Jacobians, criteria, grids, sweeps, singular curves, screws and rotations. The rest is in
subpackages: :mod:`pkmlib.stiffness` (beam-element stiffness), :mod:`pkmlib.dynamics` (rigid-body
and inverse dynamics), :mod:`pkmlib.design` (synthesis and atlases; ``pkmlib.design.studies``),
:mod:`pkmlib.tools` (notebook parameters, results and the papers' values; the commands
``python -m pkmlib.tools.report`` and ``python -m pkmlib.tools.rerun``), :mod:`pkmlib.mechanisms`
(the five papers), :mod:`pkmlib.plotting`. Names that moved out of ``pkmlib.*`` still work for one
release with a ``DeprecationWarning`` (``pkmlib/_moved.py``).
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
from ._grid import Grid
from ._jacobians import (
    A_matrix,
    B_diagonal,
    B_matrix,
    det_A,
    det_B,
    inverse_jacobian,
    inverse_jacobian_rows,
    jacobian,
    matrix_inverse,
)
from ._mechanism import Mechanism, within_limits
from .description import LoadedMechanism, load_mechanism, load_urdf_mechanism
from ._memory import MemoryBudgetError, check_memory, memory_budget
from ._params import DATA_DIR, load_params
from ._position import ForwardSolution, forward_position, solve_forward_position
from ._positions import ForwardPositions, InverseSolution, detect_structure, forward_positions, inverse_positions
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
from ._singular import cluster_levels, null_direction, refine_roots, sign_change_segments, singular_crossings
from ._singular import Crossings, Refinement, classify_crossings, refine_brackets, zero_nodes
from ._sweep import sweep
from ._sweep import chunk_size_for
from ._small_matrices import det_small, inverse_small, solve_small
from . import design, dynamics, stiffness, tools  # noqa: F401  (the subpackages, after the core they use)

__version__ = "0.1.0"

__all__ = [
    # mechanisms and their descriptions
    "Mechanism",
    "within_limits",
    "LoadedMechanism",
    "load_mechanism",
    "load_urdf_mechanism",
    "DATA_DIR",
    "load_params",
    # position solutions
    "ForwardPositions",
    "ForwardSolution",
    "InverseSolution",
    "detect_structure",
    "forward_position",
    "forward_positions",
    "inverse_positions",
    "solve_forward_position",
    # Jacobians and small matrices
    "A_matrix",
    "B_diagonal",
    "B_matrix",
    "det_A",
    "det_B",
    "inverse_jacobian",
    "inverse_jacobian_rows",
    "jacobian",
    "matrix_inverse",
    "det_small",
    "inverse_small",
    "solve_small",
    # velocity and force criteria
    "actuator_efforts",
    "load_reserve",
    "max_actuator_effort",
    "max_actuator_velocity",
    "max_gripper_force",
    "row_group_norms",
    # grids, sweeps and the size guard
    "Grid",
    "sweep",
    "chunk_size_for",
    "MemoryBudgetError",
    "check_memory",
    "memory_budget",
    # singular curves: roots told from poles and jumps, suspected double roots
    "Crossings",
    "Refinement",
    "classify_crossings",
    "cluster_levels",
    "null_direction",
    "refine_brackets",
    "refine_roots",
    "sign_change_segments",
    "singular_crossings",
    "zero_nodes",
    # screws and rotations (P5's Jacobian, P3's and P5's kinematics, the rigid-body dynamics)
    "exp_so3",
    "homogeneous_transform",
    "line",
    "moment_about_origin",
    "relative_moment",
    "rot_x",
    "rot_y",
    "rot_z",
    "rotation_matrix",
    "shift_reference",
    "skew",
    "transform_points",
    "unit_screw",
]

#: the subpackages, listed by dir(pkmlib) beside __all__
_SUBPACKAGES = ("description", "design", "dynamics", "mechanisms", "plotting", "stiffness", "tools")


def __getattr__(name: str):
    """An old top-level name (``pkmlib.BeamSection``, ...): the same object from its new place,
    with a ``DeprecationWarning`` naming it (pkmlib/_moved.py). Anything else: AttributeError."""
    from ._moved import MOVED, moved_message

    if name in MOVED:
        import importlib
        import warnings

        new = MOVED[name]
        warnings.warn(moved_message(f"pkmlib.{name}", f"{new}.{name}"), DeprecationWarning, stacklevel=2)
        return getattr(importlib.import_module(new), name)
    raise AttributeError(f"module 'pkmlib' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted([*__all__, *_SUBPACKAGES, "__version__"])
