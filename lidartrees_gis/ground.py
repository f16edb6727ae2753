"""Ground filtering by robust interpolation (Kraus & Pfeifer 1998, as in FUSION's GroundFilter,
tuned for eucalyptus by Leite et al., seed 003) and the DTM texture-quality sweep of seed 003.

Surface model (documented choice): a grid of ``cell`` metres; each cell holds the weighted mean
height of its points (weights from the previous iteration; all 1 at the start), empty cells are
filled by :func:`lidartrees_gis.grid.fill_mean8`, and the surface at a point is the bilinear
interpolation of the cell centres. The filter runs hierarchically (after Pfeifer et al.'s
hierarchical robust interpolation): ``levels`` grids from ``cell * 2**(levels-1)`` down to
``cell``, ``iterations`` each, every level starting from the weights of the coarser one, so large
objects (buildings, dense crowns) are rejected at the coarse levels and terrain detail comes
back at the fine ones; ``levels=1`` is the plain single-grid filter. Residual v = z - surface.
Weights (seed 003, eq. 1)::

    p = 1                          v <= g
    p = 1 / (1 + (a (v - g))^b)    g < v <= g + w
    p = 0                          v > g + w

g is kept fixed between iterations (it is what seed 003 sweeps; FUSION's automatic shift of g is
not reproduced). After the last iteration, points within the ground band (v <= g + w, against
the final surface) are ground (class 2); with ``tolerance`` (FUSION's /tolerance) the points
with |v| <= tolerance are.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from .errors import InputError
from .grid import GridSpec, fill_mean8
from .progress import as_progress, check_cancel


@dataclass(frozen=True)
class KrausPfeifer:
    """Parameters of the robust-interpolation ground filter (FUSION GroundFilter defaults)."""

    g: float = -2.0
    w: float = 2.5
    a: float = 1.0
    b: float = 4.0
    iterations: int = 5
    cell: float = 3.0
    levels: int = 3
    tolerance: float | None = None

    def __post_init__(self):
        if not self.w > 0:
            raise InputError(f"-w must be > 0, got {self.w}")
        if not (self.a > 0 and self.b > 0):
            raise InputError("-a and -b must be > 0")
        if int(self.iterations) < 1:
            raise InputError(f"-iterations must be >= 1, got {self.iterations}")
        if not self.cell > 0:
            raise InputError(f"-cell must be > 0 m, got {self.cell}")
        if int(self.levels) < 1:
            raise InputError(f"-levels must be >= 1, got {self.levels}")
        if self.tolerance is not None and not self.tolerance > 0:
            raise InputError(f"-tolerance must be > 0 m, got {self.tolerance}")

    def as_dict(self):
        return asdict(self)


def kp_weights(v, g=-2.0, w=2.5, a=1.0, b=4.0):
    """Kraus & Pfeifer weight of residuals ``v`` (seed 003, eq. 1).

    >>> kp_weights(np.array([-3.0, -1.0, 1.0]), g=-2, w=2.5).round(4).tolist()
    [1.0, 0.5, 0.0]
    """
    v = np.asarray(v, dtype=np.float64)
    p = 1.0 / (1.0 + (a * (v - g)) ** b)
    p = np.where(v <= g, 1.0, p)
    return np.where(v > g + w, 0.0, p)


def _surface(x, y, z, wts, spec: GridSpec):
    row, col = spec.cell_index(x, y)
    idx = row * spec.width + col
    n = spec.width * spec.height
    sw = np.bincount(idx, weights=wts, minlength=n)
    swz = np.bincount(idx, weights=wts * z, minlength=n)
    with np.errstate(invalid="ignore", divide="ignore"):
        grid = np.where(sw > 0, swz / sw, np.nan).reshape(spec.shape)
    return fill_mean8(grid)


def _bilinear(grid, spec: GridSpec, x, y):
    """Bilinear interpolation of cell-centre values at points (edges clamped)."""
    fc = (np.asarray(x) - spec.left) / spec.res - 0.5
    fr = (spec.top - np.asarray(y)) / spec.res - 0.5
    c0 = np.clip(np.floor(fc).astype(np.int64), 0, spec.width - 1)
    r0 = np.clip(np.floor(fr).astype(np.int64), 0, spec.height - 1)
    c1 = np.clip(c0 + 1, 0, spec.width - 1)
    r1 = np.clip(r0 + 1, 0, spec.height - 1)
    tx = np.clip(fc - c0, 0, 1)
    ty = np.clip(fr - r0, 0, 1)
    top = grid[r0, c0] * (1 - tx) + grid[r0, c1] * tx
    bot = grid[r1, c0] * (1 - tx) + grid[r1, c1] * tx
    return top * (1 - ty) + bot * ty


def kraus_pfeifer(x, y, z, params: KrausPfeifer | None = None, progress=None):
    """Robust-interpolation ground filter.

    Parameters
    ----------
    x, y, z : (N,) ndarray of float
    params : KrausPfeifer

    Returns
    -------
    ground : (N,) ndarray of bool
        True for points within the ground band after the last iteration.
    weights : (N,) ndarray of float
        Final weights.
    """
    p = params or KrausPfeifer()
    x, y, z = (np.asarray(a, dtype=np.float64) for a in (x, y, z))
    if x.size == 0:
        raise InputError("ground filter: no points")
    wts = np.ones(x.size)
    prog = as_progress(progress)
    levels = int(p.levels)
    total = levels * int(p.iterations)
    step = 0
    for lev in range(levels):
        spec = GridSpec.from_bounds(x.min(), y.min(), x.max(), y.max(),
                                    p.cell * 2 ** (levels - 1 - lev))
        for it in range(int(p.iterations)):
            check_cancel(progress)
            surf = _surface(x, y, z, wts, spec)
            v = z - _bilinear(surf, spec, x, y)
            wts = kp_weights(v, p.g, p.w, p.a, p.b)
            if wts.sum() == 0:
                raise InputError(f"ground filter: every weight became 0 at iteration {it + 1}; "
                                 "lower -g or raise -w")
            step += 1
            prog.update(step / total, f"level {lev + 1}/{levels}, iteration {it + 1}")
    surf = _surface(x, y, z, wts, spec)
    v = z - _bilinear(surf, spec, x, y)
    ground = (np.abs(v) <= p.tolerance) if p.tolerance is not None else (v <= p.g + p.w)
    return ground, kp_weights(v, p.g, p.w, p.a, p.b)


# ---------------------------------------------------------------------------------------------
# Accuracy against reference labels (ISPRS filter test)
def filter_errors(pred_ground, ref_ground) -> dict:
    """Type I (ground rejected), type II (object accepted as ground), total error and Cohen's
    kappa, in % (kappa as a fraction), as Sithole & Vosselman (2004) report them."""
    pg = np.asarray(pred_ground, bool)
    rg = np.asarray(ref_ground, bool)
    a = int((rg & pg).sum())      # ground -> ground
    b = int((rg & ~pg).sum())     # ground -> object (type I)
    c = int((~rg & pg).sum())     # object -> ground (type II)
    d = int((~rg & ~pg).sum())    # object -> object
    n = a + b + c + d
    po = (a + d) / n
    pe = ((a + b) * (a + c) + (c + d) * (b + d)) / n ** 2
    return {"type1": 100 * b / max(a + b, 1), "type2": 100 * c / max(c + d, 1),
            "total": 100 * (b + c) / n, "kappa": (po - pe) / (1 - pe) if pe < 1 else 1.0}


# ---------------------------------------------------------------------------------------------
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
    (labels, centroids)."""
    from scipy.cluster.vq import kmeans2

    X = np.asarray(X, dtype=np.float64)
    best = None
    for r in range(restarts):
        cent, lab = kmeans2(X, k, minit="++", seed=seed + r)
        sse = float(((X - cent[lab]) ** 2).sum())
        if len(np.unique(lab)) == k and (best is None or sse < best[0]):
            best = (sse, lab, cent)
    if best is None:
        raise InputError(f"k-means could not form {k} clusters (too few distinct DTMs)")
    return best[1], best[2]
