"""Point reading: XYZ text (any common dialect, gzip, :mod:`.xyz`) and LAS/LAZ 1.0-1.4
(:mod:`.las`), in chunks, behind one :class:`PointSource` opened by :func:`open_points`.

Memory never grows with the file: :meth:`PointSource.chunks` yields :class:`PointChunk` objects of
at most ``chunk_size`` points. Bad lines fail with the file, the line number and the line's text,
or are skipped and counted with ``skip_invalid=True``.
"""
from __future__ import annotations

from pathlib import Path
from typing import Iterator

import numpy as np

from ..crs import Reprojection, check_coordinates, crs_from_sidecar, parse_crs, reprojection
from ..errors import CRSError, InputError, ReadError
from .chunk import PointChunk, PointStats
from .las import (_check_las_header, _check_las_raw, _DecoderStderr, las_chunks, las_crs,
                  las_point_count, laz_backend)
from .xyz import XYZDialect, sniff_xyz, xyz_chunks

LAS_SUFFIXES = (".las", ".laz")
DEFAULT_CHUNK = 1_000_000


class PointSource:
    """An opened point file (XYZ text or LAS/LAZ) with its CRS, read chunk by chunk.

    Use :func:`open_points` to make one.
    """

    def __init__(self, path, fmt, crs, *, dialect=None, skip_invalid=False,
                 chunk_size=DEFAULT_CHUNK, repro: Reprojection | None = None, header_info=None):
        self.path = Path(path)
        self.format = fmt
        self.src_crs = crs
        self.repro = repro
        self.dialect = dialect
        self.skip_invalid = skip_invalid
        self.chunk_size = int(chunk_size)
        self.header_info = header_info or {}
        self.skipped = 0
        self._stats = None
        self.drop_classes: frozenset = frozenset()
        self.keep_classes: frozenset | None = None
        self.dropped: dict = {}  # class -> points dropped by the class filter
        self.file_crs = None  # the file's own CRS (set by open_points)

    def set_class_filter(self, drop=None, keep=None) -> None:
        """Drop points of the classes ``drop`` (e.g. 7 and 18, noise) or keep only the classes
        ``keep`` (as LAStools' ``-drop_class`` / ``-keep_class``). Points without a
        classification (XYZ text without a class column) are never dropped."""
        self.drop_classes = frozenset(int(c) for c in (drop or ()))
        self.keep_classes = None if keep is None else frozenset(int(c) for c in keep)
        self._stats = None

    @property
    def crs(self):
        """CRS of the points as yielded (the target CRS when reprojecting)."""
        return self.repro.dst if self.repro is not None else self.src_crs

    @property
    def count_hint(self) -> int | None:
        """Point count from the header (LAS) or a previous scan; None if unknown."""
        if self._stats is not None:
            return self._stats.count
        return self.header_info.get("count")

    def header_bounds(self):
        """Bounds from the LAS header when they can be trusted for gridding, else None."""
        if self.format == "las" and self.repro is None:
            return self.header_info.get("bounds")
        return None

    def chunks(self, progress=None) -> Iterator[PointChunk]:
        """Yield :class:`PointChunk` objects (in the output CRS) until the file ends."""
        gen = las_chunks(self, progress) if self.format == "las" else xyz_chunks(self, progress)
        filt = bool(self.drop_classes) or self.keep_classes is not None
        self.dropped = {}  # counts of the latest pass
        for chunk in gen:
            if filt and chunk.classification is not None and len(chunk):
                cls = chunk.classification
                bad = np.isin(cls, list(self.drop_classes)) if self.drop_classes else \
                    np.zeros(len(cls), bool)
                if self.keep_classes is not None:
                    bad |= ~np.isin(cls, list(self.keep_classes))
                if bad.any():
                    v, k = np.unique(cls[bad], return_counts=True)
                    for c_, n_ in zip(v.tolist(), k.tolist()):
                        self.dropped[int(c_)] = self.dropped.get(int(c_), 0) + int(n_)
                    chunk = chunk.subset(~bad)
            if self.repro is not None and len(chunk):
                chunk.x, chunk.y = self.repro(chunk.x, chunk.y)
                chunk.x = np.asarray(chunk.x)
                chunk.y = np.asarray(chunk.y)
            yield chunk

    def read_all(self, progress=None) -> PointChunk:
        """Read every point into one chunk (small files only)."""
        return PointChunk.concat(self.chunks(progress))

    def scan(self, progress=None) -> PointStats:
        """One pass over the points: count, bounds, z range, classes, returns."""
        if self._stats is not None:
            return self._stats
        n = 0
        b = [np.inf, np.inf, -np.inf, -np.inf, np.inf, -np.inf]
        classes: dict = {}
        returns: dict = {}
        for c in self.chunks(progress):
            if not len(c):
                continue
            n += len(c)
            b = [min(b[0], c.x.min()), min(b[1], c.y.min()), max(b[2], c.x.max()),
                 max(b[3], c.y.max()), min(b[4], c.z.min()), max(b[5], c.z.max())]
            for arr, d in ((c.classification, classes), (c.return_number, returns)):
                if arr is not None:
                    vals, cnt = np.unique(arr, return_counts=True)
                    for v, k in zip(vals.tolist(), cnt.tolist()):
                        d[int(v)] = d.get(int(v), 0) + int(k)
        if n == 0:
            raise InputError(f"{self.path}: no points")
        self._stats = PointStats(n, tuple(float(v) for v in b[:4]), (float(b[4]), float(b[5])),
                                 dict(sorted(classes.items())), dict(sorted(returns.items())),
                                 self.skipped)
        return self._stats



#: signatures and names of files that are not point data (they would otherwise be read as text)
_NOT_POINTS = ((b"SQLite format 3\x00", "a GeoPackage/SQLite database"),
               (b"\x00\x00\x27\x0a", "a shapefile"), (b"\x89PNG", "a PNG image"),
               (b"II*\x00", "a TIFF/GeoTIFF raster"), (b"MM\x00*", "a TIFF/GeoTIFF raster"),
               (b"%PDF", "a PDF document"), (b"PK\x03\x04", "a ZIP archive"),
               (b"\xff\xd8\xff", "a JPEG image"))
_NOT_POINT_SUFFIXES = {".gpkg": "a GeoPackage", ".shp": "a shapefile", ".shx": "a shapefile index",
                       ".dbf": "a shapefile table", ".tif": "a GeoTIFF raster",
                       ".tiff": "a GeoTIFF raster", ".png": "an image", ".jpg": "an image",
                       ".geojson": "a GeoJSON vector", ".kml": "a KML vector",
                       ".zip": "a ZIP archive", ".pdf": "a PDF document", ".vrt": "a GDAL VRT"}


def _refuse_non_point_data(path):
    """Refuse files that are not point data (vectors, rasters, images, archives)."""
    with open(path, "rb") as fh:
        head = fh.read(16)
    what = _NOT_POINT_SUFFIXES.get(path.suffix.lower())
    for sig, name in _NOT_POINTS:
        if head.startswith(sig):
            what = name
    if what:
        raise InputError(f"{path}: this is {what}, not point data; give LAS/LAZ or XYZ text "
                         "(x y z per line)")


def open_points(path, *, a_srs=None, t_srs=None, delimiter=None, decimal_comma=None,
                header=None, columns=None, skip_invalid=False, chunk_size=DEFAULT_CHUNK,
                require_crs=False) -> PointSource:
    """Open a point file for chunked reading.

    Parameters
    ----------
    path : str or Path
        ``.las``/``.laz`` or XYZ text (any other name; may be gzip-compressed).
    a_srs : str, optional
        Assign this CRS (overrides the file's; needed for XYZ unless a ``.prj`` sidecar exists).
    t_srs : str, optional
        Reproject the points to this CRS as they are read.
    delimiter, decimal_comma, header, columns
        Force the XYZ dialect instead of detecting it (see :func:`sniff_xyz`).
    skip_invalid : bool
        Skip malformed XYZ lines (counted in ``PointSource.skipped``) instead of failing.
    chunk_size : int
        Points per chunk.
    require_crs : bool
        Raise :class:`CRSError` when no CRS is known.
    """
    path = Path(path)
    if not path.exists():
        raise ReadError(f"{path}: no such file")
    if path.is_dir():
        raise ReadError(f"{path}: is a directory, expected a point file")
    if path.stat().st_size == 0:
        raise InputError(f"{path}: empty file, no points")
    if chunk_size < 1:
        raise InputError(f"chunk_size: must be >= 1, got {chunk_size}")
    crs = parse_crs(a_srs) if a_srs else None
    if path.name.lower() == "ept.json":
        raise InputError(f"{path}: an Entwine Point Tile index (a point cloud QGIS has indexed): "
                         "chm and trees read all its nodes; for this command give the LAS/LAZ "
                         "file it was built from")
    _refuse_non_point_data(path)
    if path.suffix.lower() in LAS_SUFFIXES:
        import laspy

        _check_las_raw(path)
        try:
            with _DecoderStderr():
                reader = laspy.open(path)
            with reader:
                h = reader.header
                info = {
                    "count": int(h.point_count),
                    "bounds": (float(h.mins[0]), float(h.mins[1]), float(h.maxs[0]), float(h.maxs[1])),
                    "zrange": (float(h.mins[2]), float(h.maxs[2])),
                    "version": str(h.version),
                    "point_format": int(h.point_format.id),
                }
                file_crs = las_crs(h, path)
        except BaseException as exc:  # noqa: BLE001 - a decoder panic is a BaseException
            if isinstance(exc, (KeyboardInterrupt, SystemExit)):
                raise
            raise ReadError(f"{path}: cannot open as LAS/LAZ ({type(exc).__name__}: "
                            f"{str(exc)[:120]})") from None
        if info["count"] == 0:
            raise InputError(f"{path}: the LAS header says the file holds no points")
        _check_las_header(path, h, info["count"])
        src = PointSource(path, "las", crs or file_crs, chunk_size=chunk_size, header_info=info)
        check_coordinates(crs or file_crs, info["bounds"], path,
                          given=crs is not None)
    else:
        dialect = sniff_xyz(path, delimiter=delimiter, decimal_comma=decimal_comma, header=header,
                            columns=columns)
        file_crs = crs_from_sidecar(path)
        src = PointSource(path, "xyz", crs or file_crs, dialect=dialect,
                          skip_invalid=skip_invalid, chunk_size=chunk_size)
    src.file_crs = file_crs  # the file's own CRS (its records or its .prj), even under -a_srs
    if t_srs:
        if src.src_crs is None:
            from ..crs import missing_crs_hint

            raise CRSError(f"{path}: -t_srs needs the source CRS and the file has none; "
                           f"{missing_crs_hint(*_first_xy(src))}")
        src.repro = reprojection(src.src_crs, t_srs)
        if src.repro.dst.is_geographic:  # a grid needs metres
            from ..crs import crs_label, utm_hint

            raise CRSError(f"-t_srs {t_srs}: {crs_label(src.repro.dst)} is a geographic CRS "
                           "(degrees) and the grids need metres: give a projected one, e.g. "
                           f"-t_srs {utm_hint(src.src_crs, *_first_xy(src))}")
    if require_crs and src.crs is None:
        from ..crs import missing_crs_hint

        x0, y0 = _first_xy(src)
        raise CRSError(f"{path}: no CRS in the file, the outputs would not be georeferenced; "
                       f"{missing_crs_hint(x0, y0)}; or put a .prj file beside it, or write "
                       "without a CRS with --allow-no-crs")
    return src


def _first_xy(src) -> tuple:
    """A point of the source (the LAS header's lower corner, or the first XYZ point), for
    messages; (None, None) when it cannot be had cheaply."""
    try:
        if src.format == "las":
            b = src.header_info["bounds"]
            return b[0], b[1]
        for chunk in src.chunks():
            if len(chunk):
                return float(chunk.x[0]), float(chunk.y[0])
    except Exception:  # noqa: BLE001 - only for a message
        pass
    return None, None


__all__ = ["DEFAULT_CHUNK", "LAS_SUFFIXES", "PointChunk", "PointSource", "PointStats",
           "XYZDialect", "las_point_count", "laz_backend", "open_points", "sniff_xyz"]
