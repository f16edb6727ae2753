"""What dtm-quality's "good" label asks beyond seed 003's texture, so that a user can trust it
without a reference ground: pure functions over the swept DTMs (numpy arrays).

* **completeness** (seed 003's group 2, "DTMs that could not be completely generated"): at least
  :data:`MIN_GROUND_DENSITY` ground points per m² of the data's footprint (1 per 10 m²; a TIN
  of fewer bridges whole crowns and hollows) and at least :data:`MIN_COVERAGE` of the data's
  cells covered;
* **agreement**: the consensus of the sweep is the per-cell median of its complete DTMs; each
  DTM's distance to it is the median absolute difference over the data's cells. A member of the
  good texture cluster farther from the consensus than the cluster's median distance plus
  :func:`agreement_limit`'s margin is an *outlier*: smooth, but not the ground the other DTMs
  agree on (on bcts_1, three smooth DTMs 1.0-1.1 m from the consensus were 1.55-1.65 m from
  the vendor's ground, where the rest of the cluster is 0.24 m from it).
"""
from __future__ import annotations

import numpy as np

#: a complete DTM has at least this many ground points per m² of the data's footprint
MIN_GROUND_DENSITY = 0.1
#: ... and covers at least this share of the cells holding points
MIN_COVERAGE = 0.9
#: the smallest margin (m) over the good cluster's median distance to the consensus
AGREEMENT_FLOOR = 0.25
#: the margin in robust standard deviations (1.4826 MAD) of the good members' distances
AGREEMENT_SIGMAS = 3.0
#: the consensus and the distances are measured on at most this many cells (a regular sample)
SAMPLE_CELLS = 250_000


def completeness(ground_points, coverage, footprint_m2: float) -> tuple:
    """``(complete mask, ground density per m², reason per DTM)``: the reason is "" for a
    complete DTM, else one line saying which test it fails."""
    n = np.asarray(ground_points, np.float64)
    cov = np.asarray(coverage, np.float64)
    dens = n / footprint_m2 if footprint_m2 > 0 else np.zeros_like(n)
    why = []
    for k in range(n.size):
        if n[k] < 3:
            why.append(f"{int(n[k])} ground points")
        elif dens[k] < MIN_GROUND_DENSITY:
            why.append(f"{dens[k]:.3g} ground points per m² ({int(n[k])}; at least "
                       f"{MIN_GROUND_DENSITY:g} needed, 1 per 10 m²)")
        elif cov[k] < MIN_COVERAGE:
            why.append(f"covers {100 * cov[k]:.0f} % of the data's cells "
                       f"({100 * MIN_COVERAGE:.0f} % needed)")
        else:
            why.append("")
    return np.array([w == "" for w in why]), dens, why


def sample_cells(footprint, limit: int = SAMPLE_CELLS) -> np.ndarray:
    """Flat indices of at most ``limit`` cells of the footprint, evenly spread."""
    idx = np.flatnonzero(np.asarray(footprint, bool))
    if idx.size > limit:
        idx = idx[np.linspace(0, idx.size - 1, limit).astype(np.int64)]
    return idx


def consensus_distances(dtms, complete, footprint) -> np.ndarray:
    """Each DTM's median absolute difference (m) to the consensus, the per-cell median of the
    complete DTMs, over a sample of the footprint's cells (:func:`sample_cells`); NaN for a DTM
    sharing no cell with it. ``dtms``: a list of 2-D arrays (memory-mapped ones are read only
    at the sampled cells)."""
    idx = sample_cells(footprint)
    vals = np.full((len(dtms), idx.size), np.nan, np.float32)
    for k, d in enumerate(dtms):
        vals[k] = np.asarray(d).ravel()[idx] if idx.size else []
    ok = np.asarray(complete, bool)
    out = np.full(len(dtms), np.nan)
    if not ok.any() or idx.size == 0:
        return out
    import warnings

    with warnings.catch_warnings():  # cells no complete DTM covers: NaN, left out below
        warnings.simplefilter("ignore", RuntimeWarning)
        cons = np.nanmedian(vals[ok], axis=0)
    for k in range(len(dtms)):
        e = np.abs(vals[k] - cons)
        e = e[np.isfinite(e)]
        if e.size:
            out[k] = float(np.median(e))
    return out


def agreement_limit(distances) -> float:
    """The largest distance to the consensus a good member may have: the members' median plus
    the larger of :data:`AGREEMENT_FLOOR` and :data:`AGREEMENT_SIGMAS` robust standard
    deviations of their distances (the median holds at least half of the members in)."""
    d = np.asarray(distances, np.float64)
    d = d[np.isfinite(d)]
    if d.size == 0:
        return float("inf")
    med = float(np.median(d))
    mad = float(np.median(np.abs(d - med))) * 1.4826
    return med + max(AGREEMENT_FLOOR, AGREEMENT_SIGMAS * mad)
