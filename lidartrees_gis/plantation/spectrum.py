"""The planting lattice's first guess from the tops' spectrum (:func:`_spectral_guess`), for
:func:`lidartrees_gis.plantation.stocking.detect_planting` where the neighbours' directions mislead."""
from __future__ import annotations

import numpy as np

#: :func:`_spectral_guess` looks for planting periods between these lengths (m): rows 2.5-4 m
#: apart and 1.2-3.5 m within rows, with room either side
SPECTRAL_PERIODS = (1.0, 4.8)
#: ... on the projections' histograms of this bin (m) ...
SPECTRAL_BIN = 0.05
#: ... and takes a peak for a lattice's when random positions would reach it with this chance
SPECTRAL_CHANCE = 1e-6
#: a lattice's periods span at least this many CHM cells (tops on the cell centres: the cells'
#: own grid has a period of one cell; two tops less than two cells apart are not resolved)
MIN_PERIOD_CELLS = 2.0


def projection_peak(dx, dy, theta: float, lo: float, hi: float) -> tuple:
    """The strongest period of the positions ``dx, dy`` projected on the direction ``theta``
    (radians, clockwise from north) among the frequencies ``lo``-``hi`` (cycles per metre):
    ``(r, period)``, ``r`` the mean resultant length of the positions' phases at that period
    (1: every position on one phase; about ``1 / sqrt(N)`` for ``N`` positions at random),
    from their histogram in :data:`SPECTRAL_BIN` bins."""
    p = dx * np.sin(theta) + dy * np.cos(theta)
    n = int(np.ceil((p.max() - p.min()) / SPECTRAL_BIN)) + 1
    h = np.bincount(((p - p.min()) / SPECTRAL_BIN).astype(np.int64), minlength=n)
    size = 1 << int(np.ceil(np.log2(max(4 * n, 1024))))  # zero-padded: finer frequencies
    f = np.fft.rfftfreq(size, SPECTRAL_BIN)
    band = (f >= lo) & (f <= hi)
    amp = np.abs(np.fft.rfft(h, size))[band] / p.size
    k = int(np.argmax(amp))
    return float(amp[k]), 1.0 / float(f[band][k])


def _spectral_guess(dx, dy, cell: float = 0.0):
    """Row direction (radians) and the periods across and along the rows, from the power
    spectrum of the positions ``dx, dy`` projected on every direction (0.5° steps): the
    direction whose projection is most periodic within :data:`SPECTRAL_PERIODS` is one axis
    of the lattice, the direction at right angles to it the other; the rows run along the
    axis of the shorter period. Unlike the neighbours' directions, it does not lean to the
    directions a CHM grid favours (3 x 2 m tops on 0.4 m cells: 11° for rows at 20°).

    Both axes must be periodic beyond chance: each spectral peak above the level that the
    largest of the search's independent cells reaches for positions at random with a chance of
    one in a million (the mean resultant length of N random phases exceeds ``t`` with chance
    ``exp(-N t²)``); random trees are given up on here.

    ``cell``: the CHM's cell size (m), when the tops lie on its cell centres: periods shorter
    than :data:`MIN_PERIOD_CELLS` cells are not looked at (the cells' own grid, one cell
    apart, is as periodic as a lattice and no lattice that fine is resolved).

    Returns ``(azimuth, row_period, tree_period)`` or None."""
    lo = 1.0 / SPECTRAL_PERIODS[1]
    hi = 1.0 / max(SPECTRAL_PERIODS[0], MIN_PERIOD_CELLS * cell)
    if hi <= lo:
        return None
    extent = float(max(np.ptp(dx), np.ptp(dy), 1.0))
    cells = 360 * max((hi - lo) * extent, 1.0)  # directions x independent frequencies
    level = float(np.sqrt(np.log(cells / SPECTRAL_CHANCE) / max(dx.size, 1)))

    thetas = np.radians(np.arange(0.0, 180.0, 0.5))
    found = [projection_peak(dx, dy, t, lo, hi) for t in thetas]
    k1 = int(np.argmax([a for a, _ in found]))
    t1, p1 = float(thetas[k1]), found[k1][1]
    # the other axis: at right angles (the lattice is rectangular), within 2°
    cand = t1 + np.pi / 2 + np.radians(np.arange(-2.0, 2.01, 0.25))
    other = [projection_peak(dx, dy, t, lo, hi) for t in cand]
    k2 = int(np.argmax([a for a, _ in other]))
    t2, p2 = float(cand[k2]), other[k2][1]
    if min(found[k1][0], other[k2][0]) < level:
        return None
    if p2 <= p1:  # the rows run along the shorter period
        return t2 % np.pi, p1, p2
    return t1 % np.pi, p2, p1

