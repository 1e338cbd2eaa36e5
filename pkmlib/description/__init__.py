"""Mechanisms as data: a description file (``data/mechanisms/*.yaml``) -> :class:`pkmlib.Mechanism`.

The format is specified in ``data/mechanisms/README.md``; :func:`load_mechanism` is the entry
point (also ``pkmlib.load_mechanism``).
"""

from ._closures import Closure, Element
from ._expressions import Expression, compile_expression
from ._format import JOINT_FREEDOM, Description, Joint, Output, parse_description
from ._loader import LoadedMechanism, load_mechanism
from ._urdf import load_urdf_mechanism, urdf_description

__all__ = [
    "JOINT_FREEDOM",
    "Closure",
    "Description",
    "Element",
    "Expression",
    "Joint",
    "LoadedMechanism",
    "Output",
    "compile_expression",
    "load_mechanism",
    "load_urdf_mechanism",
    "parse_description",
    "urdf_description",
]
