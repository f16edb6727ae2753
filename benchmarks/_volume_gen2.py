#!/usr/bin/env python
"""
gen_volume_farm.py -- independent simulator of airborne LiDAR over Brazilian
eucalyptus plantation stands with known wood volume, plus a field inventory
(circular 400 m2 plots) as a Brazilian forestry crew would deliver it.

Usage:  python gen_volume_farm.py --config c1_base --out DIR --draw K [--no-laz]

Models (all independent of any software under test):
  * layout   : farm quadrilateral cut by skewed road lines (6-10 m wide) into
               irregular quadrilateral stands of 3-8 ha, whole farm rotated.
  * terrain  : plane (stand-wide slope) + 3 sinusoidal undulations, slope capped.
  * planting : rows at stand azimuth (parallel to a stand side, or to contour
               lines on slopes), spacing jitter, missing trees (single + runs
               along rows), suppressed trees, gap release of neighbours, edge effect.
  * height   : Chapman-Richards dominant-height site curve, base age 7 yr,
               tree relative-height distribution.
  * diameter : DAP = a (H-1.3)^b * site * density * clone * noise (lognormal).
  * volume   : Max & Burkhart (1976) segmented-polynomial taper, normalised at
               1.3 m, integrated analytically from 0.10 m stump to the tip
               (total stem volume over bark).
  * crowns   : "egg" crowns = two half-ellipsoids (upper/lower semi-axis) with
               elliptic cross-section (elongated across rows), horizontal
               offset from stem, crown length 30-50 % of H, radius ~ DAP.
  * LiDAR    : oscillating-mirror zig-zag scan, +-20 deg, 2-3 flight lines with
               overlap, 0.25 m footprint (sub-beam offset), analytic ray/crown
               intersection, crowns as turbid media (Beer-Lambert exponential
               free path), partial interception, 1.8 m range dead zone,
               max 4 returns, understory returns, ground returns, few birds.
"""
import argparse
import json
import os
import time
import zlib

import numpy as np
import pandas as pd
import geopandas as gpd
import shapely
from shapely.geometry import Polygon, LineString, Point
from shapely.ops import split
from shapely import affinity
import pyproj
import laspy
from scipy.spatial import cKDTree

EPSG = 31983
E0, N0, Z0 = 600000.0, 7500000.0, 720.0
PLOT_R = 11.28
STUMP = 0.10
AGL = 650.0            # flying height above datum (m)
HALF_ANGLE = 20.0      # max scan angle (deg)
FOOTPRINT = 0.25       # beam footprint diameter (m)
DEAD_ZONE = 1.8        # min range separation between returns (m)
MAX_RET = 4
RANGE_SD = 0.03

# Max & Burkhart (1976) taper coefficients (b1 clone specific)
# (a2 lowered from 0.1109 to 0.06: eucalyptus stems have little butt swell; gives form
# factors 0.46-0.52 for total volume over bark)
MB_B2, MB_B3, MB_B4, MB_A1, MB_A2 = 1.4388, -1.4498, 39.1928, 0.7497, 0.06

# Chapman-Richards shape (site index = dominant height at 7 years)
CR_K, CR_C, BASE_AGE = 0.30, 1.25, 7.0

# clones: DAP factor at equal height, taper b1, crown-radius factor
CLONES = {
    "AEC 144": dict(dap=1.00, b1=-3.02, crown=1.00),
    "I 144":   dict(dap=0.98, b1=-3.08, crown=0.96),
    "GG 100":  dict(dap=1.02, b1=-2.98, crown=1.05),
    "VM 01":   dict(dap=0.97, b1=-3.12, crown=0.94),
    "AEC 224": dict(dap=1.01, b1=-3.00, crown=1.02),
    "CO 1407": dict(dap=0.99, b1=-3.05, crown=0.98),
    "I 224":   dict(dap=1.03, b1=-2.96, crown=1.04),
}

SP_ALL = [(3.0, 2.0), (3.0, 2.5), (3.0, 3.0), (3.5, 2.5), (3.0, 1.5)]

CONFIGS = {
    "c1_base": dict(
        desc="6-7 yr, 3x2, 8 returns/m2, flat-ish",
        n_stands=5, mean_ha=4.4, dens=8.0,
        ages=[6.0, 6.3, 6.6, 6.8, 7.0], sites=[17, 21, 24, 27, 29.5],
        spacings=[(3.0, 2.0)], grad=(0.005, 0.02), undul=0.4, max_slope=0.05,
        miss=(0.03, 0.07), run_share=0.4, supp=(0.03, 0.06),
        clones=["AEC 144", "I 144", "GG 100", "AEC 144", "VM 01"], clone_dap=None),
    "c2_young": dict(
        desc="2.5-4 yr young stands, 7 returns/m2",
        n_stands=6, mean_ha=4.2, dens=7.0,
        ages=[2.5, 2.8, 3.1, 3.4, 3.7, 4.0], sites=[24, 33, 26, 30, 25, 31],
        spacings=[(3.0, 2.0), (3.0, 2.5), (3.0, 3.0)], grad=(0.01, 0.04), undul=0.8, max_slope=0.08,
        miss=(0.03, 0.08), run_share=0.4, supp=(0.03, 0.06),
        clones=["AEC 144", "I 224", "GG 100", "CO 1407", "VM 01", "AEC 224"], clone_dap=None),
    "c3_dense_sparse": dict(
        desc="mixed spacings 3x1.5 and 3.5x2.5, 5 returns/m2",
        n_stands=6, mean_ha=5.6, dens=5.0,
        ages=[2.5, 3.5, 4.5, 5.5, 6.5, 7.0], sites=[26, 31, 24, 29, 27, 32],
        spacings=[(3.0, 1.5), (3.5, 2.5)], grad=(0.01, 0.04), undul=0.8, max_slope=0.08,
        miss=(0.03, 0.08), run_share=0.4, supp=(0.03, 0.07),
        clones=["AEC 144", "I 144", "GG 100", "AEC 224", "CO 1407", "I 224"], clone_dap=None),
    "c4_slope": dict(
        desc="10-15 % slope, rows on contour, 6 returns/m2",
        n_stands=6, mean_ha=5.0, dens=6.0,
        ages=[3.0, 3.8, 4.6, 5.4, 6.2, 7.0], sites=[25, 31, 23, 28, 33, 27],
        spacings=[(3.0, 2.0), (3.0, 2.5), (3.0, 3.0)], grad=(0.11, 0.12), undul=1.2, max_slope=0.15,
        min_slope=0.10,
        miss=(0.03, 0.08), run_share=0.4, supp=(0.03, 0.06),
        clones=["GG 100", "AEC 144", "VM 01", "I 224", "CO 1407", "AEC 224"], clone_dap=None),
    "c5_missing": dict(
        desc="12 % missing (mostly in runs), 10 % suppressed, 6 returns/m2",
        n_stands=6, mean_ha=5.0, dens=6.0,
        ages=[3.0, 4.0, 5.0, 6.0, 6.5, 7.0], sites=[24, 30, 27, 33, 22, 29],
        spacings=[(3.0, 2.0), (3.0, 2.5), (3.0, 3.0), (3.5, 2.5)], grad=(0.01, 0.04), undul=0.8,
        max_slope=0.08,
        miss=(0.12, 0.12), run_share=0.7, supp=(0.10, 0.10),
        clones=["AEC 144", "I 144", "GG 100", "AEC 224", "CO 1407", "VM 01"], clone_dap=None),
    "c6_clones": dict(
        desc="stands differ in clone: DAP at equal height +-6 %, 6 returns/m2",
        n_stands=6, mean_ha=5.0, dens=6.0,
        ages=[3.5, 3.5, 5.0, 5.0, 6.5, 6.5], sites=[27, 27, 30, 30, 29, 29],
        spacings=[(3.0, 2.0)], grad=(0.01, 0.03), undul=0.6, max_slope=0.07,
        miss=(0.04, 0.06), run_share=0.4, supp=(0.04, 0.05),
        clones=["AEC 144", "I 224", "GG 100", "VM 01", "CO 1407", "AEC 224"],
        clone_dap=[0.94, 1.06, 1.06, 0.94, 0.97, 1.03], keep_order=True),
}


# ----------------------------------------------------------------------------
# growth / allometry / taper
# ----------------------------------------------------------------------------
def site_curve(age, S):
    return S * ((1 - np.exp(-CR_K * age)) / (1 - np.exp(-CR_K * BASE_AGE))) ** CR_C


def mb_f(z, b1):
    z = np.asarray(z, float)
    return (b1 * (z - 1) + MB_B2 * (z ** 2 - 1)
            + MB_B3 * (MB_A1 - z) ** 2 * (z <= MB_A1)
            + MB_B4 * (MB_A2 - z) ** 2 * (z <= MB_A2))


def mb_int(z0, b1):
    """integral of mb_f from z0 to 1"""
    z0 = np.asarray(z0, float)
    return (b1 * ((1 - z0 ** 2) / 2 - (1 - z0)) + MB_B2 * ((1 - z0 ** 3) / 3 - (1 - z0))
            + MB_B3 * np.where(z0 < MB_A1, (MB_A1 - z0) ** 3 / 3, 0.0)
            + MB_B4 * np.where(z0 < MB_A2, (MB_A2 - z0) ** 3 / 3, 0.0))


def taper_d(h, D, H, b1):
    """diameter (cm) at height h (m) for tree with DAP D (cm), total height H (m)"""
    return D * np.sqrt(np.maximum(mb_f(h / H, b1), 0) / mb_f(1.3 / H, b1))


def stem_volume(D, H, b1):
    """total stem volume over bark (m3), stump 0.10 m to tip"""
    D = np.asarray(D, float); H = np.asarray(H, float)
    return np.pi / 40000.0 * D ** 2 / mb_f(1.3 / H, b1) * H * mb_int(STUMP / H, b1)


# ----------------------------------------------------------------------------
# layout
# ----------------------------------------------------------------------------
def make_layout(rng, n_stands, mean_ha):
    cols = [3, 3] if n_stands == 6 else [3, 2]
    for attempt in range(500):
        A = n_stands * mean_ha * 1e4 * 1.05
        W = np.sqrt(A * rng.uniform(1.5, 1.9))
        Hh = A / W
        c = [(rng.uniform(-20, 20), rng.uniform(-20, 20)),
             (W + rng.uniform(-20, 20), rng.uniform(-20, 20)),
             (W + rng.uniform(-20, 20), Hh + rng.uniform(-20, 20)),
             (rng.uniform(-20, 20), Hh + rng.uniform(-20, 20))]
        farm = Polygon(c)
        y1 = Hh * rng.uniform(0.44, 0.56)
        hl = LineString([(-100, y1 + rng.uniform(-25, 25)), (W + 100, y1 + rng.uniform(-25, 25))])
        roads = [(hl, rng.uniform(6, 10))]
        halves = list(split(farm, hl).geoms)
        if len(halves) != 2:
            continue
        halves.sort(key=lambda p: p.centroid.y)
        pieces = []
        for r, half in enumerate(halves):
            m = cols[r]
            hb = half.bounds
            vl = []
            for j in range(1, m):
                xb = W * j / m + rng.uniform(-0.06, 0.06) * W
                xt = xb + rng.uniform(-35, 35)
                line = LineString([(xb - (xt - xb), hb[1] - (hb[3] - hb[1])),
                                   (xt + (xt - xb), hb[3] + (hb[3] - hb[1]))])
                vl.append((line, rng.uniform(6, 10)))
            parts = [half]
            for line, w in vl:
                newp = []
                for p in parts:
                    newp.extend(split(p, line).geoms)
                parts = newp
            road_poly = shapely.union_all([hl.buffer(roads[0][1] / 2, cap_style="flat", join_style="mitre")] +
                                          [l.buffer(w / 2, cap_style="flat", join_style="mitre") for l, w in vl])
            for p in parts:
                q = p.difference(road_poly)
                pieces.append(q)
            roads.extend(vl)
        if len(pieces) != n_stands or any(q.geom_type != "Polygon" for q in pieces):
            continue
        areas = np.array([q.area for q in pieces]) / 1e4
        if areas.min() < 3.2 or areas.max() > 7.8:
            continue
        # simplify to clean quadrilaterals
        pieces = [shapely.Polygon(q.exterior.coords).simplify(0.01) for q in pieces]
        rot = rng.uniform(-35, 35)
        ctr = farm.centroid
        off = (E0 + rng.uniform(-500, 500) - ctr.x, N0 + rng.uniform(-500, 500) - ctr.y)

        def tf(g):
            g = affinity.rotate(g, rot, origin=ctr)
            return affinity.translate(g, off[0], off[1])
        pieces = [tf(q) for q in pieces]
        farm = tf(farm)
        # order stands: south-west to north-east
        order = sorted(range(len(pieces)), key=lambda i: (round(pieces[i].centroid.y / 150), pieces[i].centroid.x))
        pieces = [pieces[i] for i in order]
        return farm, pieces, rot
    raise RuntimeError("layout failed")


def make_terrain(rng, farm, cfg):
    ctr = farm.centroid
    xc, yc = ctr.x, ctr.y
    gmag = rng.uniform(*cfg["grad"])
    gdir = rng.uniform(0, 2 * np.pi)
    gx, gy = gmag * np.cos(gdir), gmag * np.sin(gdir)
    waves = []
    for j in range(3):
        lam = rng.uniform(180, 500)
        b = rng.uniform(0, np.pi)
        waves.append([cfg["undul"] * rng.uniform(0.5, 1.0), np.cos(b), np.sin(b), lam, rng.uniform(0, 2 * np.pi)])
    T = dict(xc=xc, yc=yc, z0=Z0 + rng.uniform(-80, 80), gx=gx, gy=gy, waves=waves)
    # cap slopes
    b = farm.buffer(30).bounds
    X, Y = np.meshgrid(np.linspace(b[0], b[2], 120), np.linspace(b[1], b[3], 120))
    for it in range(30):
        s = terrain_slope(T, X, Y)
        ok_max = s.max() <= cfg["max_slope"]
        ok_min = s.min() >= cfg.get("min_slope", 0.0)
        if ok_max and ok_min:
            break
        for w in T["waves"]:
            w[0] *= 0.8
    return T


def terrain_z(T, x, y):
    dx = x - T["xc"]; dy = y - T["yc"]
    z = T["z0"] + T["gx"] * dx + T["gy"] * dy
    for A, cb, sb, lam, ph in T["waves"]:
        z = z + A * np.sin(2 * np.pi * (dx * cb + dy * sb) / lam + ph)
    return z


def terrain_slope(T, x, y):
    dx = x - T["xc"]; dy = y - T["yc"]
    sx = np.full_like(np.asarray(x, float), T["gx"]); sy = np.full_like(np.asarray(x, float), T["gy"])
    for A, cb, sb, lam, ph in T["waves"]:
        c = A * 2 * np.pi / lam * np.cos(2 * np.pi * (dx * cb + dy * sb) / lam + ph)
        sx = sx + c * cb; sy = sy + c * sb
    return np.hypot(sx, sy)


# ----------------------------------------------------------------------------
# stands and trees
# ----------------------------------------------------------------------------
def longest_side_azimuth(poly):
    c = np.asarray(poly.exterior.coords)
    d = np.diff(c, axis=0)
    i = np.argmax(np.hypot(d[:, 0], d[:, 1]))
    return np.degrees(np.arctan2(d[i, 0], d[i, 1])) % 180.0


def plant_stand(rng, st, T, cfg):
    poly = st["poly"]
    az = np.radians(st["row_az"])
    ux, uy = np.sin(az), np.cos(az)          # along row
    vx, vy = np.cos(az), -np.sin(az)         # across rows
    rs, ts = st["spacing"]
    c = np.asarray(poly.exterior.coords)
    cu = c[:, 0] * ux + c[:, 1] * uy
    cv = c[:, 0] * vx + c[:, 1] * vy
    v0 = cv.min() + rng.uniform(0, rs)
    nrow = int((cv.max() - v0) / rs) + 1
    u0 = cu.min()
    ntr = int((cu.max() - u0) / ts) + 2
    K, J = np.meshgrid(np.arange(nrow), np.arange(ntr), indexing="ij")
    K = K.ravel(); J = J.ravel()
    row_shift = rng.uniform(0, ts, nrow)                # each row planted from the edge
    row_wobble = rng.normal(0, 0.08, nrow)
    v = v0 + K * rs + row_wobble[K] + rng.normal(0, 0.08, K.size)
    u = u0 + row_shift[K] + J * ts + rng.normal(0, 0.15, K.size)
    x = u * ux + v * vx
    y = u * uy + v * vy
    inner = poly.buffer(-st["edge_margin"], join_style="mitre")
    ins = shapely.contains_xy(inner, x, y)
    x, y, K, J = x[ins], y[ins], K[ins], J[ins]
    n = x.size
    # --- missing trees: runs along rows + singles
    key = K.astype(np.int64) * 100000 + J
    order = np.argsort(key); key_s = key[order]
    missing = np.zeros(n, bool)
    m_tot = int(round(st["miss_frac"] * n))
    m_run = int(round(st["miss_frac"] * cfg["run_share"] * n))
    guard = 0
    while missing.sum() < m_run and guard < 10000:
        guard += 1
        i0 = rng.integers(n)
        L = rng.geometric(1 / 4.0)
        L = min(L, m_run - missing.sum())
        ks = K[i0] * 100000 + J[i0] + np.arange(L)
        pos = np.searchsorted(key_s, ks)
        pos = pos[pos < n]
        pos = pos[key_s[pos] == ks[:pos.size]] if pos.size else pos
        missing[order[pos]] = True
    free = np.flatnonzero(~missing)
    extra = m_tot - missing.sum()
    if extra > 0:
        missing[rng.choice(free, extra, replace=False)] = True
    live = ~missing
    # gap release: number of missing along-row neighbours
    nb = np.zeros(n)
    for dj in (-1, 1):
        ks = key + dj
        pos = np.clip(np.searchsorted(key_s, ks), 0, n - 1)
        hit = key_s[pos] == ks
        nb += hit & missing[order[pos]]
    # suppressed
    li = np.flatnonzero(live)
    supp = np.zeros(n, bool)
    supp[rng.choice(li, int(round(st["supp_frac"] * li.size)), replace=False)] = True
    # --- heights
    Hd = site_curve(st["idade"], st["site"])
    r = np.clip(rng.normal(0.935, 0.05, n), 0.78, 1.08)
    r[supp] = rng.uniform(0.45, 0.78, supp.sum())
    H = Hd * r
    # --- DAP
    ap = rs * ts
    site_f = (st["site"] / 28.0) ** -0.15
    dens_f = (ap / 6.0) ** 0.18
    dist_edge = shapely.distance(shapely.points(x, y), poly.boundary)
    edge = dist_edge < 3.5
    D = (1.55 * (H - 1.3) ** 0.74 * site_f * dens_f * st["clone_dap"]
         * np.exp(rng.normal(0, 0.07, n)) * np.where(supp, 0.85, 1.0)
         * np.where(edge, 1.04, 1.0) * (1 + 0.04 * nb))
    D = np.maximum(D, 2.5)
    V = stem_volume(D, H, st["b1"])
    # --- crowns
    CRr = np.clip(0.52 - 0.022 * st["idade"] + rng.normal(0, 0.04, n), 0.30, 0.50)
    CL = CRr * H
    R = st["crown_f"] * (0.35 + 0.075 * D) * np.exp(rng.normal(0, 0.10, n)) * np.where(supp, 0.8, 1.0)
    e = rng.uniform(0.0, 0.2, n)
    A = R * (1 + e); B = R * (1 - e)
    # major axis across rows (+-25 deg)
    omega = np.arctan2(vy, vx) + np.radians(rng.normal(0, 25, n))
    offm = rng.uniform(0, 0.3, n) * R
    offd = rng.uniform(0, 2 * np.pi, n)
    cx = x + offm * np.cos(offd); cy = y + offm * np.sin(offd)
    ftop = rng.uniform(0.35, 0.50, n)
    zg = terrain_z(T, x, y)
    ztop = zg + H
    cm = ztop - ftop * CL
    return dict(x=x, y=y, K=K, J=J, live=live, supp=supp, edge=edge, H=H, D=D, V=V,
                CL=CL, R=R, A=A, B=B, omega=omega, cx=cx, cy=cy, cm=cm,
                Ct=ftop * CL, Cb=(1 - ftop) * CL, zg=zg, nbgap=nb)


# ----------------------------------------------------------------------------
# build farm (deterministic for a configuration)
# ----------------------------------------------------------------------------
def build_farm(name):
    cfg = CONFIGS[name]
    seed = zlib.crc32(name.encode()) & 0x7FFFFFFF
    rng = np.random.default_rng(seed)
    farm, polys, rot = make_layout(rng, cfg["n_stands"], cfg["mean_ha"])
    T = make_terrain(rng, farm, cfg)
    n = len(polys)
    ages = list(cfg["ages"]); sites = list(cfg["sites"])
    if not cfg.get("keep_order"):
        p = rng.permutation(n); ages = [ages[i] for i in p]; sites = [sites[i] for i in p]
    nums = [1, 1, 2, 3, 3, 4][:n] if n == 6 else [1, 2, 2, 3, 4]
    letters = {}
    stands = []
    for i, poly in enumerate(polys):
        num = nums[i]
        letters[num] = letters.get(num, 0) + 1
        talhao = f"{num:03d}-{'ABC'[letters[num] - 1]}"
        clone = cfg["clones"][i]
        cp = CLONES[clone]
        if cfg.get("clone_dap"):
            cdap = cfg["clone_dap"][i]
        else:
            cdap = cp["dap"]
        sp = cfg["spacings"][i % len(cfg["spacings"])] if len(cfg["spacings"]) <= 2 else \
            cfg["spacings"][rng.integers(len(cfg["spacings"]))]
        if name == "c4_slope":
            cen = poly.centroid
            # contour direction = perpendicular to local gradient
            eps = 1.0
            gxl = (terrain_z(T, cen.x + eps, cen.y) - terrain_z(T, cen.x - eps, cen.y)) / (2 * eps)
            gyl = (terrain_z(T, cen.x, cen.y + eps) - terrain_z(T, cen.x, cen.y - eps)) / (2 * eps)
            az = (np.degrees(np.arctan2(-gyl, gxl)) + rng.uniform(-5, 5)) % 180.0
        else:
            az = (longest_side_azimuth(poly) + (90.0 if rng.random() < 0.3 else 0.0)
                  + rng.uniform(-4, 4)) % 180.0
        st = dict(talhao=talhao, clone=clone, idade=float(ages[i]), site=float(sites[i]),
                  spacing=sp, row_az=float(az), poly=poly,
                  miss_frac=float(rng.uniform(*cfg["miss"])), supp_frac=float(rng.uniform(*cfg["supp"])),
                  clone_dap=float(cdap), b1=cp["b1"], crown_f=cp["crown"],
                  edge_margin=float(rng.uniform(0.8, 1.5)),
                  kappa=float(rng.uniform(0.55, 0.85)), p_cont=float(rng.uniform(0.55, 0.68)),
                  p_us=float(rng.uniform(0.08, 0.22)))
        st["trees"] = plant_stand(rng, st, T, cfg)
        stands.append(st)
    return dict(name=name, cfg=cfg, seed=seed, farm=farm, stands=stands, T=T, rot=rot)


# ----------------------------------------------------------------------------
# LiDAR simulation
# ----------------------------------------------------------------------------
def flight_plan(F, aoi):
    mrr = aoi.minimum_rotated_rectangle
    c = np.asarray(mrr.exterior.coords)[:4]
    e1 = c[1] - c[0]; e2 = c[2] - c[1]
    long_e, short_e = (e1, e2) if np.hypot(*e1) >= np.hypot(*e2) else (e2, e1)
    h = short_e / np.hypot(*short_e)           # heading along the short axis
    a = np.array([h[1], -h[0]])                # across track (right of heading)
    pts = np.asarray(aoi.exterior.coords)
    sp = pts @ h; cp = pts @ a
    cmin, cmax = cp.min() - 20, cp.max() + 20
    # flying height chosen so that two lines with ~30 % side overlap cover the farm
    AGL = float(np.clip((cmax - cmin) / 1.7 / (2 * np.tan(np.radians(HALF_ANGLE))), 450.0, 900.0))
    F["agl"] = AGL
    W = 2 * AGL * np.tan(np.radians(HALF_ANGLE))
    nl = max(2, int(np.ceil((cmax - cmin - W) / (0.7 * W) - 1e-6)) + 1)
    centers = np.linspace(cmin + W / 2, cmax - W / 2, nl) if cmax - cmin > W else \
        np.array([(cmin + cmax) / 2 - 0.15 * W, (cmin + cmax) / 2 + 0.15 * W])
    lines = []
    for li, cc in enumerate(centers):
        direction = 1 if li % 2 == 0 else -1
        hh = h * direction; aa = a * direction
        s0 = (sp.min() - 15) if direction == 1 else -(sp.max() + 15)
        length = sp.max() - sp.min() + 30
        origin = cc * a + s0 * hh      # s=0 start of line at datum (xy)
        lines.append(dict(h=hh, a=aa, origin=origin, length=length, W=W, id=li + 1))
    return lines


def coverage_area(lines, aoi):
    tot = 0.0
    for L in lines:
        o, h, a, W = L["origin"], L["h"], L["a"], L["W"]
        sw = Polygon([o - a * W / 2, o + a * W / 2, o + a * W / 2 + h * L["length"], o - a * W / 2 + h * L["length"]])
        tot += sw.intersection(aoi).area
    return tot


def simulate_lidar(F, d_pulse, rng, trees_all, aoi, verbose=True):
    T = F["T"]
    AGL = F["agl"]
    zref = T["z0"]
    zA = zref + AGL
    lines = F["lines"]
    aoi_big = aoi.buffer(25)
    P = {k: [] for k in ("gx", "gy", "c", "line", "k", "i", "t", "N")}
    grids = []
    pid0 = 0
    t_line = 0.0
    stand_idx_poly = [st["poly"] for st in F["stands"]]
    for L in lines:
        W = L["W"]
        dlt = 1.0 / np.sqrt(d_pulse)
        N = int(round(W / dlt))
        dc = W / N
        ds = 1.0 / (d_pulse * dc)
        nk = int(L["length"] / ds) + 1
        kk, ii = np.meshgrid(np.arange(nk), np.arange(N), indexing="ij")
        kk = kk.ravel(); ii = ii.ravel()
        itime = np.where(kk % 2 == 0, ii, N - 1 - ii)
        c = -W / 2 + (ii + 0.5) * dc + rng.normal(0, 0.05 * dc, kk.size)
        s = kk * ds + (itime / N) * ds + rng.normal(0, 0.05 * ds, kk.size)
        nx = L["origin"][0] + s * L["h"][0] + c * L["a"][0]
        ny = L["origin"][1] + s * L["h"][1] + c * L["a"][1]
        keep = shapely.contains_xy(aoi_big, nx, ny)
        kk, ii, itime, c, s, nx, ny = kk[keep], ii[keep], itime[keep], c[keep], s[keep], nx[keep], ny[keep]
        # ground intersection: xy(z) = nominal - (z - zref) * c/AGL * a
        tx = -c / AGL * L["a"][0]; ty = -c / AGL * L["a"][1]
        z = terrain_z(T, nx, ny)
        for _ in range(6):
            z = terrain_z(T, nx + (z - zref) * tx, ny + (z - zref) * ty)
        gx = nx + (z - zref) * tx; gy = ny + (z - zref) * ty
        keep = shapely.contains_xy(aoi, gx, gy)
        kk, ii, itime, c, gx, gy = kk[keep], ii[keep], itime[keep], c[keep], gx[keep], gy[keep]
        order = np.lexsort((itime, kk))
        kk, ii, itime, c, gx, gy = kk[order], ii[order], itime[order], c[order], gx[order], gy[order]
        n = kk.size
        pid = pid0 + np.arange(n)
        grid = np.full((nk, N), -1, np.int64)
        grid[kk, ii] = pid
        v = 60.0  # m/s
        dt = ds / v / N
        t = t_line + (kk * N + itime) * dt
        t_line = t.max() + 120.0
        P["gx"].append(gx); P["gy"].append(gy); P["c"].append(c)
        P["line"].append(np.full(n, L["id"])); P["k"].append(kk); P["i"].append(ii); P["t"].append(t)
        P["N"].append(np.full(n, N))
        grids.append(dict(grid=grid, nk=nk, N=N, dc=dc, ds=ds, pid0=pid0, n=n))
        pid0 += n
    for k in P:
        P[k] = np.concatenate(P[k])
    npul = pid0
    # per-pulse direction: horizontal displacement per unit rise
    la = np.array([L["a"] for L in lines])
    a_p = la[P["line"] - 1]
    P["tx"] = -P["c"] / AGL * a_p[:, 0]; P["ty"] = -P["c"] / AGL * a_p[:, 1]
    P["zg"] = terrain_z(T, P["gx"], P["gy"])
    P["sec"] = np.sqrt(1 + P["tx"] ** 2 + P["ty"] ** 2)
    # sub-beam offset within footprint
    rr = FOOTPRINT / 2 * np.sqrt(rng.random(npul)); th = rng.uniform(0, 2 * np.pi, npul)
    ox = rr * np.cos(th); oy = rr * np.sin(th)
    # stand-specific medium properties by pulse location
    kappa = np.full(npul, 0.7); pcont = np.full(npul, 0.6); pus = np.full(npul, 0.04)
    for st in F["stands"]:
        m = shapely.contains_xy(st["poly"], P["gx"], P["gy"])
        kappa[m] = st["kappa"]; pcont[m] = st["p_cont"]; pus[m] = st["p_us"]
    # ---- ray / crown intersections
    Tr = trees_all
    segp, sega, segb = [], [], []
    for gi, (L, G) in enumerate(zip(lines, grids)):
        h, a, o, W = L["h"], L["a"], L["origin"], L["W"]
        rel_x = Tr["cx"] - o[0]; rel_y = Tr["cy"] - o[1]
        s_c = rel_x * h[0] + rel_y * h[1]
        c_c = rel_x * a[0] + rel_y * a[1]
        Rm = np.maximum(Tr["A"], Tr["B"]) + FOOTPRINT / 2 + 0.05
        ht = Tr["cm"] + Tr["Ct"] - zref; hb = Tr["cm"] - Tr["Cb"] - zref
        kt = AGL / (AGL - ht); kb = AGL / (AGL - hb)
        lo = np.minimum((c_c - Rm) * kt, (c_c - Rm) * kb) - 0.3 * G["dc"]
        hi = np.maximum((c_c + Rm) * kt, (c_c + Rm) * kb) + 0.3 * G["dc"]
        i_lo = np.floor((lo + W / 2) / G["dc"] - 0.5).astype(np.int64)
        i_hi = np.ceil((hi + W / 2) / G["dc"] - 0.5).astype(np.int64)
        k_lo = np.floor((s_c - Rm) / G["ds"]).astype(np.int64) - 2
        k_hi = np.ceil((s_c + Rm) / G["ds"]).astype(np.int64) + 1
        i_lo = np.clip(i_lo, 0, G["N"] - 1); i_hi = np.clip(i_hi, 0, G["N"] - 1)
        k_lo = np.clip(k_lo, 0, G["nk"] - 1); k_hi = np.clip(k_hi, 0, G["nk"] - 1)
        ni = i_hi - i_lo + 1; nkk = k_hi - k_lo + 1
        cnt = np.where((ni > 0) & (nkk > 0), ni * nkk, 0)
        # chunk over crowns
        ncr = cnt.size
        cs = np.cumsum(cnt)
        start = 0
        while start < ncr:
            stop = int(np.searchsorted(cs, (cs[start - 1] if start > 0 else 0) + 3_000_000)) + 1
            stop = min(max(stop, start + 1), ncr)
            idx = np.arange(start, stop)
            cn = cnt[idx]
            tot = cn.sum()
            if tot == 0:
                start = stop; continue
            cid = np.repeat(idx, cn)
            off = np.arange(tot) - np.repeat(np.cumsum(cn) - cn, cn)
            kq = k_lo[cid] + off // ni[cid]
            iq = i_lo[cid] + off % ni[cid]
            pid = G["grid"][kq, iq]
            ok = pid >= 0
            cid = cid[ok]; pid = pid[ok]
            # intersection
            gx = P["gx"][pid] + ox[pid]; gy = P["gy"][pid] + oy[pid]
            zg = P["zg"][pid]; tx = P["tx"][pid]; ty = P["ty"][pid]
            cm = Tr["cm"][cid]
            px0 = gx + (cm - zg) * tx - Tr["cx"][cid]
            py0 = gy + (cm - zg) * ty - Tr["cy"][cid]
            cw = np.cos(Tr["omega"][cid]); sw = np.sin(Tr["omega"][cid])
            X0 = cw * px0 + sw * py0; Y0 = -sw * px0 + cw * py0
            TX = cw * tx + sw * ty; TY = -sw * tx + cw * ty
            iA2 = 1 / Tr["A"][cid] ** 2; iB2 = 1 / Tr["B"][cid] ** 2
            qa = TX * TX * iA2 + TY * TY * iB2
            qb = 2 * (X0 * TX * iA2 + Y0 * TY * iB2)
            qc = X0 * X0 * iA2 + Y0 * Y0 * iB2 - 1
            res = []
            for C in (Tr["Ct"][cid], Tr["Cb"][cid]):
                aa = qa + 1 / C ** 2
                disc = qb * qb - 4 * aa * qc
                sq = np.sqrt(np.maximum(disc, 0))
                res.append(((-qb - sq) / (2 * aa), (-qb + sq) / (2 * aa), disc > 0))
            (u1, u2, ud), (l1, l2, ldsc) = res
            lo_u = np.maximum(u1, 0); hi_u = u2; vu = ud & (hi_u > lo_u)
            lo_l = l1; hi_l = np.minimum(l2, 0); vl = ldsc & (hi_l > lo_l)
            valid = vu | vl
            zlo = cm + np.where(vl, lo_l, lo_u)
            zhi = cm + np.where(vu, hi_u, hi_l)
            zlo = np.maximum(zlo, zg + 0.05)
            valid &= zhi > zlo + 1e-4
            pv = pid[valid]
            sec = P["sec"][pv]
            segp.append(pv)
            sega.append((zA - zhi[valid]) * sec)
            segb.append((zA - zlo[valid]) * sec)
            start = stop
    segp = np.concatenate(segp); sega = np.concatenate(sega); segb = np.concatenate(segb)
    # merge overlapping segments per pulse
    o = np.lexsort((sega, segp))
    segp, sega, segb = segp[o], sega[o], segb[o]
    BIG = 1e4
    runmax = np.maximum.accumulate(segp * BIG + segb) - segp * BIG
    newseg = np.ones(segp.size, bool)
    newseg[1:] = (segp[1:] != segp[:-1]) | (sega[1:] > runmax[:-1])
    starts = np.flatnonzero(newseg)
    ends_idx = np.r_[starts[1:] - 1, segp.size - 1]
    mp = segp[starts]; ma = sega[starts]; mb = runmax[ends_idx]
    Ls = mb - ma
    Cend = np.cumsum(Ls); Cstart = Cend - Ls
    ar = np.arange(npul)
    f = np.searchsorted(mp, ar, "left"); l = np.searchsorted(mp, ar, "right")
    has = l > f
    fc = np.minimum(f, max(mp.size - 1, 0))
    base = np.where(has, Cstart[fc], 0.0)
    Ttot = np.where(has, Cend[np.maximum(l - 1, 0)] - base, 0.0)
    keyA = mp * BIG + ma

    def opt_at(p, r):
        idx = np.searchsorted(keyA, p * BIG + r, "right") - 1
        okk = idx >= f[p]
        idc = np.maximum(idx, 0)
        val = Cstart[idc] - base[p] + np.clip(r - ma[idc], 0, Ls[idc])
        return np.where(okk, val, 0.0)

    def r_at(p, ell):
        G = base[p] + ell
        idx = np.searchsorted(Cend, G, "right")
        idx = np.minimum(idx, l[p] - 1)
        return ma[idx] + (G - Cstart[idx])

    rg = (zA - P["zg"]) * P["sec"]
    active = np.ones(npul, bool)
    r_last = np.full(npul, -np.inf)
    out_p, out_r, out_t = [], [], []
    for it in range(MAX_RET):
        ids = np.flatnonzero(active)
        if ids.size == 0:
            break
        ell0 = np.zeros(ids.size) if it == 0 else opt_at(ids, r_last[ids] + DEAD_ZONE)
        ell = ell0 + rng.exponential(1.0, ids.size) / kappa[ids]
        hit = ell < Ttot[ids]
        hid = ids[hit]
        if hid.size:
            re = r_at(hid, ell[hit])
            out_p.append(hid); out_r.append(re); out_t.append(np.zeros(hid.size, np.int8))
            r_last[hid] = re
            cont = rng.random(hid.size) < pcont[hid]
            active[hid[~cont]] = False
        gid = ids[~hit]
        if gid.size:
            us = rng.random(gid.size) < pus[gid]
            hus = rng.uniform(0.15, 1.0, gid.size)
            rr_ = rg[gid] - np.where(us, hus * P["sec"][gid], 0.0)
            okg = (rr_ - r_last[gid]) >= DEAD_ZONE
            out_p.append(gid[okg]); out_r.append(rr_[okg])
            out_t.append(np.where(us[okg], 2, 1).astype(np.int8))
            active[gid] = False
    rp = np.concatenate(out_p); rr_ = np.concatenate(out_r); rt = np.concatenate(out_t)
    o = np.lexsort((rr_, rp))
    rp, rr_, rt = rp[o], rr_[o], rt[o]
    # coordinates along the central ray
    z = zA - rr_ / P["sec"][rp]
    z = z + rng.normal(0, RANGE_SD, z.size)
    x = P["gx"][rp] + (z - P["zg"][rp]) * P["tx"][rp]
    y = P["gy"][rp] + (z - P["zg"][rp]) * P["ty"][rp]
    first = np.r_[True, rp[1:] != rp[:-1]]
    grpstart = np.maximum.accumulate(np.where(first, np.arange(rp.size), 0))
    retnum = np.arange(rp.size) - grpstart + 1
    cnts = np.bincount(rp, minlength=npul)
    nret = cnts[rp]
    return dict(x=x, y=y, z=z, pid=rp, typ=rt, retnum=retnum, nret=nret, P=P, npulses=npul)


def write_laz(path, F, R, rng):
    n = R["x"].size
    AGL = F["agl"]
    P = R["P"]
    rp = R["pid"]
    # a few birds / high outliers (classified 1 like the rest of non-ground)
    nb = F["n_birds"]
    aoi = F["aoi"]
    bx, by = [], []
    b = aoi.bounds
    while len(bx) < nb:
        px, py = rng.uniform(b[0], b[2]), rng.uniform(b[1], b[3])
        if aoi.contains(Point(px, py)):
            bx.append(px); by.append(py)
    bx = np.array(bx); by = np.array(by)
    bz = terrain_z(F["T"], bx, by) + rng.uniform(45, 120, nb)
    # birds get their own (unique) time stamp half-way between two consecutive pulses
    tp = np.sort(P["t"])
    jj = rng.choice(tp.size - 1, nb, replace=False)
    btime = 0.5 * (tp[jj] + tp[jj + 1])
    typ = R["typ"]
    cls = np.where(typ == 1, 2, 1).astype(np.uint8)
    # intensity: reflectance * energy share
    refl = np.where(typ == 0, 0.45, np.where(typ == 1, 0.30, 0.38)) * np.exp(rng.normal(0, 0.2, n))
    share = 0.62 ** (R["retnum"] - 1)
    inten = np.clip(refl * share * 60000, 50, 65535).astype(np.uint16)
    ang = np.degrees(np.arctan(P["c"][rp] / AGL))
    x = np.r_[R["x"], bx]; y = np.r_[R["y"], by]; z = np.r_[R["z"], bz]
    t = np.r_[P["t"][rp], btime]
    o = np.argsort(t, kind="stable")
    hdr = laspy.LasHeader(point_format=6, version="1.4")
    hdr.scales = np.array([0.01, 0.01, 0.01])
    hdr.offsets = np.array([np.floor(x.min()), np.floor(y.min()), 0.0])
    hdr.add_crs(pyproj.CRS.from_epsg(EPSG))
    hdr.system_identifier = "SIM ALS (gen2)"
    hdr.generating_software = "gen_volume_farm.py"
    las = laspy.LasData(hdr)
    las.x = x[o]; las.y = y[o]; las.z = z[o]
    las.intensity = np.r_[inten, rng.integers(200, 3000, nb).astype(np.uint16)][o]
    las.return_number = np.r_[R["retnum"], np.ones(nb, int)][o].astype(np.uint8)
    las.number_of_returns = np.r_[R["nret"], np.ones(nb, int)][o].astype(np.uint8)
    las.classification = np.r_[cls, np.ones(nb, np.uint8)][o]
    las.scan_angle = np.round(np.r_[ang, np.zeros(nb)] / 0.006).astype(np.int16)[o]
    las.gps_time = 3.0e8 + t[o]
    las.point_source_id = np.r_[P["line"][rp], np.ones(nb, int)][o].astype(np.uint16)
    las.scan_direction_flag = np.r_[(P["k"][rp] % 2 == 0), np.zeros(nb, bool)][o].astype(np.uint8)
    edge = (P["i"][rp] == 0) | (P["i"][rp] == P["N"][rp] - 1)
    las.edge_of_flight_line = np.r_[edge, np.zeros(nb, bool)][o].astype(np.uint8)
    las.write(path, laz_backend=laspy.LazBackend.Lazrs)
    return x.size


# ----------------------------------------------------------------------------
# truth, plots, field table
# ----------------------------------------------------------------------------
def stand_truth(st):
    tr = st["trees"]
    lv = tr["live"]
    area = st["poly"].area / 1e4
    D = tr["D"][lv]; H = tr["H"][lv]; V = tr["V"][lv]
    g = np.pi / 40000 * D ** 2
    ndom = max(1, int(round(100 * area)))
    dom = np.argsort(-D)[:ndom]
    # design-based expectation of a plot estimate (uniform random centre in the
    # admissible region = polygon buffered by -(R+1.5)), i.e. what an unbiased
    # plot-expansion estimator converges to for this stand
    inner = st["poly"].buffer(-(PLOT_R + 1.5))
    xs, ys = tr["x"][lv], tr["y"][lv]
    disks = shapely.buffer(shapely.points(xs, ys), PLOT_R, quad_segs=32)
    w = shapely.area(shapely.intersection(disks, inner)) / inner.area
    plot_exp = float((V * w).sum() / (np.pi * PLOT_R ** 2) * 1e4)
    return dict(
        talhao=st["talhao"], clone=st["clone"], idade=st["idade"], area_ha=round(area, 4),
        plot_expected_vol_m3_ha=round(plot_exp, 3),
        espacamento=f"{st['spacing'][0]:g}x{st['spacing'][1]:g}",
        n_arvores_vivas=int(lv.sum()), n_posicoes=int(lv.size),
        arvores_ha=round(lv.sum() / area, 1),
        vol_total_m3=round(float(V.sum()), 3), vol_m3_ha=round(float(V.sum() / area), 3),
        G_m2_ha=round(float(g.sum() / area), 4),
        h_media_m=round(float(H.mean()), 3),
        h_lorey_m=round(float((g * H).sum() / g.sum()), 3),
        h_dom_m=round(float(H[dom].mean()), 3),
        h_dom_def="mean height of the 100 thickest (DAP) trees per ha (Assmann)",
        dap_medio_cm=round(float(D.mean()), 3), dg_cm=round(float(np.sqrt((D ** 2).mean())), 3),
        site_index_7yr_m=st["site"], site_curve_hdom_m=round(float(site_curve(st["idade"], st["site"])), 3),
        clone_dap_factor=st["clone_dap"], taper_b1=st["b1"],
        missing_frac=round(1 - lv.mean(), 4), suppressed_frac_of_live=round(float(tr["supp"][lv].mean()), 4),
        row_azimuth_deg=round(st["row_az"], 2),
        mean_crown_radius_m=round(float(tr["R"][lv].mean()), 3),
        mean_crown_length_m=round(float(tr["CL"][lv].mean()), 3),
        foliage_extinction_per_m=round(st["kappa"], 3),
    )


def draw_plots(F, K):
    rng = np.random.default_rng([F["seed"], 7919, K])
    recs = []
    pno = 1
    for si, st in enumerate(F["stands"]):
        area = st["poly"].area / 1e4
        n = max(1, int(round(area / 5.0)))
        if area / n > 6.0:
            n += 1
        inner = st["poly"].buffer(-(PLOT_R + 1.5))
        b = inner.bounds
        cen = []
        for tries in range(20000):
            if len(cen) >= n:
                break
            px, py = rng.uniform(b[0], b[2]), rng.uniform(b[1], b[3])
            if not inner.contains(Point(px, py)):
                continue
            if any(np.hypot(px - q[0], py - q[1]) < 2 * PLOT_R + 4 for q in cen):
                continue
            cen.append((px, py))
        for (px, py) in cen:
            recs.append(dict(parcela=pno, si=si, x=px, y=py))
            pno += 1
    return recs


def field_table(F, plots, K):
    rng = np.random.default_rng([F["seed"], 104729, K])
    rows = []   # parcela, arvore, true index, cap_meas, ht_meas, vol
    truth_rows = []
    for pl in plots:
        st = F["stands"][pl["si"]]
        tr = st["trees"]
        d = np.hypot(tr["x"] - pl["x"], tr["y"] - pl["y"])
        inside = np.flatnonzero(d <= PLOT_R)
        live_in = inside[tr["live"][inside]]
        dead_in = inside[~tr["live"][inside]]
        p_f = min(1.0, 0.015 / max(st["miss_frac"], 1e-3))
        dead_rec = dead_in[rng.random(dead_in.size) < p_f]
        recs = np.r_[live_in, dead_rec]
        # crew walks rows in serpentine order
        Kr = tr["K"][recs]; Jr = tr["J"][recs]
        kr = np.unique(Kr)
        rank = {k: i for i, k in enumerate(kr)}
        rk = np.array([rank[k] for k in Kr])
        order = np.lexsort((np.where(rk % 2 == 0, Jr, -Jr), rk))
        recs = recs[order]
        for j, ti in enumerate(recs):
            rows.append(dict(parcela=pl["parcela"], arvore=j + 1, ti=ti, si=pl["si"], live=bool(tr["live"][ti])))
        V = tr["V"][live_in]; D = tr["D"][live_in]
        truth_rows.append(dict(parcela=pl["parcela"], talhao=st["talhao"], x=round(pl["x"], 3), y=round(pl["y"], 3),
                               n_vivas=int(live_in.size), vol_m3_ha=round(float(V.sum() / 0.04), 3),
                               G_m2_ha=round(float((np.pi / 40000 * D ** 2).sum() / 0.04), 4)))
    df = pd.DataFrame(rows)
    live = df["live"].values
    Dt = np.array([F["stands"][s]["trees"]["D"][t] for s, t in zip(df.si, df.ti)])
    Ht = np.array([F["stands"][s]["trees"]["H"][t] for s, t in zip(df.si, df.ti)])
    Vt = np.array([F["stands"][s]["trees"]["V"][t] for s, t in zip(df.si, df.ti)])
    cap = np.where(live, np.round(np.pi * Dt + rng.normal(0, 0.3, len(df)), 1), np.nan)
    # cubagem: 1 tree per block of 12 in CAP order (stratified over size classes)
    li = np.flatnonzero(live)
    srt = li[np.argsort(cap[li])]
    cub = np.zeros(len(df), bool)
    for b0 in range(0, srt.size, 12):
        blk = srt[b0:b0 + 12]
        if blk.size >= 6 or b0 == 0:
            cub[rng.choice(blk)] = True
    # heights: 4 thickest per plot (dominants) + cubagem + random to ~30 %
    meas = cub.copy()
    for p, g in df[live].groupby("parcela"):
        idx = g.index.values
        top = idx[np.argsort(-cap[idx])[:4]]
        meas[top] = True
    for p, g in df[live].groupby("parcela"):
        idx = g.index.values
        target = int(round(0.30 * idx.size))
        cand = idx[~meas[idx]]
        need = target - meas[idx].sum()
        if need > 0 and cand.size:
            meas[rng.choice(cand, min(need, cand.size), replace=False)] = True
    ht = np.where(meas, np.where(cub, np.round(Ht + rng.normal(0, 0.05, len(df)), 1),
                                 np.round(Ht + rng.normal(0, 0.6, len(df)), 1)), np.nan)
    vol = np.where(cub, np.round(Vt, 4), np.nan)
    df["cap"] = cap; df["ht"] = ht; df["vol"] = vol
    df["D_true"] = Dt; df["H_true"] = Ht; df["V_true"] = Vt
    return df, truth_rows


def fmt(v, nd):
    if v is None or (isinstance(v, float) and np.isnan(v)):
        return ""
    return f"{v:.{nd}f}".replace(".", ",")


def write_csv(path, df):
    lines = ["parcela;arvore;cap;ht;vol"]
    for r in df.itertuples():
        lines.append(f"{r.parcela};{r.arvore};{fmt(r.cap, 1)};{fmt(r.ht, 1)};{fmt(r.vol, 4)}")
    with open(path, "w", encoding="cp1252", newline="") as f:
        f.write("\r\n".join(lines) + "\r\n")


# ----------------------------------------------------------------------------
def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--config", required=True, choices=sorted(CONFIGS))
    ap.add_argument("--out", required=True)
    ap.add_argument("--draw", type=int, default=0)
    ap.add_argument("--no-laz", action="store_true", help="skip LiDAR (voo.laz) generation")
    args = ap.parse_args()
    t0 = time.time()
    os.makedirs(args.out, exist_ok=True)
    F = build_farm(args.config)
    cfg = F["cfg"]
    crs = pyproj.CRS.from_epsg(EPSG)
    aoi = F["farm"].buffer(12, join_style="mitre")
    F["aoi"] = aoi
    F["lines"] = flight_plan(F, aoi)
    F["n_birds"] = int(round(0.4 * aoi.area / 1e4))
    # stands
    gdf = gpd.GeoDataFrame({"talhao": [s["talhao"] for s in F["stands"]],
                            "clone": [s["clone"] for s in F["stands"]],
                            "idade": [s["idade"] for s in F["stands"]]},
                           geometry=[s["poly"] for s in F["stands"]], crs=crs)
    gdf.to_file(os.path.join(args.out, "talhoes.gpkg"), layer="talhoes", driver="GPKG")
    truth = dict(config=args.config, description=cfg["desc"],
                 volume_definition="total stem volume over bark, stump 0.10 m to tip, "
                                   "Max&Burkhart(1976) taper integrated; live trees with stem inside polygon",
                 crs=f"EPSG:{EPSG}", plot_radius_m=PLOT_R,
                 params={k: v for k, v in cfg.items()},
                 terrain=dict(z0=F["T"]["z0"], grad_x=F["T"]["gx"], grad_y=F["T"]["gy"],
                              waves=F["T"]["waves"]),
                 stands=[])
    trees_all = {}
    keys = ["cx", "cy", "cm", "Ct", "Cb", "A", "B", "omega"]
    for k in keys:
        trees_all[k] = np.concatenate([s["trees"][k][s["trees"]["live"]] for s in F["stands"]])
    for st in F["stands"]:
        tt = stand_truth(st)
        tr = st["trees"]
        tt["slope_mean_pct"] = round(float(terrain_slope(F["T"], tr["x"], tr["y"]).mean() * 100), 2)
        tt["slope_max_pct"] = round(float(terrain_slope(F["T"], tr["x"], tr["y"]).max() * 100), 2)
        truth["stands"].append(tt)
    # tree-level truth
    tl = []
    for st in F["stands"]:
        tr = st["trees"]
        tl.append(pd.DataFrame(dict(talhao=st["talhao"], x=np.round(tr["x"], 3), y=np.round(tr["y"], 3),
                                    z_solo=np.round(tr["zg"], 3), viva=tr["live"].astype(int),
                                    suprimida=tr["supp"].astype(int), dap_cm=np.round(tr["D"], 3),
                                    h_m=np.round(tr["H"], 3), vol_m3=np.round(tr["V"], 5),
                                    raio_copa_m=np.round(tr["R"], 3), comp_copa_m=np.round(tr["CL"], 3),
                                    copa_x=np.round(tr["cx"], 3), copa_y=np.round(tr["cy"], 3))))
    tl = pd.concat(tl, ignore_index=True)
    tl.loc[tl.viva == 0, ["dap_cm", "h_m", "vol_m3", "raio_copa_m", "comp_copa_m"]] = np.nan
    tl.to_csv(os.path.join(args.out, "truth_arvores.csv"), index=False)
    # LiDAR
    if not args.no_laz:
        rng_l = np.random.default_rng([F["seed"], 31337])
        A_cov = coverage_area(F["lines"], aoi)
        target_pts = cfg["dens"] * aoi.area
        # pilot at low density to estimate returns per pulse
        d0 = 0.25
        Rp = simulate_lidar(F, d0, np.random.default_rng([F["seed"], 99]), trees_all, aoi)
        rho = Rp["x"].size / Rp["npulses"]
        n_pulse = target_pts / rho
        d_pulse = n_pulse / A_cov
        R = simulate_lidar(F, d_pulse, rng_l, trees_all, aoi)
        npts = write_laz(os.path.join(args.out, "voo.laz"), F, R, rng_l)
        typ = R["typ"]
        truth["lidar"] = dict(points=int(npts), pulses=int(R["npulses"]), aoi_area_ha=round(aoi.area / 1e4, 3),
                              returns_per_m2=round(npts / aoi.area, 3),
                              pulses_per_m2=round(R["npulses"] / aoi.area, 3),
                              returns_per_pulse=round(R["x"].size / R["npulses"], 3),
                              ground_frac=round(float((typ == 1).mean()), 4),
                              understory_frac=round(float((typ == 2).mean()), 4),
                              birds_high_outliers=int(F["n_birds"]),
                              flying_height_m=round(F['agl'], 1), max_scan_angle_deg=HALF_ANGLE, footprint_m=FOOTPRINT,
                              n_flight_lines=len(F["lines"]), dead_zone_m=DEAD_ZONE, max_returns=MAX_RET)
        with open(os.path.join(args.out, "truth.json"), "w") as f:
            json.dump(truth, f, indent=1, ensure_ascii=False, default=float)
    else:
        p = os.path.join(args.out, "truth.json")
        if os.path.exists(p):
            old = json.load(open(p))
            truth["lidar"] = old.get("lidar")
        with open(p, "w") as f:
            json.dump(truth, f, indent=1, ensure_ascii=False, default=float)
    # plots for draw K
    plots = draw_plots(F, args.draw)
    pg = gpd.GeoDataFrame({"parcela": np.array([p["parcela"] for p in plots], dtype=np.int64)},
                          geometry=[Point(p["x"], p["y"]) for p in plots], crs=crs)
    pg.to_file(os.path.join(args.out, f"parcelas_{args.draw}.gpkg"), layer="parcelas", driver="GPKG")
    df, ptruth = field_table(F, plots, args.draw)
    write_csv(os.path.join(args.out, f"arvores_{args.draw}.csv"), df)
    with open(os.path.join(args.out, f"truth_parcelas_{args.draw}.json"), "w") as f:
        json.dump(ptruth, f, indent=1, ensure_ascii=False)
    print(f"{args.config} draw {args.draw}: {len(plots)} plots, {len(df)} rows, "
          f"{time.time() - t0:.1f}s", flush=True)


if __name__ == "__main__":
    main()
