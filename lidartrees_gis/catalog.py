"""Many point files as one acquisition, cut into tiles with buffers (lidR's LAScatalog idea).

* :func:`expand_inputs` — files, folders, globs, text lists (one path a line), virtual point
  clouds (``.vpc``, the STAC ItemCollection QGIS and PDAL write) and Entwine Point Tile indexes
  (``ept.json``, what QGIS 3.22 builds for a loaded point cloud) to a list of files;
* :class:`Catalog` — the files with their bounds, point counts and CRS (from LAS headers; XYZ
  files are scanned once);
* :func:`make_tiles` — square tiles aligned to multiples of the tile size, each with a core (the
  trees whose top falls in it belong to it) and a buffer around it;
* :class:`TileSource` — the points of every file that fall in one buffered tile, read chunk by
  chunk with the class filter, with the interface of :class:`~lidartrees_gis.io.points.PointSource`
  that :func:`~lidartrees_gis.pipeline.compute_surfaces` needs.
"""
from __future__ import annotations

import glob
import json
import math
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .errors import CRSError, InputError, ReadError
from .io.points import LAS_SUFFIXES, PointChunk

POINT_SUFFIXES = (".las", ".laz", ".xyz", ".txt", ".csv", ".pts", ".gz")


def _vpc_files(path: Path) -> list:
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise ReadError(f"{path}: cannot read as a virtual point cloud (JSON): {exc}") from None
    out = []
    for feat in doc.get("features", []):
        href = (feat.get("assets", {}).get("data", {}) or {}).get("href")
        if not href:
            continue
        p = Path(href)
        out.append(p if p.is_absolute() else (path.parent / p).resolve())
    if not out:
        raise InputError(f"{path}: the virtual point cloud lists no files (features[].assets.data.href)")
    return out


def is_ept(path) -> bool:
    """True for an Entwine Point Tile index (``ept.json``), what QGIS makes of a point cloud."""
    return Path(str(path)).name.lower() == "ept.json"


def _ept_doc(path: Path) -> dict:
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise ReadError(f"{path}: cannot read as an Entwine Point Tile index (JSON): {exc}") from None
    if not isinstance(doc, dict) or "schema" not in doc:
        raise InputError(f"{path}: not an Entwine Point Tile index (no schema)")
    return doc


def _ept_files(path: Path) -> list:
    """The data files of an EPT index: every point is in exactly one node, so all the nodes
    together are the whole cloud."""
    doc = _ept_doc(path)
    if doc.get("dataType") != "laszip":
        raise InputError(f"{path}: EPT data type {doc.get('dataType')!r} is not read; only "
                         "'laszip' (LAZ nodes) is. Use the original LAS/LAZ file instead")
    files = sorted((path.parent / "ept-data").glob("*.laz"))
    if not files:
        raise InputError(f"{path}: the EPT index has no data files in ept-data/")
    return files


def ept_crs(path):
    """The CRS an EPT index states (``srs.wkt`` or ``srs.authority:horizontal``), or None."""
    srs = _ept_doc(Path(str(path))).get("srs") or {}
    if srs.get("wkt"):
        return srs["wkt"]
    if srs.get("authority") and srs.get("horizontal"):
        return f"{srs['authority']}:{srs['horizontal']}"
    return None


def expand_inputs(inputs) -> list:
    """Point files named by ``inputs`` (a path or a list of them): files, folders (their point
    files), glob patterns, ``.txt``/``.lst`` lists of paths (one per line, relative to the
    list), ``.vpc`` virtual point clouds and ``ept.json`` Entwine Point Tile indexes (their
    LAZ nodes). Order is kept; duplicates are dropped."""
    items = [inputs] if isinstance(inputs, (str, Path)) else list(inputs)
    out = []
    for it in items:
        s = str(it)
        p = Path(s)
        if any(ch in s for ch in "*?[") and not p.exists():
            hits = sorted(glob.glob(s))
            if not hits:
                raise ReadError(f"{s}: the pattern matches no file")
            out += [Path(h) for h in hits]
        elif p.is_dir():
            found = sorted(q for q in p.iterdir() if q.suffix.lower() in POINT_SUFFIXES and q.is_file())
            if not found:
                raise ReadError(f"{p}: the folder holds no point file ({', '.join(POINT_SUFFIXES)})")
            out += found
        elif p.suffix.lower() == ".vpc":
            out += _vpc_files(p)
        elif is_ept(p) and p.is_file():
            out += _ept_files(p)
        elif p.suffix.lower() in (".lst",) or (p.suffix.lower() == ".txt" and _is_list(p)):
            base = p.parent
            for line in p.read_text(encoding="utf-8").splitlines():
                line = line.strip()
                if line and not line.startswith("#"):
                    q = Path(line)
                    out.append(q if q.is_absolute() else base / q)
        else:
            out.append(p)
    seen, uniq = set(), []
    for q in out:
        k = str(Path(q).resolve())
        if k not in seen:
            seen.add(k)
            uniq.append(Path(q))
    for q in uniq:
        if not q.exists():
            raise ReadError(f"{q}: no such file")
    return uniq


def _is_list(p: Path) -> bool:
    """A .txt file whose first non-empty line names an existing point file."""
    try:
        with open(p, encoding="utf-8", errors="replace") as fh:
            for line in fh:
                line = line.strip()
                if line:
                    q = Path(line)
                    q = q if q.is_absolute() else p.parent / q
                    return q.suffix.lower() in POINT_SUFFIXES and q.exists()
    except OSError:
        return False
    return False


@dataclass
class Catalog:
    """Point files with their XY bounds, point counts and one CRS."""

    files: list
    bounds: list  # per file (xmin, ymin, xmax, ymax)
    counts: list
    crs: object = None
    read_kw: dict = field(default_factory=dict)

    @classmethod
    def open(cls, inputs, *, a_srs=None, **read_kw) -> "Catalog":
        """Read the headers (LAS) or scan the files (XYZ) named by ``inputs``."""
        from .io.points import open_points

        files = expand_inputs(inputs)
        if a_srs is None:  # EPT nodes often hold no CRS; the index states it
            items = [inputs] if isinstance(inputs, (str, Path)) else list(inputs)
            a_srs = next((ept_crs(i) for i in items if is_ept(i) and Path(str(i)).is_file()), None)
        bounds, counts, crs = [], [], None
        for f in files:
            src = open_points(f, a_srs=a_srs, **read_kw)
            hb = src.header_bounds() if src.format == "las" else None
            if hb is not None and src.count_hint:
                bounds.append(tuple(hb))
                counts.append(int(src.count_hint))
            else:
                st = src.scan()
                bounds.append(tuple(st.bounds))
                counts.append(int(st.count))
            if src.crs is not None:
                if crs is None:
                    crs = src.crs
                elif not crs.equals(src.crs, ignore_axis_order=True):
                    raise CRSError(f"{f}: CRS {src.crs.to_string()} differs from the other files' "
                                   f"{crs.to_string()}; reproject them first or give -a_srs")
        return cls(files, bounds, counts, crs, {"a_srs": a_srs, **read_kw})

    @property
    def extent(self) -> tuple:
        b = np.asarray(self.bounds, float)
        return (float(b[:, 0].min()), float(b[:, 1].min()), float(b[:, 2].max()), float(b[:, 3].max()))

    @property
    def count(self) -> int:
        return int(sum(self.counts))

    @property
    def area(self) -> float:
        """Covered area (m²): the sum of the files' bounding boxes (tiles do not overlap)."""
        return float(sum(max(b[2] - b[0], 0) * max(b[3] - b[1], 0) for b in self.bounds))

    def files_for(self, box) -> list:
        """Files whose bounds intersect ``box`` (xmin, ymin, xmax, ymax)."""
        x0, y0, x1, y1 = box
        return [f for f, b in zip(self.files, self.bounds)
                if b[0] <= x1 and b[2] >= x0 and b[1] <= y1 and b[3] >= y0]


@dataclass(frozen=True)
class Tile:
    """One tile: ``core`` (trees whose top is in it belong to it, half-open on the east and
    north edges) and ``box`` (core plus buffer, clipped to the data)."""

    index: tuple
    core: tuple
    box: tuple

    def in_core(self, x, y):
        x0, y0, x1, y1 = self.core
        x = np.asarray(x)
        y = np.asarray(y)
        return (x >= x0) & (x < x1) & (y >= y0) & (y < y1)


def make_tiles(extent, tile_size: float, buffer: float) -> list:
    """Tiles of ``tile_size`` m aligned to multiples of it, covering ``extent``; the last row and
    column also hold points exactly on the extent's east/north edge."""
    if not (tile_size > 0 and buffer >= 0):
        raise InputError(f"-tile_size must be > 0 and -buffer >= 0 (got {tile_size}, {buffer})")
    x0, y0, x1, y1 = extent
    if math.isinf(tile_size):  # one tile: the whole area
        return [Tile((0, 0), (x0, y0, x1 + 1e-6, y1 + 1e-6), (x0, y0, x1, y1))]
    i0, i1 = math.floor(x0 / tile_size), math.floor(x1 / tile_size)
    j0, j1 = math.floor(y0 / tile_size), math.floor(y1 / tile_size)
    if (i1 - i0 + 1) * (j1 - j0 + 1) > 1_000_000:
        raise InputError(f"-tile_size {tile_size} m makes more than a million tiles over "
                         f"{x1 - x0:.0f} x {y1 - y0:.0f} m")
    tiles = []
    eps = 1e-6
    for j in range(j0, j1 + 1):
        for i in range(i0, i1 + 1):
            cx0, cy0 = i * tile_size, j * tile_size
            cx1, cy1 = cx0 + tile_size, cy0 + tile_size
            if i == i1:
                cx1 = max(cx1, x1 + eps)
            if j == j1:
                cy1 = max(cy1, y1 + eps)
            box = (max(cx0 - buffer, x0), max(cy0 - buffer, y0), min(cx1 + buffer, x1),
                   min(cy1 + buffer, y1))
            if box[2] <= box[0] or box[3] <= box[1]:
                continue
            tiles.append(Tile((i, j), (cx0, cy0, cx1, cy1), box))
    return tiles


#: decompressed points kept per process (bytes), so that the neighbouring tiles whose buffers
#: reach into a file do not decompress it again; files over half of it are never kept
READ_CACHE_BYTES = int(float(os.environ.get("LIDARTREES_READ_CACHE_MB", 128)) * 2 ** 20)


class ReadCache:
    """The points of recently read files (after the class filter), least recently used dropped
    first, at most ``budget`` bytes. Keyed by path, size and modification time and by how the
    file is read, so a changed file is read again."""

    def __init__(self, budget: int = READ_CACHE_BYTES):
        from collections import OrderedDict

        import threading

        self.budget = int(budget)
        self.items: "OrderedDict" = OrderedDict()
        self.nbytes = 0
        self.hits = self.misses = 0
        self._lock = threading.Lock()  # shared by a process's worker threads

    @staticmethod
    def key(path, read_kw: dict, drop, keep):
        st = Path(path).stat()
        return (str(Path(path).resolve()), st.st_size, st.st_mtime_ns,
                repr(sorted(read_kw.items())), tuple(sorted(drop)),
                None if keep is None else tuple(sorted(keep)))

    def get(self, key):
        with self._lock:
            hit = self.items.get(key)
            if hit is None:
                self.misses += 1
                return None
            self.hits += 1
            self.items.move_to_end(key)
            return hit[0], hit[1]

    def put(self, key, chunks: list, dropped: dict) -> None:
        size = sum(_chunk_nbytes(c) for c in chunks)
        with self._lock:
            if size > self.budget // 2 or key in self.items:
                return
            self.items[key] = (chunks, dict(dropped), size)
            self.nbytes += size
            while self.nbytes > self.budget and self.items:
                _, (_, _, n) = self.items.popitem(last=False)
                self.nbytes -= n

    def clear(self) -> None:
        with self._lock:
            self.items.clear()
            self.nbytes = 0


def _chunk_nbytes(c: PointChunk) -> int:
    arrays = [c.x, c.y, c.z, c.classification, c.return_number, c.number_of_returns, c.intensity,
              *c.extra.values()]
    return int(sum(a.nbytes for a in arrays if a is not None))


#: this process's cache (each Dask worker has its own)
READ_CACHE = ReadCache()


class TileSource:
    """The points of a catalog inside one box, for :func:`~lidartrees_gis.pipeline.compute_surfaces`.

    Reads every file that intersects the box chunk by chunk and keeps the points inside it;
    the class filter of :meth:`set_class_filter` applies.
    """

    format = "tile"
    repro = None
    skipped = 0

    def __init__(self, catalog: Catalog, box, *, chunk_size: int = 1_000_000):
        self.catalog = catalog
        self.box = tuple(float(v) for v in box)
        self.files = catalog.files_for(self.box)
        self.path = Path(f"tile {self.box[0]:.0f},{self.box[1]:.0f}")
        self.crs = catalog.crs
        self.chunk_size = chunk_size
        self.drop_classes = frozenset()
        self.keep_classes = None
        self.dropped: dict = {}

    def set_class_filter(self, drop=None, keep=None) -> None:
        self.drop_classes = frozenset(int(c) for c in (drop or ()))
        self.keep_classes = None if keep is None else frozenset(int(c) for c in keep)

    def header_bounds(self):
        return self.box

    @property
    def count_hint(self):
        return None

    def chunks(self, progress=None):
        from .io.points import open_points

        x0, y0, x1, y1 = self.box
        self.dropped = {}
        cache = READ_CACHE
        for f in self.files:
            kw = {k: v for k, v in self.catalog.read_kw.items() if v is not None}
            try:
                key = cache.key(f, kw, self.drop_classes, self.keep_classes)
            except OSError:  # gone: open_points says so
                key = None
            hit = None if key is None else cache.get(key)
            kept, kept_bytes = None, 0  # what a first read keeps for the cache
            if hit is not None:
                chunks, dropped = hit
            else:
                src = open_points(f, chunk_size=self.chunk_size, **kw)
                src.set_class_filter(self.drop_classes, None if self.keep_classes is None
                                     else sorted(self.keep_classes))
                chunks = src.chunks()
                if key is not None:
                    kept = []
            for c in chunks:
                if kept is not None:
                    # own arrays: a view would keep the reader's whole point record buffer
                    kept.append(c.subset(np.ones(len(c), bool)))
                    kept_bytes += _chunk_nbytes(kept[-1])
                    if kept_bytes > cache.budget // 2:  # too big to keep anyway
                        kept = None
                m = (c.x >= x0) & (c.x <= x1) & (c.y >= y0) & (c.y <= y1)
                if m.any():
                    yield c.subset(m)  # a copy: what is kept is never handed out
            if hit is None:
                dropped = src.dropped
                if kept is not None:
                    cache.put(key, kept, dropped)
            for k, v in dropped.items():
                self.dropped[k] = self.dropped.get(k, 0) + v

    def read_all(self, progress=None) -> PointChunk:
        return PointChunk.concat(self.chunks(progress))

    def scan(self, progress=None):
        raise InputError("a tile is scanned through its catalog")


def is_catalog_input(inputs) -> bool:
    """True when ``inputs`` names more than one file or a folder, glob, list or .vpc."""
    if not isinstance(inputs, (str, Path)):
        return len(list(inputs)) > 1 or any(is_catalog_input(i) for i in inputs)
    s = str(inputs)
    p = Path(s)
    if p.is_dir() or p.suffix.lower() in (".vpc", ".lst") or is_ept(p):
        return True
    if any(ch in s for ch in "*?[") and not p.exists():
        return True
    return p.suffix.lower() == ".txt" and p.exists() and _is_list(p)


__all__ = ["Catalog", "ReadCache", "READ_CACHE", "Tile", "TileSource", "expand_inputs", "is_ept", "ept_crs", "make_tiles", "is_catalog_input",
           "LAS_SUFFIXES"]
