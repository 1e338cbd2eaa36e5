"""Evaluate any pointwise function over a grid: ``jit`` + ``vmap``, in chunks, float64."""

from __future__ import annotations

import functools
import math
import sys
from typing import Any, Callable

import jax
import jax.numpy as jnp
import numpy as np

from . import _config  # noqa: F401  (float64)
from ._grid import Grid
from ._memory import check_memory

#: Sweeps with more points than this show a progress bar unless told otherwise.
PROGRESS_MIN_POINTS = 1_000_000


@functools.lru_cache(maxsize=32)
def _chunk_function(fn: Callable, grid: Grid, rows: int, batched: bool, n_args: int = 0) -> Callable:
    """Compiled evaluation of ``rows`` consecutive slices of the grid along its first axis.

    The points of a chunk are generated inside the compiled function from the first-axis index
    and a constant block of the remaining axes (no per-point integer division). Cached, so a
    second sweep of the same function over the same grid does not compile again.
    """
    inner_axes = [jnp.asarray(a) for a in grid.axes[1:]]
    inner = [m.ravel() for m in jnp.meshgrid(*inner_axes, indexing="ij")] if inner_axes else []
    n_inner = int(np.prod(grid.shape[1:], dtype=np.int64))
    start0, step0, n0 = grid.starts[0], grid.steps[0], grid.shape[0]
    # Both forms return leaves shaped (*out, chunk): the points axis last.
    fn_b = fn if batched else jax.vmap(fn, in_axes=(1,) + (None,) * n_args, out_axes=-1)

    @jax.jit
    def run(first_row, *args):
        # The padded tail of the last chunk repeats the last slice; it is cut off on the host.
        i0 = jnp.minimum(first_row + jnp.arange(rows, dtype=jnp.int64), n0 - 1)
        x0 = jnp.repeat(start0 + i0.astype(jnp.float64) * step0, n_inner, total_repeat_length=rows * n_inner)
        others = [jnp.tile(c, rows) for c in inner]
        return fn_b(jnp.stack([x0, *others]), *args)  # points as (ndim, chunk)

    return run


def sweep(
    fn: Callable[..., Any],
    grid: Grid,
    *,
    args: tuple = (),
    chunk_size: int = 1 << 16,
    batched: bool = False,
    progress: bool | None = None,
    size_parameter: str | None = None,
    memory_budget: float | None = None,
) -> Any:
    """Evaluate ``fn(point)`` at every grid point and return arrays shaped like the grid.

    ``fn`` takes one point (shape ``(grid.ndim,)``, coordinates in the order of
    ``grid.names``) and returns an array or a pytree of arrays; each leaf comes back as a NumPy
    array of shape ``grid.shape + leaf.shape``. The grid is evaluated ``chunk_size`` points at a
    time (rounded to whole slices along the first axis) by one compiled ``vmap`` of ``fn`` (the
    points are generated inside the compiled function, so memory stays at a few chunks even for
    4-million-point maps). Poses outside the
    workspace give whatever ``fn`` gives there: pkmlib's position solutions give NaN.

    With ``batched=True``, ``fn`` is already vectorised in structure-of-arrays form: it takes
    points of shape ``(grid.ndim, chunk)`` and returns leaves of shape ``(*out, chunk)``, as
    pkmlib's Jacobian and criteria functions do when given ``(n, chunk)`` arrays. This skips
    ``vmap``'s per-point matrices and is several times faster for large maps.

    Args:
        fn: pointwise function, traceable by JAX.
        grid: the :class:`Grid`.
        args: further arguments, ``fn(point, *args)``: pytrees of arrays passed to the compiled
            function at run time (loads, branches, fixed coordinates), so a second sweep with
            other values reuses the compiled code. Pass ``fn`` itself as a module-level function,
            not a fresh lambda, for the same reason: compiled code is cached per function object.
        chunk_size: points per compiled call (> 0).
        progress: show a ``tqdm`` bar on stderr; default only when the grid has more than
            ``PROGRESS_MIN_POINTS`` points.
        size_parameter: the parameter that sets the grid's size (``"step_m"``), named in the
            error when the result would not fit in memory.
        memory_budget: bytes the results may take (default: ``$PKMLIB_MEMORY_BUDGET`` or half
            the machine's memory); a larger sweep fails at once with a ``ValueError``.
    """
    if int(chunk_size) <= 0:
        raise ValueError(f"chunk_size must be positive, got {chunk_size!r}")
    n = grid.size
    n_inner = n // grid.shape[0]
    rows = max(1, min(int(chunk_size) // n_inner, grid.shape[0]))
    chunk_size = rows * n_inner
    args = tuple(args)
    point = jax.ShapeDtypeStruct((grid.ndim, 1) if batched else (grid.ndim,), jnp.float64)
    out_shape = jax.eval_shape(fn, point, *args)
    per_point = sum(int(np.prod(l.shape[:-1] if batched else l.shape)) * np.dtype(l.dtype).itemsize
                    for l in jax.tree_util.tree_leaves(out_shape))
    check_memory(float(n) * per_point, what=f"a sweep of {n:.3g} points ({grid.shape})",
                 parameter=size_parameter, budget=memory_budget)
    run = _chunk_function(fn, grid, rows, batched, len(args))
    n_chunks = math.ceil(n / chunk_size)
    if progress is None:
        progress = n > PROGRESS_MIN_POINTS
    chunks = range(n_chunks)
    if progress:
        from tqdm import tqdm

        chunks = tqdm(chunks, desc=f"sweep {n} points", unit="chunk", file=sys.stderr)

    out = None
    pending = run(0, *args)
    for c in chunks:
        current = pending
        if c + 1 < n_chunks:
            pending = run((c + 1) * rows, *args)  # dispatched before the host copy below
        host = jax.tree_util.tree_map(lambda a: np.moveaxis(np.asarray(a), -1, 0), jax.device_get(current))
        if out is None:
            out = jax.tree_util.tree_map(lambda a: np.empty((n,) + a.shape[1:], dtype=a.dtype), host)
        lo, hi = c * chunk_size, min((c + 1) * chunk_size, n)
        jax.tree_util.tree_map(lambda o, h: o.__setitem__(slice(lo, hi), h[: hi - lo]), out, host)
    return jax.tree_util.tree_map(lambda a: a.reshape(grid.shape + a.shape[1:]), out)
