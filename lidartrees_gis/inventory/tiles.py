"""Heights above ground of an area's returns, tile by tile, and their metrics per cell and per
zone (plots, stands).

Every tile computes its DTM as the ``chm`` chain does (:func:`~lidartrees_gis.als.surfaces.
box_surfaces` with the area's plan: ``-dtm auto`` = class-2 ground TIN, else lowest:5, ...),
takes the returns of its core, their height above that DTM (bilinear, as the CHM's), and
returns the metrics of the cells of its core (tile cores are whole metric cells) and the
returns of the zones that lie in its core (gathered over the tiles, their metrics computed at
the end, so a plot cut by a tile edge gets the metrics of all its returns).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ..als.area import MIN_BUFFER, plan_area
from ..als.chain import check_failed, run_tiles, runner_for
from ..als.surfaces import ON_GROUND, SurfaceOptions, bilinear, box_surfaces
from ..catalog.catalog import TilingOptions, make_tiles
from ..catalog.source import TileSource
from ..bounds import check_fields
from ..errors import InputError
from ..grid import GridSpec
from ..progress import SubProgress, as_progress
from .metrics import METRICS, RETURNS, group_metrics

#: side of the squares whose returns tell where the points cover the ground (m, about): a
#: metric cell's share of them holding a return is its coverage (a flight's edge, a void)
COVER_SIDE = 2.0


def cover_split(res: float) -> int:
    """Squares per side of a metric cell of ``res`` m that :func:`area_metrics` reads its
    coverage on (:data:`COVER_SIDE` m squares, one at least)."""
    return max(1, int(round(res / COVER_SIDE)))


def cover_spec(cells: GridSpec) -> GridSpec:
    """The grid of coverage squares over the metric cells ``cells``."""
    k = cover_split(cells.res)
    return GridSpec(cells.left, cells.top, cells.res / k, cells.width * k, cells.height * k,
                    cells.crs)


@dataclass(frozen=True)
class MetricOptions:
    """Which returns the metrics take.

    Attributes
    ----------
    min_height : float or None
        The metrics are computed on the returns above it (m; None: every return, as lidR's
        ``pixel_metrics(las, .stdmetrics_z)`` on normalised points); ``cover`` counts the first
        returns above it.
    returns : {"all", "first"}
    """

    min_height: float | None = 2.0
    returns: str = "all"

    def __post_init__(self):
        check_fields(self, {"min_height": "m"})
        if self.returns not in RETURNS:
            raise InputError(f"-returns: expected all or first, got {self.returns!r}")
        if self.min_height is not None and not math.isfinite(self.min_height):
            raise InputError(f"-min_height: expected a finite number, got {self.min_height!r}")

    def compute(self, z, group, n_groups, first=None) -> dict:
        return group_metrics(z, group, n_groups, first=first, min_height=self.min_height,
                             returns=self.returns)


@dataclass(frozen=True)
class HeightTask:
    """What each tile computes: the metric cells (None: none), the zones whose returns it
    gathers, and the metric options."""

    cells: GridSpec | None
    zones: tuple  # of plots.Zones
    options: MetricOptions


def _cell_window(cells: GridSpec, row, col):
    r0, r1 = int(row.min()), int(row.max()) + 1
    c0, c1 = int(col.min()), int(col.max()) + 1
    return r0, r1, c0, c1


def tile_heights(tile, area, plan, surface: SurfaceOptions, task: HeightTask, surfaces=None,
                 progress=None) -> dict:
    """One tile's cell metrics and zone returns (see the module doc)."""
    s = surfaces if surfaces is not None else box_surfaces(area, tile.box, plan.res, surface,
                                                           stats=plan.stats, progress=progress)
    out = {"points": 0, "cells": None, "zones": [None] * len(task.zones), "dropped": {}}
    if s is None:
        return out
    src = TileSource(area, tile.box)
    pts = src.read_all()
    # cells as lidR's pixel_metrics makes them: a return on a row edge in the row below
    core = tile.in_core(pts.x, pts.y, closed_top=True)
    x, y = pts.x[core], pts.y[core]
    hag = pts.z[core] - bilinear(s["dtm"], s["spec"], x, y)
    hag[np.abs(hag) < ON_GROUND] = 0.0
    first = None if pts.return_number is None else pts.return_number[core] <= 1
    out["points"], out["dropped"] = int(x.size), dict(src.dropped)
    if x.size == 0:
        return out
    if task.cells is not None:
        row, col = task.cells.cell_index(x, y, closed_top=True)
        r0, r1, c0, c1 = _cell_window(task.cells, row, col)
        w = c1 - c0
        m = task.options.compute(hag, (row - r0) * w + (col - c0), (r1 - r0) * w, first)
        out["cells"] = (r0, c0, np.stack([m[k].reshape(r1 - r0, w) for k in METRICS])
                        .astype(np.float32))
        out["occupied"] = _occupied(task.cells, x, y, r0, r1, c0, c1)
    for k, zones in enumerate(task.zones):
        pi, zi = zones.pairs(x, y)
        out["zones"][k] = (zi, hag[pi].astype(np.float64),
                           None if first is None else first[pi])
    return out


def _occupied(cells: GridSpec, x, y, r0, r1, c0, c1):
    """``(row, col, bool array)``: the coverage squares (:func:`cover_spec`) of the metric
    cells ``r0:r1, c0:c1`` that hold one of the returns ``x, y``."""
    k = cover_split(cells.res)
    sub = cover_spec(cells)
    row, col = sub.cell_index(x, y, closed_top=True)
    h, w = (r1 - r0) * k, (c1 - c0) * k
    row, col = np.clip(row - r0 * k, 0, h - 1), np.clip(col - c0 * k, 0, w - 1)
    occ = np.zeros((h, w), bool)
    occ[row, col] = True
    return r0 * k, c0 * k, occ


def _aligned_plan(plan, area, cells: GridSpec | None, tiling: TilingOptions):
    """The plan with tiles whose side is a whole number of metric cells (each cell in one
    tile's core)."""
    if cells is None or len(plan.tiles) < 2:
        return plan
    side = max(1, math.ceil(plan.tile_size / cells.res)) * cells.res
    tiles = make_tiles(area.extent, side, plan.buffer)
    return replace(plan, tiles=tuple(tiles), tile_size=side)


def area_metrics(area, *, cells_res=None, zones=(), options: MetricOptions | None = None,
                 surface: SurfaceOptions | None = None, tiling: TilingOptions | None = None,
                 progress=None) -> dict:
    """Metrics of an area's returns per cell of ``cells_res`` (m) and per zone.

    Returns
    -------
    dict with ``cells``: ``(GridSpec, (len(METRICS), H, W) float32 array)`` or None;
    ``occupied``: ``(GridSpec, bool array)`` of the coverage squares (:func:`cover_spec`)
    holding a return, and ``coverage``: each cell's share of them (H, W), or None;
    ``zones``: per zone set, a dict of metric arrays (one value a zone); ``points``: returns
    read; ``res``: the DTM's cell size; ``tiles``.
    """
    options = options or MetricOptions()
    surface = surface or SurfaceOptions(chm="max", fill="none", outliers=False)
    tiling = tiling or TilingOptions()
    prog = as_progress(progress)
    cells = None if cells_res is None else GridSpec.from_bounds(*area.extent, cells_res,
                                                                crs=area.crs, closed_top=True)
    grid = None if cells is None else np.full((len(METRICS), *cells.shape), np.nan, np.float32)
    sub = None if cells is None else cover_spec(cells)
    occupied = None if cells is None else np.zeros(sub.shape, bool)
    gathered = [[] for _ in zones]
    points = 0
    with runner_for(area, tiling) as runner:
        prog.update(0.01, "measuring the area")
        plan, ready = plan_area(area, surface, tiling, runner=runner, rule="density",
                                buffer=MIN_BUFFER, keep=True,
                                progress=SubProgress(prog, 0.02, 0.2))
        aligned = _aligned_plan(plan, area, cells, tiling)
        if aligned is not plan:
            plan, ready = aligned, None
        task = HeightTask(cells, tuple(zones), options)
        for r in run_tiles(runner, tile_heights, plan, (area, plan, surface, task), ready,
                           SubProgress(prog, 0.2, 0.95)):
            points += r["points"]
            if r["cells"] is not None:
                r0, c0, arr = r["cells"]
                win = grid[:, r0:r0 + arr.shape[1], c0:c0 + arr.shape[2]]
                np.copyto(win, arr, where=np.isfinite(arr))
                q0, p0, occ = r["occupied"]
                occupied[q0:q0 + occ.shape[0], p0:p0 + occ.shape[1]] |= occ
            for k, z in enumerate(r["zones"]):
                if z is not None and z[0].size:
                    gathered[k].append(z)
        result = {"points": points, "res": plan.res, "tiles": len(plan.tiles)}
        check_failed(runner, result)
    if points == 0:
        raise InputError(f"{area.label()}: no points")
    zone_metrics = []
    for zs, got in zip(zones, gathered):
        if got:
            idx = np.concatenate([g[0] for g in got])
            hag = np.concatenate([g[1] for g in got])
            first = None if any(g[2] is None for g in got) else np.concatenate([g[2] for g in got])
        else:
            idx, hag, first = np.empty(0, np.int64), np.empty(0), None
        zone_metrics.append(options.compute(hag, idx, len(zs), first))
    prog.update(1.0, "metrics")
    coverage = None
    if cells is not None:
        k = cover_split(cells.res)
        coverage = occupied.reshape(cells.height, k, cells.width, k).mean(axis=(1, 3))
    return {**result, "cells": None if cells is None else (cells, grid), "zones": zone_metrics,
            "occupied": None if cells is None else (sub, occupied), "coverage": coverage}
