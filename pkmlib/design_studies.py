"""Moved to :mod:`pkmlib.design.studies`. This alias, the same module with a
``DeprecationWarning``, goes after one more release."""

from ._moved import alias_module

alias_module(__name__, "pkmlib.design_studies")
