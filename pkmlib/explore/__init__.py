"""Interactive figures for the site: the paper figures' maps precomputed over their controls.

JAX does not run in a browser, so ``python -m pkmlib.explore --out site/explore/data`` (part of
``make report``) sweeps each interactive figure's controls at the resolutions stated in its
module and writes compact data files (:mod:`pkmlib.explore._store`); ``site/explore/pk-explore.js``
draws them. Every value is computed by the same pkmlib function on the same grid as the
notebook's static figure, so at the paper's parameters the page shows the static figure's values.

One module per paper; each has ``write(out)`` returning the files it wrote:

* :mod:`pkmlib.explore.p1`: P1 Figs 2, 4, 5, 6a over phi and s, Fig 6b over the external load.
* :mod:`pkmlib.explore.p2`: P2 Figs 2a, 3a, 4a, 4b over phi, the reading of l3 and the working mode.
* :mod:`pkmlib.explore.p3`: P3 Figs 9 and 11, the workspace sections over the section's position.
* :mod:`pkmlib.explore.p4`: P4 Figs 5-6 over the proximal/distal length ratio.
* :mod:`pkmlib.explore.p5`: P5's six accelerations over the six motor forces (an exported affine map).
* :mod:`pkmlib.explore.design`: the design page's P2 atlas with a design picker, that design's maps.
"""

from __future__ import annotations

from . import design, p1, p2, p3, p4, p5

#: figure module per name, in the order they are written
MODULES = {"p1": p1, "p5": p5, "p4": p4, "p2": p2, "p3": p3, "design": design}

__all__ = ["MODULES", "design", "p1", "p2", "p3", "p4", "p5"]
