"""Canopy, pulses and returns of the second stand family (`_family2`).

Written from physics, independently of the project's own generator:

* every crown is rasterised into a leaf-area-density (LAD) voxel grid of height above ground
  (0.25 m x 0.25 m x 0.5 m): an envelope that runs from a cone to a paraboloid below the apex,
  widest at 55-75 % of the crown length and narrowing again to the crown base, elliptical
  (wider across the row), with azimuthal lobes, a one-sided bulge towards empty neighbours
  and a leaning axis; the foliage inside is clumped by a hashed noise field (branch clusters);
* pulses come from flight lines (sine or zig-zag scan mirror, +-20 degrees), each with a
  Gaussian beam footprint sampled by sub-rays; a sub-ray loses energy to foliage by Beer-Lambert
  (G = 0.35, eucalyptus leaves hang steeply) and the rest reaches the ground;
* the energies make a waveform (0.15 m bins, a Gaussian system pulse); a discrete-return
  detector takes its peaks above a threshold from the top down, with a dead zone between
  returns, up to five per pulse; a return lies on the beam axis at its peak's range, and is
  ground (class 2) when the ground's energy dominates its peak.
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import gaussian_filter1d, uniform_filter

DXY = 0.25          # voxel side in x and y, m
DH = 0.5            # voxel height, m
BIN = 0.15          # waveform bin, m
G_LEAF = 0.5        # projection of leaf area on the beam
SIGMA_PULSE = 0.30  # system pulse, m (one standard deviation in range)
DEAD_ZONE = 2.0     # smallest separation of two returns of one pulse, m
MAX_RETURNS = 4
THRESHOLD = 0.03    # detection threshold: share of the peak a full-energy hard target gives
SUB_RAYS = 3


def scene_clumps(nx, ny, nh, rng, sigma=0.9):
    """Lognormal clumping (mean 1) of foliage on 0.5 m cells of the whole scene, box-filtered
    over 1 m (branch clusters); indexed by ``build_voxels`` with the 0.25 m cells // 2."""
    u = rng.random((ny, nx, nh), dtype=np.float32)
    m = uniform_filter(u, size=(2, 2, 2), mode="nearest")
    n = (m - 0.5) / np.float32(np.sqrt(1.0 / 12.0 / 8.0))
    return np.exp(np.float32(sigma) * n - np.float32(0.5 * sigma * sigma)).astype(np.float32)


def crown_profile(d, p, dm, b):
    """Relative crown radius at relative depth d below the apex (0 apex, 1 crown base)."""
    up = np.power(np.clip(d / dm, 0.0, 1.0), p)
    down = 1.0 - (1.0 - b) * (d - dm) / (1.0 - dm)
    return np.where(d < dm, up, down)


def crown_reach(t):
    """Largest horizontal reach of each crown from its apex column, m."""
    lob = 1.0 + np.abs(t["c1"]) + np.abs(t["c2"]) + np.abs(t["c3"])
    lean = np.hypot(t["ax"] - t["x"], t["ay"] - t["y"]) / t["H"] * t["L"]
    return t["R"] * np.maximum(t["ea"], t["eb"]) * lob + lean + 0.3


def build_voxels(t, terrain, gx0, gy0, gix0, giy0, nx, ny, nh, clumps, understory=0.0):
    """LAD grid (ny, nx, nh) of one tile: cells gix0.. x giy0.. of the scene's 0.25 m grid.

    ``clumps``: (array, margin) from ``scene_clumps``, its cell (0, 0) at 0.25 m cell
    (-margin, -margin) of the scene."""
    x0, y0 = gx0 + gix0 * DXY, gy0 + giy0 * DXY
    xc = x0 + (np.arange(nx) + 0.5) * DXY
    yc = y0 + (np.arange(ny) + 0.5) * DXY
    tc = terrain(*np.meshgrid(xc, yc))                         # (ny, nx)
    grid = np.zeros(ny * nx * nh, np.float64)
    reach = crown_reach(t)
    sel = np.nonzero((t["ax"] + reach > x0) & (t["ax"] - reach < x0 + nx * DXY)
                     & (t["ay"] + reach > y0) & (t["ay"] - reach < y0 + ny * DXY))[0]
    flats, weights = [], []
    for start in range(0, sel.size, 60):
        k = sel[start:start + 60]
        m = int(np.ceil(reach[k].max() / DXY))
        oy, ox = np.mgrid[-m:m + 1, -m:m + 1]
        ox, oy = ox.ravel(), oy.ravel()
        cix = np.floor((t["ax"][k] - x0) / DXY).astype(int)
        ciy = np.floor((t["ay"][k] - y0) / DXY).astype(int)
        kk = np.repeat(np.arange(k.size), ox.size)
        ix = np.repeat(cix, ox.size) + np.tile(ox, k.size)
        iy = np.repeat(ciy, ox.size) + np.tile(oy, k.size)
        ok = (ix >= 0) & (ix < nx) & (iy >= 0) & (iy < ny)
        kk, ix, iy = kk[ok], ix[ok], iy[ok]
        # keep the cells within the crown's widest outline (at depth dm), grown by the lean
        lean = np.hypot(t["ax"] - t["x"], t["ay"] - t["y"])[k] / t["H"][k] * t["L"][k]
        dx = xc[ix] - (t["ax"][k] - (t["ax"][k] - t["x"][k]) / t["H"][k] * t["dm"][k]
                       * t["L"][k])[kk]
        dy = yc[iy] - (t["ay"][k] - (t["ay"][k] - t["y"][k]) / t["H"][k] * t["dm"][k]
                       * t["L"][k])[kk]
        pa = dx * t["ux"][k][kk] + dy * t["uy"][k][kk]
        pv = dx * t["uy"][k][kk] - dy * t["ux"][k][kk]
        e = (pa + 1j * pv) / (np.hypot(pa, pv) + 1e-9)
        lob = 1.0 + np.real(t["c1"][k][kk] * e + t["c2"][k][kk] * e * e
                            + t["c3"][k][kk] * e * e * e)
        q = np.hypot(pa / t["ea"][k][kk], pv / t["eb"][k][kk])
        ok = q <= t["R"][k][kk] * lob + lean[kk] * 1.2 + 0.3
        kk, ix, iy, lob, q = kk[ok], ix[ok], iy[ok], lob[ok], q[ok]
        if kk.size == 0:
            continue
        tr = {key: np.asarray(v)[k][kk] for key, v in t.items()}
        # depth range of the crown over this cell (profile inverted, widened by the lean)
        x_lo = np.clip((q - lean[kk] - 0.3) / (tr["R"] * lob), 0.0, 1.0)
        d_lo = tr["dm"] * x_lo ** (1.0 / tr["p"])
        d_hi = np.minimum(1.0, tr["dm"] + (1.0 - x_lo) / (1.0 - tr["b"]) * (1.0 - tr["dm"]))
        za = tr["zb"] + tr["H"]
        tcell = tc[iy, ix]
        top = np.minimum(np.floor((za - d_lo * tr["L"] - tcell) / DH).astype(int) + 1, nh - 1)
        bot = np.maximum(np.floor((za - d_hi * tr["L"] - tcell) / DH).astype(int) - 1, 0)
        cnt = np.maximum(top - bot + 1, 0)
        j = np.repeat(np.arange(kk.size), cnt)
        lev = top[j] - (np.arange(j.size) - np.repeat(np.cumsum(cnt) - cnt, cnt))
        d = (za[j] - tcell[j] - (lev + 0.5) * DH) / tr["L"][j]
        lx = (tr["ax"] - tr["x"]) / tr["H"] * tr["L"]
        ly = (tr["ay"] - tr["y"]) / tr["H"] * tr["L"]
        dx = xc[ix[j]] - (tr["ax"][j] - lx[j] * d)
        dy = yc[iy[j]] - (tr["ay"][j] - ly[j] * d)
        pa = dx * tr["ux"][j] + dy * tr["uy"][j]
        pv = dx * tr["uy"][j] - dy * tr["ux"][j]
        qq = np.hypot(pa / tr["ea"][j], pv / tr["eb"][j])
        renv = tr["R"][j] * crown_profile(d, tr["p"][j], tr["dm"][j], tr["b"][j]) * lob[j]
        shell = 0.4 + 1.2 * np.minimum(qq / np.maximum(renv, 1e-6), 1.0) ** 2  # foliage at
        w = (tr["lad"][j] * (1.6 - 1.2 * d) * shell                          # branch tips
             * np.clip((renv - qq) / 0.25 + 0.5, 0.0, 1.0))
        nz = (w > 0) & (d >= 0) & (d <= 1)
        flats.append(((iy[j] * nx + ix[j]) * nh + lev)[nz])
        weights.append(w[nz])
    if flats:
        grid += np.bincount(np.concatenate(flats), weights=np.concatenate(weights),
                            minlength=grid.size)
    grid = grid.reshape(ny, nx, nh).astype(np.float32)
    if understory > 0:
        grid[:, :, :2] += np.float32(understory)
    cl, margin = clumps
    cy_ = (giy0 + np.arange(ny) + margin) // 2
    cx_ = (gix0 + np.arange(nx) + margin) // 2
    grid *= cl[np.clip(cy_, 0, cl.shape[0] - 1)][:, np.clip(cx_, 0, cl.shape[1] - 1), :nh]
    return grid


def trace(grid, x0, y0, pulses, rng, rho_leaf=0.45, rho_ground=0.30):
    """Returns of pulses through one tile's LAD grid (origin x0, y0).

    ``pulses``: dict of arrays xg, yg, zg (central ray's ground point), gx, gy (terrain
    gradient there), wx, wy (horizontal shift per metre up the beam), fp (footprint diameter, m),
    plus pass-through fields. Returns a dict of per-return arrays.
    """
    ny, nx, nh = grid.shape
    filled = np.nonzero(grid.reshape(-1, nh).max(axis=0) > 0)[0]
    nhe = int(filled.max()) + 2 if filled.size else 1
    nhe = min(nhe, nh)
    p = pulses
    n = p["xg"].size
    s = SUB_RAYS
    off = rng.normal(0.0, 1.0, (n, s, 2)) * (p["fp"] / 4.0)[:, None, None]
    denom = 1.0 - (p["gx"] * p["wx"] + p["gy"] * p["wy"])
    path = DH / denom * np.sqrt(1.0 + p["wx"] ** 2 + p["wy"] ** 2)
    zrel = ((np.arange(nhe) + 0.5) * DH)[None, :] / denom[:, None]            # (n, k)
    xs = p["xg"][:, None, None] + off[:, :, 0:1] + p["wx"][:, None, None] * zrel[:, None, :]
    ys = p["yg"][:, None, None] + off[:, :, 1:2] + p["wy"][:, None, None] * zrel[:, None, :]
    ix = np.floor((xs - x0) / DXY).astype(np.int64)
    iy = np.floor((ys - y0) / DXY).astype(np.int64)
    inside = (ix >= 0) & (ix < nx) & (iy >= 0) & (iy < ny)
    kk = np.broadcast_to(np.arange(nhe), ix.shape)
    lad = np.where(inside, grid[np.clip(iy, 0, ny - 1), np.clip(ix, 0, nx - 1), kk], 0.0)
    pint = 1.0 - np.exp(-G_LEAF * lad * path[:, None, None])
    cp = np.cumprod((1.0 - pint)[:, :, ::-1], axis=2)                        # from the top
    above = np.concatenate([np.ones_like(cp[:, :, :1]), cp[:, :, :-1]], axis=2)[:, :, ::-1]
    rl = rho_leaf * rng.uniform(0.75, 1.25, pint.shape)
    e_leaf = above * pint * rl / s
    gdz = p["gx"][:, None] * off[:, :, 0] + p["gy"][:, None] * off[:, :, 1]  # (n, s)
    jitter = rng.uniform(-0.5, 0.5, pint.shape) * DH / denom[:, None, None]
    z_leaf = gdz[:, :, None] + zrel[:, None, :] + jitter                      # relative to zg
    e_ground = cp[:, :, -1] * rho_ground * rng.uniform(0.8, 1.2, (n, s)) / s
    z_ground = gdz + rng.normal(0.0, 0.01, (n, s))
    return _detect(p, e_leaf, z_leaf, e_ground, z_ground, nhe, denom, rng)


def _detect(p, e_leaf, z_leaf, e_ground, z_ground, nhe, denom, rng):
    """Discrete returns from each pulse's waveform (see module docstring)."""
    n = p["xg"].size
    base = -1.5
    nb = int(np.ceil((nhe * DH / denom.min() + 3.0) / BIN))
    bl = np.clip(np.floor((z_leaf - base) / BIN).astype(np.int64), 0, nb - 1)
    bg = np.clip(np.floor((z_ground - base) / BIN).astype(np.int64), 0, nb - 1)
    pid = np.arange(n)
    wf = np.bincount((pid[:, None, None] * nb + bl).ravel(), e_leaf.ravel(), n * nb)
    wg = np.bincount((pid[:, None] * nb + bg).ravel(), e_ground.ravel(), n * nb)
    wf = wf.reshape(n, nb) + wg.reshape(n, nb)
    sig = SIGMA_PULSE / BIN
    wf = gaussian_filter1d(wf, sig, axis=1, mode="constant", truncate=3.0)
    wg = gaussian_filter1d(wg.reshape(n, nb), sig, axis=1, mode="constant", truncate=3.0)
    full = 1.0 / (np.sqrt(2 * np.pi) * sig)        # peak of a full-energy hard target
    thr = THRESHOLD * full
    wf_n = wf + rng.normal(0.0, 0.15 * thr, wf.shape)
    mid = wf_n[:, 1:-1]
    peak = (mid > wf_n[:, :-2]) & (mid >= wf_n[:, 2:]) & (mid > thr)
    pp, bb = np.nonzero(peak)
    bb = bb + 1
    order = np.lexsort((-bb, pp))
    pp, bb = pp[order], bb[order]
    dead = DEAD_ZONE / BIN
    last = np.full(n, np.inf)
    taken = np.zeros(pp.size, bool)
    for _ in range(MAX_RETURNS):
        cand = (~taken) & (bb <= last[pp] - dead)
        idx = np.nonzero(cand)[0]
        if idx.size == 0:
            break
        _, first = np.unique(pp[idx], return_index=True)
        pick = idx[first]
        taken[pick] = True
        last[pp[pick]] = bb[pick]
    pp, bb = pp[taken], bb[taken]
    a0, a1, a2 = wf[pp, bb - 1], wf[pp, bb], wf[pp, np.minimum(bb + 1, nb - 1)]
    den = a0 - 2 * a1 + a2
    frac = np.where(np.abs(den) > 1e-12, 0.5 * (a0 - a2) / np.where(den == 0, 1, den), 0.0)
    zr = base + (bb + 0.5 + np.clip(frac, -0.5, 0.5)) * BIN + rng.normal(0.0, 0.02, bb.size)
    ground = wg[pp, bb] >= 0.5 * wf[pp, bb]
    order = np.lexsort((-zr, pp))
    pp, zr, ground, amp = pp[order], zr[order], ground[order], a1[order]
    counts = np.bincount(pp, minlength=n)
    starts = np.cumsum(counts) - counts
    rn = np.arange(pp.size) - starts[pp] + 1
    out = {
        "x": p["xg"][pp] + p["wx"][pp] * zr,
        "y": p["yg"][pp] + p["wy"][pp] * zr,
        "z": p["zg"][pp] + zr,
        "classification": np.where(ground, 2, 1).astype(np.uint8),
        "return_number": rn.astype(np.uint8),
        "number_of_returns": counts[pp].astype(np.uint8),
        "intensity": np.clip(amp / full * 60000.0 * p["gain"][pp], 1, 65535).astype(np.uint16),
    }
    for key in ("pid", "gps_time", "scan_angle", "point_source_id", "scan_direction_flag",
                "edge_of_flight_line"):
        if key in p:
            out[key] = p[key][pp]
    return out


def flight_pulses(bbox, terrain, density, rng, altitude=800.0, heading=0.0, scanner="sine",
                  half_angle=20.0, overlap=0.3, speed=55.0, divergence=0.3e-3):
    """Pulses of parallel flight lines over ``bbox`` (xmin, ymin, xmax, ymax).

    ``density`` is the mean pulse density (pulses per m^2 over the lines' ground); the lines fly
    back and forth ``heading`` degrees from north, ``overlap`` of the swath apart; the mirror
    sweeps +-``half_angle`` across track as a sine (dense at the swath edges) or a zig-zag
    (constant angular speed, sweeps that converge at one swath edge and diverge at the other).
    """
    x0, y0, x1, y1 = bbox
    hd = np.radians(heading)
    along = np.array([np.sin(hd), np.cos(hd)])
    across = np.array([np.cos(hd), -np.sin(hd)])
    tmax = np.tan(np.radians(half_angle))
    swath = 2.0 * altitude * tmax
    spacing = swath * (1.0 - overlap)
    cx, cy = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
    corners = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]]) - [cx, cy]
    ca, cc = corners @ along, corners @ across
    zref = float(np.mean(terrain(corners[:, 0] + cx, corners[:, 1] + cy)))
    prf = density * speed * spacing
    freq = speed * np.sqrt(density) / 2.4
    phase = rng.uniform(0, spacing)
    offsets = np.arange(cc.min() - swath / 2 - phase, cc.max() + swath / 2, spacing)
    out = []
    for li, off in enumerate(offsets):
        sign = 1.0 if li % 2 == 0 else -1.0
        start = (ca.min() - 3.0) if sign > 0 else (ca.max() + 3.0)
        n = int(prf * (ca.max() - ca.min() + 6.0) / speed)
        t = np.arange(n) / prf
        ph = 2 * np.pi * freq * t + rng.uniform(0, 2 * np.pi)
        if scanner == "sine":
            theta = np.sin(ph)
            dtheta = np.cos(ph)
        else:
            theta = (2.0 / np.pi) * np.arcsin(np.sin(ph))
            dtheta = np.cos(ph)
        theta = np.arctan(tmax * theta) + rng.normal(0.0, np.radians(0.01), n)
        ax = cx + across[0] * off + along[0] * (start + sign * speed * t)
        ay = cy + across[1] * off + along[1] * (start + sign * speed * t)
        zf = zref + altitude
        zg = np.full(n, zref)
        tan = np.tan(theta)
        for _ in range(4):
            gx = ax + across[0] * tan * (zf - zg)
            gy = ay + across[1] * tan * (zf - zg)
            zg = terrain(gx, gy)
        keep = (gx >= x0) & (gx < x1) & (gy >= y0) & (gy < y1)
        if not keep.any():
            continue
        rng_m = (zf - zg[keep]) / np.cos(theta[keep])
        k = int(keep.sum())
        out.append({
            "xg": gx[keep], "yg": gy[keep], "zg": zg[keep],
            "wx": -across[0] * tan[keep], "wy": -across[1] * tan[keep],
            "fp": divergence * rng_m,
            "gps_time": 3.0e5 + 600.0 * li + t[keep],
            "scan_angle": np.degrees(theta[keep]).astype(np.float32),
            "point_source_id": np.full(k, li + 1, np.uint16),
            "scan_direction_flag": (dtheta[keep] > 0).astype(np.uint8),
            "edge_of_flight_line": (np.abs(theta[keep]) > np.radians(0.98 * half_angle)
                                    ).astype(np.uint8),
            "gain": np.full(k, 1.0 + rng.normal(0.0, 0.05)),
        })
    if not out:
        raise ValueError("no pulse reaches the area")
    return {key: np.concatenate([o[key] for o in out]) for key in out[0]}
