"""Field plots (parcelas): polygons, or centres with a radius, and which returns they hold.

:func:`load_plots` reads a plot layer as companies keep it (any OGR source: a polygon per plot,
or a point per plot centre and ``-plot_radius``), brings it into the points' CRS and gives each
plot its id. :meth:`Plots.members` says which plot each return lies in: a circular plot holds
the returns with ``(x - xc)² + (y - yc)² <= r²`` (lidR's ``clip_circle``), a polygon the returns
inside it (``shapely.contains_xy``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import CRSError, InputError
from ..io.names import plain

#: the plot id field looked for when ``-plot_id`` is not given (case and accents ignored)
PLOT_ID_FIELDS = ("plot_id", "parcela", "id_parcela", "cod_parcela", "num_parcela", "plot",
                  "idpep", "id", "name", "nome")


@dataclass(frozen=True)
class Plots:
    """Field plots in the points' CRS.

    Attributes
    ----------
    ids : tuple of str
    geoms : ndarray of shapely polygons
        Each plot's area (a circle as a 64-sided polygon for the output layer).
    x, y, radius : ndarray
        Circle centres and radii (NaN radius: a polygon plot).
    attrs : pandas.DataFrame
        The layer's other fields, one row a plot.
    source : str
    """

    ids: tuple
    geoms: np.ndarray
    x: np.ndarray
    y: np.ndarray
    radius: np.ndarray
    attrs: object
    source: str = ""

    def __len__(self) -> int:
        return len(self.ids)

    @property
    def area_m2(self) -> np.ndarray:
        import shapely

        circ = np.isfinite(self.radius)
        return np.where(circ, np.pi * np.nan_to_num(self.radius) ** 2, shapely.area(self.geoms))

    @property
    def bounds(self) -> np.ndarray:
        import shapely

        return shapely.bounds(self.geoms)

    @property
    def zones(self) -> "Zones":
        return Zones(self.geoms, self.x, self.y, self.radius)


@dataclass(frozen=True)
class Zones:
    """Areas whose returns are grouped (plots, stands): polygons, and for circles their centre
    and radius (NaN radius: the polygon). What a tile gets (light to send to a worker)."""

    geoms: np.ndarray
    x: np.ndarray
    y: np.ndarray
    radius: np.ndarray

    @classmethod
    def of_polygons(cls, geoms) -> "Zones":
        n = len(geoms)
        return cls(np.asarray(geoms, dtype=object), *(np.full(n, np.nan) for _ in range(3)))

    def __len__(self) -> int:
        return len(self.geoms)

    def pairs(self, x, y) -> tuple:
        """``(point index, zone index)`` of every return in every zone (a return in two
        overlapping plots belongs to both)."""
        import shapely

        x, y = np.asarray(x, np.float64), np.asarray(y, np.float64)
        b = shapely.bounds(self.geoms)
        pi, zi = [], []
        # many zones (the pieces of cells stand borders cut): each looks only at the returns
        # of its own strip of x
        order = np.argsort(x, kind="stable") if len(self.geoms) > 16 else None
        if order is not None:
            xs = x[order]
            lo = np.searchsorted(xs, b[:, 0] - 1e-6, "left")
            hi = np.searchsorted(xs, b[:, 2] + 1e-6, "right")
        for k in range(len(self.geoms)):
            if order is None:
                near = np.flatnonzero((x >= b[k, 0] - 1e-6) & (x <= b[k, 2] + 1e-6)
                                      & (y >= b[k, 1] - 1e-6) & (y <= b[k, 3] + 1e-6))
            else:
                near = np.sort(order[lo[k]:hi[k]])
                near = near[(y[near] >= b[k, 1] - 1e-6) & (y[near] <= b[k, 3] + 1e-6)]
            if near.size == 0:
                continue
            if np.isfinite(self.radius[k]):
                dx, dy = x[near] - self.x[k], y[near] - self.y[k]
                inside = dx * dx + dy * dy <= self.radius[k] ** 2
            else:
                inside = shapely.contains_xy(self.geoms[k], x[near], y[near])
            pi.append(near[inside])
            zi.append(np.full(int(inside.sum()), k, np.int64))
        if not pi:
            return np.empty(0, np.int64), np.empty(0, np.int64)
        return np.concatenate(pi), np.concatenate(zi)

    def members(self, x, y) -> np.ndarray:
        """The zone index of each return (-1: in none; the first zone where zones overlap)."""
        out = np.full(np.asarray(x).size, -1, np.int64)
        pi, zi = self.pairs(x, y)
        out[pi[::-1]] = zi[::-1]  # the first zone wins
        return out

    def counts(self, x, y, weights=None) -> np.ndarray:
        """Per zone, the returns (or the sum of ``weights``) inside it."""
        pi, zi = self.pairs(x, y)
        w = None if weights is None else np.asarray(weights, float)[pi]
        return np.bincount(zi, weights=w, minlength=len(self.geoms)).astype(float)


def _ids(gdf, id_field, name: str):
    cols = [c for c in gdf.columns if c != gdf.geometry.name]
    if id_field:
        match = [c for c in cols if plain(c) == plain(id_field)]
        if not match:
            raise InputError(f"-plot_id: {name} has no field {id_field!r} (fields: "
                             f"{', '.join(map(str, cols)) or 'none'})")
        col = match[0]
    else:
        by_plain = {plain(c): c for c in cols}
        col = next((by_plain[f] for f in PLOT_ID_FIELDS if f in by_plain), None)
    if col is None:
        return [str(i + 1) for i in range(len(gdf))]
    vals = [str(int(v)) if isinstance(v, float) and float(v).is_integer() else str(v).strip()
            for v in gdf[col].tolist()]
    dup = sorted({v for v in vals if vals.count(v) > 1})
    if dup:
        raise InputError(f"PLOTS: {name}: plot id {dup[0]!r} ({col}) given to "
                         f"{vals.count(dup[0])} plots; each plot needs its own id")
    return vals


def load_plots(source, crs=None, *, plot_id: str | None = None,
               plot_radius: float | None = None) -> Plots:
    """Read field plots and bring them into ``crs`` (the points').

    Parameters
    ----------
    source : str, Path or GeoDataFrame
        ``PATH`` or ``PATH:LAYER`` of a polygon layer, or of a point layer of plot centres.
    crs : pyproj.CRS, optional
        The points' CRS; plots in another CRS are reprojected, plots without a CRS refused
        (a plot a few metres off takes other trees).
    plot_id : str, optional
        The id field; default the first of :data:`PLOT_ID_FIELDS` present, else 1, 2, ...
    plot_radius : float, optional
        Radius (m) of the circular plots of a point layer (required for one).
    """
    import shapely

    if hasattr(source, "geometry"):
        gdf, name = source, "GeoDataFrame"
    else:
        from ..io.vector import read_polygons

        gdf, name = read_polygons(source, param="PLOTS")
    gdf = gdf[~(gdf.geometry.isna() | gdf.geometry.is_empty)]
    if len(gdf) == 0:
        raise InputError(f"PLOTS: {name} has no plot with a geometry")
    if crs is None and gdf.crs is not None:
        from ..crs import crs_label

        raise InputError(f"PLOTS: {name} is in {crs_label(gdf.crs)} and the points have no "
                         "CRS (an XYZ file?): give theirs (-a_srs, a_srs=) so that the plots "
                         "can be placed on them")
    if crs is not None:
        if gdf.crs is None:
            raise CRSError(f"PLOTS: {name} has no CRS; give the layer its CRS (the points' are "
                           f"{crs.to_string() if hasattr(crs, 'to_string') else crs})")
        if not gdf.crs.equals(crs):
            from ..crs import check_coordinates

            check_coordinates(gdf.crs, gdf.total_bounds, f"PLOTS: {name}", layer=True)
            gdf = gdf.to_crs(crs)
    ids = _ids(gdf, plot_id, name)
    kinds = set(gdf.geom_type)
    n = len(gdf)
    if kinds <= {"Point"}:
        if plot_radius is None:
            raise InputError(f"PLOTS: {name} holds plot centres (points): give -plot_radius "
                             "(e.g. 11.28 for 400 m² circular plots)")
        if not plot_radius > 0:
            raise InputError(f"-plot_radius must be > 0 m, got {plot_radius!r} (e.g. 11.28 for "
                             "400 m² circular plots)")
        x = np.asarray(gdf.geometry.x, np.float64)
        y = np.asarray(gdf.geometry.y, np.float64)
        radius = np.full(n, float(plot_radius))
        geoms = shapely.buffer(shapely.points(x, y), radius, quad_segs=16)
    elif kinds <= {"Polygon", "MultiPolygon"}:
        if plot_radius is not None:
            import warnings

            from ..errors import DataWarning

            warnings.warn(DataWarning(f"-plot_radius {plot_radius:g} ignored: PLOTS {name} holds "
                                      "polygons, whose own areas are the plots'"), stacklevel=2)
        geoms = np.asarray(shapely.make_valid(np.asarray(gdf.geometry.values, dtype=object)))
        x = y = radius = np.full(n, np.nan)
        small = shapely.area(geoms) <= 0
        if small.any():
            raise InputError(f"PLOTS: {name}: plot {ids[int(np.flatnonzero(small)[0])]} has no "
                             "area")
    else:
        raise InputError(f"PLOTS: {name}: expected polygons or points, got "
                         f"{', '.join(sorted(kinds))}")
    attrs = gdf.drop(columns=gdf.geometry.name).reset_index(drop=True)
    return Plots(tuple(ids), geoms, x, y, radius, attrs, name)


def warn_overlaps(plots: Plots) -> int:
    """Warn (one line naming the first pairs) when plots overlap: their trees are counted in
    both, and two plots in one place weigh a stand twice. Returns the number of pairs."""
    import shapely

    g = np.asarray(plots.geoms)
    if g.size < 2:
        return 0
    i, j = shapely.STRtree(g).query(g, predicate="intersects")
    keep = i < j
    i, j = i[keep], j[keep]
    if i.size:
        keep = shapely.area(shapely.intersection(g[i], g[j])) > 0
        i, j = i[keep], j[keep]
    if i.size:
        import warnings

        from ..errors import DataWarning, listing

        warnings.warn(DataWarning(
            f"PLOTS: {plots.source}: {i.size} pair(s) of plots overlap "
            f"({listing([f'{plots.ids[a]} and {plots.ids[b]}' for a, b in zip(i, j)], 3)}): "
            "their trees count in both, and the stands' intervals come out too narrow"),
            stacklevel=2)
    return int(i.size)


def check_inside(plots: Plots, extent, label: str) -> None:
    """Refuse plots lying outside the points' extent (one line naming the first ones)."""
    x0, y0, x1, y1 = extent
    b = plots.bounds
    out = (b[:, 0] < x0 - 1e-6) | (b[:, 1] < y0 - 1e-6) | (b[:, 2] > x1 + 1e-6) | \
        (b[:, 3] > y1 + 1e-6)
    if out.any():
        from ..errors import listing

        names = [plots.ids[i] for i in np.flatnonzero(out)]
        raise InputError(f"PLOTS: {plots.source}: {int(out.sum())} of {len(plots)} plots lie "
                         f"outside the points, wholly or in part, of {label} (x {x0:.0f}.."
                         f"{x1:.0f}, y {y0:.0f}..{y1:.0f}): {listing(names)}; check the CRS and "
                         "-plot_radius, or drop them")
