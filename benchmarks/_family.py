"""A family of plantation stands made apart from the package's own generator
(``lidartrees_gis.synthetic``), for benchmarks that one generator cannot fool (issue 23).

It varies what real plantations vary: crown radius (crowns that touch and overlap), suppressed
trees under the canopy, missing trees with shrubs in some gaps, flat or sloped undulating
ground, point density, row azimuth, spacing, several stands in one file. Its crowns are
half-ellipsoids topped by a cone (not the package's paraboloids), its ground a tilted plane with
two wave trains, and its pulses may pass the upper canopy and return from a lower crown or the
ground. Nothing here is read by the detector; none of its numbers is a detector constant.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.spatial import cKDTree


@dataclass(frozen=True)
class StandSpec:
    """One stand of the family (metres, degrees, points/m²)."""

    name: str = "base"
    width: float = 90.0
    height: float = 90.0
    row_spacing: float = 3.0
    tree_spacing: float = 2.0
    azimuth: float = 20.0  # row direction, degrees from north
    top_height: float = 23.0
    crown_radius: tuple = (0.8, 1.9)  # uniform range (m) of dominant trees
    suppressed: float = 0.08  # share of planted positions holding a suppressed tree
    suppressed_rel: tuple = (0.52, 0.78)  # their height / the top height
    missing: float = 0.05
    shrubs: float = 0.5  # share of missing positions with a shrub of 0.5-3 m
    slope_pct: float = 15.0
    density: float = 12.0
    origin: tuple = (500000.0, 7500000.0)
    ground_origin: tuple = (500000.0, 7500000.0)  # one terrain for the stands of a file
    seed: int = 0


def ground(x, y, s: StandSpec):
    """A tilted plane (``slope_pct`` down to the south-east) with two wave trains."""
    dx, dy = np.asarray(x) - s.ground_origin[0], np.asarray(y) - s.ground_origin[1]
    g = s.slope_pct / 100.0
    return (700.0 - g * 0.8 * dx - g * 0.6 * dy + 1.1 * np.sin(dx / 17.0 + 0.4)
            + 0.7 * np.cos(dy / 23.0) * np.sin(dx / 41.0))


def _trees(s: StandSpec, rng):
    """Planting positions and what stands on each: 0 missing, 1 dominant, 2 suppressed."""
    a = np.radians(s.azimuth)
    u = np.array([np.sin(a), np.cos(a)])  # along the rows
    v = np.array([np.cos(a), -np.sin(a)])  # across
    cx, cy = s.origin[0] + s.width / 2, s.origin[1] + s.height / 2
    half = 0.75 * max(s.width, s.height)
    ii = np.arange(-half // s.tree_spacing - 1, half // s.tree_spacing + 2)
    jj = np.arange(-half // s.row_spacing - 1, half // s.row_spacing + 2)
    I, J = np.meshgrid(ii, jj)
    off = rng.random(2) * [s.tree_spacing, s.row_spacing]
    px = cx + (I.ravel() * s.tree_spacing + off[0]) * u[0] + (J.ravel() * s.row_spacing + off[1]) * v[0]
    py = cy + (I.ravel() * s.tree_spacing + off[0]) * u[1] + (J.ravel() * s.row_spacing + off[1]) * v[1]
    keep = ((px >= s.origin[0]) & (px < s.origin[0] + s.width) & (py >= s.origin[1])
            & (py < s.origin[1] + s.height))
    px, py = px[keep], py[keep]
    n = px.size
    r = rng.random(n)
    status = np.where(r < s.missing, 0, np.where(r < s.missing + s.suppressed, 2, 1))
    tx = px + rng.normal(0, 0.12, n)
    ty = py + rng.normal(0, 0.12, n)
    h = np.where(status == 2, s.top_height * rng.uniform(*s.suppressed_rel, n),
                 rng.normal(s.top_height, 1.3, n))
    rad = rng.uniform(*s.crown_radius, n) * np.where(status == 2, 0.7, 1.0)
    shrub = (status == 0) & (rng.random(n) < s.shrubs)
    return {"pos_x": px, "pos_y": py, "status": status, "x": tx, "y": ty, "height": h,
            "radius": rad, "shrub": shrub, "shrub_h": rng.uniform(0.5, 3.0, n)}


def _crown(d, top, radius):
    """Cone over a half-ellipsoid: the top third of the crown's depth a cone."""
    depth = 0.45 * top
    q = np.clip(d / radius, 0, None)
    body = top - depth * (1 - np.sqrt(np.clip(1 - q ** 2, 0, None))) - 0.25 * depth * q
    return np.where(q <= 1.0, body, np.nan)


def make_stand(s: StandSpec):
    """Points (x, y, z, classification) and the truth of one stand.

    Returns
    -------
    points : dict of arrays ``x, y, z, classification``
    truth : dict with ``x, y, height, status`` of every tree (status 1 dominant, 2 suppressed)
        and ``positions``: planting positions ``x, y, status`` (0 missing, 1, 2), the stand's
        name, spacing and azimuth.
    """
    rng = np.random.default_rng(s.seed)
    t = _trees(s, rng)
    live = t["status"] > 0
    n = rng.poisson(s.density * s.width * s.height)
    x = s.origin[0] + rng.random(n) * s.width
    y = s.origin[1] + rng.random(n) * s.height
    g = ground(x, y, s)
    # every crown (and shrub) a point may hit, highest first; a pulse returns from the first
    # it meets, or passes it (gaps between branches) to the next, or to the ground
    cx = np.r_[t["x"][live], t["pos_x"][t["shrub"]]]
    cy = np.r_[t["y"][live], t["pos_y"][t["shrub"]]]
    ch = np.r_[t["height"][live], t["shrub_h"][t["shrub"]]]
    cr = np.r_[t["radius"][live], np.full(int(t["shrub"].sum()), 0.8)]
    tree = cKDTree(np.c_[cx, cy])
    cand = tree.query_ball_point(np.c_[x, y], r=float(cr.max()))
    z = np.full(n, np.nan)
    for k, c in enumerate(cand):
        if not c:
            continue
        c = np.asarray(c)
        d = np.hypot(x[k] - cx[c], y[k] - cy[c])
        hz = _crown(d, ch[c], cr[c])
        hz = np.sort(hz[np.isfinite(hz)])[::-1]
        for level in hz:
            if rng.random() < 0.78:  # returns from this crown
                z[k] = level
                break
    hit = np.isfinite(z)
    cls = np.where(hit, 1, 2).astype(np.uint8)
    z = np.where(hit, g + z, g) + rng.normal(0, 0.04, n)
    truth = {"x": t["x"][live], "y": t["y"][live], "height": t["height"][live],
             "status": t["status"][live],
             "positions": {"x": t["pos_x"], "y": t["pos_y"], "status": t["status"]},
             "name": s.name, "spacing": (s.row_spacing, s.tree_spacing), "azimuth": s.azimuth}
    return {"x": x, "y": y, "z": z, "classification": cls}, truth


#: the family: a base stand and one variation at a time (defaults first in the report)
def family(density_scale: float = 1.0) -> list:
    b = StandSpec()
    out = [b,
           replace(b, name="touching crowns 0.6-1.0 m", crown_radius=(0.6, 1.0), seed=1),
           replace(b, name="overlapping crowns 1.4-2.0 m", crown_radius=(1.4, 2.0), seed=2),
           replace(b, name="no suppressed", suppressed=0.0, seed=3),
           replace(b, name="15 % suppressed at 40-80 %", suppressed=0.15,
                   suppressed_rel=(0.4, 0.8), seed=4),
           replace(b, name="2 % missing", missing=0.02, seed=5),
           replace(b, name="10 % missing, shrubs", missing=0.10, shrubs=1.0, seed=6),
           replace(b, name="flat", slope_pct=0.0, seed=7),
           replace(b, name="25 % slope", slope_pct=25.0, seed=8),
           replace(b, name="2 pts/m2", density=2.0, seed=9),
           replace(b, name="4 pts/m2", density=4.0, seed=10),
           replace(b, name="25 pts/m2", density=25.0, seed=11),
           replace(b, name="rows at 0", azimuth=0.0, seed=12),
           replace(b, name="rows at 67", azimuth=67.0, seed=13),
           replace(b, name="3x3", tree_spacing=3.0, seed=14),
           replace(b, name="2.5x2.5", row_spacing=2.5, tree_spacing=2.5, seed=15),
           replace(b, name="3.5x2.5", row_spacing=3.5, tree_spacing=2.5, seed=16)]
    return [replace(s, density=s.density * density_scale) for s in out]


def two_stands(density: float = 12.0):
    """Two stands side by side in one file: 3 x 2 m rows at 20° and 3.5 x 2.5 m rows at 115°.
    Returns points, the two truths and the two stand boxes (xmin, ymin, xmax, ymax)."""
    a = StandSpec(name="A 3x2 at 20", width=90, density=density, seed=21)
    b = StandSpec(name="B 3.5x2.5 at 115", width=90, row_spacing=3.5, tree_spacing=2.5,
                  azimuth=115.0, density=density, seed=22,
                  origin=(a.origin[0] + a.width, a.origin[1]))
    pa, ta = make_stand(a)
    pb, tb = make_stand(b)
    pts = {k: np.r_[pa[k], pb[k]] for k in pa}
    boxes = [(a.origin[0], a.origin[1], a.origin[0] + a.width, a.origin[1] + a.height),
             (b.origin[0], b.origin[1], b.origin[0] + b.width, b.origin[1] + b.height)]
    return pts, [ta, tb], boxes
