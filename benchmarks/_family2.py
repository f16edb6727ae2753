"""A second, independent plantation stand family (issue 41): stands, truth, LAS and stands layer.

Written from physics and from ``shared/docs/PLANTATIONS.md`` without reading the project's own
generator. A configuration (``CONFIGS``) describes one file: terrain (a plane of 0-30 % slope,
undulations, planting furrows), the flight (altitude, heading, sine or zig-zag scanner,
+-20 degrees), the point density (all returns per m^2 over the stands) and one or two stands
(talhoes), each with its planting design (rows x plants, m), row azimuth, age, crown size,
leaf area index and its shares of missing (in runs of 1-6 along a row: ants, drought),
suppressed (a small tree under its neighbours) and replanted (shorter than its row) trees.

A stand polygon follows roads and firebreaks; the planted area lies inside it, each edge set
back between half a row spacing and 4.5 m; the rows are oblique to the polygon's edges. Trees
beyond the roads (another planting, another design) appear in some files but are no stand's.
Crowns, pulses and returns: ``_family2_scan``.

``make_stand(config, seed) -> (points, truth)``; ``write_las``; ``write_stands``.
"""

from __future__ import annotations

import os
import tempfile
import zlib

import numpy as np
import shapely
from shapely.geometry import Polygon, box
from shapely.geometry.polygon import orient

try:
    from . import _family2_scan as scan
except ImportError:  # run as a script from benchmarks/
    import _family2_scan as scan

TILE = 60.0
STATUSES = ("tree", "missing", "suppressed", "replant")


def _stand(spacing, azimuth, area_ha=2.0, age=6.0, crown_k=1.15, missing=0.10,
           suppressed=0.015, replant=0.03, lai=3.6, scatter=1.0):
    """One stand's design; ``scatter`` scales the stems' planting errors, the rows' wander
    and the stems' lean (0: every top straight above its planting position)."""
    return dict(spacing=tuple(spacing), azimuth=float(azimuth), area_ha=area_ha, age=age,
                crown_k=crown_k, missing=missing, suppressed=suppressed, replant=replant,
                lai=lai, scatter=scatter)


def _cfg(name, stands, density=8.0, slope=0.05, altitude=None, scanner="sine",
         neighbours=False, understory=0.08):
    if altitude is None:
        altitude = {4.0: 1000.0, 8.0: 700.0}.get(float(density), 450.0)
    return dict(name=name, stands=stands, density=float(density), slope=float(slope),
                altitude=altitude, scanner=scanner, neighbours=neighbours,
                understory=understory)


OPEN, CLOSED, DENSE = 0.8, 1.15, 1.35  # crown diameter over sqrt(rows x plants)
CONFIGS = [
    _cfg("s3x2_a20_d8_open", [_stand((3, 2), 20, 2.5, age=3, crown_k=OPEN, lai=2.2)]),
    _cfg("s3x2_a20_d8_closed", [_stand((3, 2), 20, 2.5, crown_k=CLOSED)], slope=0.08),
    _cfg("s3x2_a95_d4_closed", [_stand((3, 2), 95, 3.5, crown_k=CLOSED)], density=4,
         slope=0.12, scanner="zigzag", neighbours=True),
    _cfg("s3x2_a140_d20_dense", [_stand((3, 2), 140, 1.2, crown_k=DENSE, missing=0.12)],
         density=20, slope=0.03),
    _cfg("s3x2_a65_d8_7yr_m15", [_stand((3, 2), 65, 2.5, age=7, crown_k=DENSE,
                                        missing=0.15)], slope=0.15, neighbours=True),
    _cfg("s3x2_a150_d8_young", [_stand((3, 2), 150, 2.0, age=2, crown_k=OPEN, lai=1.8,
                                       missing=0.12)], slope=0.20, scanner="zigzag"),
    _cfg("s3x1.5_a0_d8_closed", [_stand((3, 1.5), 0, 2.0, crown_k=CLOSED)], slope=0.05),
    _cfg("s3x1.5_a45_d20_open", [_stand((3, 1.5), 45, 1.2, age=3, crown_k=OPEN, lai=2.2)],
         density=20, slope=0.10),
    _cfg("s3x1.5_a160_d4_closed", [_stand((3, 1.5), 160, 3.5, crown_k=CLOSED)], density=4,
         slope=0.20, scanner="zigzag"),
    _cfg("s3x1.5_a110_d8_slope30", [_stand((3, 1.5), 110, 2.0, crown_k=DENSE)], slope=0.30,
         neighbours=True),
    _cfg("s3.5x2.5_a115_d8_open", [_stand((3.5, 2.5), 115, 3.0, age=3, crown_k=OPEN,
                                          lai=2.2)], slope=0.06),
    _cfg("s3.5x2.5_a70_d4_closed", [_stand((3.5, 2.5), 70, 4.0, crown_k=CLOSED)], density=4,
         slope=0.18),
    _cfg("s3.5x2.5_a170_d20_closed", [_stand((3.5, 2.5), 170, 1.5, crown_k=CLOSED)],
         density=20, slope=0.02, scanner="zigzag"),
    _cfg("s2.8x2.8_a30_d8_closed", [_stand((2.8, 2.8), 30, 2.5, crown_k=CLOSED)], slope=0.12),
    _cfg("s2.8x2.8_a135_d4_open", [_stand((2.8, 2.8), 135, 3.5, age=3, crown_k=OPEN,
                                          lai=2.2)], density=4, slope=0.25),
    _cfg("s2.8x2.8_a80_d20_dense", [_stand((2.8, 2.8), 80, 1.2, crown_k=DENSE)], density=20,
         slope=0.08, neighbours=True),
    _cfg("s3x3_a10_d8_closed", [_stand((3, 3), 10, 3.0, crown_k=CLOSED, missing=0.06)],
         slope=0.04),
    _cfg("s3x3_a125_d4_open", [_stand((3, 3), 125, 4.0, age=3, crown_k=OPEN, lai=2.2,
                                      missing=0.05)], density=4, slope=0.08),
    _cfg("s3x3_a55_d20_slope30", [_stand((3, 3), 55, 1.5, crown_k=CLOSED)], density=20,
         slope=0.30, scanner="zigzag"),
    _cfg("s2.5x2.5_a100_d8_closed", [_stand((2.5, 2.5), 100, 2.0, crown_k=CLOSED)],
         slope=0.10),
    _cfg("s4x1.2_a40_d8_closed", [_stand((4, 1.2), 40, 2.0, crown_k=CLOSED)], slope=0.06),
    _cfg("two_3x2_a20+3.5x2.5_a115_d8", [_stand((3, 2), 20, 1.6, crown_k=CLOSED),
                                          _stand((3.5, 2.5), 115, 1.6, crown_k=CLOSED)],
         slope=0.06),
    _cfg("two_3x1.5_a160+3x3_a75_d8", [_stand((3, 1.5), 160, 1.5, crown_k=CLOSED),
                                        _stand((3, 3), 75, 1.5, age=4, crown_k=OPEN)],
         slope=0.10, scanner="zigzag", neighbours=True),
]
# controls for the lattice finder: open 3 x 2 m and 3 x 3 m stands, tops straight above their
# planting positions (scatter 0), and none missing
DIAGNOSTICS = [
    _cfg("diag_s3x2_a20_d8_open_scatter0", [_stand((3, 2), 20, 2.5, age=3, crown_k=OPEN,
                                                   lai=2.2, scatter=0.0)], slope=0.05),
    _cfg("diag_s3x2_a20_d8_open_scatter0_full", [_stand((3, 2), 20, 2.5, age=3, crown_k=OPEN,
                                                        lai=2.2, scatter=0.0, missing=0.0)],
         slope=0.05),
    _cfg("diag_s3x3_a10_d8_open_scatter0", [_stand((3, 3), 10, 2.5, age=3, crown_k=OPEN,
                                                   lai=2.2, scatter=0.0)], slope=0.05),
]
CONFIG_BY_NAME = {c["name"]: c for c in CONFIGS + DIAGNOSTICS}


# ----------------------------------------------------------------------------------- terrain
class Terrain:
    """A plane of the given slope, undulations and planting furrows; callable on x, y."""

    def __init__(self, params):
        self.p = params

    @classmethod
    def random(cls, rng, cx, cy, slope, furrow_dir=(0.0, 1.0), furrow_spacing=3.0):
        aspect = rng.uniform(0, 2 * np.pi)
        waves = []
        for _ in range(3):
            lam = rng.uniform(50, 160)
            ang = rng.uniform(0, 2 * np.pi)
            amp = 0.025 * lam / (2 * np.pi)           # each wave adds at most 2.5 % slope
            waves.append([amp, 2 * np.pi / lam * np.sin(ang), 2 * np.pi / lam * np.cos(ang),
                          rng.uniform(0, 2 * np.pi)])
        return cls(dict(cx=cx, cy=cy, z0=rng.uniform(600, 900), slope=slope,
                        sx=np.sin(aspect), sy=np.cos(aspect), waves=waves,
                        fx=furrow_dir[0], fy=furrow_dir[1], fs=furrow_spacing, fa=0.06))

    def __call__(self, x, y):
        p = self.p
        dx, dy = np.asarray(x) - p["cx"], np.asarray(y) - p["cy"]
        z = p["z0"] + p["slope"] * (dx * p["sx"] + dy * p["sy"])
        for a, kx, ky, ph in p["waves"]:
            z = z + a * np.cos(kx * dx + ky * dy + ph)
        across = dx * p["fy"] - dy * p["fx"]
        return z + p["fa"] * np.cos(2 * np.pi * across / p["fs"])

    def grad(self, x, y):
        p = self.p
        dx, dy = np.asarray(x) - p["cx"], np.asarray(y) - p["cy"]
        gx = np.full(np.shape(dx), p["slope"] * p["sx"])
        gy = np.full(np.shape(dy), p["slope"] * p["sy"])
        for a, kx, ky, ph in p["waves"]:
            s = -a * np.sin(kx * dx + ky * dy + ph)
            gx, gy = gx + s * kx, gy + s * ky
        return gx, gy


def terrain_z(truth, x, y):
    """Ground height of the truth's terrain at x, y."""
    return Terrain(truth["terrain"])(x, y)


# ---------------------------------------------------------------------------------- polygons
def _cut_corners(poly, rng, n):
    """Cut ``n`` corners of a convex polygon by oblique chords (15-35 % of each side)."""
    for _ in range(n):
        c = np.asarray(poly.exterior.coords)[:-1]
        i = rng.integers(len(c))
        a, b, d = c[i - 1], c[i], c[(i + 1) % len(c)]
        p1 = b + (a - b) * rng.uniform(0.15, 0.35)
        p2 = b + (d - b) * rng.uniform(0.15, 0.35)
        poly = poly.difference(Polygon([b, p1, p2]).buffer(1e-6))
        poly = shapely.convex_hull(poly)
    return orient(poly, 1.0)


def _rect(cx, cy, w, h, ang):
    ca, sa = np.cos(ang), np.sin(ang)
    pts = [(-w / 2, -h / 2), (w / 2, -h / 2), (w / 2, h / 2), (-w / 2, h / 2)]
    return Polygon([(cx + x * ca - y * sa, cy + x * sa + y * ca) for x, y in pts])


def _stand_polygons(cfg, rng, cx, cy):
    areas = [s["area_ha"] * 1e4 for s in cfg["stands"]]
    road = 7.0
    ang = rng.uniform(0, np.pi)
    ar = rng.uniform(1.1, 1.6)
    total = sum(areas) * 1.12 + (road * np.sqrt(sum(areas)) if len(areas) > 1 else 0)
    w = np.sqrt(total * ar)
    big = _rect(cx, cy, w, total / w, ang)
    if len(areas) == 1:
        return [_cut_corners(big, rng, 2)]
    f = areas[0] / sum(areas)
    tilt = ang + np.pi / 2 + rng.uniform(-0.35, 0.35)
    mx = cx + np.cos(ang) * w * (f - 0.5)
    my = cy + np.sin(ang) * w * (f - 0.5)
    nx, ny = np.cos(tilt), np.sin(tilt)
    L = 10 * w
    half = Polygon([(mx - nx * L, my - ny * L), (mx + nx * L, my + ny * L),
                    (mx + nx * L + ny * L, my + ny * L - nx * L),
                    (mx - nx * L + ny * L, my - ny * L - nx * L)])
    parts = [big.difference(half), big.intersection(half)]
    c0 = np.array(parts[0].centroid.coords[0]) - [mx, my]
    if c0 @ [np.cos(ang), np.sin(ang)] > 0:
        parts = parts[::-1]
    out = []
    for part in parts:
        part = part.buffer(-road / 2, join_style="mitre")
        out.append(_cut_corners(part, rng, 1))
    return out


def _planted_area(poly, rng, rs):
    """The stand polygon with each edge set back by 0.5 x rows .. 4.5 m (firebreaks, roads)."""
    c = np.asarray(poly.exterior.coords)
    area = poly
    setbacks = []
    for a, b in zip(c[:-1], c[1:]):
        d = rng.uniform(0.5 * rs, 4.5)
        t = (b - a) / np.linalg.norm(b - a)
        n = np.array([-t[1], t[0]])                    # left of a CCW edge = inside
        big = 1e4
        hp = Polygon([a + n * d - t * big, b + n * d + t * big,
                      b + n * big + t * big, a + n * big - t * big])
        area = area.intersection(hp)
        setbacks.append(d)
    return area, setbacks


# -------------------------------------------------------------------------------- positions
def _units(az):
    a = np.radians(az)
    return np.array([np.sin(a), np.cos(a)]), np.array([np.cos(a), -np.sin(a)])


def _lattice_positions(planted, origin, az, rs, ps):
    u, v = _units(az)
    c = np.asarray(planted.exterior.coords) - origin
    al, ac = c @ u, c @ v
    i = np.arange(int(np.floor(ac.min() / rs)) - 1, int(np.ceil(ac.max() / rs)) + 2)
    j = np.arange(int(np.floor(al.min() / ps)) - 1, int(np.ceil(al.max() / ps)) + 2)
    ii, jj = np.meshgrid(i, j, indexing="ij")
    ii, jj = ii.ravel(), jj.ravel()
    x = origin[0] + ii * rs * v[0] + jj * ps * u[0]
    y = origin[1] + ii * rs * v[1] + jj * ps * u[1]
    keep = shapely.contains_xy(planted, x, y)
    return x[keep], y[keep], ii[keep], jj[keep]


def _statuses(row, plant, st, rng):
    n = row.size
    status = np.array(["tree"] * n, dtype="U10")
    key = {(r, p): k for k, (r, p) in enumerate(zip(row.tolist(), plant.tolist()))}
    target = int(round(st["missing"] * n))
    lengths = np.arange(1, 7)
    probs = np.array([0.38, 0.2, 0.15, 0.11, 0.09, 0.07])
    guard = 0
    while (status == "missing").sum() < target and guard < 100 * n:
        guard += 1
        k = rng.integers(n)
        run = rng.choice(lengths, p=probs)
        for s in range(run):
            m = key.get((row[k], plant[k] + s))
            if m is None or (status == "missing").sum() >= target:
                break
            status[m] = "missing"
    trees = np.nonzero(status == "tree")[0]
    near = [k for k in trees if status[key.get((row[k], plant[k] - 1), k)] == "missing"
            or status[key.get((row[k], plant[k] + 1), k)] == "missing"]
    n_rep = int(round(st["replant"] * n))
    pool_near = rng.permutation(near)[: int(0.6 * n_rep)]
    rest = np.setdiff1d(trees, pool_near)
    rep = np.concatenate([pool_near, rng.permutation(rest)[: n_rep - pool_near.size]])
    status[rep.astype(int)] = "replant"
    trees = np.nonzero(status == "tree")[0]
    status[rng.permutation(trees)[: int(round(st["suppressed"] * n))]] = "suppressed"
    return status, key


def height_at_age(age):
    """Mean height of a good-site eucalyptus clone (m) at ``age`` years."""
    return 30.0 * (1.0 - np.exp(-0.3 * age)) ** 1.3


def _crown_volume_factor(p, dm, b):
    d = np.linspace(0, 1, 41)[None, :]
    return np.mean(scan.crown_profile(d, p[:, None], dm[:, None], b[:, None]) ** 2, axis=1)


def _trees(x, y, row, plant, status, key, st, rng, terrain, origin_az):
    """Tree arrays (stem, apex, crown shape, LAD) for the positions that hold a tree."""
    rs, ps = st["spacing"]
    u, v = _units(origin_az)
    n = x.size
    has = status != "missing"
    k = np.nonzero(has)[0]
    hm = height_at_age(st["age"]) * rng.uniform(0.95, 1.05)
    rows = np.unique(row)
    row_eff = dict(zip(rows.tolist(), rng.normal(0, 0.02, rows.size)))
    wander = {r: (rng.uniform(0, 0.12), rng.uniform(30, 80), rng.uniform(0, 6.3))
              for r in rows.tolist()}
    along = plant * ps
    wa = np.array([wander[r][0] * np.sin(2 * np.pi * a / wander[r][1] + wander[r][2])
                   for r, a in zip(row.tolist(), along)])
    sc = st.get("scatter", 1.0)
    ea_err, ec_err = sc * rng.normal(0, 0.10, n), sc * (rng.normal(0, 0.06, n) + wa)
    sx = x + ea_err * u[0] + ec_err * v[0]
    sy = y + ea_err * u[1] + ec_err * v[1]
    h = hm * (1 + np.array([row_eff[r] for r in row.tolist()]) + rng.normal(0, 0.07, n))
    r0 = st["crown_k"] * np.sqrt(rs * ps) / 2.0
    rad = r0 * (h / hm) ** 0.8 * (1 + rng.normal(0, 0.08, n))
    rep, sup = status == "replant", status == "suppressed"
    h[rep] = hm * rng.uniform(0.55, 0.8, rep.sum())
    rad[rep] = r0 * rng.uniform(0.5, 0.75, rep.sum())
    h[sup] = hm * rng.uniform(0.35, 0.55, sup.sum())
    rad[sup] = r0 * rng.uniform(0.35, 0.55, sup.sum())
    emptiness = {"missing": 1.0, "suppressed": 0.6, "replant": 0.3, "tree": 0.0}
    c1 = rng.normal(0, 0.08, n).astype(complex)
    for dr, dp, phi, w in ((0, 1, 0.0, 0.3), (0, -1, np.pi, 0.3),
                           (1, 0, np.pi / 2, 0.22), (-1, 0, -np.pi / 2, 0.22)):
        e = np.array([1.0 if (r + dr, p + dp) not in key
                      else emptiness[status[key[(r + dr, p + dp)]]]
                      for r, p in zip(row.tolist(), plant.tolist())])
        c1 += w * e * np.exp(-1j * phi)
    mag = np.abs(c1)
    c1 = np.where(mag > 0.5, c1 * 0.5 / np.maximum(mag, 1e-9), c1)
    phi0 = -np.angle(c1)
    lean_a = rng.normal(0, 0.015, n) + 0.03 * np.abs(c1) * np.cos(phi0)
    lean_c = rng.normal(0, 0.012, n) + 0.03 * np.abs(c1) * np.sin(phi0)
    lean_a, lean_c = np.clip(sc * lean_a, -0.05, 0.05), np.clip(sc * lean_c, -0.05, 0.05)
    ax = sx + h * (lean_a * u[0] + lean_c * v[0])
    ay = sy + h * (lean_a * u[1] + lean_c * v[1])
    q = np.clip(np.sqrt(rs / ps), 1.0, 1.35)
    ea = np.where(sup, 1.0, 1 / np.sqrt(q))
    eb = np.where(sup, 1.0, np.sqrt(q))
    cr = np.clip(0.85 - 0.06 * st["age"], 0.4, 0.8)
    L = np.where(sup, 0.6, cr) * h * rng.uniform(0.9, 1.1, n)
    p = rng.uniform(0.35, 0.7, n)
    dm = rng.uniform(0.3, 0.5, n)
    b = rng.uniform(0.35, 0.65, n)
    vol = np.pi * np.mean(r0 ** 2 * cr * hm * _crown_volume_factor(p, dm, b))
    lad = st["lai"] * rs * ps / vol * rng.uniform(0.85, 1.15, n)
    c2 = rng.uniform(0.04, 0.16, n) * np.exp(-1j * rng.uniform(0, 2 * np.pi, n))
    c3 = rng.uniform(0.02, 0.10, n) * np.exp(-1j * rng.uniform(0, 2 * np.pi, n))
    t = dict(x=sx, y=sy, zb=terrain(sx, sy), ax=ax, ay=ay, H=h, R=rad, L=L, ea=ea, eb=eb,
             ux=np.full(n, u[0]), uy=np.full(n, u[1]), p=p, dm=dm, b=b, c1=c1, c2=c2, c3=c3,
             lad=lad)
    return {key_: val[k] for key_, val in t.items()}, dict(stem_x=sx, stem_y=sy, top_x=ax,
                                                          top_y=ay, height=h, crown_radius=rad)


def _position_table(x, y, row, plant, status, extra, talhao):
    n = x.size
    dt = [("talhao", "U8"), ("x", "f8"), ("y", "f8"), ("row", "i4"), ("plant", "i4"),
          ("status", "U10"), ("stem_x", "f8"), ("stem_y", "f8"), ("top_x", "f8"),
          ("top_y", "f8"), ("height", "f8"), ("crown_radius", "f8")]
    tab = np.zeros(n, dtype=dt)
    tab["talhao"], tab["x"], tab["y"] = talhao, x, y
    tab["row"], tab["plant"], tab["status"] = row, plant, status
    miss = status == "missing"
    for f in ("stem_x", "stem_y", "top_x", "top_y", "height", "crown_radius"):
        tab[f] = np.where(miss, np.nan, extra[f])
    return tab


def _neighbour_trees(bbox, stands_union, rng, terrain, age):
    """Another planting beyond the roads around the stands (3 x 2 m, own azimuth)."""
    az = rng.uniform(0, 180)
    st = _stand((3, 2), az, age=age, crown_k=1.1, missing=0.03)
    area = box(*bbox).difference(stands_union.buffer(7.0))
    if area.is_empty:
        return None
    origin = np.array([bbox[0], bbox[1]]) + rng.uniform(0, 3, 2)
    out_x, out_y, rr, pp = [], [], [], []
    for poly in getattr(area, "geoms", [area]):
        if poly.geom_type != "Polygon" or poly.area < 20:
            continue
        x, y, r, p = _lattice_positions(poly, origin, az, 3.0, 2.0)
        out_x.append(x), out_y.append(y), rr.append(r), pp.append(p)
    if not out_x:
        return None
    x, y, r, p = (np.concatenate(a) for a in (out_x, out_y, rr, pp))
    status, key = _statuses(r, p, st, rng)
    t, _ = _trees(x, y, r, p, status, key, st, rng, terrain, az)
    return t


# ---------------------------------------------------------------------------------- the scene
def _simulate(trees, terrain, pulses, bbox, seed, understory, rng, chunk=6000):
    """Returns of ``pulses`` over the scene, tile by tile (40 m cores with a ray buffer)."""
    gx0, gy0 = bbox[0], bbox[1]
    hmax = float(trees["H"].max())
    nh = int(np.ceil((hmax + 1.5) / scan.DH))
    buf = np.tan(np.radians(20.5)) * (hmax + 1.5) + 1.0
    tx = np.floor((pulses["xg"] - gx0) / TILE).astype(int)
    ty = np.floor((pulses["yg"] - gy0) / TILE).astype(int)
    tid = ty * 100000 + tx
    gx, gy = terrain.grad(pulses["xg"], pulses["yg"])
    pulses = dict(pulses, gx=gx, gy=gy)
    margin = int(np.ceil(buf / scan.DXY)) + 4
    ncx = int(np.ceil((bbox[2] - bbox[0]) / scan.DXY)) + 2 * margin
    ncy = int(np.ceil((bbox[3] - bbox[1]) / scan.DXY)) + 2 * margin
    crng = np.random.default_rng([seed, 11, int(bbox[0]) % 100000])
    clumps = (scan.scene_clumps(ncx // 2 + 2, ncy // 2 + 2, nh, crng), margin)
    outs = []
    for t in np.unique(tid):
        sel = np.nonzero(tid == t)[0]
        x0, y0 = gx0 + (t % 100000) * TILE, gy0 + (t // 100000) * TILE
        gix0 = int(np.floor((x0 - buf - gx0) / scan.DXY))
        giy0 = int(np.floor((y0 - buf - gy0) / scan.DXY))
        nx = ny = int(np.ceil((TILE + 2 * buf) / scan.DXY)) + 1
        grid = scan.build_voxels(trees, terrain, gx0, gy0, gix0, giy0, nx, ny, nh, clumps,
                                 understory=understory)
        for s in range(0, sel.size, chunk):
            part = {k: v[sel[s:s + chunk]] for k, v in pulses.items()}
            outs.append(scan.trace(grid, gx0 + gix0 * scan.DXY, gy0 + giy0 * scan.DXY,
                                   part, rng))
    return {k: np.concatenate([o[k] for o in outs]) for k in outs[0]}


def _flight(cfg, bbox, terrain, density, seed):
    frng = np.random.default_rng([seed, 7, zlib.crc32(cfg["name"].encode())])
    heading = frng.choice([0.0, 90.0, 45.0, 135.0]) + frng.normal(0, 8)
    return scan.flight_pulses(bbox, terrain, density, frng, altitude=cfg["altitude"],
                              heading=heading, scanner=cfg["scanner"])


def _returns_per_pulse(cfg, stands, polys, trees, terrain, bbox, seed, rng):
    """Pilot: returns per pulse over the stands (2,000 pulses in each planted area's central
    tile; a firebreak pulse gives about one return)."""
    pilot = _flight(cfg, bbox, terrain, cfg["density"] / 1.5, seed)
    total = 0.0
    for st, poly in zip(stands, polys):
        planted = shapely.from_wkt(st["planted"])
        tile = np.floor((np.array(planted.centroid.coords[0]) - np.array(bbox[:2])) / TILE)
        near = np.nonzero((np.floor((pilot["xg"] - bbox[0]) / TILE) == tile[0])
                          & (np.floor((pilot["yg"] - bbox[1]) / TILE) == tile[1])
                          & shapely.contains_xy(planted, pilot["xg"], pilot["yg"]))[0]
        near = rng.permutation(near)[:2000]
        r = 2.0
        if near.size:
            pr = _simulate(trees, terrain, {k: v[near] for k, v in pilot.items()}, bbox, seed,
                           cfg["understory"], rng)
            r = pr["x"].size / near.size
        total += r * planted.area + 1.02 * (poly.area - planted.area)
    return total / sum(p.area for p in polys)


def make_stand(config, seed=0):
    """One file of the family: ``(points, truth)`` for a configuration (dict or name).

    ``points``: dict of arrays x, y, z (float64), classification (2 ground, 1 other),
    return_number, number_of_returns, intensity, gps_time, scan_angle, point_source_id,
    scan_direction_flag, edge_of_flight_line. ``truth``: config, seed, epsg, terrain (parameters,
    see ``terrain_z``), bbox, stands (one dict per talhao: talhao, lattice {azimuth,
    row_spacing, plant_spacing, origin}, positions (a structured array: talhao, x, y, row,
    plant, status in tree/missing/suppressed/replant, stem_x/y, top_x/y, height,
    crown_radius), polygon and planted (WKT), setbacks, counts, stocking_pct, area_ha),
    positions (all stands), stocking_pct (all stands), density (returns per m^2 over the
    stands), n_pulses.
    """
    cfg = CONFIG_BY_NAME[config] if isinstance(config, str) else config
    rng = np.random.default_rng([seed, zlib.crc32(cfg["name"].encode())])  # own layout each
    cx, cy = 640000.0 + rng.uniform(0, 20000), 7780000.0 + rng.uniform(0, 40000)
    polys = _stand_polygons(cfg, rng, cx, cy)
    st0 = cfg["stands"][0]
    u0, v0 = _units(st0["azimuth"])
    terrain = Terrain.random(rng, cx, cy, cfg["slope"], furrow_dir=tuple(u0),
                             furrow_spacing=st0["spacing"][0])
    stands, tree_parts = [], []
    for i, (st, poly) in enumerate(zip(cfg["stands"], polys)):
        rs, ps = st["spacing"]
        planted, setbacks = _planted_area(poly, rng, rs)
        u, v = _units(st["azimuth"])
        c = np.array(planted.centroid.coords[0])
        origin = c + rng.uniform(0, rs) * v + rng.uniform(0, ps) * u
        x, y, ii, jj = _lattice_positions(planted, origin, st["azimuth"], rs, ps)
        row, plant = ii - ii.min(), jj - jj.min()
        origin = origin + ii.min() * rs * v + jj.min() * ps * u
        status, key = _statuses(row, plant, st, rng)
        t, extra = _trees(x, y, row, plant, status, key, st, rng, terrain, st["azimuth"])
        tree_parts.append(t)
        talhao = f"T{i + 1:02d}"
        tab = _position_table(x, y, row, plant, status, extra, talhao)
        counts = {s: int((status == s).sum()) for s in STATUSES}
        stands.append(dict(
            talhao=talhao, lattice=dict(azimuth=st["azimuth"] % 180.0, row_spacing=rs,
                                        plant_spacing=ps, origin=(float(origin[0]),
                                                                  float(origin[1]))),
            positions=tab, polygon=poly.wkt, planted=planted.wkt, setbacks=setbacks,
            counts=counts, n_positions=int(x.size), area_ha=poly.area / 1e4,
            stocking_pct=100.0 * (x.size - counts["missing"]) / x.size, config=st))
    union = shapely.union_all(polys)
    b = union.bounds
    bbox = (np.floor(b[0] - 12), np.floor(b[1] - 12), np.ceil(b[2] + 12), np.ceil(b[3] + 12))
    if cfg["neighbours"]:
        nt = _neighbour_trees(bbox, union, rng, terrain, cfg["stands"][0]["age"])
        if nt is not None:
            tree_parts.append(nt)
    trees = {k: np.concatenate([t[k] for t in tree_parts]) for k in tree_parts[0]}
    r_stand = _returns_per_pulse(cfg, stands, polys, trees, terrain, bbox, seed, rng)
    # the stands may lie in a strip flown once or twice: scale the rate by the pulses they get
    dp = cfg["density"] / r_stand
    trial = _flight(cfg, bbox, terrain, dp, seed)
    local = shapely.contains_xy(union, trial["xg"], trial["yg"]).sum() / union.area
    pulses = _flight(cfg, bbox, terrain, 1.1 * dp * dp / max(local, 1e-6), seed)
    pulses["pid"] = np.arange(pulses["xg"].size)
    pts = _simulate(trees, terrain, pulses, bbox, seed, cfg["understory"], rng)
    # a lower pulse rate: keep a regular share of the pulses (in time order) for the density
    inside = shapely.contains_xy(union, pts["x"], pts["y"])
    q = min(1.0, cfg["density"] * union.area / max(inside.sum(), 1))
    i = np.arange(pulses["xg"].size)
    kept = np.floor((i + 1) * q) > np.floor(i * q)
    keep = kept[pts["pid"]]
    pts = {k: v[keep] for k, v in pts.items() if k != "pid"}
    inside = inside[keep]
    order = np.lexsort((pts["return_number"], pts["gps_time"]))
    pts = {k: v[order] for k, v in pts.items()}
    positions = np.concatenate([s["positions"] for s in stands])
    n_pos = positions.size
    truth = dict(
        config=cfg["name"], seed=seed, epsg=31983, terrain=terrain.p, bbox=bbox,
        stands=stands, positions=positions,
        stocking_pct=100.0 * (positions["status"] != "missing").sum() / n_pos,
        density=float(inside.sum() / union.area), n_pulses=int(kept.sum()),
        n_trees_scene=int(trees["H"].size))
    return pts, truth


# ------------------------------------------------------------------------------------ writers
def _atomic(path, write):
    path = os.fspath(path)
    d = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(dir=d, suffix=os.path.splitext(path)[1])
    os.close(fd)
    try:
        write(tmp)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)


def write_las(points, path, epsg=31983):
    """Write the points as LAS 1.4 (point format 6) with the CRS as a WKT VLR."""
    import laspy
    import pyproj

    hdr = laspy.LasHeader(point_format=6, version="1.4")
    hdr.scales = np.array([0.001, 0.001, 0.001])
    hdr.offsets = np.array([np.floor(points["x"].min()), np.floor(points["y"].min()),
                            np.floor(points["z"].min())])
    hdr.add_crs(pyproj.CRS.from_epsg(epsg))
    las = laspy.LasData(hdr)
    las.x, las.y, las.z = points["x"], points["y"], points["z"]
    for f in ("intensity", "return_number", "number_of_returns", "classification",
              "gps_time", "point_source_id", "scan_direction_flag", "edge_of_flight_line"):
        if f in points:
            setattr(las, f, points[f])
    if "scan_angle" in points:
        las.scan_angle = np.round(np.asarray(points["scan_angle"]) / 0.006).astype(np.int16)
    _atomic(path, las.write)


def write_stands(truth_list, path, epsg=31983):
    """Write the stand polygons (field ``talhao``, area_ha) to a GeoPackage layer ``talhoes``.

    ``truth_list``: a truth from ``make_stand``, or a list of truths or of their stands.
    """
    import geopandas as gpd

    items = truth_list if isinstance(truth_list, (list, tuple)) else [truth_list]
    stands = []
    for t in items:
        stands.extend(t["stands"] if "stands" in t else [t])
    gdf = gpd.GeoDataFrame(
        {"talhao": [s["talhao"] for s in stands],
         "area_ha": [round(s["area_ha"], 4) for s in stands]},
        geometry=[shapely.from_wkt(s["polygon"]) for s in stands], crs=f"EPSG:{epsg}")
    _atomic(path, lambda tmp: gdf.to_file(tmp, layer="talhoes", driver="GPKG",
                                          engine="pyogrio"))
