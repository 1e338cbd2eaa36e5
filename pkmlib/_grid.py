"""Rectilinear grids of poses over which pointwise quantities are swept."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ._validation import as_real, check_count, check_finite, check_positive, check_range

#: Largest number of points along one axis (a step far smaller than its range is a mistake, not a
#: grid: 1e9 float64 values are already 8 GB).
MAX_AXIS_POINTS = 10**9


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
        for field in ("names", "starts", "steps", "counts"):
            value = getattr(self, field)
            if isinstance(value, (str, bytes)) or not isinstance(value, (tuple, list, np.ndarray)):
                raise ValueError(f"grid: {field} must be a tuple with one entry per axis, got {value!r}")
        if len(self.names) == 0:
            raise ValueError("grid: an empty grid (no axes) cannot be swept")
        if not (len(self.names) == len(self.starts) == len(self.steps) == len(self.counts)):
            raise ValueError("grid: names, starts, steps and counts must have the same length")
        for name in self.names:
            if not isinstance(name, str) or not name:
                raise ValueError(f"grid: axis names must be non-empty strings, got {name!r}")
        if len(set(self.names)) != len(self.names):
            raise ValueError(f"grid: axis names must be distinct, got {tuple(self.names)!r}")
        starts, steps, counts = [], [], []
        for name, start, step, count in zip(self.names, self.starts, self.steps, self.counts):
            start = check_finite(f"grid axis {name} start", start)
            step = check_positive(f"grid axis {name} step", step)
            count = check_count(f"grid axis {name} count", count, minimum=1, maximum=MAX_AXIS_POINTS)
            _check_resolvable(name, start, step, count)
            starts.append(start)
            steps.append(step)
            counts.append(count)
        # Normalised, so that shape, axes and size always agree (counts=(3.0,) is 3 points).
        object.__setattr__(self, "names", tuple(self.names))
        object.__setattr__(self, "starts", tuple(starts))
        object.__setattr__(self, "steps", tuple(steps))
        object.__setattr__(self, "counts", tuple(counts))

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
            if isinstance(spec, (str, bytes)) or not isinstance(spec, (tuple, list, np.ndarray)) or len(spec) != 3:
                raise ValueError(f"grid axis {name}: expected (min, max, step), got {spec!r}")
            lo, hi = check_range(f"grid axis {name}", spec[0], spec[1])
            step = as_real(f"grid axis {name} step", spec[2], "a finite positive number")
            if step == 0.0:
                raise ValueError(f"grid axis {name} step must be a finite positive number (got 0)")
            step = check_positive(f"grid axis {name} step", step)
            span = (hi - lo) / step
            if not math.isfinite(span) or span + 1 > MAX_AXIS_POINTS:
                raise ValueError(
                    f"grid axis {name}: step {spec[2]!r} over [{lo!r}, {hi!r}] gives {span + 1:.3g} points; "
                    f"accepted: at most {MAX_AXIS_POINTS:.0e} points per axis (a larger step)"
                )
            names.append(name)
            starts.append(lo)
            steps.append(step)
            counts.append(int(math.floor(span + 1e-9)) + 1)
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
        if name not in self.names:
            raise ValueError(f"grid has no axis {name!r}; its axes are {self.names}")
        return self.axes[self.names.index(name)]

    @property
    def cell_area(self) -> float:
        """Product of the steps: the area (volume) one grid point stands for."""
        return float(np.prod(self.steps))

    def points(self) -> np.ndarray:
        """All points, shape ``grid.shape + (ndim,)`` (for small grids; sweeps never build this)."""
        return np.stack(np.meshgrid(*self.axes, indexing="ij"), axis=-1)


def _check_resolvable(name: str, start: float, step: float, count: int) -> None:
    """The axis values must be distinct floats: a step below the float spacing at the axis
    values would repeat points (start 1e10, step 1e-10)."""
    end = start + (count - 1) * step
    if not math.isfinite(end):
        raise ValueError(f"grid axis {name}: start {start!r} + {count - 1} steps of {step!r} overflows")
    if count > 1 and step <= 4 * np.spacing(max(abs(start), abs(end))):
        raise ValueError(
            f"grid axis {name}: step {step!r} is below the float64 resolution at {max(abs(start), abs(end)):g}; "
            "accepted: a step at least a few ulps of the axis values"
        )
