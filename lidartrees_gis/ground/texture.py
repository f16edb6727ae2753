"""Texture of DTMs for seed 003's quality sweep: grey-level co-occurrence matrices (GLCM) and
their descriptors, principal components and k-means. Pure functions over numpy arrays."""
from __future__ import annotations

import numpy as np

from ..errors import InputError


# DTM texture quality (seed 003)
ANGLES = (0, 45, 90, 135)


_OFFSETS = {0: (0, 1), 45: (1, 1), 90: (1, 0), 135: (1, -1)}  # (row, col), as scikit-image


def to_grey(dtm, levels: int = 256) -> np.ndarray:
    """Normalise to integer grey levels 0..levels-1: g = (levels-1)(f - fmin)/(fmax - fmin)
    (seed 000's display rule); NaN cells become -1 (left out of the co-occurrences)."""
    a = np.asarray(dtm, dtype=np.float64)
    ok = np.isfinite(a)
    out = np.full(a.shape, -1, dtype=np.int64)
    if ok.any():
        lo, hi = a[ok].min(), a[ok].max()
        span = hi - lo if hi > lo else 1.0
        out[ok] = np.rint((levels - 1) * (a[ok] - lo) / span).astype(np.int64)
    return out


def glcm(grey, angle: int, levels: int = 256, distance: int = 1) -> np.ndarray:
    """Normalised grey-level co-occurrence matrix P(i, j) for one offset (not symmetric):
    pairs (pixel at (r, c), neighbour at (r + d·sin θ, c + d·cos θ)), the convention of
    ``skimage.feature.graycomatrix``."""
    dr, dc = _OFFSETS[angle]
    dr, dc = dr * distance, dc * distance
    H, W = grey.shape
    r0, r1 = max(0, -dr), min(H, H - dr)
    c0, c1 = max(0, -dc), min(W, W - dc)
    a = grey[r0:r1, c0:c1]
    b = grey[r0 + dr:r1 + dr, c0 + dc:c1 + dc]
    ok = (a >= 0) & (b >= 0)
    m = np.bincount(a[ok] * levels + b[ok], minlength=levels * levels).astype(np.float64)
    s = m.sum()
    return (m / s if s else m).reshape(levels, levels)


def texture_descriptors(dtm, levels: int = 256) -> dict:
    """Seed 003's 12 descriptors: contrast Σ(i-j)²P, homogeneity ΣP/(1+(i-j)²) (the seed prints
    |i+j|, a typo) and dissimilarity Σ|i-j|P at distance 1 and 0°, 45°, 90°, 135°."""
    g = to_grey(dtm, levels)
    i, j = np.mgrid[0:levels, 0:levels]
    d = (i - j).astype(np.float64)
    out = {}
    for ang in ANGLES:
        P = glcm(g, ang, levels)
        out[f"contrast_{ang}"] = float((d ** 2 * P).sum())
        out[f"homogeneity_{ang}"] = float((P / (1 + d ** 2)).sum())
        out[f"dissimilarity_{ang}"] = float((np.abs(d) * P).sum())
    return out


def pca_select(X, threshold: float = 0.3):
    """PCA of standardised columns; returns (indices of columns whose |loading| on PC1 is at least
    ``threshold``, PC1 loadings, explained variance ratios). Loadings are the unit eigenvector
    coefficients of PC1."""
    Z = _standardise(X)
    u, s, vt = np.linalg.svd(Z, full_matrices=False)
    load = vt[0]
    if load[np.argmax(np.abs(load))] < 0:
        load = -load
    var = s ** 2 / max((s ** 2).sum(), 1e-300)
    return np.nonzero(np.abs(load) >= threshold)[0], load, var


def _standardise(X):
    X = np.asarray(X, dtype=np.float64)
    sd = X.std(axis=0)
    return (X - X.mean(axis=0)) / np.where(sd > 0, sd, 1.0)


def kmeans(X, k: int = 3, seed: int = 0, restarts: int = 10):
    """k-means (scipy, k-means++ start), best of ``restarts`` seeded runs; returns
    (labels, centroids). With fewer than ``k`` distinct rows, each distinct row is a cluster."""
    from scipy.cluster.vq import kmeans2

    X = np.asarray(X, dtype=np.float64)
    uniq, inv = np.unique(np.round(X, 9), axis=0, return_inverse=True)
    if len(uniq) <= k:
        return inv.ravel(), uniq
    best = None
    for r in range(restarts):
        cent, lab = kmeans2(X, k, minit="++", seed=seed + r)
        sse = float(((X - cent[lab]) ** 2).sum())
        if len(np.unique(lab)) == k and (best is None or sse < best[0]):
            best = (sse, lab, cent)
    if best is None:
        raise InputError(f"k-means could not form {k} clusters")
    return best[1], best[2]
