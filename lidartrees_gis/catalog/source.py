"""The points of a catalog inside one box, read file by file with a bounded cache of
decompressed files, behind the interface of :class:`~lidartrees_gis.io.points.PointSource`
that the surfaces need."""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..io.points import PointChunk
from .catalog import FAR_CHECK_POINTS, Catalog, far_points


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
    def key(path, read):
        """The cache key of a file read with :class:`~lidartrees_gis.io.options.ReadOptions`
        ``read``."""
        st = Path(path).stat()
        return (str(Path(path).resolve()), st.st_size, st.st_mtime_ns, repr(read))

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

#: the environment variable naming the folder of a run's :class:`SharedReadCache` (set by
#: :class:`~lidartrees_gis.catalog.runner.TileRunner` for the run's local processes)
SHARED_CACHE_ENV = "LIDARTREES_SHARED_READ_CACHE"
#: ... and whether the run's processes leave their decompressed files in it ("1": several
#: processes read the same files; a run in one process keeps them in :data:`READ_CACHE` only:
#: at 16 M points on one worker the folder took 470 MB of writes and saved no time)
SHARED_POINTS_ENV = "LIDARTREES_SHARED_READ_POINTS"
#: bytes of decompressed points a run keeps in its shared folder (temporary files: the
#: system's page cache holds them, and may write them out)
SHARED_CACHE_BYTES = int(float(os.environ.get("LIDARTREES_SHARED_CACHE_MB", 1024)) * 2 ** 20)
#: the file names of :class:`SharedReadCache`'s values kept for one reader
KEEP_PREFIX = "keep-"


class SharedReadCache:
    """Decompressed files shared by the processes of one run on one machine (the calling
    process and its local Dask workers), as ``.npz`` files in a temporary folder
    (:mod:`lidartrees_gis.io.store`: arrays with a JSON description, read without pickle and
    validated, so a file planted there cannot run code and a foreign one is a miss): a file whose
    points two workers need (tiles on either side of the line between their runs of tiles)
    is decompressed once. At most ``budget`` bytes; the oldest files go first. Values kept for
    one later reader (``keep``: plantation mode's tile surfaces between its two passes, taken
    by :meth:`take`) go after every decompressed file, the newest first, so that a second pass
    in the first one's order finds the first tiles' values. Every failure (the folder gone, a
    file another process is replacing or dropping) is a miss."""

    def __init__(self, folder, budget: int = SHARED_CACHE_BYTES):
        self.folder = str(folder)
        self.budget = int(budget)

    def _path(self, key, keep: bool = False) -> str:
        import hashlib

        name = hashlib.sha1(repr(key).encode()).hexdigest() + ".npz"
        return os.path.join(self.folder, KEEP_PREFIX + name if keep else name)

    def get(self, key, keep: bool = False):
        from ..io.store import StoreError, load

        def check(value, meta):  # the file of this key, holding what put gave
            if meta.get("key") != repr(key) or (not keep and not _is_chunks(value)):
                raise StoreError("another key")

        try:
            return load(self._path(key, keep), check)[0]
        except (OSError, StoreError, RecursionError, MemoryError):
            return None

    def take(self, key):
        """The value :meth:`put_value` kept (``keep=True``) under ``key``, removed from the
        folder (its one reader has it), or None."""
        value = self.get(key, keep=True)
        try:
            os.unlink(self._path(key, keep=True))
        except OSError:
            pass
        return value

    def put(self, key, chunks: list, dropped: dict) -> None:
        """A decompressed file: its chunks and the points dropped per class."""
        self.put_value(key, (chunks, dict(dropped)))

    def put_value(self, key, value, keep: bool = False) -> None:
        """Any ``value`` :mod:`~lidartrees_gis.io.store` keeps (arrays, point chunks, grids and
        their containers) under ``key``; ``keep``: for one later reader (:meth:`take`),
        dropped after every other file when the folder is over its budget."""
        from ..io.store import save

        try:
            save(self._path(key, keep), value, {"key": repr(key)})  # atomic, as a rename
            self._trim()
        except (OSError, TypeError):  # a disk that filled up: no half-written file left
            pass

    def _trim(self) -> None:
        files = []
        for e in os.scandir(self.folder):
            if e.name.endswith(".npz"):
                try:
                    st = e.stat()
                except OSError:
                    continue
                keep = e.name.startswith(KEEP_PREFIX)  # after the others, newest first
                files.append((keep, -st.st_mtime_ns if keep else st.st_mtime_ns, st.st_size,
                              e.path))
        total = sum(f[2] for f in files)
        for _, _, size, path in sorted(files):
            if total <= self.budget:
                break
            try:
                os.unlink(path)
            except OSError:
                pass
            total -= size


def _is_chunks(value) -> bool:
    """A decompressed file as :meth:`SharedReadCache.put` keeps it: ``(chunks, dropped)``."""
    return isinstance(value, tuple) and len(value) == 2 and isinstance(value[0], list) and \
        isinstance(value[1], dict)


def shared_cache() -> SharedReadCache | None:
    """This run's shared cache (None outside a run, or when its folder is gone)."""
    folder = os.environ.get(SHARED_CACHE_ENV)
    return SharedReadCache(folder) if folder and os.path.isdir(folder) else None


class TileSource:
    """The points of a catalog inside one box, for
    :func:`~lidartrees_gis.als.surfaces.compute_surfaces`.

    Reads every file that intersects the box chunk by chunk and keeps the points inside it;
    the catalog's class filter (``read.drop_class``, ``read.keep_class``) applies.
    """

    format = "tile"
    repro = None
    skipped = 0

    def __init__(self, catalog: Catalog, box, *, chunk_size: int = 1_000_000,
                 cache: bool = True):
        self.catalog = catalog
        self.cache = cache  # False: read the files without the read caches
        self.box = tuple(float(v) for v in box)
        self.files = catalog.files_for(self.box)
        self.path = Path(f"tile {self.box[0]:.0f},{self.box[1]:.0f}") if len(catalog.files) > 1 \
            else catalog.path
        self.crs = catalog.crs
        self.chunk_size = chunk_size
        self.dropped: dict = {}

    def header_bounds(self):
        return self.box

    @property
    def count_hint(self):
        return None

    def chunks(self, progress=None):
        from ..progress import SubProgress, as_progress

        x0, y0, x1, y1 = self.box
        self.dropped = {}
        cache, read, shared = READ_CACHE, self.catalog.read, shared_cache()
        if not self.cache:
            cache, shared = ReadCache(0), None
        prog, nf = as_progress(progress), max(len(self.files), 1)
        for k, f in enumerate(self.files):
            try:
                key = cache.key(f, read)
            except OSError:  # gone: open_points says so
                key = None
            hit = None if key is None else cache.get(key)
            if hit is None and key is not None and shared is not None:
                hit = shared.get(key)  # decompressed by another process of the run
                if hit is not None:
                    cache.put(key, *hit)
            kept, kept_bytes = None, 0  # what a first read keeps for the cache
            if hit is not None:
                chunks, dropped = hit
            else:
                src = read.open(f, chunk_size=self.chunk_size)
                chunks = src.chunks(SubProgress(prog, k / nf, (k + 1) / nf))
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
                if self.catalog.keep_box is not None:  # stray points far from the rest
                    m &= self.catalog.keeps(c.x, c.y)
                if m.any():
                    yield c.subset(m)  # a copy: what is kept is never handed out
            if hit is None:
                dropped = src.dropped
                if kept is not None:
                    cache.put(key, kept, dropped)
                    if shared is not None and os.environ.get(SHARED_POINTS_ENV) == "1":
                        shared.put(key, kept, dropped)
            for k, v in dropped.items():
                self.dropped[k] = self.dropped.get(k, 0) + v

    def read_all(self, progress=None) -> PointChunk:
        return PointChunk.concat(self.chunks(progress))

    def scan(self, progress=None):
        raise InputError("a tile is scanned through its catalog")


def drop_far_points(cat: Catalog) -> int:
    """Find the few points far from all the others (:func:`far_points`; a typo in a
    coordinate, a return from a bird or an aircraft's other strip) and leave them out of
    everything: the area's extent, its tiles and every file's points become those of the
    others, so they change neither the cell size nor the tiles nor the trees. One warning
    names them; their count is in ``cat.far`` (and each command's summary). Looked for
    when the area holds at most :data:`FAR_CHECK_POINTS` points (one read of them all)."""
    if cat.far_checked or not 10 <= cat.count <= FAR_CHECK_POINTS:
        return cat.far
    cat.far_checked = True
    from ..io.las import one_thread

    # this process may fork its workers next: LAZ is decoded on one thread (a forked child
    # hangs on a decoder's thread pool), and not kept (the sequential decoder reads files the
    # parallel one refuses, whose refusal must not depend on this look)
    laz = any(str(f).lower().endswith(".laz") for f in cat.files)
    xs, ys = [], []
    from ..errors import Cancelled, LidarTreesError

    try:
        with one_thread():
            for c in TileSource(cat, cat.extent, cache=not laz).chunks():
                xs.append(np.asarray(c.x, float))
                ys.append(np.asarray(c.y, float))
    except Cancelled:
        raise
    except LidarTreesError:
        # a file that cannot be read is not refused by this look: its tiles fail (and are
        # named, or set aside with -on_error skip) as they would without it
        return 0
    if not xs:
        return 0
    x, y = np.concatenate(xs), np.concatenate(ys)
    far, rest = far_points(x, y)
    n = int(far.sum())
    if not n:
        return 0
    cat.keep_box, cat.far = rest, n
    cat.bounds = [(max(b[0], rest[0]), max(b[1], rest[1]), min(b[2], rest[2]),
                   min(b[3], rest[3])) for b in cat.bounds]
    import warnings

    from ..errors import DataWarning

    x0, y0, x1, y1 = (min(float(x.min()), rest[0]), min(float(y.min()), rest[1]),
                      max(float(x.max()), rest[2]), max(float(y.max()), rest[3]))
    where = ", ".join(f"({a:.2f}, {b:.2f})" for a, b in zip(x[far][:3], y[far][:3]))
    warnings.warn(DataWarning(
        f"{cat.label()}: {n:,} point(s) lie far from the other {x.size - n:,} ({where}"
        f"{' ...' if n > 3 else ''}) and are left out of every output: they would stretch "
        f"the {rest[2] - rest[0]:,.0f} x {rest[3] - rest[1]:,.0f} m of the others to "
        f"{x1 - x0:,.0f} x {y1 - y0:,.0f} m"), stacklevel=3)
    return n
