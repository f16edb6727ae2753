"""What each ``lidartrees`` command runs: its options, as the CLI and the QGIS provider pass
them (strings, numbers, None for "not given"), turned into the option dataclasses and one
library call. The command table (:mod:`.commands`) names these functions; they hold no
algorithm code.
"""
from __future__ import annotations

from ..errors import InputError


def _number(kw, name, kind=float):
    """``kw[name]`` as a number (None when not given); a clear error naming ``-name``."""
    v = kw.get(name)
    if v is None or v == "":
        return None
    try:
        f = float(v)
        if f != f or f in (float("inf"), float("-inf")):  # nan, inf: no option takes them
            raise ValueError
        if kind is int:
            if f != int(f):
                raise ValueError
            return int(f)
        return f
    except (TypeError, ValueError, OverflowError):
        raise InputError(f"-{name}: expected {'a whole number' if kind is int else 'a finite number'}"
                         f", got {v!r}") from None


def _read(kw, georeferenced=True):
    """:class:`~lidartrees_gis.io.options.ReadOptions` from the reading options."""
    from ..io.options import NOISE_CLASSES, ReadOptions

    keys = ("a_srs", "t_srs", "delimiter", "decimal_comma", "columns")
    vals = {k: kw[k] for k in keys if kw.get(k) is not None}
    vals["skip_invalid"] = bool(kw.get("skip_invalid"))
    if georeferenced and "allow_no_crs" in kw:  # commands whose outputs are georeferenced
        vals["require_crs"] = not kw.get("allow_no_crs")
    vals["drop_class"] = kw["drop_class"] if kw.get("drop_class") is not None else NOISE_CLASSES
    vals["keep_class"] = kw.get("keep_class") or None
    return ReadOptions(**vals)


def _surface(kw, fill="mean8"):
    from ..als.surfaces import SurfaceOptions

    return SurfaceOptions(res=kw.get("res") or "auto", dtm=kw.get("dtm") or "auto",
                          chm=kw.get("chm") or "pitfree", fill=kw.get("fill") or fill,
                          outliers=not kw.get("keep_outliers"))


def _tiling(kw):
    from ..catalog.catalog import TilingOptions

    return TilingOptions(tile_size=kw.get("tile_size"), buffer=_number(kw, "buffer"),
                         workers=_number(kw, "workers", int), scheduler=kw.get("scheduler"),
                         on_error=kw.get("on_error") or "stop", resume=bool(kw.get("resume")))


def _out(kw):
    from ..io.output import OutputOptions
    from ..io.raster import parse_kv
    from ..io.tables import TableOptions, split_table_options

    lco, table = split_table_options(parse_kv(kw.get("layer_options"), "-lco"))
    return OutputOptions(overwrite=bool(kw.get("overwrite")), append=bool(kw.get("append")),
                         nln=kw.get("nln") or "", layer_options=lco or None,
                         creation_options=parse_kv(kw.get("creation_options"), "-co") or None,
                         table=TableOptions.from_options(table))


def _tree_params(kw):
    from ..als.trees import TreeParams

    text = ("method", "smooth", "tops", "spacing", "planting")
    numbers = ("min_height", "step", "mean_crown_area", "sd_crown_area", "max_crown_area",
               "min_crown_height", "crown_scale", "window_factor", "min_separation")
    vals = {n: kw[n] for n in text if kw.get(n) not in (None, "")}
    vals.update({n: _number(kw, n) for n in numbers if kw.get(n) not in (None, "")})
    if kw.get("connectivity") not in (None, ""):
        vals["connectivity"] = _number(kw, "connectivity", int)
    for key in ("treex_centred", "treex_local"):
        if kw.get(key) is not None:
            vals[key] = bool(kw[key])
    return TreeParams(**vals)


def _kp_params(kw):
    from ..ground.filter import KrausPfeifer

    vals = {"gshift": bool(kw.get("gshift"))}
    for n in ("g", "w", "a", "b", "cell", "tolerance", "slope", "tin_cell", "low", "w_growth"):
        if kw.get(n) not in (None, "") and not (n in ("g", "w") and ":" in str(kw[n])):
            vals[n] = _number(kw, n)
    for n in ("iterations", "levels", "refine"):
        if kw.get(n) not in (None, ""):
            vals[n] = _number(kw, n, int)
    return KrausPfeifer(**vals)


def info(input, **kw):
    from ..catalog.info import describe_input

    return describe_input(input, _read(kw, georeferenced=False), progress=kw.get("progress"))


def grid(input, output, **kw):
    from ..als.rasters import grid_run

    return grid_run(input, output, res=kw.get("res") or "auto", stat=kw.get("stat") or "max",
                    fill=kw.get("fill") or "none", read=_read(kw), tiling=_tiling(kw),
                    out=_out(kw), progress=kw.get("progress"))


def chm(input, output, **kw):
    from ..als.rasters import chm_run

    return chm_run(input, output, surface=_surface(kw), read=_read(kw), tiling=_tiling(kw),
                   out=_out(kw), dsm_out=kw.get("dsm_out"), dtm_out=kw.get("dtm_out"),
                   progress=kw.get("progress"))


def trees(input, output, **kw):
    from ..als.chain import trees_run
    from ..catalog.runner import FailedTiles

    try:
        r = _trees_run(trees_run, input, output, kw)
    except FailedTiles as exc:  # written without some tiles: its result as a full run's
        exc.result = {k: v for k, v in (exc.result or {}).items()
                      if k not in ("tree_ids", "layers")}
        raise
    return {k: v for k, v in r.items() if k not in ("tree_ids", "layers")}


def _trees_run(trees_run, input, output, kw):
    return trees_run(input, output, params=_tree_params(kw), surface=_surface(kw),
                     read=_read(kw), tiling=_tiling(kw), out=_out(kw), png=kw.get("png"),
                     csv=kw.get("csv"), title=kw.get("title") or None,
                     chm_out=kw.get("chm_out"), stands=kw.get("stands") or None, stand_id=kw.get("stand_id") or None,
                     stand_csv=kw.get("stand_csv") or None, progress=kw.get("progress"))


def compare(input, output, **kw):
    from ..als.compare import compare_run

    r = compare_run(input, output, surface=_surface(kw), read=_read(kw),
                    strict=(kw.get("tops") or "strict") == "strict",
                    min_height=_number(kw, "min_height") or 2.0, step=_number(kw, "step") or 0.1,
                    overwrite=bool(kw.get("overwrite")), progress=kw.get("progress"))
    return {"output": r["output"], "reprojection": r.get("reprojection"), "table": r["table"]}


def ground(input, output, **kw):
    from ..ground.tiled import ground_run

    return ground_run(input, output, dtm_out=kw.get("dtm_out"), res=kw.get("res") or "auto",
                      params=_kp_params(kw), read=_read(kw), out=_out(kw),
                      reclassify=bool(kw.get("reclassify")), tiling=_tiling(kw),
                      progress=kw.get("progress"))


def dtm_quality(input, outdir, **kw):
    from ..ground.quality import dtm_quality_file

    return dtm_quality_file(input, outdir, g=kw.get("g") or "-4:1:0.5",
                            w=kw.get("w") or "1:4:0.5", res=kw.get("res") or "auto",
                            params=_kp_params({"refine": 0, **{k: v for k, v in kw.items()
                                                                if v is not None}}),
                            seed=_number(kw, "seed", int) or 0,
                            reference=kw.get("reference_dtm") or "auto",
                            read=_read(kw), overwrite=bool(kw.get("overwrite")),
                            progress=kw.get("progress"))


def stem(input, prefix, **kw):
    from ..tls.chain import stem_file
    from ..tls.stem import DmaxParams

    vals = {n: _number(kw, n) for n in ("section", "search", "hspacing", "vspacing", "start")
            if kw.get(n) not in (None, "")}
    if kw.get("base") is not None:
        vals["base"] = str(kw["base"])
    return stem_file(input, prefix, params=DmaxParams(**vals), read=_read(kw),
                     overwrite=bool(kw.get("overwrite")), progress=kw.get("progress"))


def profile(input, output, **kw):
    from ..tls.chain import profile_file

    return profile_file(input, output, bin=_number(kw, "bin") or 0.05,
                        sigma=_number(kw, "sigma") or 0.3, rule=kw.get("rule") or "spread",
                        read=_read(kw),
                        overwrite=bool(kw.get("overwrite")), progress=kw.get("progress"))


def evaluate(detected, reference, **kw):
    from ..report.evaluate import evaluate_file

    md, mz = _number(kw, "max_dist"), _number(kw, "max_dz")
    return evaluate_file(detected, reference, kw.get("report"), layer=kw.get("layer") or None,
                         ref_layer=kw.get("ref_layer") or None,
                         max_dist=2.5 if md is None else md, max_dz=5.0 if mz is None else mz,
                         area=kw.get("area") or None, overwrite=bool(kw.get("overwrite")),
                         table=_out(kw).table, progress=kw.get("progress"))


def demo(outdir=None, **kw):
    from ..demo import run_demo

    return run_demo(outdir or "lidartrees_demo", overwrite=bool(kw.get("overwrite")),
                    progress=kw.get("progress"))


def _metric_options(kw):
    from ..inventory.tiles import MetricOptions

    mh = kw.get("min_height")
    mh = 2.0 if mh in (None, "") else None if str(mh).strip().lower() == "none" else \
        _number({"min_height": str(mh).replace(",", ".")}, "min_height")
    return MetricOptions(min_height=mh, returns=kw.get("returns") or "all")


def _metric_surface(kw):
    from ..als.surfaces import SurfaceOptions

    return SurfaceOptions(dtm=kw.get("dtm") or "auto", chm="max", fill="none", outliers=False)


def metrics(input, output, **kw):
    from ..inventory.chain import metrics_run

    res = _number(kw, "res")
    r = metrics_run(input, output, res=20.0 if res is None else res, plots=kw.get("plots"),
                    plot_id=kw.get("plot_id"), plot_radius=_number(kw, "plot_radius"),
                    stands=kw.get("stands"), stand_id=kw.get("stand_id"),
                    options=_metric_options(kw), surface=_metric_surface(kw), read=_read(kw),
                    tiling=_tiling(kw), out=_out(kw), progress=kw.get("progress"))
    return {k: v for k, v in r.items() if k not in ("grid", "layers")}


def volume(input, plots, output, **kw):
    from ..inventory.field import Equation
    from ..inventory.volume import VolumeOptions, volume_run

    eq = kw.get("volume_equation")
    n = _number(kw, "resamples", int)
    opts = VolumeOptions(approach=kw.get("approach") or "aba",
                         equation=Equation.parse(eq) if eq not in (None, "") else None,
                         res=kw.get("res") or "auto", resamples=400 if n is None else n,
                         estimator=kw.get("estimator") or "eblup")
    r = volume_run(input, plots, output, stands=kw.get("stands"),
                   trees_table=kw.get("trees_table") or None, plot_id=kw.get("plot_id"),
                   plot_radius=_number(kw, "plot_radius"), stand_id=kw.get("stand_id"),
                   stand_csv=kw.get("stand_csv") or None,
                   volume_field=kw.get("volume_field") or None,
                   options=opts, metric=_metric_options(kw), surface=_metric_surface(kw),
                   read=_read(kw), tiling=_tiling(kw), out=_out(kw), progress=kw.get("progress"))
    rep = r["report"]
    out = {k: v for k, v in r.items() if k not in ("layers", "volume_grid", "report")}
    for key in ("volume_model", "basal_area_model"):
        if key in rep:
            m = rep[key]
            out[key] = f"{m['equation']} (R² {m['r2']:.3f}, RMSE {m['rmse_pct']:.1f} %, LOO " \
                       f"RMSE {m['loo_rmse_pct']:.1f} %, {m['procedure_loo_rmse_pct']:.1f} % " \
                       "with the choice redone)"
    if "total_m3" in rep:
        from ..inventory.outputs import total_line

        out["total"] = total_line(rep)
    from ..inventory.outputs import stand_lines

    out.update(stand_lines(r["layers"]["stands"], opts.approach))
    return out
