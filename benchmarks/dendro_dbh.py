"""DBH of one tree with dendromatics (the library behind 3DFin), for bench_tls.py.

Runs in its own venv (dendromatics pins an older laspy):  .venv-dendro/bin/python
benchmarks/dendro_dbh.py FILE  -> prints JSON {"dbh_m": ..., "seconds": ...}.

3DFin's steps for one tree: heights above the base (0.1th percentile of z), a stripe 0.7-3.5 m,
verticality clustering of the stripe (stem points), the largest cluster as the stem, circles
fitted at 1.2, 1.3 and 1.4 m (compute_sections, 3DFin's defaults otherwise); DBH = 2 x the
median valid radius.
"""
import json
import sys
import time

import numpy as np


def load(path):
    if path.lower().endswith((".las", ".laz")):
        import laspy

        las = laspy.read(path)
        return np.c_[las.x, las.y, las.z]
    return np.loadtxt(path, usecols=(0, 1, 2), comments="#", skiprows=0 if open(path).read(1).isdigit() or open(path).read(1) == "-" else 1)


def main(path):
    import dendromatics as dm

    t = time.perf_counter()
    xyz = load(path)
    z0 = xyz[:, 2] - np.percentile(xyz[:, 2], 0.1)
    cloud = np.c_[xyz, z0]
    stripe = cloud[(z0 > 0.7) & (z0 < 3.5)]
    clust = dm.verticality_clustering(stripe[:, [0, 1, 3]], n_iter=2, n_points=200)
    ids, counts = np.unique(clust[:, -1], return_counts=True)
    if ids.size == 0:
        return {"dbh_m": None, "seconds": time.perf_counter() - t, "note": "no stem cluster"}
    best = ids[np.argmax(counts)]
    stem = clust[clust[:, -1] == best]
    stems = np.c_[stem[:, 0], stem[:, 1], stem[:, 2], stem[:, 2], np.ones(len(stem))]
    sections = np.array([1.2, 1.3, 1.4])
    X_c, Y_c, R, check, second, perct, n_in = dm.compute_sections(stems, sections, section_width=0.05)
    r = R[0]
    ok = (r > 0) & (check[0] == 0)
    dbh = float(2 * np.median(r[ok])) if ok.any() else (float(2 * np.median(r[r > 0])) if (r > 0).any() else None)
    return {"dbh_m": dbh, "seconds": time.perf_counter() - t, "valid_sections": int(ok.sum()),
            "stem_points": int(len(stem))}


if __name__ == "__main__":
    print(json.dumps(main(sys.argv[1])))
