"""The ground filter over a catalog: one task per point file, each with a buffer of its
neighbours' points, on the same runner as ``trees`` (this process, a local Dask cluster or an
existing one). A single file is a catalog of one.

Each task reads its file and the points of the other files within ``buffer`` metres of it,
filters them together (the grids of the filter are those of the whole area, clipped to the
task's box: :func:`~lidartrees_gis.ground.filter.kraus_pfeifer`'s ``extent``), writes the
file's classified copy and returns its piece of the DTM, written into one GeoTIFF mosaic as the
tasks finish. Memory is bounded by a file and its buffer, not by the acquisition. Every output
is written under a temporary name and renamed once every task has finished.
"""
from __future__ import annotations

import contextlib
import os
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from .._version import __version__
from ..catalog.catalog import Catalog, TilingOptions
from ..catalog.mosaic import MosaicWriter
from ..catalog.runner import FailedTiles, TileRunner, default_workers
from ..catalog.source import drop_far_points
from ..crs import crs_label
from ..errors import InputError
from ..grid import GridSpec, auto_resolution, check_resolution
from ..io.options import ReadOptions
from ..io.claim import claim_output, place
from ..io.output import OutputOptions, check_output, check_outputs, claim_outputs
from ..io.provenance import raster_tags, repro_meta, repro_report
from ..progress import SubProgress, as_progress
from ..tin import interpolate_tin
from .filter import KrausPfeifer, kraus_pfeifer, refine_cell_for

#: buffer (m) of each file's task: the filter's TIN uses triangles up to 20 m in circumradius
#: (``filter.DENSIFY_RADIUS``); with it the four lasR bcts tiles as a folder classify their
#: 2.83 M points as the four merged into one file do (0 differ; tests/test_ground_tiled.py)
GROUND_BUFFER = 30.0


@dataclass(frozen=True)
class GroundJob:
    """What every file's task needs besides its file: the filter, the grids and the outputs."""

    params: KrausPfeifer
    buffer: float
    refine_res: float
    dtm_res: float | None
    outputs: tuple  # temporary classified output per file
    reclassify: bool = False


def area_refine_res(area: Catalog) -> float:
    """The densification grid of the whole area (:func:`filter.refine_cell_for` its density)."""
    return refine_cell_for(area.area, area.count)


def area_resolution(area: Catalog, res) -> float:
    """The DTM cell of ``area``: ``res`` metres, or ``auto``: seed 003's sqrt(1/n) of the
    area's density."""
    if isinstance(res, str) and res.strip().lower() == "auto":
        return auto_resolution(area.count, area.area)
    return check_resolution(res)


def ground_xyz(pts, mask, nb=None, nb_mask=None):
    """The ground points (``mask``) of a file and those (``nb_mask``) of its neighbours."""
    gx, gy, gz = pts.x[mask], pts.y[mask], pts.z[mask]
    if nb is None:
        return gx, gy, gz
    return tuple(np.concatenate([a, c[nb_mask]]) for a, c in ((gx, nb.x), (gy, nb.y), (gz, nb.z)))


def output_paths(area: Catalog, output) -> list:
    """The classified file written for each input: ``output`` itself for one file; for several,
    a file of the same name in the folder ``output`` (``.las``/``.laz`` kept, XYZ -> ``.laz``)."""
    if len(area.files) == 1 and Path(output).suffix.lower() in (".las", ".laz"):
        return [Path(output)]
    folder = Path(output)
    if folder.suffix.lower() in (".las", ".laz"):
        raise InputError(f"OUTPUT: {output}: {len(area.files)} input files give one classified "
                         "file each; give a folder")
    if folder.exists() and not folder.is_dir():
        raise InputError(f"OUTPUT: {output} is a file; give a folder for the classified files")
    paths, seen = [], {}
    for f in area.files:
        p = Path(f)
        name = p.stem + (p.suffix.lower() if p.suffix.lower() in (".las", ".laz") else ".laz")
        if name in seen:
            raise InputError(f"OUTPUT: {f} and {seen[name]} would both be written as {name}; "
                             "rename one")
        seen[name] = f
        paths.append(folder / name)
    return paths


def _part(path: Path) -> Path:
    return path.parent / f".{path.stem}.lidartrees-part{path.suffix}"


def _neighbours(area: Catalog, k: int, box):
    """Points (noise classes left out) of the other files inside ``box``."""
    from ..catalog.source import TileSource

    others = [i for i in range(len(area.files)) if i != k]
    sub = replace(area, files=[area.files[i] for i in others],
                  bounds=[area.bounds[i] for i in others], counts=[area.counts[i] for i in others],
                  repros=[area.repros[i] for i in others] if area.repros else [])
    if not sub.files_for(box):
        return None
    return TileSource(sub, box).read_all()


def classify_buffered(f, area: Catalog, params: KrausPfeifer, buffer: float, refine_res: float,
                      progress=None):
    """The ground filter on file ``f`` of ``area`` with its neighbours' points within
    ``buffer`` metres, on the area's grids: ``(src, pts, own, nb, nb_ground)``, ``own`` the
    ground mask of the file's points (noise classes never ground), ``nb`` the neighbours'
    points (or None) and ``nb_ground`` their ground mask."""
    from .chain import filtered_points

    prog = as_progress(progress)
    k = list(area.files).index(f)
    src = area.read.open(f, filtered=False)
    pts = src.read_all(SubProgress(prog, 0.0, 0.25))
    use = filtered_points(pts, f) & area.keeps(pts.x, pts.y)  # stray far points never ground
    box = area.clip(area.bounds[k], buffer)
    nb = _neighbours(area, k, box) if len(area.files) > 1 else None
    n_nb = 0 if nb is None else len(nb)
    x = np.concatenate([pts.x[use]] + ([nb.x] if n_nb else []))
    y = np.concatenate([pts.y[use]] + ([nb.y] if n_nb else []))
    z = np.concatenate([pts.z[use]] + ([nb.z] if n_nb else []))
    g, _ = kraus_pfeifer(x, y, z, params, progress=SubProgress(prog, 0.25, 1.0),
                         refine_res=refine_res, extent=box)
    own = np.zeros(len(pts), bool)
    n_use = int(use.sum())
    own[use] = g[:n_use]
    return src, pts, own, (nb if n_nb else None), g[n_use:]


def dtm_window(gx, gy, gz, bounds, res):
    """The DTM (linear TIN of ground points) on the cells of ``bounds`` of the area's grid of
    ``res`` metres: ``(array, left, top)``; NaN where fewer than 3 ground points."""
    spec = GridSpec.from_bounds(*bounds, res)
    if gx.size < 3:
        return np.full(spec.shape, np.nan, np.float32), spec.left, spec.top
    return interpolate_tin(gx, gy, gz, spec).astype(np.float32), spec.left, spec.top


def ground_task(f, area: Catalog, job: GroundJob, progress=None) -> dict:
    """Classify the file ``f`` of ``area`` (with the points of its neighbours within the
    buffer), write its classified copy and return its counts and DTM piece."""
    from ..io.lasout import write_classified
    from .chain import ground_classes

    prog = as_progress(progress)
    k = list(area.files).index(f)
    src, pts, own, nb, nb_ground = classify_buffered(f, area, job.params, job.buffer,
                                                     job.refine_res, SubProgress(prog, 0, 0.75))
    buf = job.buffer
    if own.sum() < 3:
        raise InputError(f"{f}: the ground filter kept {int(own.sum())} points; raise -w or "
                         "lower -g")
    cls = ground_classes(pts.classification, own, job.reclassify)
    meta = {"command": "ground", "tool": f"lidartrees_gis {__version__}", "input": str(f),
            "crs": crs_label(src.crs), "reclassify": job.reclassify,
            "files": len(area.files), "buffer": buf if len(area.files) > 1 else None,
            **job.params.as_dict(), **repro_meta(src)}
    prog.update(0.8, "writing")
    write_classified(job.outputs[k], src, cls, overwrite=True, metadata=meta)
    out = {"file": k, "points": len(pts), "ground": int((cls == 2).sum()),
           "kept_classes": int((~np.isin(cls, (1, 2))).sum())}
    if job.dtm_res:
        # the neighbours' ground as their own files get it
        ncls = None if nb is None else \
            ground_classes(nb.classification, nb_ground, job.reclassify) == 2
        gx, gy, gz = ground_xyz(pts, cls == 2, nb, ncls)
        out["dtm"], out["left"], out["top"] = dtm_window(gx, gy, gz, area.bounds[k], job.dtm_res)
    prog.update(1.0, "done")
    return out


def ground_run(input, output, *, dtm_out=None, res="auto", params=None,
               read: ReadOptions | None = None, tiling: TilingOptions | None = None,
               out: OutputOptions | None = None, reclassify=False, progress=None) -> dict:
    """Classify ground (class 2) in point files with Kraus & Pfeifer robust interpolation and
    TIN densification; write a classified LAS/LAZ per input file and optionally one DTM GeoTIFF
    (linear TIN of the ground points, cell ``res`` or sqrt(1/n) of the area's density).

    ``input``: a file, folder, glob, list or ``.vpc``. One file: ``output`` is the classified
    file. Several: ``output`` is a folder, each file keeps its name there; each file is a task
    with a buffer of ``tiling.buffer`` metres (default :data:`GROUND_BUFFER`) of its neighbours'
    points, run in this process or on Dask (``tiling.workers``, ``tiling.scheduler``).
    """
    read, tiling, out = read or ReadOptions(), tiling or TilingOptions(), out or OutputOptions()
    params = params or KrausPfeifer()
    prog = as_progress(progress)
    check_outputs([(dtm_out, "-dtm_out")], (), out.overwrite)
    area = Catalog.open(input, read)
    drop_far_points(area)  # stray points far from the rest: left out (a hang before)
    finals = output_paths(area, output)
    folder = Path(output) if len(finals) > 1 else None
    if folder is not None and not folder.exists():  # made once the checks pass
        check_output(folder, False)
        check_outputs([(dtm_out, "-dtm_out")], area.files, out.overwrite)
    else:
        check_outputs([(p, "OUTPUT") for p in finals] + [(dtm_out, "-dtm_out")], area.files,
                      out.overwrite)
    dtm_res = area_resolution(area, res) if dtm_out else None
    buffer = GROUND_BUFFER if tiling.buffer is None else float(tiling.buffer)
    parts = [_part(p) for p in finals]
    job = GroundJob(params, buffer, area_refine_res(area), dtm_res, tuple(str(p) for p in parts),
                    bool(reclassify))
    if folder is not None:
        folder.mkdir(exist_ok=True)
    workers = default_workers(tiling.workers, tiling.scheduler, area.count)
    totals = {"points": 0, "ground": 0, "kept_classes": 0}
    done = set()
    dtm_tmp = None
    claims = contextlib.ExitStack()  # the outputs are this run's until they take their names
    try:
        claims.enter_context(claim_output(folder, param="OUTPUT") if folder is not None else
                             claim_outputs([(finals[0], "OUTPUT")], out.overwrite))
        with contextlib.ExitStack() as stack:
            mosaic = None
            if dtm_out:
                from ..io.output import atomic_output

                dtm_tmp = stack.enter_context(atomic_output(dtm_out, out.overwrite,
                                                            param="-dtm_out"))
                spec = GridSpec.from_bounds(*area.extent, dtm_res, crs=area.crs)
                mosaic = MosaicWriter(dtm_tmp, spec, creation_options=out.creation_options,
                                      tags=raster_tags("ground", area,
                                                       {"res": dtm_res, **params.as_dict()}, input),
                                      description="terrain height (m)")
                stack.callback(mosaic.close)
            runner = stack.enter_context(TileRunner(workers, tiling.scheduler,
                                                    on_error=tiling.on_error))
            if runner.scheduler:
                runner.check_readable(area.files)
            for r in runner.map(ground_task, list(area.files), (area, job),
                                progress=SubProgress(prog, 0.0, 0.97), inner_progress=True,
                                label="file"):
                done.add(r["file"])
                for key in totals:
                    totals[key] += r[key]
                if mosaic is not None:
                    mosaic.write(r["dtm"], r["left"], r["top"])
            failed = list(runner.failed)
            if not done:
                raise InputError(f"{input}: no file was classified")
        for k in sorted(done):  # every task finished: the classified files take their names
            check_output(finals[k], out.overwrite)
            place(parts[k], finals[k], out.overwrite)
    finally:
        for k, p in enumerate(parts):
            with contextlib.suppress(OSError):
                if p.exists():
                    p.unlink()
        claims.close()
    result = {"output": str(output), "files": len(area.files), **totals,
              "ground_share": totals["ground"] / max(totals["points"], 1),
              "crs": crs_label(area.crs), "reprojection": repro_report(area),
              "buffer": buffer if len(area.files) > 1 else None,
              "far_points": area.far or None, "workers": workers or os.cpu_count()}
    if dtm_out:
        from ..io.styles import write_sidecar_style

        result.update({"dtm": str(dtm_out), "res": dtm_res})
        write_sidecar_style(dtm_out, "dtm_hillshade.qml", out.overwrite)
    prog.update(1.0, "done")
    if failed:
        result["failed_files"] = [str(e.item) for e in failed]
        raise FailedTiles(failed, result, len(area.files))
    return result
