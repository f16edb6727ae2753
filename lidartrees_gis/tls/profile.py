"""Roots / stem / canopy segmentation of one tree from its point-density profile (Queiroz 2017,
seed 002).

1. z_n = z - z_min; horizontal slices of ``bin`` metres; point count per slice.
2. Gaussian smoothing of the counts with sigma in metres (0.3 m was best in the seed).
3. Second derivative by finite differences: forward at the first slice, central inside,
   backward at the end (seed 002, step 4).
4. Zero crossings of the second derivative, going up from the ground: the first is the tree
   start, the second the end of the prop roots and start of the stem, the next the end of the
   stem and start of the canopy (concave parts, d2 < 0, are roots and canopy; the stem is convex).

Two rules place the boundaries (``rule``):

* ``queiroz``, the seed's ordinal rule as written: the 1st, 2nd and 3rd crossings going up are
  the tree start, the stem start and the canopy start, whatever their direction. On real trees
  scanned through leaves and understorey the density profile of the lower stem is noisy and the
  3rd crossing lands within a few metres of the ground (0.9-2.0 m on trees whose crown starts at
  13-19 m).
* ``spread`` (default): the stem start as the first crossing from concave to convex (- to +),
  with a root zone when a concave stretch precedes it (the seed's Avicennia has none, and points
  below the stem start are then stem); the canopy start where the tree's horizontal spread
  leaves the stem's (:func:`crown_base`): the lowest slice above breast height from which the
  points lie farther from the slice's centre than :data:`SPREAD_FACTOR` times the stem's spread
  (on the narrowest metre between 0.5 and 3 m, so that a 6 m sapling whose crown starts at
  1.5-2 m keeps its crown out of the stem's measure) and :data:`SPREAD_MIN` m more, over the
  next metre. This is where the first branches start, the boundary the seed's inflection marks
  on a clean profile.
"""
from __future__ import annotations

import numpy as np
from scipy.ndimage import gaussian_filter1d

from ..bounds import check_number
from ..errors import InputError

ROOTS, STEM, CANOPY = 1, 2, 3
PART_NAMES = {ROOTS: "roots", STEM: "stem", CANOPY: "canopy"}


def second_derivative(f, h: float) -> np.ndarray:
    """Second derivative of samples ``f`` spaced ``h``: forward differences at the start,
    central inside, backward at the end."""
    f = np.asarray(f, dtype=np.float64)
    n = f.size
    d2 = np.zeros(n)
    if n < 3:
        return d2
    d2[1:-1] = f[2:] - 2 * f[1:-1] + f[:-2]
    d2[0] = f[2] - 2 * f[1] + f[0]
    d2[-1] = f[-1] - 2 * f[-2] + f[-3]
    return d2 / (h * h)


def zero_crossings(d2, z):
    """Heights where ``d2`` changes sign (linear interpolation) and the direction (+1 for - to
    +, -1 for + to -). Exact zeros join the following sign."""
    s = np.sign(d2)
    for i in range(s.size - 2, -1, -1):  # zeros take the next sign
        if s[i] == 0:
            s[i] = s[i + 1]
    out = []
    for i in range(s.size - 1):
        if s[i] != 0 and s[i + 1] != 0 and s[i] != s[i + 1]:
            t = d2[i] / (d2[i] - d2[i + 1])
            out.append((float(z[i] + t * (z[i + 1] - z[i])), int(np.sign(s[i + 1]))))
    return out


#: the most slices a profile is cut into (the counts and their smoothing are arrays of it)
MAX_BINS = 2_000_000


def density_profile(z, *, bin: float = 0.05, sigma: float = 0.3):  # noqa: A002 - seed's name
    """Counts per slice, smoothed counts and second derivative. Returns a dict with ``z`` (slice
    centres above z_min), ``counts``, ``smooth``, ``d2``."""
    check_number("-bin", bin, "m")
    check_number("-sigma", sigma, "m")
    if not 0 < bin <= 5:
        raise InputError(f"-bin must be > 0 and <= 5 m, got {bin}")
    if not 0 < sigma <= 10:
        raise InputError(f"-sigma must be > 0 and <= 10 m, got {sigma}")
    z = np.asarray(z, dtype=np.float64)
    if z.size < 10:
        raise InputError(f"profile: {z.size} points; too few for a profile")
    zn = z - z.min()
    nb = int(np.floor(zn.max() / bin)) + 1
    if nb > MAX_BINS:
        raise InputError(f"-bin {bin:g} m makes {nb:,} slices over the {zn.max():.1f} m of the "
                         f"points' heights, more than {MAX_BINS:,}; give a larger -bin")
    counts = np.bincount(np.minimum((zn / bin).astype(np.int64), nb - 1), minlength=nb).astype(float)
    smooth = gaussian_filter1d(counts, sigma / bin, mode="constant", cval=0.0)
    return {"z": (np.arange(nb) + 0.5) * bin, "counts": counts, "smooth": smooth,
            "d2": second_derivative(smooth, bin), "bin": bin, "sigma": sigma}


#: ``rule="spread"``: a slice is crown when its spread is this many times the stem's ...
SPREAD_FACTOR = 3.0
#: ... and at least this much more (m)
SPREAD_MIN = 0.25
RULES = ("spread", "queiroz")


def slice_spread(x, y, z, *, bin: float = 0.25):  # noqa: A002
    """Horizontal spread per slice: the 90th percentile of the points' distances to the slice's
    median position (m; NaN for slices of fewer than 5 points). Returns (slice centres above
    z_min, spread)."""
    x, y, z = (np.asarray(a, np.float64) for a in (x, y, z))
    zn = z - z.min()
    k = np.minimum((zn / bin).astype(np.int64), int(zn.max() / bin))
    order = np.argsort(k, kind="stable")
    k, xs, ys = k[order], x[order], y[order]
    nb = int(k[-1]) + 1
    spread = np.full(nb, np.nan)
    starts = np.searchsorted(k, np.arange(nb + 1))
    for i in range(nb):
        a, b = starts[i], starts[i + 1]
        if b - a >= 5:
            d = np.hypot(xs[a:b] - np.median(xs[a:b]), ys[a:b] - np.median(ys[a:b]))
            spread[i] = np.percentile(d, 90)
    return (np.arange(nb) + 0.5) * bin, spread


#: ``rule="spread"``: a stem spreads less than this (m, the 90th percentile distance of a
#: 1.2 m thick stem); a tree wider on every metre between 0.5 and 3 m has branches there (a
#: spruce)
STEM_MAX = 0.6


#: ``rule="spread"``: the stem's spread is measured on 1 m of slices between these heights (m)
STEM_ZONE = (0.5, 3.0)


def stem_spread(zc, sp, bin: float):  # noqa: A002
    """The stem's spread: the smallest median spread of 1 m of consecutive slices lying between
    :data:`STEM_ZONE` (the narrowest metre of the lower bole, so that the crown of a short tree
    starting at 1.5-2 m does not count as stem, nor a flare at the ground). None when no such
    metre has a measured slice."""
    run = max(1, int(round(1.0 / bin)))
    lo, hi = STEM_ZONE
    best = None
    for i in range(zc.size):
        if zc[i] - bin / 2 < lo - 1e-9:
            continue
        if zc[i] - bin / 2 + run * bin > hi + 1e-9:
            break
        w = sp[i:i + run]
        w = w[np.isfinite(w)]
        if w.size * 2 >= run:
            m = float(np.median(w))
            best = m if best is None else min(best, m)
    return best


def crown_base(x, y, z, *, bin: float = 0.25, factor: float = SPREAD_FACTOR,  # noqa: A002
               minimum: float = SPREAD_MIN):
    """Height above z_min where the crown begins: the lowest slice above 1.3 m from which at
    least half of the slices of the next metre (itself included) spread more than
    ``max(factor * s0, s0 + minimum)``, s0 the stem's spread (:func:`stem_spread`: the
    narrowest metre between 0.5 and 3 m). When s0 is over :data:`STEM_MAX` the tree has
    branches there: the lowest slice from which the next metre spreads more than that. None
    when no slice does (a bare pole)."""
    zc, sp = slice_spread(x, y, z, bin=bin)
    s0 = stem_spread(zc, sp, bin)
    if s0 is None:
        return None
    if s0 > STEM_MAX:
        wide, above = np.nan_to_num(sp, nan=0.0) > STEM_MAX, 0.0
    else:
        wide, above = np.nan_to_num(sp, nan=0.0) > max(factor * s0, s0 + minimum), 1.3
    run = max(1, int(round(1.0 / bin)))
    for i in np.nonzero(wide & (zc > above))[0]:
        if wide[i:i + run].sum() * 2 >= min(run, wide.size - i):
            return float(zc[i] - bin / 2)
    return None


def segment_profile(z, *, bin: float = 0.05, sigma: float = 0.3, rule: str = "spread",  # noqa: A002
                    x=None, y=None) -> dict:
    """Boundaries (metres above z_min) and a label per point (1 roots, 2 stem, 3 canopy) by
    ``rule`` (see the module's text; ``spread`` needs ``x`` and ``y``)."""
    if rule not in RULES:
        raise InputError(f"-rule: expected {' or '.join(RULES)}, got {rule!r}")
    prof = density_profile(z, bin=bin, sigma=sigma)
    cross = zero_crossings(prof["d2"], prof["z"])
    top = float(prof["z"][-1] + bin / 2)
    if rule == "queiroz":
        b = _ordinal(cross, top)
    else:
        if x is None or y is None:
            raise InputError("profile: the spread rule needs the points' x and y")
        b = _by_spread(cross, top, crown_base(x, y, z))
    zn = np.asarray(z, float) - float(np.min(z))
    labels = np.full(zn.size, STEM, np.uint8)
    if b["has_roots"]:
        labels[zn < b["stem_start"]] = ROOTS
    labels[zn >= b["canopy_start"]] = CANOPY
    return {**b, "top": top, "rule": rule, "crossings": cross, "labels": labels, "profile": prof,
            "counts": {PART_NAMES[k]: int((labels == k).sum()) for k in PART_NAMES}}


def _ordinal(cross, top) -> dict:
    """Seed 002's rule as written: crossings 1, 2, 3 = tree start, stem start, canopy start;
    roots from the ground to the stem start."""
    zs = [c[0] for c in cross]
    notes = []
    tree_start = zs[0] if zs else None
    stem_start = zs[1] if len(zs) > 1 else None
    canopy_start = zs[2] if len(zs) > 2 else None
    if stem_start is None:
        notes.append(f"{len(zs)} inflection(s): no stem start")
    if canopy_start is None:
        canopy_start = top
        notes.append(f"{len(zs)} inflection(s): no canopy start (all points below the top are "
                     "roots or stem)")
    return {"tree_start": tree_start, "stem_start": stem_start, "canopy_start": canopy_start,
            "has_roots": stem_start is not None, "notes": notes}


def _by_spread(cross, top, base) -> dict:
    """``rule="spread"``: the stem from the inflections, the canopy from the spread."""
    stem_i = next((k for k, (_, d) in enumerate(cross) if d > 0), None)
    notes, tree_start, stem_start = [], None, None
    if stem_i is None:
        notes.append("no concave-to-convex inflection: no stem start found")
    else:
        stem_start = cross[stem_i][0]
        before = [c for c in cross[:stem_i] if c[1] < 0]
        tree_start = before[0][0] if before else None
    has_roots = tree_start is not None
    if stem_start is not None and not has_roots:
        notes.append("no root zone (no concave stretch below the stem): points below the stem "
                     "start are labelled stem")
    if base is None:
        base = top
        notes.append("the spread never leaves the stem's: no canopy")
    if stem_start is not None and base <= stem_start:
        has_roots, stem_start = False, None
        notes.append("the crown starts below the density profile's stem start: no stem or "
                     "root zone below the crown")
    return {"tree_start": tree_start, "stem_start": stem_start, "canopy_start": base,
            "has_roots": has_roots, "notes": notes}
