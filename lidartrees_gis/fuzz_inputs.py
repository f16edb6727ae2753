"""Fuzzing the inputs the project must refuse or warn about (issue 42), beside the malformed
files of :mod:`lidartrees_gis.fuzz`.

Families, each built on a small synthetic stand (under 10,000 points) whose unmutated results
are measured once per campaign:

* ``far``: 1-5 points moved 2-10 km away, in ``trees``, ``chm``, ``grid``, ``ground`` and
  ``dtm-quality``, with and without ``-tr``;
* ``crs``: conflicting CRS records (LAS 1.2 GeoKeys and a WKT record of another CRS, LAS 1.4
  with two WKT records) and a WKT EPSG:4326 record on metre coordinates;
* ``nodata``: the stand's CHM GeoTIFF with no nodata value and a border of -9999, -32768 or
  -3.4e38;
* ``degenerate``: one point or every point identical (``chm``, ``trees``), every point noise
  (class 7) or a ``-keep_class`` of an absent class (``grid`` too);
* ``number``: a number option of a command at an extreme (1e308, inf, nan, 1e-320, ...);
* ``co``: a GDAL creation option GDAL rejects.

A case fails (:func:`verdict`) as in :func:`lidartrees_gis.fuzz.verdict` (traceback, signal,
over the time limit, more than one error line), when its process grew over
:data:`MEMORY_LIMIT`, when a degenerate input exits 0, or when a result differs by more than
5 % from the unmutated one (trees, raster shape, ground points, the CRS) without a warning.

``python -m lidartrees_gis.fuzz_inputs --cases 500 --seed 0 --dir /tmp/fz``
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from .fuzz import run_cases
from .fuzz import verdict as base_verdict

TIME_LIMIT = 30.0
MEMORY_LIMIT = 4 * 2 ** 30
FAMILIES = ("far", "crs", "nodata", "degenerate", "number", "co")
#: values a number option is set to
EXTREMES = ["1e308", "-1e308", "inf", "-inf", "nan", "1e-320", "-1e-320", "1e-9", "0", "-1",
            "1e5", "100000", "3e38", "1e15", "5e-324"]
BAD_CO = ["BLOCKXSIZE=7", "BLOCKYSIZE=1000000001", "COMPRESS=NOPE", "PREDICTOR=9", "FOO=BAR",
          "ZLEVEL=99", "TILED=MAYBE", "BIGTIFF=PERHAPS", "NUM_THREADS=-1", "OVERVIEWS=SOME",
          "BLOCKXSIZE=", "==", "INTERLEAVE=DIAGONAL"]
MARKERS = (-9999.0, -32768.0, -3.4028234663852886e38)
#: (command, extra arguments, what is compared) of the far family
FAR_RUNS = [("trees", ".gpkg", [], "trees"), ("trees", ".gpkg", ["-tr", "0.5"], "trees"),
            ("chm", ".tif", [], "shape"), ("chm", ".tif", ["-tr", "1"], "shape"),
            ("grid", ".tif", ["-tr", "1"], "shape"), ("ground", ".las", [], "ground"),
            ("dtm-quality", "", ["-g", "-2:0:1", "-w", "1:2:1"], None)]


def _stand(n_max=9000, seed=0):
    """A small synthetic stand (30 x 30 m, under ``n_max`` points): x, y, z, classes."""
    from .synthetic import StandParams, make_stand

    pts, _ = make_stand(StandParams(width=30.0, height=30.0, density=9.0, seed=seed))
    k = np.arange(len(pts.x))[:n_max]
    return pts.x[k], pts.y[k], pts.z[k], np.asarray(pts.classification)[k]


def _write(path, x, y, z, cls, *, version="1.4", geokeys=None, wkts=()):
    """A LAS file with the CRS records asked for: GeoKeys of EPSG ``geokeys`` (LAS 1.2) and
    OGC WKT records of the EPSG codes ``wkts`` (1.4: the WKT bit set)."""
    import laspy
    import pyproj
    from laspy.vlrs.known import WktCoordinateSystemVlr

    h = laspy.LasHeader(point_format=1 if version == "1.2" else 6, version=version)
    h.scales = np.array([0.01, 0.01, 0.01])
    h.offsets = np.array([np.floor(x.min()), np.floor(y.min()), np.floor(z.min())])
    if geokeys is not None:
        h.add_crs(pyproj.CRS.from_epsg(geokeys))  # 1.2: GeoKeys
    for code in wkts:
        h.vlrs.append(WktCoordinateSystemVlr(pyproj.CRS.from_epsg(code).to_wkt()))
    if version != "1.2" and wkts:
        h.global_encoding.wkt = True
    las = laspy.LasData(h)
    las.x, las.y, las.z = x, y, z
    las.classification = cls
    las.write(str(path))


def _run(argv) -> tuple:
    """``(exit code, stdout)`` of the CLI in this process (the references)."""
    import contextlib
    import io

    from .cli.app import main

    out = io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(io.StringIO()):
        code = main(argv)
    return code, out.getvalue()


def value(stdout: str, key: str):
    """The ``key: value`` line of a command's summary (None when absent)."""
    for line in stdout.splitlines():
        if line.startswith(key + ": "):
            return line.split(": ", 1)[1].strip()
    return None


def prepare(work: Path, seed: int = 0) -> dict:
    """The base inputs of a campaign and their unmutated results."""
    work.mkdir(parents=True, exist_ok=True)
    x, y, z, cls = _stand(seed=seed)
    base = work / "stand.las"
    _write(base, x, y, z, cls, wkts=(31983,))
    chm = work / "stand_chm.tif"
    _run(["chm", str(base), str(chm), "-overwrite", "-q"])
    ref = {"points": (x, y, z, cls), "base": base, "chm": chm, "runs": {}}
    for cmd, ext, extra, key in FAR_RUNS:
        if key is None:
            continue
        code, out = _run([cmd, str(base), str(work / f"ref_{cmd}{ext}"), *extra, "-overwrite",
                          "-q"])
        ref["runs"][(cmd, tuple(extra))] = value(out, key) if code == 0 else None
    code, out = _run(["trees", str(chm), str(work / "ref_chm_trees.gpkg"), "-overwrite", "-q"])
    ref["chm_trees"] = value(out, "trees")
    return ref


def _far_case(rng, ref, work, i):
    x, y, z, cls = (a.copy() for a in ref["points"])
    k = int(rng.integers(1, 6))
    idx = rng.choice(x.size, k, replace=False)
    d, a = rng.uniform(2000, 10000, k), rng.uniform(0, 2 * np.pi, k)
    x[idx] += d * np.cos(a)
    y[idx] += d * np.sin(a)
    f = work / f"far{i}.las"
    _write(f, x, y, z, cls, wkts=(31983,))
    cmd, ext, extra, key = FAR_RUNS[int(rng.integers(0, len(FAR_RUNS)))]
    out = work / f"o{i}{ext}"
    expect = None if key is None else (key, ref["runs"].get((cmd, tuple(extra))))
    return [cmd, str(f), str(out), *extra], {"expect": expect}


def _crs_case(rng, ref, work, i):
    x, y, z, cls = ref["points"]
    f = work / f"crs{i}.las"
    other = int(rng.choice([31984, 29193, 32723, 4674]))
    kind = int(rng.integers(0, 3))
    if kind == 0:  # LAS 1.2: GeoKeys and a WKT record
        _write(f, x, y, z, cls, version="1.2", geokeys=31983, wkts=(other,))
        want = "EPSG:31983"
    elif kind == 1:  # LAS 1.4: two WKT records
        _write(f, x, y, z, cls, wkts=(31983, other))
        want = "EPSG:31983"
    else:  # WKT EPSG:4326 on metres
        _write(f, x, y, z, cls, wkts=(4326,))
        want = None
    cmd = ["info", str(f)] if rng.random() < 0.5 else ["chm", str(f), str(work / f"o{i}.tif"),
                                                       "-tr", "1"]
    return cmd, {"expect": ("crs", want), "refuse": want is None}


def _nodata_case(rng, ref, work, i):
    import rasterio
    from rasterio.transform import Affine

    with rasterio.open(ref["chm"]) as ds:
        a, prof, nd = ds.read(1).astype(np.float32), ds.profile, ds.nodata
    marker = MARKERS[int(rng.integers(0, len(MARKERS)))]
    pad = int(rng.integers(1, 15))
    a[(a == nd) | ~np.isfinite(a)] = marker
    b = np.full((a.shape[0] + 2 * pad, a.shape[1] + 2 * pad), marker, np.float32)
    b[pad:-pad, pad:-pad] = a
    t = prof["transform"]
    prof.update(width=b.shape[1], height=b.shape[0], nodata=None,
                transform=Affine(t.a, 0, t.c - pad * t.a, 0, t.e, t.f - pad * t.e))
    f = work / f"nodata{i}.tif"
    with rasterio.open(f, "w", **prof) as ds:
        ds.write(b, 1)
    return ["trees", str(f), str(work / f"o{i}.gpkg")], {"expect": ("trees", ref["chm_trees"])}


def _degenerate_case(rng, ref, work, i):
    x, y, z, cls = ref["points"]
    kind = int(rng.integers(0, 4))
    f = work / f"deg{i}.las"
    extra = []
    if kind == 0:
        _write(f, x[:1], y[:1], z[:1], cls[:1], wkts=(31983,))
    elif kind == 1:
        n = int(rng.integers(2, 200))
        _write(f, np.full(n, x[0]), np.full(n, y[0]), np.full(n, z[0]), cls[:n], wkts=(31983,))
    elif kind == 2:
        _write(f, x, y, z, np.full(x.size, 7, np.uint8), wkts=(31983,))
    else:
        _write(f, x, y, z, cls, wkts=(31983,))
        extra = ["-keep_class", "5"]
    # a grid of one point (or of points at one place) is its one cell: chm and trees refuse it
    cmd = ["chm", "trees", "grid"][int(rng.integers(0, 3 if kind >= 2 else 2))]
    ext = ".gpkg" if cmd == "trees" else ".tif"
    tr = ["-tr", "1"] if rng.random() < 0.7 else []
    return [cmd, str(f), str(work / f"o{i}{ext}"), *tr, *extra], {"refuse": True}


def _number_case(rng, ref, work, i):
    from .cli.commands import COMMANDS

    names = ["chm", "trees", "grid", "ground", "profile", "stem"]
    cmd = names[int(rng.integers(0, len(names)))]
    params = [p for p in COMMANDS[cmd].params if p.flag and (
        p.kind in ("float", "int", "res") or p.name in ("tile_size", "base"))]
    p = params[int(rng.integers(0, len(params)))]
    v = EXTREMES[int(rng.integers(0, len(EXTREMES)))]
    ext = {"trees": ".gpkg", "ground": ".las", "profile": ".las", "stem": ""}.get(cmd, ".tif")
    return [cmd, str(ref["base"]), str(work / f"o{i}{ext}"), f"{p.flag}={v}"], {}


def _co_case(rng, ref, work, i):
    co = BAD_CO[int(rng.integers(0, len(BAD_CO)))]
    cmd = ["chm", "grid"][int(rng.integers(0, 2))]
    return [cmd, str(ref["base"]), str(work / f"o{i}.tif"), "-tr", "1", "-co", co], {}


_MAKERS = {"far": _far_case, "crs": _crs_case, "nodata": _nodata_case,
           "degenerate": _degenerate_case, "number": _number_case, "co": _co_case}


def make_cases(n: int, seed: int, workdir, ref: dict | None = None) -> list:
    """``n`` cases of the :data:`FAMILIES` in turn (seeded), their inputs under ``workdir``."""
    work = Path(workdir)
    ref = ref or prepare(work, seed)
    rng = np.random.default_rng(seed)
    cases = []
    for i in range(n):
        fam = FAMILIES[i % len(FAMILIES)]
        argv, meta = _MAKERS[fam](rng, ref, work, i)
        cases.append({"id": i, "label": fam, "argv": argv + ["-overwrite", "-q"]
                      if argv[0] != "info" else argv + ["-q"], **meta})
    return cases


def _warned(stderr: str) -> bool:
    return any(": warning: " in ln for ln in stderr.splitlines())


def verdict(r, time_limit: float = TIME_LIMIT) -> str | None:
    """Why a case failed, or None (see the module doc)."""
    v = base_verdict(r, time_limit)
    if v:
        return v
    if (r.get("maxrss") or 0) > MEMORY_LIMIT:
        return f"memory ({r['maxrss'] / 2 ** 30:.1f} GB)"
    if r.get("refuse"):
        return "exit 0 on an input to refuse" if r["code"] == 0 else None
    exp = r.get("expect")
    if r["code"] != 0 or not exp or exp[1] is None or _warned(r["stderr"]):
        return None
    got = value(r.get("stdout", ""), exp[0])
    if exp[0] == "crs":
        return None if got and got.startswith(exp[1] + " ") else f"crs {got} (not {exp[1]})"
    if got is None:
        return f"no {exp[0]} in the summary"
    a = np.array([float(t) for t in str(exp[1]).split(",")])
    b = np.array([float(t) for t in str(got).split(",")])
    if a.shape != b.shape or np.any(np.abs(b - a) > 0.05 * np.maximum(np.abs(a), 1)):
        return f"{exp[0]} {got}, not {exp[1]}, without a warning"
    return None


def campaign(n: int, seed: int, workdir, time_limit: float = TIME_LIMIT, progress=None) -> dict:
    """Run ``n`` cases; the counts the issue asks for and the failures."""
    t = time.perf_counter()
    cases = make_cases(n, seed, workdir)
    res = run_cases(cases, time_limit=time_limit, progress=progress)
    bad = [(r, v) for r in res if (v := verdict(r, time_limit))]
    by = {}
    for _, v in bad:
        key = v.split(" (")[0].split(" ")[0] if not v.startswith("exit 0") else v
        by[key] = by.get(key, 0) + 1
    return {"cases": len(res), "seed": seed, "failed": len(bad), "by_reason": by,
            "families": {f: sum(r["label"] == f for r in res) for f in FAMILIES},
            "refused": sum(r["code"] == 1 for r in res), "ran": sum(r["code"] == 0 for r in res),
            "slowest_s": round(max((r["seconds"] for r in res), default=0.0), 2),
            "max_rss_gb": round(max((r.get("maxrss") or 0 for r in res), default=0) / 2 ** 30,
                                2),
            "wall_s": round(time.perf_counter() - t, 1),
            "failures": [{"id": r["id"], "label": r["label"], "argv": r["argv"], "verdict": v,
                          "stderr": r["stderr"][-300:]} for r, v in bad[:50]]}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", type=int, default=300)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--dir", default="fuzz_inputs_work")
    ap.add_argument("--out", default=None, help="JSON report")
    a = ap.parse_args(argv)
    rep = campaign(a.cases, a.seed, a.dir, progress=lambda k, n: print(
        f"\r{k}/{n}", end="", file=sys.stderr))
    print(file=sys.stderr)
    print(json.dumps({k: v for k, v in rep.items() if k != "failures"}, indent=1))
    if a.out:
        Path(a.out).write_text(json.dumps(rep, indent=1, default=str))
    return 1 if rep["failed"] else 0


if __name__ == "__main__":
    sys.exit(main())
