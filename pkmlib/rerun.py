"""Moved to :mod:`pkmlib.tools.rerun` (``python -m pkmlib.tools.rerun``). This alias, the same module with a
``DeprecationWarning``, goes after one more release."""

from ._moved import alias_module

alias_module(__name__, "pkmlib.rerun")
