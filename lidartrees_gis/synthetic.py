"""Deterministic synthetic plantation stands with known trees (the embedded demo and test truth).

A clonal eucalyptus stand as seed 000 and seed 001 describe it: 3 x 2 m spacing (3 m between
rows, 2 m along a row), trees about 23 m tall (sd 1.5 m), crowns about 1.5 m in radius, a few
missing trees, gently sloping ground, laser returns on the crowns plus some ground returns,
about 25 points per m², in SAD-69 / UTM zone 24S (EPSG:29194) near E 412300, N 7952400.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .io.points import PointChunk

CRS = "EPSG:29194"


@dataclass(frozen=True)
class StandParams:
    """Parameters of a synthetic stand (metres)."""

    width: float = 60.0
    height: float = 60.0
    row_spacing: float = 3.0
    tree_spacing: float = 2.0
    mean_height: float = 23.0
    sd_height: float = 1.5
    mean_crown_radius: float = 1.5
    sd_crown_radius: float = 0.15
    crown_depth: float = 9.0
    missing_fraction: float = 0.03
    density: float = 25.0
    ground_penetration: float = 0.15
    noise: float = 0.05
    origin_x: float = 412300.0
    origin_y: float = 7952400.0
    slope_x: float = 0.03
    slope_y: float = 0.02
    seed: int = 42


def ground_height(x, y, p: StandParams = StandParams()):
    """Terrain height (m) of the synthetic stand at map coordinates."""
    dx, dy = np.asarray(x) - p.origin_x, np.asarray(y) - p.origin_y
    return 600.0 + p.slope_x * dx + p.slope_y * dy + 0.4 * np.sin(dx / 25.0) * np.cos(dy / 30.0)


def _crown_surface(d, top, radius, depth):
    """Paraboloid crown: height at horizontal distance ``d`` from the stem (NaN outside)."""
    q = (d / radius) ** 2
    return np.where(q <= 1.0, top - depth * q, np.nan)


def make_stand(params: StandParams | None = None):
    """Generate points and the truth table of a synthetic stand.

    Returns
    -------
    points : PointChunk
        x, y, z (with ``classification`` 2 for ground returns, 1 otherwise).
    truth : dict of ndarray
        ``tree_id, x, y, ground, height, crown_radius, visible_crown_diameter`` for every
        standing tree, and ``_missing_x``, ``_missing_y``: the planting positions left empty. ``visible_crown_diameter`` = sqrt(4A/π) of the area A where that tree's
        crown is the top surface (neighbouring crowns overlap along the rows).
    """
    p = params or StandParams()
    rng = np.random.default_rng(p.seed)
    # stems: rows run along y (2 m apart in a row), rows 3 m apart in x, half a spacing in
    xs = np.arange(p.row_spacing / 2, p.width, p.row_spacing)
    ys = np.arange(p.tree_spacing / 2, p.height, p.tree_spacing)
    gx, gy = np.meshgrid(xs, ys, indexing="xy")
    tx = gx.ravel() + p.origin_x + rng.normal(0, 0.1, gx.size)
    ty = gy.ravel() + p.origin_y + rng.normal(0, 0.1, gy.size)
    keep = rng.random(tx.size) >= p.missing_fraction
    miss_x, miss_y = tx[~keep], ty[~keep]
    tx, ty = tx[keep], ty[keep]
    nt = tx.size
    th = rng.normal(p.mean_height, p.sd_height, nt)
    tr = np.clip(rng.normal(p.mean_crown_radius, p.sd_crown_radius, nt), 0.8, None)
    tg = ground_height(tx, ty, p)
    ttop = tg + th

    def top_surface(px, py):
        """(height of the highest crown or NaN, index of that tree or -1) at points."""
        from scipy.spatial import cKDTree

        tree = cKDTree(np.column_stack([tx, ty]))
        rmax = float(tr.max())
        best = np.full(px.shape, np.nan)
        owner = np.full(px.shape, -1, dtype=np.int64)
        k = 8
        dist, idx = tree.query(np.column_stack([px, py]), k=k, distance_upper_bound=rmax)
        for j in range(k):
            ok = np.isfinite(dist[:, j])
            ii = idx[ok, j]
            s = _crown_surface(dist[ok, j], ttop[ii], tr[ii], p.crown_depth)
            cur = best[ok]
            better = ~np.isnan(s) & (np.isnan(cur) | (s > cur))
            cur[better] = s[better]
            best[ok] = cur
            o = owner[ok]
            o[better] = ii[better]
            owner[ok] = o
        return best, owner

    npts = rng.poisson(p.density * p.width * p.height)
    px = p.origin_x + rng.random(npts) * p.width
    py = p.origin_y + rng.random(npts) * p.height
    surf, _ = top_surface(px, py)
    g = ground_height(px, py, p)
    to_ground = np.isnan(surf) | (rng.random(npts) < p.ground_penetration)
    pz = np.where(to_ground, g, surf) + rng.normal(0, p.noise, npts)
    cls = np.where(to_ground, 2, 1).astype(np.uint8)
    # visible crown areas on a fine lattice (0.05 m)
    step = 0.05
    fx, fy = np.meshgrid(np.arange(step / 2, p.width, step) + p.origin_x,
                         np.arange(step / 2, p.height, step) + p.origin_y)
    _, own = top_surface(fx.ravel(), fy.ravel())
    area = np.bincount(own[own >= 0], minlength=nt) * step * step
    truth = {
        "tree_id": np.arange(1, nt + 1),
        "x": tx, "y": ty, "ground": tg, "height": th, "crown_radius": tr,
        "visible_crown_diameter": np.sqrt(4 * area / np.pi),
        # planting positions left empty (not columns of the truth table)
        "_missing_x": miss_x, "_missing_y": miss_y,
    }
    return PointChunk(px, py, pz, classification=cls), truth


def write_xyz_seed_dialect(path, points: PointChunk) -> None:
    """Write points as seed 000's text: tab separated, decimal comma, 2/2/4 decimals."""
    lines = [f"{x:.2f}\t{y:.2f}\t{z:.4f}".replace(".", ",")
             for x, y, z in zip(points.x.tolist(), points.y.tolist(), points.z.tolist())]
    with open(path, "w", encoding="ascii", newline="\n") as fh:
        fh.write("\n".join(lines))
        fh.write("\n")


def write_truth_csv(path, truth: dict) -> None:
    """Write the truth table as CSV (decimal point, comma separated)."""
    cols = [c for c in truth if not c.startswith("_")]
    with open(path, "w", encoding="ascii", newline="\n") as fh:
        fh.write(",".join(cols) + "\n")
        for i in range(len(truth["tree_id"])):
            fh.write(",".join(f"{truth[c][i]:.3f}" if c != "tree_id" else str(int(truth[c][i]))
                              for c in cols) + "\n")
