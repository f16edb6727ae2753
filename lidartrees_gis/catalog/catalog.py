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

from ..errors import CRSError, InputError
from .inputs import ept_crs, expand_inputs, is_ept


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
        from ..io.points import open_points

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
