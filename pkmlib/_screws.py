"""Screws and lines in Pluecker coordinates, their relative (mutual) moment, and the paper's
homogeneous transform.

A screw is stored as a ``(..., 6)`` array ``(s, s0)``: the vector part ``s`` and the moment part
``s0`` about the origin of the frame it is written in (P5 writes the force screws as
``R_i(r_i, r_i^0)`` and the moving axes as ``(xi, xi^0)``, ...). A line (a screw of zero pitch)
through a point ``p`` along a unit vector ``s`` has ``s0 = p x s`` (P5, the moment part
``r_i^0 = r_Ai x r_i``). Every function broadcasts over leading axes.

P5 (Kheylo et al., J. Mach. Manuf. Reliab. 2022 no. 1) prints no equation numbers. pkmlib cites its
displayed equations by number in order of appearance:

- (P5 eq 1) the points ``A_i^m`` in the moving frame;
- (P5 eq 2) ``A_i^b = M_bm A_i^m``;
- (P5 eq 3) ``M_bm = [[R, T], [0, 1]]``, ``R = R_gamma R_beta R_alpha`` with the three elementary rotations;
- (P5 eq 4) the vector parts ``r_i`` of the force screws (along x, x, y, y, z, z);
- (P5 eq 5) the moment parts ``r_i^0 = r_Ai x r_i``;
- (P5 eq 6) the relative moments ``mom(R_i, xi) = r_i . xi^0 + r_i^0 . xi`` (and for eta, zeta);
- (P5 eq 7) the Newton-Euler equations in the moving (principal) frame;
- (P5 eq 8) the same with the moments written as sums of ``P_i mom(R_i, .)``.
"""

from __future__ import annotations

from typing import Any

import jax.numpy as jnp

from . import _config  # noqa: F401  (float64)
from ._validation import check_array, check_last_axes, check_last_axis

Array = Any


def rot_x(alpha: Array) -> Array:
    """``R_alpha``, rotation by ``alpha`` about x (P5 eq 3). Shape ``(..., 3, 3)``."""
    alpha = check_array("alpha", alpha, what="angle, rad")
    c, s = jnp.cos(alpha), jnp.sin(alpha)
    o, z = jnp.ones_like(c), jnp.zeros_like(c)
    return jnp.stack([jnp.stack([o, z, z], -1), jnp.stack([z, c, -s], -1), jnp.stack([z, s, c], -1)], -2)


def rot_y(beta: Array) -> Array:
    """``R_beta``, rotation by ``beta`` about y (P5 eq 3). Shape ``(..., 3, 3)``."""
    beta = check_array("beta", beta, what="angle, rad")
    c, s = jnp.cos(beta), jnp.sin(beta)
    o, z = jnp.ones_like(c), jnp.zeros_like(c)
    return jnp.stack([jnp.stack([c, z, s], -1), jnp.stack([z, o, z], -1), jnp.stack([-s, z, c], -1)], -2)


def rot_z(gamma: Array) -> Array:
    """``R_gamma``, rotation by ``gamma`` about z (P5 eq 3). Shape ``(..., 3, 3)``."""
    gamma = check_array("gamma", gamma, what="angle, rad")
    c, s = jnp.cos(gamma), jnp.sin(gamma)
    o, z = jnp.ones_like(c), jnp.zeros_like(c)
    return jnp.stack([jnp.stack([c, -s, z], -1), jnp.stack([s, c, z], -1), jnp.stack([z, z, o], -1)], -2)


def rotation_matrix(alpha: Array, beta: Array, gamma: Array) -> Array:
    """``R = R_gamma R_beta R_alpha`` (P5 eq 3): first about x by alpha, then y by beta, then z by
    gamma, all about the fixed base axes. Its columns are the moving axes xi, eta, zeta in the base
    frame."""
    return rot_z(gamma) @ rot_y(beta) @ rot_x(alpha)


def homogeneous_transform(alpha: Array, beta: Array, gamma: Array, T: Array) -> Array:
    """``M_bm = [[R, T], [0, 0, 0, 1]]`` (P5 eq 3), mapping moving-frame to base-frame coordinates.
    ``T`` is the position of the moving origin O_m in the base frame, ``(..., 3)``."""
    R = rotation_matrix(alpha, beta, gamma)
    T = check_last_axis("T", T, 3, "position of O_m in the base frame")
    top = jnp.concatenate([R, T[..., :, None]], axis=-1)
    bottom = jnp.broadcast_to(jnp.array([0.0, 0.0, 0.0, 1.0], dtype=R.dtype), top.shape[:-2] + (1, 4))
    return jnp.concatenate([top, bottom], axis=-2)


def transform_points(M: Array, points: Array) -> Array:
    """``A^b = M_bm A^m`` (P5 eq 2) for points ``(..., n, 3)`` in the moving frame (the homogeneous
    1 is appended here). Returns ``(..., n, 3)`` in the base frame."""
    M = check_last_axes("M", M, (4, 4), "homogeneous transform")
    points = check_last_axis("points", points, 3)
    return points @ jnp.swapaxes(M[..., :3, :3], -1, -2) + M[..., None, :3, 3]


def moment_about_origin(direction: Array, point: Array) -> Array:
    """Moment part of the line through ``point`` along ``direction``: ``point x direction``
    (P5 eq 5, ``r_i^0 = r_Ai x r_i``). The moment of a unit force on that line about the origin."""
    return jnp.cross(check_last_axis("point", point, 3), check_last_axis("direction", direction, 3))


def unit_screw(direction: Array, point: Array, pitch: Array = 0.0) -> Array:
    """Unit screw ``(s, point x s + pitch s)`` with ``s = direction / |direction|``, ``(..., 6)``.

    Pitch 0 gives a line (a pure force, P5's force screws ``R_i(r_i, r_i^0)``, eq 4-5); the moving
    axes ``(xi, xi^0)`` are the lines through O_m along the columns of R.
    """
    d = check_last_axis("direction", direction, 3)
    point = check_last_axis("point", point, 3)
    pitch = check_array("pitch", pitch)
    s = d / jnp.linalg.norm(d, axis=-1, keepdims=True)
    h = jnp.broadcast_to(pitch, s.shape[:-1])[..., None]
    s0 = moment_about_origin(s, point) + h * s
    return jnp.concatenate([s, s0], axis=-1)


def line(direction: Array, point: Array) -> Array:
    """Pluecker coordinates ``(s, point x s)`` of the line through ``point`` along the unit vector
    of ``direction`` (a unit screw of zero pitch; P5 eq 4-5)."""
    return unit_screw(direction, point, 0.0)


def relative_moment(S1: Array, S2: Array) -> Array:
    """Relative (mutual) moment ``mom(S1, S2) = s1 . s2^0 + s1^0 . s2`` (P5 eq 6).

    For a unit force on line 1 and an axis line 2 it is the moment of the force about that axis.
    For lines through ``p1``, ``p2`` it equals ``(p2 - p1) . (s2 x s1)``, of size ``d |sin(phi)|``
    for lines at distance d and angle phi. It does not depend on the reference point (see
    :func:`shift_reference`). Broadcasts over leading axes of ``(..., 6)``.
    """
    S1, S2 = check_last_axis("S1", S1, 6, "a screw"), check_last_axis("S2", S2, 6, "a screw")
    return jnp.sum(S1[..., :3] * S2[..., 3:], axis=-1) + jnp.sum(S1[..., 3:] * S2[..., :3], axis=-1)


def shift_reference(S: Array, d: Array) -> Array:
    """The same screw written about the point ``d`` instead of the origin:
    ``(s, s0 - d x s)`` (the moment about ``d`` of the line, P5 eq 5 with ``r_A - d``)."""
    S, d = check_last_axis("S", S, 6, "a screw"), check_last_axis("d", d, 3, "a point")
    s = S[..., :3]
    return jnp.concatenate([s, S[..., 3:] - jnp.cross(d, s)], axis=-1)


def skew(v: Array) -> Array:
    """The matrix ``[v]x`` with ``[v]x w = v x w``, ``(..., 3, 3)``; ``v`` is ``(..., 3)``."""
    v = check_last_axis("v", v, 3)
    x, y, z = v[..., 0], v[..., 1], v[..., 2]
    o = jnp.zeros_like(x)
    return jnp.stack([jnp.stack([o, -z, y], -1), jnp.stack([z, o, -x], -1), jnp.stack([-y, x, o], -1)], -2)


def exp_so3(v: Array) -> Array:
    """Rotation ``exp([v]x)`` by the angle ``|v|`` about ``v`` (Rodrigues' formula),
    ``I + sinc(th) [v]x + 1/2 sinc(th/2)^2 [v]x^2`` with ``sinc(x) = sin(x)/x``: no cancellation in
    ``1 - cos``, and a Taylor series below ``|v| = 1e-2`` so that values and JAX derivatives are
    finite at ``v = 0`` (the textbook ``sin(th)/th`` has a NaN gradient there). ``(..., 3)`` to
    ``(..., 3, 3)``."""
    v = check_last_axis("v", v, 3, "rotation vector")
    th2 = jnp.sum(v * v, axis=-1)
    small = th2 < 1e-4
    safe = jnp.where(small, 1.0, th2)  # the double-where trick: no NaN from the branch not taken
    th = jnp.sqrt(safe)
    sinc = jnp.where(small, 1.0 - th2 / 6.0 + th2**2 / 120.0, jnp.sin(th) / th)
    half = jnp.where(small, 1.0 - th2 / 24.0 + th2**2 / 1920.0, jnp.sin(0.5 * th) / (0.5 * th))
    K = skew(v)
    I = jnp.broadcast_to(jnp.eye(3, dtype=K.dtype), K.shape)
    return I + sinc[..., None, None] * K + (0.5 * half**2)[..., None, None] * (K @ K)
