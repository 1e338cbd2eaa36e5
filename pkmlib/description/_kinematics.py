"""Rigid transforms of a mechanism description: frames, joint motions, points.

A frame is a pose in its parent: planar ``(theta, (p_x, p_y))`` (rotation about z by
``theta``), spatial ``(R, (p_x, p_y, p_z))`` with ``R`` a 3 x 3 nested tuple. Every entry is a
Python float or a JAX array of any shape, so one call transforms a whole grid of poses
("structure of arrays", as :mod:`pkmlib._jacobians` expects); the arithmetic skips exact zeros
and ones of constant geometry so that a description produces the same small expression graph
as a hand-written constraint function.

A joint's child frame in its parent is ``J M(v) T(-child_at)``: ``J`` the joint frame
(``at`` and ``rpy``; URDF's convention ``R = R_z(yaw) R_y(pitch) R_x(roll)``), ``M(v)`` the
motion at joint value ``v`` (a turn about ``axis`` by ``v`` for a revolute, Rodrigues' formula;
a shift ``v axis`` for a prismatic; none for a fixed joint) and ``T(-child_at)`` the shift that
puts the joint centre at ``child_at`` in the child's frame (README "Joints").
"""

from __future__ import annotations

import math
from typing import Any

import jax.numpy as jnp

Array = Any


def _zero(a) -> bool:
    return isinstance(a, float) and a == 0.0


def _one(a) -> bool:
    return isinstance(a, float) and a == 1.0


def mul(a, b):
    """``a * b`` with exact zeros and ones of constant geometry folded."""
    if _zero(a) or _zero(b):
        return 0.0
    if _one(a):
        return b
    if _one(b):
        return a
    return a * b


def add(*terms):
    """Sum with exact zeros folded."""
    out = 0.0
    for t in terms:
        if _zero(t):
            continue
        out = t if _zero(out) else out + t
    return out


def neg(a):
    return 0.0 if _zero(a) else -a


def sub(a, b):
    if _zero(b):
        return a
    if _zero(a):
        return -b
    return a - b


def const(v):
    """A Python float for a concrete value (so that zeros fold), else the value."""
    if isinstance(v, (int, float)):
        return float(v)
    return v


def cos(a):
    return 1.0 if _zero(a) else (math.cos(a) if isinstance(a, float) else jnp.cos(a))


def sin(a):
    return 0.0 if _zero(a) else (math.sin(a) if isinstance(a, float) else jnp.sin(a))


# --------------------------------------------------------------------------- planar
def planar_identity():
    return (0.0, (0.0, 0.0))


def planar_compose(f1, f2):
    t1, (x1, y1) = f1
    t2, (x2, y2) = f2
    c, s = cos(t1), sin(t1)
    return (add(t1, t2), (add(x1, mul(c, x2), neg(mul(s, y2))), add(y1, mul(s, x2), mul(c, y2))))


def planar_point(f, v):
    """The point ``v`` (in frame ``f``) in ``f``'s parent."""
    return planar_compose(f, (0.0, v))[1]


def planar_joint(at, rpy, axis, child_at, jtype: str, value):
    """Child frame of a planar joint in its parent (see the module docstring)."""
    J = (const(rpy[0]), tuple(const(a) for a in at))
    if jtype == "revolute":
        M = (value, (0.0, 0.0))
    elif jtype == "prismatic":
        ux, uy = (const(a) for a in axis)
        n = math.hypot(ux, uy) if isinstance(ux, float) and isinstance(uy, float) else jnp.hypot(ux, uy)
        M = (0.0, (mul(value, ux / n), mul(value, uy / n)))
    else:
        M = planar_identity()
    f = planar_compose(J, M)
    if child_at is not None:
        f = planar_compose(f, (0.0, tuple(neg(const(c)) for c in child_at)))
    return f


# --------------------------------------------------------------------------- spatial
IDENTITY3 = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))


def spatial_identity():
    return (IDENTITY3, (0.0, 0.0, 0.0))


def matmul(A, B):
    return tuple(tuple(add(*(mul(A[i][k], B[k][j]) for k in range(3))) for j in range(3)) for i in range(3))


def matvec(A, v):
    return tuple(add(*(mul(A[i][k], v[k]) for k in range(3))) for i in range(3))


def spatial_compose(f1, f2):
    R1, p1 = f1
    R2, p2 = f2
    Rp = matvec(R1, p2)
    return (matmul(R1, R2), tuple(add(p1[i], Rp[i]) for i in range(3)))


def spatial_point(f, v):
    R, p = f
    Rv = matvec(R, v)
    return tuple(add(p[i], Rv[i]) for i in range(3))


def axis_rotation(k, angle):
    """Rotation by ``angle`` about the unit axis ``k``: ``c I + s [k]x + (1 - c) k k^T`` (Rodrigues)."""
    c, s = cos(angle), sin(angle)
    omc = sub(1.0, c)
    K = ((0.0, neg(k[2]), k[1]), (k[2], 0.0, neg(k[0])), (neg(k[1]), k[0], 0.0))
    return tuple(
        tuple(add(c if i == j else 0.0, mul(s, K[i][j]), mul(omc, mul(k[i], k[j]))) for j in range(3)) for i in range(3)
    )


def _unit(v):
    v = tuple(const(a) for a in v)
    if all(isinstance(a, float) for a in v):
        n = math.sqrt(sum(a * a for a in v))
        if n == 0.0:
            raise ValueError("zero axis")
        return tuple(a / n for a in v)
    n = jnp.sqrt(sum(a * a for a in v))
    return tuple(a / n for a in v)


def rpy_matrix(rpy):
    roll, pitch, yaw = (const(a) for a in rpy)
    return matmul(
        axis_rotation((0.0, 0.0, 1.0), yaw),
        matmul(axis_rotation((0.0, 1.0, 0.0), pitch), axis_rotation((1.0, 0.0, 0.0), roll)),
    )


def spatial_joint(at, rpy, axis, child_at, jtype: str, value):
    """Child frame of a spatial joint in its parent (see the module docstring)."""
    J = (rpy_matrix(rpy), tuple(const(a) for a in at))
    if jtype == "revolute":
        M = (axis_rotation(_unit(axis), value), (0.0, 0.0, 0.0))
    elif jtype == "prismatic":
        u = _unit(axis)
        M = (IDENTITY3, tuple(mul(value, a) for a in u))
    else:
        M = spatial_identity()
    f = spatial_compose(J, M)
    if child_at is not None:
        f = spatial_compose(f, (IDENTITY3, tuple(neg(const(c)) for c in child_at)))
    return f


def unit(v):
    """``v / |v|`` (``ValueError`` for a constant zero vector)."""
    return _unit(v)
