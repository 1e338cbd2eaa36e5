"""P5 (Kheylo et al. 2022, decoupled 6-DOF): the six accelerations over the six motor forces.

The accelerations are affine in the forces at a fixed pose and angular velocity (P5 eq 8:
``F = sum P_i r_i``, ``M = sum P_i mom(R_i, .)``, then Newton-Euler), ``a = G P + c`` with
``G = d(a)/dP`` by ``jax.jacfwd`` of ``decoupled_6dof.forward_dynamics`` and ``c`` its value at
``P = 0`` (the gyroscopic term). The page computes ``G P + c`` exactly (float64) from the
exported matrix, for any forces within the sliders' range.
"""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np

from .. import _params, _screws
from ..mechanisms import decoupled_6dof as m
from ._store import write_figure

NOTEBOOK = "p5_decoupled_6dof_dynamics"
#: The notebook's parameters cell (P5's numeric example).
PAPER = {
    "angles_deg": (30.0, 30.0, 30.0),
    "position_m": (0.1, 0.15, 0.2),
    "forces_N": (1.0, 1.0, 2.0, 2.0, 3.0, 3.0),
    "omega_rad_s": (3.0, 2.0, 1.0),
}
#: Slider range and step of every motor force, N (any value in between is exact, the map is affine).
FORCE_RANGE_N = (-5.0, 5.0, 0.25)


def _accelerations(P, p):
    T = jnp.asarray(PAPER["position_m"], dtype=jnp.float64)
    R = _screws.rotation_matrix(*np.deg2rad(PAPER["angles_deg"]))
    lin, ang = m.forward_dynamics(T, R, jnp.asarray(PAPER["omega_rad_s"], dtype=jnp.float64), P, p)
    return jnp.concatenate([lin, ang])


@functools.cache
def _compiled():
    p = m.Decoupled6DofParams.from_dict(_params.load_params("p5")["mechanism"])
    f = functools.partial(_accelerations, p=p)
    return jax.jit(f), jax.jit(jax.jacfwd(f))


def accelerations(forces_N) -> np.ndarray:
    """(a_x, a_y, a_z, eps_xi, eps_eta, eps_zeta) at P5's example pose and angular velocity, by
    ``decoupled_6dof.forward_dynamics`` (m/s^2 in the base frame, rad/s^2 on the moving axes)."""
    return np.asarray(_compiled()[0](jnp.asarray(forces_N, dtype=jnp.float64)))


def affine_map() -> tuple[np.ndarray, np.ndarray]:
    """``(G, c)`` with accelerations ``= G @ forces + c`` (G by ``jax.jacfwd``, c at zero forces)."""
    G = np.asarray(_compiled()[1](jnp.zeros(6, dtype=jnp.float64)))
    return G, accelerations(np.zeros(6))


def write(out) -> list:
    """The P5 figure into ``out/p5_accelerations`` (one manifest, no further files)."""
    G, c = affine_map()
    # the map is affine: G P + c reproduces forward_dynamics at the paper's forces and at others
    for P in (PAPER["forces_N"], (1.0, -2.0, 0.5, 3.0, -1.5, 2.0)):
        np.testing.assert_allclose(G @ np.asarray(P) + c, accelerations(P), rtol=1e-12, atol=1e-12)
    lo, hi, step = FORCE_RANGE_N
    controls = [
        {
            "name": f"P_{i + 1}",
            "label": f"P{'₁₂₃₄₅₆'[i]}",
            "unit": "N",
            "min": lo,
            "max": hi,
            "step": step,
            "paper": PAPER["forces_N"][i],
            "digits": 4,
            "kind": "slider",
            "axis": "xxyyzz"[i],
        }
        for i in range(6)
    ]
    outputs = [
        {"name": n, "label": lab, "unit": u}
        for n, lab, u in (
            ("a_x", "a_x", "m/s²"),
            ("a_y", "a_y", "m/s²"),
            ("a_z", "a_z", "m/s²"),
            ("eps_xi", "ε_ξ", "rad/s²"),
            ("eps_eta", "ε_η", "rad/s²"),
            ("eps_zeta", "ε_ζ", "rad/s²"),
        )
    ]
    manifest = {
        "kind": "linear",
        "notebook": NOTEBOOK,
        "title": "P5 accelerations of the platform",
        "controls": controls,
        "outputs": outputs,
        "param": "forces_N",
        "G": G.tolist(),
        "c": c.tolist(),
        "digits": 4,
        "resolution": f"exact: the accelerations are affine in the forces, G P + c with the 6 x 6 matrix G = d(a, ε)/dP "
        f"(jax.jacfwd of decoupled_6dof.forward_dynamics); sliders from {lo:g} to {hi:g} N by {step:g} N",
        "fixed": "α = β = γ = 30°, O_m = (0.1, 0.15, 0.2) m, ω = (3, 2, 1) rad/s (P5's example)",
    }
    return write_figure(out, "p5_accelerations", manifest, {})
