"""Scan lines in the returns (lidartrees_gis.plantation.scan): their waves read from the
returns' density, and a plant period the tops show that is theirs taken for the scanner's."""
from __future__ import annotations

import numpy as np

from lidartrees_gis.plantation.positions import fit_stand_grids
from lidartrees_gis.plantation.scan import (SCAN_MIN_AMPLITUDE, along_rows, merge_waves,
                                            scan_period, scan_waves)
from lidartrees_gis.plantation.stocking import detect_planting

X0, Y0 = 600000.0, 7500000.0


def _scan_returns(period=1.27, direction=16.5, along=0.35, side=200.0, seed=0):
    """Returns laid in straight scan lines ``period`` m apart whose wave vector points to
    ``direction`` (degrees from north), ``along`` m apart on each line, each jittered by a
    tenth of the line spacing (a footprint); 3 returns a pulse in a column, as crowns give."""
    rng = np.random.default_rng(seed)
    a = np.radians(direction)
    k, t = np.array([np.sin(a), np.cos(a)]), np.array([np.cos(a), -np.sin(a)])
    n_lines, n_along = int(1.5 * side / period), int(1.5 * side / along)
    li, si = np.meshgrid(np.arange(n_lines) - n_lines / 2, np.arange(n_along) - n_along / 2)
    p = li.ravel()[:, None] * period * k + si.ravel()[:, None] * along * t
    p += rng.normal(0, 0.1 * period, p.shape)
    p = p[(np.abs(p[:, 0]) < side / 2) & (np.abs(p[:, 1]) < side / 2)]
    p = np.repeat(p, 3, axis=0)
    return X0 + p[:, 0], Y0 + p[:, 1]


def _locked_tops(az=21.6, R=3.0, period=1.27, direction=16.5, side=200.0, seed=1):
    """Tops where the scan lines cross rows ``R`` m apart at ``az``: along each row the lines'
    period projected on it, one phase for the whole stand (a plane wave), as the tops of a
    closed 3 x 1.5 m stand sampled by 1.27 m lines read on the volume generator's farm."""
    rng = np.random.default_rng(seed)
    a, d = np.radians(az), np.radians(direction)
    u, v = np.array([np.sin(a), np.cos(a)]), np.array([np.cos(a), -np.sin(a)])
    k = 2 * np.pi / period * np.array([np.sin(d), np.cos(d)])
    ku, kv = k @ u, k @ v
    xs, ys = [], []
    for j in range(int(side / R)):
        across = (j - side / R / 2) * R
        # positions along the row where the phase k . p is a whole turn
        m = np.arange(-200, 200)
        along = (2 * np.pi * m - kv * across) / ku
        along = along[np.abs(along) < side / 2]
        keep = rng.random(along.size) > 0.05
        along = along[keep] + rng.normal(0, 0.15, keep.sum())
        xs.append(X0 + along * u[0] + across * v[0])
        ys.append(Y0 + along * u[1] + across * v[1])
    return np.concatenate(xs), np.concatenate(ys)


def _planted_tops(az=115.5, R=3.0, C=1.5, side=200.0, seed=2):
    """Tops of a 3 x 1.5 m stand at ``az``, aligned rows, 0.2 m jitter, 5 % missing."""
    rng = np.random.default_rng(seed)
    a = np.radians(az)
    u, v = np.array([np.sin(a), np.cos(a)]), np.array([np.cos(a), -np.sin(a)])
    i, j = np.meshgrid(np.arange(-side / C / 2, side / C / 2), np.arange(-side / R / 2,
                                                                        side / R / 2))
    p = i.ravel()[:, None] * C * u + j.ravel()[:, None] * R * v
    p = p[rng.random(len(p)) > 0.05]
    p = p + rng.normal(0, 0.2, p.shape)
    p = p[(np.abs(p[:, 0]) < side / 2) & (np.abs(p[:, 1]) < side / 2)]
    return X0 + p[:, 0], Y0 + p[:, 1]


def test_scan_waves_are_read_from_the_returns_density():
    """Lines 1.27 m apart (wave to 16.5°): the strongest wave is theirs, to 1 % and 1°, well
    above the level; returns at random give none, nor a smooth rise in density as crowns give
    (above the level, without a harmonic); the waves of two windows merge into one."""
    x, y = _scan_returns()
    w = scan_waves(x, y)
    assert len(w) >= 1 and w[0, 2] >= 2 * SCAN_MIN_AMPLITUDE
    period = 2 * np.pi / np.hypot(w[0, 0], w[0, 1])
    direction = np.degrees(np.arctan2(w[0, 0], w[0, 1])) % 180.0
    assert abs(period - 1.27) <= 0.0127 and abs(direction - 16.5) <= 1.0
    rng = np.random.default_rng(3)
    assert len(scan_waves(X0 + rng.uniform(0, 200, x.size), Y0 + rng.uniform(0, 200, x.size))) \
        == 0
    # a smooth rise in density along 3 m rows (crowns: 0.125 of amplitude, no harmonic) is
    # no scan wave
    k = 2 * np.pi / 3.0 * np.array([np.sin(np.radians(82.4)), np.cos(np.radians(82.4))])
    px, py = rng.uniform(0, 200, 3 * x.size), rng.uniform(0, 200, 3 * x.size)
    keep = rng.random(px.size) < (1 + 0.25 * np.cos(k[0] * px + k[1] * py)) / 1.25
    assert abs(np.exp(1j * (k[0] * px[keep] + k[1] * py[keep])).mean()) > SCAN_MIN_AMPLITUDE
    assert len(scan_waves(X0 + px[keep], Y0 + py[keep])) == 0
    both = merge_waves([w[:1], w[:1] * [-1, -1, 0.9]])  # the same wave, its opposite
    assert len(both) == 1
    # along rows at 21.6° the lines read 1.27 m; along rows at 111.6° about 15 m
    assert abs(along_rows(w[:1], 21.6)[0] - 1.27 / np.cos(np.radians(5.1))) < 0.02
    assert along_rows(w[:1], 111.6)[0] > 10


def test_a_plant_period_is_the_scanners_only_near_a_wave_of_its_size():
    """A wave's projection on the rows counts only when the wave itself is at least half the
    plant period: pulses 0.57 m apart at 77° to rows project to 2.57 m on them, and 3 x 2.5 m
    plants are not taken for them."""
    k = 2 * np.pi / 0.573
    d = np.radians(105.7)
    w = np.array([[k * np.sin(d), k * np.cos(d), 0.11]])
    assert abs(along_rows(w, 28.6)[0] - 2.567) < 0.01
    assert scan_period(2.5, 28.6, w) is None
    k = 2 * np.pi / 1.268
    d = np.radians(16.5)
    w = np.array([[k * np.sin(d), k * np.cos(d), 0.3]])
    assert scan_period(1.27, 21.6, w) is not None and scan_period(1.5, 21.6, w) is None


def test_tops_locked_on_scan_lines_give_no_lattice_and_say_why():
    """Tops where 1.27 m scan lines cross 3 m rows: without the returns' waves their lattice
    reads 3 x 1.27 m; with them there is none, and the stand's ``lattice`` words say it is
    the scan lines'. A planted 3 x 1.5 m stand beside it under the same lines keeps its
    lattice, and the locked stand does not take the area's lattice instead."""
    tx, ty = _locked_tops()
    g = detect_planting(tx, ty, cell=0.5)
    assert g is not None and abs(g.tree_spacing - 1.27) < 0.03 and abs(g.row_spacing - 3) < 0.05
    w = scan_waves(*_scan_returns())
    notes = {}
    assert detect_planting(tx, ty, cell=0.5, scan=w, notes=notes) is None
    assert abs(notes["scan"][0] - 1.27) < 0.03
    px, py = _planted_tops()
    g = detect_planting(px, py, cell=0.5, scan=w)
    assert g is not None and abs(g.tree_spacing - 1.5) < 0.02 and abs(g.row_spacing - 3) < 0.02
    x, y = np.r_[tx, px + 400.0], np.r_[ty, py]
    zone = np.r_[np.zeros(tx.size, int), np.ones(px.size, int)]
    out = fit_stand_grids(x, y, zone, "auto", cell=0.5, scan=w)
    assert out[0] is None and "scan lines" in out[("why", 0)] and "1.27 m" in out[("why", 0)]
    assert out[1] is not None and abs(out[1].tree_spacing - 1.5) < 0.02
    # without the waves, as before: the locked stand's lattice is the lines'
    out = fit_stand_grids(x, y, zone, "auto", cell=0.5)
    assert abs(out[0].tree_spacing - 1.27) < 0.03 and ("why", 0) not in out
