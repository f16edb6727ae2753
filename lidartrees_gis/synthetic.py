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


# ---------------------------------------------------------------------------------------------
# a farm of clonal stands with stems (DAP, volume) and field plots: the volume command's truth

#: Schumacher-Hall coefficients of the generated clones: V = b0 DAP^b1 HT^b2 (DAP cm, HT m, m³)
SCHUMACHER = (0.000049, 1.85, 1.05)


@dataclass(frozen=True)
class FarmParams:
    """A farm of ``cols x rows`` square stands of ``side`` m (heights above flat ground).

    Each stand has its own mean height (uniform in ``heights``), its own site factor of the
    DAP-height relation (``DAP = site 0.9 H^0.91 exp(N(0, dap_cv))``, site log-normal with
    ``site_cv``), ``missing`` planting positions empty and ``suppressed`` holding a tree of
    0.5-0.8 of the stand's height. Crowns are paraboloids of radius ``0.35 + 0.055 H`` and depth
    ``0.45 H``; a pulse returns from the highest crown above it, or (``gap``) from the ground.
    """

    cols: int = 3
    rows: int = 2
    side: float = 280.0
    row_spacing: float = 3.0
    tree_spacing: float = 2.0
    heights: tuple = (14.0, 30.0)
    height_cv: float = 0.08
    dap_cv: float = 0.08
    site_cv: float = 0.0
    missing: float = 0.04
    suppressed: float = 0.05
    density: float = 8.0
    gap: float = 0.12
    origin: tuple = (412000.0, 7952000.0)
    seed: int = 0


def _farm_trees(p: FarmParams, rng) -> dict:
    """Every tree: x, y, stand, height, DAP, volume."""
    xs = np.arange(p.row_spacing / 2, p.cols * p.side, p.row_spacing)
    ys = np.arange(p.tree_spacing / 2, p.rows * p.side, p.tree_spacing)
    gx, gy = np.meshgrid(xs, ys)
    x = gx.ravel() + rng.normal(0, 0.1, gx.size)
    y = gy.ravel() + rng.normal(0, 0.1, gx.size)
    stand = (np.floor(y / p.side) * p.cols + np.floor(x / p.side)).astype(int)
    ns = p.cols * p.rows
    top = rng.uniform(*p.heights, ns)
    site = np.exp(rng.normal(0, p.site_cv, ns)) if p.site_cv > 0 else np.ones(ns)
    r = rng.random(x.size)
    keep = r >= p.missing
    supp = r < p.missing + p.suppressed
    h = top[stand] * np.exp(rng.normal(0, p.height_cv, x.size))
    h = np.where(supp, top[stand] * rng.uniform(0.5, 0.8, x.size), h)
    dap = site[stand] * 0.9 * h ** 0.91 * np.exp(rng.normal(0, p.dap_cv, x.size))
    b0, b1, b2 = SCHUMACHER
    vol = b0 * dap ** b1 * h ** b2
    k = keep
    return {"x": x[k] + p.origin[0], "y": y[k] + p.origin[1], "stand": stand[k], "height": h[k],
            "dap": dap[k], "volume": vol[k], "crown_radius": 0.35 + 0.055 * h[k],
            "stand_height": top, "site": site}


def make_farm(params: FarmParams | None = None):
    """Points (heights above a flat ground at z = 0, ground returns class 2) and the truth.

    Returns
    -------
    points : PointChunk
    truth : dict
        ``trees`` (x, y, stand, height, dap, volume), ``stands``: per stand ``box`` (xmin,
        ymin, xmax, ymax), ``volume_m3_ha``, ``basal_area_m2_ha``, ``area_ha``.
    """
    from scipy.spatial import cKDTree

    p = params or FarmParams()
    rng = np.random.default_rng(p.seed)
    t = _farm_trees(p, rng)
    w, h = p.cols * p.side, p.rows * p.side
    n = rng.poisson(p.density * w * h)
    px = p.origin[0] + rng.random(n) * w
    py = p.origin[1] + rng.random(n) * h
    kd = cKDTree(np.column_stack([t["x"], t["y"]]))
    rmax = float(t["crown_radius"].max())
    best = np.full(n, np.nan)
    for lo in range(0, n, 1_000_000):  # bounded memory
        sl = slice(lo, min(n, lo + 1_000_000))
        dist, idx = kd.query(np.column_stack([px[sl], py[sl]]), k=8, distance_upper_bound=rmax)
        ok = np.isfinite(dist)
        ii = np.where(ok, idx, 0)
        top, rad = t["height"][ii], t["crown_radius"][ii]
        q = (np.where(ok, dist, np.inf) / rad) ** 2
        s = np.where(q <= 1.0, top - 0.45 * top * q, np.nan)
        best[sl] = np.nanmax(np.where(np.isfinite(s), s, -np.inf), axis=1)
    best[~np.isfinite(best)] = np.nan
    ground = np.isnan(best) | (rng.random(n) < p.gap)
    pz = np.where(ground, 0.0, best) + rng.normal(0, 0.03, n)
    cls = np.where(ground, 2, 1).astype(np.uint8)
    ns = p.cols * p.rows
    area_ha = p.side * p.side / 1e4
    vol = np.bincount(t["stand"], weights=t["volume"], minlength=ns) / area_ha
    ba = np.bincount(t["stand"], weights=np.pi * (t["dap"] / 200) ** 2, minlength=ns) / area_ha
    boxes = [(p.origin[0] + (k % p.cols) * p.side, p.origin[1] + (k // p.cols) * p.side,
              p.origin[0] + (k % p.cols + 1) * p.side, p.origin[1] + (k // p.cols + 1) * p.side)
             for k in range(ns)]
    truth = {"trees": t, "stands": {"box": boxes, "volume_m3_ha": vol, "basal_area_m2_ha": ba,
                                    "area_ha": np.full(ns, area_ha)}}
    return PointChunk(px, py, pz, classification=cls,
                      return_number=np.ones(n, np.uint8)), truth


def farm_plots(params: FarmParams, per_ha: float = 1 / 6.0, radius: float = 11.28,
               seed: int = 0, min_per_stand: int = 1) -> tuple:
    """Circular plot centres: ``min_per_stand`` in every stand, the rest (to one per
    ``1 / per_ha`` ha) in stands drawn at random, each at least ``radius + 2`` m inside its
    stand. Returns ``(x, y, stand)``."""
    rng = np.random.default_rng(seed)
    p = params
    ns = p.cols * p.rows
    total = max(ns * min_per_stand, int(round(ns * p.side * p.side / 1e4 * per_ha)))
    stands = np.r_[np.repeat(np.arange(ns), min_per_stand),
                   rng.integers(0, ns, total - ns * min_per_stand)]
    m = radius + 2.0
    x, y = np.empty(stands.size), np.empty(stands.size)
    for i, k in enumerate(stands):  # plots do not overlap (2 radii and 5 m apart)
        for _ in range(1000):
            x[i] = p.origin[0] + (k % p.cols) * p.side + rng.uniform(m, p.side - m)
            y[i] = p.origin[1] + (k // p.cols) * p.side + rng.uniform(m, p.side - m)
            if i == 0 or np.min(np.hypot(x[:i] - x[i], y[:i] - y[i])) > 2 * radius + 5:
                break
    return x, y, stands


def plot_trees(truth: dict, x, y, radius: float = 11.28, ht_share: float = 1.0,
               seed: int = 0) -> dict:
    """The field trees of circular plots: ``parcela, arvore, dap, ht`` (HT measured on
    ``ht_share`` of the trees, NaN for the others), as a crew measures them (DAP to 0.1 cm,
    HT to 0.1 m)."""
    from scipy.spatial import cKDTree

    rng = np.random.default_rng(seed)
    t = truth["trees"]
    kd = cKDTree(np.column_stack([t["x"], t["y"]]))
    rows = {"parcela": [], "arvore": [], "dap": [], "ht": []}
    for k, (cx, cy) in enumerate(zip(x, y)):
        idx = np.asarray(sorted(kd.query_ball_point([cx, cy], radius)), int)
        rows["parcela"] += [k + 1] * idx.size
        rows["arvore"] += list(range(1, idx.size + 1))
        rows["dap"] += list(np.round(t["dap"][idx], 1))
        ht = np.round(t["height"][idx], 1)
        rows["ht"] += list(np.where(rng.random(idx.size) < ht_share, ht, np.nan))
    return {k: np.asarray(v) for k, v in rows.items()}


def write_trees_ptbr(path, rows: dict) -> None:
    """The field trees as a pt-BR spreadsheet exports them: ``;`` and a decimal comma."""
    with open(path, "w", encoding="cp1252", newline="\n") as fh:
        fh.write("parcela;arvore;dap;ht\n")
        for i in range(len(rows["parcela"])):
            ht = "" if not np.isfinite(rows["ht"][i]) else f"{rows['ht'][i]:.1f}".replace(".", ",")
            fh.write(f"{int(rows['parcela'][i])};{int(rows['arvore'][i])};"
                     f"{rows['dap'][i]:.1f}".replace(".", ",") + f";{ht}\n")


def write_volume_example(folder, density: float = 4.0, n_plots: int = 9, seed: int = 0):
    """A small farm to try ``lidartrees volume`` on (docs/VOLUME.md): in ``folder``,
    ``farm.laz`` (3 x 2 stands of 110 m, ``density`` points/m²), ``stands.gpkg`` (field
    ``talhao``), ``plots.gpkg`` (``n_plots`` plot centres, field ``parcela``; radius 11.28 m)
    and ``arvores.csv`` (the plots' trees as a pt-BR spreadsheet exports them, HT on 40 %).
    Returns ``(truth, trees)``: the farm's truth (:func:`make_farm`) and the table's rows."""
    from pathlib import Path

    import geopandas as gpd
    import pyproj
    import shapely

    from .io.lasout import write_points

    d = Path(folder)
    d.mkdir(parents=True, exist_ok=True)
    p = FarmParams(cols=3, rows=2, side=110, density=density, seed=seed)
    pts, truth = make_farm(p)
    write_points(d / "farm.laz", pts.x, pts.y, pts.z, crs=pyproj.CRS(CRS),
                 classification=pts.classification)
    boxes = truth["stands"]["box"]
    gpd.GeoDataFrame({"talhao": [f"T{k + 1}" for k in range(len(boxes))]},
                     geometry=[shapely.box(*b) for b in boxes], crs=CRS).to_file(d / "stands.gpkg")
    x, y, _ = farm_plots(p, per_ha=n_plots / (p.cols * p.rows * p.side ** 2 / 1e4), seed=seed)
    gpd.GeoDataFrame({"parcela": np.arange(1, x.size + 1)}, geometry=gpd.points_from_xy(x, y),
                     crs=CRS).to_file(d / "plots.gpkg")
    rows = plot_trees(truth, x, y, ht_share=0.4, seed=seed)
    write_trees_ptbr(d / "arvores.csv", rows)
    return truth, rows
