"""Many point files as one acquisition, cut into tiles with buffers (lidR's LAScatalog idea).

* :class:`Catalog` — the files with their bounds, point counts and CRS (from LAS headers; XYZ
  files are scanned once); a single file is a catalog of one;
* :class:`Tile` and :func:`make_tiles` — square tiles aligned to multiples of the tile size,
  each with a core (the trees whose top falls in it belong to it) and a buffer around it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..crs import check_coordinates, crs_label
from ..bounds import check_fields
from ..errors import CRSError, InputError
from ..io.options import ReadOptions
from .inputs import ept_crs, expand_inputs, is_ept


@dataclass
class Catalog:
    """Point files with their XY bounds, point counts, one CRS and how they are read.

    A single file is a catalog of one: every chain plans, tiles and merges the same way for
    one file and for a whole flight.
    """

    files: list
    bounds: list  # per file (xmin, ymin, xmax, ymax), in the output CRS
    counts: list
    crs: object = None
    read: ReadOptions = field(default_factory=ReadOptions)
    skipped: int = 0  # malformed XYZ lines skipped (with read.skip_invalid)
    repro: object = None  # the -t_srs reprojection (of the first file), or None
    repros: list = field(default_factory=list)  # each file's -t_srs reprojection (or None)
    keep_box: tuple | None = None  # points outside it are stray and left out (drop_far_points)
    far: int = 0  # the stray points left out
    far_checked: bool = False  # whether the points were looked at for stray ones

    @classmethod
    def open(cls, inputs, read: ReadOptions | None = None) -> "Catalog":
        """Read the headers (LAS) or scan the files (XYZ) named by ``inputs`` (a file, a folder,
        a glob, a list or a .vpc, see :func:`~lidartrees_gis.catalog.inputs.expand_inputs`)."""
        read = read or ReadOptions()
        files = expand_inputs(inputs)
        if read.a_srs is None:  # EPT nodes often hold no CRS; the index states it
            items = [inputs] if isinstance(inputs, (str, Path)) else list(inputs)
            a_srs = next((ept_crs(i) for i in items if is_ept(i) and Path(str(i)).is_file()), None)
            if a_srs is not None:
                read = read.with_crs(a_srs)
        bounds, counts, crs, skipped, repro, repros = [], [], None, 0, None, []
        overridden = []  # the files' own CRSs that -a_srs replaces
        for f in files:
            src = read.open(f)
            hb = src.header_bounds() if src.format == "las" else None
            if hb is not None and src.count_hint:
                bounds.append(tuple(hb))
                counts.append(int(src.count_hint))
            else:
                st = src.scan()
                bounds.append(tuple(st.bounds))
                counts.append(int(st.count))
                skipped += int(st.skipped or 0)
                if src.format != "las" and src.repro is None:  # LAS: checked on its header
                    check_coordinates(src.crs, st.bounds, f, given=src.file_crs is None)
            if read.a_srs is not None and src.file_crs is not None \
                    and not src.file_crs.equals(src.src_crs, ignore_axis_order=True):
                overridden.append(crs_label(src.file_crs))
            repro = repro or src.repro
            repros.append(src.repro)
            if src.crs is not None:
                if crs is None:
                    crs = src.crs
                elif not crs.equals(src.crs, ignore_axis_order=True):
                    raise CRSError(
                        f"{f}: CRS {crs_label(src.crs)} differs from the other files' "
                        f"{crs_label(crs)}; give -t_srs (e.g. -t_srs {crs_label(crs).split()[0]}) "
                        "to transform every file from its own CRS into one (-a_srs would only "
                        "relabel them and misplace the data)")
        if overridden:
            warn_overridden(overridden, len(files), crs)
        return cls(files, bounds, counts, crs, read, skipped, repro, repros)

    def header_bounds(self):
        """The area's extent (for :func:`lidartrees_gis.grid.resolve_resolution`)."""
        return self.extent

    @property
    def count_hint(self) -> int:
        """The points of the area less the stray ones left out."""
        return self.count - self.far

    def keeps(self, x, y) -> np.ndarray:
        """Which of the points ``(x, y)`` are not stray (all of them when none was found)."""
        x, y = np.asarray(x), np.asarray(y)
        if self.keep_box is None:
            return np.ones(x.shape, bool)
        x0, y0, x1, y1 = self.keep_box
        return (x >= x0) & (x <= x1) & (y >= y0) & (y <= y1)


    @property
    def path(self) -> Path:
        """The file, or the first file of several (for messages)."""
        return Path(self.files[0])

    def label(self) -> str:
        """The input in words: the file, or the count of files."""
        return str(self.files[0]) if len(self.files) == 1 else f"{len(self.files)} files"

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

    def clip(self, box, buffer: float = 0.0) -> tuple:
        """``box`` grown by ``buffer`` on every side and clipped to the area's extent."""
        e = self.extent
        return (max(box[0] - buffer, e[0]), max(box[1] - buffer, e[1]),
                min(box[2] + buffer, e[2]), min(box[3] + buffer, e[3]))

    def points_in(self, box) -> float:
        """An estimate of the points inside ``box``: each file's count times the share of its
        bounding box inside ``box`` (a file of no area counts whole when it meets the box)."""
        x0, y0, x1, y1 = box
        b = np.asarray(self.bounds, float).reshape(-1, 4)
        w = np.minimum(b[:, 2], x1) - np.maximum(b[:, 0], x0)
        h = np.minimum(b[:, 3], y1) - np.maximum(b[:, 1], y0)
        full = (b[:, 2] - b[:, 0]) * (b[:, 3] - b[:, 1])
        share = np.where(full > 0, w * h / np.where(full > 0, full, 1.0), 1.0)
        meets = (w >= 0) & (h >= 0)
        return float(np.sum(np.asarray(self.counts, float)[meets] * share[meets]))

    def files_for(self, box) -> list:
        """Files whose bounds intersect ``box`` (xmin, ymin, xmax, ymax)."""
        x0, y0, x1, y1 = box
        return [f for f, b in zip(self.files, self.bounds)
                if b[0] <= x1 and b[2] >= x0 and b[1] <= y1 and b[3] >= y0]


#: an area of at most this many points is read once at opening for points far from the rest
FAR_CHECK_POINTS = 5_000_000


def far_points(x, y) -> tuple:
    """``(mask, bounds of the others)`` of points far from the bulk: beyond the 1 and 99 %
    quantiles of x or y by more than their span (at least 100 m), when they are at most 1 % of
    the points; else an empty mask and None."""
    far = np.zeros(x.size, bool)
    for v in (x, y):
        lo, hi = np.quantile(v, [0.01, 0.99])
        pad = max(hi - lo, 100.0)
        far |= (v < lo - pad) | (v > hi + pad)
    if not far.any() or far.sum() > 0.01 * x.size:
        return np.zeros(x.size, bool), None
    k = ~far
    return far, (float(x[k].min()), float(y[k].min()), float(x[k].max()), float(y[k].max()))


def warn_overridden(labels: list, files: int, crs) -> None:
    """One warning that -a_srs replaces the CRS the files carry (``labels``: each overridden
    file's own CRS): how many files and which CRSs."""
    import warnings

    from ..errors import DataWarning

    kinds = sorted(set(labels))
    warnings.warn(DataWarning(
        f"-a_srs {crs_label(crs)} overrides the CRS of {len(labels)} of {files} file(s), which "
        f"carry {'; '.join(kinds)}: their coordinates are relabelled, not transformed (give "
        "-t_srs instead of -a_srs to transform them)"), stacklevel=3)


#: the largest tile side given (m); none (inf) is one tile
MAX_TILE_SIDE = 1e5


@dataclass(frozen=True)
class TilingOptions:
    """How an area is cut into tiles and where they run.

    Attributes
    ----------
    tile_size : float, optional
        Tile side (m); None: automatic (one tile for a small area, else from the point density,
        see :func:`lidartrees_gis.als.area.auto_tile_size`); ``inf``: one tile.
    buffer : float, optional
        Buffer around each tile (m); None: the command's default.
    workers : int, optional
        Worker processes of the local Dask cluster; None: all cores (this process for a small
        area); 1: this process.
    scheduler : str, optional
        Address of an existing Dask scheduler to run the tiles on.
    any_size : bool
        Accept any given tile size (tests of the tiling on small files); by default a tile under
        20 cells or twice the buffer is refused (:func:`lidartrees_gis.als.area.check_tile_size`).
    on_error : {'stop', 'skip'}
        A tile that fails (twice on Dask) stops the run, leaving no output (``stop``), or is
        left out while the others are written and the run then fails naming it (``skip``).
    resume : bool
        Continue a killed run from the tiles it kept beside its output.
    """

    tile_size: float | None = None
    buffer: float | None = None
    workers: int | None = None
    scheduler: str | None = None
    any_size: bool = False
    on_error: str = "stop"
    resume: bool = False

    def __post_init__(self):
        check_fields(self, {"buffer": "m"}, skip=("tile_size",))  # tile_size: inf = one tile
        ts = self.tile_size
        if isinstance(ts, str):
            low = ts.strip().lower()
            if low in ("", "auto"):
                ts = None
            elif low in ("none", "inf", "0"):
                ts = math.inf
            else:
                try:
                    ts = float(low)
                except ValueError:
                    raise InputError(f"-tile_size: expected metres, auto or none, got {ts!r}") from None
        if ts is not None and not ts > 0:
            raise InputError(f"-tile_size must be > 0 m, got {self.tile_size!r}")
        if ts is not None and math.isfinite(ts) and ts > MAX_TILE_SIDE:
            raise InputError(f"-tile_size {ts:g} m is over {MAX_TILE_SIDE:g} m; give none for "
                             "one tile")
        object.__setattr__(self, "tile_size", None if ts is None else float(ts))
        for k in ("buffer", "workers"):
            v = getattr(self, k)
            if v is not None and not isinstance(v, (int, float)):
                try:
                    v = float(v)
                except ValueError:
                    raise InputError(f"-{k}: expected a number, got {v!r}") from None
            object.__setattr__(self, k, v)
        if self.buffer is not None and not self.buffer >= 0:
            raise InputError(f"-buffer must be >= 0 m, got {self.buffer!r}")
        if self.workers is not None:
            if not self.workers >= 1:
                raise InputError(f"-workers must be >= 1, got {self.workers!r}")
            object.__setattr__(self, "workers", int(self.workers))
        object.__setattr__(self, "scheduler", self.scheduler or None)
        on_error = (self.on_error or "stop").strip().lower()
        if on_error not in ("stop", "skip"):
            raise InputError(f"-on_error: expected stop or skip, got {self.on_error!r}")
        object.__setattr__(self, "on_error", on_error)


@dataclass(frozen=True)
class Tile:
    """One tile: ``core`` (trees whose top is in it belong to it, half-open on the east and
    north edges) and ``box`` (core plus buffer, clipped to the data)."""

    index: tuple
    core: tuple
    box: tuple

    def in_core(self, x, y, *, closed_top: bool = False):
        """Points in the core ``[x0, x1) x [y0, y1)``; ``closed_top``: ``(y0, y1]`` (a point on
        a row edge in the row below, see :meth:`GridSpec.cell_index`)."""
        x0, y0, x1, y1 = self.core
        x = np.asarray(x)
        y = np.asarray(y)
        if closed_top:
            return (x >= x0) & (x < x1) & (y > y0) & (y <= y1)
        return (x >= x0) & (x < x1) & (y >= y0) & (y < y1)


def make_tiles(extent, tile_size: float, buffer: float) -> list:
    """Tiles of ``tile_size`` m aligned to multiples of it, covering ``extent``. The cores of
    the outer tiles reach to infinity on the area's outer sides, so a tree whose top cell
    centre lies just outside the points' extent (it is half a cell away at most) is kept, as
    it is when the area is one tile."""
    if not (tile_size > 0 and buffer >= 0):
        raise InputError(f"-tile_size must be > 0 and -buffer >= 0 (got {tile_size}, {buffer})")
    x0, y0, x1, y1 = extent
    inf = math.inf
    if math.isinf(tile_size):  # one tile: the whole area
        return [Tile((0, 0), (-inf, -inf, inf, inf), (x0, y0, x1, y1))]
    i0, i1 = math.floor(x0 / tile_size), math.floor(x1 / tile_size)
    j0, j1 = math.floor(y0 / tile_size), math.floor(y1 / tile_size)
    if (i1 - i0 + 1) * (j1 - j0 + 1) > 1_000_000:
        raise InputError(f"-tile_size {tile_size} m makes more than a million tiles over "
                         f"{x1 - x0:.0f} x {y1 - y0:.0f} m")
    tiles = []
    for j in range(j0, j1 + 1):
        for i in range(i0, i1 + 1):
            cx0, cy0 = i * tile_size, j * tile_size
            cx1, cy1 = cx0 + tile_size, cy0 + tile_size
            box = (max(cx0 - buffer, x0), max(cy0 - buffer, y0), min(cx1 + buffer, x1),
                   min(cy1 + buffer, y1))
            if box[2] < box[0] or box[3] < box[1]:
                continue
            core = (-inf if i == i0 else cx0, -inf if j == j0 else cy0,
                    inf if i == i1 else cx1, inf if j == j1 else cy1)
            tiles.append(Tile((i, j), core, box))
    return tiles
