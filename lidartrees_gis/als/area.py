"""One plan for an area, whatever its size or how it is split into files: cell size, what the
tiles' surfaces take from the area, crown scale, dominant height, tiles and buffer, measured once,
by one rule.

The rule (lidR's LAScatalog and lasR's pipeline do the same: the per-tile function knows nothing
of where its tile came from):

* the area is measured on **windows** (:func:`measurement_windows`): an area of at most
  :data:`ONE_TILE_POINTS` points and at most :data:`MAX_TILE_SIZE` across is measured whole, as
  one file always was; a larger one on up to nine 150 m windows centred at 1/6, 1/2 and 5/6 of
  its sides;
* the **cell size** (``-tr auto``) comes from the median point density of the windows, each over
  its box or, when that is denser, over the 3 m cells that hold points (a stand turned in its
  bounding box, gaps between files, empty corners);
* the **surface statistics** (:class:`~lidartrees_gis.als.surfaces.SurfaceStats`: pit-free edge
  limit, footprint reach, ``lowest:R`` median, what ``-dtm auto`` chose), the **crown scale** and
  the **dominant height** are the medians of the windows' own values (``ground`` for
  ``-dtm auto`` when any window has ground points);
* an area of at most :data:`ONE_TILE_POINTS` points that fits in :data:`MAX_TILE_SIZE` is **one
  tile** (no buffer needed), otherwise tiles of :func:`auto_tile_size`; the buffer is
  :data:`BUFFER_CROWNS` crown scales, at least :data:`MIN_BUFFER` m.

Everything here depends on the points only, so the trees of an area do not depend on how it is
tiled (tiled = untiled), and a single file is a catalog of one processed as one tile. When the
area is one window and one tile, the window's surfaces serve the tile (computed once).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..catalog.catalog import TilingOptions, far_points, make_tiles  # noqa: F401
from ..catalog.raster import RasterArea
from ..catalog.source import TileSource, drop_far_points
from ..errors import InputError
from ..grid import auto_resolution, check_sparse
from .chm import chm_resolution, crown_scale
from .surfaces import SurfaceOptions, SurfaceStats, box_surfaces

#: side (m) of the windows the area is measured on
MEASURE_WINDOW = 150.0
#: cell (m) over which the point density is measured (cells holding points)
FOOTPRINT_CELL = 3.0
#: the smallest and largest default tile side (m); between them a tile holds about
#: TILE_POINTS points (see :func:`auto_tile_size`)
TILE_SIZE = 250.0
MAX_TILE_SIZE = 1000.0
TILE_POINTS = 500_000
#: an area of at most this many points (and at most MAX_TILE_SIZE across) is one tile: the
#: memory of one tile, and below it a local cluster's start costs more than it saves
ONE_TILE_POINTS = 1_000_000
#: a CHM raster of at most this many cells is one tile; larger ones are cut into tiles of
#: RASTER_TILE_CELLS cells a side
ONE_TILE_CELLS = 16_000_000
RASTER_TILE_CELLS = 2_000
#: default buffer = BUFFER_CROWNS x the crown scale, at least MIN_BUFFER m (two DTM triangle
#: radii, see :data:`lidartrees_gis.tin.DTM_MAX_RADIUS`)
BUFFER_CROWNS = 8.0
MIN_BUFFER = 20.0


def auto_tile_size(density: float) -> float:
    """Default tile side (m) for ``density`` points per m²: the side of a square holding
    :data:`TILE_POINTS` points, rounded to 50 m, between :data:`TILE_SIZE` and
    :data:`MAX_TILE_SIZE`. Dense data keep 250 m tiles (memory per worker); in sparse data larger
    tiles spend less of the work on their buffers. Measured on the Megaplot copies (1.9 points
    per occupied m², so 500 m): 16 M points 39.8 -> 38.6 s on one core and 26.5 -> 24.4 s on
    two workers, peak RSS +85 MB (610 MB).

    >>> auto_tile_size(1.9), auto_tile_size(4.0), auto_tile_size(25.0), auto_tile_size(0.1)
    (500.0, 350.0, 250.0, 1000.0)
    """
    if not density > 0:
        return TILE_SIZE
    side = round(math.sqrt(TILE_POINTS / density) / 50.0) * 50.0
    return float(min(max(side, TILE_SIZE), MAX_TILE_SIZE))


def measurement_windows(extent, count: int, window: float = MEASURE_WINDOW) -> list:
    """The windows (left, bottom, right, top) an area is measured on: the area itself when it
    holds at most :data:`ONE_TILE_POINTS` points and is at most :data:`MAX_TILE_SIZE` across,
    else up to nine ``window``-metre squares centred on a 3 x 3 grid over it (at 1/6, 1/2 and
    5/6 of each side), clipped to it."""
    x0, y0, x1, y1 = extent
    if count <= ONE_TILE_POINTS and max(x1 - x0, y1 - y0) <= MAX_TILE_SIZE:
        return [tuple(extent)]
    h = window / 2
    boxes = []
    for fy in (1 / 6, 1 / 2, 5 / 6):
        for fx in (1 / 6, 1 / 2, 5 / 6):
            cx, cy = x0 + fx * (x1 - x0), y0 + fy * (y1 - y0)
            box = (max(cx - h, x0), max(cy - h, y0), min(cx + h, x1), min(cy + h, y1))
            if box not in boxes:
                boxes.append(box)
    return boxes


def window_density(box, catalog, progress=None) -> float:
    """Points per m² inside ``box``: over the box, or over the :data:`FOOTPRINT_CELL` cells
    (aligned on multiples of the cell) that hold points when that is denser (a stand turned in
    its bounding box, gaps between files, a file's empty corners); NaN for an empty box. A
    task."""
    n, cells = 0, set()
    for c in TileSource(catalog, box).chunks(progress):
        n += len(c)
        gx = np.floor(c.x / FOOTPRINT_CELL + 1e-9).astype(np.int64)
        gy = np.floor(c.y / FOOTPRINT_CELL + 1e-9).astype(np.int64)
        cells.update(np.unique(gx * 100_000_007 + gy).tolist())
    box_area = (box[2] - box[0]) * (box[3] - box[1])
    if not n or not box_area > 0:  # no points, or all on one line: no area to measure over
        return float("nan")
    return max(n / box_area, n / (len(cells) * FOOTPRINT_CELL ** 2))


def window_measures(s, params=None) -> dict | None:
    """What one window's surfaces ``s`` tell of the area (None: no surfaces): their
    :class:`SurfaceStats`, and with tree ``params`` the 95th percentile of the canopy heights,
    the crown scale (unless given) and, for region growing, the highest value of the smoothed
    CHM (Annex 2's ``altura_max``)."""
    if s is None:
        return None
    out = {"stats": s.get("stats"), "p95": float("nan"), "crown_scale": float("nan"),
           "top": float("nan"), "rows": None}
    if params is None:
        return out
    chm, res = s["chm"], s["spec"].res
    canopy = chm[np.isfinite(chm) & (chm >= params.min_height)]
    if canopy.size:
        out["p95"] = float(np.percentile(canopy, 95))
    cs = params.crown_scale
    if cs is None:
        cs = out["crown_scale"] = crown_scale(chm, res, min_height=params.min_height)
    if params.method == "rg":
        out["top"] = _smoothed_top(chm, res, params, cs)
    if (params.spacing == "auto" or params.spacing is None and params.looks_for_lattice) \
            and canopy.size:
        from ..plantation.canopy_lattice import canopy_rows_seen

        out["rows"] = canopy_rows_seen(chm, res)  # the planting rows its parts show
    return out


def _smoothed_top(chm, res: float, params, cs) -> float:
    """The highest value of the CHM smoothed as the trees' detection smooths it."""
    from .smooth import smooth
    from .trees import auto_smoothing

    filt = params.smooth
    if filt == "auto":
        filt = auto_smoothing(cs if cs is not None and np.isfinite(cs) else 2.0 * res, res)[0]
    a = smooth(np.asarray(chm, np.float64), filt, res=res)
    return float(np.nanmax(a)) if np.isfinite(a).any() else float("nan")


def window_canopy(box, area, res, surface, params):
    """:func:`window_measures` of the surfaces of one window (a task)."""
    return window_measures(box_surfaces(area, box, res, surface, whole_dtm=False), params)


@dataclass(frozen=True)
class AreaPlan:
    """What :func:`plan_area` measured and decided for an area."""

    res: float
    density: float  # points per m² (median of the windows); NaN for a raster
    stats: SurfaceStats  # what the tiles' surfaces take from the whole area
    crown_scale: float | None  # m
    crown_scale_source: str  # measured | given | spacing | default (no canopy to measure)
    dominant_height: float | None  # m
    top_height: float | None  # region growing's start: the highest smoothed canopy height (m)
    windows: int
    tiles: tuple
    buffer: float
    tile_size: float  # m (inf: one tile)
    canopy_windows: int = 0  # windows with canopy above -min_height (trees only)
    canopy_rows: tuple = ()  # (apart m, azimuth °) of the windows whose canopy shows rows

    @property
    def one_tile(self) -> bool:
        return len(self.tiles) == 1


def check_degenerate(area) -> None:
    """Refuse a cloud of points that cover no area at all (one point, or every point at the
    same x and y): no surface or tree can be made of it."""
    if isinstance(area, RasterArea):
        return
    x0, y0, x1, y1 = area.extent
    if x1 - x0 <= 0 and y1 - y0 <= 0:
        raise InputError(f"{area.label()}: degenerate point cloud: its {area.count:,} point(s) "
                         f"lie at one location (x {x0:.2f}, y {y0:.2f}); nothing to grid")


def one_tile_area(area) -> bool:
    """Whether the area is processed as one tile by default (see the module doc)."""
    if isinstance(area, RasterArea):
        return area.count <= ONE_TILE_CELLS
    x0, y0, x1, y1 = area.extent
    return area.count <= ONE_TILE_POINTS and max(x1 - x0, y1 - y0) <= MAX_TILE_SIZE


def area_density(area, windows, runner, progress=None) -> float:
    """The area's point density: the median of its windows' (:func:`window_density`)."""
    dens = [d for d in runner.map(window_density, windows, (area,), ordered=True,
                                  label="window", progress=progress, inner_progress=True)
            if np.isfinite(d)]
    return float(np.median(dens)) if dens else float("nan")


def _resolution(area, surface: SurfaceOptions, tiling: TilingOptions, rule: str, runner,
                progress) -> tuple:
    """``(cell size, density, windows)`` of the area; the density is NaN where nothing needs it
    (a cell size given and the tiles' side given or one tile)."""
    windows = measurement_windows(area.extent, area.count)
    if isinstance(area, RasterArea):
        return area.spec.res, float("nan"), windows
    if not surface.auto_res and (tiling.tile_size is not None or one_tile_area(area)):
        return float(surface.res), float("nan"), windows
    density = area_density(area, windows, runner, progress)
    if not surface.auto_res:
        return float(surface.res), density, windows
    if not np.isfinite(density):
        x0, y0, x1, y1 = area.extent
        if len(windows) > 1 and area.count >= 100:  # windows across a wide extent found nothing
            raise InputError(
                f"{area.label()}: -tr auto: none of the {len(windows)} windows the density is "
                f"measured on across the {x1 - x0:,.0f} x {y1 - y0:,.0f} m extent holds points: "
                f"the {area.count:,} points are not spread over it (a few points far from the "
                "rest? `lidartrees info` gives the bounds); give -tr RES, and drop the stray "
                "points or their file")
        raise InputError(f"{area.label()}: -tr auto needs a point density, and the points cover "
                         "no area (none, all at one location or on a line); give -tr RES")
    if rule == "density":  # seed 003's sqrt(1/n), grids and DTMs
        return auto_resolution(int(round(density * 1e6)), 1e6), density, windows
    return chm_resolution(int(round(density * 1e6)), 1e6), density, windows


def _tile_side(area, tiling: TilingOptions, density: float, res: float) -> float:
    """The tile side (m; inf: one tile), on whole cells (see the module doc)."""
    x0, y0, x1, y1 = area.extent
    ts = tiling.tile_size
    if ts is None:
        if one_tile_area(area):
            ts = math.inf
        elif isinstance(area, RasterArea):
            ts = RASTER_TILE_CELLS * res
        else:
            ts = auto_tile_size(density)
    return max(res, round(ts / res) * res) if math.isfinite(ts) else ts


def plan_area(area, surface: SurfaceOptions, tiling: TilingOptions, *, runner, params=None,
              rule: str = "chm", buffer: float | None = None, keep: bool = False,
              progress=None):
    """Measure ``area`` and cut it into tiles (see the module doc).

    Parameters
    ----------
    area : Catalog or RasterArea
    surface : SurfaceOptions
    tiling : TilingOptions
    runner : TileRunner
        Runs the windows' measures (in this process or on Dask).
    params : TreeParams, optional
        Trees: the crown scale and dominant height are measured unless given (or, for the
        crown scale, set by ``spacing``). Without, only the cell size and the edge limit.
    rule : {"chm", "density", "none"}
        ``-tr auto``: the CHM rule (:func:`lidartrees_gis.als.chm.chm_resolution`), seed 003's
        sqrt(1/n) (grids), or ``none``: the cell size only, no surfaces measured.
    buffer : float, optional
        The default buffer when ``tiling.buffer`` is not given (trees: from the crown scale).
    keep : bool
        When the area is one window and one tile, return its surfaces too (computed in this
        process, reporting to ``progress``), for the tile to use instead of computing them
        again.

    Returns
    -------
    (AreaPlan, surfaces or None)
    """
    from ..progress import SubProgress, as_progress

    prog = as_progress(progress)

    def run(fn, items, args):
        return runner.map(fn, items, args, ordered=True, label="window",
                          progress=SubProgress(prog, 0.3, 1.0))

    if not isinstance(area, RasterArea):
        drop_far_points(area)  # before anything is measured: they change nothing
    if rule != "density":  # a grid of one point is its one cell; no CHM or tree is made of it
        check_degenerate(area)
    res, density, windows = _resolution(area, surface, tiling, rule, runner,
                                        SubProgress(prog, 0.0, 0.3))
    x0, y0, x1, y1 = area.extent
    if not isinstance(area, RasterArea):
        cells = (x1 - x0) / res * ((y1 - y0) / res)
        check_sparse(cells, area.count, area.extent, res, area.path)
    ts = _tile_side(area, tiling, density, res)
    measures, kept = [], None
    if rule != "density":
        if keep and len(windows) == 1 and math.isinf(ts):
            # the area is one window and one tile: its surfaces serve both, computed once here
            kept = box_surfaces(area, windows[0], res, surface,
                                keep_points=params is not None and params.looks_at_planting,
                                progress=SubProgress(prog, 0.3, 1.0))
            measures = [window_measures(kept, params)]
        else:
            measures = list(run(window_canopy, windows, (area, res, surface, params)))
    measures = [m for m in measures if m is not None]
    stats = _area_stats([m["stats"] for m in measures if m["stats"] is not None])
    cs, source, hd = _crown_scale_and_height(params, measures, res)
    tops = [m["top"] for m in measures if np.isfinite(m["top"])]
    buf = tiling.buffer if tiling.buffer is not None else (
        buffer if buffer is not None else max(MIN_BUFFER, BUFFER_CROWNS * (cs or 0.0)))
    if not tiling.any_size:
        check_tile_size(tiling.tile_size, ts, res, buf)
    tiles = tuple(make_tiles(area.extent, ts, buf))
    canopy = sum(1 for m in measures if np.isfinite(m["p95"]))
    plan = AreaPlan(res, density, stats, cs, source, hd, max(tops) if tops else None,
                    len(windows), tiles, buf, ts, canopy,
                    tuple(r for m in measures for r in (m.get("rows") or ())))
    return plan, kept


#: a given tile is at least this many cells a side (and twice the buffer)
MIN_TILE_CELLS = 20


def check_tile_size(given, ts: float, res: float, buffer: float) -> None:
    """Refuse a given ``-tile_size`` under ``max(MIN_TILE_CELLS cells, twice the buffer)``:
    smaller tiles read more buffer than core (a 20 m tile with a 20 m buffer reads 25 times its
    core) and 0.5 m tiles mean millions of them."""
    if given is None or not math.isfinite(ts):
        return
    least = max(MIN_TILE_CELLS * res, 2 * buffer)
    if float(given) < least:
        raise InputError(f"-tile_size {float(given):g} m is too small: tiles must be at least "
                         f"{least:g} m (the larger of {MIN_TILE_CELLS} cells of {res:g} m and "
                         f"twice the {buffer:g} m buffer); use -tile_size auto or "
                         f"{math.ceil(least):g}, or a smaller -buffer")


def _area_stats(stats: list) -> SurfaceStats:
    """The area's :class:`SurfaceStats` from its windows': the medians, and ``ground`` for
    ``-dtm auto`` when any window holds ground points."""
    kinds = {s.dtm_kind for s in stats if s.dtm_kind}
    return SurfaceStats(max_edge=_median([s.max_edge for s in stats], None),
                        footprint=_median([s.footprint for s in stats], None),
                        lowest_median=_median([s.lowest_median for s in stats], None),
                        dtm_kind=("ground" if "ground" in kinds else "lowest") if kinds else None)


def _median(values, default):
    v = [float(x) for x in values if x is not None and np.isfinite(x)]
    return float(np.median(v)) if v else default


def _crown_scale_and_height(params, measures, res):
    """The crown scale (and where it came from) and the dominant height of the area."""
    if params is None:
        return None, "", None
    if params.crown_scale is not None:
        cs, source = float(params.crown_scale), "given"
    else:
        cs = _median([m["crown_scale"] for m in measures], None)
        cs, source = (cs, "measured") if cs is not None else (2.0 * res,
                                                              "default (no canopy to measure)")
    hd = params.dominant_height
    if hd is None:
        hd = _median([m["p95"] for m in measures], max(params.min_height, 1.0))
    return cs, source, float(hd)
