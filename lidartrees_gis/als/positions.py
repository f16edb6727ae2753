"""What stands at each planting position of a plantation: a lattice fitted per stand
(:func:`stocking_by_stand`) and each empty position told apart as holding a suppressed tree or
none (:func:`classify_gaps`)."""
from __future__ import annotations

import numpy as np

from .stocking import fit_planting_grid, stand_mask, stocking


#: a stand with fewer tops than this in a tile (with its buffer) takes the lattice fitted to all
#: the tile's tops instead of its own (a corner of a stand)
STAND_FIT_MIN_TOPS = 30


def stocking_by_stand(top_x, top_y, chm, spec, spacing, zone, *, min_height: float = 2.0,
                      grid: PlantingGrid | None = None, within=None) -> dict:
    """:func:`stocking` with a planting lattice fitted per stand.

    ``zone``: the stand index of every cell of ``spec`` (-1 outside every stand; see
    :func:`lidartrees_gis.als.stands.zones`), or None for one stand. Each stand's positions are
    those of the lattice fitted to the tops inside it (:data:`STAND_FIT_MIN_TOPS`), in its part
    of the planted area; the cells outside every stand are one more zone, so the sums over the
    zones are the whole tile's. Returns :func:`stocking`'s dict (counts summed, gaps and the
    tops' row and plant numbers of every zone) with ``gaps_zone`` and ``zones`` (per zone
    index: ``expected, stocked, missing, extra, planted_area_ha, azimuth``); ``grid`` is the
    lattice of the zone with the most positions.
    """
    R, C = spacing
    tx, ty = np.asarray(top_x, float), np.asarray(top_y, float)
    if zone is None or not (np.asarray(zone) >= 0).any():
        st = stocking(tx, ty, chm, spec, spacing, min_height=min_height, grid=grid,
                      within=within)
        st["gaps_zone"] = np.full(st["gaps_x"].size, -1, np.int64)
        st["zones"] = {-1: {**{k: st[k] for k in ("expected", "stocked", "missing", "extra",
                                                  "planted_area_ha")},
                            "azimuth": st["grid"].azimuth}}
        return st
    zone = np.asarray(zone)
    planted = stand_mask(chm, spec.res, R, C, min_height=min_height)
    r, c = spec.cell_index(tx, ty)
    inside = (r >= 0) & (r < spec.height) & (c >= 0) & (c < spec.width)
    top_zone = np.full(tx.size, -1, np.int64)
    top_zone[inside] = zone[r[inside], c[inside]]
    whole = [grid]

    def tile_grid():
        if whole[0] is None:
            whole[0] = fit_planting_grid(tx, ty, R, C)
        return whole[0]

    parts = {}
    for k in np.unique(zone[planted]).tolist():
        own = top_zone == k
        g = fit_planting_grid(tx[own], ty[own], R, C) if own.sum() >= STAND_FIT_MIN_TOPS \
            else tile_grid()
        parts[k] = stocking(tx, ty, chm, spec, spacing, min_height=min_height, grid=g,
                            within=within, planted=planted & (zone == k), own=own)
    if not parts:  # nothing planted: the whole tile's empty answer
        return stocking_by_stand(tx, ty, chm, spec, spacing, None, min_height=min_height,
                                 grid=grid, within=within)
    main = max(parts.values(), key=lambda p: p["expected"])
    out = {k: sum(p[k] for p in parts.values()) for k in ("expected", "stocked", "missing",
                                                           "extra", "planted_area_ha")}
    cat = {k: np.concatenate([p[k] for p in parts.values()])
           for k in ("gaps_x", "gaps_y", "gaps_i", "gaps_j", "gaps_row", "gaps_plant")}
    tops_row = np.zeros(tx.size, np.int64)
    tops_plant = np.zeros(tx.size, np.int64)
    for p in parts.values():
        took = p["tops_row"] > 0
        tops_row[took], tops_plant[took] = p["tops_row"][took], p["tops_plant"][took]
    e = out["expected"]
    out.update(cat, grid=main["grid"], numbering=main["numbering"], tops_row=tops_row,
               tops_plant=tops_plant, planted_per_ha=1e4 / (R * C),
               stocking_pct=100.0 * out["stocked"] / e if e else float("nan"),
               gaps_zone=np.concatenate([np.full(p["gaps_x"].size, k, np.int64)
                                         for k, p in parts.items()]),
               zones={k: {**{f: p[f] for f in ("expected", "stocked", "missing", "extra",
                                               "planted_area_ha")},
                          "azimuth": p["grid"].azimuth} for k, p in parts.items()})
    return out


#: an empty planting position holds a suppressed tree when at least :data:`SUPPRESSED_SHARE`
#: of the returns within :data:`SUPPRESSED_REACH` x the smaller spacing of it lie at or above
#: :data:`SUPPRESSED_HEIGHT` x the dominant height: a crown stands at the position, under or
#: beside its neighbours' (the ground or a shrub of a missing tree's position does not reach
#: that height). Measured on benchmarks/_family.py (a generator apart from the package's):
#: 428 of 446 suppressed trees kept, 25 of 460 missing positions taken for one
SUPPRESSED_HEIGHT = 0.3
SUPPRESSED_SHARE = 0.5
SUPPRESSED_REACH = 0.25
#: fewer returns than this within the reach: it grows to :data:`SUPPRESSED_WIDE` spacings
SUPPRESSED_MIN_RETURNS = 4
SUPPRESSED_WIDE = 0.4


def suppressed_at(gaps_x, gaps_y, points, spacing, dominant_height: float,
                  min_height: float = 2.0) -> np.ndarray:
    """Which empty planting positions hold a suppressed tree (see :data:`SUPPRESSED_SHARE`).

    Parameters
    ----------
    gaps_x, gaps_y : (N,) array_like
        Planting positions with no top.
    points : tuple of arrays
        ``(x, y, height above ground)`` of every return near them (all returns: a suppressed
        crown is seen by the pulses that pass the canopy).
    spacing : (float, float)
    dominant_height : float
        The stand's dominant height (m); a suppressed tree reaches at least
        ``SUPPRESSED_HEIGHT`` of it (and ``min_height``).
    """
    from scipy.spatial import cKDTree

    gx, gy = np.asarray(gaps_x, float), np.asarray(gaps_y, float)
    out = np.zeros(gx.size, bool)
    if not gx.size or points is None or not len(points[0]):
        return out
    px, py, ph = (np.asarray(a) for a in points)
    thr = max(float(min_height), SUPPRESSED_HEIGHT * float(dominant_height))
    # only the points near a position matter: the tree of a tile's points is built once
    tree = cKDTree(np.c_[px, py])
    near = tree.query_ball_point(np.c_[gx, gy], SUPPRESSED_WIDE * min(spacing))
    r2 = (SUPPRESSED_REACH * min(spacing)) ** 2
    for k, idx in enumerate(near):
        if not idx:
            continue
        idx = np.asarray(idx)
        d2 = (px[idx] - gx[k]) ** 2 + (py[idx] - gy[k]) ** 2
        close = idx[d2 <= r2]
        use = close if close.size >= SUPPRESSED_MIN_RETURNS else idx
        out[k] = np.mean(ph[use] >= thr) >= SUPPRESSED_SHARE
    return out


def classify_gaps(st: dict, points, spacing, dominant_height: float,
                  min_height: float = 2.0) -> dict:
    """:func:`stocking`'s (or :func:`stocking_by_stand`'s) result with each empty position
    classified (``gaps_status``: 1 suppressed, 0 missing): ``missing`` counts only the
    missing ones, ``suppressed`` the others, per zone too, and ``stocking_pct`` takes the
    suppressed trees as stocking their positions."""
    sup = suppressed_at(st["gaps_x"], st["gaps_y"], points, spacing, dominant_height,
                        min_height)
    st = dict(st)
    st["gaps_status"] = sup.astype(np.int8)
    st["suppressed"] = int(sup.sum())
    st["missing"] = int(st["missing"]) - st["suppressed"]
    e = st["expected"]
    st["stocking_pct"] = 100.0 * (st["stocked"] + st["suppressed"]) / e if e else float("nan")
    if "zones" in st:
        zones = {}
        gz = np.asarray(st.get("gaps_zone", np.full(sup.size, -1)))
        for k, z in st["zones"].items():
            n = int(sup[gz == k].sum())
            zones[k] = {**z, "suppressed": n, "missing": int(z["missing"]) - n}
        st["zones"] = zones
    return st
