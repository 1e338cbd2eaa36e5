"""Mechanisms of the reproduced papers, each built on the pkmlib core."""

from . import decoupled_6dof, five_bar, gripper_4prr, three_rrr, two_t_one_r

__all__ = ["decoupled_6dof", "five_bar", "gripper_4prr", "three_rrr", "two_t_one_r"]
