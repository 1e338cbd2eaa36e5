"""The library guide's example: a 2-RPR defined by its chain equations alone."""

import jax.numpy as jnp
import numpy as np

import pkmlib as pk
from conftest import assert_close


def chain(i, x, q_i, p):  # base joints at (0, 0) and (1, 0), leg lengths q
    bx = (0.0, 1.0)[i]
    return (x[0] - bx) ** 2 + x[1] ** 2 - q_i**2


def inverse(x, p, branch):
    return jnp.stack([jnp.hypot(x[0] - bx, x[1]) for bx in (0.0, 1.0)])


rpr = pk.Mechanism(name="2-RPR", chain_constraint=chain, inverse_position=inverse,
                   actuator_limits=lambda p: (jnp.zeros(2), jnp.full(2, 2.0)),
                   output_names=("x", "y"), output_units=("m", "m"),
                   actuator_names=("q1", "q2"), actuator_units=("m", "m"))


def test_two_rpr_maps_match_the_leg_direction_formula():
    grid = pk.Grid.from_ranges(x=(-0.5, 1.5, 0.25), y=(0.05, 1.0, 0.25))
    vel = pk.sweep(lambda pt: pk.max_actuator_velocity(
        pk.inverse_jacobian(rpr, pt, rpr.inverse(pt, None), None), [(0, 1)], [1.0]), grid)
    # q_i' = u_i . x' with u_i the unit leg vector: the max over unit x' is 1 for every leg
    assert_close(vel, np.ones(grid.shape), rtol=1e-12)
    det = pk.sweep(lambda pt: pk.det_A(rpr, pt, rpr.inverse(pt, None), None), grid)
    pts = grid.points()
    # det A = 4 * det([[x, y], [x - 1, y]]) = 4 y
    assert_close(det, 4 * pts[..., 1], rtol=1e-12)
