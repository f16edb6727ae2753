"""Plantation mode's summary fields: the counts a run sums over its tiles, the stocking with its
interval over the unresolved positions (or why there is none), and the row azimuths and
spacings a summary reports."""
from __future__ import annotations

import numpy as np

#: a planting lattice is recognised under at least this many tops
PLANTING_MIN_TREES = 100

#: the plantation counts a run sums over its tiles (per area and per stand), read by
#: :func:`stocking_fields`
STOCK_COUNTS = ("expected", "stocked", "suppressed", "missing", "missing_crowned", "uncertain",
                "uncertain_stocked", "stocked_var", "resolved_var", "edge_unresolved", "extra",
                "planted_area_ha")


#: the stocking interval's standard normal quantile (95 %)
STOCKING_Z = 1.959964


def stocking_fields(spacing, azimuth: float, st: dict, *, tops: int | None = None,
                    why: str | None = None) -> dict:
    """The summary fields of plantation mode from the counts of
    :func:`lidartrees_gis.plantation.stocking.stocking` (``expected, stocked, missing, extra,
    planted_area_ha``, and :func:`lidartrees_gis.plantation.status.classify_gaps`'s
    ``suppressed, uncertain, uncertain_stocked, missing_crowned, resolved_var,
    edge_unresolved``; summed over the tiles).

    ``stocking_pct_low``, ``stocking_pct_high``: its interval over the positions the returns
    could not resolve: the stocking were every uncertain position empty and the empty
    positions just beyond the rows' ends and a row's positions in the band along the data's
    edge (``edge_unresolved``) missing trees as far as :func:`edge_missing` allows, and as
    many stocked positions a neighbour's crown over a missing tree as :func:`second_tops`
    allows, and were
    every uncertain position stocked and every missing
    call with a return at crown height near it (``missing_crowned``: a small tree under its
    neighbours' crowns is not ruled out there) a tree; each end widened by the 95 % spread
    of the missing and suppressed calls (``resolved_var``), clipped to what the positions
    allow. With no lattice (``spacing`` None: ``-spacing auto`` found none) the
    stocking fields are empty (None) and ``lattice`` says why (``why``, when given: the
    canopy shows rows but no plants along them); ``tops``: the tree tops the lattice was
    looked for under."""
    e = st["expected"]
    sup = st.get("suppressed", 0)
    unc = st.get("uncertain_stocked", 0.0)
    if spacing is None or not e:  # -spacing auto and no lattice found, or no position
        if spacing is None:
            why = ("no planting lattice: no tree top in it" if tops == 0 else
                   f"no planting lattice: {tops} tops, fewer than the {PLANTING_MIN_TREES} "
                   "needed" if tops is not None and tops < PLANTING_MIN_TREES else why or
                   "no planting lattice: the tops lie in no rows of one direction and spacing")
        else:
            why = "no planting position in the planted area"
        return {"lattice": why, "spacing": None, "row_azimuth": None,
                "planting_positions": 0, "stocked_positions": 0, "suppressed_trees": 0,
                "missing_trees": 0, "uncertain_positions": 0, "extra_tops": 0,
                "stocking_pct": None, "stocking_pct_low": None, "stocking_pct_high": None,
                "planted_per_ha": None, "planted_area_ha": st.get("planted_area_ha", 0.0)}
    sure = st["stocked"] + sup
    point = sure + unc
    # every way the uncertain positions could go (each empty, each stocked), and as many
    # positions beyond the rows' ends planted and missing as the stand's missing share allows,
    # and as many stocked positions empty as its extra tops allow (:func:`second_tops`);
    # widened by the 95 % spread of the missing and suppressed calls
    half = STOCKING_Z * float(np.sqrt(max(st.get("resolved_var", 0.0), 0.0)))
    low = min(max(sure - half - second_tops(st), 0.0) * e / (e + edge_missing(st)), point)
    high = max(min(sure + st.get("uncertain", 0) + st.get("missing_crowned", 0) + half,
                   float(e)), point)
    return {"lattice": "found",
            "spacing": f"{spacing[0]:g}x{spacing[1]:g}", "row_azimuth": axial_round(azimuth),
            "planting_positions": e, "stocked_positions": st["stocked"],
            "suppressed_trees": sup, "missing_trees": st["missing"],
            "uncertain_positions": st.get("uncertain", 0), "extra_tops": st["extra"],
            # an uncertain position (a field check) counts by its share of crown returns
            "stocking_pct": 100.0 * point / e,
            "stocking_pct_low": 100.0 * low / e, "stocking_pct_high": 100.0 * high / e,
            "planted_per_ha": 1e4 / (spacing[0] * spacing[1]),
            "planted_area_ha": st["planted_area_ha"]}


def edge_missing(st: dict) -> float:
    """How many of the empty positions just beyond the rows' ends and of the rows' positions
    along the data's edge (``edge_unresolved``: a missing tree at a row's end, or no planting;
    a crown the data's edge cuts) may be missing trees: the upper end of a 95 %
    interval of a binomial count at the stand's share of missing positions (a tree at a row's
    end is as likely to be missing as any other), at most all of them."""
    n = float(st.get("edge_unresolved", 0))
    e = float(st.get("expected", 0))
    if n <= 0 or e <= 0:
        return 0.0
    from scipy.stats import binom

    m = min(max((st.get("missing", 0) + st.get("uncertain", 0)) / e, 0.0), 1.0)
    return float(binom.ppf(0.975, int(n), m))


def second_tops(st: dict) -> float:
    """How many stocked positions may hold no tree of their own but a second top of a
    neighbour's crown grown over a missing tree: the upper end of a 95 % Poisson interval of
    the count of tops that share a position with a nearer one (``extra``: crowns seen with a
    second top where a neighbour stands). The returns cannot tell such a top from a tree's;
    on the third stand family the tops at missing positions were 0.3-1.7 times the extra tops
    of their stand (docs/plantation3.md)."""
    n = float(st.get("extra", 0))
    if n <= 0:
        return 0.0
    from scipy.stats import poisson

    return float(poisson.ppf(0.975, n))


def axial_round(azimuth, ndigits: int = 1) -> float:
    """A row azimuth as every output reports it: an axis (rows at 0° and 180° are the same
    rows) in [0, 180), rounded to ``ndigits`` (the lattice fit's 0.05° step) before it is
    brought into the range, so rows at 179.96° read 0.0 as rows at 0.01° do, never 180.0."""
    a = float(azimuth)
    if not np.isfinite(a):
        return float("nan")
    return round(a % 180.0 + 1e-9, ndigits) % 180.0 + 0.0  # half up: 179.95 reads 0.0


def axial_mean(azimuths, weights=None) -> float:
    """The mean of row azimuths (degrees, an axis: 0 and 180 are the same rows) weighted by
    ``weights``, in [0, 180). A median or plain mean of tiles at 179.9 and 0.1 gave 90."""
    a = np.radians(2.0 * np.asarray(azimuths, float))
    w = np.ones_like(a) if weights is None else np.asarray(weights, float)
    if not np.isfinite(a).any() or w.sum() <= 0:
        return float("nan")
    ok = np.isfinite(a)
    ang = 0.5 * np.degrees(np.arctan2((w[ok] * np.sin(a[ok])).sum(), (w[ok] * np.cos(a[ok])).sum()))
    return round(float(ang % 180.0), 3) % 180.0


def fitted_spacing(spacing, found: list):
    """The spacing a summary reports: the one given, or with ``-spacing auto`` the one found
    under the most planting positions (``found``: ``[(spacing, positions), ...]``)."""
    if isinstance(spacing, tuple):
        return spacing
    if not found:
        return None
    best = {}
    for sp, n in found:
        key = (round(sp[0], 2), round(sp[1], 2))
        best[key] = best.get(key, 0) + n
    return max(best, key=best.get)
