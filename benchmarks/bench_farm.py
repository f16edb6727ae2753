"""Farm scale (issue 41): a generated farm of >= 50 M points and 20 stands, the defaults beside
plantation mode (``-spacing auto -stands``) on the same points, time and peak memory.

The farm: ``--cols`` x ``--rows`` blocks of ``--block`` m separated by 10 m roads; each block is
one stand (talhao) whose polygon follows the roads and whose planted area is set back 1.5-4 m
from it. Each stand has its own design (3x2, 3x1.5, 3.5x2.5, 2.8x2.8, 3x3 m, in turn), row
azimuth (0-180 degrees, oblique to the polygon), height (14-28 m), crown size (0.8-1.15 of the
spacing) and 3-15 % missing trees in runs of 1-4 along a row, 3 % suppressed. Terrain: a 4 %
slope with undulations. Returns: the highest paraboloid crown above a uniform pulse, else the
ground (12 % of canopy pulses reach it), ground class 2. Written as ``--tile`` m LAZ tiles, one
tile in memory at a time.

Both runs are the CLI as a user types it, timed with their peak memory (resident set of the
process and its children, sampled every 0.1 s)::

    lidartrees trees FARM_DIR defaults.gpkg -overwrite
    lidartrees trees FARM_DIR plantation.gpkg -spacing auto -stands stands.gpkg -overwrite

Every stand of the plantation run is scored against the truth as in ``bench_stands2``, and the
defaults' tree F per stand beside it (their tops inside the stand's polygon; without stands
the defaults read the farm's planted blocks, ``runs.defaults.blocks``).
Results: ``benchmarks/results/farm.json``.
Usage: ``python benchmarks/bench_farm.py [--work /tmp/farm] [--density 10]``.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from bench_stands2 import score_stand, write_json  # noqa: E402

DESIGNS = ((3.0, 2.0), (3.0, 1.5), (3.5, 2.5), (2.8, 2.8), (3.0, 3.0))
ROAD = 10.0
ORIGIN = (402000.0, 7_750_000.0)
EPSG = 31983


def ground_z(x, y):
    dx, dy = x - ORIGIN[0], y - ORIGIN[1]
    return 650.0 + 0.04 * dx - 0.015 * dy + 2.0 * np.sin(dx / 140.0) * np.cos(dy / 190.0)


def _positions(planted, az, rs, ps, rng):
    """Planting positions of a lattice (rows along ``az`` degrees from north) in a box."""
    x0, y0, x1, y1 = planted
    u = np.array([np.sin(np.radians(az)), np.cos(np.radians(az))])   # along the row
    v = np.array([u[1], -u[0]])                                      # across the rows
    c = np.array([(x0 + x1) / 2, (y0 + y1) / 2]) + rng.uniform(-1, 1, 2) * (rs, ps)
    half = np.hypot(x1 - x0, y1 - y0) / 2 + 3
    i = np.arange(-int(half / rs) - 1, int(half / rs) + 2)
    j = np.arange(-int(half / ps) - 1, int(half / ps) + 2)
    ii, jj = (a.ravel() for a in np.meshgrid(i, j, indexing="ij"))
    x = c[0] + ii * rs * v[0] + jj * ps * u[0]
    y = c[1] + ii * rs * v[1] + jj * ps * u[1]
    keep = (x > x0) & (x < x1) & (y > y0) & (y < y1)
    return x[keep], y[keep], ii[keep], jj[keep]


def _status(row, plant, rng, missing=0.08, suppressed=0.03):
    """'tree' / 'missing' (runs of 1-4 along a row) / 'suppressed'."""
    n = row.size
    status = np.full(n, "tree", dtype="U10")
    order = np.lexsort((plant, row))             # positions along each row, rows in turn
    rank = np.empty(n, int)
    rank[order] = np.arange(n)
    target = int(round(missing * n))
    done = 0
    while done < target:
        k = rng.integers(n)
        run = int(rng.choice([1, 2, 3, 4], p=[0.5, 0.25, 0.15, 0.1]))
        at = rank[k]
        for s in range(run):
            m = order[min(at + s, n - 1)]
            if row[m] != row[k] or status[m] == "missing" or done >= target:
                break
            status[m] = "missing"
            done += 1
    trees = np.nonzero(status == "tree")[0]
    status[rng.permutation(trees)[: int(round(suppressed * n))]] = "suppressed"
    return status


def make_farm(cols, rows, block, seed=0):
    """Stands (truth in the form ``bench_stands2.score_stand`` reads) and every tree."""
    from shapely.geometry import box

    rng = np.random.default_rng(seed)
    stands, trees = [], []
    for k in range(cols * rows):
        bx, by = ORIGIN[0] + (k % cols) * block, ORIGIN[1] + (k // cols) * block
        poly = (bx + ROAD / 2, by + ROAD / 2, bx + block - ROAD / 2, by + block - ROAD / 2)
        s = rng.uniform(1.5, 4.0, 4)
        planted = (poly[0] + s[0], poly[1] + s[1], poly[2] - s[2], poly[3] - s[3])
        rs, ps = DESIGNS[k % len(DESIGNS)]
        az = float(np.round(rng.uniform(0, 180), 1))
        x, y, ii, jj = _positions(planted, az, rs, ps, rng)
        status = _status(ii, jj, rng, missing=rng.uniform(0.03, 0.15))
        n = x.size
        top_h = rng.uniform(14, 28)
        h = top_h * np.exp(rng.normal(0, 0.07, n))
        sup = status == "suppressed"
        h[sup] = top_h * rng.uniform(0.5, 0.75, sup.sum())
        crown_k = rng.uniform(0.8, 1.15)
        r = crown_k * np.sqrt(rs * ps) / 2 * (h / top_h) ** 0.5 * np.exp(rng.normal(0, 0.08, n))
        tx, ty = x + rng.normal(0, 0.12, n), y + rng.normal(0, 0.12, n)
        pos = np.zeros(n, dtype=[("x", "f8"), ("y", "f8"), ("status", "U10"),
                                 ("top_x", "f8"), ("top_y", "f8")])
        pos["x"], pos["y"], pos["status"], pos["top_x"], pos["top_y"] = x, y, status, tx, ty
        tid = f"T{k + 1:02d}"
        stands.append({"talhao": tid, "polygon": box(*poly).wkt,
                       "area_ha": (poly[2] - poly[0]) * (poly[3] - poly[1]) / 1e4,
                       "lattice": {"row_spacing": rs, "plant_spacing": ps, "azimuth": az},
                       "positions": pos, "crown_k": round(float(crown_k), 3),
                       "height": round(float(top_h), 2),
                       "stocking_pct": 100.0 * (status != "missing").sum() / n})
        has = status != "missing"
        trees.append(np.column_stack([tx[has], ty[has], h[has], r[has]]))
    return stands, np.concatenate(trees)


def write_tiles(trees, extent, tile, density, work, seed=0):
    """LAZ tiles of ``tile`` m; returns the number of points written."""
    import laspy
    import pyproj
    from scipy.spatial import cKDTree

    kd = cKDTree(trees[:, :2])
    rmax = float(trees[:, 3].max())
    x0, y0, x1, y1 = extent
    total = 0
    crs = pyproj.CRS.from_epsg(EPSG)
    for ty0 in np.arange(y0, y1, tile):
        for tx0 in np.arange(x0, x1, tile):
            path = work / f"farm_{int(tx0)}_{int(ty0)}.laz"
            w, h = min(tile, x1 - tx0), min(tile, y1 - ty0)
            rng = np.random.default_rng([seed, int(tx0), int(ty0)])
            n = rng.poisson(density * w * h)
            if path.exists():
                total += laspy.open(path).header.point_count
                continue
            px, py = tx0 + rng.random(n) * w, ty0 + rng.random(n) * h
            dist, idx = kd.query(np.column_stack([px, py]), k=8, distance_upper_bound=rmax)
            ok = np.isfinite(dist)
            ii = np.where(ok, idx, 0)
            top, rad = trees[ii, 2], trees[ii, 3]
            q = (np.where(ok, dist, np.inf) / rad) ** 2
            srf = np.where(q <= 1.0, top - 0.45 * top * q, -np.inf).max(axis=1)
            ground = ~np.isfinite(srf) | (rng.random(n) < 0.12)
            pz = ground_z(px, py) + np.where(ground, 0.0, srf) + rng.normal(0, 0.03, n)
            hdr = laspy.LasHeader(point_format=6, version="1.4")
            hdr.scales = np.array([0.01, 0.01, 0.01])
            hdr.offsets = np.array([tx0, ty0, 0.0])
            hdr.add_crs(crs)
            las = laspy.LasData(hdr)
            las.x, las.y, las.z = px, py, pz
            las.classification = np.where(ground, 2, 1).astype(np.uint8)
            tmp = path.with_suffix(".tmp.laz")
            las.write(tmp)
            os.replace(tmp, path)
            total += n
    return total


def write_stands(stands, path):
    import geopandas as gpd
    import shapely

    gdf = gpd.GeoDataFrame({"talhao": [s["talhao"] for s in stands]},
                           geometry=[shapely.from_wkt(s["polygon"]) for s in stands],
                           crs=f"EPSG:{EPSG}")
    tmp = str(path) + ".tmp.gpkg"
    gdf.to_file(tmp, layer="talhoes", driver="GPKG", engine="pyogrio")
    os.replace(tmp, path)


def timed(cmd):
    """Run ``cmd``; wall seconds, peak resident set (MB) of it and its children, exit, log."""
    import psutil

    t0 = time.time()
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            cwd=str(HERE.parent))
    peak = [0]
    stop = threading.Event()

    def watch():
        p = psutil.Process(proc.pid)
        while not stop.is_set():
            try:
                rss = p.memory_info().rss + sum(c.memory_info().rss
                                                for c in p.children(recursive=True))
                peak[0] = max(peak[0], rss)
            except psutil.Error:
                pass
            stop.wait(0.1)

    th = threading.Thread(target=watch, daemon=True)
    th.start()
    log = proc.communicate()[0]
    stop.set()
    th.join()
    return time.time() - t0, peak[0] / 2**20, proc.returncode, log


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--work", default="/tmp/bench_farm")
    ap.add_argument("--cols", type=int, default=5)
    ap.add_argument("--rows", type=int, default=4)
    ap.add_argument("--block", type=float, default=500.0, help="stand block side, m")
    ap.add_argument("--tile", type=float, default=250.0, help="LAZ tile side, m")
    ap.add_argument("--density", type=float, default=10.0, help="returns per m^2")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--workers", default=None, help="-workers for both runs (default: CLI's)")
    ap.add_argument("--out", default=str(HERE / "results" / "farm.json"))
    a = ap.parse_args(argv)
    work = Path(a.work)
    tiles = work / "tiles"
    tiles.mkdir(parents=True, exist_ok=True)
    t0 = time.time()
    stands, trees = make_farm(a.cols, a.rows, a.block, a.seed)
    extent = (ORIGIN[0], ORIGIN[1], ORIGIN[0] + a.cols * a.block, ORIGIN[1] + a.rows * a.block)
    n_points = write_tiles(trees, extent, a.tile, a.density, tiles, a.seed)
    stands_path = work / "stands.gpkg"
    write_stands(stands, stands_path)
    gen_s = time.time() - t0
    print(f"farm: {n_points} points, {len(stands)} stands, {trees.shape[0]} trees, "
          f"{gen_s:.0f} s", flush=True)
    base = [sys.executable, "-m", "lidartrees_gis.cli", "trees", str(tiles)]
    extra = ["-workers", a.workers] if a.workers else []
    runs = {}
    for name, opts in (("defaults", []),
                       ("plantation", ["-spacing", "auto", "-stands", str(stands_path)])):
        out = work / f"{name}.gpkg"
        wall, peak, rc, log = timed(base + [str(out), "-overwrite", *opts, *extra])
        runs[name] = {"command": " ".join(["lidartrees", "trees", "FARM_DIR", out.name,
                                           "-overwrite", *opts[:2],
                                           *(["-stands", "stands.gpkg"] if opts else []),
                                           *extra]),
                      "wall_s": round(wall, 1), "peak_mb": round(peak), "exit": rc,
                      "last_lines": log.strip().splitlines()[-3:]}
        print(name, runs[name], flush=True)
    rows = []
    if runs["plantation"]["exit"] == 0:
        import geopandas as gpd
        import pyogrio

        out = work / "plantation.gpkg"
        st = gpd.read_file(out, layer="stands")
        layers = {n for n, _ in pyogrio.list_layers(out)}
        gaps = gpd.read_file(out, layer="gaps") if "gaps" in layers else gpd.GeoDataFrame()
        tops = gpd.read_file(out, layer="tree_tops")
        for s in stands:
            r = score_stand(s, st, gaps, tops)
            r.update(crown_k=s["crown_k"], height=s["height"])
            rows.append(r)
            print(" | ".join(str(r.get(c)) for c in (
                "talhao", "design", "azimuth_true", "crown_k", "lattice_ok", "stocking_true",
                "stocking_err_pts", "truth_in_interval", "gap_precision", "missing_recall",
                "tree_f")), flush=True)
    if runs["defaults"]["exit"] == 0:  # the defaults' trees per stand (its planted blocks)
        import geopandas as gpd
        import pyogrio

        out = work / "defaults.gpkg"
        layers = {n for n, _ in pyogrio.list_layers(out)}
        tops = gpd.read_file(out, layer="tree_tops")
        pol = gpd.read_file(stands_path)
        j = gpd.sjoin(tops, pol[["talhao", "geometry"]], how="left", predicate="within")
        tops["stand_id"] = j["talhao"].astype(str).to_numpy()
        empty = gpd.GeoDataFrame({"stand_id": pol["talhao"].astype(str)}, geometry=pol.geometry)
        blocks = gpd.read_file(out, layer="stands") if "stands" in layers else None
        runs["defaults"]["blocks"] = 0 if blocks is None else len(blocks)
        runs["defaults"]["blocks_with_lattice"] = 0 if blocks is None else \
            int((blocks["lattice"] == "found").sum())
        by = {r["talhao"]: r for r in rows}
        for s in stands:
            r = score_stand(s, empty, gpd.GeoDataFrame(), tops)
            if s["talhao"] in by:
                by[s["talhao"]].update(defaults_trees_found=r["trees_found"],
                                       defaults_tree_f=r["tree_f"])
        print("defaults blocks", runs["defaults"]["blocks"], "tree F",
              [by[s["talhao"]].get("defaults_tree_f") for s in stands if s["talhao"] in by],
              flush=True)
    ratio = (runs["plantation"]["wall_s"] / runs["defaults"]["wall_s"]
             if runs["defaults"]["wall_s"] else None)
    result = {"benchmark": "bench_farm", "points": int(n_points), "stands": len(stands),
              "trees": int(trees.shape[0]), "density": a.density, "block_m": a.block,
              "tile_m": a.tile, "cpus": os.cpu_count(), "generate_s": round(gen_s, 1),
              "runs": runs, "plantation_over_defaults": None if ratio is None
              else round(ratio, 3), "stands_scored": rows}
    write_json(a.out, result)
    return 0


if __name__ == "__main__":
    sys.exit(main())
