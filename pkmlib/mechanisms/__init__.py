"""Mechanisms of the reproduced papers, each built on the pkmlib core."""

from . import gripper_4prr

__all__ = ["gripper_4prr"]
