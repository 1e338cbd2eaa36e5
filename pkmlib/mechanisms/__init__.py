"""Mechanisms of the reproduced papers, each built on the pkmlib core.

Every module follows one contract (checked for every registered paper by
``tests/test_contract.py``; the papers are registered in :mod:`pkmlib._papers`):

- ``PAPER``: its key in the registry (``"p1"`` .. ``"p5"``).
- ``UNITS``: the module's one unit convention, ``{quantity: unit}`` (``"length"``, ``"angle"``,
  ...); every output and actuator unit of its mechanisms is one of them.
- A parameters class (a JAX pytree) whose ``from_dict`` takes the whole
  ``data/params/<paper>.json`` as :func:`pkmlib.load_params` returns it, and
  ``load_params(key=None, source=None)``, which reads that file (or ``source``: another name, a
  path or a dict of the same layout) and returns the checked parameters of mechanism ``key``.
- ``MECHANISMS``: ``{key: pkmlib.Mechanism}``, the paper's mechanisms (``{"A": ..., "B": ...}``
  for P3, one entry elsewhere); a module with one mechanism also names it ``mechanism``.
- ``PAPER_BRANCH``: the inverse-position branch the paper's analysis uses, a tuple of signs (the
  mechanism's ``default_branch``), a dict by mechanism key for P3, None for P5 (one inverse
  solution). Every sign pattern of the mechanism's ``branch_size`` is a branch
  (:func:`sign_branches`); where the paper orders them, ``INVERSE_BRANCHES`` (P3, Table 2) and
  the closed-form forward branches ``FORWARD_BRANCHES`` (P3, Table 1) are dicts by key too.
- ``pose(...)``: the output vector ``x`` from its coordinates, in the order of the mechanism's
  ``output_names``.
- ``pose_criteria(x, params, ..., branch=PAPER_BRANCH)``: everything the paper maps at one pose
  (P1, P2; P4's is its stiffness, ``pose_stiffness``). P3 and P5 have no pointwise criteria.
- ``draw(ax, x, params, branch=PAPER_BRANCH, ...)``: the mechanism drawn from the same model,
  on a matplotlib axes. P5's dynamics (and its drawing) take the pose as ``(position,
  rotation)``, ``draw(ax, position, rotation, params, ...)``; ``position_rotation(x)`` turns its
  ``x`` into them.

Old names (``DEFAULT_BRANCH``, ``WORKING_MODE``, ``TABLE1_BRANCHES_A``, ...) still work for one
release and warn with a ``DeprecationWarning`` naming the new one.

P5's mechanism: the carriage coordinates follow from the constraint equations
``q_i = r_i . A_i^b(x)`` (P5 eq 2-4) with ``x = (x, y, z, alpha, beta, gamma)`` (the position of
O_m and P5's angles), so it is a :class:`pkmlib.Mechanism` like the others (chainwise, ``B = I``);
its J^-1 is in angle rates, whereas :func:`decoupled_6dof.wrench_jacobian` is in small rotations
about the moving axes (the two differ by the angle-rate map).
"""

from . import decoupled_6dof, five_bar, gripper_4prr, three_rrr, two_t_one_r
from ._contract import sign_branches as sign_branches  # re-exported (the contract's branches)

__all__ = ["decoupled_6dof", "five_bar", "gripper_4prr", "three_rrr", "two_t_one_r"]
