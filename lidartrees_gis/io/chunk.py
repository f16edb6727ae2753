"""Blocks of points as the readers yield them, and what one pass over a source tells."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class PointChunk:
    """A block of points. ``x, y, z`` are float64 arrays; other attributes may be None."""

    x: np.ndarray
    y: np.ndarray
    z: np.ndarray
    classification: np.ndarray | None = None
    return_number: np.ndarray | None = None
    number_of_returns: np.ndarray | None = None
    intensity: np.ndarray | None = None
    extra: dict = field(default_factory=dict)

    def __len__(self) -> int:
        return int(self.x.shape[0])

    def subset(self, mask) -> "PointChunk":
        def s(a):
            return None if a is None else a[mask]
        return PointChunk(self.x[mask], self.y[mask], self.z[mask], s(self.classification),
                          s(self.return_number), s(self.number_of_returns), s(self.intensity),
                          {k: v[mask] for k, v in self.extra.items()})

    @staticmethod
    def concat(chunks) -> "PointChunk":
        chunks = list(chunks)
        if not chunks:
            e = np.empty(0)
            return PointChunk(e, e.copy(), e.copy())

        def cat(name):
            vals = [getattr(c, name) for c in chunks]
            return None if any(v is None for v in vals) else np.concatenate(vals)
        extra = {}
        for k in chunks[0].extra:
            if all(k in c.extra for c in chunks):
                extra[k] = np.concatenate([c.extra[k] for c in chunks])
        return PointChunk(cat("x"), cat("y"), cat("z"), cat("classification"), cat("return_number"),
                          cat("number_of_returns"), cat("intensity"), extra)


@dataclass
class PointStats:
    """What one pass over a point source tells: count, bounds, classes and returns."""

    count: int
    bounds: tuple  # (xmin, ymin, xmax, ymax)
    zrange: tuple  # (zmin, zmax)
    classes: dict
    returns: dict
    skipped: int = 0

    @property
    def area(self) -> float:
        xmin, ymin, xmax, ymax = self.bounds
        return max(xmax - xmin, 0.0) * max(ymax - ymin, 0.0)

    @property
    def density(self) -> float:
        """Points per m² over the XY bounding box (NaN when the box has no area)."""
        return self.count / self.area if self.area > 0 else float("nan")
