"""Moved to :mod:`pkmlib.tools.rerun` (``python -m pkmlib.tools.rerun``). This alias, the same
module with a ``DeprecationWarning``, goes after one more release."""

import sys
import warnings

from ._moved import moved_message

# as a command (python -m pkmlib.rerun) the warning is attributed to __main__, so Python shows it
warnings.warn(
    moved_message("pkmlib.rerun", "pkmlib.tools.rerun"),
    DeprecationWarning,
    stacklevel=1 if __name__ == "__main__" else 2,
)

from .tools import rerun as _new  # noqa: E402

if __name__ == "__main__":
    sys.exit(_new.main())
sys.modules[__name__] = _new
