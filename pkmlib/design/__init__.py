"""Design synthesis and performance atlases: smooth versions of the papers' workspace measures,
L-BFGS-B with exact JAX gradients, SQP for max-min problems, a derivative-free baseline, atlases
over designs x poses. The studies of ``notebooks/design_studies.ipynb`` are
:mod:`pkmlib.design.studies` (``from pkmlib.design import studies``; imported on demand).

Formerly at ``pkmlib.*`` and ``pkmlib.design_studies`` (those still work for one release, with a
``DeprecationWarning``)."""

from .._design import (
    DesignResult,
    atlas,
    exact_area,
    latin_hypercube_starts,
    maximise,
    maximise_derivative_free,
    maximise_min,
    near_singularity,
    penalised_min,
    soft_area,
    soft_indicator,
    soft_max,
    soft_min,
)

__all__ = [
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
]
