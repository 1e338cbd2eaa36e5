"""Numerical configuration shared by every pkmlib module.

pkmlib computes in float64 throughout (README.md, "Conventions"): importing the package turns on
``jax_enable_x64`` before any array is created.
"""

import jax

jax.config.update("jax_enable_x64", True)
