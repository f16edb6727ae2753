"""Stands (talhões): the polygons a forest manager reports by.

:func:`load_stands` reads them (any OGR polygon source, reprojected to the points' CRS);
:func:`locate` and :func:`zones` say which stand a point or a cell lies in (what a tile needs);
:class:`StandsTally` sums what the tiles send per stand, and :meth:`StandsTally.rows` gives the
``stands`` layer's figures. Every figure is a sum over tiles of what lies in their cores (trees,
cells, planting positions), so a stand spanning many tiles gets the figures of one run.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np

from ..errors import DataWarning, InputError, listing
from ..io.names import plain
from .stocking import STOCK_COUNTS

#: the stand id field looked for when ``-stand_id`` is not given (case and accents ignored)
ID_FIELDS = ("stand_id", "talhao", "id_talhao", "cod_talhao", "codigo_talhao", "stand", "codigo",
             "cod", "id", "name", "nome")
#: a field whose name holds one of these is taken as the ids (with a warning naming it) when
#: none of :data:`ID_FIELDS` is present: ``NUM_TALHAO``, ``talhao_num``, ``STAND_NO``
ID_HINTS = ("talhao", "talhoes", "stand")
#: dominant height (Assmann): the mean height of the 100 tallest trees per hectare
DOMINANT_PER_HA = 100
#: a stand less covered by the points than this (%) is named in a warning: its per-hectare
#: figures count only the trees of the part that was flown
MIN_DATA_COVER_PCT = 95.0


@dataclass(frozen=True)
class Stands:
    """Stand polygons in the points' CRS.

    Attributes
    ----------
    ids : tuple of str
        Each stand's id (the ``id_field`` values, or 1, 2, ... when there is none).
    geoms : ndarray of shapely geometries
        (Multi)polygons, valid, one per id (features sharing an id are joined).
    id_field : str
        The field the ids came from (``""``: numbered in the source's order).
    source : str
        ``PATH[:LAYER]`` or ``GeoDataFrame``.
    reprojection : str
        The operation that brought them into the points' CRS and its accuracy (``""``: none).
    attributes : tuple of dict
        Each stand's own attributes as the source gives them (species, clone, planting date,
        area in the company's register, the id field itself), under their own names (a name
        the stands layer uses for a figure gets ``_input``: see :func:`user_attributes`).
    """

    ids: tuple
    geoms: np.ndarray
    id_field: str = ""
    source: str = ""
    reprojection: str = ""
    attributes: tuple = ()
    _tree: object = field(default=None, repr=False, compare=False)

    def __len__(self) -> int:
        return len(self.ids)

    @property
    def area_ha(self) -> np.ndarray:
        import shapely

        return shapely.area(self.geoms) / 1e4

    def __getstate__(self):  # the STRtree is rebuilt where it is used (a Dask worker)
        return {k: getattr(self, k) for k in ("ids", "geoms", "id_field", "source",
                                              "reprojection", "attributes")}

    def __setstate__(self, state):
        for k, v in state.items():
            object.__setattr__(self, k, v)
        object.__setattr__(self, "_tree", None)

    def digest(self) -> str:
        """A digest of the ids and geometries (what a kept tile depends on)."""
        import hashlib

        import shapely

        h = hashlib.sha256(repr(self.ids).encode())
        for w in shapely.to_wkb(self.geoms):
            h.update(w)
        return h.hexdigest()

    def tree(self):
        import shapely

        if self._tree is None:
            object.__setattr__(self, "_tree", shapely.STRtree(self.geoms))
        return self._tree


def _geometries(gdf, name: str):
    """Valid polygons of ``gdf``: empty ones dropped and invalid ones repaired, each named in a
    warning; a feature that is not a polygon is an error."""
    import shapely

    geoms = np.asarray(gdf.geometry.values, dtype=object)
    keep = np.ones(len(geoms), bool)
    for i, g in enumerate(geoms):
        label = f"{name}: feature {i + 1}"
        if g is None or shapely.is_empty(g):
            warnings.warn(DataWarning(f"-stands: {label} has no geometry; left out"),
                          stacklevel=4)
            keep[i] = False
            continue
        if g.geom_type not in ("Polygon", "MultiPolygon"):
            raise InputError(f"-stands: {label} is a {g.geom_type}, not a polygon")
        if not shapely.is_valid(g):
            reason = shapely.is_valid_reason(g)
            g = shapely.make_valid(g)
            if g.geom_type == "GeometryCollection":
                g = shapely.union_all([p for p in g.geoms
                                       if p.geom_type in ("Polygon", "MultiPolygon")])
            warnings.warn(DataWarning(f"-stands: {label} is not a valid polygon ({reason}); "
                                      f"repaired ({g.area:,.0f} m²)"), stacklevel=4)
            geoms[i] = g
        if shapely.area(geoms[i]) <= 0:
            warnings.warn(DataWarning(f"-stands: {label} has no area; left out"), stacklevel=4)
            keep[i] = False
    return geoms, keep


def _ids(gdf, id_field, name: str) -> tuple:
    cols = [c for c in gdf.columns if c != gdf.geometry.name]
    if id_field:
        match = [c for c in cols if c == id_field] or [c for c in cols
                                                       if plain(c) == plain(id_field)]
        if not match:
            raise InputError(f"-stand_id: {name} has no field {id_field!r} (fields: "
                             f"{', '.join(map(str, cols)) or 'none'})")
        col = match[0]
    else:
        by_plain = {plain(c): c for c in cols}
        col = next((by_plain[f] for f in ID_FIELDS if f in by_plain), "")
        if not col:
            col = next((c for c in cols if any(w in plain(c) for w in ID_HINTS)), "")
            listed = ", ".join(map(str, cols))
            if col:
                warnings.warn(DataWarning(
                    f"-stands: {name}: no field named as a stand id ({', '.join(ID_FIELDS)}); "
                    f"the ids are taken from {col!r} (fields: {listed}); -stand_id FIELD picks "
                    "another"), stacklevel=3)
            elif cols:
                warnings.warn(DataWarning(
                    f"-stands: {name}: no field named as a stand id ({', '.join(ID_FIELDS)}); "
                    f"the stands are numbered 1, 2, ... in the file's order (fields: {listed}); "
                    "-stand_id FIELD takes the ids from one of them"), stacklevel=3)
    if not col:
        return [str(i + 1) for i in range(len(gdf))], ""
    vals = gdf[col].tolist()
    for i, v in enumerate(vals):
        if v is None or (isinstance(v, float) and not np.isfinite(v)) or str(v).strip() == "":
            raise InputError(f"-stand_id: {name}: feature {i + 1} has no {col}")
    return [str(int(v)) if isinstance(v, float) and float(v).is_integer() else str(v).strip()
            for v in vals], str(col)


def load_stands(source, crs=None, id_field: str | None = None) -> Stands:
    """Read stand polygons and bring them into ``crs`` (the points').

    Parameters
    ----------
    source : str, Path or GeoDataFrame
        ``PATH`` or ``PATH:LAYER`` of any OGR polygon source (GeoPackage, shapefile, ...).
    crs : pyproj.CRS, optional
        The points' CRS. Stands in another CRS are reprojected (the operation and its accuracy
        kept in :attr:`Stands.reprojection`); stands without a CRS are taken to be in it.
    id_field : str, optional
        The field holding the stand id; default the first of :data:`ID_FIELDS` present, else
        the features are numbered 1, 2, ...

    Features sharing an id are one stand (a stand in several parts). Empty polygons are left
    out and invalid ones repaired, each with a warning naming the feature; overlapping stands
    are named in a warning (a tree in both counts in the first).
    """
    import shapely

    if hasattr(source, "geometry"):
        gdf, name = source, "GeoDataFrame"
    else:
        from ..io.vector import read_polygons

        gdf, name = read_polygons(source, param="-stands")
    if len(gdf) == 0:
        raise InputError(f"-stands: {name} has no features")
    ids = _ids(gdf, id_field, name)
    ids, used = ids
    geoms, keep = _geometries(gdf, name)
    repro = ""
    if crs is None and gdf.crs is not None:
        from ..crs import crs_label

        raise InputError(f"-stands: {name} is in {crs_label(gdf.crs)} and the points have no "
                         "CRS (an XYZ file?): give theirs (-a_srs, a_srs=) so that the stands "
                         "can be placed on them")
    if crs is not None and gdf.crs is not None and not gdf.crs.equals(crs):
        from ..crs import check_coordinates, reprojection

        check_coordinates(gdf.crs, gdf.total_bounds, f"-stands: {name}", layer=True)
        op = reprojection(gdf.crs, crs)
        geoms = np.asarray([shapely.transform(g, lambda xy: np.column_stack(op(xy[:, 0], xy[:, 1])))
                            if k else g for g, k in zip(geoms, keep)], dtype=object)
        repro = op.report()
    elif crs is not None and gdf.crs is None:
        warnings.warn(DataWarning(f"-stands: {name} has no CRS; taken to be the points' "
                                  "CRS"), stacklevel=2)
    ids = [i for i, k in zip(ids, keep) if k]
    geoms = geoms[keep]
    if not ids:
        raise InputError(f"-stands: {name}: no polygon with an area")
    order = list(dict.fromkeys(ids))  # first appearance
    joined = np.asarray([shapely.union_all(geoms[[j for j, i in enumerate(ids) if i == sid]])
                         for sid in order], dtype=object)
    _warn_overlaps(joined, order, name)
    first = {sid: j for j, sid in reversed(list(enumerate(ids)))}
    kept = gdf[keep]
    if not id_field:  # a field the user names joins its features on purpose (per farm)
        _warn_shared_ids(kept, ids, name)
    drop = [kept.geometry.name] + ([used] if used and used.lower() == "stand_id" else [])
    attrs = user_attributes(kept.drop(columns=drop).iloc[[first[sid] for sid in order]])
    return Stands(tuple(order), joined, used, name, repro, tuple(attrs))


def _plain_value(v):
    """A field value as a plain Python value (numpy scalars unwrapped; NaN, NaT: None)."""
    import pandas as pd

    if v is None:
        return None
    try:
        if pd.isna(v):
            return None
    except (TypeError, ValueError):
        pass
    return v.item() if isinstance(v, np.generic) else v


def _warn_shared_ids(frame, ids, name) -> None:
    """Features sharing an id are one stand in several parts; where their other attributes
    differ (another clone, area or age) they look like two stands given one id: said (with
    the id field found, not given)."""
    import pandas as pd

    cols = [c for c in frame.columns if c != frame.geometry.name]
    s = pd.Series(ids)
    odd = []
    for sid in s[s.duplicated()].unique():
        rows = frame.iloc[np.flatnonzero(s.to_numpy() == sid)]
        diff = [c for c in cols if rows[c].astype(str).nunique() > 1]
        if diff:
            odd.append(f"{sid} ({', '.join(map(str, diff[:3]))})")
    if odd:
        warnings.warn(DataWarning(
            f"-stands: {name}: features sharing an id differ in their attributes, joined as one "
            f"stand each: {listing(odd, 8)}; give each stand its own id"), stacklevel=3)


def free_names(columns, taken) -> dict:
    """``{column: name}``: each of a user's ``columns`` under its own name, or with ``_input``
    added while a layer's own field (``taken``, compared without case, as GeoPackage columns
    are) or an earlier column holds it (``area_ha`` -> ``area_ha_input``)."""
    taken = {str(t).lower() for t in taken} | {"fid", "geom", "geometry"}
    names = {}
    for c in columns:
        n = str(c)
        while n.lower() in taken:
            n += "_input"
        taken.add(n.lower())
        names[c] = n
    return names


def user_attributes(frame) -> list:
    """Each row of ``frame`` (the stands' fields, no geometry) as a dict of plain values under
    the field's own name; a name the stands layer gives one of its figures gets ``_input``
    (:func:`free_names`)."""
    names = free_names(frame.columns, FIELD_DOCS)
    return [{names[c]: _plain_value(v) for c, v in zip(frame.columns, row)}
            for row in frame.itertuples(index=False, name=None)]


def check_overlap(stands: Stands, extent, points: str) -> None:
    """Raise :class:`InputError` when no stand overlaps the points' ``extent`` (xmin, ymin,
    xmax, ymax): the wrong file, or stands in another CRS without one said."""
    import shapely

    box = shapely.box(*extent)
    if not shapely.intersects(stands.geoms, box).any():
        sb = shapely.total_bounds(stands.geoms)
        raise InputError(
            f"-stands: {stands.source}: no stand overlaps the points: stands extent "
            f"{_extent(sb)}, points extent {_extent(extent)} ({points}); the wrong file, or "
            "the stands are in another CRS than the one their file declares")


def _extent(b) -> str:
    return f"({b[0]:.1f}, {b[1]:.1f}, {b[2]:.1f}, {b[3]:.1f})"


def _warn_overlaps(geoms, ids, name) -> None:
    import shapely

    tree = shapely.STRtree(geoms)
    a, b = tree.query(geoms, predicate="intersects")
    pairs = [(i, j) for i, j in zip(a.tolist(), b.tolist()) if i < j]
    over = [(ids[i], ids[j], shapely.area(shapely.intersection(geoms[i], geoms[j])))
            for i, j in pairs]
    over = [o for o in over if o[2] > 1.0]
    if over:
        listed = "; ".join(f"{i} and {j} ({m:,.0f} m²)" for i, j, m in over[:5])
        warnings.warn(DataWarning(f"-stands: {name}: {len(over)} pair(s) of stands overlap: "
                                  f"{listed}{' ...' if len(over) > 5 else ''}; what lies in two "
                                  "stands counts in the first"), stacklevel=3)


def locate(stands: Stands | None, x, y) -> np.ndarray:
    """The index of the stand each point (x, y) lies in (the first, when stands overlap);
    -1 outside every stand (or no stands)."""
    import shapely

    x = np.asarray(x, float)
    out = np.full(x.size, -1, np.int64)
    if stands is None or not x.size:
        return out
    pts = shapely.points(x, np.asarray(y, float))
    p, s = stands.tree().query(pts, predicate="within")
    order = np.lexsort((-s, p))  # per point, the first stand last, so it wins
    out[p[order]] = s[order]
    return out


def zones(stands: Stands | None, spec) -> np.ndarray:
    """The stand index of every cell of ``spec`` (cell centres; -1 outside every stand)."""
    out = np.full(spec.shape, -1, np.int32)
    if stands is None:
        return out
    import shapely
    from rasterio.features import rasterize

    box = shapely.box(*spec.bounds)
    hit = stands.tree().query(box, predicate="intersects")
    if not hit.size:
        return out
    shapes = [(stands.geoms[k], int(k)) for k in sorted(hit.tolist(), reverse=True)]
    return rasterize(shapes, out_shape=spec.shape, transform=spec.transform, fill=-1,
                     dtype="int32")


def stand_cells(zone_core, chm_core, min_height: float) -> dict:
    """Per stand in a tile's core: cells with a canopy height (data) and cells at or above
    ``min_height`` (canopy). ``{stand index: (data cells, canopy cells)}``."""
    z = np.asarray(zone_core)
    a = np.asarray(chm_core, float)
    ok = (z >= 0) & np.isfinite(a)
    if not ok.any():
        return {}
    data = np.bincount(z[ok], minlength=0)
    canopy = np.bincount(z[ok & (a >= min_height)], minlength=data.size)
    return {int(k): (int(data[k]), int(canopy[k])) for k in np.nonzero(data)[0]}


#: the plantation counts summed per stand (as :class:`lidartrees_gis.als.sinks.TreesSummary`)
STOCK = STOCK_COUNTS


class StandsTally:
    """What the tiles send per stand, summed: tree heights (kept, for the dominant height and
    the histogram: 4 bytes a tree), crown diameters, data and canopy cells, and in plantation
    mode the planting positions of each stand's own lattice."""

    def __init__(self, stands: Stands):
        n = len(stands)
        self.stands = stands
        self.heights = [[] for _ in range(n)]
        self.dsum = np.zeros(n)
        self.crowned = np.zeros(n, np.int64)
        self.cells = np.zeros((n, 2), np.int64)
        self.stock = {k: np.zeros(n) for k in STOCK}
        self.azimuths = [[] for _ in range(n)]
        self.spacings = [[] for _ in range(n)]
        self.why = {}  # why a stand whose canopy shows rows has no lattice
        self.outside = 0

    def add(self, r: dict) -> None:
        s = np.asarray(r["stand"], np.int64)
        h = np.asarray(r["height"], float)
        d = np.asarray(r["crown_diameter"], float)
        crowned = np.asarray(r["suppressed"]) == 0
        self.outside += int((s < 0).sum())
        for k in np.unique(s[s >= 0]).tolist():
            sel = s == k
            self.heights[k].append(h[sel].astype(np.float32))
            self.dsum[k] += float(d[sel].sum())
            self.crowned[k] += int((sel & crowned).sum())
        for k, (data, canopy) in (r.get("stand_cells") or {}).items():
            self.cells[k] += (data, canopy)
        self.why.update({k: v for k, v in (r.get("lattice_why") or {}).items()
                         if isinstance(k, int) and k >= 0})
        for k, st in (r.get("stand_stocking") or {}).items():
            if k < 0:
                continue
            for f in STOCK:
                self.stock[f][k] += st.get(f, 0)
            if st["expected"]:
                self.azimuths[k].append((st["azimuth"], st["expected"]))
                if st.get("spacing") is not None:
                    self.spacings[k].append((tuple(st["spacing"]), st["expected"]))

    def rows(self, res: float, spacing=None, classes=None) -> list:
        """One dict per stand: the ``stands`` layer's and ``-stand_csv``'s fields (see
        :data:`FIELD_DOCS`). ``classes``: upper limits of the height classes (m)."""
        from ..report.classes import height_classes
        from .stocking import axial_mean, fitted_spacing, stocking_fields

        hs = [np.concatenate(h) if h else np.empty(0, np.float32) for h in self.heights]
        if classes is None:
            top = max((float(h.max()) for h in hs if h.size), default=1.0)
            classes = height_classes(top)
        area = self.stands.area_ha
        rows = []
        for k, sid in enumerate(self.stands.ids):
            h, n = hs[k].astype(float), hs[k].size
            flown = self.cells[k, 0] * res * res / 1e4
            per = min(area[k], flown) if flown > 0 else np.nan
            ndom = max(1, int(round(DOMINANT_PER_HA * per))) if per == per else 0
            row = {"stand_id": sid,
                   **(self.stands.attributes[k] if self.stands.attributes else {}),
                   "area_ha": round(float(area[k]), 4),
                   "data_cover_pct": round(min(100.0, 100.0 * flown / area[k]), 2),
                   "trees": n, "trees_per_ha": n / per if per else np.nan,
                   "mean_height": float(h.mean()) if n else np.nan,
                   "sd_height": float(h.std(ddof=1)) if n > 1 else np.nan,
                   "dominant_height": float(np.sort(h)[-ndom:].mean()) if n and ndom else np.nan,
                   "mean_crown_diameter": (self.dsum[k] / self.crowned[k] if self.crowned[k]
                                           else np.nan),
                   "canopy_cover_pct": (100.0 * self.cells[k, 1] / self.cells[k, 0]
                                        if self.cells[k, 0] else np.nan)}
            lo = 0.0
            counts = np.histogram(h, bins=[0.0, *classes[:-1], np.inf])[0] if n else \
                np.zeros(len(classes), int)
            for hi, c in zip(classes, counts):
                row[f"trees_{lo:g}_{hi:g}m"] = int(c)
                lo = hi
            if spacing is not None:
                az = axial_mean(*zip(*self.azimuths[k])) if self.azimuths[k] else np.nan
                row.update(stocking_fields(fitted_spacing(spacing, self.spacings[k]), az,
                                           {f: self.stock[f][k] for f in STOCK}, tops=n,
                                           why=self.why.get(k)))
                for f in ("planting_positions", "stocked_positions", "suppressed_trees",
                          "missing_trees", "uncertain_positions", "extra_tops"):
                    row[f] = int(row[f])
            rows.append(row)
        return rows

    def check_cover(self, rows: list) -> None:
        """Name the stands the points leave partly or wholly uncovered, in one warning."""
        thin = [r for r in rows if not r["data_cover_pct"] >= MIN_DATA_COVER_PCT]
        if thin:
            listed = ", ".join(f"{r['stand_id']} ({r['data_cover_pct']:.0f} %)" for r in thin[:8])
            inside = sum(int(r["trees"] or 0) for r in rows)
            # stands half off the points while most trees stand outside them: the stands and
            # the points do not meet where they should (a datum, zone or -a_srs mix-up)
            shifted = (f"; and {self.outside:,} of {self.outside + inside:,} trees lie "
                       "outside every stand: are the points' CRS (-a_srs) and the stands' "
                       "the same datum and zone?") if self.outside > inside else ""
            warnings.warn(DataWarning(
                f"-stands: {len(thin)} of {len(rows)} stand(s) are less than "
                f"{MIN_DATA_COVER_PCT:g} % covered by the points: {listed}"
                f"{' ...' if len(thin) > 8 else ''}; their per-hectare figures are those of "
                f"the covered part{shifted}"), stacklevel=3)


#: what each field of the ``stands`` layer means (written as the layer's description)
FIELD_DOCS = {
    "stand_id": "the stand's id (the -stand_id field of -stands)",
    "area_ha": "the stand polygon's area (ha)",
    "data_cover_pct": "share of the stand covered by the points (cells with a canopy height)",
    "trees": "tree tops inside the stand",
    "trees_per_ha": "trees per hectare of the covered part of the stand",
    "mean_height": "mean tree height (m)", "sd_height": "standard deviation of tree heights (m)",
    "dominant_height": "dominant height (Assmann): mean height of the 100 tallest trees per "
                       "hectare (m)",
    "mean_crown_diameter": "mean crown diameter (m)",
    "canopy_cover_pct": "share of the covered part of the stand under a canopy height at or "
                        "above -min_height",
    "spacing": "planting spacing, rows x trees in a row (m; -spacing)",
    "row_azimuth": "row direction of the stand's own planting lattice (degrees from north, an "
                   "axis in [0, 180), to 0.1°)",
    "planting_positions": "positions of the stand's own planting lattice in its planted area",
    "stocked_positions": "planting positions with a tree top",
    "suppressed_trees": "planting positions without a top where a suppressed tree stands "
                        "(at least half the returns at the position at 30 % or more of the "
                        "dominant height, allowing for their number)",
    "missing_trees": "planting positions where no tree stands (the gaps layer's points of "
                     "status missing)",
    "uncertain_positions": "planting positions without a top whose returns leave it uncertain "
                           "whether a suppressed tree stands there (status uncertain: a field "
                           "check)",
    "extra_tops": "tops on a position another top already takes (forks, weeds)",
    "stocking_pct": "planting positions with a tree (a top, or a suppressed tree; an uncertain "
                    "position counts by its share of crown returns) / planting positions of "
                    "the stand's lattice",
    "stocking_pct_low": "lower end of the stocking's interval over the positions the "
                        "returns leave unresolved: every uncertain position empty and the "
                        "empty positions beyond the rows' ends missing trees at the stand's "
                        "missing share (95 %), less the 95 % spread of the missing and "
                        "suppressed calls (not of detection errors, see docs/PLANTATION.md)",
    "stocking_pct_high": "upper end of that interval: every uncertain position stocked, plus "
                         "that spread",
    "lattice": "found, or why no planting lattice was found (its stocking fields then empty)",
    "planted_per_ha": "trees planted per hectare at this spacing (10,000 / (R x C))",
    "planted_area_ha": "the stand's planted area (canopy closed over gaps, ha)",
}


def field_docs(columns) -> dict:
    """:data:`FIELD_DOCS` for the stands layer's ``columns`` (height classes and plantation
    fields included)."""
    import re

    out = {}
    for c in columns:
        m = re.fullmatch(r"trees_([0-9.]+)_([0-9.]+)m", str(c))
        if m:
            out[c] = f"trees with a height in ({m.group(1)}, {m.group(2)}] m"
        elif c in FIELD_DOCS:
            out[c] = FIELD_DOCS[c]
    return out


#: decimals of the stands table's numbers: hectares to the m², heights and diameters to the
#: cm, per-hectare figures to 0.1, percentages to 0.01, azimuths to 0.1°
STAND_DECIMALS = {"area_ha": 4, "planted_area_ha": 4, "data_cover_pct": 2,
                  "canopy_cover_pct": 2, "stocking_pct": 2, "stocking_pct_low": 2,
                  "stocking_pct_high": 2, "trees_per_ha": 1,
                  "planted_per_ha": 1, "mean_height": 2, "sd_height": 2, "dominant_height": 2,
                  "mean_crown_diameter": 2, "row_azimuth": 1}


def write_stand_csv(path, rows: list, options=None) -> None:
    """The stands' figures as a table (one row per stand, the stands layer's fields, the
    user's attributes included): CSV in the dialect of ``options`` (the locale's by default,
    see :mod:`lidartrees_gis.io.tables`), or a workbook when ``path`` ends in ``.xlsx``.
    Numbers are rounded to what they mean (:data:`STAND_DECIMALS`); ids are text."""
    from ..io.tables import write_table

    write_table(path, rows, decimals=STAND_DECIMALS, text=("stand_id",), options=options,
                name="stands")
