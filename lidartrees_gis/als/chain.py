"""The file-level chains of the ALS commands (``grid``, ``chm``, ``trees``, ``compare``): one
code path for one file and for a whole flight.

Every chain opens its input as an area (a :class:`~lidartrees_gis.catalog.catalog.Catalog` of
point files, one file being a catalog of one, or a CHM raster), plans it once
(:func:`lidartrees_gis.als.area.plan_area`: cell size, edge limit, crown scale, tiles), runs its
per-tile function (:mod:`lidartrees_gis.als.tile`) in this process or on Dask, and merges the
tiles' results into its outputs as they come (:mod:`lidartrees_gis.als.sinks`, mosaics), each
written to a temporary file renamed at the end.
"""
from __future__ import annotations

import contextlib
from dataclasses import replace
from pathlib import Path

import numpy as np

from .._version import __version__
from ..catalog.catalog import Catalog, TilingOptions
from ..catalog.inputs import is_catalog_input
from ..catalog.mosaic import MosaicWriter
from ..catalog.raster import RasterArea, is_raster
from ..catalog.checkpoint import Checkpoint, run_fingerprint
from ..catalog.runner import FailedTiles, TileRunner, default_workers, tile_name
from ..crs import crs_label
from ..errors import InputError
from ..grid import GridSpec
from ..io.options import ReadOptions, filter_report
from ..io.output import OutputOptions, atomic_output, check_outputs, claim_outputs
from ..io.provenance import raster_tags, repro_meta, repro_report
from ..progress import SubProgress, as_progress
from .area import AreaPlan, one_tile_area, plan_area
from .sinks import (GpkgTreeLayers, QuickLook, Tally, TreeLayers, TreesSummary, TreesTable,
                    sidecar, tree_layer_names)
from .surfaces import SurfaceOptions, box_surfaces
from ..plantation.stands import StandsTally, write_stand_csv
from .planted import BLOCKS_SOURCE, planted_stands, wants_blocks
from .stand_checks import check_chm_plantation, stands_summary, warn_other_lattices
from .tile import tile_first_tops, tile_trees, warn_sparse_plantation
from .trees import TreeParams, area_window_corner, auto_smoothing


def open_area(input, read: ReadOptions | None = None):
    """The area of ``input``: a CHM raster (``.tif``, for ``trees`` and ``compare``) or a
    catalog of point files (a file, folder, glob, list, .vpc or ept.json)."""
    read = read or ReadOptions()
    if isinstance(input, (str, Path)) and is_raster(input) and not is_catalog_input(input):
        return RasterArea.open(input, read.a_srs)
    return Catalog.open(input, read)


def runner_for(area, tiling: TilingOptions) -> TileRunner:
    """Where the tiles of ``area`` run: a local Dask cluster or an existing one, or this process
    (small areas, one tile: with ``--scheduler`` too, and a warning says why)."""
    workers = default_workers(tiling.workers, tiling.scheduler, area.count)
    scheduler = tiling.scheduler
    if scheduler and tiling.tile_size is None and one_tile_area(area):
        import warnings

        from ..errors import DataWarning

        warnings.warn(DataWarning(
            f"{area.label()}: {area.count:,} points make one tile, run in this process "
            f"(--scheduler {scheduler} is used for areas of several tiles; give -tile_size to "
            "cut this one)"), stacklevel=2)
        scheduler = None
    return TileRunner(workers, scheduler, on_error=tiling.on_error)


@contextlib.contextmanager
def kept_tiles(runner: TileRunner, output, tiling: TilingOptions, plan: AreaPlan, *parts):
    """While a run of several tiles writes ``output``: each tile's result is kept beside it
    (:class:`~lidartrees_gis.catalog.checkpoint.Checkpoint`), so ``-resume`` continues a killed
    run; removed once the outputs are written and no tile failed. ``parts``: what makes the
    run's tiles (the area, the options) beside the plan."""
    if runner.scheduler and runner.client is not None:
        runner.check_readable(parts[0].files if isinstance(parts[0], Catalog) else ())
    if output is None or len(plan.tiles) < 2:
        if tiling.resume:
            _warn(f"-resume: {'no output file' if output is None else 'one tile'}, nothing kept "
                  "to resume from; the run starts from the beginning")
        yield None
        return
    area = parts[0]
    files = [str(f) for f in getattr(area, "files", [])]
    read = area.read.describe() if isinstance(area, Catalog) else None
    ck = Checkpoint.beside(output, run_fingerprint(files, __version__, read, *parts[1:], plan),
                           tiling.resume)
    if tiling.resume:
        stale_outputs(output)
    runner.checkpoint = ck
    try:
        yield ck
    except BaseException:
        done = ck.done()
        if done:
            _warn(f"{done} of {len(plan.tiles)} tiles are kept in {ck.folder}: the same command "
                  "with -resume continues from them")
        raise
    finally:
        runner.checkpoint = None
    if ck.resumed:
        _warn(f"-resume: {ck.resumed} of {len(plan.tiles)} tiles were taken from the killed run")
    if runner.failed:
        _warn(f"{ck.done()} of {len(plan.tiles)} tiles are kept in {ck.folder}: once the failed "
              "tiles are fixed, the same command with -resume -overwrite runs only those")
    else:
        ck.finish()


def stale_outputs(output) -> None:
    """Remove the temporary outputs a killed run left beside ``output`` (a kill runs no
    clean-up; -resume starts a new one)."""
    out = Path(output)
    for f in out.parent.glob(f".{out.stem}.*.part{out.suffix}"):
        with contextlib.suppress(OSError):
            f.unlink()


def check_failed(runner: TileRunner, result: dict) -> dict:
    """``result``, or :class:`~lidartrees_gis.catalog.runner.FailedTiles` (holding it) when
    tiles were left out (``-on_error skip``)."""
    if runner.failed:
        result["failed_tiles"] = [tile_name(e.item) for e in runner.failed]
        raise FailedTiles(runner.failed, result, result.get("tiles"))
    return result


def check_points(area, tally: Tally, read: ReadOptions | None = None) -> None:
    """Refuse a run whose tiles read no point (every point dropped by the class filter, or
    none in the area): its outputs would be all nodata, or hold no tree. Called before the
    outputs are renamed into place, so none is written."""
    if not isinstance(area, Catalog) or tally.points:
        return
    dropped = ", ".join(f"{v:,} of class {c}" for c, v in sorted(tally.dropped.items()))
    filt = ", ".join(f"-{k} {v}" for k, v in (read.describe() if read else {}).items() if v)
    why = "the class filter dropped every point" + "".join(
        f" ({t})" for t in ("; ".join(x for x in (dropped, filt) if x),) if t)
    raise InputError(f"{area.label()}: no points left to process: {why}; change -drop_class "
                     "or -keep_class")


def check_trees(area, plan: AreaPlan, trees: int, params: TreeParams) -> None:
    """Refuse 0 trees from an area that holds canopy above ``-min_height`` (a detection
    that found nothing there has failed: its GeoPackage would be a wrong, empty result)."""
    if trees == 0 and plan.canopy_windows:
        raise InputError(f"{area.label()}: no tree found, though the canopy rises above "
                         f"-min_height {params.min_height:g} m (dominant height "
                         f"{plan.dominant_height:.1f} m); check -min_height, -smooth and the "
                         "crown-size options")


def _warn(message: str) -> None:
    import warnings

    from ..errors import DataWarning

    warnings.warn(DataWarning(message), stacklevel=3)


def run_tiles(runner: TileRunner, fn, plan: AreaPlan, args, ready=None, progress=None):
    """Yield ``fn(tile, *args)`` for the plan's tiles as they finish; ``ready``: the one tile's
    surfaces, computed while planning."""
    if ready is not None:
        yield fn(plan.tiles[0], *args, surfaces=ready, progress=progress)
        return
    area = next((a for a in args if isinstance(a, Catalog)), None)
    # each worker a run of tiles of about equal points (the edge tiles hold fewer); in this
    # process the order alone matters
    spread = runner.workers > 1 or runner.scheduler
    weights = [area.points_in(t.box) for t in plan.tiles] if area is not None and spread \
        else None
    yield from runner.map(fn, list(plan.tiles), args, progress=progress, inner_progress=True,
                          weights=weights)


def _result(area, plan: AreaPlan, summary: Tally) -> dict:
    """What every chain reports of its area, its plan and what its tiles read."""
    return {"crs": crs_label(area.crs), "files": len(area.files),
            "points": getattr(area, "count", None) if isinstance(area, Catalog) else None,
            "points_read": summary.points or None, "tiles": len(plan.tiles),
            "buffer": round(plan.buffer, 2) if len(plan.tiles) > 1 else None, "res": plan.res,
            **filter_report(summary.dropped), "outlier_points": summary.outliers or None,
            "far_points": getattr(area, "far", 0) or None,
            "skipped": getattr(area, "skipped", 0) or None, "reprojection": repro_report(area)}


def _trees_meta(input, area, params: TreeParams, plan: AreaPlan, surface: SurfaceOptions) -> dict:
    meta = {"lidartrees_version": __version__, "input": str(input),
            "files": [str(f) for f in area.files], "res": plan.res, "dtm": surface.dtm,
            "chm": surface.chm if isinstance(area, Catalog) else "input raster",
            "fill": surface.fill, "outliers": surface.outliers, **params.as_dict(),
            "crown_scale_source": plan.crown_scale_source, "tiles": len(plan.tiles),
            "buffer": plan.buffer}
    if isinstance(area, Catalog):
        meta.update(area.read.describe())
    meta.update({k: v for k, v in repro_meta(area).items() if v is not None})
    return meta


def trees_run(input, output=None, *, params: TreeParams | None = None,
              surface: SurfaceOptions | None = None, read: ReadOptions | None = None,
              tiling: TilingOptions | None = None, out: OutputOptions | None = None, png=None,
              csv=None, chm_out=None, stands=None, stand_id=None, stand_csv=None,
              title=None, progress=None) -> dict:
    """Tree tops, crowns and a stand summary from points or a CHM, into a GeoPackage.

    Parameters
    ----------
    input : str or Path or list
        Point files (a file, folder, glob, list or .vpc) or a CHM GeoTIFF.
    output : str or Path, optional
        The GeoPackage (layers ``tree_tops``, ``crowns``, ``summary`` and, in plantation mode,
        ``gaps``); None keeps the layers in memory (``result["layers"]``).
    params : TreeParams
        Detection (default: automatic smoothing and window; ``spacing`` for plantation mode).
    surface, read, tiling, out : SurfaceOptions, ReadOptions, TilingOptions, OutputOptions
    png, csv, chm_out : str or Path, optional
        Also write the quick-look PNG, the TreeX-layout CSV, the CHM GeoTIFF.
    stands : str, Path or GeoDataFrame, optional
        Stand (talhão) polygons (``PATH[:LAYER]``, any OGR source): every tree and gap gets its
        ``stand_id`` and a ``stands`` layer the per-stand figures (in plantation mode with each
        stand's own lattice); see :func:`lidartrees_gis.plantation.stands.load_stands`.
    stand_id : str, optional
        The stands' id field (default: the first of ``stand_id``, ``talhao``, ... present).
    stand_csv : str or Path, optional
        Also write the stands' figures as a CSV table.
    title : str, optional
        The quick look's title (default: the input's name and the summary, which then follows
        on a second line).

    Returns
    -------
    dict: ``output``, ``trees``, the summary's figures, ``tree_ids``, what was read.
    """
    p = params or TreeParams()
    by_stands = False  # plantation mode because stands are given (stands_plantation)
    surface, read = surface or SurfaceOptions(), read or ReadOptions()
    tiling, out = tiling or TilingOptions(), out or OutputOptions()
    if output is not None and Path(output).suffix.lower() != ".gpkg":
        raise InputError(f"OUTPUT: {output}: expected a .gpkg file name")
    outputs = [(output, "OUTPUT", out.overwrite or out.append), (png, "-png"), (csv, "-csv"),
               (chm_out, "-chm_out"), (stand_csv, "-stand_csv")]
    if stand_csv is not None and stands is None:
        raise InputError("-stand_csv: needs -stands (the stand polygons)")
    check_outputs(outputs, (), out.overwrite)
    prog = as_progress(progress)
    area = open_area(input, read)
    check_outputs(outputs, area.files, out.overwrite)
    if not isinstance(area, Catalog):
        check_chm_plantation(p, stands, area.label())
    if stands is not None:
        from ..plantation.stands import check_overlap, load_stands

        stands = load_stands(stands, area.crs, stand_id)
        check_overlap(stands, area.extent, area.label())
        by_stands = p.spacing is None
        p = stands_plantation(p, area)
        by_stands = by_stands and p.spacing is not None
    # the outputs are this run's until written (a -append waits for another run's to land)
    with claim_outputs(outputs, out.overwrite, output if out.append else None), \
            runner_for(area, tiling) as runner:
        prog.update(0.01, "measuring the area")
        plan, ready = plan_area(area, surface, tiling, runner=runner, params=p, keep=True,
                                progress=SubProgress(prog, 0.02, 0.45))
        p = replace(p, crown_scale=plan.crown_scale, dominant_height=plan.dominant_height,
                    top_height=plan.top_height)
        if p.tops_finder == "treex":  # the windows start at the area's first cell (seed 001)
            p = replace(p, window_corner=area_window_corner(area, plan.res))
        first = None  # the first pass over the tiles, when the blocks needed it
        if stands is None and isinstance(area, Catalog) and wants_blocks(p, plan):
            prog.update(0.45, "planted blocks")
            stands, first = planted_stands(runner, area, p, plan, surface, ready,
                                           SubProgress(prog, 0.45, 0.6))
            if stands is not None and p.spacing is None:  # each block its lattice, a stand's
                p, by_stands = replace(p, spacing="auto"), True
        if p.spacing is not None and isinstance(area, Catalog) and not by_stands:
            warn_sparse_plantation(_density(area, plan, ready, runner))
        summary = TreesSummary()
        tally = None if stands is None else StandsTally(stands)
        with kept_tiles(runner, output, tiling, plan, area, p, surface, bool(chm_out or png),
                        png, csv, chm_out, stands and stands.digest()), \
                contextlib.ExitStack() as stack:
            sinks = _trees_sinks(stack, input, output, area, p, plan, surface, out, csv, chm_out,
                                 png, stands, stand_csv)
            grids, start = None, 0.45
            if p.spacing is not None and ready is None:  # plantation mode over tiles
                grids, start = _area_grids(runner, area, p, plan, surface, stands,
                                           SubProgress(prog, 0.45 if first is None else 0.6,
                                                       0.7), first), 0.7
            args = (area, p, plan, surface, bool(chm_out or png), stands, grids)
            n = len(plan.tiles)
            other = {}  # the stands on another lattice than an explicit -spacing
            for done, r in enumerate(run_tiles(runner, tile_trees, plan, args, ready,
                                               SubProgress(prog, start, 0.95)), 1):
                summary.add(r)
                other.update(r.get("lattice_other") or {})
                if tally is not None:
                    tally.add(r)
                # the last wave of tiles is written as it comes, while the other workers finish
                sinks["layers"].add(r, flush=n - done < runner.workers)
                for k in ("csv", "quicklook"):
                    if sinks.get(k) is not None:
                        sinks[k].add(r)
                if sinks.get("chm") is not None:
                    sinks["chm"].write(r["chm"], r["chm_left"], r["chm_top"])
            check_points(area, summary, read)
            warn_other_lattices(other, p.spacing, stands)
            smooth = auto_smoothing(plan.crown_scale, plan.res)[0] if p.smooth == "auto" else p.smooth
            row = summary.row(p, plan, smooth)
            if stands is None:
                warn_rows_without_lattice(plan, row, p)
            if not runner.failed:
                check_trees(area, plan, int(row["trees"]), p)
            srows = None
            if tally is not None:
                srows = tally.rows(plan.res, p.spacing)
                if by_stands and any(r.get("lattice") == "found" for r in srows):
                    warn_sparse_plantation(_density(area, plan, ready, runner))
                if stands.source != BLOCKS_SOURCE:  # blocks lie where the tops are
                    tally.check_cover(srows)
                    stands_summary(row, srows)
                if stand_csv:
                    write_stand_csv(sinks["stand_csv"], srows, out.table)
            sinks["layers"].finish(row, p.spacing is not None,
                                   None if srows is None else (srows, stands.geoms))
        if chm_out:
            sidecar(chm_out, "chm.qml", out.overwrite, sinks["chm"].max)
        if png:
            head = row if "stands_trees_per_ha" not in row else \
                {**row, "trees_per_ha": row["stands_trees_per_ha"]}  # the stands', not the extent's
            sinks["quicklook"].write(png, _title(head, input, title), out.overwrite,
                                     stands=None if stands is None else (stands.ids, stands.geoms))
    prog.update(1.0, "done")
    res = _trees_result(output, area, plan, summary, row, p, sinks["layers"], surface)
    if stands is not None:
        res.update(_stands_result(stands, srows, tally, stand_csv))
    return check_failed(runner, res)


def stands_plantation(p: TreeParams, area) -> TreeParams:
    """With stands and no ``spacing``: each stand's planting lattice is looked for, as with
    ``-spacing auto`` (plantation mode where a stand shows one, the defaults' trees where it
    shows none), when the defaults look for a lattice at all (:attr:`TreeParams.
    looks_for_lattice`; ``-planting none`` or a seed method: no) and the area is points (the
    empty positions are read from the returns). Without, the defaults' tops on the porous,
    overlapping crowns of a closed plantation are as much the returns' noise as the trees
    (docs/PLANTATION.md, "With stands")."""
    if p.spacing is None and p.looks_for_lattice and isinstance(area, Catalog):
        return replace(p, spacing="auto")
    return p


def warn_rows_without_lattice(plan: AreaPlan, row: dict, p: TreeParams) -> None:
    """A :class:`DataWarning` when the canopy shows planting rows (:attr:`AreaPlan.
    canopy_rows`) but fewer than half the tiles' tops lie on a planting lattice, without
    stands or a spacing: the tops alone misread a closed plantation's trees (the porous,
    overlapping crowns' noise is as many tops as the trees), and each stand's lattice, which
    ``-stands`` looks for, reads them."""
    if p.spacing is not None or not p.looks_for_lattice or not plan.canopy_rows:
        return
    if int(row.get("planting_tiles") or 0) >= 0.5 * len(plan.tiles):
        return
    seen = []
    for apart, az in plan.canopy_rows:
        if not any(abs(apart - a) <= 0.1 and abs((az - b + 90.0) % 180.0 - 90.0) <= 3.0
                   for a, b in seen):
            seen.append((apart, az))
    rows = "; ".join(f"{a:.1f} m apart at {b:.0f}°" for a, b in seen[:3])
    more = f" and {len(seen) - 3} more directions" if len(seen) > 3 else ""
    _warn(f"the canopy shows planting rows ({rows}{more}) but the tops lie on no planting "
          "lattice: in a closed plantation the tops alone misread its trees; give the stands "
          "(-stands STANDS.gpkg: each stand's lattice and its trees), or -spacing auto for "
          "one planting")


def _area_grids(runner, area, p: TreeParams, plan: AreaPlan, surface, stands, progress,
                first=None) -> dict:
    """Plantation mode over tiles: each stand's planting lattice fitted once, on the tops every
    tile finds first in its core (:func:`~lidartrees_gis.als.tile.tile_first_tops`), as a run
    on one file fits it on all its tops: the tiles then count their positions on the same
    lattice, so a stand's counts do not depend on the tiling (a lattice per tile shifted by a
    few centimetres counted the positions along the tiles' edges twice or not at all). Costs
    a first pass over the tiles' surfaces."""
    from ..plantation.positions import fit_lattice, fit_stand_grids

    # labelled apart from the trees' tiles: nothing kept for -resume, and a tile set aside
    # (-on_error skip) is told as left out of the lattices
    if first is None:
        found = list(runner.map(tile_first_tops, list(plan.tiles),
                                (area, p, plan, surface, stands), progress=progress,
                                inner_progress=True, label="lattice tile"))
    else:  # made for the planted blocks (als.planted): each top's block found here
        found = first
    if not found:
        return {"all": None}
    x, y, z = (np.concatenate([np.asarray(r[k]) for r in found]) for k in ("x", "y", "zone"))
    if first is not None and stands is not None:
        from ..plantation.stands import locate

        z = locate(stands, x, y)
    from ..plantation.positions import add_anchors
    from ..plantation.scan import merge_waves

    scan = merge_waves([r.get("scan") for r in found])  # the returns' scan lines
    from .tile import number_regions, tile_canopy_spectra

    def spectra(keys):  # -spacing auto, stands whose tops show no lattice: their canopies
        from ..plantation.canopy_lattice import stand_spectrum

        parts = {}
        for r in runner.map(tile_canopy_spectra, list(plan.tiles),
                            (area, p, plan, surface, stands, list(keys)), label="lattice tile"):
            for k, v in r.items():
                parts.setdefault(k, []).append(v)
        return {k: stand_spectrum([p for p, _ in v], [q for _, q in v], plan.res)
                for k, v in parts.items()}

    def fits(jobs, spacing, cell, scan):  # one stand's lattice per task, on the run's workers
        out = list(runner.map(fit_lattice, jobs, (spacing, cell, scan), ordered=True,
                              label="lattice fit"))
        if len(out) != len(jobs):  # -on_error skip left one out: no lattice is left unsaid
            raise RuntimeError(f"{len(jobs) - len(out)} of {len(jobs)} stands' lattice fits "
                               "failed")
        return out

    grids = fit_stand_grids(x, y, z if stands is not None else None, p.spacing, whole=True,
                            cell=plan.res, spectra=spectra, fits=fits, scan=scan)
    # where each stand's row and plant numbers start: made once here, for every tile
    zones = [-1] + ([] if stands is None else list(range(len(stands))))
    return add_anchors(grids, number_regions(stands, area.extent), plan.res, zones)


def _stands_result(stands, rows, tally, stand_csv) -> dict:
    """The stands' figures a trees run reports: each stand's key figures on one line."""
    out = {"stands": len(stands), "stands_source": stands.source,
           "stand_id_field": stands.id_field or "(numbered)",
           "trees_outside_stands": tally.outside}
    if stands.reprojection:
        out["stands_reprojection"] = stands.reprojection
    if stand_csv:
        out["stand_csv"] = str(stand_csv)
    for r in rows:
        if not r["trees"]:  # no figure to give (never a nan): say why
            cover = r.get("data_cover_pct") or 0.0
            out[f"stand {r['stand_id']}"] = (
                f"no tree, {r['area_ha']:.2f} ha, " + ("outside the points" if not cover else
                                                        f"{_round(cover, 1)} % covered by "
                                                        "the points, no canopy above the "
                                                        "trees' minimum height"))
            continue
        text = (f"{r['trees']} trees, {_round(r['trees_per_ha'], 0):g}/ha, mean height "
                f"{_round(r['mean_height'], 1)} m, dominant height "
                f"{_round(r['dominant_height'], 1)} m, {r['area_ha']:.2f} ha")
        if "stocking_pct" in r and r["stocking_pct"] is None:
            text += f", {r['lattice']}"
        elif "stocking_pct" in r:
            text += (f", stocking {_round(r['stocking_pct'], 1)} % "
                     f"(95 % interval {_round(r['stocking_pct_low'], 1)}-"
                     f"{_round(r['stocking_pct_high'], 1)}; "
                     f"{r['missing_trees']} "
                     f"missing, {r['suppressed_trees']} suppressed, "
                     f"{r['uncertain_positions']} uncertain of "
                     f"{r['planting_positions']} positions, rows at {r['row_azimuth']:.1f}°"
                     f"{_square(r['spacing'])})")
        out[f"stand {r['stand_id']}"] = text
    return out


def _square(spacing) -> str:
    """The stand line's words for a square lattice (its rows could run either way)."""
    from ..plantation.stocking import is_square

    r, c = (float(v) for v in str(spacing).split("x"))
    return ", or across: a square lattice" if is_square(r, c) else ""


def _density(area, plan: AreaPlan, ready, runner) -> float:
    """Points per m² of the area: the plan's, else (a cell size was given) those of the one
    tile's surfaces over its data footprint, else measured on the plan's windows."""
    from .area import area_density, measurement_windows

    if np.isfinite(plan.density):
        return plan.density
    if ready is not None:
        return ready["density"]
    return area_density(area, measurement_windows(area.extent, area.count), runner)


def _trees_sinks(stack, input, output, area, p, plan, surface, out, csv, chm_out, png,
                 stands=None, stand_csv=None) -> dict:
    """The open outputs of a trees run (each a temporary file renamed when ``stack`` closes)."""
    sinks = {}
    gspec = GridSpec.from_bounds(*area.extent, plan.res, crs=area.crs)
    ids = None if stands is None else stands.ids
    if output is None:
        sinks["layers"] = TreeLayers(area.crs, p.method, out.nln, ids)
    else:
        from ..io.vector import start_from_existing

        tmp = stack.enter_context(atomic_output(output, out.overwrite, append=out.append))
        existing = start_from_existing(Path(output), tmp, out.append,
                                       owned=tree_layer_names(out.nln).values())
        sinks["layers"] = GpkgTreeLayers(tmp, area.crs, p.method, out.nln, existing=existing,
                                         metadata=_trees_meta(input, area, p, plan, surface),
                                         layer_options=out.layer_options, stand_ids=ids)
    if stand_csv:
        sinks["stand_csv"] = stack.enter_context(atomic_output(stand_csv, out.overwrite,
                                                               param="-stand_csv"))
    if csv:
        ctmp = stack.enter_context(atomic_output(csv, out.overwrite, param="-csv"))
        sinks["csv"] = TreesTable(ctmp, gspec, None if stands is None else stands.ids,
                                  out.table)
        stack.callback(sinks["csv"].close)
    if chm_out:
        mtmp = stack.enter_context(atomic_output(chm_out, out.overwrite, param="-chm_out"))
        sinks["chm"] = MosaicWriter(mtmp, gspec, creation_options=out.creation_options,
                                    description="canopy height (m)",
                                    tags=raster_tags("trees", area, {"res": plan.res}, input))
        stack.callback(sinks["chm"].close)
    if png:
        sinks["quicklook"] = QuickLook(gspec)
    return sinks


def _title(row: dict, source, title=None) -> str:
    from ..report.quicklook import quicklook_title

    return quicklook_title(row, source if not isinstance(source, (list, tuple)) else None,
                           title)


def _round(v, n):
    """Round a number for reports; NaN and None stay as they are."""
    try:
        return round(float(v), n) if np.isfinite(v) else v
    except (TypeError, ValueError):
        return v


def _trees_result(output, area, plan, summary, row, p, layers, surface) -> dict:
    out = {"output": None if output is None else str(output), "trees": int(row["trees"]),
           **_result(area, plan, summary),
           "chm": "input raster" if isinstance(area, RasterArea) else surface.chm,
           "smooth": row["smooth"], "tops": row["tops"],
           "crown_scale": None if plan.crown_scale is None else round(plan.crown_scale, 3),
           "mean_height": _round(row["mean_height"], 2),
           "mean_crown_diameter": _round(row["mean_crown_diameter"], 2),
           "small_crowns": int(row["small_crowns"]),
           "suppressed_trees": int(row["suppressed_trees"]),
           "uncertain_trees": int(row["uncertain_trees"]),
           "trees_per_ha": _round(row["trees_per_ha"], 1),
           **({"stands_trees_per_ha": _round(row["stands_trees_per_ha"], 1)}
              if "stands_trees_per_ha" in row else {}),
           "gap_trees": int(row["gap_trees"]),
           "planting_detected": row["planting_detected"] or None,
           "planting_tiles": int(row["planting_tiles"]),
           "tree_ids": summary.tree_ids}
    if p.spacing is not None:
        out.update({k: row[k] for k in ("lattice", "spacing", "row_azimuth",
                                         "planting_positions", "missing_trees",
                                         "uncertain_positions", "numbering")})
        for k in ("stocking_pct", "stocking_pct_low", "stocking_pct_high"):
            out[k] = _round(row[k], 2)
    if output is None:
        out["layers"] = layers.frames()
    return out


def area_surfaces(input, *, surface: SurfaceOptions | None = None,
                  read: ReadOptions | None = None, params: TreeParams | None = None,
                  progress=None) -> tuple:
    """The surfaces of a whole area as one tile, in memory (``compare``, the Python API):
    ``(surfaces, plan, area)``. The area is planned as every chain plans it (cell size, edge
    limit and, with ``params``, crown scale), so its CHM is the one ``chm`` and ``trees`` make
    of an area of one tile."""
    surface, read = surface or SurfaceOptions(), read or ReadOptions()
    prog = as_progress(progress)
    area = open_area(input, read)
    with TileRunner(1) as runner:
        plan, ready = plan_area(area, surface, TilingOptions(tile_size=float("inf")),
                                runner=runner, params=params, keep=True,
                                progress=SubProgress(prog, 0.02, 1.0))
        s = ready if ready is not None else box_surfaces(
            area, plan.tiles[0].box, plan.res, surface, stats=plan.stats,
            progress=SubProgress(prog, 0.1, 1.0))
    if s is None:
        raise InputError(f"{area.label()}: no points")
    return s, plan, area
