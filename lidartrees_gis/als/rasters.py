"""The raster chains: ``grid`` (one statistic per cell) and ``chm`` (CHM, DTM, DSM), for one
file or a whole flight alike (see :mod:`lidartrees_gis.als.chain`)."""
from __future__ import annotations

import contextlib

from ..catalog.catalog import Catalog, TilingOptions
from ..catalog.mosaic import MosaicWriter
from ..errors import InputError
from ..grid import STATS, GridSpec
from ..io.options import ReadOptions
from ..io.output import OutputOptions, atomic_output, check_outputs, claim_outputs
from ..io.provenance import raster_tags
from ..progress import SubProgress, as_progress
from .area import MIN_BUFFER, plan_area
from .chain import _result, check_failed, check_points, kept_tiles, run_tiles, runner_for
from .sinks import Tally, sidecar
from .surfaces import SurfaceOptions
from .tile import tile_grid, tile_surfaces

#: the surfaces ``chm`` writes: output parameter, band description
SURFACES = {"chm": ("OUTPUT", "canopy height (m)"), "dtm": ("-dtm_out", "terrain height (m)"),
            "dsm": ("-dsm_out", "surface height (m)")}


def _points(input, read: ReadOptions) -> Catalog:
    from ..catalog.raster import is_raster

    if is_raster(input):
        raise InputError(f"{input}: expected point files (LAS/LAZ, XYZ text), got a raster")
    return Catalog.open(input, read)


def _dtm_label(labels: set) -> str | None:
    """The DTM the tiles used, as one label (``auto (ground)``; several when ``auto`` chose
    differently from tile to tile)."""
    labels = sorted(v for v in labels if v)
    if len(labels) <= 1:
        return labels[0] if labels else None
    return "auto (" + ", ".join(v[6:-1] for v in labels) + ")"


def chm_run(input, output, *, surface: SurfaceOptions | None = None,
            read: ReadOptions | None = None, tiling: TilingOptions | None = None,
            out: OutputOptions | None = None, dsm_out=None, dtm_out=None, progress=None) -> dict:
    """Canopy height model GeoTIFF (and the DSM and DTM) of point files, tile by tile.

    Defaults: cell size ``auto`` (the area's density, :func:`lidartrees_gis.als.area.plan_area`),
    DTM ``auto`` (class-2 ground if any, else lowest:5), pit-free CHM (Khosravipour et al.
    2014), noise classes 7 and 18 dropped and isolated returns far above the canopy removed.
    """
    surface, read = surface or SurfaceOptions(), read or ReadOptions()
    tiling, out = tiling or TilingOptions(), out or OutputOptions()
    paths = {"chm": output, "dtm": dtm_out, "dsm": dsm_out}
    outputs = [(p, SURFACES[k][0]) for k, p in paths.items()]
    check_outputs(outputs, (), out.overwrite)
    prog = as_progress(progress)
    area = _points(input, read)
    check_outputs(outputs, area.files, out.overwrite)
    tally, dtm_labels = Tally(), set()
    with claim_outputs(outputs, out.overwrite), runner_for(area, tiling) as runner:
        prog.update(0.01, "measuring the area")
        plan, ready = plan_area(area, surface, tiling, runner=runner, buffer=MIN_BUFFER,
                                keep=True, progress=SubProgress(prog, 0.02, 0.45))
        gspec = GridSpec.from_bounds(*area.extent, plan.res, crs=area.crs)
        with kept_tiles(runner, output, tiling, plan, area, surface, tuple(
                k for k, v in paths.items() if v)), contextlib.ExitStack() as stack:
            mosaics = {}
            for key, path in paths.items():
                if path:
                    tmp = stack.enter_context(atomic_output(path, out.overwrite,
                                                            param=SURFACES[key][0]))
                    mosaics[key] = MosaicWriter(tmp, gspec, creation_options=out.creation_options,
                                                description=SURFACES[key][1])
                    stack.callback(mosaics[key].close)
            args = (area, plan, surface, tuple(mosaics))
            for r in run_tiles(runner, tile_surfaces, plan, args, ready,
                               SubProgress(prog, 0.45, 0.98)):
                for key, mos in mosaics.items():
                    mos.write(r[key], r["left"], r["top"])
                tally.add(r)
                dtm_labels.add(r["dtm_method"])
            check_points(area, tally, read)
            params = {"res": plan.res, "dtm": _dtm_label(dtm_labels), "chm": surface.chm,
                      "fill": surface.fill, "outliers": surface.outliers, **read.describe(),
                      "tiles": len(plan.tiles), "buffer": plan.buffer}
            for mos in mosaics.values():
                mos.set_tags(raster_tags("chm", area, params, input))
    for key, qml in (("chm", "chm.qml"), ("dtm", "dtm_hillshade.qml")):
        if key in mosaics:  # styled wherever the GeoTIFF is opened
            sidecar(paths[key], qml, out.overwrite, mosaics[key].max)
    prog.update(1.0, "done")
    return check_failed(runner, {"output": str(output), **_result(area, plan, tally),
                                 "shape": gspec.shape, "dtm": params["dtm"], "chm": surface.chm})


def grid_run(input, output, *, res="auto", stat: str = "max", fill: str = "none",
             read: ReadOptions | None = None, tiling: TilingOptions | None = None,
             out: OutputOptions | None = None, progress=None) -> dict:
    """One statistic of z per cell (``max``, ``min``, ``mean``, ``count``) into a GeoTIFF.

    Empty cells are nodata (0 for count) unless ``fill="mean8"``. ``res="auto"`` is seed 003's
    sqrt(1/n) of the area's point density. Points of the classes ``read.drop_class`` (noise, 7
    and 18, by default) are left out.
    """
    read, tiling, out = read or ReadOptions(), tiling or TilingOptions(), out or OutputOptions()
    if stat not in STATS:
        raise InputError(f"-stat: expected one of {', '.join(STATS)}, got {stat!r}")
    if stat == "count" and fill not in (None, "none"):
        raise InputError("-fill: gap filling does not apply to -stat count")
    surface = SurfaceOptions(res=res, fill=fill or "none")
    check_outputs([(output, "OUTPUT")], (), out.overwrite)
    prog = as_progress(progress)
    area = _points(input, read)
    check_outputs([(output, "OUTPUT")], area.files, out.overwrite)
    tally = Tally()
    buffer = MIN_BUFFER if surface.fill != "none" else 0.0  # filling looks beyond the tile
    with claim_outputs([(output, "OUTPUT")], out.overwrite), runner_for(area, tiling) as runner:
        prog.update(0.01, "measuring the area")
        plan, _ = plan_area(area, surface, tiling, runner=runner, rule="density", buffer=buffer,
                            progress=SubProgress(prog, 0.02, 0.3))
        gspec = GridSpec.from_bounds(*area.extent, plan.res, crs=area.crs)
        params = {"res": plan.res, "stat": stat, **({} if stat == "count" else {"fill": fill})}
        count = stat == "count"
        with kept_tiles(runner, output, tiling, plan, area, surface, stat), \
                atomic_output(output, out.overwrite) as tmp:
            mos = MosaicWriter(tmp, gspec, creation_options=out.creation_options,
                               tags=raster_tags("grid", area, params, input),
                               description="count" if count else f"z {stat}",
                               dtype="int32" if count else "float32",
                               nodata=None if count else "default")
            try:
                for r in run_tiles(runner, tile_grid, plan, (area, plan, stat, surface.fill),
                                   progress=SubProgress(prog, 0.3, 0.98)):
                    mos.write(r["grid"], r["left"], r["top"])
                    tally.add(r)
                check_points(area, tally, read)
            finally:
                mos.close()
    prog.update(1.0, "done")
    return check_failed(runner, {"output": str(output), **_result(area, plan, tally),
                                 "shape": gspec.shape})
