"""The ``volume`` command: wood volume per stand from LiDAR and field plots (docs/VOLUME.md).

1. the plots' measured figures: from the tree table (:mod:`.field`: HT completed by the
   hypsometric relation, volumes by Schumacher-Hall), or from the plots layer's own
   ``volume_m3_ha`` field;
2. the height metrics of every plot and of every cell of the plots' size over the area, by the
   same function (:mod:`.tiles`);
3. area-based approach: the model chosen by leave-one-out RMSE, applied to the cells, averaged
   per stand, with bootstrap intervals (:mod:`.models`);
4. tree approach: the detected trees (the ``trees`` chain), each tree's DAP from its height
   (``ln DAP = a + b ln H`` fitted on the plots' trees) and volume from the equation, summed per
   stand and scaled by the plots' ratio of field volume to detected volume;
5. outputs (:mod:`.outputs`): plots, stands and tree layers, the volume raster, the report.
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

from ..catalog.catalog import TilingOptions
from ..bounds import check_fields
from ..errors import DataWarning, InputError, listing
from ..io.names import normalise
from ..io.options import ReadOptions
from ..io.output import OutputOptions, check_outputs, claim_outputs
from ..progress import SubProgress, as_progress
from .chain import open_points
from .field import Equation, complete_trees, plot_figures, read_trees, table_label
from .cells import CellShares, cell_shares
from .models import BOOTSTRAP, aba_stands, check_plots, fit_dap_height, ratio_stands, \
    select_model
from .plots import Zones, check_inside, load_plots, warn_overlaps
from .tiles import MetricOptions, area_metrics

APPROACHES = ("aba", "trees", "both")
#: below this leave-one-out R² the volume model is said to predict its plots poorly
MIN_LOO_R2 = 0.5
ESTIMATORS = ("eblup", "model")
#: a metric cell less covered by the returns (its share of squares holding one,
#: :func:`~.tiles.cover_split`) is not predicted: a flight's edge or a void
MIN_CELL_COVER = 0.5
#: a plot less covered than this is refused (its metrics are those of a part of it)
MIN_PLOT_COVER = 0.8
#: plot layer fields taken as the plot's measured volume (m³/ha) when there is no tree table
PLOT_VOLUME_FIELDS = ("volumem3ha", "volumeha", "volha", "vtccha", "volume", "vol")


@dataclass(frozen=True)
class VolumeOptions:
    """How volume is estimated.

    Attributes
    ----------
    approach : {"aba", "trees", "both"}
    equation : Equation, optional
        Schumacher-Hall coefficients (None: fitted on the trees carrying a volume).
    res : float or "auto"
        Cell size of the wall-to-wall metrics (auto: the side of a square of the plots' mean
        area, 20 m for 400 m² plots).
    resamples : int
        Bootstrap resamples of the plots for the intervals.
    seed : int
    estimator : {"eblup", "model"}
        A stand's figure: the model's, corrected by the stand's own plots as far as they can
        be trusted (eblup, :func:`~.models.stand_effects`), or the model's alone.
    """

    approach: str = "aba"
    equation: Equation | None = None
    res: object = "auto"
    resamples: int = BOOTSTRAP
    seed: int = 0
    estimator: str = "eblup"

    def __post_init__(self):
        check_fields(self, {"res": "m"}, skip=("seed", "estimator"))
        if self.approach not in APPROACHES:
            raise InputError(f"-approach: expected aba, trees or both, got {self.approach!r}")
        if self.estimator not in ESTIMATORS:
            raise InputError(f"-estimator: expected eblup or model, got {self.estimator!r}")
        if not (isinstance(self.res, str) and self.res == "auto"):
            try:
                ok = float(self.res) > 0
            except (TypeError, ValueError):
                ok = False
            if not ok:
                raise InputError(f"-tr: expected auto or a cell size > 0, got {self.res!r}")


def side_outputs(output) -> dict:
    """The files written beside ``OUT.gpkg``: the volume raster and the report."""
    from pathlib import Path

    p = Path(output)
    stem = p.with_suffix("")
    return {"raster": Path(f"{stem}_volume.tif"), "json": Path(f"{stem}_report.json"),
            "png": Path(f"{stem}_report.png")}


def _plot_measurements(plots, trees_table, equation, volume_field=None) -> dict:
    """Each plot's measured figures and the completed tree table (None without one)."""
    if volume_field is not None and trees_table is not None:
        raise InputError("-volume_field: the plots' volume comes from -trees_table; give one "
                         "of the two")
    if trees_table is None:
        cols = {normalise(c): c for c in plots.attrs.columns}
        if volume_field is not None:
            col = cols.get(normalise(volume_field))
            if col is None:
                fields = ", ".join(map(str, plots.attrs.columns)) or "none"
                raise InputError(f"-volume_field: {volume_field!r} is not a field of PLOTS "
                                 f"{plots.source} (its fields: {fields})")
        else:
            col = next((cols[f] for f in PLOT_VOLUME_FIELDS if f in cols), None)
        if col is None:
            fields = ", ".join(map(str, plots.attrs.columns)) or "none"
            raise InputError(f"PLOTS: {plots.source}: no tree table (-trees_table) and no plot "
                             "volume field (volume_m3_ha, vol_ha, vtcc_ha, volume or vol; its "
                             f"fields: {fields}); give one of them, or -volume_field")
        import pandas as pd

        v = pd.to_numeric(plots.attrs[col].astype(str).str.replace(",", "."), errors="coerce")
        if v.isna().any():
            bad = plots.ids[int(np.flatnonzero(v.isna().to_numpy())[0])]
            raise InputError(f"PLOTS: {plots.source}: plot {bad} has no {col}")
        return {"figures": {"volume_m3_ha": v.to_numpy(float)}, "trees": None,
                "volume_field": str(col)}
    trees = complete_trees(read_trees(trees_table), equation)
    figs = plot_figures(trees, plots.ids, plots.area_m2)
    return {"figures": figs, "trees": trees}


def _cell_res(options: VolumeOptions, plots) -> float:
    if isinstance(options.res, str):
        return max(0.5, round(2 * math.sqrt(float(np.mean(plots.area_m2)))) / 2)  # 0.5 m steps
    return float(options.res)


def stand_cells(area, res: float, stand_geoms) -> tuple:
    """``(grid, CellShares, pieces as Zones, unit_cell)``: the metric cells
    :func:`~.tiles.area_metrics` makes over ``area`` at ``res``, how they and the pieces the
    stands' borders cut lie in the stands, and each unit's cell (cells, then pieces)."""
    from ..grid import GridSpec

    spec = GridSpec.from_bounds(*area.extent, res, crs=area.crs, closed_top=True)
    shares, pieces, piece_cell = cell_shares(spec, stand_geoms)
    return (spec, shares, Zones.of_polygons(pieces),
            np.r_[np.arange(spec.width * spec.height), piece_cell])


def unit_metrics(r, pieces) -> tuple:
    """``(cells, units, cells left out)`` from an :func:`~.tiles.area_metrics` result whose
    last zone set is ``pieces`` (:func:`stand_cells`): cells and pieces less than
    :data:`MIN_CELL_COVER` covered by the returns are not predicted."""
    from .metrics import METRICS

    spec, grid = r["cells"]
    covered = (r["coverage"] >= MIN_CELL_COVER).ravel()
    pc = cover_shares(*r["occupied"], pieces.geoms) >= MIN_CELL_COVER if len(pieces) else \
        np.zeros(0, bool)
    pm = r["zones"][-1]
    cells = {k: np.where(covered, grid[i].ravel().astype(np.float64), np.nan)
             for i, k in enumerate(METRICS)}
    units = {k: np.concatenate([cells[k], np.where(pc, np.asarray(pm[k], float), np.nan)])
             for k in METRICS}
    has = np.isfinite(np.r_[grid[0].ravel(), pm["n"]])
    return cells, units, ~np.r_[covered, pc] & has


def cover_shares(sub, occupied, geoms) -> np.ndarray:
    """Each polygon's share of its coverage squares (those whose centre it holds; the one
    under its representative point when it holds none) that hold a return: 1 where the
    points cover it, about 0.4 where a flight's edge crosses it at 40 %."""
    import shapely
    from rasterio.features import rasterize
    from rasterio.windows import Window, transform as wtransform

    out = np.full(len(geoms), np.nan)
    for k, g in enumerate(geoms):
        x0, y0, x1, y1 = shapely.bounds(g)
        r0, c0 = (int(v) - 1 for v in sub.cell_index(x0, y1))  # and a square around
        r1, c1 = (int(v) + 1 for v in sub.cell_index(x1, y0))
        # the squares beyond the grid (beyond the points' extent) hold no return
        occ = np.zeros((r1 - r0 + 1, c1 - c0 + 1), bool)
        a0, a1 = max(r0, 0), min(r1, sub.height - 1)
        b0, b1 = max(c0, 0), min(c1, sub.width - 1)
        if a1 >= a0 and b1 >= b0:
            occ[a0 - r0:a1 - r0 + 1, b0 - c0:b1 - c0 + 1] = occupied[a0:a1 + 1, b0:b1 + 1]
        win = Window(c0, r0, c1 - c0 + 1, r1 - r0 + 1)
        inside = rasterize([(g, 1)], out_shape=occ.shape, fill=0,
                           transform=wtransform(win, sub.transform), dtype=np.uint8) > 0
        # a polygon smaller than a square: the square under its representative point
        out[k] = float(occ[inside].mean()) if inside.any() else \
            float(occ[tuple(int(v) - o for v, o in zip(sub.cell_index(
                *g.representative_point().coords[0]), (r0, c0)))])
    return out


def _check_plot_cover(pl, occupied) -> None:
    """Refuse plots the returns cover less than :data:`MIN_PLOT_COVER` (a flight's edge or a
    gap between flight lines crosses them: their metrics are those of a part)."""
    share = cover_shares(*occupied, pl.geoms)
    thin = np.flatnonzero(~(share >= MIN_PLOT_COVER))
    if thin.size:
        names = [f"{pl.ids[i]} ({100 * share[i]:.0f} %)" for i in thin]
        raise InputError(f"PLOTS: {pl.source}: {thin.size} plot(s) less than "
                         f"{100 * MIN_PLOT_COVER:.0f} % covered by the points: "
                         f"{listing(names, 8)}; at the flight's edge? drop them")


def _tree_approach(input, plots, stands_src, stand_id, stands, trees, equation, read, tiling,
                   surface, progress, flown=None) -> dict:
    """Detected trees' DAP and volume, their sums per plot and stand, the ratio estimate.
    ``flown``: each stand's share the points cover (its trees' volume per ha is that of its
    flown part, as the area-based figure is)."""
    from ..als.chain import trees_run
    from ..als.surfaces import SurfaceOptions
    from .field import fit_schumacher

    with warnings.catch_warnings():  # the run's stands cover is said once, by the caller
        warnings.filterwarnings("ignore", message=r"-stands: \d+ of \d+ stand\(s\) are less "
                                "than", category=DataWarning)
        r = trees_run(input, None, read=read, tiling=tiling, stands=stands_src,
                      stand_id=stand_id, surface=SurfaceOptions(dtm=surface.dtm),
                      progress=progress)
    tops = r["layers"]["tree_tops"]
    h = tops["height"].to_numpy(float)
    measured = ~trees["ht_estimated"]
    use = measured if measured.sum() >= 5 else np.ones(measured.size, bool)
    a, b, s2, n_fit = fit_dap_height(trees["dap"][use], trees["ht"][use])
    eq = trees["equation"] or equation or fit_schumacher(trees["dap"], trees["ht"],
                                                         trees["volume"])
    dap = np.exp(a + b * np.log(np.maximum(h, 1.3)) + s2 / 2)
    vol = eq(dap, h)
    tx, ty = tops.geometry.x.to_numpy(), tops.geometry.y.to_numpy()
    plot_det = plots.zones.counts(tx, ty, vol) / (plots.area_m2 / 1e4)
    plot_count = plots.zones.counts(tx, ty) / (plots.area_m2 / 1e4)
    sid = Zones.of_polygons(stands.geoms).members(tx, ty)
    sok = sid >= 0
    share = np.ones(len(stands)) if flown is None else np.asarray(flown, float)
    with np.errstate(invalid="ignore", divide="ignore"):
        stand_det = np.bincount(sid[sok], weights=vol[sok], minlength=len(stands)) / \
            (stands.area_ha * np.where(share > 0, share, np.nan))
    return {"tops": tops.assign(dap_cm=dap, volume_m3=vol), "detected_m3_ha": plot_det,
            "detected_trees_ha": plot_count, "stand_detected_m3_ha": stand_det,
            "dap_height": {"form": "ln(DAP) = a + b ln(H)", "a": a, "b": b, "s2": s2,
                           "trees": n_fit},
            "equation": eq}


def _aba(pm, figures, cm, cell_stand, n_stands, plot_stand, options) -> dict:
    """The area-based models (volume, and basal area when the trees give it) and their stand
    estimates: ``{"volume": (model, selection table, estimates), "basal_area": ...}``."""
    out = {}
    for key, target in (("volume", "volume_m3_ha"), ("basal_area", "basal_area_m2_ha")):
        if target not in figures:
            continue
        y = figures[target]
        model, table = select_model(pm, y, target)
        noise = figures.get("sampling_var_m3_ha") if key == "volume" else None
        est = aba_stands(model, pm, y, cm, cell_stand, n_stands, plot_stand, plot_noise=noise,
                         resamples=options.resamples, seed=options.seed,
                         stand_effect=options.estimator == "eblup")
        if key == "volume":
            if est["resamples_chose"] < options.resamples / 2:
                warnings.warn(DataWarning(
                    f"PLOTS: {est['resamples_chose']} of {options.resamples} resamples of the "
                    f"{y.size} plots held enough distinct plots to choose the model again: the "
                    "intervals rest on few refits (or on the chosen model's, which leave out "
                    "the uncertainty of its choice); more plots make them sound"),
                    stacklevel=2)
            loo_r2 = model.stats.get("loo_r2", np.nan)
            if not loo_r2 >= MIN_LOO_R2:
                warnings.warn(DataWarning(
                    f"PLOTS: the volume model ({model.equation()}) predicts the plots it was "
                    f"not fitted on poorly (leave-one-out R² {loo_r2:.2f}): the stands' "
                    "figures lean on the plots' mean; more plots, or plots over the stands' "
                    "range of heights, make it steadier"), stacklevel=2)
        out[key] = (model, table, est)
    return out


def _warn_density(table_ha, detected_ha, plots) -> None:
    """Warn when the plots' trees per ha by the table are under half or over twice the trees
    detected in them (median over the plots): the plots' area (``-plot_radius``) is wrong, as
    a radius of 5.64 m given for 400 m² plots makes every figure four times too large."""
    if table_ha is None:
        return
    t, d = np.asarray(table_ha, float), np.asarray(detected_ha, float)
    ok = np.isfinite(t) & np.isfinite(d) & (d > 0) & (t > 0)
    if ok.sum() < 3:
        return
    ratio = float(np.median(t[ok] / d[ok]))
    if not 0.5 <= ratio <= 2.0:
        warnings.warn(DataWarning(
            f"PLOTS: the plots' trees per ha by the table are {ratio:.1f} times the trees "
            f"detected in them (median of {int(ok.sum())} plots; {np.mean(plots.area_m2):.0f} "
            "m² a plot): check -plot_radius or the plots' polygons"), stacklevel=3)


#: trees per ha above which plots are too small for what they hold: 1.8 times the densest
#: common planting design (3 x 1.5 m, 2222 trees/ha; ../shared/docs/PLANTATIONS.md)
MAX_TREES_HA = 4000.0


def _warn_crowded(table_ha, plots) -> None:
    """Warn when the plots' trees per ha by the table (median) exceed :data:`MAX_TREES_HA`:
    the plots' area is smaller than their trees' (the 100 m² radius, 5.64 m, given for
    400 m² plots makes every figure four times too large); the area-based approach alone has
    no detected trees to compare them with (:func:`_warn_density`)."""
    t = np.asarray(table_ha if table_ha is not None else [], float)
    t = t[np.isfinite(t) & (t > 0)]
    if t.size >= 3 and float(np.median(t)) > MAX_TREES_HA:
        warnings.warn(DataWarning(
            f"PLOTS: the plots' trees make {float(np.median(t)):.0f} trees/ha (median of "
            f"{t.size} plots of {np.mean(plots.area_m2):.0f} m²), more than any planting "
            "design holds: check -plot_radius or the plots' polygons"), stacklevel=3)


def _warn_stands(st, share, cm, cell_stand, pm, res_aba) -> None:
    """Warn (the run goes on) of stands the points do not cover (``share``, from
    :func:`cover_shares`: their m³/ha is their flown part's) and of stands whose metrics lie
    beyond the plots' (the model extrapolates)."""
    from ..plantation.stands import MIN_DATA_COVER_PCT

    share = 100.0 * np.asarray(share, float)
    thin = [f"{st.ids[k]} ({share[k]:.0f} %)" for k in np.flatnonzero(
        ~(share >= MIN_DATA_COVER_PCT))]
    if thin:
        warnings.warn(DataWarning(
            f"STANDS: {len(thin)} stands less than {MIN_DATA_COVER_PCT:g} % covered by the "
            f"points: {listing(thin, 8)}; a stand's m³/ha is its flown part's (none without "
            "one) and its m³ that figure times its whole area"), stacklevel=3)
    if "volume" not in res_aba:
        return
    model = res_aba["volume"][0]
    out = []
    for p in model.predictors:
        v = np.asarray(pm[p], float)
        lo, hi = float(np.nanmin(v)), float(np.nanmax(v))
        pad = 0.1 * (hi - lo)
        mean, n = CellShares.of(cell_stand).means(cm[p], len(st.ids))
        for k in np.flatnonzero((n > 0) & ((mean < lo - pad) | (mean > hi + pad))):
            out.append(f"{st.ids[k]} ({p} {mean[k]:.3g}; plots {lo:.3g}-{hi:.3g})")
    if out:
        warnings.warn(DataWarning(
            f"PLOTS: {len(out)} stand(s) beyond the plots' range of the model's metrics: "
            f"{listing(out, 6)}; their figures extrapolate the model (a plot there would "
            "tell)"), stacklevel=3)


def volume_run(input, plots, output, *, stands, trees_table=None, plot_id=None,
               plot_radius=None, stand_id=None, stand_csv=None, volume_field=None,
               options: VolumeOptions | None = None,
               metric: MetricOptions | None = None, surface=None,
               read: ReadOptions | None = None, tiling: TilingOptions | None = None,
               out: OutputOptions | None = None, progress=None) -> dict:
    """Wood volume per stand (see the module doc). ``output`` a ``.gpkg`` (layers ``plots``,
    ``stands``, and ``tree_tops`` with the tree approach) or None (kept in memory); the
    volume raster and the report (JSON, PNG) are written beside it
    (:func:`side_outputs`)."""
    from ..als.surfaces import SurfaceOptions

    options, metric = options or VolumeOptions(), metric or MetricOptions()
    read, out = read or ReadOptions(), out or OutputOptions()
    surface = surface or SurfaceOptions(chm="max", fill="none", outliers=False)
    prog = as_progress(progress)
    if stands is None:
        raise InputError("-stands: the volume command needs the stand polygons")
    if options.approach != "aba" and trees_table is None:
        raise InputError(f"-approach {options.approach}: the tree approach needs the plots' "
                         "trees (-trees_table)")
    side = side_outputs(output) if output is not None else {}
    if output is not None:
        from pathlib import Path

        if Path(output).suffix.lower() != ".gpkg":
            raise InputError(f"OUTPUT: {output}: expected a .gpkg file name")
        check_outputs([(output, "OUTPUT"), *((p, k) for k, p in side.items()),
                       (stand_csv, "-stand_csv")],
                      (input, plots, stands, None if trees_table is None
                       else table_label(trees_table)), out.overwrite)
    elif stand_csv is not None:
        raise InputError("-stand_csv: needs the output GeoPackage")
    claims = [(output, "OUTPUT"), *((p, k) for k, p in side.items()),
              (stand_csv, "-stand_csv")] if output is not None else []
    # held from the start: a second run into the same outputs is refused at once, not after
    # its hours of work (and the first run's files are never half replaced)
    with claim_outputs(claims, out.overwrite):
        return _estimate(input, plots, output, stands, trees_table, plot_id, plot_radius,
                         stand_id, stand_csv, options, metric, surface, read, tiling, out, prog,
                         side, volume_field)


def _estimate(input, plots, output, stands, trees_table, plot_id, plot_radius, stand_id,
              stand_csv, options, metric, surface, read, tiling, out, prog, side,
              volume_field=None) -> dict:
    """:func:`volume_run` once its outputs are checked and claimed."""
    from ..plantation.stands import check_overlap, load_stands
    from . import outputs as outs

    area = open_points(input, read)
    pl = load_plots(plots, area.crs, plot_id=plot_id, plot_radius=plot_radius)
    check_inside(pl, area.extent, area.label())
    warn_overlaps(pl)
    st = load_stands(stands, area.crs, stand_id)
    check_overlap(st, area.extent, area.label())
    meas = _plot_measurements(pl, trees_table, options.equation, volume_field)
    y = meas["figures"]["volume_m3_ha"]
    check_plots(len(pl), "a volume model" if options.approach != "trees" else
                "the tree approach")
    extra = meas["figures"].get("unmatched_plots")
    label = None if trees_table is None else table_label(trees_table)
    if extra:
        warnings.warn(DataWarning(
            f"-trees_table: {label}: the trees of {len(extra)} plot(s) not in PLOTS "
            f"({listing(extra, 8)}) enter the height, DAP and volume relations only, no "
            "plot's figures"), stacklevel=2)
    if meas["trees"] is not None and meas["trees"].get("rows_without_dap"):
        warnings.warn(DataWarning(
            f"-trees_table: {label}: {meas['trees']['rows_without_dap']} rows without a "
            "DAP (dead or missing trees) left out of the plots' figures"), stacklevel=2)
    if options.approach == "aba":  # the tree approach compares them with the trees it finds
        _warn_crowded(meas["figures"].get("trees_ha"), pl)
    res = _cell_res(options, pl)
    spec0, cell_stand, pieces, unit_cell = stand_cells(area, res, st.geoms)
    prog.update(0.02, "metrics")
    r = area_metrics(area, cells_res=res, zones=[pl.zones, pieces], options=metric,
                     surface=surface, tiling=tiling, progress=SubProgress(prog, 0.02, 0.5))
    pm = r["zones"][0]
    empty = [pl.ids[i] for i in np.flatnonzero(pm["n"] == 0)]
    if empty:
        raise InputError(f"PLOTS: {len(empty)} plots hold no return above -min_height: "
                         f"{listing(empty, 8)}; outside the flight, or in a clearing?")
    _check_plot_cover(pl, r["occupied"])
    spec, grid = r["cells"]
    assert spec == spec0, (spec, spec0)
    stand_zones = Zones.of_polygons(st.geoms)
    cm, um, left_out = unit_metrics(r, pieces)
    flown = cover_shares(*r["occupied"], st.geoms)
    # the cells in a stand (or cut by its border) with returns but not predicted
    out_units = cell_stand.cell[left_out[cell_stand.cell]]
    r = {**r, "stand_cover": flown,
         "cells_left_out": int(np.unique(unit_cell[out_units]).size)}
    cx = np.array([g.representative_point().x for g in pl.geoms])
    cy = np.array([g.representative_point().y for g in pl.geoms])
    plot_stand = stand_zones.members(cx, cy)
    res_aba = {}
    if options.approach in ("aba", "both"):
        prog.update(0.55, "area-based model")
        res_aba = _aba(pm, meas["figures"], um, cell_stand, len(st), plot_stand, options)
    res_trees = None
    if options.approach in ("trees", "both"):
        prog.update(0.6, "trees")
        res_trees = _tree_approach(input, pl, stands, stand_id, st, meas["trees"],
                                   options.equation, read, tiling, surface,
                                   SubProgress(prog, 0.6, 0.9), flown)
        res_trees["stands"] = ratio_stands(y, res_trees["detected_m3_ha"],
                                           res_trees["stand_detected_m3_ha"], plot_stand,
                                           plot_noise=meas["figures"].get("sampling_var_m3_ha"),
                                           resamples=options.resamples, seed=options.seed,
                                           stand_effect=options.estimator == "eblup")
        _warn_density(meas["figures"].get("trees_ha"), res_trees["detected_trees_ha"], pl)
    _warn_stands(st, flown, um, cell_stand, pm, res_aba)
    prog.update(0.92, "writing")
    layers, report, vol_grid = outs.build(area, pl, st, meas, pm, plot_stand, res_aba, res_trees,
                                          spec, cm, options, metric, r)
    from datetime import datetime, timezone

    from .._version import __version__

    # what a technical report cites: the files, the tool and when
    report["inputs"] = {"points": str(input), "plots": pl.source, "stands": st.source,
                        "trees_table": None if trees_table is None else table_label(trees_table),
                        "estimator": options.estimator}
    report["tool"] = f"lidartrees_gis {__version__}"
    report["created"] = datetime.now(timezone.utc).isoformat(timespec="seconds")
    result = {"output": None if output is None else str(output), "plots": len(pl),
              "stands": len(st), "cell_res": spec.res, "report": report, "layers": layers,
              "volume_grid": (spec, vol_grid)}
    if output is not None:
        written = outs.write(output, side, layers, report, spec, vol_grid, res_aba, out, input,
                             area, stand_csv)
        result.update({k: str(v) for k, v in written.items()})
    prog.update(1.0, "done")
    return result
