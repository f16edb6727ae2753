"""Composed chains that the CLI and the QGIS provider call: points -> grids -> files.

Each ``*_file`` function validates its parameters, does the work with a progress object and
writes its outputs atomically; it returns a small dict describing what it did.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import __version__
from .crs import crs_label
from .errors import DataWarning, InputError
from .grid import (GridAccumulator, GridSpec, LowestPoints, auto_resolution, check_resolution,
                   check_sparse, data_footprint, fill_gaps, interpolate_tin, resample_to)
from .io.points import PointSource, open_points
from .io.raster import read_raster, write_geotiff
from .progress import SubProgress, as_progress, check_cancel

DTM_CHOICES = "min, ground, lowest:R, kp[:G:W], none, auto or a DTM GeoTIFF path"


def open_input(path, *, a_srs=None, t_srs=None, require_crs=False, **kw) -> PointSource:
    """Open a point file (see :func:`lidartrees_gis.io.points.open_points`)."""
    return open_points(path, a_srs=a_srs, t_srs=t_srs, require_crs=require_crs, **kw)


def info(src: PointSource, progress=None) -> dict:
    """Points, bounds, density (pts/m²), CRS, classes and returns of a point source."""
    st = src.scan(progress)
    out = {
        "file": str(src.path),
        "format": src.format,
        "points": st.count,
        "skipped": st.skipped,
        "bounds": list(st.bounds),
        "z_range": list(st.zrange),
        "area_m2": round(st.area, 1),
        "density_pts_m2": None if math.isnan(st.density) else round(st.density, 3),
        "crs": crs_label(src.crs),
        "crs_wkt": src.crs.to_wkt() if src.crs is not None else None,
        "classes": st.classes,
        "returns": st.returns,
        "reprojection": _repro_report(src),
    }
    if src.format == "las":
        out["las_version"] = src.header_info.get("version")
        out["point_format"] = src.header_info.get("point_format")
    else:
        out["dialect"] = src.dialect.describe()
    return out


def resolve_resolution(src: PointSource, res, progress=None, *, rule: str = "density") -> float:
    """A number, or ``"auto"``: ``rule="density"`` gives seed 003's sqrt(1/n) (grid, ground,
    DTMs); ``rule="chm"`` the CHM rule of :func:`lidartrees_gis.chm.chm_resolution`
    (max(sqrt(2/n), 0.25 m), for crown detection)."""
    if res is None or (isinstance(res, str) and res.strip().lower() == "auto"):
        if res is None and rule != "chm":
            raise InputError("-tr: a resolution is required (a number in metres, or auto)")
        from .chm import chm_resolution

        fn = chm_resolution if rule == "chm" else auto_resolution
        hb = src.header_bounds()
        if hb is not None and src.count_hint:
            area = (hb[2] - hb[0]) * (hb[3] - hb[1])
            return fn(src.count_hint, area)
        st = src.scan(progress)
        return fn(st.count, st.area)
    return check_resolution(res)


#: largest grid (cells) made in memory; larger areas go through tiles (about 30 bytes a cell)
MAX_CELLS = 200_000_000


def grid_spec_for(src: PointSource, res: float, progress=None) -> GridSpec:
    """The aligned grid that holds every point of ``src``: refused when its CRS is geographic
    (cells must be metres) or when it would exceed :data:`MAX_CELLS`."""
    from .errors import CRSError

    crs = src.crs
    if crs is not None and getattr(crs, "is_geographic", False):
        raise CRSError(f"{src.path}: the points are in a geographic CRS ({crs_label(crs)}, "
                       "degrees); grids need metres: give -t_srs with a projected CRS, e.g. "
                       "-t_srs EPSG:31984 (SIRGAS 2000 / UTM 24S)")
    b = src.header_bounds()
    if b is None:
        b = src.scan(progress).bounds
    w, h = (b[2] - b[0]) / res, (b[3] - b[1]) / res
    if w * h > MAX_CELLS:
        raise InputError(
            f"{src.path}: a {res:g} m grid over {b[2] - b[0]:.0f} x {b[3] - b[1]:.0f} m would hold "
            f"{w * h:.3g} cells (limit {MAX_CELLS:.0e}); check -tr, or the extent (a wrong digit "
            f"in a coordinate, or points far apart: x {b[0]:.2f}..{b[2]:.2f}, y {b[1]:.2f}.."
            f"{b[3]:.2f}); large areas are processed in tiles with -tile_size")
    n = src.count_hint
    check_sparse(w * h, n, b, res, src.path)
    return GridSpec.from_bounds(*b, res, crs=src.crs)


@dataclass
class DtmMethod:
    """Parsed ``-dtm`` value."""

    kind: str  # min | ground | lowest | none | auto | kp | file
    size: float | None = None
    path: str | None = None
    g: float | None = None
    w: float | None = None

    @classmethod
    def parse(cls, value) -> "DtmMethod":
        v = "min" if value is None else str(value).strip()
        low = v.lower()
        if low in ("min", "ground", "none", "auto"):
            return cls(low)
        m = re.fullmatch(r"kp(?::(-?[0-9.]+):([0-9.]+))?", low)
        if m:
            return cls("kp", g=float(m.group(1)) if m.group(1) else None,
                       w=float(m.group(2)) if m.group(2) else None)
        m = re.fullmatch(r"lowest(?::([0-9.]+))?", low)
        if m:
            size = float(m.group(1) or 5.0)
            if size <= 0:
                raise InputError(f"-dtm: lowest:R needs R > 0, got {value!r}")
            return cls("lowest", size=size)
        if low.endswith((".tif", ".tiff", ".vrt", ".img")) or Path(v).exists():
            if not Path(v).exists():
                raise InputError(f"-dtm: DTM file {v} does not exist")
            return cls("file", path=v)
        raise InputError(f"-dtm: unknown value {value!r}; use {DTM_CHOICES}")

    def describe(self) -> str:
        if self.kind == "kp" and self.g is not None:
            return f"kp:{self.g:g}:{self.w:g}"
        if self.kind == "lowest":
            return f"lowest:{(self.size or 5.0):g}"
        if self.kind == "file":
            return str(self.path)
        return self.kind


def _dtm_label(method: DtmMethod, kind: str) -> str:
    """The ``-dtm`` value as given (``lowest:5``, ``kp:-1:1``, a path); ``auto`` with what it
    chose (``auto (ground)``, ``auto (lowest:5)``)."""
    if method.kind == "auto":
        return f"auto ({'lowest:5' if kind == 'lowest' else kind})"
    return method.describe()


def _bilinear(arr, spec: GridSpec, x, y):
    """Bilinear sample of a grid at map coordinates (edges clamped)."""
    from scipy import ndimage

    col = (np.asarray(x) - spec.left) / spec.res - 0.5
    row = (spec.top - np.asarray(y)) / spec.res - 0.5
    return ndimage.map_coordinates(np.asarray(arr, np.float64), [row, col], order=1, mode="nearest")


#: cell (m) of the data footprint over which a single file's -tr auto density is checked
FOOTPRINT_CELL = 3.0


def compute_surfaces(src: PointSource, res, *, dtm="auto", fill="mean8", chm="max",
                     outliers=True, res_rule="chm", max_edge=None, progress=None) -> dict:
    """DSM, DTM and CHM on one aligned grid.

    Parameters
    ----------
    src : PointSource
        Points (its class filter, e.g. noise classes 7 and 18 dropped, applies).
    res : float or "auto"
        Cell size in metres; ``auto`` by ``res_rule`` (see :func:`resolve_resolution`). With
        the CHM rule the density is then checked over the :data:`FOOTPRINT_CELL` cells that hold
        points, and the points are read again at finer cells when it calls for them (an
        outline that does not fill its bounding box).
    dtm : str
        ``auto`` (default) ``ground`` when the file has class-2 points, else ``lowest:5``;
        ``ground`` lowest class-2 point per cell, linearly interpolated (TIN) over the grid;
        ``lowest:R`` the lowest point of each R-metre cell, at its own position, interpolated
        (TIN); ``kp`` or ``kp:G:W`` ground points of the Kraus & Pfeifer filter (seed 003;
        defaults g = -2, w = 2.5), interpolated (TIN); ``min`` lowest point per cell (seed 000's
        simple method, only meaningful where every cell holds a ground return); ``none`` heights
        are already normalised (DTM = 0); or a DTM GeoTIFF path, resampled bilinearly.
    fill : {"mean8", "none"}
        Gap filling of the DSM, CHM and of the ``min`` DTM (seed 000).
    chm : {"max", "pitfree", "tin"}
        ``max`` highest point per cell minus the DTM (seed 000); ``pitfree`` Khosravipour et al.
        (2014) pit-free CHM of the first returns' heights above the DTM; ``tin`` one TIN of the
        first returns (lidR ``dsmtin``).
    outliers : bool
        Remove isolated returns far above the canopy (:func:`lidartrees_gis.chm.canopy_outliers`).

    Returns
    -------
    dict with ``dsm``, ``dtm``, ``chm`` (float64 arrays, NaN = nodata), ``heights`` (the CHM
    or, where higher, the highest return above ground in the cell: what tree heights are read
    from), ``spec``, ``res``, ``dtm_method``, ``chm_method``, ``points``, ``dropped`` (points per
    dropped class), ``outlier_cells`` and ``outlier_points``.
    """
    from .chm import (CHM_KINDS, LOCAL_RADIUS, canopy_outliers, pitfree_chm, pitfree_edge,
                      tin_surface)

    prog = as_progress(progress)
    if chm not in CHM_KINDS:
        raise InputError(f"-chm: unknown CHM {chm!r}; use {', '.join(CHM_KINDS)}")
    method = DtmMethod.parse(dtm)
    auto_res = res_rule == "chm" and isinstance(res, str) and res.strip().lower() == "auto"
    res = resolve_resolution(src, res, SubProgress(prog, 0.0, 0.3), rule=res_rule)
    spec = grid_spec_for(src, res, SubProgress(prog, 0.0, 0.3))
    # the FOOTPRINT_CELL cells holding points: the density of an outline that does not fill its
    # bounding box (a turned or clipped stand) is measured over them (see below)
    occ = (GridAccumulator(GridSpec.from_bounds(*spec.bounds, FOOTPRINT_CELL, crs=spec.crs),
                           ("count",)) if auto_res else None)
    stats = ("max", "min") if method.kind == "min" else ("max",)
    acc = GridAccumulator(spec, stats)
    # the lowest ground (class 2) return of each cell, at its own position (a TIN through cell
    # centres would be ambiguous on the regular lattice)
    gacc = LowestPoints(spec) if method.kind in ("ground", "auto") else None
    lacc = None
    if method.kind in ("lowest", "auto"):
        size = method.size or 5.0
        b = spec.bounds
        lacc = LowestPoints(GridSpec.from_bounds(*b, size, crs=spec.crs))
    keep_pts = chm != "max"
    kept = []
    n = 0
    for chunk in src.chunks(SubProgress(prog, 0.3, 0.8)):
        n += len(chunk)
        acc.add(chunk.x, chunk.y, chunk.z)
        if occ is not None:
            occ.add(chunk.x, chunk.y, chunk.z)
        if gacc is not None and chunk.classification is not None:
            g = chunk.classification == 2
            if g.any():
                gacc.add(chunk.x[g], chunk.y[g], chunk.z[g])
        if lacc is not None:
            lacc.add(chunk.x, chunk.y, chunk.z)
        if keep_pts:
            first = chunk.return_number
            sel = slice(None) if first is None else (first <= 1)
            kept.append((chunk.x[sel], chunk.y[sel], chunk.z[sel]))
    if n == 0:
        raise InputError(f"{src.path}: no points" + (
            f" left after dropping classes {sorted(src.dropped)}" if src.dropped else ""))
    check_cancel(prog)
    if occ is not None:
        from .chm import chm_resolution

        # -tr auto took the density over the bounding box; over the cells holding points it can
        # call for finer cells (a stand turned 45° fills half its box): read again at those
        fine = chm_resolution(n, float((occ.count > 0).sum()) * occ.spec.cell_area)
        if fine < res - 1e-9:
            del acc, gacc, lacc, kept
            return compute_surfaces(src, fine, dtm=dtm, fill=fill, chm=chm, outliers=outliers,
                                    res_rule=res_rule, max_edge=max_edge, progress=progress)
    dsm_raw = acc.result("max")
    # the data footprint: cells within 2 m (or 3 point spacings) of a cell with points
    footprint = data_footprint(np.isfinite(dsm_raw), spec.res,
                               max(2.0, 3.0 * math.sqrt(spec.cell_area * np.isfinite(dsm_raw).sum() / n)))
    kind = method.kind
    if kind == "auto":
        kind = "ground" if int((gacc.count > 0).sum()) >= 3 else "lowest"
    prog.update(0.82, "terrain")
    if kind == "min":
        dtm_arr = fill_gaps(acc.result("min"), fill)
    elif kind == "none":
        dtm_arr = np.zeros(spec.shape)
    elif kind == "ground":
        gx, gy, gz = gacc.points(min_share=0.0)
        if gx.size == 0:
            raise InputError(f"{src.path}: -dtm ground: the file has no ground (class 2) points; "
                             "use -dtm auto, lowest:R, kp or a DTM GeoTIFF")
        dtm_arr = interpolate_tin(gx, gy, gz, spec)
    elif kind == "lowest":
        dtm_arr = interpolate_tin(*lacc.points(), spec)
    elif kind == "kp":
        from .ground import KrausPfeifer

        kp = KrausPfeifer() if method.g is None else KrausPfeifer(g=method.g, w=method.w)
        pts, ground = ground_points(src, kp, SubProgress(prog, 0.82, 0.88))
        dtm_arr = dtm_from_ground(pts, ground, spec)
    else:  # file
        arr, dspec, _ = read_raster(method.path)
        dtm_arr = resample_to(arr, dspec, spec)
        has = np.isfinite(dsm_raw)
        miss = int((has & ~np.isfinite(dtm_arr)).sum())
        if miss > 0.01 * max(int(has.sum()), 1):
            b, db = spec.bounds, dspec.bounds
            raise InputError(
                f"-dtm {method.path}: the DTM does not cover the points ({miss:,} of "
                f"{int(has.sum()):,} cells with points have no terrain height; DTM x "
                f"{db[0]:.1f}..{db[2]:.1f}, y {db[1]:.1f}..{db[3]:.1f}; points x {b[0]:.1f}.."
                f"{b[2]:.1f}, y {b[1]:.1f}..{b[3]:.1f}); give a DTM of the whole area or -dtm auto")
        if miss:  # a few edge cells: the nearest terrain height
            dtm_arr = fill_gaps(dtm_arr, "mean8")
    check_cancel(prog)
    chm_raw = dsm_raw - dtm_arr
    out_cells = np.zeros(spec.shape, bool)
    out_points = 0
    ceiling = None
    if outliers:
        out_cells, ceiling = canopy_outliers(chm_raw, res, origin=(spec.left, spec.top))
    if out_cells.any():
        out_points = int(out_cells.sum())
        dsm_raw = np.where(out_cells, np.nan, dsm_raw)
    # the highest return above ground of each cell (NaN: none); plantation mode looks at it
    returns = dsm_raw - dtm_arr
    prog.update(0.88, "filling gaps")
    dsm = fill_gaps(dsm_raw, fill, progress=SubProgress(prog, 0.88, 0.9), mask=footprint)
    if chm == "max":
        chm_arr = dsm - dtm_arr
        heights = chm_arr
    else:
        x = np.concatenate([k[0] for k in kept])
        y = np.concatenate([k[1] for k in kept])
        z = np.concatenate([k[2] for k in kept])
        del kept
        zn = z - _bilinear(dtm_arr, spec, x, y)
        if out_cells.any():
            r, c = spec.cell_index(x, y)
            r = np.clip(r, 0, spec.height - 1)
            c = np.clip(c, 0, spec.width - 1)
            noise = out_cells[r, c] & (zn > ceiling[r, c])
            out_points = int(noise.sum())
            x, y, zn = x[~noise], y[~noise], zn[~noise]
        prog.update(0.9, f"{chm} CHM")
        check_cancel(prog)
        if chm == "tin":
            chm_arr = tin_surface(x, y, zn, spec, max_radius=LOCAL_RADIUS)
        else:
            if max_edge is None:
                max_edge = pitfree_edge(x.size, float(np.isfinite(dsm_raw).sum()) * spec.cell_area)
            chm_arr = pitfree_chm(x, y, zn, spec, max_edge=(0.0, max_edge),
                                  coarse=np.where(out_cells, np.nan, chm_raw))
        chm_arr = fill_gaps(chm_arr, fill, mask=footprint)
        # tree heights: the highest return of a cell is above the TIN at its centre
        heights = np.fmax(chm_arr, returns)
    prog.update(0.95, "canopy height")
    return {"dsm": dsm, "dtm": dtm_arr, "chm": chm_arr, "heights": heights, "returns": returns,
            "spec": spec, "res": res,
            "dtm_method": _dtm_label(method, kind), "chm_method": chm,
            "points": n, "outside": acc.outside, "dropped": dict(src.dropped),
            # points per m² over the data footprint
            "density": n / max(float(footprint.sum()) * spec.cell_area, 1e-9),
            "outlier_cells": int(out_cells.sum()), "outlier_points": out_points}


def _tags(command: str, src: PointSource, params: dict) -> dict:
    tags = {"LIDARTREES_COMMAND": command, "LIDARTREES_INPUT": str(src.path),
            "LIDARTREES_PARAMETERS": {k: v for k, v in params.items() if v is not None},
            "LIDARTREES_CRS": crs_label(src.crs), "LIDARTREES_TOOL": f"lidartrees_gis {__version__}"}
    tags.update({k.upper().replace("REPROJECTION_", "LIDARTREES_"): v
                 for k, v in _repro_meta(src).items()})
    return tags


def _repro_report(src: PointSource):
    """The ``-t_srs`` operation in words (None without a reprojection)."""
    return src.repro.report() if getattr(src, "repro", None) else None


def _repro_meta(src: PointSource) -> dict:
    """Source CRS, operation and its accuracy of a ``-t_srs`` reprojection (empty without)."""
    r = getattr(src, "repro", None)
    if r is None:
        return {}
    acc = None if r.accuracy is None or r.accuracy < 0 else r.accuracy
    return {"reprojection_source_crs": crs_label(r.src), "reprojection_operation": r.description,
            "reprojection_accuracy_m": "unknown" if acc is None else f"{acc:g}",
            "reprojection_note": r.note.lstrip("; ") or None}


#: LAS classes dropped by default: 7 low noise, 18 high noise (ASPRS)
NOISE_CLASSES = (7, 18)


def parse_classes(value, param="-drop_class"):
    """``"7,18"``, ``"7 18"``, ``[7, 18]``, ``"none"`` -> tuple of ints (empty for none)."""
    if value is None:
        return None
    if isinstance(value, (list, tuple)):
        items = [str(v) for v in value]
    else:
        text = str(value).strip().lower()
        if text in ("", "none", "-"):
            return ()
        items = text.replace(",", " ").split()
    try:
        out = tuple(int(v) for v in items)
    except ValueError:
        raise InputError(f"{param}: expected class numbers such as 7,18 (or none), got {value!r}") from None
    if any(c < 0 or c > 255 for c in out):
        raise InputError(f"{param}: classes are 0-255, got {value!r}")
    return out


def open_filtered(input, *, a_srs=None, t_srs=None, drop_class=NOISE_CLASSES, keep_class=None,
                  **read_kw) -> PointSource:
    """Open a point file with its class filter set: ``drop_class`` (default 7 and 18, noise)
    and ``keep_class`` (only these; default all), as LAStools' ``-drop_class``/``-keep_class``."""
    src = open_input(input, a_srs=a_srs, t_srs=t_srs, **read_kw)
    src.set_class_filter(drop=parse_classes(drop_class) or (),
                         keep=parse_classes(keep_class, "-keep_class"))
    return src


def _filter_report(src, s=None) -> dict:
    out = {"dropped_classes": {str(k): v for k, v in sorted(src.dropped.items())} or None}
    if s is not None:
        out["outlier_points"] = s.get("outlier_points") or None
    return out


def grid_file(input, output, *, res="auto", stat="max", fill="none", a_srs=None, t_srs=None,
              drop_class=NOISE_CLASSES, keep_class=None, creation_options=None, overwrite=False,
              progress=None, **read_kw) -> dict:
    """Grid a point file into a GeoTIFF with one statistic per cell.

    ``stat`` is ``max``, ``min``, ``mean`` or ``count``; empty cells are nodata (0 for count)
    unless ``fill="mean8"``. ``res="auto"`` is seed 003's sqrt(1/n). Points of the classes
    ``drop_class`` (noise, 7 and 18, by default) are left out. Returns a dict with the grid
    spec, point count and the output path.
    """
    from .io.output import check_outputs

    check_outputs([(output, "OUTPUT")], (input,), overwrite)
    src = open_filtered(input, a_srs=a_srs, t_srs=t_srs, drop_class=drop_class,
                        keep_class=keep_class, **read_kw)
    prog = as_progress(progress)
    r = resolve_resolution(src, res, SubProgress(prog, 0, 0.2))
    spec = grid_spec_for(src, r, SubProgress(prog, 0, 0.2))
    acc = GridAccumulator(spec, (stat,))
    n = 0
    for chunk in src.chunks(SubProgress(prog, 0.2, 0.9)):
        n += len(chunk)
        acc.add(chunk.x, chunk.y, chunk.z)
    if n == 0:
        raise InputError(f"{input}: no points")
    check_cancel(prog)
    arr = acc.result(stat)
    if stat == "count":
        if fill not in (None, "none"):
            raise InputError("-fill: gap filling does not apply to -stat count")
        write_geotiff(output, arr, spec, overwrite=overwrite, dtype="int32", nodata=None,
                      creation_options=creation_options,
                      tags=_tags("grid", src, {"res": r, "stat": stat}), description="count")
    else:
        arr = fill_gaps(arr, fill)
        write_geotiff(output, arr, spec, overwrite=overwrite, creation_options=creation_options,
                      tags=_tags("grid", src, {"res": r, "stat": stat, "fill": fill}),
                      description=f"z {stat}")
    prog.update(1.0, "done")
    return {"output": str(output), "points": n, "res": r, "shape": spec.shape,
            "crs": crs_label(spec.crs), "skipped": src.skipped, **_filter_report(src),
            "reprojection": _repro_report(src)}


def chm_file(input, output, *, res="auto", dtm="auto", chm="pitfree", fill="mean8",
             outliers=True, drop_class=NOISE_CLASSES, keep_class=None, dsm_out=None,
             dtm_out=None, a_srs=None, t_srs=None, creation_options=None, overwrite=False,
             progress=None, **read_kw) -> dict:
    """Canopy height model GeoTIFF (and optionally the DSM and DTM) from a point file.

    Defaults: cell size ``auto`` (max(sqrt(1/n), 0.25 m)), DTM ``auto`` (class-2 ground if any,
    else lowest:5), pit-free CHM (Khosravipour et al. 2014), noise classes 7 and 18 dropped
    and isolated returns far above the canopy removed (see :func:`compute_surfaces`).
    """
    from .io.output import check_outputs

    check_outputs([(output, "OUTPUT"), (dsm_out, "-dsm_out"), (dtm_out, "-dtm_out")], (input,),
                  overwrite)
    src = open_filtered(input, a_srs=a_srs, t_srs=t_srs, drop_class=drop_class,
                        keep_class=keep_class, **read_kw)
    prog = as_progress(progress)
    s = compute_surfaces(src, res, dtm=dtm, fill=fill, chm=chm, outliers=outliers,
                         progress=SubProgress(prog, 0, 0.9))
    params = {"res": s["res"], "dtm": s["dtm_method"], "chm": chm, "fill": fill,
              "outliers": outliers, "drop_class": ",".join(map(str, parse_classes(drop_class) or ())),
              "keep_class": keep_class}
    check_cancel(prog)
    write_geotiff(output, s["chm"], s["spec"], overwrite=overwrite, creation_options=creation_options,
                  tags=_tags("chm", src, params), description="canopy height (m)")
    if dsm_out:
        write_geotiff(dsm_out, s["dsm"], s["spec"], overwrite=overwrite,
                      creation_options=creation_options, tags=_tags("chm", src, params),
                      description="surface height (m)")
    if dtm_out:
        write_geotiff(dtm_out, s["dtm"], s["spec"], overwrite=overwrite,
                      creation_options=creation_options, tags=_tags("chm", src, params),
                      description="terrain height (m)")
    prog.update(1.0, "done")
    return {"output": str(output), "points": s["points"], "res": s["res"], "shape": s["spec"].shape,
            "crs": crs_label(s["spec"].crs), "dtm": s["dtm_method"], "chm": chm,
            "skipped": src.skipped, **_filter_report(src, s),
            "reprojection": _repro_report(src)}


# ---------------------------------------------------------------------------------------------
# trees and compare
RASTER_SUFFIXES = (".tif", ".tiff", ".vrt", ".img")

#: seed 000, Table 1: the ten configurations compared by `lidartrees compare`
TABLE1 = (
    ("region growing, no smoothing", "rg", "none"),
    ("region growing, fine Gaussian", "rg", "gauss3"),
    ("region growing, coarse Gaussian", "rg", "gauss5"),
    ("watershed, no smoothing", "watershed", "none"),
    ("watershed, opening, cross", "watershed", "open:cross"),
    ("watershed, abefec, cross", "watershed", "abefec:cross"),
    ("watershed, opening, square", "watershed", "open:square"),
    ("watershed, abefec, square", "watershed", "abefec:square"),
    ("watershed, opening, rhombus", "watershed", "open:rhombus"),
    ("watershed, abefec, rhombus", "watershed", "abefec:rhombus"),
)


def load_chm(input, *, res="auto", dtm="auto", chm="pitfree", fill="mean8", outliers=True,
             drop_class=NOISE_CLASSES, keep_class=None, a_srs=None, t_srs=None, progress=None,
             returns=False, **read_kw):
    """A CHM from a GeoTIFF, or built from points (see :func:`chm_file` for the defaults).

    Returns ``(chm, spec, source, info)``; ``info`` says how a CHM was built from points
    (resolution, DTM, CHM kind, dropped classes, outliers), empty for a GeoTIFF, and holds the
    tree-height grid (``heights``) and, with ``returns=True`` (plantation mode), the highest
    return above ground of each cell (``returns``).
    """
    if str(input).lower().endswith(RASTER_SUFFIXES):
        from .crs import parse_crs

        arr, spec, _ = read_raster(input)
        if a_srs:
            spec = spec.with_crs(parse_crs(a_srs))
        return arr, spec, str(input), {"heights": arr}
    src = open_filtered(input, a_srs=a_srs, t_srs=t_srs, drop_class=drop_class,
                        keep_class=keep_class, **read_kw)
    s = compute_surfaces(src, "auto" if res is None else res, dtm=dtm, fill=fill, chm=chm,
                         outliers=outliers, progress=progress)
    info = {"res": s["res"], "dtm": s["dtm_method"], "chm": chm, "points": s["points"],
            "heights": s["heights"], "returns": s["returns"] if returns else None,
            "density": s["density"],
            **_filter_report(src, s), "repro": _repro_meta(src),
            "reprojection": _repro_report(src)}
    return s["chm"], s["spec"], str(input), info


def trees_frames(result: dict, spec: GridSpec, nln: str = ""):
    """GeoDataFrames ``tree_tops`` and ``crowns``, a ``summary`` DataFrame and, in plantation
    mode (``result["stocking"]``), a ``gaps`` point layer of the missing trees, from a result
    of :func:`lidartrees_gis.trees.detect_trees`."""
    import geopandas as gpd
    import pandas as pd
    import shapely

    from .metrics import crown_polygons

    t = result["table"]
    n = len(t["tree_id"])
    cols = ["tree_id", "x", "y", "height", "crown_area", "crown_diameter", "n_cells", "method"]
    attrs = pd.DataFrame({c: t[c] for c in cols})
    attrs["tree_id"] = attrs["tree_id"].astype("int64")
    attrs["n_cells"] = attrs["n_cells"].astype("int64")
    attrs["method"] = attrs["method"].astype(str)
    crs = spec.crs.to_wkt() if spec.crs is not None else None
    tops = gpd.GeoDataFrame(attrs.copy(), geometry=shapely.points(t["x"], t["y"]), crs=crs)
    polys = crown_polygons(result["labels"], spec, n)
    crowns = gpd.GeoDataFrame(attrs.copy(), geometry=polys, crs=crs)
    chm = result.get("chm")
    cells = int(np.isfinite(chm).sum()) if chm is not None else spec.width * spec.height
    area_ha = cells * spec.cell_area / 1e4  # area processed: cells with a canopy height
    h = t["height"]
    p = result["params"]
    auto = result.get("auto") or {}
    row = {
        "trees": n, "area_ha": area_ha, "trees_per_ha": n / area_ha if area_ha else np.nan,
        "mean_height": float(np.mean(h)) if n else np.nan,
        "sd_height": float(np.std(h, ddof=1)) if n > 1 else np.nan,
        "mean_crown_diameter": float(np.mean(t["crown_diameter"])) if n else np.nan,
        "method": p.method, "smooth": auto.get("smooth", p.smooth) if p.smooth == "auto" else p.smooth,
        "tops": result.get("tops", p.tops), "res": spec.res,
        "crown_scale": auto.get("crown_scale", np.nan),
        "dominant_height": auto.get("dominant_height", np.nan),
        # trees found by the second look at the empty planting positions (gap_tops), and the
        # spacings of the lattice found under the tops without -spacing
        "gap_trees": int(result.get("gap_trees", 0)),
        "planting_detected": result.get("planting_detected", ""),
    }
    layers = {}
    st = result.get("stocking")
    if st is not None:
        g = st["grid"]
        row.update(stocking_fields((g.row_spacing, g.tree_spacing), g.azimuth, st))
        gaps = gpd.GeoDataFrame(
            {"gap_id": np.arange(1, st["missing"] + 1, dtype=np.int64),
             "row_index": st["gaps_j"], "position_in_row": st["gaps_i"],
             "x": st["gaps_x"], "y": st["gaps_y"]},
            geometry=shapely.points(st["gaps_x"], st["gaps_y"]), crs=crs)
        layers[f"{nln}gaps"] = gaps
    summary = pd.DataFrame([row])
    return {f"{nln}tree_tops": tops, f"{nln}crowns": crowns, **layers, f"{nln}summary": summary}


def stocking_fields(spacing, azimuth: float, st: dict) -> dict:
    """The summary fields of plantation mode from the counts of
    :func:`lidartrees_gis.stocking.stocking` (``expected, stocked, missing, extra,
    planted_area_ha``; summed over the tiles of a tiled run)."""
    e = st["expected"]
    return {"spacing": f"{spacing[0]:g}x{spacing[1]:g}", "row_azimuth": azimuth,
            "planting_positions": e, "stocked_positions": st["stocked"],
            "missing_trees": st["missing"], "extra_tops": st["extra"],
            "stocking_pct": 100.0 * st["stocked"] / e if e else float("nan"),
            "planted_per_ha": 1e4 / (spacing[0] * spacing[1]),
            "planted_area_ha": st["planted_area_ha"]}


def nice_step(span: float, classes: int = 6) -> float:
    """A round class width (1, 2 or 5 times a power of ten) that cuts ``span`` into the number
    of classes nearest to ``classes`` (the more classes on a tie): the CHM legends of the quick
    look and of the QGIS style. A 36 m CHM gets 5 m classes (8), a 27 m one 5 m classes (6)."""
    span = max(float(span), 1e-9)
    mag = 10.0 ** np.floor(np.log10(span / classes))
    cands = [m * mag * f for f in (0.1, 1.0, 10.0) for m in (1.0, 2.0, 5.0)]
    return float(min(cands, key=lambda st: (abs(math.ceil(span / st - 1e-9) - classes), st)))


def height_classes(top: float, classes: int = 6) -> list:
    """Upper limits of the CHM legend's classes: a round width (:func:`nice_step`) from 0 to
    just above ``top``, at least two classes (quick look, QGIS style)."""
    step = nice_step(max(float(top), 1.0), classes)
    n = max(2, math.ceil(float(top) / step - 1e-9))
    return [(i + 1) * step for i in range(n)]


def round_length(length: float) -> float:
    """The largest 1, 2 or 5 times a power of ten not above ``length`` (scale bars)."""
    length = max(float(length), 1e-9)
    mag = 10.0 ** np.floor(np.log10(length))
    return float(max(m * mag for m in (1.0, 2.0, 5.0) if m * mag <= length * (1 + 1e-9)))


def write_quicklook(path, chm, labels, rows, cols, *, spec=None, title=None, overwrite=False):
    """Quick-look PNG: the CHM in colour classes with a legend, crown outlines and tree tops,
    map coordinates on the axes, a scale bar and a title (e.g. the stand summary).

    ``spec`` (:class:`GridSpec`) gives the coordinates and scale bar; without it the axes are in
    cells. The title and the summary are also stored as PNG text (Title, Description).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import BoundaryNorm
    from mpl_toolkits.axes_grid1.anchored_artists import AnchoredSizeBar
    from skimage.segmentation import find_boundaries

    from .io.output import atomic_output

    a = np.asarray(chm, np.float64)
    h, w = a.shape
    finite = a[np.isfinite(a)]
    top = float(np.nanpercentile(finite, 99.5)) if finite.size else 1.0
    bounds = np.array([0.0] + height_classes(top))
    cmap = plt.get_cmap("YlGn", bounds.size - 1).with_extremes(bad="#d9d9d9")
    if spec is not None:
        left, right = spec.left, spec.left + w * spec.res
        bottom, topy = spec.top - h * spec.res, spec.top
        px = spec.res
    else:
        left, right, bottom, topy, px = 0.0, float(w), float(h), 0.0, 1.0
    extent = (left, right, bottom, topy)
    aspect = h / max(w, 1)
    fig_w = 9.0
    fig = plt.figure(figsize=(fig_w, min(max(fig_w * aspect * 0.85 + 1.2, 4.0), 14.0)), dpi=110)
    ax = fig.add_axes([0.1, 0.08, 0.72, 0.82])
    im = ax.imshow(np.ma.masked_invalid(np.clip(a, 0, None)), cmap=cmap,
                   norm=BoundaryNorm(bounds, cmap.N, clip=True), extent=extent,
                   interpolation="nearest")
    k = max(1, int(np.ceil(500 / max(h, w))))  # outlines on a finer grid stay thin
    lab = np.kron(np.asarray(labels), np.ones((k, k), dtype=np.asarray(labels).dtype))
    edge = find_boundaries(lab, mode="inner") & (lab > 0)
    ov = np.zeros(lab.shape + (4,))
    ov[edge] = (0.85, 0.0, 0.55, 1.0)  # magenta outlines: not in the CHM's greens
    ax.imshow(ov, extent=extent, interpolation="nearest")
    r, c = np.asarray(rows, float), np.asarray(cols, float)
    if spec is not None:
        tx, ty = left + (c + 0.5) * px, topy - (r + 0.5) * px
    else:
        tx, ty = c + 0.5, r + 0.5
    ax.scatter(tx, ty, s=max(4.0, 3000.0 / max(len(r), 1) ** 0.5 / 10), c="#e31a1c",
               edgecolors="white", linewidths=0.4, zorder=3, label=f"tree tops ({len(r):,})")
    ax.plot([], [], color=(0.85, 0.0, 0.55), label="crowns")
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 0.2), fontsize=8, frameon=False)
    ax.set_xlim(left, right)
    ax.set_ylim(bottom, topy)
    ax.ticklabel_format(useOffset=False, style="plain")
    ax.tick_params(labelsize=7)
    for t in ax.get_yticklabels():
        t.set_rotation(90)
        t.set_va("center")
    unit = "m" if spec is not None else "cells"
    ax.set_xlabel(f"x ({unit})" + (f"  ·  {crs_label(spec.crs)}" if spec is not None and
                                    spec.crs is not None else ""), fontsize=8)
    ax.set_ylabel(f"y ({unit})", fontsize=8)
    span = (right - left) * 0.2
    bar = round_length(span) if span > 0 else 1.0
    ax.add_artist(AnchoredSizeBar(ax.transData, bar, f"{bar:g} {unit}", "lower right", pad=0.4,
                                  color="black", frameon=True, size_vertical=max(bar / 40, px)))
    cax = fig.add_axes([0.85, 0.45, 0.025, 0.45])
    cb = fig.colorbar(im, cax=cax, ticks=bounds)
    cb.set_label("canopy height (m)", fontsize=8)
    cb.ax.tick_params(labelsize=7)
    title = title or "lidartrees_gis quick look"
    fig.suptitle(title, fontsize=9)
    with atomic_output(path, overwrite, param="-png") as tmp:
        fig.savefig(tmp, format="png", metadata={"Title": title.split("\n")[0],
                                                 "Description": title,
                                                 "Software": f"lidartrees_gis {__version__}"})
    plt.close(fig)


def quicklook_title(summary: dict, source) -> str:
    """The quick-look title: the input's name and the stand summary in one or two lines."""
    def f(k, fmt):
        v = summary.get(k)
        return None if v is None or (isinstance(v, float) and not np.isfinite(v)) else fmt.format(v)

    parts = [f("trees", "{:,} trees"), f("trees_per_ha", "{:,.0f} trees/ha"),
             f("mean_height", "mean height {:.1f} m"),
             f("mean_crown_diameter", "crown diameter {:.1f} m"),
             f("stocking_pct", "stocking {:.1f} %")]
    name = Path(str(source)).name if source else "CHM"
    return f"{name}\n" + " · ".join(p for p in parts if p)


#: plantation mode warns below this point density (points/m² over the data footprint): planted
#: trees lower than their in-row neighbours are often missed and the stocking is under-reported
#: (measured on the synthetic 3 x 2 m stand: 93.0 % for a true 95.8 % at 4 pts/m², 81.8 % at
#: 2 pts/m²); a delivery of 4 pts/m² measures 3.9-4.0
PLANTATION_MIN_DENSITY = 3.5


def warn_sparse_plantation(density: float) -> None:
    """A :class:`DataWarning` in plantation mode below :data:`PLANTATION_MIN_DENSITY`."""
    if density < PLANTATION_MIN_DENSITY:
        import warnings

        warnings.warn(DataWarning(
            f"{density:.1f} points/m²: below {PLANTATION_MIN_DENSITY:g} points/m² planted "
            "trees lower than their neighbours are often missed, so the stocking is "
            "under-reported (a synthetic 3 x 2 m stand: 81.8 % found for a true 95.8 % at "
            "2 points/m², 93.0 % at 4 points/m²)"), stacklevel=3)


def detect_with_stocking(arr, spec, params, heights=None, progress=None, *, returns=None,
                         density=None, within=None) -> dict:
    """:func:`lidartrees_gis.trees.detect_trees` on a CHM, plus the stocking of the fitted
    planting grid in plantation mode (``params.spacing``); the CHM is kept as ``result["chm"]``.

    In plantation mode, with ``returns`` (the highest return above ground of each cell, from
    points), the empty planting positions are searched once more for a tree the tops finder
    missed (:func:`lidartrees_gis.stocking.gap_tops`); the crowns are then grown again from all
    tops and ``result["gap_trees"]`` says how many were added. Below
    :data:`PLANTATION_MIN_DENSITY` points per m² (``density``) a :class:`DataWarning` says
    that the stocking is under-reported. Without a spacing (``params.planting="auto"``), when
    the tops lie on a planting lattice (:func:`lidartrees_gis.stocking.detect_planting`;
    ``result["planting_detected"]`` gives its spacings), its empty positions get the same
    second look, without a stocking report. The cells of the added tops are
    ``result["gap_tops"]`` (rows, cols). ``within``: the box (a tile's core) whose positions
    the stocking counts and whose empty positions get the second look.
    """
    from .trees import detect_trees

    result = detect_trees(arr, spec, params, heights=heights)
    check_cancel(progress)
    result["chm"] = arr
    spacing, given, added, detected, grid = params.spacing, params.spacing is not None, 0, None, None
    if not given and params.planting == "auto" and returns is not None:
        from .stocking import detect_planting

        t = result["table"]
        g = detect_planting(t["x"], t["y"])
        if g is not None:
            spacing, grid = (g.row_spacing, g.tree_spacing), g
            detected = f"{g.row_spacing:.2f}x{g.tree_spacing:.2f}"
    if spacing is not None:
        from .stocking import gap_tops, stocking

        as_progress(progress).update(0.75, "planting grid")
        if given and density is not None:
            warn_sparse_plantation(density)
        t = result["table"]
        st = stocking(t["x"], t["y"], arr, spec, spacing, min_height=params.min_height, grid=grid,
                      within=within)
        if returns is not None and st["missing"]:
            rows, cols = gap_tops(st["gaps_x"], st["gaps_y"], returns, result["smoothed"], spec,
                                  spacing, top_x=t["x"], top_y=t["y"],
                                  min_height=params.min_height)
            added = int(rows.size)
            if added:
                check_cancel(progress)
                result = detect_trees(arr, spec, params, heights=heights,
                                      tops=(np.r_[t["row"], rows], np.r_[t["col"], cols]))
                result["chm"] = arr
                t = result["table"]
                if given:
                    st = stocking(t["x"], t["y"], arr, spec, spacing,
                                  min_height=params.min_height, within=within)
        if given:  # the stocking report (gaps layer) is for plantation mode only
            result["stocking"] = st
    result["gap_trees"] = added
    if added:
        result["gap_tops"] = (rows, cols)
    if detected:
        result["planting_detected"] = detected
    return result


def trees_file(input, output, *, res="auto", params=None, dtm="auto", chm="pitfree",
               fill="mean8", outliers=True, drop_class=NOISE_CLASSES, keep_class=None, nln="",
               layer_options=None, overwrite=False, append=False, png=None, csv=None,
               chm_out=None, a_srs=None, t_srs=None, progress=None, **read_kw) -> dict:
    """Tree tops, crowns and a stand summary from points or a CHM into a GeoPackage.

    From points the CHM is built as :func:`chm_file` does (pit-free, cell size auto, DTM auto,
    noise dropped); ``params`` (:class:`lidartrees_gis.trees.TreeParams`) default to automatic
    smoothing and the adaptive window. With ``params.spacing`` (plantation mode) the planting
    grid is fitted and a ``gaps`` layer of missing trees and the stocking are written too.
    """
    from .io.output import check_outputs
    from .io.vector import write_gpkg
    from .trees import TreeParams

    p = params or TreeParams()
    check_outputs([(output, "OUTPUT", overwrite or append), (png, "-png"), (csv, "-csv"),
                   (chm_out, "-chm_out")], (input,), overwrite)
    prog = as_progress(progress)
    arr, spec, source, built = load_chm(input, res=res, dtm=dtm, chm=chm, fill=fill,
                                        outliers=outliers, drop_class=drop_class,
                                        keep_class=keep_class, a_srs=a_srs, t_srs=t_srs,
                                        progress=SubProgress(prog, 0, 0.5),
                                        returns=p.looks_at_planting, **read_kw)
    prog.update(0.5, "detecting trees")
    check_cancel(prog)
    result = detect_with_stocking(arr, spec, p, built.get("heights"), prog,
                                  returns=built.get("returns"), density=built.get("density"))
    t = result["table"]
    prog.update(0.8, "writing")
    frames = trees_frames(result, spec, nln)
    meta = {"lidartrees_version": __version__, "input": source, "res": spec.res,
            "dtm": built.get("dtm", dtm), "chm": built.get("chm", "input raster"), "fill": fill,
            **p.as_dict(), **{f"auto_{k}": v for k, v in (result.get("auto") or {}).items()}}
    meta.update({k: v for k, v in (built.get("repro") or {}).items() if v is not None})
    if "res" in built:
        meta.update({"drop_class": ",".join(map(str, parse_classes(drop_class) or ())),
                     "keep_class": keep_class, "outliers": outliers,
                     "dropped_classes": built.get("dropped_classes"),
                     "outlier_points": built.get("outlier_points")})
    write_gpkg(output, frames, overwrite=overwrite, append=append, layer_options=layer_options,
               metadata=meta)
    if csv:
        from .io.output import atomic_output

        with atomic_output(csv, overwrite, param="-csv") as tmp:
            with open(tmp, "w", encoding="utf-8") as fh:
                fh.write("id,row,col,x,y,height,crown_area\n")
                for i in range(len(t["tree_id"])):
                    fh.write(f"{i + 1},{t['row'][i]},{t['col'][i]},{t['x'][i]:.3f},{t['y'][i]:.3f},"
                             f"{t['height'][i]:.3f},{t['crown_area'][i]:.4f}\n")
    if png:
        write_quicklook(png, arr, result["labels"], t["row"], t["col"], spec=spec,
                        title=quicklook_title(frames[f"{nln}summary"].iloc[0].to_dict(), source),
                        overwrite=overwrite)
    if chm_out:
        write_geotiff(chm_out, arr, spec, overwrite=overwrite, description="canopy height (m)")
    prog.update(1.0, "done")
    srow = frames[f"{nln}summary"].iloc[0].to_dict()
    out = {"output": str(output), "trees": int(srow["trees"]), "crs": crs_label(spec.crs),
           "res": spec.res, "chm": built.get("chm", "input raster"),
           "smooth": srow["smooth"], "tops": srow["tops"],
           "crown_scale": None if not np.isfinite(srow["crown_scale"]) else round(srow["crown_scale"], 3),
           "mean_height": _round(srow["mean_height"], 2),
           "mean_crown_diameter": _round(srow["mean_crown_diameter"], 2),
           "trees_per_ha": _round(srow["trees_per_ha"], 1),
           "dropped_classes": built.get("dropped_classes"), "outlier_points": built.get("outlier_points"),
           "reprojection": built.get("reprojection"), "result": result, "spec": spec,
           "gap_trees": int(srow["gap_trees"]), "planting_detected": srow["planting_detected"] or None}
    if "stocking_pct" in srow:
        out.update({k: srow[k] for k in ("spacing", "row_azimuth", "planting_positions",
                                         "missing_trees")})
        out["stocking_pct"] = _round(srow["stocking_pct"], 2)
    return out


def _round(v, n):
    """Round a number for reports; NaN and None stay as they are."""
    try:
        return round(float(v), n) if np.isfinite(v) else v
    except (TypeError, ValueError):
        return v


def compare_file(input, output, *, res="auto", dtm="auto", chm="pitfree", fill="mean8",
                 min_height=2.0, step=0.1, strict=False, drop_class=NOISE_CLASSES, keep_class=None,
                 overwrite=False, a_srs=None, t_srs=None, progress=None, **read_kw) -> dict:
    """Seed 000's Table 1 on one input: ten configurations -> trees, mean height, mean crown
    diameter (CSV and a Markdown table). Tops are 8-neighbour maxima as in the seed
    (``strict=True``: strictly higher than all 8 neighbours, the seed's literal rule)."""
    from .io.output import atomic_output, check_outputs
    from .trees import TreeParams, detect_trees

    check_outputs([(output, "OUTPUT")], (input,), overwrite)
    prog = as_progress(progress)
    arr, spec, _, info = load_chm(input, res=res, dtm=dtm, chm=chm, fill=fill, drop_class=drop_class,
                               keep_class=keep_class, a_srs=a_srs, t_srs=t_srs,
                               progress=SubProgress(prog, 0, 0.3), **read_kw)
    rows = []
    for i, (label, method, sm) in enumerate(TABLE1):
        r = detect_trees(arr, spec, TreeParams(method=method, smooth=sm, min_height=min_height,
                                               step=step, tops="strict" if strict else "lm"),
                         heights=info.get("heights"))
        t = r["table"]
        n = len(t["tree_id"])
        rows.append({"configuration": label, "method": method, "smooth": sm, "trees": n,
                     "mean_height": float(np.mean(t["height"])) if n else float("nan"),
                     "mean_crown_diameter": float(np.mean(t["crown_diameter"])) if n else float("nan")})
        prog.update(0.3 + 0.7 * (i + 1) / len(TABLE1), label)
        check_cancel(prog)
    with atomic_output(output, overwrite) as tmp:
        with open(tmp, "w", encoding="utf-8") as fh:
            fh.write("configuration,method,smooth,trees,mean_height,mean_crown_diameter\n")
            for r in rows:
                fh.write(f"\"{r['configuration']}\",{r['method']},{r['smooth']},{r['trees']},"
                         f"{r['mean_height']:.2f},{r['mean_crown_diameter']:.2f}\n")
    md = ["| method | trees | mean height (m) | mean diameter (m) |", "|---|---|---|---|"]
    md += [f"| {r['configuration']} | {r['trees']} | {r['mean_height']:.2f} | "
           f"{r['mean_crown_diameter']:.2f} |" for r in rows]
    return {"output": str(output), "rows": rows, "table": "\n".join(md), "res": spec.res,
            "reprojection": info.get("reprojection")}


# ---------------------------------------------------------------------------------------------
# ground filter and DTM quality (seed 003)
def ground_points(src: PointSource, params=None, progress=None):
    """Run the ground filter on the points of ``src``: (points, ground mask). Points of the noise
    classes (7, 18) take no part and are never ground."""
    from .ground import kraus_pfeifer

    prog = as_progress(progress)
    pts = src.read_all(SubProgress(prog, 0.0, 0.2))
    if len(pts) == 0:
        raise InputError(f"{src.path}: no points")
    use = (~np.isin(pts.classification, NOISE_CLASSES) if pts.classification is not None
           else np.ones(len(pts), bool))
    if use.sum() == 0:
        raise InputError(f"{src.path}: every point is classified as noise (7 or 18)")
    ground = np.zeros(len(pts), bool)
    ground[use], _ = kraus_pfeifer(pts.x[use], pts.y[use], pts.z[use], params,
                                   progress=SubProgress(prog, 0.2, 0.8))
    if ground.sum() < 3:
        raise InputError(f"{src.path}: the ground filter kept {int(ground.sum())} points; "
                         "raise -w or lower -g")
    return pts, ground


def grid_surface(x, y, z, spec: GridSpec) -> np.ndarray:
    """Mean height of the points in each cell, empty cells filled by mean8 (as FUSION's
    GridSurfaceCreate, which seed 003 used for its DTMs)."""
    acc = GridAccumulator(spec, ("mean",))
    acc.add(x, y, z)
    return fill_gaps(acc.result("mean"), "mean8")


def dtm_from_ground(pts, ground, spec: GridSpec) -> np.ndarray:
    """Linear TIN of the ground points sampled at the cell centres of ``spec``."""
    return interpolate_tin(pts.x[ground], pts.y[ground], pts.z[ground], spec)


def ground_classes(classification, ground, reclassify=False) -> np.ndarray:
    """Classes written by ``ground``: the filter's decision (2 ground, 1 not) for points that were
    never classified, unclassified or ground (0, 1, 2); every other class (water, buildings,
    noise...) is kept unless ``reclassify``. Noise (7, 18) is never made ground."""
    ground = np.asarray(ground, bool)
    decided = np.where(ground, 2, 1).astype(np.uint8)
    if classification is None:
        return decided
    c = np.asarray(classification).astype(np.uint8)
    open_ = np.isin(c, (0, 1, 2))
    if reclassify:
        open_ = ~np.isin(c, NOISE_CLASSES)
    return np.where(open_, decided, c).astype(np.uint8)


def ground_file(input, output, *, dtm_out=None, res="auto", params=None, overwrite=False,
                reclassify=False, a_srs=None, t_srs=None, creation_options=None, progress=None,
                **read_kw) -> dict:
    """Classify ground (class 2) with Kraus & Pfeifer robust interpolation; write the classified
    LAS/LAZ and optionally the DTM GeoTIFF (linear TIN of the ground points, cell sqrt(1/n))."""
    from .io.lasout import write_classified
    from .io.output import check_outputs

    check_outputs([(output, "OUTPUT"), (dtm_out, "-dtm")], (input,), overwrite)
    src = open_input(input, a_srs=a_srs, t_srs=t_srs, **read_kw)
    prog = as_progress(progress)
    pts, ground = ground_points(src, params, SubProgress(prog, 0, 0.7))
    check_cancel(prog)
    cls = ground_classes(pts.classification, ground, reclassify)
    from .ground import KrausPfeifer

    meta = {"command": "ground", "tool": f"lidartrees_gis {__version__}", "input": str(src.path),
            "crs": crs_label(src.crs), "reclassify": reclassify,
            **(params or KrausPfeifer()).as_dict(), **_repro_meta(src)}
    write_classified(output, src, cls, overwrite=overwrite, metadata=meta)
    out = {"output": str(output), "points": len(pts), "ground": int((cls == 2).sum()),
           "ground_share": float((cls == 2).mean()), "kept_classes": int((~np.isin(cls, (1, 2))).sum()),
           "crs": crs_label(src.crs), "reprojection": _repro_report(src)}
    if dtm_out:
        r = resolve_resolution(src, res)
        spec = GridSpec.from_bounds(pts.x.min(), pts.y.min(), pts.x.max(), pts.y.max(), r,
                                    crs=src.crs)
        prog.update(0.85, "DTM")
        dtm = dtm_from_ground(pts, cls == 2, spec)
        check_cancel(prog)
        write_geotiff(dtm_out, dtm, spec, overwrite=overwrite, creation_options=creation_options,
                      tags=_tags("ground", src, {"res": r, **(params or KrausPfeifer()).as_dict()}),
                      description="terrain height (m)")
        out.update({"dtm": str(dtm_out), "res": r})
    prog.update(1.0, "done")
    return out


def parse_range(text, param):
    """``START:STOP:STEP`` (inclusive) or a comma list -> list of floats."""
    s = str(text).strip()
    try:
        if ":" in s:
            a, b, c = (float(t) for t in s.split(":"))
            if c <= 0 or b < a:
                raise ValueError
            n = int(round((b - a) / c)) + 1
            return [round(a + i * c, 10) for i in range(n)]
        return [float(t) for t in s.split(",") if t.strip()]
    except ValueError:
        raise InputError(f"{param}: expected START:STOP:STEP or a comma list, got {text!r}") from None


_SWEEP = {}


def _sweep_init(x, y, z, spec, base):
    _SWEEP.update(x=x, y=y, z=z, spec=spec, base=base)


def _sweep_one(gw):
    from dataclasses import replace

    from .ground import kraus_pfeifer, texture_descriptors

    g, w = gw
    x, y, z, spec = _SWEEP["x"], _SWEEP["y"], _SWEEP["z"], _SWEEP["spec"]
    try:
        ground, _ = kraus_pfeifer(x, y, z, replace(_SWEEP["base"], g=g, w=w))
    except InputError:
        ground = np.zeros(x.size, bool)
    if ground.sum() >= 3:  # the same DTM as `ground -dtm` and `chm -dtm kp`: linear TIN
        dtm = interpolate_tin(x[ground], y[ground], z[ground], spec)
    else:  # an incomplete DTM: nothing to interpolate
        dtm = np.full(spec.shape, np.nan)
    return g, w, int(ground.sum()), texture_descriptors(dtm), dtm.astype(np.float32)


def write_hillshade_png(path, dtm, res, title="", overwrite=False):
    """Hillshade (azimuth 315°, altitude 45°) of a DTM as a PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import LightSource

    from .io.output import atomic_output

    a = np.asarray(dtm, dtype=np.float64)
    fill = np.nanmean(a) if np.isfinite(a).any() else 0.0
    hs = LightSource(azdeg=315, altdeg=45).hillshade(np.where(np.isfinite(a), a, fill), dx=res, dy=res)
    fig = plt.figure(figsize=(6, 6 * a.shape[0] / max(a.shape[1], 1)), dpi=100)
    ax = fig.add_axes([0, 0, 1, 0.94])
    ax.imshow(hs, cmap="gray", interpolation="nearest")
    ax.set_axis_off()
    fig.suptitle(title, fontsize=9)
    with atomic_output(path, overwrite, param="PNG") as tmp:
        fig.savefig(tmp, format="png")
    plt.close(fig)


def cluster_roles(X, names, labels, ground_points) -> dict:
    """Seed 003's roles of the three k-means clusters: {cluster: "good" | "noisy" |
    "incomplete"} (see :func:`dtm_quality_file`)."""
    from .ground import _standardise

    Z = _standardise(X)
    cols = [i for i, n in enumerate(names) if n.startswith(("homogeneity", "dissimilarity"))]
    score = Z[:, cols].mean(axis=1)
    labels = np.asarray(labels)
    npts = np.asarray(ground_points)
    cl = [int(c) for c in np.unique(labels)]
    complete = [c for c in cl if np.median(npts[labels == c]) > 0]
    good = max(complete or cl, key=lambda c: score[labels == c].mean())
    rest = [c for c in cl if c != good]
    roles = {good: "good"}
    if rest:
        incomplete = min(rest, key=lambda c: np.median(npts[labels == c]))
        roles[incomplete] = "incomplete"
        roles.update({c: "noisy" for c in rest if c != incomplete})
    return roles


def dtm_quality_file(input, outdir, *, g="-4:1:0.5", w="1:4:0.5", res="auto", params=None,
                     seed=0, workers=None, overwrite=False, a_srs=None, t_srs=None, progress=None,
                     **read_kw) -> dict:
    """Seed 003's DTM quality sweep: the ground filter and a DTM per (g, w) (linear TIN of the
    ground points, the DTM `ground -dtm` and `chm -dtm kp` write), 12 GLCM texture descriptors
    each, PCA (descriptors with |PC1 loading| >= 0.3), k-means with k = 3, a CSV, one hillshade
    PNG per cluster, a recommended (g, w) and its DTM (``recommended_dtm.tif``).

    Roles, as seed 003 §4 and Table 2 define the groups: the *good* cluster has the highest mean
    homogeneity and dissimilarity (standardised, averaged over the 8 descriptors of those two
    kinds) among the clusters of complete DTMs; of the others, the *incomplete* one keeps fewer
    ground points (median; the seed's group 2 "could not be completely generated") and the last
    is *noisy* (spikes and holes, group 0). When the sweep gives fewer than 3 distinct DTMs
    (the densified filter often gives the same DTM for many (g, w)), each distinct DTM is a
    cluster. The recommended (g, w) is the good cluster's member nearest its centroid. ``rank``
    orders all DTMs by distance to the good centroid (1 = best).
    """
    import os
    from concurrent.futures import ProcessPoolExecutor
    from concurrent.futures import TimeoutError as FutureTimeout

    from dataclasses import replace

    from .ground import KrausPfeifer, kmeans, pca_select, _standardise

    out = Path(outdir)
    csv_path = out / "dtm_quality.csv"
    from .io.output import check_outputs

    if out.is_dir():
        check_outputs([(csv_path, "OUTPUT"), (out / "recommended_dtm.tif", "OUTPUT")], (input,),
                      overwrite)
    else:  # the folder is made at the end: the nearest existing folder above must take it
        anc = out.absolute()
        while not anc.exists():
            anc = anc.parent
        check_outputs([(anc / out.name, "OUTPUT")], (), False)
    gs, ws = parse_range(g, "-g"), parse_range(w, "-w")
    combos = [(gg, ww) for gg in gs for ww in ws]
    if len(combos) < 3:
        raise InputError("-g/-w: the sweep needs at least 3 combinations for 3 clusters")
    prog = as_progress(progress)
    src = open_input(input, a_srs=a_srs, t_srs=t_srs, **read_kw)
    pts = src.read_all(SubProgress(prog, 0, 0.05))
    r = resolve_resolution(src, res)
    spec = GridSpec.from_bounds(pts.x.min(), pts.y.min(), pts.x.max(), pts.y.max(), r, crs=src.crs)
    base = params or KrausPfeifer()
    workers = workers or int(os.environ.get("LIDARTREES_WORKERS", 0)) or os.cpu_count() or 1
    results = []
    if workers > 1:
        with ProcessPoolExecutor(workers, initializer=_sweep_init,
                                 initargs=(pts.x, pts.y, pts.z, spec, base)) as ex:
            futs = [ex.submit(_sweep_one, c) for c in combos]
            for i, f in enumerate(futs):
                while True:
                    try:
                        results.append(f.result(timeout=0.5))
                        break
                    except FutureTimeout:
                        if prog.canceled():
                            for ff in futs:
                                ff.cancel()
                            check_cancel(prog)
                prog.update(0.05 + 0.85 * (i + 1) / len(combos), f"g={combos[i][0]} w={combos[i][1]}")
    else:
        _sweep_init(pts.x, pts.y, pts.z, spec, base)
        for i, c in enumerate(combos):
            check_cancel(prog)
            results.append(_sweep_one(c))
            prog.update(0.05 + 0.85 * (i + 1) / len(combos), f"g={c[0]} w={c[1]}")
    names = list(results[0][3])
    X = np.array([[res_[3][n] for n in names] for res_ in results])
    sel, load, var = pca_select(X, 0.3)
    if sel.size == 0:  # PC1 spread evenly (every |loading| < 0.3): keep every descriptor
        sel = np.arange(X.shape[1])
    Z = _standardise(X)[:, sel]
    labels, cent = kmeans(Z, 3, seed=seed)
    npts = np.array([res_[2] for res_ in results])
    roles = cluster_roles(X, names, labels, npts)
    good = next(c for c, r in roles.items() if r == "good")
    dist = np.linalg.norm(Z - cent[good], axis=1)
    rank = np.argsort(np.argsort(dist)) + 1
    members = np.nonzero(labels == good)[0]
    best = int(members[np.argmin(dist[members])])
    out.mkdir(parents=True, exist_ok=True)
    from .io.output import atomic_output

    with atomic_output(csv_path, overwrite=True) as tmp:
        with open(tmp, "w", encoding="utf-8") as fh:
            fh.write("g,w,ground_points," + ",".join(names) + ",cluster,role,rank\n")
            for k, (gg, ww, ng, d, _) in enumerate(results):
                fh.write(f"{gg:g},{ww:g},{ng}," + ",".join(f"{d[n]:.6g}" for n in names)
                         + f",{labels[k]},{roles[int(labels[k])]},{rank[k]}\n")
    pngs = []
    for c in sorted(roles):
        mem = np.nonzero(labels == c)[0]
        dc = np.linalg.norm(Z[mem] - cent[c], axis=1)
        k = int(mem[np.argmin(dc)])
        pth = out / f"hillshade_cluster{c}.png"
        write_hillshade_png(pth, results[k][4], r, overwrite=True,
                            title=f"cluster {c} ({roles[c]}): g={results[k][0]:g} "
                                  f"w={results[k][1]:g}")
        pngs.append(str(pth))
    dtm_path = out / "recommended_dtm.tif"
    write_geotiff(dtm_path, results[best][4], spec, overwrite=True,
                  tags=_tags("dtm-quality", src, {"res": r, **replace(base, g=results[best][0],
                                                                          w=results[best][1]).as_dict()}),
                  description="terrain height (m)")
    g_eq_minus_w = [(gg, ww) for (gg, ww, *_), lab in zip(results, labels) if abs(gg + ww) < 1e-9]
    in_good = [c for c in g_eq_minus_w if labels[combos.index(c)] == good]
    prog.update(1.0, "done")
    return {"output": str(csv_path), "dtms": len(results), "res": r,
            "selected_descriptors": [names[i] for i in sel],
            "pc1_variance": float(var[0]), "clusters": [int((labels == c).sum()) for c in sorted(roles)],
            "good_cluster": good, "roles": {str(c): r for c, r in roles.items()}, "recommended_g": results[best][0],
            "recommended_w": results[best][1], "g_equals_minus_w_in_good": f"{len(in_good)}/{len(g_eq_minus_w)}",
            "pngs": pngs, "dtm": str(dtm_path),
            "reprojection": _repro_report(src)}


# ---------------------------------------------------------------------------------------------
# terrestrial scans (seeds 002 and 004)
def _plot(path, draw, *, size=(6, 6), overwrite=False):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .io.output import atomic_output

    fig, ax = plt.subplots(figsize=size, dpi=100)
    draw(ax)
    fig.tight_layout()
    with atomic_output(path, overwrite, param="PNG") as tmp:
        fig.savefig(tmp, format="png")
    plt.close(fig)


def stem_file(input, prefix, *, params=None, overwrite=False, a_srs=None, t_srs=None,
              progress=None, **read_kw) -> dict:
    """Dmax trunk filter (seed 004) on one tree: ``PREFIX_trunk.laz`` (trunk points with a
    ``section`` extra dimension), ``PREFIX_sections.csv`` and ``.gpkg`` (circles),
    ``PREFIX_summary.json`` (DBH at 1.30 m, heights) and ``PREFIX_taper.png``."""
    import json

    import geopandas as gpd
    from shapely.geometry import Point

    from .io.lasout import write_points
    from .io.output import atomic_output, check_outputs
    from .io.vector import write_gpkg
    from .tls.stem import dmax_filter

    pre = str(prefix)
    paths = {k: Path(pre + suffix) for k, suffix in (
        ("trunk", "_trunk.laz"), ("csv", "_sections.csv"), ("gpkg", "_sections.gpkg"),
        ("summary", "_summary.json"), ("png", "_taper.png"))}
    check_outputs([(pth, "OUTPUT_PREFIX") for pth in paths.values()], (input,), overwrite)
    prog = as_progress(progress)
    src = open_input(input, a_srs=a_srs, t_srs=t_srs, **read_kw)
    pts = src.read_all(SubProgress(prog, 0, 0.2))
    r = dmax_filter(pts.x, pts.y, pts.z, params, progress=SubProgress(prog, 0.2, 0.8))
    check_cancel(prog)
    ti = r["trunk_index"]
    write_points(paths["trunk"], pts.x[ti], pts.y[ti], pts.z[ti], crs=src.crs,
                 extra={"section": r["trunk_section"].astype(np.uint32)}, overwrite=overwrite)
    cols = ["section", "z", "xc", "yc", "r", "diameter", "s", "points_in", "points_kept",
            "selected", "repeated", "coverage", "converged"]
    with atomic_output(paths["csv"], overwrite) as tmp:
        with open(tmp, "w", encoding="utf-8") as fh:
            fh.write(",".join(cols) + "\n")
            for row in r["sections"]:
                fh.write(",".join("" if row.get(c) is None else (f"{row[c]:.5f}" if isinstance(row[c], float)
                                                                  else str(row[c])) for c in cols) + "\n")
    conv = [row for row in r["sections"] if row["converged"]]
    import pandas as pd

    df = pd.DataFrame([{c: row.get(c) for c in cols} for row in conv], columns=cols)
    df["z_abs"] = df["z"] + r["base"] if len(df) else []
    geom = [Point(row["xc"], row["yc"]).buffer(row["r"], 32) for row in conv]
    crs = src.crs.to_wkt() if src.crs is not None else None
    write_gpkg(paths["gpkg"], {"sections": gpd.GeoDataFrame(df, geometry=geom, crs=crs)},
               overwrite=overwrite, metadata={"input": str(input), **r["params"]})
    summary = {"input": str(input), "points": len(pts), "trunk_points": int(ti.size),
               "base": r["base"], "tree_height": r["tree_height"],
               "reached_height": r["reached_height"], "reached_percent": r["reached_percent"],
               "dbh_m": None if np.isnan(r["dbh"]) else r["dbh"],
               "dbh_cm": None if np.isnan(r["dbh"]) else 100 * r["dbh"],
               "sections_converged": len(conv), "message": r["message"], "params": r["params"]}
    with atomic_output(paths["summary"], overwrite) as tmp:
        tmp.write_text(json.dumps(summary, indent=2))

    def draw(ax):
        if conv:
            ax.plot([100 * c["diameter"] for c in conv], [c["z"] for c in conv], "o", ms=2,
                    label="section diameter")
        if summary["dbh_cm"]:
            ax.axhline(1.3, color="grey", lw=0.8, ls="--")
            ax.plot([summary["dbh_cm"]], [1.3], "r*", ms=10, label=f"DBH {summary['dbh_cm']:.1f} cm")
        ax.set_xlabel("diameter (cm)")
        ax.set_ylabel("height above base (m)")
        ax.set_ylim(0, max(r["tree_height"], 1.5))
        ax.set_title(f"Taper (Dmax filter): trunk to {r['reached_height']:.1f} m "
                     f"({r['reached_percent']:.0f} % of {r['tree_height']:.1f} m)", fontsize=9)
        ax.legend(fontsize=8)

    _plot(paths["png"], draw, size=(5, 7), overwrite=overwrite)
    prog.update(1.0, "done")
    return {**{k: str(v) for k, v in paths.items()},
            **{k: summary[k] for k in ("dbh_cm", "tree_height", "reached_height", "reached_percent",
                                       "sections_converged", "trunk_points", "message")},
            "reprojection": _repro_report(src)}


def profile_file(input, output, *, bin=0.05, sigma=0.3, overwrite=False, a_srs=None,  # noqa: A002
                 t_srs=None, progress=None, **read_kw) -> dict:
    """Roots / stem / canopy segmentation (seed 002): OUTPUT LAS/LAZ with an extra dimension
    ``part`` (1 roots, 2 stem, 3 canopy) and classification 1, plus ``OUTPUT_boundaries.json``,
    ``OUTPUT_boundaries.csv`` and ``OUTPUT_profile.png``."""
    import json

    from .io.lasout import write_points
    from .io.output import atomic_output, check_outputs
    from .tls.profile import segment_profile

    out = Path(output)
    stem = out.with_suffix("")
    paths = {"json": Path(str(stem) + "_boundaries.json"), "csv": Path(str(stem) + "_boundaries.csv"),
             "png": Path(str(stem) + "_profile.png")}
    check_outputs([(out, "OUTPUT")] + [(pth, "OUTPUT") for pth in paths.values()], (input,),
                  overwrite)
    prog = as_progress(progress)
    src = open_input(input, a_srs=a_srs, t_srs=t_srs, **read_kw)
    pts = src.read_all(SubProgress(prog, 0, 0.5))
    r = segment_profile(pts.z, bin=bin, sigma=sigma)
    check_cancel(prog)
    write_points(out, pts.x, pts.y, pts.z, crs=src.crs, classification=np.ones(len(pts), np.uint8),
                 extra={"part": r["labels"]}, overwrite=overwrite)
    info = {k: r[k] for k in ("tree_start", "stem_start", "canopy_start", "top", "has_roots",
                              "notes", "counts")}
    info.update({"z_min": float(pts.z.min()), "bin": bin, "sigma": sigma,
                 "crossings": [{"z": z, "direction": "-to+" if d > 0 else "+to-"} for z, d in r["crossings"]]})
    with atomic_output(paths["json"], overwrite) as tmp:
        tmp.write_text(json.dumps(info, indent=2))
    with atomic_output(paths["csv"], overwrite) as tmp:
        tmp.write_text("boundary,height_above_zmin_m\n" + "".join(
            f"{k},{'' if info[k] is None else round(info[k], 4)}\n"
            for k in ("tree_start", "stem_start", "canopy_start", "top")))
    prof = r["profile"]

    def draw(ax):
        ax.barh(prof["z"], prof["counts"], height=bin, color="0.8", label="points per slice")
        ax.plot(prof["smooth"], prof["z"], "r-", lw=1.2, label=f"smoothed (sigma {sigma} m)")
        ax.plot(10 * prof["d2"] * bin * bin, prof["z"], "b-", lw=0.8, label="second derivative x 10")
        for k, col in (("stem_start", "green"), ("canopy_start", "darkgreen")):
            if info[k] is not None:
                ax.axhline(info[k], color=col, ls="--", lw=1, label=f"{k.replace('_', ' ')} {info[k]:.2f} m")
        ax.axvline(0, color="k", lw=0.5)
        ax.set_xlabel("points")
        ax.set_ylabel("height above lowest point (m)")
        ax.set_title("Vertical profile (Queiroz 2017)" + ("" if r["has_roots"] else ": no root zone"),
                     fontsize=9)
        ax.legend(fontsize=7, loc="upper right")

    _plot(paths["png"], draw, size=(6, 8), overwrite=overwrite)
    prog.update(1.0, "done")
    return {"output": str(out), **{k: str(v) for k, v in paths.items()},
            **{k: info[k] for k in ("stem_start", "canopy_start", "top", "has_roots")},
            "notes": "; ".join(r["notes"]), "reprojection": _repro_report(src)}
