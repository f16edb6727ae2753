"""Point reading: XYZ text (any common dialect, gzip) and LAS/LAZ 1.0-1.4, in chunks.

Memory never grows with the file: :meth:`PointSource.chunks` yields :class:`PointChunk` objects of
at most ``chunk_size`` points. Bad lines fail with the file, the line number and the line's text,
or are skipped and counted with ``skip_invalid=True``.
"""
from __future__ import annotations

import gzip
import io
import re
import sys
import warnings
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterator

import numpy as np

from ..crs import Reprojection, crs_from_sidecar, parse_crs, reprojection
from ..errors import CRSError, InputError, LidarTreesError, ReadError
from ..progress import as_progress, check_cancel

LAS_SUFFIXES = (".las", ".laz")
_INT_TOKEN = re.compile(r"^[+-]?[0-9]+$")
#: a plain ASCII decimal number (what the XYZ readers accept)
_ASCII_NUMBER = re.compile(r"[+-]?(?:(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?|nan|inf|infinity)\Z",
                           re.IGNORECASE)
DEFAULT_CHUNK = 1_000_000

#: names accepted in an XYZ header or ``columns=`` for each attribute
COLUMN_ALIASES = {
    "x": ("x", "e", "east", "easting", "//x"),
    "y": ("y", "n", "north", "northing"),
    "z": ("z", "h", "height", "elev", "elevation", "alt", "altitude"),
    "intensity": ("intensity", "i", "int"),
    "return_number": ("return_number", "return", "returnnumber", "rn", "r"),
    "number_of_returns": ("number_of_returns", "numberofreturns", "nr", "num_returns"),
    "classification": ("classification", "class", "c", "cls"),
}
_ATTR_DTYPES = {"intensity": np.uint16, "return_number": np.uint8,
                "number_of_returns": np.uint8, "classification": np.uint8}


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


@dataclass
class XYZDialect:
    """How an XYZ text file is written."""

    delimiter: str | None  # None = runs of white space
    decimal_comma: bool
    header: bool
    columns: tuple  # attribute name per column, or None for ignored columns

    def describe(self) -> str:
        d = {None: "whitespace", "\t": "tab", ",": "comma", ";": "semicolon", " ": "space"}.get(
            self.delimiter, repr(self.delimiter))
        cols = ",".join(c or "-" for c in self.columns)
        return f"delimiter={d} decimal={'comma' if self.decimal_comma else 'point'} header={self.header} columns={cols}"


def _open_text(path: Path):
    with open(path, "rb") as fh:
        magic = fh.read(2)
    if magic == b"\x1f\x8b":
        return gzip.open(path, "rt", encoding="utf-8-sig", errors="replace", newline=None)
    return open(path, "r", encoding="utf-8-sig", errors="replace", newline=None)  # BOM dropped


_DELIMS = {"tab": "\t", "\\t": "\t", "\t": "\t", "space": None, "whitespace": None, " ": None,
           "comma": ",", ",": ",", "semicolon": ";", ";": ";", "pipe": "|", "|": "|"}


def _split(line: str, delimiter):
    return line.split(delimiter) if delimiter is not None else line.split()


def _is_number(tok: str, decimal_comma: bool) -> bool:
    t = tok.strip()
    if decimal_comma:
        t = t.replace(",", ".")
    try:
        float(t)
        return True
    except ValueError:
        return False


def parse_columns(spec, ncols: int | None = None) -> tuple:
    """Map a column list (``"x,y,z,intensity,-,classification"``) to attribute names."""
    if isinstance(spec, str):
        spec = [s.strip() for s in re.split(r"[,\s]+", spec.strip()) if s.strip()]
    out = []
    for i, name in enumerate(spec):
        key = name.strip().lower()
        if key in ("-", "_", "skip", "none", ""):
            out.append(None)
            continue
        for attr, aliases in COLUMN_ALIASES.items():
            if key in aliases:
                if attr in out:
                    raise InputError(f"columns: {attr!r} given twice in {spec!r}")
                out.append(attr)
                break
        else:
            out.append(None)  # unknown column: kept out
    for need in ("x", "y", "z"):
        if need not in out:
            raise InputError(f"columns: no {need!r} column in {list(spec)!r}; "
                             "give e.g. --columns x,y,z,intensity")
    return tuple(out)


def _warn_comma_pairs(path, lines) -> None:
    """Warn when a comma-delimited file looks like decimal commas written with comma delimiters
    (``412955,63,7952505,99,25,46``): every field an integer, and either the field count varies
    between lines, or short integers (the decimals) follow long ones in columns 1 and 3."""
    rows = [[t.strip() for t in ln.split(",")] for ln in lines]
    data = [r for r in rows if r and all(_INT_TOKEN.match(t) for t in r)]
    if len(data) < max(1, len(rows) - 1):
        return
    counts = {len(r) for r in data}
    digits = lambda t: len(t.lstrip("+-"))  # noqa: E731
    pairs = [r for r in data if len(r) >= 6 and len(r) % 2 == 0 and digits(r[0]) >= 5
             and digits(r[1]) <= 4 and digits(r[3]) <= 4 and digits(r[2]) > digits(r[3])]
    if len(counts) == 1 and len(pairs) < len(data):
        return
    from ..errors import DataWarning

    r = data[0]
    looks = len(pairs) if len(counts) == 1 else sum(len(x) != len(data[0]) for x in data) + 1
    warnings.warn(DataWarning(
        f"{path}: {looks:,} of the first {len(rows):,} lines look like decimal commas written "
        f"with comma delimiters ({lines[-1][:60]!r}); they are read as x={r[0]}, y={r[1]}, "
        f"z={r[2]}. Re-export with tabs or semicolons between the fields (both are read with "
        "decimal commas), or name the columns with --columns if this is right"), stacklevel=2)


def sniff_xyz(path, *, delimiter=None, decimal_comma=None, header=None, columns=None,
              sample_lines: int = 50) -> XYZDialect:
    """Detect an XYZ file's delimiter, decimal mark, header and columns.

    Rules: a tab, then a semicolon, then white space, then a comma is the delimiter (the first
    one found in every sampled line). With a tab, semicolon or white-space delimiter, a comma
    inside numbers means a decimal comma (``412955,63<TAB>7952505,99<TAB>25,4654``). A first line
    that is not all numbers is a header whose names map columns (x, y, z, intensity,
    classification, return_number, number_of_returns). Every detected choice can be forced.
    """
    path = Path(path)
    lines = []
    try:
        with _open_text(path) as fh:
            for line in fh:
                s = line.strip()
                if not s or s.startswith("#"):
                    continue
                lines.append(s)
                if len(lines) >= sample_lines:
                    break
    except (EOFError, OSError, zlib.error, UnicodeError) as exc:
        raise ReadError(f"{path}: cannot read the text, the file is truncated or corrupt "
                        f"({type(exc).__name__}: {str(exc)[:120]})") from None
    if not lines:
        raise InputError(f"{path}: no points (the file is empty or holds only comments)")
    if delimiter is not None:
        if delimiter not in _DELIMS and len(delimiter) != 1:
            raise InputError(f"--delimiter: unknown delimiter {delimiter!r}; use tab, space, comma, "
                             "semicolon or one character")
        delim = _DELIMS.get(delimiter, delimiter)
    else:
        data = lines[1:] or lines
        if all("\t" in ln for ln in data):
            delim = "\t"
        elif all(";" in ln for ln in data):
            delim = ";"
        elif all(re.search(r"\S\s+\S", ln) for ln in data):
            delim = None
        elif all("," in ln for ln in data):
            delim = ","
        else:
            delim = None
    data_line = lines[1] if len(lines) > 1 else lines[0]
    if decimal_comma is None:
        num_comma = re.compile(r"^[+-]?\d*,\d+([eE][+-]?\d+)?$")
        decimal_comma = delim != "," and any(num_comma.match(t.strip())
                                             for ln in lines for t in _split(ln, delim))
    if decimal_comma and delim == ",":
        raise InputError(f"{path}: a decimal comma cannot be used with a comma delimiter")
    numeric = sum(1 for ln in lines
                  if sum(_is_number(t.strip(), decimal_comma) for t in _split(ln, delim)) >= 2)
    if numeric < max(1, (len(lines) - 1) / 2):
        raise InputError(f"{path}: only {numeric} of the first {len(lines)} lines hold numbers; "
                         "this is not point data (XYZ text has x y z per line)")
    if delim == "," and not decimal_comma and columns is None:
        _warn_comma_pairs(path, lines)
    first = [t.strip() for t in _split(lines[0], delim)]
    if header is None:
        header = not all(_is_number(t, decimal_comma) for t in first if t)
    ncols = len([t for t in _split(data_line, delim)])
    if columns is not None:
        cols = parse_columns(columns)
    elif header:
        try:
            cols = parse_columns(first)
        except InputError:
            cols = parse_columns(["x", "y", "z"] + ["-"] * (ncols - 3))
    else:
        if ncols < 3:
            raise InputError(f"{path}: line 1 has {ncols} column(s); need at least x, y, z "
                             f"(line: {lines[0][:80]!r}); check --delimiter")
        cols = ("x", "y", "z") + (None,) * (ncols - 3)
    return XYZDialect(delim, bool(decimal_comma), bool(header), cols)


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
        gen = self._las_chunks(progress) if self.format == "las" else self._xyz_chunks(progress)
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

    # -- LAS ---------------------------------------------------------------------------------
    def _las_chunks(self, progress):
        import laspy

        prog = as_progress(progress)
        try:
            out_hdr = 0
            with laspy.open(self.path, laz_backend=laz_backend()) as reader:
                total = max(int(reader.header.point_count), 1)
                done = 0
                dims = set(reader.header.point_format.dimension_names)
                for pts in reader.chunk_iterator(self.chunk_size):
                    check_cancel(progress)
                    x = np.asarray(pts.x, dtype=np.float64)
                    y = np.asarray(pts.y, dtype=np.float64)
                    z = np.asarray(pts.z, dtype=np.float64)
                    chunk = PointChunk(
                        x, y, z,
                        np.asarray(pts.classification, dtype=np.uint8),
                        np.asarray(pts.return_number, dtype=np.uint8),
                        np.asarray(pts.number_of_returns, dtype=np.uint8),
                        np.asarray(pts.intensity, dtype=np.uint16) if "intensity" in dims else None,
                    )
                    hb = self.header_info.get("bounds")
                    if hb is not None:
                        zr = self.header_info.get("zrange", (-np.inf, np.inf))
                        tol = 0.01
                        out_hdr += int(((x < hb[0] - tol) | (x > hb[2] + tol) | (y < hb[1] - tol)
                                        | (y > hb[3] + tol) | (z < zr[0] - tol)
                                        | (z > zr[1] + tol)).sum())
                    bad = ~(np.isfinite(x) & np.isfinite(y) & np.isfinite(z))
                    if bad.any():
                        chunk = chunk.subset(~bad)
                        self.skipped += int(bad.sum())
                    done += len(pts)
                    prog.update(done / total, "reading points")
                    yield chunk
            if out_hdr:

                from ..errors import DataWarning

                warnings.warn(DataWarning(
                    f"{self.path}: {out_hdr:,} of {done:,} points lie outside the bounds the LAS "
                    "header states; the header is stale (the points were used)"), stacklevel=2)
        except LidarTreesError:
            raise
        except Exception as exc:  # noqa: BLE001 - laspy, lazrs, struct, EOF: a broken file
            kind = "LAZ" if self.path.suffix.lower() == ".laz" else "LAS"
            raise ReadError(f"{self.path}: cannot read {kind} points, the file is truncated or "
                            f"corrupt ({type(exc).__name__}: {str(exc)[:120]})") from None

    # -- XYZ ---------------------------------------------------------------------------------
    def _xyz_chunks(self, progress):
        try:
            yield from self._xyz_chunks_raw(progress)
        except LidarTreesError:
            raise
        except (EOFError, OSError, zlib.error, UnicodeError) as exc:
            raise ReadError(f"{self.path}: cannot read the text, the file is truncated or "
                            f"corrupt ({type(exc).__name__}: {str(exc)[:120]})") from None

    def _xyz_chunks_raw(self, progress):
        prog = as_progress(progress)
        d = self.dialect
        usecols = [i for i, c in enumerate(d.columns) if c is not None]
        names = [d.columns[i] for i in usecols]
        ncol_min = max(usecols) + 1
        size = self.path.stat().st_size or 1
        with _open_text(self.path) as fh:
            raw = fh.buffer if hasattr(fh, "buffer") else None
            lineno = 0
            if d.header:
                for line in fh:
                    lineno += 1
                    if line.strip() and not line.lstrip().startswith("#"):
                        break
            while True:
                check_cancel(progress)
                block = []
                for line in fh:
                    block.append(line)
                    if len(block) >= self.chunk_size:
                        break
                if not block:
                    break
                start = lineno + 1
                lineno += len(block)
                arr = self._parse_block(block, start, usecols, ncol_min)
                try:
                    pos = raw.tell() if raw is not None else None
                    if pos is not None:
                        prog.update(min(pos / size, 1.0), "reading points")
                except (OSError, ValueError):
                    pass
                if arr.shape[0] == 0:
                    continue
                cols = {name: arr[:, j] for j, name in enumerate(names)}
                chunk = PointChunk(
                    cols["x"].astype(np.float64), cols["y"].astype(np.float64),
                    cols["z"].astype(np.float64),
                    *(cols[a].astype(_ATTR_DTYPES[a]) if a in cols else None
                      for a in ("classification", "return_number", "number_of_returns", "intensity")),
                )
                yield chunk
        prog.update(1.0, "reading points")

    def _parse_block(self, block, start, usecols, ncol_min):
        d = self.dialect
        text = "".join(block)
        if d.decimal_comma:
            text = text.replace(",", ".")
        try:
            arr = np.loadtxt(io.StringIO(text), delimiter=d.delimiter, usecols=usecols,
                             ndmin=2, comments="#", dtype=np.float64)
            if arr.shape[0] and np.isfinite(arr).all():
                return arr
        except ValueError:
            pass
        # slow path: find (and skip, or report) the bad lines one by one
        rows = []
        for k, line in enumerate(block):
            s = line.strip()
            if not s or s.startswith("#"):
                continue
            toks = _split(s.replace(",", ".") if d.decimal_comma else s, d.delimiter)
            why = None
            if len(toks) < ncol_min:
                why = f"{len(toks)} column(s), need {ncol_min}"
            else:
                try:
                    if not all(_ASCII_NUMBER.match(toks[i].strip()) for i in usecols):
                        raise ValueError  # Python's float() takes '1_000' and non-ASCII digits
                    vals = [float(toks[i]) for i in usecols]
                    if not all(np.isfinite(vals)):
                        why = "value is NaN or infinite"
                except (ValueError, IndexError):
                    why = "not a number"
            if why is None:
                rows.append(vals)
            elif self.skip_invalid:
                self.skipped += 1
            else:
                raise InputError(f"{self.path}:{start + k}: {why}: {s[:120]!r} "
                                 f"(dialect: {d.describe()}; use --skip-invalid to skip bad lines)")
        return np.asarray(rows, dtype=np.float64).reshape(-1, len(usecols))


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


def _check_las_raw(path):
    """Check the fixed LAS header fields that tell the reader how much to read (signature,
    version, header size, VLR and EVLR counts) before laspy trusts them; returns the header
    bytes."""
    import struct

    size = path.stat().st_size
    with open(path, "rb") as fh:
        b = fh.read(375)
    if len(b) < 227 or b[:4] != b"LASF":
        raise ReadError(f"{path}: not a LAS/LAZ file (no LASF signature, or shorter than a header)")
    major, minor = b[24], b[25]
    if major != 1 or minor > 4:
        raise ReadError(f"{path}: LAS version {major}.{minor} is not LAS 1.0-1.4")
    hsize, = struct.unpack_from("<H", b, 94)
    offset, nvlr = struct.unpack_from("<II", b, 96)
    if hsize < 227 or hsize > offset or offset > size:
        raise ReadError(f"{path}: the LAS header is corrupt (header size {hsize}, point data at "
                        f"byte {offset}, file of {size} bytes)")
    if nvlr * 54 > offset - hsize:
        raise ReadError(f"{path}: the LAS header lists {nvlr:,} VLRs, more than fit before the "
                        f"point data (byte {offset}); the header is corrupt")
    if minor >= 4 and len(b) >= 255:
        start, nevlr = struct.unpack_from("<QI", b, 235)
        if nevlr and (start > size or nevlr * 60 > size - start):
            raise ReadError(f"{path}: the LAS header lists {nevlr:,} extended VLRs from byte "
                            f"{start}, beyond the {size}-byte file; the header is corrupt")
    return b


def las_point_count(path) -> int:
    """Point count from a LAS/LAZ header, after :func:`_check_las_raw`."""
    import struct

    b = _check_las_raw(Path(path))
    legacy, = struct.unpack_from("<I", b, 107)
    if b[25] >= 4 and len(b) >= 255:
        n, = struct.unpack_from("<Q", b, 247)
        return int(n or legacy)
    return int(legacy)


def _check_las_header(path, h, count):
    """Refuse a LAS/LAZ header whose scale, offset, bounds or point count cannot be true."""
    import math

    size = path.stat().st_size
    scales, offsets = [float(v) for v in h.scales], [float(v) for v in h.offsets]
    if not all(math.isfinite(v) and 1e-9 <= abs(v) <= 1e3 for v in scales):
        raise ReadError(f"{path}: the LAS header has an impossible scale {scales}")
    if not all(math.isfinite(v) and abs(v) <= 1e12 for v in offsets):
        raise ReadError(f"{path}: the LAS header has an impossible offset {offsets}")
    mins, maxs = [float(v) for v in h.mins], [float(v) for v in h.maxs]
    if not all(math.isfinite(v) and abs(v) <= 1e12 for v in mins + maxs):
        raise ReadError(f"{path}: the LAS header has impossible bounds {mins} .. {maxs}")
    rec = int(h.point_format.size)
    if path.suffix.lower() == ".las":
        need = int(h.offset_to_point_data) + count * rec
        if need > size:
            raise ReadError(f"{path}: the header says {count:,} points ({need:,} bytes) but the "
                            f"file has {size:,} bytes; it is truncated or the header is wrong")
        evlr = int(getattr(h, "start_of_first_evlr", 0) or 0)
        end = evlr if evlr > int(h.offset_to_point_data) else size
        held = (end - int(h.offset_to_point_data)) // rec
        if held > count:

            from ..errors import DataWarning

            warnings.warn(DataWarning(
                f"{path}: the file holds {held:,} point records but the header says {count:,}; "
                f"only {count:,} are read"), stacklevel=2)
    elif count > 100 * size:  # LAZ: no point takes less than a bit or so
        raise ReadError(f"{path}: the header says {count:,} points, impossible in a "
                        f"{size:,}-byte LAZ file; the header is wrong")


def laz_backend():
    """LAZ decompressor for this process: laspy's default (lazrs on all cores) in a single
    process, one thread inside a Dask worker, whose siblings already use the other cores (a
    parallel decompressor per worker only oversubscribes them)."""
    if "distributed" in sys.modules:
        from distributed import get_worker

        try:
            get_worker()
        except ValueError:  # not in a worker
            return None
        import laspy

        if laspy.LazBackend.Lazrs.is_available():
            return laspy.LazBackend.Lazrs
    return None


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
            with laspy.open(path) as reader:
                h = reader.header
                info = {
                    "count": int(h.point_count),
                    "bounds": (float(h.mins[0]), float(h.mins[1]), float(h.maxs[0]), float(h.maxs[1])),
                    "zrange": (float(h.mins[2]), float(h.maxs[2])),
                    "version": str(h.version),
                    "point_format": int(h.point_format.id),
                }
                file_crs = None
                try:
                    file_crs = h.parse_crs()
                except Exception:  # noqa: BLE001 - a broken CRS VLR is reported as no CRS
                    file_crs = None
        except Exception as exc:  # noqa: BLE001
            raise ReadError(f"{path}: cannot open as LAS/LAZ ({exc})") from None
        if info["count"] == 0:
            raise InputError(f"{path}: the LAS header says the file holds no points")
        _check_las_header(path, h, info["count"])
        src = PointSource(path, "las", crs or file_crs, chunk_size=chunk_size, header_info=info)
    else:
        dialect = sniff_xyz(path, delimiter=delimiter, decimal_comma=decimal_comma, header=header,
                            columns=columns)
        src = PointSource(path, "xyz", crs or crs_from_sidecar(path), dialect=dialect,
                          skip_invalid=skip_invalid, chunk_size=chunk_size)
    if t_srs:
        if src.src_crs is None:
            raise CRSError(f"{path}: -t_srs needs the source CRS; the file has none, give -a_srs "
                           "(e.g. -a_srs EPSG:29194)")
        src.repro = reprojection(src.src_crs, t_srs)
    if require_crs and src.crs is None:
        raise CRSError(f"{path}: no CRS in the file, the outputs would not be georeferenced; give "
                       "one with -a_srs (e.g. -a_srs EPSG:29194 or -a_srs 'SAD69 24K'), put a .prj "
                       "file beside it, or write without a CRS with --allow-no-crs")
    return src
