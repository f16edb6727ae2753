"""What each ``lidartrees`` command runs: its options, as the CLI and the QGIS provider pass
them (strings, numbers, None for "not given"), turned into one library call.

The command table (:mod:`.commands`) names these functions; they hold no algorithm code.
"""
from __future__ import annotations


def info(input, **kw):
    from ..catalog.info import info as describe
    from ..io.options import open_input

    src = open_input(input, **_read_kw(kw))
    return describe(src, progress=kw.get("progress"))


def _read_kw(kw):
    keys = ("a_srs", "t_srs", "delimiter", "decimal_comma", "columns", "skip_invalid")
    out = {k: kw[k] for k in keys if kw.get(k) is not None}
    if "allow_no_crs" in kw:  # commands whose outputs are georeferenced
        out["require_crs"] = not kw.get("allow_no_crs")
    return out


def _co(kw):
    from ..io.raster import parse_kv

    return parse_kv(kw.get("creation_options"), "-co") or None


def _classes(kw):
    return {"drop_class": kw.get("drop_class") if kw.get("drop_class") is not None else "7,18",
            "keep_class": kw.get("keep_class") or None}


def grid(input, output, **kw):
    from ..als import pipeline

    return pipeline.grid_file(input, output, res=kw.get("res") or "auto",
                              stat=kw.get("stat") or "max", fill=kw.get("fill") or "none",
                              **_classes(kw),
                              creation_options=_co(kw),
                              overwrite=bool(kw.get("overwrite")), progress=kw.get("progress"),
                              **_read_kw(kw))


def chm(input, output, **kw):
    from ..als import pipeline

    ts, tiled = _tiling(input, kw)
    if tiled:
        from ..als.tiled import chm_tiled

        return chm_tiled(input, output, tile_size=ts, **_tile_kw(kw), res=kw.get("res") or "auto",
                         dtm=kw.get("dtm") or "auto", chm=kw.get("chm") or "pitfree",
                         outliers=not kw.get("keep_outliers"), **_classes(kw),
                         fill=kw.get("fill") or "mean8", dtm_out=kw.get("dtm_out"),
                         dsm_out=kw.get("dsm_out"),
                         creation_options=_co(kw),
                         overwrite=bool(kw.get("overwrite")), a_srs=kw.get("a_srs"),
                         progress=kw.get("progress"),
                         read_kw={k: v for k, v in _read_kw(kw).items() if k != "a_srs"})

    return pipeline.chm_file(input, output, res=kw.get("res") or "auto",
                             dtm=kw.get("dtm") or "auto", chm=kw.get("chm") or "pitfree",
                             outliers=not kw.get("keep_outliers"), **_classes(kw),
                             fill=kw.get("fill") or "mean8", dsm_out=kw.get("dsm_out"),
                             dtm_out=kw.get("dtm_out"), creation_options=_co(kw),
                             overwrite=bool(kw.get("overwrite")), progress=kw.get("progress"),
                             **_read_kw(kw))


def _tree_params(kw):
    from ..als.trees import TreeParams

    names = ("method", "smooth", "min_height", "step", "tops", "mean_crown_area", "sd_crown_area",
             "max_crown_area", "min_crown_height", "connectivity", "spacing", "crown_scale",
             "window_factor", "treex_centred", "min_separation", "planting")
    conv = {"connectivity": int, "treex_centred": bool}
    text = ("method", "smooth", "tops", "spacing", "planting")
    vals = {}
    for n in names:
        v = kw.get(n)
        if v is None or (n in text and v == ""):
            continue
        try:
            vals[n] = conv.get(n, float)(v) if n not in text else v
        except ValueError:
            from ..errors import InputError

            raise InputError(f"-{n}: expected a number, got {v!r}") from None
    return TreeParams(**vals)


#: a single file with more points than this is processed in tiles by default
TILED_ABOVE = 20_000_000


def _tiling(input, kw):
    """``(tile_size or None, use tiles?)`` from -tile_size and the input."""
    from pathlib import Path

    from ..catalog.inputs import is_catalog_input
    from ..errors import InputError

    ts = kw.get("tile_size")
    if ts is not None and str(ts).strip().lower() == "auto":  # the default
        ts = None
    if ts is not None and str(ts).strip().lower() in ("none", "inf", "0"):
        return float("inf"), True
    if ts not in (None, ""):
        try:
            v = float(ts)
        except ValueError:
            raise InputError(f"-tile_size: expected metres or none, got {ts!r}") from None
        if not v > 0:
            raise InputError(f"-tile_size must be > 0 m, got {ts!r}")
        return v, True
    if is_catalog_input(input):
        return None, True
    p = Path(str(input))
    if p.suffix.lower() in (".las", ".laz") and p.exists():
        from ..io.points import las_point_count

        try:
            return None, las_point_count(p) > TILED_ABOVE
        except Exception:  # noqa: BLE001 - the reader reports a broken file properly later
            return None, False
    return None, False


def _tile_kw(kw):
    from ..errors import InputError

    out = {"buffer": None, "workers": None, "scheduler": kw.get("scheduler") or None}
    for k in ("buffer", "workers"):
        if kw.get(k) not in (None, ""):
            try:
                out[k] = float(kw[k]) if k == "buffer" else int(float(kw[k]))
            except ValueError:
                raise InputError(f"-{k}: expected a number, got {kw[k]!r}") from None
    if out["workers"] is not None and out["workers"] < 1:
        raise InputError(f"-workers must be >= 1, got {kw['workers']!r}")
    return out


def trees(input, output, **kw):
    from ..als import pipeline
    from ..io.raster import parse_kv

    ts, tiled = _tiling(input, kw)
    if tiled:
        from ..als.tiled import trees_tiled

        if kw.get("png") or kw.get("csv"):
            from ..errors import InputError

            raise InputError("-png and -csv are made for one tile; drop them for a tiled run "
                             "(or give -tile_size none)")
        r = trees_tiled(
            input, output, params=_tree_params(kw), tile_size=ts, **_tile_kw(kw),
            res=kw.get("res") or "auto", dtm=kw.get("dtm") or "auto",
            chm=kw.get("chm") or "pitfree", outliers=not kw.get("keep_outliers"), **_classes(kw),
            fill=kw.get("fill") or "mean8", nln=kw.get("nln") or "",
            layer_options=parse_kv(kw.get("layer_options"), "-lco"),
            overwrite=bool(kw.get("overwrite")), append=bool(kw.get("append")),
            chm_out=kw.get("chm_out"), a_srs=kw.get("a_srs"), progress=kw.get("progress"),
            read_kw={k: v for k, v in _read_kw(kw).items() if k != "a_srs"})
        return {k: v for k, v in r.items() if k not in ("tree_ids", "table")}

    r = pipeline.trees_file(
        input, output, res=kw.get("res") or "auto", params=_tree_params(kw),
        dtm=kw.get("dtm") or "auto", chm=kw.get("chm") or "pitfree",
        outliers=not kw.get("keep_outliers"), **_classes(kw),
        fill=kw.get("fill") or "mean8", nln=kw.get("nln") or "",
        layer_options=parse_kv(kw.get("layer_options"), "-lco"), overwrite=bool(kw.get("overwrite")),
        append=bool(kw.get("append")), png=kw.get("png"), csv=kw.get("csv"),
        chm_out=kw.get("chm_out"), progress=kw.get("progress"), **_read_kw(kw))
    return {k: v for k, v in r.items() if k not in ("result", "spec")}


def compare(input, output, **kw):
    from ..als import pipeline

    r = pipeline.compare_file(input, output, res=kw.get("res") or "auto",
                              dtm=kw.get("dtm") or "auto", chm=kw.get("chm") or "pitfree",
                              strict=bool(kw.get("strict")), **_classes(kw),
                              fill=kw.get("fill") or "mean8",
                              min_height=float(kw.get("min_height") or 2.0),
                              step=float(kw.get("step") or 0.1), overwrite=bool(kw.get("overwrite")),
                              progress=kw.get("progress"), **_read_kw(kw))
    return {"output": r["output"], "reprojection": r.get("reprojection"), "table": r["table"]}


def _kp_params(kw):
    from ..ground.filter import KrausPfeifer

    names = ("g", "w", "a", "b", "iterations", "cell", "levels", "tolerance", "refine", "slope",
             "tin_cell", "low", "w_growth")
    vals = {"gshift": bool(kw.get("gshift"))}
    for n in names:
        v = kw.get(n)
        if v is None or (n in ("g", "w") and isinstance(v, str) and ":" in v):
            continue
        try:
            f = float(v)
            if n in ("iterations", "levels", "refine"):
                if f != int(f):
                    raise ValueError
                f = int(f)
            vals[n] = f
        except ValueError:
            from ..errors import InputError

            raise InputError(f"-{n}: expected a number, got {v!r}") from None
    return KrausPfeifer(**vals)


def ground(input, output, **kw):
    from ..ground.chain import ground_file

    return ground_file(input, output, dtm_out=kw.get("dtm_out"), res=kw.get("res") or "auto",
                                params=_kp_params(kw), overwrite=bool(kw.get("overwrite")),
                                reclassify=bool(kw.get("reclassify")), creation_options=_co(kw),
                                progress=kw.get("progress"), **_read_kw(kw))


def dtm_quality(input, outdir, **kw):
    from ..ground.quality import dtm_quality_file

    return dtm_quality_file(
        input, outdir, g=kw.get("g") or "-4:1:0.5", w=kw.get("w") or "1:4:0.5",
        res=kw.get("res") or "auto", params=_kp_params(kw), seed=int(kw.get("seed") or 0),
        overwrite=bool(kw.get("overwrite")), progress=kw.get("progress"), **_read_kw(kw))


def stem(input, prefix, **kw):
    from ..tls.chain import stem_file
    from ..errors import InputError
    from ..tls.stem import DmaxParams

    vals = {}
    for n in ("section", "search", "hspacing", "vspacing", "start"):
        if kw.get(n) is not None:
            try:
                vals[n] = float(kw[n])
            except ValueError:
                raise InputError(f"-{n}: expected a number, got {kw[n]!r}") from None
    if kw.get("base") is not None:
        vals["base"] = str(kw["base"])
    return stem_file(input, prefix, params=DmaxParams(**vals),
                              overwrite=bool(kw.get("overwrite")), progress=kw.get("progress"),
                              **_read_kw(kw))


def profile(input, output, **kw):
    from ..tls.chain import profile_file

    return profile_file(input, output, bin=float(kw.get("bin") or 0.05),
                                 sigma=float(kw.get("sigma") or 0.3),
                                 overwrite=bool(kw.get("overwrite")), progress=kw.get("progress"),
                                 **_read_kw(kw))


def evaluate(detected, reference, **kw):
    from ..report.evaluate import evaluate_file
    from ..errors import InputError

    try:
        md = float(kw.get("max_dist") if kw.get("max_dist") is not None else 2.5)
        mz = float(kw.get("max_dz") if kw.get("max_dz") is not None else 5.0)
    except ValueError:
        raise InputError("-max_dist/-max_dz: expected numbers (m)") from None
    r = evaluate_file(detected, reference, kw.get("report"), layer=kw.get("layer") or None,
                      ref_layer=kw.get("ref_layer") or None, max_dist=md, max_dz=mz,
                      overwrite=bool(kw.get("overwrite")), progress=kw.get("progress"))
    return r


def demo(outdir=None, **kw):
    from ..demo import run_demo

    return run_demo(outdir or "lidartrees_demo", overwrite=bool(kw.get("overwrite")),
                    progress=kw.get("progress"))
