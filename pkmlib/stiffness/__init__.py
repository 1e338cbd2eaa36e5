"""Structural stiffness from 12 x 12 beam elements (P4): sections, static condensation of the
hinges, assembly of a frame, the stiffness along a direction and its extremes.

Formerly at ``pkmlib.*`` (those names still work for one release, with a ``DeprecationWarning``)."""

from .._stiffness import (
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

__all__ = [
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
