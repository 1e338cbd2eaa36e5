"""Rectilinear grids of poses over which pointwise quantities are swept."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ._validation import check_finite, check_positive, check_range


@dataclasses.dataclass(frozen=True)
class Grid:
    """A regular grid ``start_i + k * step_i``, ``k = 0 .. count_i - 1``, over named axes.

    Arrays sampled on the grid have shape ``grid.shape == counts``, in the order of ``names``
    (NumPy's ``indexing="ij"``): for ``Grid.from_ranges(x_D=..., y_D=...)`` a map ``Z`` has
    ``Z[i, j]`` at ``(x_D[i], y_D[j])``.
    """

    names: tuple[str, ...]
    starts: tuple[float, ...]
    steps: tuple[float, ...]
    counts: tuple[int, ...]

    def __post_init__(self):
        if len(self.names) == 0:
            raise ValueError("grid: an empty grid (no axes) cannot be swept")
        if not (len(self.names) == len(self.starts) == len(self.steps) == len(self.counts)):
            raise ValueError("grid: names, starts, steps and counts must have the same length")
        for name, start, step, count in zip(self.names, self.starts, self.steps, self.counts):
            check_finite(f"{name} start", start)
            check_positive(f"{name} step", step)
            if int(count) < 1:
                raise ValueError(f"{name}: an axis needs at least one point, got count={count!r}")

    @classmethod
    def from_ranges(cls, **axes: tuple[float, float, float]) -> "Grid":
        """Build from ``name=(min, max, step)``; both ends included when ``step`` divides the range.

        Example (P1, the grid after eq (6)): ``Grid.from_ranges(x_D=(0.2, 1.2, 0.005),
        y_D=(-0.25, 0.25, 0.0025))`` has 201 x 201 points.
        """
        if not axes:
            raise ValueError("grid: an empty grid (no axes) cannot be swept")
        names, starts, steps, counts = [], [], [], []
        for name, spec in axes.items():
            if len(spec) != 3:
                raise ValueError(f"{name}: expected (min, max, step), got {spec!r}")
            lo, hi = check_range(name, spec[0], spec[1])
            step = float(spec[2])
            if step == 0.0:
                raise ValueError(f"{name} step must be non-zero (got 0)")
            check_positive(f"{name} step", step)
            names.append(name)
            starts.append(lo)
            steps.append(step)
            counts.append(int(math.floor((hi - lo) / step + 1e-9)) + 1)
        return cls(tuple(names), tuple(starts), tuple(steps), tuple(counts))

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(int(c) for c in self.counts)

    @property
    def size(self) -> int:
        return int(np.prod(self.shape))

    @property
    def ndim(self) -> int:
        return len(self.names)

    @property
    def axes(self) -> tuple[np.ndarray, ...]:
        """The coordinates along each axis, computed exactly as the sweep computes them."""
        return tuple(s + np.arange(c, dtype=np.float64) * h for s, h, c in zip(self.starts, self.steps, self.counts))

    def axis(self, name: str) -> np.ndarray:
        return self.axes[self.names.index(name)]

    @property
    def cell_area(self) -> float:
        """Product of the steps: the area (volume) one grid point stands for."""
        return float(np.prod(self.steps))

    def points(self) -> np.ndarray:
        """All points, shape ``grid.shape + (ndim,)`` (for small grids; sweeps never build this)."""
        return np.stack(np.meshgrid(*self.axes, indexing="ij"), axis=-1)
