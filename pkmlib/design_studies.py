"""Moved to :mod:`pkmlib.design.studies`. This alias, the same module with a
``DeprecationWarning``, goes after one more release."""

import sys
import warnings

from ._moved import moved_message

warnings.warn(moved_message("pkmlib.design_studies", "pkmlib.design.studies"), DeprecationWarning, stacklevel=2)

from .design import studies as _new  # noqa: E402

sys.modules[__name__] = _new
