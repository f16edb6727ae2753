"""Roots / stem / canopy segmentation of one tree from its point-density profile (Queiroz 2017,
seed 002).

1. z_n = z - z_min; horizontal slices of ``bin`` metres; point count per slice.
2. Gaussian smoothing of the counts with sigma in metres (0.3 m was best in the seed).
3. Second derivative by finite differences: forward at the first slice, central inside,
   backward at the last (seed 002, step 4).
4. Zero crossings of the second derivative, going up from the ground: the first is the tree
   start, the second the end of the prop roots and start of the stem, the next the end of the
   stem and start of the canopy (concave parts, d2 < 0, are roots and canopy; the stem is convex).

Reading used here: the stem starts at the first crossing from concave to convex (- to +) and
the canopy at the next crossing from convex to concave (+ to -). A root zone exists when a
concave stretch precedes the stem start (a + to - crossing below it, the "tree start"); when it
does not (the seed's Avicennia, without aerial roots), the profile is reported as having no root
zone, points below the stem start are labelled stem, and the canopy start is still placed.
"""
from __future__ import annotations

import numpy as np
from scipy.ndimage import gaussian_filter1d

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


def density_profile(z, *, bin: float = 0.05, sigma: float = 0.3):  # noqa: A002 - seed's name
    """Counts per slice, smoothed counts and second derivative. Returns a dict with ``z`` (slice
    centres above z_min), ``counts``, ``smooth``, ``d2``."""
    if not bin > 0:
        raise InputError(f"-bin must be > 0 m, got {bin}")
    if not sigma > 0:
        raise InputError(f"-sigma must be > 0 m, got {sigma}")
    z = np.asarray(z, dtype=np.float64)
    if z.size < 10:
        raise InputError(f"profile: {z.size} points; too few for a profile")
    zn = z - z.min()
    nb = int(np.floor(zn.max() / bin)) + 1
    counts = np.bincount(np.minimum((zn / bin).astype(np.int64), nb - 1), minlength=nb).astype(float)
    smooth = gaussian_filter1d(counts, sigma / bin, mode="constant", cval=0.0)
    return {"z": (np.arange(nb) + 0.5) * bin, "counts": counts, "smooth": smooth,
            "d2": second_derivative(smooth, bin), "bin": bin, "sigma": sigma}


def segment_profile(z, *, bin: float = 0.05, sigma: float = 0.3) -> dict:  # noqa: A002
    """Boundaries (metres above z_min) and a label per point (1 roots, 2 stem, 3 canopy)."""
    prof = density_profile(z, bin=bin, sigma=sigma)
    cross = zero_crossings(prof["d2"], prof["z"])
    top = float(prof["z"][-1] + bin / 2)
    stem_i = next((k for k, (_, d) in enumerate(cross) if d > 0), None)
    notes = []
    if stem_i is None:
        stem_start, canopy_start, tree_start = 0.0, None, None
        notes.append("no concave-to-convex inflection: no stem found")
    else:
        stem_start = cross[stem_i][0]
        before = [c for c in cross[:stem_i] if c[1] < 0]
        tree_start = before[0][0] if before else None
        canopy = next((c[0] for c in cross[stem_i + 1:] if c[1] < 0), None)
        canopy_start = canopy
    has_roots = stem_i is not None and tree_start is not None
    if stem_i is not None and not has_roots:
        notes.append("no root zone (no concave stretch below the stem): points below the stem "
                     "start are labelled stem")
    if canopy_start is None:
        # fall back: the last convex-to-concave crossing, else the lower third of the profile
        conc = [c[0] for c in cross if c[1] < 0 and c[0] > stem_start]
        canopy_start = conc[-1] if conc else stem_start + (top - stem_start) / 3
        notes.append("no convex-to-concave inflection above the stem: canopy start estimated")
    zn = np.asarray(z, float) - float(np.min(z))
    labels = np.full(zn.size, STEM, np.uint8)
    if has_roots:
        labels[zn < stem_start] = ROOTS
    labels[zn >= canopy_start] = CANOPY
    return {"tree_start": tree_start, "stem_start": stem_start if stem_i is not None else None,
            "canopy_start": canopy_start, "top": top, "has_roots": has_roots,
            "crossings": cross, "labels": labels, "profile": prof, "notes": notes,
            "counts": {PART_NAMES[k]: int((labels == k).sum()) for k in PART_NAMES}}
