"""Mechanisms of the reproduced papers, each built on the pkmlib core."""

from . import gripper_4prr, three_rrr

__all__ = ["gripper_4prr", "three_rrr"]
