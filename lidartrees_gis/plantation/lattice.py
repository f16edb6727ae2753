"""The planting lattice: :class:`PlantingGrid` (rows, plants along them, each row's phase)
and the positions' concentration on its periods, shared by the aligned fit (:mod:`.stocking`)
and the rows with their own phases (:mod:`.rows`)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class PlantingGrid:
    """A planting lattice: position ``(i, j)`` (tree ``i`` along the row, row ``j``) is at
    ``origin + (i + phase_j) * tree_spacing * u + j * row_spacing * v`` with ``u`` the row
    direction (azimuth ``azimuth`` degrees clockwise from grid north) and ``v`` across the rows.

    ``phases``: where each row's plants start, in tree spacings (-0.5 to 0.5), of rows
    ``first_row``, ``first_row + 1``, ...: a crew plants each row from the stand's edge, so a
    row's plants need not face its neighbours' (:mod:`.rows`); empty (0 for every row) when
    the rows' plants are aligned, and for rows beyond those given."""

    row_spacing: float
    tree_spacing: float
    azimuth: float
    origin_x: float
    origin_y: float
    fit: float  # 0-1: how concentrated the tops are on the lattice (1 = exactly on it)
    phases: tuple = ()
    first_row: int = 0

    @property
    def aligned(self) -> bool:
        """The rows' plants face each other (no phase per row)."""
        return not self.phases

    def row_phase(self, j):
        """The phase (tree spacings) of the rows ``round(j)``."""
        j = np.rint(np.asarray(j, float)).astype(np.int64)
        if not self.phases:
            return np.zeros(j.shape)
        ph = np.asarray(self.phases, float)
        k = j - self.first_row
        ok = (k >= 0) & (k < ph.size)
        return np.where(ok, ph[np.clip(k, 0, ph.size - 1)], 0.0)

    @property
    def u(self):
        a = np.radians(self.azimuth)
        return np.array([np.sin(a), np.cos(a)])

    @property
    def v(self):
        a = np.radians(self.azimuth)
        return np.array([np.cos(a), -np.sin(a)])

    def to_lattice(self, x, y):
        """Fractional lattice coordinates ``(i, j)`` of map points."""
        dx = np.asarray(x, float) - self.origin_x
        dy = np.asarray(y, float) - self.origin_y
        u, v = self.u, self.v
        fj = (dx * v[0] + dy * v[1]) / self.row_spacing
        return (dx * u[0] + dy * u[1]) / self.tree_spacing - self.row_phase(fj), fj

    def to_map(self, i, j):
        """Map coordinates of lattice coordinates ``(i, j)``."""
        j = np.asarray(j, float)
        i = np.asarray(i, float) + self.row_phase(j)
        u, v = self.u, self.v
        x = self.origin_x + i * self.tree_spacing * u[0] + j * self.row_spacing * v[0]
        y = self.origin_y + i * self.tree_spacing * u[1] + j * self.row_spacing * v[1]
        return x, y


def _concentration(p, period):
    z = np.exp(2j * np.pi * p / period).mean(axis=-1)
    return np.abs(z), np.angle(z)


#: the planting grid is fitted on at most this many tops (a fixed sample of larger stands: the
#: lattice is the same, and the fit's memory and time stay bounded)
FIT_MAX_TREES = 20_000


def _sample(x, y, n: int = FIT_MAX_TREES):
    """At most ``n`` of the positions, the same ones on every run."""
    if x.size <= n:
        return x, y
    k = np.sort(np.random.default_rng(0).choice(x.size, n, replace=False))
    return x[k], y[k]


def _spacing_along(p, s0, within: float = 0.15, step: float | None = None):
    """The period near ``s0`` (within ``within``, ±15 %) on which the positions ``p``
    concentrate most; among 121 candidates, or (``step``) among the multiples of ``step`` (m):
    the same candidates whatever ``s0``."""
    if step is None:
        cand = s0 * np.linspace(1.0 - within, 1.0 + within, 121)
    else:
        cand = np.arange(np.floor(s0 * (1 - within) / step),
                         np.ceil(s0 * (1 + within) / step) + 1) * step
    r, _ = _concentration(p[None, :], cand[:, None])
    return float(cand[int(np.argmax(r))])
