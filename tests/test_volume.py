"""The volume command on a generated farm with known stems (lidartrees_gis.synthetic.make_farm):
CLI and Python, the outputs' fields, stand volumes near the truth, and one line per bad
input with nothing written."""
import json
import re

import numpy as np
import pytest

from lidartrees_gis.cli import main

EQ = "0.000049,1.85,1.05"  # the generator's Schumacher-Hall


def _write_farm(d, density=4.0, n_plots=9, seed=0):
    from lidartrees_gis.synthetic import write_volume_example

    return write_volume_example(d, density=density, n_plots=n_plots, seed=seed)


@pytest.fixture(scope="module")
def farm(tmp_path_factory):
    d = tmp_path_factory.mktemp("farm")
    truth, rows = _write_farm(d)
    return d, truth, rows


def _args(d, out, *extra):
    return ["volume", str(d / "farm.laz"), str(d / "plots.gpkg"), str(out), "-stands",
            str(d / "stands.gpkg"), "-trees_table", str(d / "arvores.csv"), "-plot_radius",
            "11.28", "-q", *extra]


def test_cli_both_approaches(farm, tmp_path, capsys):
    import geopandas as gpd
    import rasterio

    d, truth, rows = farm
    out = tmp_path / "vol.gpkg"
    capsys.readouterr()
    assert main(_args(d, out, "-volume_equation", EQ, "-approach", "both",
                      "-resamples", "200", "-stand_csv", str(tmp_path / "both.csv"))) == 0
    text = capsys.readouterr().out.splitlines()
    printed = [ln for ln in text if ln.startswith("stand T")]
    total = [ln for ln in text if ln.startswith("total: ")]
    plots = gpd.read_file(out, layer="plots")
    stands = gpd.read_file(out, layer="stands")
    # one line a stand: its volume and interval as in the layer, its plots
    assert len(printed) == 6
    for ln, (_, s) in zip(printed, stands.iterrows()):
        lo, hi = s["volume_m3_ha_low"], s["volume_m3_ha_high"]
        err = 100 * (hi - lo) / 2 / s["volume_m3_ha"]
        assert ln.startswith(f"stand {s['stand_id']}: area-based {s['volume_m3_ha']:.1f} m³/ha "
                             f"±{err:.1f} % ({lo:.1f}-{hi:.1f}"), ln
        assert f"tree method {s['volume_trees_m3_ha']:.1f} m³/ha ±" in ln
        assert ln.endswith(f"{s['area_ha']:.2f} ha, {s['n_plots']} plot"
                           + ("" if s["n_plots"] == 1 else "s"))
        assert ("its plots' weight" in ln) == bool(s["volume_trees_plots_weight"] > 0)
    tops = gpd.read_file(out, layer="tree_tops")
    assert len(plots) == 9 and plots.crs.to_epsg() == 29194
    for f in ("volume_m3_ha", "predicted_m3_ha", "residual_m3_ha", "loo_predicted_m3_ha",
              "basal_area_m2_ha", "trees_ha"):
        assert f in plots.columns
    # measured volume of each plot = Schumacher-Hall of its trees (HT measured or estimated)
    p1 = rows["parcela"] == 1
    assert plots["n_trees"][0] == p1.sum()
    assert np.allclose(plots["residual_m3_ha"], plots["volume_m3_ha"] - plots["predicted_m3_ha"],
                       atol=2e-3)
    assert list(stands["stand_id"]) == [f"T{k}" for k in range(1, 7)]
    assert stands["n_plots"].sum() == 9 and (stands["n_plots_model"] == 9).all()
    for pre in ("volume", "volume_trees"):
        est = stands[f"{pre}_m3_ha"].to_numpy()
        assert (stands[f"{pre}_m3_ha_low"] < est).all()
        assert (est < stands[f"{pre}_m3_ha_high"]).all()
        assert np.allclose(stands[f"{pre}_m3"], est * stands["area_ha"], rtol=1e-3)
        err = est / truth["stands"]["volume_m3_ha"] - 1
        assert np.abs(err).max() < 0.15, (pre, err)  # 9 plots, 1.2 ha stands (bench: 8 ha)
    assert (stands["basal_area_m2_ha_low"] < stands["basal_area_m2_ha"]).all()
    # the stand's figure: the model's, moved by its own plots' weight (0: the model's alone)
    for pre in ("volume", "volume_trees"):
        w = stands[f"{pre}_plots_weight"].to_numpy()
        assert ((w >= 0) & (w < 1)).all()
        same = np.isclose(stands[f"{pre}_m3_ha"], stands[f"{pre}_model_m3_ha"], atol=2e-3)
        assert (same == (w == 0)).all(), (pre, w)
    # the same trees from a workbook (.xlsx, as crews keep them), the stands also as a pt-BR
    # table: the same model, the table's rows the layer's
    import pandas as pd

    from lidartrees_gis.io.names import read_text_table

    read_text_table(d / "arvores.csv").to_excel(tmp_path / "arvores.xlsx", index=False)
    out2, csv = tmp_path / "model.gpkg", tmp_path / "talhoes.csv"
    a = _args(d, out2, "-volume_equation", EQ, "-estimator", "model", "-resamples", "50",
              "-stand_csv", str(csv), "-lco", "SEPARATOR=SEMICOLON", "-lco", "DECIMAL=COMMA")
    a[a.index("-trees_table") + 1] = str(tmp_path / "arvores.xlsx")
    assert main(a) == 0
    s2 = gpd.read_file(out2, layer="stands")
    t = pd.read_csv(csv, sep=";", decimal=",", dtype={"stand_id": str}, encoding="utf-8-sig")
    # the last row the farm's total with its interval, as the report has it
    trow, t = t.iloc[-1], t.iloc[:-1]
    rep2 = json.loads((tmp_path / "model_report.json").read_text())
    assert trow["stand_id"] == "total" and trow["area_ha"] == pytest.approx(
        s2["area_ha"].sum(), abs=1e-3) and trow["n_plots"] == s2["n_plots"].sum()
    for end in ("", "_low", "_high"):
        assert trow[f"volume_m3{end}"] == pytest.approx(rep2[f"total_m3{end}"], abs=0.06)
        assert trow[f"volume_m3_ha{end}"] == pytest.approx(
            rep2[f"total_m3{end}"] / s2["area_ha"].sum(), rel=1e-3)
    # the basal area per ha over the stands: their area-weighted mean, inside its interval
    g = float((s2["basal_area_m2_ha"] * s2["area_ha"]).sum() / s2["area_ha"].sum())
    assert trow["basal_area_m2_ha"] == pytest.approx(g, rel=1e-3)
    assert trow["basal_area_m2_ha_low"] < g < trow["basal_area_m2_ha_high"]
    assert list(t["stand_id"]) == list(s2["stand_id"]) and "talhao" in t.columns
    for f in ("volume_m3_ha", "volume_m3_ha_low", "volume_m3_ha_high", "volume_m3",
              "basal_area_m2_ha", "n_plots"):
        assert np.allclose(t[f], s2[f], rtol=1e-4), f
    assert (s2["volume_plots_weight"] == 0).all()
    assert np.allclose(s2["volume_m3_ha"], s2["volume_model_m3_ha"], atol=2e-3)
    assert np.allclose(s2["volume_model_m3_ha"], stands["volume_model_m3_ha"], atol=2e-3)
    assert {"dap_cm", "volume_m3"} <= set(tops.columns) and len(tops) > 10000
    assert tops["dap_cm"].between(5, 40).mean() > 0.95
    with rasterio.open(tmp_path / "vol_volume.tif") as ds:
        assert ds.descriptions[0] == "volume (m³/ha)" and ds.res == (20.0, 20.0)
        v = ds.read(1, masked=True)
        assert 150 < float(v.mean()) < 700
    rep = json.loads((tmp_path / "vol_report.json").read_text())
    # the farm's total with its interval: the stands' m³ summed; the interval at least that of
    # independent stands and at most that of stands erring all alike
    for pre, part in (("volume", rep), ("volume_trees", rep["tree_approach"])):
        t, lo, hi = part["total_m3"], part["total_m3_low"], part["total_m3_high"]
        assert t == pytest.approx(stands[f"{pre}_m3"].sum(), abs=0.1)
        half = (stands[f"{pre}_m3_high"] - stands[f"{pre}_m3_low"]).to_numpy() / 2
        assert 0.9 * np.sqrt(np.sum(half ** 2)) < (hi - lo) / 2 < 1.01 * half.sum(), pre
    assert total == [f"total: area-based {rep['total_m3']:.0f} m³ ±"
                     f"{100 * (rep['total_m3_high'] - rep['total_m3_low']) / 2 / rep['total_m3']:.1f}"
                     f" % ({rep['total_m3_low']:.0f}-{rep['total_m3_high']:.0f}); tree method "
                     f"{rep['tree_approach']['total_m3']:.0f} m³ ±"
                     + total[0].split("tree method ")[1].split("±")[1]]
    # why a stand's plots weigh what they weigh: the analysis of variance, in the report
    for pre, part in (("volume", rep["volume_model"]), ("volume_trees", rep["tree_approach"])):
        test = part["stands_differ_test"]
        assert test["alpha"] == 0.05 and test["stands_2plus"] == 2
        assert test["differ"] == (test["p"] <= 0.05)
        if not test["differ"]:
            assert (stands[f"{pre}_plots_weight"] == 0).all(), pre
    both = pd.read_csv(tmp_path / "both.csv", dtype={"stand_id": str}).iloc[-1]
    for pre, part in (("volume", rep), ("volume_trees", rep["tree_approach"])):
        assert both["stand_id"] == "total" and both[f"{pre}_m3_high"] == pytest.approx(
            part["total_m3_high"], abs=0.06), pre
    assert rep["inputs"]["points"] == str(d / "farm.laz") and rep["tool"].startswith(
        "lidartrees_gis ") and rep["created"][:2] == "20"
    assert list(plots.columns[:3]) == ["plot_id", "parcela", "stand_id"]  # the crew's fields
    m = rep["volume_model"]
    assert m["plots"] == 9 and 1 <= len(m["predictors"]) <= 2 and m["loo_rmse_pct"] < 15
    assert m["departures"] == ("relative" if m["form"] == "loglog" else "m³/ha")
    assert rep["field"]["heights_estimated"] > 0 and rep["field"]["hypsometric"]["trees"] > 0
    # the whole procedure's leave-one-out, the choice redone without each plot, from the plots
    from lidartrees_gis.inventory.models import CANDIDATES, nested_loo

    y = plots["volume_m3_ha"].to_numpy(float)
    e = y - np.maximum(nested_loo({k: plots[k].to_numpy(float) for k in CANDIDATES}, y), 0)
    assert m["procedure_loo_rmse_pct"] == pytest.approx(
        100 * np.sqrt(np.mean(e ** 2)) / y.mean(), abs=0.01)
    # the model beside every stand's figure and interval, both methods
    from PIL import Image

    with Image.open(tmp_path / "vol_report.png") as im:
        assert im.size[0] == 12 * 150 and im.size[1] >= 6 * 150
    import sqlite3

    con = sqlite3.connect(out)
    styled = dict(con.execute("SELECT f_table_name, description FROM layer_styles"))
    con.close()
    assert "volume_stands.qml" in styled["stands"]
    assert "volume_plots.qml" in styled["plots"]


def test_python_in_memory_writes_nothing(farm, tmp_path, monkeypatch):
    import lidartrees_gis as lt  # the package's own name, as docs/VOLUME.md writes it

    d, truth, _ = farm
    monkeypatch.chdir(tmp_path)
    r = lt.volume(d / "farm.laz", d / "plots.gpkg", stands=d / "stands.gpkg",
                  trees_table=d / "arvores.csv", plot_radius=11.28, volume_equation=EQ,
                  resamples=100)
    assert not list(tmp_path.iterdir())
    s = r["layers"]["stands"]
    err = s["volume_m3_ha"].to_numpy() / truth["stands"]["volume_m3_ha"] - 1
    assert np.abs(err).max() < 0.15
    spec, grid = r["volume_grid"]
    assert grid.shape == spec.shape and r["report"]["volume_model"]["plots"] == 9


def _bad(capsys, args, tmp_path, out):
    rc = main(args)
    err = capsys.readouterr().err.strip().splitlines()
    assert rc != 0 and len(err) == 1, err
    assert not out.exists() and not list(out.parent.glob("vol_*"))
    return err[0]


def test_bad_inputs_one_line_no_output(farm, tmp_path, capsys):
    import geopandas as gpd
    import shapely

    d, _, _ = farm
    out = tmp_path / "vol.gpkg"
    # plots outside the data (10 km east: a wrong CRS or shifted layer)
    pl = gpd.read_file(d / "plots.gpkg")
    pl.set_geometry(pl.geometry.translate(10000, 0)).to_file(tmp_path / "far.gpkg")
    a = _args(d, out, "-volume_equation", EQ)
    a[2] = str(tmp_path / "far.gpkg")
    assert "outside the points, wholly or in part" in _bad(capsys, a, tmp_path, out)
    # plots without a CRS
    pl.set_crs(None, allow_override=True).to_file(tmp_path / "nocrs.shp")
    a[2] = str(tmp_path / "nocrs.shp")
    assert "no CRS" in _bad(capsys, a, tmp_path, out)
    # plots and stands whose UTM metres are labelled geographic (SIRGAS 2000, EPSG:4674): said
    # before reprojecting them to nowhere (their returns were "none above -min_height")
    pl.set_crs(4674, allow_override=True).to_file(tmp_path / "deg.gpkg")
    a[2] = str(tmp_path / "deg.gpkg")
    line = _bad(capsys, a, tmp_path, out)
    assert line.startswith("lidartrees volume: error: PLOTS: ") and "deg.gpkg" in line and \
        "EPSG:4674" in line and "beyond longitude" in line and "give the layer its true CRS" in line
    gpd.read_file(d / "stands.gpkg").set_crs(4674, allow_override=True).to_file(
        tmp_path / "st_deg.gpkg")
    b = _args(d, out, "-volume_equation", EQ)
    b[b.index("-stands") + 1] = str(tmp_path / "st_deg.gpkg")
    line = _bad(capsys, b, tmp_path, out)
    assert "-stands: " in line and "st_deg.gpkg" in line and "its features span" in line, line
    # stands 10 km off the points (the plots on them): said as the plots are, nothing written
    gpd.read_file(d / "stands.gpkg").translate(10000, 0).to_file(tmp_path / "st_far.gpkg")
    b[b.index("-stands") + 1] = str(tmp_path / "st_far.gpkg")
    line = _bad(capsys, b, tmp_path, out)
    assert "st_far.gpkg: no stand overlaps the points" in line, line
    # no tree table and no volume field: the names read and the layer's fields are said
    c = _args(d, out)
    i = c.index("-trees_table")
    del c[i:i + 2]
    line = _bad(capsys, c, tmp_path, out)
    assert "no plot volume field (volume_m3_ha, vol_ha, vtcc_ha, volume or vol; its fields: " \
        "parcela)" in line, line
    # a plot without trees
    extra = gpd.GeoDataFrame({"parcela": [99]}, geometry=[shapely.Point(
        pl.geometry[0].x + 1, pl.geometry[0].y + 30)], crs=pl.crs)
    gpd.GeoDataFrame(gpd.pd.concat([pl, extra], ignore_index=True), crs=pl.crs).to_file(
        tmp_path / "more.gpkg")
    a[2] = str(tmp_path / "more.gpkg")
    assert "have no trees" in _bad(capsys, a, tmp_path, out)
    # a plot id mistyped in the table: both the layer's plot and the table's id are named
    text = (d / "arvores.csv").read_text(encoding="cp1252").splitlines()
    typo = [text[0]] + [ln.replace(ln.split(";")[0], "77", 1) if ln.split(";")[0] == "2"
                        else ln for ln in text[1:]]
    (tmp_path / "typo.csv").write_text("\n".join(typo) + "\n", encoding="cp1252")
    a = _args(d, out, "-volume_equation", EQ)
    a[a.index("-trees_table") + 1] = str(tmp_path / "typo.csv")
    line = _bad(capsys, a, tmp_path, out)
    assert "have no trees" in line and ": 2 (its plots not in PLOTS: 77)" in line, line
    # DAP in millimetres
    text = (d / "arvores.csv").read_text(encoding="cp1252").splitlines()
    mm = [text[0]] + [";".join(f[:2] + [str(round(float(f[2].replace(",", ".")) * 10))] + f[3:])
                      for f in (ln.split(";") for ln in text[1:])]
    (tmp_path / "mm.csv").write_text("\n".join(mm) + "\n", encoding="cp1252")
    a = _args(d, out, "-volume_equation", EQ)
    a[a.index("-trees_table") + 1] = str(tmp_path / "mm.csv")
    assert "millimetres" in _bad(capsys, a, tmp_path, out)
    # too few plots
    pl.iloc[:3].to_file(tmp_path / "three.gpkg")
    a = _args(d, out, "-volume_equation", EQ)
    a[2] = str(tmp_path / "three.gpkg")
    line = _bad(capsys, a, tmp_path, out)
    assert "at least 5" in line, line
    # an existing stand table is not replaced without -overwrite, and nothing else is written
    (tmp_path / "st.csv").write_text("keep\n")
    a = _args(d, out, "-volume_equation", EQ, "-stand_csv", str(tmp_path / "st.csv"))
    assert "st.csv: output exists; use -overwrite" in _bad(capsys, a, tmp_path, out)
    assert (tmp_path / "st.csv").read_text() == "keep\n"
    # the crew's plot coordinates as a CSV table: a vector layer is asked for
    (tmp_path / "parcelas.csv").write_text("parcela;x;y\n1;412050;7952050\n")
    a = _args(d, out, "-volume_equation", EQ)
    a[2] = str(tmp_path / "parcelas.csv")
    assert "a table without geometries" in _bad(capsys, a, tmp_path, out)
    # another run writing one of the outputs: refused at the start, nothing written
    from test_claims import _hold

    hold = _hold(tmp_path / "vol_report.png", 60)
    try:
        line = _bad(capsys, _args(d, out, "-volume_equation", EQ), tmp_path, out)
        assert "vol_report.png is being written by another run" in line, line
    finally:
        hold.kill()
        hold.wait()
    # the tree approach without trees
    a = _args(d, out, "-approach", "trees")
    i = a.index("-trees_table")
    del a[i:i + 2]
    assert "-trees_table" in _bad(capsys, a, tmp_path, out)


def test_field_table_forms(tmp_path):
    """CAP instead of DAP, English names, a pt-BR equation, heights of a few trees only."""
    from lidartrees_gis.errors import InputError
    from lidartrees_gis.inventory.field import Equation, complete_trees, plot_figures, read_trees

    (tmp_path / "t.csv").write_text("plot,tree,cbh,height\n1,1,47.1,20.0\n1,2,53.4,\n"
                                    "1,3,40.8,18.5\n2,1,50.3,21.0\n2,2,,\n", encoding="utf-8")
    t = read_trees(tmp_path / "t.csv")
    assert t["dap"][0] == pytest.approx(47.1 / np.pi) and t["rows_without_dap"] == 1
    eq = Equation.parse("0,000049;1,85;1,05")
    assert (eq.b0, eq.b1, eq.b2) == (0.000049, 1.85, 1.05)
    c = complete_trees(t, eq)
    assert c["ht_estimated"].tolist() == [False, True, False, False]
    assert 18.5 < c["ht"][1] < 23  # the thickest tree: Curtis' relation puts it tallest
    f = plot_figures(c, ["1", "2"], [400.0, 400.0])
    assert f["n_trees"].tolist() == [3, 1] and f["trees_ha"][0] == pytest.approx(75.0)
    v1 = eq(c["dap"][:3], c["ht"][:3]).sum() / 0.04
    assert f["volume_m3_ha"][0] == pytest.approx(v1)
    with pytest.raises(InputError, match="b0,b1,b2"):
        Equation.parse("1,2")
    # a workbook's named sheet (PATH.xlsx:SHEET), as the crew's file has a cover sheet first
    import pandas as pd

    with pd.ExcelWriter(tmp_path / "t.xlsx") as w:
        pd.DataFrame({"nota": ["capa"]}).to_excel(w, sheet_name="Capa", index=False)
        pd.read_csv(tmp_path / "t.csv").to_excel(w, sheet_name="Dados", index=False)
    tx = read_trees(f"{tmp_path / 't.xlsx'}:Dados")
    assert np.allclose(tx["dap"], t["dap"]) and tx["rows_without_dap"] == 1
    # a form factor (fator de forma) as companies without an equation use: V = f·g·HT
    ff = Equation.parse("ff:0,45")
    assert ff(20.0, 25.0) == pytest.approx(0.45 * np.pi * 0.2 ** 2 / 4 * 25.0)
    assert ff.source == "form factor 0.45"
    for bad in ("ff:3", "ff:x", "ff:"):
        with pytest.raises(InputError, match="form factor"):
            Equation.parse(bad)


def test_warnings_extra_table_plots_and_overlaps(farm, tmp_path):
    """Trees of a plot the layer does not hold, and two plots overlapping: the run goes on,
    each said in one warning naming them; the extra plot's trees change no plot figure."""
    import warnings

    import geopandas as gpd
    import shapely

    import lidartrees_gis as lt
    from lidartrees_gis.errors import DataWarning

    d, _, _ = farm
    text = (d / "arvores.csv").read_text(encoding="cp1252").splitlines()
    more = [ln.replace(ln.split(";")[0], "88", 1) for ln in text[1:] if ln.split(";")[0] == "1"]
    (tmp_path / "more.csv").write_text("\n".join(text + more) + "\n", encoding="cp1252")
    pl = gpd.read_file(d / "plots.gpkg")
    pl.loc[1, "geometry"] = shapely.Point(pl.geometry[0].x + 15.0, pl.geometry[0].y)
    pl.to_file(tmp_path / "overlap.gpkg")
    kw = dict(stands=d / "stands.gpkg", plot_radius=11.28, volume_equation=EQ, resamples=30)
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        r = lt.volume(d / "farm.laz", tmp_path / "overlap.gpkg", trees_table=tmp_path / "more.csv",
                      **kw)
    said = [str(w.message) for w in rec if issubclass(w.category, DataWarning)]
    assert any("1 plot(s) not in PLOTS (88)" in s for s in said), said
    assert any("1 pair(s) of plots overlap (1 and 2)" in s for s in said), said
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DataWarning)  # the overlap, said above
        base = lt.volume(d / "farm.laz", tmp_path / "overlap.gpkg",
                         trees_table=d / "arvores.csv", **kw)
    a, b = r["layers"]["plots"], base["layers"]["plots"]
    assert np.allclose(a["n_trees"], b["n_trees"]) and len(a) == len(b) == 9
    # a radius of half the plots' (5.64 m for 400 m² plots): the table's trees fill a quarter
    # of the area, four times the trees detected there; said, with the tree method's data,
    # and by the table's trees per ha alone with the area-based approach (once each)
    kw["plot_radius"] = 5.64
    for approach, said_it in (("both", True), ("aba", True)):
        with warnings.catch_warnings(record=True) as rec:
            warnings.simplefilter("always")
            lt.volume(d / "farm.laz", d / "plots.gpkg", trees_table=d / "arvores.csv",
                      approach=approach, **kw)
        said = [str(w.message) for w in rec if "check -plot_radius" in str(w.message)]
        assert len(said) == int(said_it), said
        if approach == "both":
            ratio = float(said[0].split(" are ")[1].split(" times")[0])
            assert 3.0 < ratio < 5.5 and "(median of 9 plots; 100 m² a plot)" in said[0]
        else:
            assert "more than any planting design" in said[0] and "of 100 m²" in said[0]


def test_a_model_that_predicts_its_plots_poorly_is_said(recwarn):
    """Plots whose volumes the metrics do not follow: the run goes on and one warning gives the
    model and its leave-one-out R²."""
    from lidartrees_gis.errors import DataWarning
    from lidartrees_gis.inventory.volume import VolumeOptions, _aba

    rng = np.random.default_rng(3)
    n = 8
    pm = {k: rng.uniform(10, 30, n) for k in ("zq95", "zq75", "zq50", "zmean", "zmax")}
    pm.update(cover=rng.uniform(60, 90, n), pzabovezmean=rng.uniform(40, 60, n),
              zsd=rng.uniform(3, 6, n), zL2=rng.uniform(2, 4, n))
    cm = {k: v.repeat(10) for k, v in pm.items()}
    figs = {"volume_m3_ha": rng.uniform(200, 400, n)}
    out = _aba(pm, figs, cm, np.arange(n).repeat(10) % 3, 3, np.arange(n) % 3,
               VolumeOptions(resamples=50))
    said = [str(w.message) for w in recwarn if issubclass(w.category, DataWarning)]
    r2 = out["volume"][0].stats["loo_r2"]
    assert r2 < 0.5
    assert any(f"leave-one-out R² {r2:.2f}" in s for s in said), said


def test_stand_lines_never_print_nan():
    """A stand without cells, or without an interval, is said in words on its line."""
    import pandas as pd

    from lidartrees_gis.inventory.outputs import stand_lines

    nan = float("nan")
    df = pd.DataFrame({"stand_id": ["A", "B"], "volume_m3_ha": [300.0, nan],
                       "volume_m3_ha_low": [nan, nan], "volume_m3_ha_high": [nan, nan],
                       "volume_m3": [600.0, nan], "volume_m3_low": [nan, nan],
                       "volume_m3_high": [nan, nan], "area_ha": [2.0, 1.0], "n_plots": [1, 0]})
    lines = stand_lines(df)
    assert lines["stand A"] == ("area-based 300.0 m³/ha (no interval), 600 m³ (no interval); "
                                "2.00 ha, 1 plot")
    assert lines["stand B"].startswith("area-based: no figure")
    assert not any("nan" in v.lower() for v in lines.values())


def test_units_and_coefficients_a_crew_gets_wrong_are_refused(tmp_path):
    """HT in centimetres, DAP in metres, a young stand's DAP in millimetres (its median alone
    looks like centimetres), a b0 ten thousand times too large, volumes in dm³: each one line
    naming the column or the option; plot 01 of a spreadsheet is plot 1 of the layer."""
    from lidartrees_gis.errors import InputError
    from lidartrees_gis.inventory.field import (Equation, complete_trees, plot_figures,
                                                read_trees)

    rng = np.random.default_rng(0)
    ht = rng.uniform(8, 12, 30)
    dap = 0.9 * ht ** 0.91
    vol = 0.000049 * dap ** 1.85 * ht ** 1.05

    def table(name, d=dap, h=ht, v=None, plot="1"):
        rows = ["parcela;arvore;dap;ht" + (";volume" if v is not None else "")]
        for i in range(d.size):
            rows.append(f"{plot};{i + 1};{d[i]:.3f};{h[i]:.2f}"
                        + (f";{v[i]:.6f}" if v is not None else ""))
        (tmp_path / name).write_text("\n".join(rows) + "\n")
        return tmp_path / name

    for name, kw, words in (("cm.csv", {"h": ht * 100}, "centimetres or decimetres? give metres"),
                            ("m.csv", {"d": dap / 100}, "metres? give centimetres"),
                            ("mm.csv", {"d": dap * 10}, "millimetres? give centimetres")):
        with pytest.raises(InputError, match=re.escape(words)) as e:
            read_trees(table(name, **kw))
        assert name in str(e.value)
    t = read_trees(table("ok.csv"))
    with pytest.raises(InputError, match="-volume_equation 0.49,1.85,1.05: .*form factor"):
        complete_trees(t, Equation(0.49, 1.85, 1.05))
    with pytest.raises(InputError, match="dm3.csv: volume column: .*form factor"):
        complete_trees(read_trees(table("dm3.csv", v=vol * 1000)), None)
    c = complete_trees(read_trees(table("zero.csv", plot="01")), Equation(0.000049, 1.85, 1.05))
    f = plot_figures(c, ["1"], [400.0])
    assert f["n_trees"].tolist() == [30] and f["volume_m3_ha"][0] == pytest.approx(
        vol.sum() / 0.04, rel=1e-3)


def test_a_circumference_in_the_dap_column_is_refused_by_the_plots_basal_area(tmp_path):
    """CAP typed under ``dap`` (its ratio to HT, 2.5, looks like a stout tree) gives pi² times
    the basal area: plot 7's 466 m²/ha, more than any stand carries, is refused naming the plot
    and the column; the same numbers under ``cap`` give the true 47 m²/ha."""
    from lidartrees_gis.errors import InputError
    from lidartrees_gis.inventory.field import (Equation, complete_trees, plot_figures,
                                                read_trees)

    rng = np.random.default_rng(1)
    ht = rng.uniform(22, 28, 60)
    dap = rng.normal(20.0, 1.5, 60)
    cap = np.pi * dap
    for col, ok in (("dap", False), ("cap", True)):
        rows = [f"parcela;arvore;{col};ht"] + [f"7;{i + 1};{str(round(cap[i], 1)).replace('.', ',')};"
                                              f"{str(round(ht[i], 1)).replace('.', ',')}"
                                              for i in range(60)]
        path = tmp_path / f"{col}.csv"
        path.write_text("\n".join(rows) + "\n")
        t = complete_trees(read_trees(path), Equation(0.000049, 1.85, 1.05))
        if ok:
            ba = plot_figures(t, ["7"], [400.0])["basal_area_m2_ha"][0]
            assert ba == pytest.approx(np.sum(np.pi * (dap / 200) ** 2) / 0.04, rel=1e-3)
            assert 40 < ba < 55
            continue
        with pytest.raises(InputError, match=r"dap.csv: plot 7's basal area is 4\d\d m²/ha "
                           r"from its DAP column 'dap' .*circumference \(CAP\)"):
            plot_figures(t, ["7"], [400.0])


def test_overwrite_drops_the_commands_layers_this_run_does_not_write(farm, tmp_path, capsys):
    """``volume -approach both`` then ``-approach aba -overwrite`` on one file: the first run's
    tree_tops are gone (QGIS loaded them beside the new stands); a layer of the user's stays."""
    import geopandas as gpd
    import pyogrio
    import shapely

    d, _, _ = farm
    out = tmp_path / "vol.gpkg"
    assert main(_args(d, out, "-volume_equation", EQ, "-approach", "both", "-resamples", "20")) == 0
    assert {"plots", "stands", "tree_tops"} <= {n for n, _ in pyogrio.list_layers(out)}
    gpd.GeoDataFrame({"a": [1]}, geometry=[shapely.Point(0, 0)], crs=31984).to_file(
        out, layer="mine")
    assert main(_args(d, out, "-volume_equation", EQ, "-resamples", "20", "-overwrite")) == 0
    assert sorted(n for n, _ in pyogrio.list_layers(out)) == ["layer_styles", "mine", "plots",
                                                              "stands"]
    capsys.readouterr()


def test_alt_is_a_height_column_and_a_table_without_one_is_named(tmp_path):
    """``parcela;arv;dap;alt`` (a common field sheet) reads its heights; a table with no height
    column says so with its columns (it said "only 0 trees with a height"); -plot_radius 0 is
    named as a radius that must be > 0 (it said "give -plot_radius")."""
    import shapely

    from lidartrees_gis.errors import InputError
    from lidartrees_gis.inventory.field import Equation, complete_trees, read_trees
    from lidartrees_gis.inventory.plots import load_plots

    rows = ["parcela;arv;dap;Alt (m)"] + [f"1;{i};{12 + i % 5},5;{18 + i % 4},2" for i in range(1, 31)]
    (tmp_path / "alt.csv").write_text("\n".join(rows) + "\n", encoding="cp1252")
    t = complete_trees(read_trees(tmp_path / "alt.csv"), Equation(0.000049, 1.85, 1.05))
    assert t["hypsometric"] is None and t["ht"][:5].tolist() == [19.2, 20.2, 21.2, 18.2, 19.2]
    (tmp_path / "xx.csv").write_text("\n".join(r.replace("Alt (m)", "obs") for r in rows) + "\n")
    with pytest.raises(InputError, match=r"xx.csv: no HT column \(ht, altura, alt, h\); "
                       r"columns: parcela, arv, dap, obs"):
        complete_trees(read_trees(tmp_path / "xx.csv"), Equation(0.000049, 1.85, 1.05))
    import geopandas as gpd

    g = gpd.GeoDataFrame({"parcela": [1]}, geometry=[shapely.Point(0, 0)], crs=31984)
    with pytest.raises(InputError, match=r"-plot_radius must be > 0 m, got -5"):
        load_plots(g, g.crs, plot_radius=-5.0)
    from lidartrees_gis.errors import DataWarning

    with pytest.warns(DataWarning, match=r"-plot_radius 11.28 ignored: PLOTS GeoDataFrame holds "
                      "polygons"):
        p = load_plots(g.set_geometry(g.buffer(10.0)), g.crs, plot_radius=11.28)
    assert p.area_m2[0] == pytest.approx(np.pi * 100, rel=0.01)


def test_no_stand_below_nothing_and_outside_the_plots_said(recwarn):
    """A linear model applied to a young stand without plots (its metrics below every plot's)
    would go negative: the stand gets 0 inside its interval, and one warning names it."""
    import shapely

    from lidartrees_gis.errors import DataWarning
    from lidartrees_gis.inventory.models import AbaModel, aba_stands
    from lidartrees_gis.inventory.volume import _warn_stands
    from lidartrees_gis.plantation.stands import Stands

    rng = np.random.default_rng(1)
    n = 10
    pm = {"zq95": rng.uniform(15, 30, n)}
    y = -150 + 20 * pm["zq95"] + rng.normal(0, 5, n)
    X = np.column_stack([np.ones(n), pm["zq95"]])
    coef = np.linalg.lstsq(X, y, rcond=None)[0]
    fitted = X @ coef
    loo = fitted + rng.normal(0, 5, n)
    m = AbaModel("linear", ("zq95",), coef, 25.0, n, stats={"fitted": fitted, "loo": loo})
    cell_stand = np.repeat([0, 1], 9)
    cm = {"zq95": np.r_[rng.uniform(18, 26, 9), rng.uniform(4, 5, 9)],
          "cover": np.ones(18)}
    est = aba_stands(m, pm, y, cm, cell_stand, 2, np.zeros(n, int), resamples=50,
                     reselect=False)
    assert est["estimate"][1] == 0.0 and est["low"][1] <= 0.0 <= est["high"][1]
    assert est["estimate"][0] > 100
    st = Stands(("A", "young"), np.array([shapely.box(0, 0, 60, 60),
                                          shapely.box(60, 0, 120, 60)]))
    cs = np.array([0, 0, 0, 1, 1, 1] * 3)
    cells = {"zq95": np.where(cs == 0, 22.0, 4.5), "cover": np.ones(18)}
    _warn_stands(st, np.ones(2), cells, cs, pm, {"volume": (m, None, est)})  # both flown
    said = [str(w.message) for w in recwarn if issubclass(w.category, DataWarning)]
    assert len(said) == 1 and "young (zq95 4.5; plots" in said[0], said


def test_stands_the_points_do_not_cover_are_said_and_left_out_of_the_total(farm, tmp_path,
                                                                            capsys):
    """A stand half beyond the flight and one wholly beyond it: one warning gives each one's
    cover; the total says which stand it leaves out; the m³ of the others unchanged."""
    import geopandas as gpd
    import shapely

    d, _, _ = farm
    st = gpd.read_file(d / "stands.gpkg")
    x0, y0, x1, y1 = st.total_bounds
    extra = gpd.GeoDataFrame({"talhao": ["H", "F"]}, geometry=[
        shapely.box(x1 - 50, y0, x1 + 50, y0 + 100), shapely.box(x1 + 200, y0, x1 + 300, y0 + 100)],
        crs=st.crs)
    gpd.pd.concat([st, extra], ignore_index=True).pipe(gpd.GeoDataFrame, crs=st.crs).to_file(
        tmp_path / "more.gpkg")
    a = _args(d, tmp_path / "v.gpkg", "-volume_equation", EQ, "-resamples", "30")
    a[a.index("-stands") + 1] = str(tmp_path / "more.gpkg")
    a.remove("-q")
    capsys.readouterr()
    assert main(a) == 0
    out, err = capsys.readouterr()
    warned = [ln for ln in err.splitlines() if "covered by the points" in ln]
    # (cover by the metric cells: half the stand, to a cell)
    assert len(warned) == 1 and re.search(r"H \((5|6)\d %\)", warned[0]), warned
    assert "F (0 %)" in warned[0]
    total = next(ln for ln in out.splitlines() if ln.startswith("total: "))
    assert total.endswith("; without F (no figure)"), total
    s = gpd.read_file(tmp_path / "v.gpkg", layer="stands")
    assert s["volume_m3"].isna().tolist() == [False] * 7 + [True]


def test_stand_panel_writes_each_stands_figures():
    """The PNG's stands panel writes each stand's m³/ha and interval beside it, as the table
    has them (a report's reader needs the numbers, not only the bars)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import pandas as pd

    from lidartrees_gis.inventory.outputs import _draw_stands

    st = pd.DataFrame({"stand_id": ["T1", "T2"], "volume_m3_ha": [250.4, 101.2],
                       "volume_m3_ha_low": [230.0, 80.6], "volume_m3_ha_high": [270.9, 121.0]})
    fig, ax = plt.subplots()
    _draw_stands(st)(ax)
    texts = [t.get_text().strip() for t in ax.texts]
    plt.close(fig)
    assert texts == ["250 (230-271)", "101 (81-121)"]


def test_a_flight_edge_across_stands_and_a_plot(farm, tmp_path, capsys):
    """The flight ends across the farm's lower stands (half of each flown): each stand's
    covered share is said, the cells the edge leaves less than half covered are not predicted,
    the tree method's m³/ha is that of the flown part (not halved by the unflown one), and a
    plot the edge crosses is refused."""
    import geopandas as gpd
    import laspy
    import rasterio
    import shapely

    d, truth, _ = farm
    cut = 7952055.0  # the lower stands span 7952000-7952110
    las = laspy.read(d / "farm.laz")
    part = laspy.LasData(las.header)
    part.points = las.points[np.asarray(las.y) >= cut]
    part.write(tmp_path / "cut.laz")
    pl = gpd.read_file(d / "plots.gpkg")
    below = pl.geometry.y < cut + 11.28
    assert below.sum() == 1  # plot 1, wholly in the unflown part
    pl[~below].to_file(tmp_path / "plots.gpkg")
    out = tmp_path / "v.gpkg"
    a = _args(d, out, "-volume_equation", EQ, "-approach", "both", "-resamples", "30")
    a[1], a[2] = str(tmp_path / "cut.laz"), str(tmp_path / "plots.gpkg")
    capsys.readouterr()
    assert main(a) == 0
    said = [ln for ln in capsys.readouterr().err.splitlines() if "covered by the points" in ln]
    assert len(said) == 1 and "T1 (51 %)" in said[0], said  # once, not by each approach
    s = gpd.read_file(out, layer="stands")
    lower = s["stand_id"].isin(["T1", "T2", "T3"]).to_numpy()
    assert lower.sum() == 3
    # half flown, to a 2 m coverage square
    assert np.all((s["data_cover_pct"][lower] >= 50) & (s["data_cover_pct"][lower] <= 52.5))
    assert np.all(s["data_cover_pct"][~lower] == 100)
    true = np.asarray(truth["stands"]["volume_m3_ha"])
    err = np.abs(s["volume_trees_m3_ha"].to_numpy() / true - 1)
    assert err[lower].max() < 0.08, err  # the unflown half counted as empty: -0.5
    report = json.loads((tmp_path / "v_report.json").read_text())
    with rasterio.open(tmp_path / "v_volume.tif") as r:
        v = r.read(1, masked=True)
        rows = np.array([r.xy(i, 0)[1] for i in range(r.height)])
    # the 20 m row of cells 7952040-60 holds a quarter of a row's returns: not predicted;
    # the rows above it are
    edge = np.abs(rows - 7952050) < 1
    assert edge.sum() == 1 and v[edge].mask.all()
    above = rows > 7952060
    assert (~v[above].mask).all()
    # the row's cells in the stands (412000-412330): 17, the last one half in, those on the
    # T1-T2 and T2-T3 borders counted once
    assert report["metrics"]["cells_left_out"] == 17
    # a plot an edge crosses within the points' extent (a notch of the flight's outline):
    # refused by name with its cover
    x, y = np.asarray(las.x), np.asarray(las.y)
    notch = laspy.LasData(las.header)
    notch.points = las.points[~((x < 412060) & (y < 7952100))]
    notch.write(tmp_path / "notch.laz")
    crossing = gpd.GeoDataFrame({"parcela": [1]}, geometry=[shapely.Point(412060.0, 7952080.0)],
                                crs=pl.crs)
    gpd.GeoDataFrame(gpd.pd.concat([pl[~below], crossing], ignore_index=True),
                     crs=pl.crs).to_file(tmp_path / "crossing.gpkg")
    a[1], a[2] = str(tmp_path / "notch.laz"), str(tmp_path / "crossing.gpkg")
    out2 = tmp_path / "v2.gpkg"
    a[3] = str(out2)
    a.append("-q")
    capsys.readouterr()
    line = _bad(capsys, a, tmp_path, out2)
    assert re.search(r"1 plot\(s\) less than 80 % covered by the points: 1 \((4|5)\d %\)", line), line


def test_python_takes_the_tree_table_as_a_dataframe(farm):
    """``lt.volume(trees_table=DataFrame)``: the same figures as from the file, the report
    naming it, and a bad cell named by its row."""
    import warnings

    import lidartrees_gis as lt
    from lidartrees_gis.errors import InputError
    from lidartrees_gis.io.names import read_text_table

    d, _, _ = farm
    df = read_text_table(d / "arvores.csv")
    kw = dict(stands=d / "stands.gpkg", plot_radius=11.28, volume_equation=EQ, resamples=30)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        a = lt.volume(d / "farm.laz", d / "plots.gpkg", trees_table=df, **kw)
        b = lt.volume(d / "farm.laz", d / "plots.gpkg", trees_table=d / "arvores.csv", **kw)
    np.testing.assert_array_equal(a["layers"]["stands"]["volume_m3_ha"],
                                  b["layers"]["stands"]["volume_m3_ha"])
    assert a["report"]["inputs"]["trees_table"] == f"<DataFrame of {len(df)} rows>"
    bad = df.astype({"dap": object})
    bad.loc[3, "dap"] = "18 cm"
    with pytest.raises(InputError, match=r"-trees_table: <DataFrame of \d+ rows>: row 3: DAP "
                       "'18 cm' is not a number"):
        lt.volume(d / "farm.laz", d / "plots.gpkg", trees_table=bad, **kw)


def test_volume_field_names_the_plots_own_volume(farm, tmp_path, capsys):
    """A plots layer with its volume under its own name (efi_plot's ``VOI``): ``-volume_field
    VOI`` gives the figures of the same volumes read from the table; a name not in the layer,
    or given with a tree table, is refused in one line."""
    import geopandas as gpd

    d, _, _ = farm
    first = tmp_path / "from_table.gpkg"
    assert main(_args(d, first, "-volume_equation", EQ, "-resamples", "30")) == 0
    got = gpd.read_file(first, layer="plots")
    pl = gpd.read_file(d / "plots.gpkg").merge(
        got[["parcela", "volume_m3_ha"]].rename(columns={"volume_m3_ha": "VOI"}), on="parcela")
    assert len(pl) == 9
    pl.to_file(tmp_path / "voi.gpkg")
    a = ["volume", str(d / "farm.laz"), str(tmp_path / "voi.gpkg"), str(tmp_path / "v.gpkg"),
         "-stands", str(d / "stands.gpkg"), "-plot_radius", "11.28", "-resamples", "30", "-q"]
    line = _bad(capsys, a, tmp_path, tmp_path / "v.gpkg")  # VOI is not a name read by itself
    assert "give one of them, or -volume_field" in line and "VOI" in line, line
    assert main([*a, "-volume_field", "voi"]) == 0  # as the layer's fields are read: any case
    s0 = gpd.read_file(first, layer="stands")
    s1 = gpd.read_file(tmp_path / "v.gpkg", layer="stands")
    # the same plot volumes (to the table's 4 decimals), the same stands
    np.testing.assert_allclose(s1["volume_m3_ha"], s0["volume_m3_ha"], rtol=2e-3)
    b = [*a[:3], str(tmp_path / "w.gpkg"), *a[4:], "-volume_field", "VOL_HA"]
    line = _bad(capsys, b, tmp_path, tmp_path / "w.gpkg")
    assert "-volume_field: 'VOL_HA' is not a field of PLOTS" in line and "VOI" in line, line
    c = [*b[:-1], "VOI", "-trees_table", str(d / "arvores.csv")]
    line = _bad(capsys, c, tmp_path, tmp_path / "w.gpkg")
    assert "-volume_field: the plots' volume comes from -trees_table" in line, line


def test_plots_given_a_quarter_of_their_area_are_said_with_the_area_based_approach(
        farm, tmp_path, capsys):
    """400 m² plots entered with the 100 m² radius (5.64 m): four times the trees per ha of
    any planting design; the area-based run (no detected trees to compare with) says so."""
    d, _, _ = farm
    a = _args(d, tmp_path / "v.gpkg", "-volume_equation", EQ, "-resamples", "30")
    a[a.index("-plot_radius") + 1] = "5.64"
    a.remove("-q")
    capsys.readouterr()
    assert main(a) == 0
    said = [ln for ln in capsys.readouterr().err.splitlines() if "planting design" in ln]
    assert len(said) == 1 and "of 100 m²" in said[0] and "-plot_radius" in said[0], said
    tree_ha = float(said[0].split("make ")[1].split(" trees/ha")[0])
    assert 5000 < tree_ha < 8000  # the farm's 3 x 2 m (1667 trees/ha) times four
    b = _args(d, tmp_path / "w.gpkg", "-volume_equation", EQ, "-resamples", "30")
    b.remove("-q")
    assert main(b) == 0
    assert "planting design" not in capsys.readouterr().err
