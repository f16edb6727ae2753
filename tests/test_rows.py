"""Rows planted each from the stand's edge: a lattice whose rows have their own phases
(lidartrees_gis.plantation.rows)."""
from __future__ import annotations

import numpy as np
import pytest

from lidartrees_gis.plantation.rows import choose, find_rows, fit_rows, tree_period
from lidartrees_gis.plantation.stocking import (PLANTING_MIN_FIT, PlantingGrid, _sample,
                                                detect_planting, fit_planting_grid)


def _rows_stand(R=3.0, C=2.0, az=25.0, n_rows=40, length=120.0, jitter=0.25, missing=0.08,
                seed=0, extra=0.0):
    """Tops of a stand whose rows each start at a random phase (as a crew plants a row from an
    oblique edge), with ``jitter`` (m) on each top, ``missing`` of them gone and ``extra``
    more tops at random; returns ``(x, y, phases)``."""
    rng = np.random.default_rng(seed)
    a = np.radians(az)
    u, v = np.array([np.sin(a), np.cos(a)]), np.array([np.cos(a), -np.sin(a)])
    phase = rng.uniform(0, 1, n_rows)
    xs, ys = [], []
    for j in range(n_rows):
        i = np.arange(int(length / C))
        keep = rng.random(i.size) >= missing
        along = (i[keep] + phase[j]) * C + rng.normal(0, jitter, keep.sum())
        across = j * R + rng.normal(0, jitter, keep.sum())
        xs.append(600000.0 + along * u[0] + across * v[0])
        ys.append(7500000.0 + along * u[1] + across * v[1])
    x, y = np.concatenate(xs), np.concatenate(ys)
    k = int(extra * x.size)
    if k:
        x = np.r_[x, rng.uniform(x.min(), x.max(), k)]
        y = np.r_[y, rng.uniform(y.min(), y.max(), k)]
    return x, y, phase


def test_rows_of_their_own_phases_are_found_where_an_aligned_lattice_sees_none():
    """3 x 2 m rows at 25°, each row's plants at a phase of its own, 0.25 m jitter, 8 % missing
    and 30 % extra tops at random: an aligned lattice fits them below the acceptance level, the
    rows' own phases give the design to 0.02 m and 0.5°, and the tops lie about their
    positions as closely as their jitter allows."""
    x, y, _ = _rows_stand(extra=0.3)
    a = np.radians(25.0)
    along = (x - x.mean()) * np.sin(a) + (y - y.mean()) * np.cos(a)
    across = (x - x.mean()) * np.cos(a) - (y - y.mean()) * np.sin(a)
    ru = abs(np.exp(2j * np.pi * along / 2.0).mean())
    rv = abs(np.exp(2j * np.pi * across / 3.0).mean())
    assert ru * rv < 0.5 * PLANTING_MIN_FIT  # an aligned lattice, even at the true azimuth
    g = fit_planting_grid(x, y, 3.0, 2.0)  # at the spacing given: the rows' phases
    assert not g.aligned and g.fit > PLANTING_MIN_FIT
    g = detect_planting(x, y, cell=0.4)
    assert g is not None and not g.aligned
    assert abs(g.row_spacing - 3.0) <= 0.02 and abs(g.tree_spacing - 2.0) <= 0.02
    assert abs((g.azimuth - 25.0 + 90.0) % 180.0 - 90.0) <= 0.5
    xt, yt, _ = _rows_stand(extra=0.0)
    fi, fj = g.to_lattice(xt, yt)
    px, py = g.to_map(np.rint(fi), np.rint(fj))
    assert np.median(np.hypot(px - xt, py - yt)) < 0.35
    assert np.percentile(np.hypot(px - xt, py - yt), 95) < 0.7  # the jitter alone: 0.61


def test_aligned_rows_keep_the_aligned_lattice():
    """Plants facing each other across the rows: the aligned lattice fits, and no phase per row
    is kept (the stand families' lattices, unchanged)."""
    rng = np.random.default_rng(1)
    i, j = np.meshgrid(np.arange(60), np.arange(40))
    a = np.radians(70.0)
    along, across = i.ravel() * 2.0, j.ravel() * 3.0
    x = along * np.sin(a) + across * np.cos(a) + rng.normal(0, 0.2, i.size)
    y = along * np.cos(a) - across * np.sin(a) + rng.normal(0, 0.2, i.size)
    g = fit_planting_grid(x, y, 3.0, 2.0)
    assert g.aligned and g.fit > PLANTING_MIN_FIT
    d = detect_planting(x, y, cell=0.4)
    assert d is not None and d.aligned


def test_random_tops_give_no_rows():
    """Tops at random (a natural forest, 2,000 of them) show no rows of their own phases."""
    rng = np.random.default_rng(2)
    x, y = rng.uniform(0, 200, 2000), rng.uniform(0, 200, 2000)
    sx, sy = _sample(x, y, 5000)
    g = find_rows(x, y, sx - sx.mean(), sy - sy.mean(), 0.4)
    assert g is None or g.fit * np.sqrt(x.size) < 5.0
    assert detect_planting(x, y, cell=0.4) is None


def test_tree_period_takes_the_plants_not_the_tops_between_them():
    """Tops at every plant (2 m) and at 30 % of the midpoints between them: the tops
    concentrate most at 1 m, but the plants are 2 m apart (plants at 1 m would cancel at 2 m)."""
    x, y, _ = _rows_stand(jitter=0.1, missing=0.0)
    g = fit_rows(x, y, 3.0, 2.0, azimuths=np.arange(24.0, 26.01, 0.25))
    fi, fj = g.to_lattice(x, y)
    rng = np.random.default_rng(3)
    k = rng.random(x.size) < 0.3
    mx, my = g.to_map(np.rint(fi[k]) + 0.5, np.rint(fj[k]))
    ax, ay = np.r_[x, mx], np.r_[y, my]
    dx, dy = ax - ax.mean(), ay - ay.mean()
    period, r = tree_period(dx, dy, g.azimuth, 3.0, 1.0, 4.8)
    assert period == pytest.approx(2.0, abs=0.02)
    # plants truly 1 m apart keep 1 m
    x1, y1, _ = _rows_stand(C=1.0, length=60.0, jitter=0.08, missing=0.0)
    p1, _ = tree_period(x1 - x1.mean(), y1 - y1.mean(), 25.0, 3.0, 0.8, 4.8)
    assert p1 == pytest.approx(1.0, abs=0.01)


def test_choose_between_the_tops_rows_and_the_canopy_lattice():
    """Same rows: the canopy's plant spacing wins unless it is the tops' (within 5 %) or a half
    or third of it, or its lattice fits the tops under a quarter as well as the rows; rows that
    disagree: the one across which the tops concentrate more."""
    x, y, _ = _rows_stand()
    rows = fit_rows(x, y, 3.0, 2.0, azimuths=np.arange(24.0, 26.01, 0.25))

    def grid(R, C, az, fit=0.5 * rows.fit):
        return PlantingGrid(R, C, az, float(x.mean()), float(y.mean()), fit)

    assert choose(rows, None, x, y) is rows
    assert choose(rows, grid(3.0, 2.04, rows.azimuth), x, y) is rows      # the same spacing
    assert choose(rows, grid(3.0, 1.01, rows.azimuth), x, y) is rows      # a harmonic
    c = grid(3.0, 1.56, rows.azimuth)
    assert choose(rows, c, x, y) is c                                    # the canopy's plants
    # ... unless the tops belie them (c1 004-A of the volume generator: 0.006 against 0.098)
    assert choose(rows, grid(3.0, 1.56, rows.azimuth, 0.06 * rows.fit), x, y) is rows
    across = grid(3.66, 3.0, (rows.azimuth + 90.0) % 180.0)
    assert choose(rows, across, x, y) is rows                            # rows disagree


def test_row_phases_round_trip_and_wrap():
    """``to_map`` and ``to_lattice`` are inverse with phases, also for rows beyond those given
    (phase 0), and a fit reported just under 180° keeps each top on its position."""
    g = PlantingGrid(3.0, 2.0, 10.0, 100.0, 200.0, 0.5, (0.1, -0.3, 0.45), -1)
    i, j = np.meshgrid(np.arange(-3, 4), np.arange(-3, 4))
    x, y = g.to_map(i.ravel(), j.ravel())
    fi, fj = g.to_lattice(x, y)
    assert np.allclose(fi, i.ravel()) and np.allclose(fj, j.ravel())
    assert np.allclose(g.row_phase([-1, 0, 1, 2, 5]), [0.1, -0.3, 0.45, 0.0, 0.0])
    x, y, _ = _rows_stand(az=179.8, jitter=0.05, missing=0.0)
    r = fit_rows(x, y, 3.0, 2.0, azimuths=np.arange(178.0, 182.01, 0.25) % 180.0)
    fi, fj = r.to_lattice(x, y)
    px, py = r.to_map(np.rint(fi), np.rint(fj))
    assert np.percentile(np.hypot(px - x, py - y), 99) < 0.25
