"""Where each name that left ``pkmlib.*`` lives now (issue 22, after pkmlib 0.1.0).

``pkmlib.__getattr__`` still returns these for one release, with a ``DeprecationWarning`` that
names the new place; the README's "What moved" table lists them. The old module paths
``pkmlib.report``, ``pkmlib.rerun`` and ``pkmlib.design_studies`` are thin aliases that warn
the same way (:data:`MOVED_MODULES`, :func:`alias_module`)."""

import importlib
import sys
import warnings

#: old top-level name -> the subpackage that holds it now (same object, same name)
MOVED = {
    # pkmlib.stiffness
    "BeamSection": "pkmlib.stiffness",
    "FIXED_HINGE_Y": "pkmlib.stiffness",
    "Frame": "pkmlib.stiffness",
    "HINGE_HINGE_Y": "pkmlib.stiffness",
    "canonical_sign": "pkmlib.stiffness",
    "condense": "pkmlib.stiffness",
    "directional_stiffness": "pkmlib.stiffness",
    "element_global": "pkmlib.stiffness",
    "element_rotation": "pkmlib.stiffness",
    "extremal_stiffness": "pkmlib.stiffness",
    "find_empty_dofs": "pkmlib.stiffness",
    "frame_element_local": "pkmlib.stiffness",
    "hinged_element_local": "pkmlib.stiffness",
    "node_dof": "pkmlib.stiffness",
    "node_dofs": "pkmlib.stiffness",
    "rectangle_section": "pkmlib.stiffness",
    "release": "pkmlib.stiffness",
    "schur_complement": "pkmlib.stiffness",
    "transformation_matrix": "pkmlib.stiffness",
    # pkmlib.dynamics
    "INTEGRATION_METHODS": "pkmlib.dynamics",
    "RigidBodyState": "pkmlib.dynamics",
    "angular_momentum": "pkmlib.dynamics",
    "angular_velocity_from_angle_rates": "pkmlib.dynamics",
    "box_inertia": "pkmlib.dynamics",
    "check_inertia": "pkmlib.dynamics",
    "euler_coefficients": "pkmlib.dynamics",
    "integrate": "pkmlib.dynamics",
    "inverse_dynamics_lagrange": "pkmlib.dynamics",
    "inverse_dynamics_virtual_work": "pkmlib.dynamics",
    "kinetic_energy": "pkmlib.dynamics",
    "newton_euler": "pkmlib.dynamics",
    "newton_euler_as_printed": "pkmlib.dynamics",
    "rotation_error": "pkmlib.dynamics",
    "state_trajectory": "pkmlib.dynamics",
    # pkmlib.design
    "DesignResult": "pkmlib.design",
    "atlas": "pkmlib.design",
    "exact_area": "pkmlib.design",
    "latin_hypercube_starts": "pkmlib.design",
    "maximise": "pkmlib.design",
    "maximise_derivative_free": "pkmlib.design",
    "maximise_min": "pkmlib.design",
    "near_singularity": "pkmlib.design",
    "penalised_min": "pkmlib.design",
    "soft_area": "pkmlib.design",
    "soft_indicator": "pkmlib.design",
    "soft_max": "pkmlib.design",
    "soft_min": "pkmlib.design",
    # pkmlib.tools
    "ParameterRule": "pkmlib.tools",
    "ParameterSpec": "pkmlib.tools",
    "check_parameter": "pkmlib.tools",
    "check_parameters": "pkmlib.tools",
    "choice": "pkmlib.tools",
    "flag": "pkmlib.tools",
    "less": "pkmlib.tools",
    "not_all_zero": "pkmlib.tools",
    "number": "pkmlib.tools",
    "numbers": "pkmlib.tools",
    "signs": "pkmlib.tools",
    "text": "pkmlib.tools",
    "NOT_PAPER_PARAMETERS": "pkmlib.tools",
    "claim": "pkmlib.tools",
    "claim_reference": "pkmlib.tools",
    "compare": "pkmlib.tools",
    "compare_reference": "pkmlib.tools",
    "format_table": "pkmlib.tools",
    "load_reference_file": "pkmlib.tools",
    "paper_value": "pkmlib.tools",
    "reference_row": "pkmlib.tools",
    "summary": "pkmlib.tools",
    "write_results": "pkmlib.tools",
    "markdown_table": "pkmlib.tools",
    "markdown_table_text": "pkmlib.tools",
}

#: old module path -> new module path
MOVED_MODULES = {
    "pkmlib.report": "pkmlib.tools.report",
    "pkmlib.rerun": "pkmlib.tools.rerun",
    "pkmlib.design_studies": "pkmlib.design.studies",
}


def moved_message(old: str, new: str) -> str:
    """The DeprecationWarning's text: where ``old`` went, and that the old spelling goes."""
    return f"{old} moved to {new}; the old name works for one more release (see the README, 'What moved')"


def alias_module(name: str, old: str) -> None:
    """Run by the old module ``old`` (its ``__name__`` is ``name``): warn that it moved to
    :data:`MOVED_MODULES` ``[old]`` and become that module; as a command (``python -m old``,
    ``name == "__main__"``) run the new module's ``main`` instead. The warning is attributed to
    the importer, or to ``__main__`` for a command, where Python shows it."""
    new = MOVED_MODULES[old]
    warnings.warn(moved_message(old, new), DeprecationWarning, stacklevel=2 if name == "__main__" else 3)
    module = importlib.import_module(new)
    if name == "__main__":
        sys.exit(module.main())
    sys.modules[name] = module
