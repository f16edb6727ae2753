"""Where the trees of the tiles go, as the tiles finish: the GeoPackage layers (tops, crowns,
gaps, summary), the same layers in memory (the Python API), a CSV in TreeX's layout and the
quick-look PNG; and the stand summary accumulated over the tiles (so the calling process holds
one batch of trees at a time, whatever the size of the area)."""
from __future__ import annotations

import json
import math
import warnings
from pathlib import Path

import numpy as np

from ..errors import OutputExistsError
from ..io.styles import GPKG_DATASET_OPTIONS, LAYER_STYLES, embed_styles
from .metrics import tree_ids
from ..plantation.status import MISSING, STATUS_NAMES, UNCERTAIN
from ..plantation.stocking import STOCK_COUNTS, axial_mean, fitted_spacing, stocking_fields
from ..plantation.table import Positions
from .tile import INT_FIELDS, TREE_FIELDS

#: trees written to the GeoPackage together (one write per batch, not two per tile)
BATCH_TREES = 20_000
#: the quick look's largest side (pixels of the CHM drawn); larger areas are drawn coarser
QUICKLOOK_CELLS = 2_000


class Tally:
    """Points read (with the buffers), outliers removed and points per dropped class, summed over
    the tiles of any chain."""

    def __init__(self):
        self.points, self.outliers, self.dropped = 0, 0, {}

    def add(self, r: dict) -> None:
        self.points += r["points"]
        self.outliers += r.get("outlier_points") or 0
        for c, v in r["dropped"].items():
            self.dropped[c] = self.dropped.get(c, 0) + v


class TreesSummary(Tally):
    """The stand summary of an area, summed tile by tile."""

    STOCK = STOCK_COUNTS

    def __init__(self):
        super().__init__()
        self.n, self.hsum, self.h2sum, self.dsum = 0, 0.0, 0.0, 0.0
        self.canopy, self.gap_trees, self.small = 0, 0, 0
        self.crowned, self.suppressed, self.leaning = 0, 0, 0
        self.lattices, self.azimuths, self.ids, self.spacings = [], [], [], []
        self.numbering, self.numbered = "", 0
        self.stock = dict.fromkeys(self.STOCK, 0)
        self.why = None  # why the area's canopy, showing rows, gave no lattice
        self.stock["planted_area_ha"] = 0.0

    def add(self, r: dict) -> None:
        super().add(r)
        self.ids.append(np.asarray(r["tree_id"], np.int64))
        h = np.asarray(r["height"], float)
        sup = np.asarray(r["suppressed"]) != 0  # no crown of their own
        self.n += h.size
        self.hsum += float(h.sum())
        self.h2sum += float((h ** 2).sum())
        self.dsum += float(np.sum(r["crown_diameter"]))
        self.crowned += int((~sup).sum())
        self.suppressed += int((np.asarray(r["suppressed"]) == 1).sum())
        self.leaning += int((np.asarray(r["suppressed"]) == 2).sum())
        self.small += int((small_crowns(r["crown_area"], r["n_cells"]) & ~sup).sum())
        self.canopy += r["canopy_cells"]
        self.gap_trees += r["gap_trees"]
        if r["planting"]:
            self.lattices.append(tuple(r["planting"]))
        why = r.get("lattice_why") or {}
        self.why = self.why or why.get("all") or next(iter(why.values()), None)
        st = r["stocking"]
        if st is not None:
            for k in self.STOCK:
                self.stock[k] += st.get(k, 0)
            self.azimuths.append((st["azimuth"], st["expected"]))
            if st.get("spacing") is not None:
                self.spacings.append((tuple(st["spacing"]), st["expected"]))
            if st.get("numbering") and st["expected"] >= self.numbered:  # the largest tile's
                self.numbering, self.numbered = st["numbering"], st["expected"]

    @property
    def tree_ids(self) -> np.ndarray:
        return np.concatenate(self.ids) if self.ids else np.empty(0, np.int64)

    @property
    def planting(self) -> str:
        """The median spacings of the tiles that found a planting lattice under their tops."""
        if not self.lattices:
            return ""
        return "{:.2f}x{:.2f}".format(*np.median(np.asarray(self.lattices), axis=0))

    def tops_label(self, params) -> str:
        """How the tops were found, and the trees the look at the planting positions added
        (whose crowns were grown again, by a marker watershed for ``-method watershed``)."""
        label = params.tops_finder if params.method != "watershed" else "watershed basins"
        if self.gap_trees:
            label += f" + {self.gap_trees} at empty planting positions"
            if params.method == "watershed":
                label += " (crowns grown again by a marker-controlled watershed)"
        return label

    def row(self, params, plan, smooth: str) -> dict:
        """The summary layer's one row."""
        n, res = self.n, plan.res
        area_ha = self.canopy * res * res / 1e4  # the area processed: cells with a canopy height
        mean_h = self.hsum / n if n else np.nan
        sd_h = float(np.sqrt(max(self.h2sum - n * mean_h ** 2, 0.0) / (n - 1))) if n > 1 else np.nan
        row = {"trees": n, "area_ha": area_ha, "trees_per_ha": n / area_ha if area_ha else np.nan,
               "mean_height": mean_h, "sd_height": sd_h,
               "mean_crown_diameter": self.dsum / self.crowned if self.crowned else np.nan,
               "small_crowns": self.small,
               # trees at an empty planting position with no top (no crown polygon)
               "suppressed_trees": self.suppressed,
               # trees at uncertain positions (their returns lean to a tree: a field check)
               "uncertain_trees": self.leaning,
               "method": params.method, "smooth": smooth,
               "tops": self.tops_label(params),
               "res": res, "crown_scale": plan.crown_scale, "dominant_height": plan.dominant_height,
               "tiles": len(plan.tiles),
               "tile_size": plan.tile_size if math.isfinite(plan.tile_size) else np.nan,
               "buffer": plan.buffer, "points": self.points, "outlier_points": self.outliers,
               "dropped_classes": ",".join(f"{c}:{v}" for c, v in sorted(self.dropped.items())),
               # trees found by the second look at the empty planting positions, and the
               # spacings of the lattice found under the tops without -spacing
               "gap_trees": self.gap_trees, "planting_detected": self.planting,
               "planting_tiles": len(self.lattices)}
        if params.spacing is not None:  # plantation mode: the stocking of all tiles
            ok = [(a, e) for a, e in self.azimuths if e and np.isfinite(a)]
            az = axial_mean(*zip(*ok)) if ok else np.nan
            row.update(stocking_fields(fitted_spacing(params.spacing, self.spacings), az,
                                       self.stock, tops=n, why=self.why))
            # how row_number and plant_number count: per stand, the same in every tiling
            row["numbering"] = self.numbering
        return row


def tree_arrays(r: dict) -> dict:
    """One tile's trees as arrays ordered by tree_id (crowns and tops as WKB)."""
    order = np.argsort(r["tree_id"], kind="stable")
    rows = {c: np.asarray(r[c])[order] for c in TREE_FIELDS}
    for g in ("wkb", "top_wkb"):
        rows[g] = np.asarray(list(r[g]), dtype=object)[order]
    box = r.get("crown_box")
    if box is None or len(box) != order.size:  # a result stored by an older version
        import shapely

        box = shapely.bounds(shapely.from_wkb(np.r_[rows["wkb"], [None]])[:-1])
        rows["crown_box"] = box
    else:
        rows["crown_box"] = np.asarray(box, float).reshape(-1, 4)[order]
    if r.get("crown_method"):  # the method that grew the tile's crowns
        rows["method"] = np.full(order.size, r["crown_method"], dtype=object)
    return rows


#: crowns smaller than this (m²) or than :data:`SMALL_CROWN_CELLS` cells are flagged
#: (``small_crown`` = 1): a suppressed tree squeezed between its neighbours, or a sliver of a
#: neighbour's crown split off by a false top; check them before reporting crown sizes
SMALL_CROWN_M2 = 1.0
SMALL_CROWN_CELLS = 4


def small_crowns(crown_area, n_cells) -> np.ndarray:
    """Which crowns are flagged small (see :data:`SMALL_CROWN_M2`)."""
    return (np.asarray(crown_area, float) < SMALL_CROWN_M2) | \
        (np.asarray(n_cells) < SMALL_CROWN_CELLS)


def _point_boxes(x, y) -> np.ndarray:
    """Points' bounds (``(n, 4)``: x, y, x, y)."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    return np.column_stack([x, y, x, y])


def stand_names(index, stand_ids) -> np.ndarray:
    """Stand indices (-1: none) as the stands' ids ("" for none)."""
    names = np.asarray(["", *stand_ids], dtype=object)
    return names[np.asarray(index, np.int64) + 1]


def gap_arrays(st: dict, res: float, tile, stand_ids=None) -> dict:
    """The empty planting positions of one tile: ids from the position's cell in the global
    grid (as tree_id), row and plant numbers as a crew counts them
    (:func:`lidartrees_gis.plantation.stocking.crew_numbers`, per stand: the same in every tiling)
    and, with
    stands, the stand's id."""
    gaps = st["gaps"]
    gx, gy = gaps.x, gaps.y
    out = {"gap_id": tree_ids(gx, gy, res), "row_number": gaps.column("row", 0),
           "plant_number": gaps.column("plant", 0), "x": gx, "y": gy,
           "tile": np.full(gx.size, "_".join(map(str, tile)), dtype=object)}
    # what stands at the position: nothing (missing, a gap), a suppressed tree under or
    # beside its neighbours' crowns (no top of its own), or either (uncertain: a field check);
    # crown_share: the share of the returns there at a suppressed tree's height, of `returns`
    out["status"] = np.asarray(STATUS_NAMES, dtype=object)[
        gaps.column("status", 0).astype(np.int64)]
    out["crown_share"] = gaps.column("share", 0.0)
    out["returns"] = gaps.column("returns", 0)
    if stand_ids is not None:
        out["stand_id"] = stand_names(gaps.column("zone", -1), stand_ids)
    return out


#: the layers a trees run writes (under ``-nln``'s prefix); ``-overwrite`` replaces them all,
#: also those this run does not write (an earlier run's gaps or stands would not be its trees')
TREE_LAYERS = ("tree_tops", "crowns", "gaps", "summary", "stands")


def tree_layer_names(nln: str = "") -> dict:
    """``{layer: name in the file}`` of :data:`TREE_LAYERS` under the prefix ``nln``."""
    return {k: f"{nln}{k}" for k in TREE_LAYERS}


class TreeLayers:
    """The layers of a trees run, fed tile by tile: ``add`` a tile's result, ``finish`` with
    the summary row. This base keeps them in memory (the Python API's frames)."""

    def __init__(self, crs, method: str, nln: str = "", stand_ids=None):
        self.crs, self.method, self.stand_ids = crs, method, stand_ids
        self.names = tree_layer_names(nln)
        self.parts, self.gaps, self.summary, self.stands = [], [], None, None

    def add(self, r: dict, flush: bool = False) -> None:
        if len(r["tree_id"]):
            self.parts.append(tree_arrays(r))
        st = r["stocking"]
        if st is not None and len(st["gaps"]):
            self.gaps.append(gap_arrays(st, r["res"], r["tile"], self.stand_ids))

    def finish(self, summary: dict, plantation: bool, stands=None) -> None:
        """The summary row; ``stands``: ``(rows, geometries)`` of the stands layer."""
        self.summary, self.plantation, self.stands = summary, plantation, stands

    def _stands_frame(self):
        import geopandas as gpd

        rows, geoms = self.stands
        crs = self.crs.to_wkt() if self.crs is not None else None
        return gpd.GeoDataFrame(rows, geometry=list(geoms), crs=crs)

    def _fields(self, parts: list) -> dict:
        data = {c: np.concatenate([p[c] for p in parts]) if parts else
                np.empty(0, np.int64 if c in INT_FIELDS else np.float64)
                for c in TREE_FIELDS}
        for c in INT_FIELDS:
            data[c] = data[c].astype(np.int64)
        stand = data.pop("stand")
        if self.stand_ids is not None:
            data["stand_id"] = stand_names(stand, self.stand_ids)
        data["method"] = np.concatenate(
            [p["method"] if "method" in p else np.full(len(p["tree_id"]), self.method, dtype=object)
             for p in parts]) if parts else np.empty(0, dtype=object)
        data["small_crown"] = (small_crowns(data["crown_area"], data["n_cells"])
                               & (data["suppressed"] == 0)).astype(np.int32)
        return data

    def frames(self) -> dict:
        """``{layer name: GeoDataFrame or DataFrame}``."""
        import geopandas as gpd
        import pandas as pd
        import shapely

        attrs = pd.DataFrame(self._fields(self.parts))
        wkb = [np.concatenate([p[g] for p in self.parts]) if self.parts else np.empty(0, object)
               for g in ("top_wkb", "wkb")]
        crs = self.crs.to_wkt() if self.crs is not None else None
        crowned = (attrs["suppressed"] == 0).to_numpy()  # a suppressed tree has no crown
        out = {self.names["tree_tops"]: gpd.GeoDataFrame(attrs.copy(), crs=crs,
                                                         geometry=shapely.from_wkb(wkb[0])),
               self.names["crowns"]: gpd.GeoDataFrame(
                   attrs[crowned].reset_index(drop=True), crs=crs,
                   geometry=shapely.from_wkb(wkb[1][crowned]))}
        if self.plantation:
            g = {k: np.concatenate([p[k] for p in self.gaps]) for k in self.gaps[0]} \
                if self.gaps else {k: np.empty(0) for k in ("gap_id", "row_number",
                                                            "plant_number", "x", "y", "tile",
                                                            "status", "crown_share", "returns")
                                   + (("stand_id",) if self.stand_ids is not None else ())}
            out[self.names["gaps"]] = gpd.GeoDataFrame(g, crs=crs,
                                                       geometry=shapely.points(g["x"], g["y"]))
        out[self.names["summary"]] = pd.DataFrame([self.summary])
        if self.stands is not None:
            out[self.names["stands"]] = self._stands_frame()
        return out


class GpkgTreeLayers(TreeLayers):
    """The layers written into the (temporary) GeoPackage ``path`` as the tiles come: the
    workers' WKB goes to GDAL as it is (``pyogrio.raw.write``), one write per
    :data:`BATCH_TREES` trees; the summary table last. ``existing``: layers of the file that are
    appended to (``-append``); appending trees a layer already holds is refused."""

    def __init__(self, path, crs, method: str, nln="", *, existing=(), metadata=None,
                 layer_options=None, stand_ids=None):
        super().__init__(crs, method, nln, stand_ids)
        self.path, self.existing, self.created = path, set(existing), set()
        self.meta = {k: (v if isinstance(v, str) else json.dumps(v, default=str))
                     for k, v in (metadata or {}).items()}
        self.lco = layer_options or None
        self.wkt = crs.to_wkt() if crs is not None else None
        self.pending, self.pending_rows = [], 0
        self.old_ids = self._existing_ids()
        # the new layers' spatial indexes, made at the end from the features' bounds
        # (io.gpkg_rtree: GDAL's, updated feature by feature, was two thirds of the writing);
        # not when -lco says how to index
        self.boxes = {}
        self.defer = not any(str(k).upper() == "SPATIAL_INDEX" for k in (self.lco or {}))

    def _existing_ids(self) -> set:
        import pyogrio

        name = self.names["tree_tops"]
        if name not in self.existing:
            return set()
        old = pyogrio.read_dataframe(self.path, layer=name, columns=["tree_id"],
                                     read_geometry=False)
        return set(old["tree_id"].tolist()) if "tree_id" in old.columns else set()

    def _new(self, layer) -> bool:
        new = layer not in self.existing and layer not in self.created
        self.created.add(layer)
        return new

    def _raw(self, wkb, fields: dict, layer, geometry_type, bounds) -> None:
        """Write features (``bounds``: their ``(n, 4)`` bounds, for the spatial index)."""
        import pyogrio.raw

        new = self._new(layer)
        lco = self.lco
        if new and self.defer:
            lco = {**(self.lco or {}), "SPATIAL_INDEX": "NO"}
            self.boxes[layer] = []
        if layer in self.boxes:  # as the R-tree keeps them: float32, 16 bytes a feature
            from ..io.gpkg_rtree import float32_box

            self.boxes[layer].append(float32_box(bounds))
        with warnings.catch_warnings():  # points without a CRS (a TLS tree in local coordinates)
            warnings.filterwarnings("ignore", message="'crs' was not provided")
            pyogrio.raw.write(self.path, wkb, list(fields.values()), list(fields), layer=layer,
                              driver="GPKG", geometry_type=geometry_type, crs=self.wkt,
                              append=not new, layer_options=lco if new else None,
                              layer_metadata=self.meta if new else None,
                              dataset_options=None if Path(self.path).exists()
                              else GPKG_DATASET_OPTIONS)

    def add(self, r: dict, flush: bool = False) -> None:
        if len(r["tree_id"]):
            dup = self.old_ids.intersection(np.asarray(r["tree_id"]).tolist()) \
                if self.old_ids else ()
            if dup:
                raise OutputExistsError(
                    f"{self.path}: -append: layer {self.names['tree_tops']} already holds "
                    f"{len(dup):,} of these trees (same tree_id: the same area twice?); use "
                    "-overwrite to replace the layers, or append other areas only")
            self.pending.append(tree_arrays(r))
            self.pending_rows += len(r["tree_id"])
        if flush or self.pending_rows >= BATCH_TREES:
            self.flush()
        st = r["stocking"]
        if st is not None and len(st["gaps"]):
            import shapely

            g = gap_arrays(st, r["res"], r["tile"], self.stand_ids)
            self._raw(shapely.to_wkb(shapely.points(g["x"], g["y"])), g, self.names["gaps"],
                      "Point", _point_boxes(g["x"], g["y"]))

    def flush(self) -> None:
        if self.pending:
            data = self._fields(self.pending)
            crowned = data["suppressed"] == 0  # a suppressed tree has no crown polygon
            for layer, g, kind in (("tree_tops", "top_wkb", "Point"), ("crowns", "wkb", "Polygon")):
                wkb = np.concatenate([p[g] for p in self.pending])
                fields = data
                box = _point_boxes(data["x"], data["y"]) if layer == "tree_tops" else \
                    np.concatenate([p["crown_box"] for p in self.pending])
                if layer == "crowns" and not crowned.all():
                    wkb, fields = wkb[crowned], {k: v[crowned] for k, v in data.items()}
                    box = box[crowned]
                self._raw(wkb, fields, self.names[layer], kind, box)
        self.pending, self.pending_rows = [], 0

    def finish(self, summary: dict, plantation: bool, stands=None) -> None:
        import pandas as pd
        import pyogrio

        self.flush()
        for layer, kind in (("tree_tops", "Point"), ("crowns", "Polygon")):
            if self.names[layer] not in self.created | self.existing:  # no tree: empty layers
                data = self._fields([])
                self._raw(np.empty(0, object), data, self.names[layer], kind, np.empty((0, 4)))
        if plantation and self.names["gaps"] not in self.created | self.existing:
            import shapely

            g = gap_arrays({"gaps": Positions.empty()}, 1.0, (), self.stand_ids)
            self._raw(shapely.to_wkb(shapely.points(g["x"], g["y"])), g, self.names["gaps"],
                      "Point", np.empty((0, 4)))
        self._index()
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", message=".*geometry.*")
            pyogrio.write_dataframe(pd.DataFrame([summary]), self.path,
                                    layer=self.names["summary"], driver="GPKG",
                                    append=self.names["summary"] in self.existing)
            if stands is not None:
                from ..io.vector import describe_columns
                from ..plantation.stands import field_docs

                self.stands = stands
                frame = self._stands_frame()
                pyogrio.write_dataframe(frame, self.path, layer=self.names["stands"],
                                        driver="GPKG",
                                        append=self.names["stands"] in self.existing,
                                        layer_options=self.lco)
                describe_columns(self.path, self.names["stands"], field_docs(frame.columns))
        embed_styles(self.path, {self.names[k]: qml for k, qml in LAYER_STYLES.items()})

    def _index(self) -> None:
        """The spatial index of each layer this run made (:func:`~lidartrees_gis.io.gpkg_rtree.
        add_rtree`), from the bounds kept as its features were written (in fid order)."""
        import sqlite3

        from ..io.gpkg_rtree import add_rtree

        if not self.boxes:
            return
        con = sqlite3.connect(str(self.path))
        try:
            for layer, parts in self.boxes.items():
                col = con.execute("SELECT column_name FROM gpkg_geometry_columns WHERE "
                                  "table_name = ?", (layer,)).fetchone()[0]
                pk = next(r[1] for r in con.execute(f'PRAGMA table_info("{layer}")') if r[5])
                lo, hi, n = con.execute(f'SELECT min("{pk}"), max("{pk}"), count(*) FROM '
                                        f'"{layer}"').fetchone()
                fids = np.arange(lo, hi + 1, dtype=np.int64) if n and hi - lo + 1 == n else \
                    np.array([r[0] for r in con.execute(
                        f'SELECT "{pk}" FROM "{layer}" ORDER BY "{pk}"')], np.int64)
                box = np.concatenate(parts) if parts else np.empty((0, 4), np.float32)
                if fids.size != len(box):  # pragma: no cover - GDAL numbers them as written
                    raise RuntimeError(f"{self.path}: {layer}: {fids.size} features, "
                                       f"{len(box)} bounds")
                add_rtree(con, layer, col, fids, box, pk=pk)
            con.commit()
        finally:
            con.close()
        self.boxes = {}


#: the trees table of ``-csv``: the tree's id (text: a spreadsheet keeps its 16 digits),
#: stand, planting row and plant (plantation mode; 0 for none), position and sizes, and the
#: top's cell in the area's CHM grid (``chm_row``, ``chm_col``)
TREE_TABLE = ("tree_id", "stand_id", "row_number", "plant_number", "x", "y", "height",
              "crown_diameter", "crown_area", "suppressed", "chm_row", "chm_col")
#: decimals of the tables' numbers: cm for positions, heights and diameters, dm² for areas
TREE_DECIMALS = {"x": 2, "y": 2, "height": 2, "crown_diameter": 2, "crown_area": 2}


class TreesTable:
    """The trees as a table for people (``-csv``, see :data:`TREE_TABLE`), in the dialect of
    ``options`` (:class:`lidartrees_gis.io.tables.TableOptions`: the locale's by default), or
    a workbook when the name ends in ``.xlsx``."""

    def __init__(self, path, spec, stand_ids=None, options=None):
        from ..io.tables import TableWriter

        self.spec, self.stand_ids = spec, stand_ids
        cols = [c for c in TREE_TABLE if c != "stand_id" or stand_ids is not None]
        self.w = TableWriter(path, cols, TREE_DECIMALS, ("tree_id", "stand_id"), options,
                             name="trees")

    def add(self, r: dict) -> None:
        t = tree_arrays(r)
        rows, cols = self.spec.cell_index(t["x"], t["y"])
        t["chm_row"], t["chm_col"] = rows, cols
        if self.stand_ids is not None:
            t["stand_id"] = stand_names(t["stand"], self.stand_ids)
        names = self.w.columns
        for vals in zip(*(t[c].tolist() for c in names)):
            self.w.write(vals)

    def close(self) -> None:
        self.w.close()


class QuickLook:
    """The quick look of an area, assembled from the tiles: their core CHMs on a canvas of at
    most :data:`QUICKLOOK_CELLS` a side (coarser cells, the highest of the cells they cover,
    for large areas), the crowns and the tops."""

    def __init__(self, spec):
        from ..grid import GridSpec

        k = max(1, math.ceil(max(spec.width, spec.height) / QUICKLOOK_CELLS))
        self.k, self.fine = k, spec
        self.spec = spec if k == 1 else GridSpec.from_bounds(*spec.bounds, spec.res * k,
                                                             crs=spec.crs)
        self.chm = np.full(self.spec.shape, np.nan)
        self.crowns, self.x, self.y, self.gx, self.gy = [], [], [], [], []
        self.ux, self.uy, self.sx, self.sy = [], [], [], []

    def add(self, r: dict) -> None:
        a = np.asarray(r["chm"], np.float64)
        if a.size:
            self._paste(a, r["chm_left"], r["chm_top"])
        if len(r["tree_id"]):
            self.crowns.append(np.asarray(list(r["wkb"]), dtype=object))
            sup = np.asarray(r.get("suppressed", np.zeros(len(r["x"]))), int) > 0
            self.x.append(np.asarray(r["x"])[~sup])
            self.y.append(np.asarray(r["y"])[~sup])
            self.sx.append(np.asarray(r["x"])[sup])  # no crown of their own: marked apart
            self.sy.append(np.asarray(r["y"])[sup])
        st = r.get("stocking")
        if st is not None and len(st["gaps"]):
            gaps = st["gaps"]
            status = gaps.column("status", MISSING)
            for xs, ys, code in ((self.gx, self.gy, MISSING), (self.ux, self.uy, UNCERTAIN)):
                xs.append(gaps.x[status == code])
                ys.append(gaps.y[status == code])

    def _paste(self, a, left, top) -> None:
        s, k = self.fine, self.k
        c0 = int(round((left - s.left) / s.res))
        r0 = int(round((s.top - top) / s.res))
        rr, cc = np.mgrid[r0:r0 + a.shape[0], c0:c0 + a.shape[1]]
        ok = np.isfinite(a)
        rr, cc, v = rr[ok] // k, cc[ok] // k, a[ok]
        inside = (rr >= 0) & (rr < self.spec.height) & (cc >= 0) & (cc < self.spec.width)
        np.fmax.at(self.chm, (rr[inside], cc[inside]), v[inside])

    def write(self, path, title: str, overwrite: bool, stands=None) -> None:
        """``stands``: ``(ids, polygons)`` outlined on the quick look."""
        import shapely
        from rasterio.features import rasterize

        from ..report.quicklook import write_quicklook

        labels = np.zeros(self.spec.shape, np.int32)
        if self.crowns:
            geoms = shapely.from_wkb(np.concatenate(self.crowns))
            labels = rasterize(((g, i + 1) for i, g in enumerate(geoms) if g is not None),
                               out_shape=self.spec.shape, transform=self.spec.transform,
                               dtype="int32")
        x = np.concatenate(self.x) if self.x else np.empty(0)
        y = np.concatenate(self.y) if self.y else np.empty(0)
        rows, cols = self.spec.cell_index(x, y)
        gaps = (np.concatenate(self.gx), np.concatenate(self.gy)) if self.gx else None
        unc = (np.concatenate(self.ux), np.concatenate(self.uy)) if self.ux else None
        sup = (np.concatenate(self.sx), np.concatenate(self.sy)) if self.sx else None
        write_quicklook(path, self.chm, labels, rows, cols, spec=self.spec, title=title,
                        overwrite=overwrite, gaps=gaps, stands=stands, uncertain=unc,
                        suppressed=sup)


def sidecar(path, qml: str, overwrite: bool, top: float = float("nan")):
    """The QGIS style ``qml`` beside a GeoTIFF output (``chm.tif`` -> ``chm.qml``), the CHM's
    classes fitted to its highest cell ``top``
    (:func:`lidartrees_gis.io.styles.write_sidecar_style`)."""
    from ..io.styles import write_sidecar_style
    from ..report.classes import height_classes

    limits = height_classes(top) if qml == "chm.qml" and np.isfinite(top) and top > 0 else None
    return write_sidecar_style(path, qml, overwrite, limits)
