"""Seed 003's DTM quality sweep as a file-level chain: the ground filter over a (g, w) grid, a
DTM each, GLCM texture, PCA and k-means, a CSV, hillshades and the recommended DTM."""
from __future__ import annotations

import contextlib
import tempfile
from dataclasses import replace
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..catalog.catalog import Catalog
from ..catalog.source import drop_far_points
from ..grid import GridSpec, resolve_resolution
from ..io.options import ReadOptions
from ..io.provenance import raster_tags, repro_report
from ..io.raster import write_geotiff
from ..progress import SubProgress, as_progress, check_cancel
from ..report.plots import write_hillshade_png
from ..tin import interpolate_tin
from .consensus import agreement_limit, completeness, consensus_distances
from .filter import KrausPfeifer, kraus_pfeifer, low_points
from .texture import _standardise, kmeans, pca_select, texture_descriptors


def parse_range(text, param):
    """``START:STOP:STEP`` (inclusive) or a comma list -> list of floats."""
    s = str(text).strip()
    try:
        if ":" in s:
            a, b, c = (float(t) for t in s.split(":"))
            if c <= 0 or b < a:
                raise ValueError
            n = int(round((b - a) / c)) + 1
            return [round(a + i * c, 10) for i in range(n)]
        return [float(t) for t in s.split(",") if t.strip()]
    except ValueError:
        raise InputError(f"{param}: expected START:STOP:STEP or a comma list, got {text!r}") from None


_SWEEP = {}


def _sweep_init(x, y, z, spec, base, low=None):
    _SWEEP.update(x=x, y=y, z=z, spec=spec, base=base,
                  low=low_points(x, y, z, base.low) if low is None else low)


def _sweep_one(gw):
    from dataclasses import replace

    g, w = gw
    x, y, z, spec = _SWEEP["x"], _SWEEP["y"], _SWEEP["z"], _SWEEP["spec"]
    try:
        ground, _ = kraus_pfeifer(x, y, z, replace(_SWEEP["base"], g=g, w=w), low=_SWEEP["low"])
    except InputError:
        ground = np.zeros(x.size, bool)
    if ground.sum() >= 3:  # the same DTM as `ground -dtm` and `chm -dtm kp`: linear TIN
        dtm = interpolate_tin(x[ground], y[ground], z[ground], spec)
    else:  # an incomplete DTM: nothing to interpolate
        dtm = np.full(spec.shape, np.nan)
    return g, w, int(ground.sum()), texture_descriptors(dtm), dtm.astype(np.float32)


def cluster_roles(X, names, labels) -> dict:
    """Roles of the k-means clusters of complete DTMs: {cluster: "good" | "noisy"}. The good
    cluster is the smoothest, the highest mean homogeneity (standardised, over the 4 angles):
    the spikes and holes of seed 003's noisy group lower it. Seed 003's Table 2 also found its
    good group's dissimilarity higher; on real data the two disagree (bcts_1: the cluster of
    highest dissimilarity is 1.2 m from the vendor's ground, that of highest homogeneity 0.25 m),
    so homogeneity decides. Incomplete DTMs (seed 003's group 2, "could not be completely
    generated") are set apart before clustering (:func:`complete_dtms`)."""
    Z = _standardise(X)
    cols = [i for i, n in enumerate(names) if n.startswith("homogeneity")]
    score = Z[:, cols].mean(axis=1)
    labels = np.asarray(labels)
    cl = [int(c) for c in np.unique(labels)]
    good = max(cl, key=lambda c: score[labels == c].mean())
    return {c: ("good" if c == good else "noisy") for c in cl}


def complete_dtms(results: list, footprint, res: float) -> tuple:
    """Which swept DTMs are complete (:func:`lidartrees_gis.ground.consensus.completeness`: at
    least 1 ground point per 10 m² of the data's footprint, 90 % of the cells holding points
    covered; a TIN covers the hull of its ground points): ``(mask, coverage, density, why)``."""
    fp = np.asarray(footprint, bool)
    cov = np.array([np.isfinite(r[4])[fp].mean() if fp.any() else 0.0 for r in results])
    ok, dens, why = completeness([r[2] for r in results], cov, float(fp.sum()) * res * res)
    return ok, cov, dens, why


def reference_agreement(dtm, ref) -> tuple:
    """(RMSE, mean difference dtm - ref, share of the reference's cells covered), NaN when
    they share no cell."""
    m = np.isfinite(dtm) & np.isfinite(ref)
    n_ref = int(np.isfinite(ref).sum())
    if not m.any():
        return float("nan"), float("nan"), 0.0
    e = dtm[m] - ref[m]
    return float(np.sqrt(np.mean(e * e))), float(e.mean()), float(m.sum() / max(n_ref, 1))


def dtm_quality_file(input, outdir, *, g="-4:1:0.5", w="1:4:0.5", res="auto", params=None,
                     seed=0, workers=None, reference="auto", read: ReadOptions | None = None,
                     overwrite=False, progress=None) -> dict:
    """Seed 003's DTM quality sweep: the ground filter and a DTM per (g, w) (linear TIN of the
    ground points, the DTM `ground -dtm` and `chm -dtm kp` write), 12 GLCM texture descriptors
    each, PCA (descriptors with |PC1 loading| >= 0.3), k-means with k = 3, a CSV, one hillshade
    PNG per cluster, a recommended (g, w) and its DTM (``recommended_dtm.tif``).

    ``params`` defaults to the seed's filter (``refine=0``: robust interpolation only, whose
    result depends on g and w; the densified filter of ``ground`` gives one DTM for most (g, w)).
    Incomplete DTMs (fewer than 1 ground point per 10 m² of the data's footprint, or less than
    90 % of the data's cells covered) are seed 003's group 2 and are set apart; the complete
    ones are clustered, the smoothest cluster is *good*, the others *noisy*
    (:func:`cluster_roles`). When there are fewer than 3 distinct complete DTMs, each is a
    cluster. A good member too far from the sweep's consensus (the per-cell median of the
    complete DTMs; :mod:`lidartrees_gis.ground.consensus`) is an *outlier*, not good.

    ``reference``: a reference ground to check the DTMs against, a DTM GeoTIFF path, ``auto``
    (the file's class-2 points when it has any, the vendor's ground, as a TIN) or ``none``.
    Each DTM's RMSE and mean difference to it go in the CSV, and the recommended DTM is then the
    complete DTM closest to it (the sweep's own choice is reported beside, with its rank);
    without a reference, the good DTM nearest the good centroid. ``rank`` orders the complete
    DTMs, 1 the most trusted: the good ones, then the noisy ones (each by distance to the good
    centroid: ``texture_rank``, seed 003's order), then the outliers; ``why`` says why each DTM
    has its role.
    """
    out = Path(outdir)
    csv_path = out / "dtm_quality.csv"
    _check_outputs(out, csv_path, input, overwrite)
    gs, ws = parse_range(g, "-g"), parse_range(w, "-w")
    combos = [(gg, ww) for gg in gs for ww in ws]
    if len(combos) < 3:
        raise InputError("-g/-w: the sweep needs at least 3 combinations for 3 clusters")
    prog = as_progress(progress)
    base = params or KrausPfeifer(refine=0)
    read = read or ReadOptions()
    stack = contextlib.ExitStack()
    with stack:
        area = Catalog.open(input, read)  # a file is a catalog of one
        drop_far_points(area)  # stray points far from the rest: left out (a hang before)
        if area is not None and len(area.files) > 1:
            # several files: each (g, w) over each file with a buffer, DTMs kept on disk
            from .quality_area import footprint_and_reference, sweep_area
            from .tiled import area_resolution

            src = area
            r = area_resolution(src, res)
            spec = GridSpec.from_bounds(*src.extent, r, crs=src.crs)
            auto = str(reference or "auto").lower() == "auto"
            footprint, ref, n2 = footprint_and_reference(src, spec, auto)
            if auto:
                ref_source = (f"the files' class-2 points ({n2})" if ref is not None
                              else "none (the files have no class-2 points)")
            else:
                ref, ref_source = _reference(reference, None, spec)
            tmp = Path(stack.enter_context(tempfile.TemporaryDirectory(
                prefix=".lidartrees-dtms-", dir=_existing_parent(out))))
            results = sweep_area(src, spec, base, combos, workers, tmp,
                                 progress=SubProgress(prog, 0.05, 0.9))
        else:
            # one file (a folder or list of one: that file)
            src = read.open(area.files[0] if area is not None else input, filtered=False)
            pts = src.read_all(SubProgress(prog, 0, 0.05))
            r = resolve_resolution(src, res)
            if area.keep_box is not None:  # stray far points left out, of the cell size too
                pts = pts.subset(area.keeps(pts.x, pts.y))
                r = resolve_resolution(area, res)
            spec = GridSpec.from_bounds(pts.x.min(), pts.y.min(), pts.x.max(), pts.y.max(), r,
                                        crs=src.crs)
            ref, ref_source = _reference(reference, pts, spec)
            results = _sweep(pts, spec, base, combos, workers, SubProgress(prog, 0.05, 0.9))
            footprint = np.zeros(spec.shape, bool)
            rr, cc = spec.cell_index(pts.x, pts.y)
            inside = (rr >= 0) & (rr < spec.height) & (cc >= 0) & (cc < spec.width)
            footprint[rr[inside], cc[inside]] = True
            del pts
        return _analyse(out, csv_path, src, spec, r, base, results, footprint, ref, ref_source,
                        seed, prog)


def _existing_parent(out: Path) -> Path:
    """The output folder, or the nearest folder above it that exists."""
    p = out.absolute()
    while not p.exists():
        p = p.parent
    return p


def _analyse(out: Path, csv_path: Path, src, spec, r, base, results, footprint, ref, ref_source,
             seed, prog) -> dict:
    """Clusters, reference agreement, CSV, hillshades and the recommended DTM of a sweep."""
    c = _clusters(results, seed, footprint, r)
    agree = [reference_agreement(res_[4], ref) if ref is not None else (np.nan, np.nan, 0.0)
             for res_ in results]
    c["agree"] = agree
    best = c["best"]
    if ref is not None:
        ok = np.nonzero(c["complete"])[0]
        best = int(ok[np.nanargmin([agree[k][0] for k in ok])]) if ok.size else best
    out.mkdir(parents=True, exist_ok=True)
    _write_csv(csv_path, results, c)
    pngs = _write_hillshades(out, results, c, r)
    dtm_path = out / "recommended_dtm.tif"
    params_best = replace(base, g=results[best][0], w=results[best][1]).as_dict()
    write_geotiff(dtm_path, results[best][4], spec, overwrite=True,
                  tags=raster_tags("dtm-quality", src, {"res": r, **params_best}),
                  description="terrain height (m)")
    prog.update(1.0, "done")
    return {"output": str(csv_path), "dtms": len(results), "res": r,
            "filter": "robust interpolation (refine 0, Leite et al.)" if base.refine == 0
            else f"robust interpolation + {base.refine} densification passes",
            **_summary(results, c, best, ref_source),
            "pngs": pngs, "dtm": str(dtm_path), "reprojection": repro_report(src)}


def _reference(reference, pts, spec):  # pts: only for "auto"
    """The reference ground on the grid: (array or None, its source)."""
    from ..io.raster import read_raster, resample_to

    choice = "auto" if reference in (None, "") else str(reference)
    if choice.lower() == "none":
        return None, "none"
    if choice.lower() == "auto":
        cls = getattr(pts, "classification", None)
        if cls is None or (cls == 2).sum() < 3:
            return None, "none (the file has no class-2 points)"
        m = cls == 2
        return interpolate_tin(pts.x[m], pts.y[m], pts.z[m], spec), \
            f"the file's class-2 points ({int(m.sum())})"
    if not Path(choice).is_file():
        raise InputError(f"-reference: {choice}: no such DTM GeoTIFF")
    arr, rspec, _ = read_raster(choice)
    return resample_to(arr, rspec, spec), choice


def _summary(results, c, best, ref_source) -> dict:
    """What the run found, in plain figures."""
    from .consensus import MIN_GROUND_DENSITY

    roles, good, role = c["roles"], c["good"], c["role"]
    ranked = sorted((k for k in range(len(results)) if c["rank"][k]), key=lambda k: c["rank"][k])
    g_eq = [k for k, (gg, ww, *_) in enumerate(results) if abs(gg + ww) < 1e-9]
    out = {"selected_descriptors": [c["names"][i] for i in c["sel"]],
           "pc1_variance": float(c["var"][0]),
           "clusters": {rl: role.count(rl) for rl in ("good", "noisy", "outlier", "incomplete")},
           "min_ground_density": MIN_GROUND_DENSITY,
           "consensus_limit": round(float(c["limit"]), 3),
           "ranked": [f"{c['rank'][k]}. g={results[k][0]:g} w={results[k][1]:g}: {c['why'][k]}"
                      for k in ranked[:5]],
           "good_cluster": good, "roles": {str(k): v for k, v in roles.items()},
           "recommended_g": results[best][0], "recommended_w": results[best][1],
           "g_equals_minus_w_in_good": f"{sum(role[k] == 'good' for k in g_eq)}/{len(g_eq)}",
           "reference": ref_source}
    rm = np.array([a[0] for a in c["agree"]])
    if np.isfinite(rm).any():
        ok = np.nonzero(c["complete"] & np.isfinite(rm))[0]
        order = ok[np.argsort(rm[ok])]
        tex = c["best"]
        out.update({
            "recommended_by": "the reference (closest complete DTM)",
            "recommended_rmse": round(float(rm[best]), 3),
            "closest_3": [f"g={results[k][0]:g} w={results[k][1]:g} rmse={rm[k]:.3f}"
                          for k in order[:3]],
            "texture_recommended": f"g={results[tex][0]:g} w={results[tex][1]:g} "
                                   f"rmse={rm[tex]:.3f} (rank {int(np.nonzero(order == tex)[0][0]) + 1 if tex in order else 'n/a'} of {order.size})",
            "median_rmse_by_role": {rl: round(float(np.nanmedian([rm[k] for k in ok if role[k] == rl])), 3)
                                    for rl in ("good", "noisy", "outlier")
                                    if any(role[k] == rl for k in ok)},
            "good_rmse_max": round(float(np.nanmax([rm[k] for k in ok if role[k] == "good"])), 3)
            if any(role[k] == "good" for k in ok) else None,
            "g_equals_minus_w_rmse": round(float(np.nanmedian(rm[g_eq])), 3) if g_eq else None})
    else:
        out["recommended_by"] = "texture (the good cluster's member nearest its centroid)"
    return out


def _check_outputs(out: Path, csv_path: Path, input, overwrite: bool) -> None:
    """The sweep's outputs may be written: in an existing folder, or a new one made at the
    end, which the nearest existing folder above must take."""
    from ..io.output import check_outputs

    if out.is_dir():
        check_outputs([(csv_path, "OUTPUT"), (out / "recommended_dtm.tif", "OUTPUT")], (input,),
                      overwrite)
        return
    anc = out.absolute()
    while not anc.exists():
        anc = anc.parent
    check_outputs([(anc / out.name, "OUTPUT")], (), False)


def _sweep(pts, spec, base, combos, workers, prog) -> list:
    """:func:`_sweep_one` for every (g, w), on ``workers`` processes (default: all cores)."""
    import os
    from concurrent.futures import ProcessPoolExecutor
    from concurrent.futures import TimeoutError as FutureTimeout

    workers = workers or int(os.environ.get("LIDARTREES_WORKERS", 0)) or os.cpu_count() or 1
    results = []
    low = low_points(pts.x, pts.y, pts.z, base.low)  # the same for every (g, w)
    if workers <= 1:
        _sweep_init(pts.x, pts.y, pts.z, spec, base, low)
        for i, c in enumerate(combos):
            check_cancel(prog)
            results.append(_sweep_one(c))
            prog.update((i + 1) / len(combos), f"g={c[0]} w={c[1]}")
        return results
    with ProcessPoolExecutor(workers, initializer=_sweep_init,
                             initargs=(pts.x, pts.y, pts.z, spec, base, low)) as ex:
        futs = [ex.submit(_sweep_one, c) for c in combos]
        for i, f in enumerate(futs):
            while True:
                try:
                    results.append(f.result(timeout=0.5))
                    break
                except FutureTimeout:
                    if prog.canceled():
                        for ff in futs:
                            ff.cancel()
                        check_cancel(prog)
            prog.update((i + 1) / len(combos), f"g={combos[i][0]} w={combos[i][1]}")
    return results


def _clusters(results: list, seed: int, footprint, res: float) -> dict:
    """Seed 003's analysis of the swept DTMs: incomplete ones set apart, descriptors selected
    by PC1, k-means (k = 3) of the complete ones, the clusters' roles; then the good cluster
    checked against the sweep's consensus (:mod:`lidartrees_gis.ground.consensus`: its members
    too far from the median DTM are *outliers*), each DTM's rank, why, and the texture's
    recommendation."""
    names = list(results[0][3])
    X = np.array([[res_[3][n] for n in names] for res_ in results])
    complete, cov, dens, why_incomplete = complete_dtms(results, footprint, res)
    idx = np.nonzero(complete)[0]
    if idx.size == 0:
        raise InputError("dtm-quality: no (g, w) gave a complete DTM (1 ground point per 10 m² "
                         "covering 90 % of the data's cells); widen -g/-w")
    Xc = X[idx]
    sel, _, var = pca_select(Xc, 0.3)
    if sel.size == 0:  # PC1 spread evenly (every |loading| < 0.3): keep every descriptor
        sel = np.arange(X.shape[1])
    Zc = _standardise(Xc)[:, sel]
    lab_c, cent = kmeans(Zc, min(3, idx.size), seed=seed)
    roles = cluster_roles(Xc, names, lab_c)
    good = next(c for c, r in roles.items() if r == "good")
    labels = np.full(len(results), -1)
    labels[idx] = lab_c
    Z = np.full((len(results), sel.size), np.nan)
    Z[idx] = Zc
    dist = np.full(len(results), np.inf)
    dist[idx] = np.linalg.norm(Zc - cent[good], axis=1)
    texture_rank = np.zeros(len(results), int)
    texture_rank[idx] = np.argsort(np.argsort(dist[idx])) + 1
    agree = consensus_distances([res_[4] for res_ in results], complete, footprint)
    members = np.nonzero(labels == good)[0]
    limit = agreement_limit(agree[members])
    role = [("incomplete" if not complete[k] else roles[int(labels[k])])
            for k in range(len(results))]
    for k in members:
        if not agree[k] <= limit:
            role[k] = "outlier"
    trusted = [k for k in members if role[k] == "good"]
    # the ranking: good (nearest the good centroid first), noisy (likewise), outliers (nearest
    # the consensus first); incomplete DTMs have none
    key = {"good": 0, "noisy": 1, "outlier": 2}
    order = sorted(idx, key=lambda k: (key[role[k]], agree[k] if role[k] == "outlier" else dist[k]))
    rank = np.zeros(len(results), int)
    rank[np.asarray(order, int)] = np.arange(1, len(order) + 1)
    why = [_why(role[k], labels[k], agree[k], limit, why_incomplete[k])
           for k in range(len(results))]
    return {"names": names, "sel": sel, "var": var, "Z": Z, "labels": labels, "cent": cent,
            "roles": roles, "good": good, "rank": rank, "texture_rank": texture_rank,
            "complete": complete, "coverage": cov, "density": dens, "consensus": agree,
            "limit": limit, "role": role, "why": why,
            "best": int(min(trusted, key=lambda k: dist[k]))}


def _why(role, label, agree, limit, incomplete) -> str:
    """One line saying why a DTM has its role."""
    if role == "incomplete":
        return f"incomplete: {incomplete}"
    near = f"{agree:.2f} m from the sweep's median DTM"
    if role == "outlier":
        return (f"outlier: smooth texture (cluster {label}) but {near}, over the good "
                f"cluster's limit {limit:.2f} m")
    if role == "good":
        return f"good: smooth texture (cluster {label}), {near} (limit {limit:.2f} m)"
    return f"noisy: texture cluster {label} (spikes or holes)"


def _write_csv(path: Path, results: list, c: dict) -> None:
    """One row per (g, w): its ground, texture, cluster, role, rank (1 = the most trusted,
    :func:`_clusters`), the texture's own rank (distance to the good centroid), the distance to
    the sweep's consensus, the agreement with the reference and why it has its role."""
    from ..io.output import atomic_output

    names, labels, rank = c["names"], c["labels"], c["rank"]
    with atomic_output(path, overwrite=True) as tmp:
        with open(tmp, "w", encoding="utf-8") as fh:
            fh.write("g,w,ground_points,ground_density,coverage," + ",".join(names)
                     + ",cluster,role,rank,texture_rank,consensus_mad,ref_rmse,ref_bias,"
                       "ref_coverage,why\n")
            for k, (gg, ww, ng, d, _) in enumerate(results):
                rm, bias, rc = c["agree"][k]
                why = c["why"][k].replace('"', "'")
                fh.write(f"{gg:g},{ww:g},{ng},{c['density'][k]:.4g},{c['coverage'][k]:.4f},"
                         + ",".join(f"{d[n]:.6g}" for n in names)
                         + f",{labels[k] if labels[k] >= 0 else ''},{c['role'][k]},"
                         + f"{rank[k] or ''},{c['texture_rank'][k] or ''},"
                         + f"{_num(c['consensus'][k])},{_num(rm)},{_num(bias)},{rc:.4f},"
                         + f'"{why}"\n')


def _num(v) -> str:
    return "" if not np.isfinite(v) else f"{v:.4f}"


def _write_hillshades(out: Path, results: list, c: dict, res: float) -> list:
    """One hillshade PNG per cluster of complete DTMs: the member nearest its centroid."""
    pngs = []
    for k in sorted(c["roles"]):
        mem = np.nonzero(c["labels"] == k)[0]
        near = int(mem[np.argmin(np.linalg.norm(c["Z"][mem] - c["cent"][k], axis=1))])
        pth = out / f"hillshade_cluster{k}.png"
        write_hillshade_png(pth, results[near][4], res, overwrite=True,
                            title=f"cluster {k} ({c['roles'][k]}): g={results[near][0]:g} "
                                  f"w={results[near][1]:g}")
        pngs.append(str(pth))
    return pngs
