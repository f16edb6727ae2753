"""GeoTIFF reading and writing (rasterio): CRS, nodata, float32, DEFLATE, tiled, provenance tags."""
from __future__ import annotations

import json

import numpy as np

from .._version import __version__
from ..errors import InputError, ReadError
from ..grid import GridSpec
from .output import atomic_output

NODATA = -9999.0
DEFAULT_CO = {"COMPRESS": "DEFLATE", "TILED": "YES", "BLOCKXSIZE": "256", "BLOCKYSIZE": "256",
              "PREDICTOR": "2"}


def parse_kv(items, param="-co") -> dict:
    """``["K=V", ...]`` to a dict, with a clear error for malformed items."""
    out = {}
    for it in items or ():
        if "=" not in it:
            raise InputError(f"{param}: expected KEY=VALUE, got {it!r}")
        k, v = it.split("=", 1)
        out[k.strip().upper()] = v.strip()
    return out


def rio_crs(crs):
    """A rasterio CRS from a pyproj CRS (None stays None)."""
    from rasterio.crs import CRS

    if crs is None:
        return None
    epsg = crs.to_epsg()
    return CRS.from_epsg(epsg) if epsg else CRS.from_wkt(crs.to_wkt())


#: rasters larger than this (cells, either side) get overviews by default (``-co OVERVIEWS=``
#: ``AUTO``, the default; ``NONE``; ``FORCE``), so that QGIS opens a flight's CHM quickly
OVERVIEW_MIN_SIDE = 2048


def split_overviews(co: dict) -> tuple:
    """(GDAL creation options without ``OVERVIEWS``, the overview mode) from ``-co`` options."""
    co = dict(co)
    mode = str(co.pop("OVERVIEWS", "AUTO")).upper()
    if mode not in ("AUTO", "NONE", "NO", "FORCE", "YES"):
        raise InputError(f"-co OVERVIEWS={mode}: expected AUTO, NONE or FORCE")
    return co, {"NO": "NONE", "YES": "FORCE"}.get(mode, mode)


def build_overviews(ds, mode: str = "AUTO", resampling: str = "average") -> list:
    """Internal overviews (factors 2, 4, 8 ... down to 256 cells) of an open dataset when
    ``mode`` is FORCE, or AUTO and a side exceeds :data:`OVERVIEW_MIN_SIDE` cells."""
    from rasterio.enums import Resampling

    big = max(ds.width, ds.height)
    if mode == "NONE" or (mode == "AUTO" and big <= OVERVIEW_MIN_SIDE):
        return []
    factors, f = [], 2
    while big / f >= 256 or not factors:
        factors.append(f)
        f *= 2
    ds.build_overviews(factors, getattr(Resampling, resampling))
    ds.update_tags(ns="rio_overview", resampling=resampling)
    return factors


def write_geotiff(path, array, spec, *, overwrite=False, nodata=NODATA, dtype="float32",
                  creation_options=None, tags=None, description=None) -> None:
    """Write one band to a GeoTIFF atomically.

    Parameters
    ----------
    path : str or Path
    array : (M, N) or (B, M, N) ndarray
        NaN cells are written as ``nodata``; a 3-D array is written as B bands.
    spec : GridSpec
        Georeferencing (transform and CRS).
    overwrite : bool
        Replace an existing file; otherwise it is refused and left untouched.
    creation_options : dict, optional
        GDAL creation options (``-co``) added to / overriding DEFLATE, tiled 256x256; and
        ``OVERVIEWS=AUTO|NONE|FORCE`` (:func:`build_overviews`).
    tags : dict, optional
        Provenance tags (values are JSON-encoded when not strings).
    description : str or list of str, optional
        The band description (one per band for a 3-D array).
    """
    import rasterio

    arr = np.asarray(array)
    if arr.ndim == 2:
        arr = arr[None]
    if arr.shape[1:] != spec.shape:
        raise InputError(f"array shape {arr.shape} does not match grid {spec.shape}")
    co = dict(DEFAULT_CO)
    co.update({k.upper(): v for k, v in (creation_options or {}).items()})
    co, overviews = split_overviews(co)
    if spec.width < 16 or spec.height < 16:
        co.pop("TILED", None), co.pop("BLOCKXSIZE", None), co.pop("BLOCKYSIZE", None)
    if np.dtype(dtype).kind == "f":
        out = np.where(np.isnan(arr), nodata, arr).astype(dtype)
    else:
        out = arr.astype(dtype)
        if co.get("PREDICTOR") == "3":
            co["PREDICTOR"] = "2"
    with atomic_output(path, overwrite) as tmp:
        with rasterio.open(tmp, "w", driver="GTiff", width=spec.width, height=spec.height,
                           count=arr.shape[0],
                           dtype=dtype, crs=rio_crs(spec.crs), transform=spec.transform,
                           nodata=nodata, **co) as ds:
            ds.write(out)
            t = {"LIDARTREES_VERSION": __version__}
            for k, v in (tags or {}).items():
                t[str(k).upper()] = v if isinstance(v, str) else json.dumps(v, default=str)
            ds.update_tags(**t)
            descs = [description] if isinstance(description, str) else (description or [])
            for b, d in enumerate(descs):
                ds.set_band_description(b + 1, d)
            build_overviews(ds, overviews, "average" if np.dtype(dtype).kind == "f" else "nearest")


def _spec_of(ds, path) -> GridSpec:
    import pyproj

    t = ds.transform
    if abs(t.a + t.e) > 1e-9 * abs(t.a) or t.b or t.d:
        raise InputError(f"{path}: only north-up rasters with square cells are supported")
    crs = pyproj.CRS.from_wkt(ds.crs.to_wkt()) if ds.crs else None
    return GridSpec(t.c, t.f, t.a, ds.width, ds.height, crs)


#: values taken as nodata in a raster that declares none: the common "no data" markers
#: (-9999, -32768) and anything beyond 1e30 in size (ArcGIS's -3.4e38, float32's extremes);
#: no height or elevation takes them
NODATA_MARKERS = (-9999.0, -32768.0)
NODATA_BEYOND = 1e30


def unset_nodata(arr: np.ndarray) -> np.ndarray:
    """Which cells of a raster without a nodata value hold a nodata marker
    (:data:`NODATA_MARKERS`, or a magnitude over :data:`NODATA_BEYOND`)."""
    with np.errstate(invalid="ignore"):
        return np.isin(arr, NODATA_MARKERS) | (np.abs(arr) > NODATA_BEYOND)


def _band(ds, window=None) -> np.ndarray:
    arr = ds.read(1, window=window).astype(np.float64)
    if ds.nodata is not None:
        arr[arr == ds.nodata] = np.nan
    else:  # no nodata declared: the markers such files use (see warn_unset_nodata)
        arr[unset_nodata(arr)] = np.nan
    return arr


def warn_unset_nodata(path) -> None:
    """One warning when a raster declares no nodata value but its border rows and columns
    hold a nodata marker (:func:`unset_nodata`): those cells are read as nodata."""
    import rasterio
    from rasterio.windows import Window

    try:
        with rasterio.open(path) as ds:
            if ds.nodata is not None or ds.width == 0 or ds.height == 0:
                return
            w, h = ds.width, ds.height
            edges = [ds.read(1, window=Window(0, 0, w, 1)), ds.read(1, window=Window(0, h - 1, w, 1)),
                     ds.read(1, window=Window(0, 0, 1, h)), ds.read(1, window=Window(w - 1, 0, 1, h))]
    except rasterio.errors.RasterioIOError:
        return
    vals = np.concatenate([np.asarray(e, np.float64).ravel() for e in edges])
    bad = vals[unset_nodata(vals)]
    if bad.size:
        import warnings

        from ..errors import DataWarning

        warnings.warn(DataWarning(
            f"{path}: the raster declares no nodata value but its border holds {bad[0]:g} "
            "cells; they (and any cell of -9999, -32768 or beyond 1e30) are read as nodata"),
            stacklevel=3)


def read_raster(path):
    """Read band 1 of a raster: ``(array float64 with NaN nodata, GridSpec, tags)``."""
    import rasterio

    try:
        with rasterio.open(path) as ds:
            spec = _spec_of(ds, path)
            return _band(ds), spec, ds.tags()
    except rasterio.errors.RasterioIOError as exc:
        raise ReadError(f"{path}: cannot read raster ({exc})") from None


def read_raster_spec(path) -> GridSpec:
    """The grid of a raster (north-up, square cells), without reading its cells."""
    import rasterio

    try:
        with rasterio.open(path) as ds:
            return _spec_of(ds, path)
    except rasterio.errors.RasterioIOError as exc:
        raise ReadError(f"{path}: cannot read raster ({exc})") from None


def read_raster_window(path, spec: GridSpec) -> np.ndarray:
    """Band 1 of a raster over ``spec``, a window of its own grid (float64, NaN nodata)."""
    import rasterio
    from rasterio.windows import Window

    try:
        with rasterio.open(path) as ds:
            full = _spec_of(ds, path)
            c0 = int(round((spec.left - full.left) / full.res))
            r0 = int(round((full.top - spec.top) / full.res))
            return _band(ds, Window(c0, r0, spec.width, spec.height))
    except rasterio.errors.RasterioIOError as exc:
        raise ReadError(f"{path}: cannot read raster ({exc})") from None


def resample_to(src_array, src_spec: GridSpec, spec: GridSpec) -> np.ndarray:
    """Bilinear resampling of a raster (NaN = nodata) onto ``spec`` (e.g. an external DTM).

    A source without a CRS is taken to be in ``spec``'s CRS.
    """
    from rasterio.warp import Resampling, reproject

    dst = np.full(spec.shape, np.nan, dtype=np.float64)
    dcrs = rio_crs(spec.crs)
    scrs = rio_crs(src_spec.crs) or dcrs
    reproject(np.asarray(src_array, dtype=np.float64), dst, src_transform=src_spec.transform,
              src_crs=scrs, dst_transform=spec.transform, dst_crs=dcrs or scrs,
              resampling=Resampling.bilinear, src_nodata=np.nan, dst_nodata=np.nan)
    return dst


def check_creation_options(items) -> None:
    """Check GDAL creation options (``-co KEY=VALUE``, a list or a dict) before a run, by
    creating a small GeoTIFF with them (and the defaults they add to) in a temporary folder:
    an option GDAL rejects or ignores (a wrong name, a value it does not know, blocks that are
    not multiples of 16) is a one-line error naming it."""
    if not items:
        return
    import logging
    import tempfile

    import rasterio
    from rasterio.transform import from_origin

    co = dict(DEFAULT_CO)
    co.update(parse_kv(items) if not isinstance(items, dict) else
              {str(k).upper(): v for k, v in items.items()})
    co, _ = split_overviews(co)
    given = ", ".join(f"{k}={v}" for k, v in (parse_kv(items) if not isinstance(items, dict)
                                              else items).items())
    said = []

    class _Catch(logging.Handler):
        def emit(self, record):
            said.append(record.getMessage())

    log = logging.getLogger("rasterio._env")
    handler = _Catch(logging.WARNING)
    log.addHandler(handler)
    try:
        with tempfile.TemporaryDirectory(prefix=".lidartrees-co-") as tmp:
            with rasterio.open(f"{tmp}/check.tif", "w", driver="GTiff", width=256, height=256,
                               count=1, dtype="float32", transform=from_origin(0, 256, 1, 1),
                               nodata=NODATA, **co) as ds:
                ds.write(np.zeros((1, 256, 256), np.float32))
    except Exception as exc:  # noqa: BLE001 - GDAL's own reasons, as one line
        raise InputError(f"-co {given}: GDAL refuses these GeoTIFF creation options "
                         f"({str(exc).splitlines()[0][:160]})") from None
    finally:
        log.removeHandler(handler)
    bad = [m for m in said if "creation option" in m or "not recognised" in m
           or "CPLE_NotSupported" in m or "CPLE_IllegalArg" in m]
    if bad:
        raise InputError(f"-co {given}: GDAL does not take these GeoTIFF creation options "
                         f"({bad[0][:160]})")
