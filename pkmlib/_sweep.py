"""Evaluate any pointwise function over a grid: ``jit`` + ``vmap``, in chunks, float64, on one
device or sharded over several devices and hosts."""

from __future__ import annotations

import collections
import functools
import math
import numbers
import sys
from typing import Any, Callable, Sequence

import jax
import jax.numpy as jnp
import numpy as np

from . import _config  # noqa: F401  (float64)
from ._grid import Grid
from ._memory import check_memory
from ._validation import check_callable, check_flag

#: Sweeps with more points than this show a progress bar unless told otherwise.
PROGRESS_MIN_POINTS = 1_000_000
#: The most points per compiled call (and device) that ``chunk_size="auto"`` chooses.
DEFAULT_CHUNK = 1 << 16
#: ``chunk_size="auto"`` first compiles this many points per call and reads the temporaries.
PROBE_CHUNK = 1 << 13
#: With ``chunk_size="auto"``, XLA temporaries of one compiled call (per device) stay under this.
#: Each call costs more than its points (XLA splits a fused loop over the cores only when it is
#: long enough), so the largest chunk whose temporaries stay in the caches is fastest. Measured on
#: 2 cores (AMD EPYC with AVX2, 32 MiB L3; ``benchmarks/p1.py``, ``p2.py``, ``p3.py``; time over
#: numba's at 16384 / 32768 / 65536 / 131072 points per call): P1's seven maps (vmap, 2.6 MiB of
#: temporaries at 8192) 3.16 / 2.90 / 3.02 / 7.34, P2's maps (batched) 2.50 / 2.40 / 2.39 / 3.47
#: and (vmap) 1.25 / 1.19 / 1.12 / 1.30, P3's workspace 2.23 / 1.91 / 1.30 / 1.92, P1's eq (6)
#: 3.59 / 2.42 / 1.88 / 1.82. A 4 MiB budget chose 8192 points for P1's seven maps (3.90).
TEMP_BUDGET_BYTES = 16 * 2**20
#: The smallest chunk ``"auto"`` chooses.
MIN_AUTO_CHUNK = 256
#: The results of the compiled calls that ``sweep`` keeps dispatched ahead of its host copies, in
#: bytes (at least one call's). XLA runs them one after another while the host copies the first
#: that is done.
FETCH_WINDOW_BYTES = 256 * 2**20
#: Name of the mesh axis the points are sharded over.
POINTS_AXIS = "points"
#: Leaves with 2 to this many numbers per point are taken apart into their numbers and stacked
#: again inside the compiled call (:func:`_split_leaves`).
SPLIT_MAX_NUMBERS = 64


def _check_chunk_size(chunk_size: Any) -> int | str:
    """A positive whole number of points, or ``"auto"``; anything else is a ``ValueError``."""
    if isinstance(chunk_size, str) and chunk_size == "auto":
        return "auto"
    ok = False
    if isinstance(chunk_size, (bool, np.bool_)):
        ok = False
    elif isinstance(chunk_size, numbers.Integral):
        ok = int(chunk_size) > 0
    elif isinstance(chunk_size, numbers.Real):
        v = float(chunk_size)
        ok = math.isfinite(v) and v > 0 and v.is_integer()
    if not ok:
        raise ValueError(f"chunk_size must be a positive whole number of points or 'auto', got {chunk_size!r}")
    return int(chunk_size)


def _mesh(devices: Any) -> jax.sharding.Mesh | None:
    """``None`` (one device, no sharding), a sequence of devices, ``"all"`` or a one-axis ``Mesh``."""
    if devices is None:
        return None
    if isinstance(devices, jax.sharding.Mesh):
        if devices.axis_names != (POINTS_AXIS,):
            raise ValueError(
                f"devices: a Mesh must have the single axis {POINTS_AXIS!r}, got axes {devices.axis_names}"
            )
        return devices
    if isinstance(devices, str):
        if devices != "all":
            raise ValueError(f"devices must be None, 'all', a sequence of JAX devices or a Mesh, got {devices!r}")
        devices = jax.devices()
    try:
        devs = list(devices)
    except TypeError:
        raise ValueError(f"devices must be None, 'all', a sequence of JAX devices or a Mesh, got {devices!r}") from None
    if not devs or not all(isinstance(d, jax.Device) for d in devs):
        raise ValueError(f"devices must be None, 'all', a non-empty sequence of JAX devices or a Mesh, got {devices!r}")
    if len(set(devs)) != len(devs):
        raise ValueError("devices: the same device is listed twice")
    return jax.sharding.Mesh(np.array(devs), (POINTS_AXIS,))


def _chunk_points(first: Any, starts: Any, steps: Any, counts: Any, n: Any, chunk: int) -> Any:
    """The ``chunk`` grid points with flat (row-major) indices ``first, first + 1, ...``, as
    ``(ndim, chunk)``.

    Indices past the grid's end repeat its last point (cut off on the host). The multi-index is
    taken in float64 as ``floor((k + 1/2) * (1 / count))`` (exact below 2**50 points: the
    rounding error stays far below the 1/2 margin), so the loop stays vectorised and uses no
    divider, and coordinates are ``start + i * step`` exactly as :attr:`Grid.axes` computes them.
    """
    k = jnp.minimum(first + jnp.arange(chunk, dtype=jnp.float64), n - 1.0)
    ndim = starts.shape[0]
    inv_counts = 1.0 / counts
    index = [None] * ndim
    for a in range(ndim - 1, 0, -1):
        q = jnp.floor((k + 0.5) * inv_counts[a])
        index[a] = k - q * counts[a]
        k = q
    index[0] = k
    # The select (always true) keeps LLVM from contracting start + i * step into one fused
    # multiply-add, which would round differently from NumPy's Grid.axes (seen: 0.1 + 3 * 0.3).
    index = jnp.stack(index)
    offsets = jnp.where(index >= 0.0, index * steps[:, None], jnp.nan)
    return starts[:, None] + offsets


def _split_leaves(tree: Any, batched: bool) -> list:
    """The leaves of ``tree`` as a flat list, each with the points on its first axis. A leaf of 2
    to :data:`SPLIT_MAX_NUMBERS` numbers per point is taken apart into its numbers, one array
    each, and stacked again points first. ``batched``: leaves ``(*out, chunk)``; otherwise one
    point's leaves ``out`` (under ``vmap``).

    XLA writes several outputs of one fused loop in that loop, computing what they share once; the
    leaf as the function stacked it was a concatenation, whose fused loop evaluated each number's
    whole expression on its own (P3's workspace: six numbers, three of them from one arctan and
    two square roots; the stacked leaf ran at 2.05e7 points/s, its six numbers apart at 3.0e7,
    bit-equal). Its numbers apart, one multi-output loop computes them and one copy in the cache
    stacks them (P3's compiled chunk: one arctan, two square roots, 7 loops), so the host copies
    each leaf whole, not number by number into strided columns (P3's workspace, 2.5 million
    points: 0.87x the time of the numbers written on the host, bit-equal). With today's XLA the
    leaf left as the function stacked it also computes one arctan (4 loops), but its last bits
    differ (1e-14 on P3's workspace), so the stored results would move: kept split."""
    out = []
    for a in jax.tree_util.tree_leaves(tree):
        per_point = a.shape[:-1] if batched else a.shape
        k = math.prod(per_point)
        if 1 < k <= SPLIT_MAX_NUMBERS:
            rows = a.reshape((k, a.shape[-1]) if batched else (k,))
            stacked = jnp.stack([rows[i] for i in range(k)], axis=-1 if batched else 0)
            out.append(stacked.reshape(((a.shape[-1],) if batched else ()) + per_point))
        else:
            out.append(jnp.moveaxis(a, -1, 0) if batched else a)
    return out


def _build(fn: Callable, chunk: int, batched: bool, n_args: int, mesh) -> Callable:
    """The jitted evaluation of one chunk (``chunk`` points per device): the leaves of ``fn``'s
    result, flat, as :func:`_split_leaves` returns them."""

    def split(*a):
        return _split_leaves(fn(*a), batched)

    fn_b = split if batched else jax.vmap(split, in_axes=(1,) + (None,) * n_args)

    def body(first, starts, steps, counts, n, *args):
        return fn_b(_chunk_points(first, starts, steps, counts, n, chunk), *args)

    if mesh is None:  # JAX's default device, through the same shard_map: the same program
        mesh = jax.sharding.Mesh(np.array(jax.devices()[:1]), (POINTS_AXIS,))
    P = jax.sharding.PartitionSpec

    def local(first, starts, steps, counts, n, *args):
        offset = (jax.lax.axis_index(POINTS_AXIS) * chunk).astype(jnp.float64)
        return body(first + offset, starts, steps, counts, n, *args)

    sharded = jax.shard_map(local, mesh=mesh, in_specs=(P(),) * (5 + n_args), out_specs=P(POINTS_AXIS), check_vma=False)
    return jax.jit(sharded)


@functools.lru_cache(maxsize=64)
def _compiled(
    fn: Callable, ndim: int, chunk: int, auto: bool, batched: bool, mesh, arg_avals: tuple
) -> tuple[Any, int]:
    """Compiled chunk function and its chunk size, cached per function object (not per grid:
    the grid's starts, steps and counts are run-time arguments)."""
    scalars = (jax.ShapeDtypeStruct((), jnp.float64),)
    vectors = (jax.ShapeDtypeStruct((ndim,), jnp.float64),) * 3
    treedef, leaves = arg_avals
    args = tuple(jax.tree_util.tree_unflatten(treedef, leaves))
    avals = scalars + vectors + scalars + args

    def compile_at(c):
        return _build(fn, c, batched, len(args), mesh).lower(*avals).compile()

    if not auto:
        return compile_at(chunk), chunk
    # "auto": compile a probe chunk, read XLA's temporaries (they grow in proportion to the
    # chunk), and compile again at the largest power of two within the budget when that differs.
    probe = min(chunk, PROBE_CHUNK)
    compiled = compile_at(probe)
    temp = _temp_bytes(compiled)
    if not temp:
        target = chunk
    else:
        target = 1 << int(math.floor(math.log2(max(1.0, probe * TEMP_BUDGET_BYTES / temp))))
        target = min(chunk, max(MIN_AUTO_CHUNK, target))
    if target == probe:
        return compiled, probe
    return compile_at(target), target


def _temp_bytes(compiled) -> int | None:
    try:
        return int(compiled.memory_analysis().temp_size_in_bytes)
    except Exception:  # noqa: BLE001  (a backend without memory analysis: keep the default chunk)
        return None


def _compiled_for(fn, grid: Grid, chunk_request, batched, mesh, args) -> tuple[Any, int]:
    args = _as_arrays(args)
    n_dev = 1 if mesh is None else mesh.size
    cap = DEFAULT_CHUNK if chunk_request == "auto" else chunk_request
    chunk = min(cap, math.ceil(grid.size / n_dev))
    return _compiled(fn, grid.ndim, chunk, chunk_request == "auto", bool(batched), mesh, _avals(args))


def chunk_size_for(
    fn: Callable,
    grid: Grid,
    *,
    args: tuple = (),
    batched: bool = False,
    chunk_size: int | str = "auto",
    devices: Any = None,
) -> int:
    """The points per device per compiled call that :func:`sweep` uses for ``fn`` on ``grid``."""
    if not isinstance(grid, Grid):
        raise ValueError(f"grid must be a pkmlib Grid, got {type(grid).__name__}")
    check_callable("fn", fn, "a function fn(point, *args) of one grid point")
    batched = check_flag("batched", batched)
    args = _as_arrays(args)
    mesh = _mesh(devices)
    return _compiled_for(fn, grid, _check_chunk_size(chunk_size), batched, mesh, args)[1]


def _as_arrays(args: Any) -> tuple:
    """``args`` as a tuple of pytrees of strongly typed arrays (so 0.3 and np.float64(0.3) share
    compiled code)."""
    if not isinstance(args, (tuple, list)):
        raise ValueError(f"args must be a tuple of fn's further arguments, got {type(args).__name__}")
    return tuple(jax.tree_util.tree_map(lambda a: jnp.asarray(a, dtype=jnp.result_type(a)), tuple(args)))


def _avals(args: tuple) -> tuple:
    """A hashable description of ``args``: their tree structure and each leaf's shape and dtype."""
    leaves, treedef = jax.tree_util.tree_flatten(args)
    return treedef, tuple(jax.ShapeDtypeStruct(a.shape, a.dtype, weak_type=a.weak_type) for a in leaves)


def _fetch(tree: Any) -> Any:
    """Device arrays to host NumPy, gathering across hosts when the mesh spans several."""
    if jax.process_count() > 1:
        from jax.experimental import multihost_utils

        return jax.tree_util.tree_map(np.asarray, multihost_utils.process_allgather(tree, tiled=True))
    return jax.tree_util.tree_map(np.asarray, jax.device_get(tree))


def sweep(
    fn: Callable[..., Any],
    grid: Grid,
    *,
    args: tuple = (),
    chunk_size: int | str = "auto",
    batched: bool = False,
    progress: bool | None = None,
    size_parameter: str | None = None,
    memory_budget: float | None = None,
    devices: Sequence[Any] | str | jax.sharding.Mesh | None = None,
) -> Any:
    """Evaluate ``fn(point)`` at every grid point and return arrays shaped like the grid.

    ``fn`` takes one point (shape ``(grid.ndim,)``, coordinates in the order of
    ``grid.names``) and returns an array or a pytree of arrays; each leaf comes back as a NumPy
    array of shape ``grid.shape + leaf.shape``. The grid is evaluated ``chunk_size`` points at a
    time, in its flat (row-major) order whatever its shape, by one compiled ``vmap`` of ``fn``;
    the points are generated inside the compiled function from the chunk's first index, so
    memory stays at the results plus the calls in flight (at most
    ``FETCH_WINDOW_BYTES`` of results, or one call's) even for 4-million-point maps. Poses outside
    the workspace give whatever ``fn`` gives there: pkmlib's position solutions give NaN.

    With ``batched=True``, ``fn`` is already vectorised in structure-of-arrays form: it takes
    points of shape ``(grid.ndim, chunk)`` and returns leaves of shape ``(*out, chunk)``, as
    pkmlib's Jacobian and criteria functions do when given ``(n, chunk)`` arrays. Neither form is
    faster everywhere: measured side by side on an AMD EPYC (Zen 4, AVX-512, 2 cores shared with
    other jobs; ``benchmarks/p1.py``, ``benchmarks/p2.py``), ``batched=True`` ran at 1.06-1.2x
    the ``vmap`` rate on P1's velocity map (about 1e8 points/s), 0.5-1.2x on P1's seven maps
    (about 1e7 points/s per CPU second either way), and 0.57-0.65x on P2's maps, where XLA's
    fusion recomputes sin/cos of the joint angles in each consumer loop (28 sines per point
    against 9 under ``vmap``). Time both for a heavy new function. A leaf of 2 to
    :data:`SPLIT_MAX_NUMBERS` numbers per point is taken apart into its numbers and stacked
    again, so that XLA computes what the numbers share once per point (P3's workspace map: 1.45x
    faster, bit-equal).

    Compiled code is cached per function object (and per number of grid axes, chunk size,
    devices and argument shapes), not per grid: a second grid with as many axes and at least
    ``chunk_size`` points (or exactly as many, if fewer) reuses it.

    Args:
        fn: pointwise function, traceable by JAX.
        grid: the :class:`Grid`.
        args: further arguments, ``fn(point, *args)``: pytrees of arrays passed to the compiled
            function at run time (loads, branches, fixed coordinates), so a second sweep with
            other values reuses the compiled code. Pass ``fn`` itself as a module-level function,
            not a fresh lambda, for the same reason: compiled code is cached per function object.
        chunk_size: points per compiled call and device, a positive whole number, or ``"auto"``
            (default): as many as keep XLA's temporaries under ``TEMP_BUDGET_BYTES`` (read from
            the compiled code's memory analysis), between ``MIN_AUTO_CHUNK`` and
            ``DEFAULT_CHUNK``; this costs a second compilation when the probe size is not it.
        batched: ``fn`` takes and returns structure-of-arrays batches (see above).
        progress: show a ``tqdm`` bar on stderr; default only when the grid has more than
            ``PROGRESS_MIN_POINTS`` points.
        size_parameter: the parameter that sets the grid's size (``"step_m"``), named in the
            error when the result would not fit in memory.
        memory_budget: bytes the results may take, counted twice up to ``FETCH_WINDOW_BYTES``
            (the calls in flight; default: ``$PKMLIB_MEMORY_BUDGET`` or half the machine's
            memory); a larger sweep fails at once with a ``ValueError``.
        devices: ``None`` (default: JAX's default device), ``"all"`` (every device JAX sees,
            across hosts after ``jax.distributed.initialize()``), a sequence of devices, or a
            ``jax.sharding.Mesh`` with the one axis ``"points"``. Each compiled call then
            evaluates ``chunk_size`` points on every device (``jax.shard_map``); the results are
            bit-equal to one device's.
    """
    chunk_request = _check_chunk_size(chunk_size)
    if not isinstance(grid, Grid):
        raise ValueError(f"grid must be a pkmlib Grid, got {type(grid).__name__}")
    check_callable("fn", fn, "a function fn(point, *args) of one grid point")
    batched = check_flag("batched", batched)
    if progress is not None:
        progress = check_flag("progress", progress)
    if not isinstance(args, tuple):
        raise ValueError(f"args must be a tuple (passed as fn(point, *args)), got {type(args).__name__}: {args!r}")
    mesh = _mesh(devices)
    n = grid.size
    args = _as_arrays(args)
    point = jax.ShapeDtypeStruct((grid.ndim, 1) if batched else (grid.ndim,), jnp.float64)
    out_shape = jax.eval_shape(fn, point, *args)
    per_point = sum(
        int(np.prod(l.shape[:-1] if batched else l.shape)) * np.dtype(l.dtype).itemsize
        for l in jax.tree_util.tree_leaves(out_shape)
    )
    check_memory(  # the results, and up to FETCH_WINDOW_BYTES of them in flight on the device
        float(n) * per_point + min(float(n) * per_point, FETCH_WINDOW_BYTES),
        what=f"a sweep of {n:.3g} points ({grid.shape})",
        parameter=size_parameter,
        budget=memory_budget,
    )
    run, chunk = _compiled_for(fn, grid, chunk_request, batched, mesh, args)
    per_call = chunk * (1 if mesh is None else mesh.size)
    n_calls = math.ceil(n / per_call)
    window = max(1, min(n_calls, FETCH_WINDOW_BYTES // max(1, per_call * per_point)))
    starts = np.asarray(grid.starts, dtype=np.float64)
    steps = np.asarray(grid.steps, dtype=np.float64)
    counts = np.asarray(grid.shape, dtype=np.float64)
    n_f = np.float64(n)
    if progress is None:
        progress = n > PROGRESS_MIN_POINTS
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=n_calls, desc=f"sweep {n} points", unit="chunk", file=sys.stderr)

    leaves, out_tree = jax.tree_util.tree_flatten(out_shape)
    out = [np.empty((n,) + (l.shape[:-1] if batched else l.shape), dtype=l.dtype) for l in leaves]
    in_flight: collections.deque = collections.deque()  # up to `window` calls (FETCH_WINDOW_BYTES)
    dispatched = 0
    for c in range(n_calls):
        while dispatched < n_calls and len(in_flight) < window:
            in_flight.append(run(np.float64(dispatched * per_call), starts, steps, counts, n_f, *args))
            dispatched += 1
        lo, hi = c * per_call, min((c + 1) * per_call, n)
        for o, part in zip(out, _fetch(in_flight.popleft())):
            o[lo:hi] = part[: hi - lo]
        if bar is not None:
            bar.update(1)
    if bar is not None:
        bar.close()
    return jax.tree_util.tree_unflatten(out_tree, [a.reshape(grid.shape + a.shape[1:]) for a in out])
