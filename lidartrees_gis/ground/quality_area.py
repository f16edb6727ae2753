"""Seed 003's DTM quality sweep over several point files (a folder, glob, list or .vpc): the
ground filter for each (g, w) and each file, with a buffer of its neighbours' points, on the
catalog runner; each (g, w)'s DTM is assembled into one grid over the whole area as its files
come back, kept on disk (a memory-mapped array) rather than in memory, and described by its
texture once complete. Memory is bounded by a file and its buffer plus the pages of the DTMs
being read.
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ..catalog.catalog import Catalog
from ..catalog.mosaic import window_of
from ..catalog.runner import TileRunner, default_workers
from ..grid import GridSpec
from ..progress import SubProgress, as_progress
from ..tin import interpolate_tin
from .filter import KrausPfeifer
from .texture import texture_descriptors
from .tiled import GROUND_BUFFER, area_refine_res, classify_buffered, dtm_window, ground_xyz


@dataclass(frozen=True)
class SweepJob:
    """What each (file, g, w) task needs: the filter, the buffer and the area's grids."""

    base: KrausPfeifer
    buffer: float
    refine_res: float
    res: float


def sweep_task(item, area: Catalog, job: SweepJob, progress=None) -> dict:
    """The ground filter with ``(g, w)`` on one file (with its buffer) and the file's DTM
    window; ``item`` is ``(file, g, w)``."""
    from ..errors import InputError

    f, g, w = item
    k = list(area.files).index(f)
    try:
        _, pts, own, nb, nb_ground = classify_buffered(f, area, replace(job.base, g=g, w=w),
                                                       job.buffer, job.refine_res, progress)
        gx, gy, gz = ground_xyz(pts, own, nb, nb_ground)
    except InputError:  # every weight became 0: no ground with this (g, w)
        own, gx = np.zeros(0, bool), np.empty(0)
        gy = gz = gx
    dtm, left, top = dtm_window(gx, gy, gz, area.bounds[k], job.res)
    return {"g": g, "w": w, "ground": int(own.sum()), "dtm": dtm, "left": left, "top": top}


def _paste(grid, spec: GridSpec, arr, left, top) -> None:
    """Write a window of the area's grid (clipped to it)."""
    win = window_of(spec, arr.shape, left, top)
    if win is not None:
        (r0, r1, c0, c1), (ar, ac) = win
        grid[r0:r1, c0:c1] = arr[ar, ac]


def footprint_and_reference(area: Catalog, spec: GridSpec, want_reference: bool):
    """One pass over the files: the cells holding points, and the class-2 points' TIN (the
    vendor's ground) when asked and present: ``(footprint, reference or None, n_class2)``."""
    footprint = np.zeros(spec.shape, bool)
    gx, gy, gz = [], [], []
    for f in area.files:
        for c in area.read.open(f, chunk_size=1_000_000).chunks():
            r, cc = spec.cell_index(c.x, c.y)
            ok = (r >= 0) & (r < spec.height) & (cc >= 0) & (cc < spec.width)
            footprint[r[ok], cc[ok]] = True
            if want_reference and c.classification is not None:
                m = c.classification == 2
                gx.append(c.x[m])
                gy.append(c.y[m])
                gz.append(c.z[m])
    n2 = int(sum(a.size for a in gx))
    if not want_reference or n2 < 3:
        return footprint, None, n2
    ref = interpolate_tin(np.concatenate(gx), np.concatenate(gy), np.concatenate(gz), spec)
    return footprint, ref, n2


def sweep_area(area: Catalog, spec: GridSpec, base: KrausPfeifer, combos, workers, folder: Path,
               buffer=None, progress=None) -> list:
    """Seed 003's sweep over ``area``'s files: ``[(g, w, ground points, descriptors, dtm)]`` in
    the order of ``combos``, each DTM a memory-mapped float32 array in ``folder`` (kept there
    until the caller is done)."""
    prog = as_progress(progress)
    job = SweepJob(base, GROUND_BUFFER if buffer is None else float(buffer),
                   area_refine_res(area), spec.res)
    items = [(f, g, w) for f in area.files for g, w in combos]  # file by file: read cache
    grids, left, ground, results = {}, {}, {}, {}
    runner = TileRunner(default_workers(workers, None, area.count * len(combos)))
    with runner:
        for r in runner.map(sweep_task, items, (area, job), progress=SubProgress(prog, 0, 1),
                            label="file"):
            key = (r["g"], r["w"])
            if key not in grids:
                grids[key] = np.lib.format.open_memmap(
                    folder / f"dtm_{len(grids):03d}.npy", mode="w+", dtype=np.float32,
                    shape=spec.shape)
                grids[key][:] = np.nan
                left[key], ground[key] = len(area.files), 0
            _paste(grids[key], spec, r["dtm"], r["left"], r["top"])
            ground[key] += r["ground"]
            left[key] -= 1
            if left[key] == 0:  # complete: described, and left to the disk
                grids[key].flush()
                results[key] = (key[0], key[1], ground[key], texture_descriptors(grids[key]),
                                grids[key])
    return [results[(g, w)] for g, w in combos]
