"""The metrics and volume algorithms in a headless QGIS (issue 40): the same results as the
CLI, and a bad input one QgsProcessingException with nothing written."""
import sys
from pathlib import Path

import numpy as np
import pytest

pytestmark = pytest.mark.qgis
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def run(alg, params):
    import processing
    from qgis.core import QgsProcessingFeedback

    return processing.run(f"lidartrees:{alg}", params, feedback=QgsProcessingFeedback())


def test_metrics_cells_as_cli(qgis_app, tmp_path, data):
    import rasterio

    from lidartrees_gis.cli import main

    f = data("lidR_extdata/Megaplot.laz")
    r = run("metrics", {"INPUT": str(f), "OUTPUT": str(tmp_path / "q.tif"), "RES": 20,
                        "MIN_HEIGHT": "none", "DTM": "none"})
    assert main(["metrics", str(f), str(tmp_path / "c.tif"), "-min_height", "none", "-dtm",
                 "none", "-q"]) == 0
    with rasterio.open(r["OUTPUT"]) as q, rasterio.open(tmp_path / "c.tif") as c:
        assert q.crs.to_epsg() == 26917 and q.descriptions == c.descriptions
        assert q.descriptions[:3] == ("zmax", "zmean", "zsd")
        np.testing.assert_array_equal(q.read(), c.read())


def test_volume_layers_and_bad_input(qgis_app, tmp_path):
    import geopandas as gpd
    from qgis.core import QgsProcessingException

    from test_volume import EQ, _write_farm

    truth, _ = _write_farm(tmp_path, n_plots=9)
    out = tmp_path / "v.gpkg"
    params = {"INPUT": str(tmp_path / "farm.laz"), "PLOTS": str(tmp_path / "plots.gpkg"),
              "OUTPUT": str(out), "STANDS": str(tmp_path / "stands.gpkg"),
              "TREES_TABLE": str(tmp_path / "arvores.csv"), "PLOT_RADIUS": 11.28,
              "VOLUME_EQUATION": EQ, "RESAMPLES": 100}
    # the id fields as the dialog's field pickers give them, a stand table beside
    r = run("volume", {**params, "PLOT_ID": "parcela", "STAND_ID": "talhao",
                       "STAND_CSV": str(tmp_path / "talhoes.csv")})
    st = gpd.read_file(out, layer="stands")
    assert len(st) == 6 and st["n_plots"].sum() == 9
    assert list(st["stand_id"]) == [f"T{k}" for k in range(1, 7)]
    err = st["volume_m3_ha"].to_numpy() / truth["stands"]["volume_m3_ha"] - 1
    assert np.abs(err).max() < 0.15
    # the files beside the GeoPackage are the algorithm's declared outputs
    assert r["RASTER"] == str(tmp_path / "v_volume.tif") and Path(r["RASTER"]).exists()
    assert r["JSON"] == str(tmp_path / "v_report.json") and Path(r["JSON"]).exists()
    assert r["PNG"] == str(tmp_path / "v_report.png") and Path(r["PNG"]).exists()
    assert r["STAND_CSV"] == str(tmp_path / "talhoes.csv")
    lines = (tmp_path / "talhoes.csv").read_text(encoding="utf-8-sig").splitlines()
    assert len(lines) == 8 and lines[-1].split(lines[0][len("stand_id")])[0] == '"total"'
    # run and loaded as from the toolbox, both approaches: the stands, the plots (styled:
    # outlined and labelled) and the trees join the project
    import processing
    from qgis.core import QgsProject

    both = tmp_path / "both.gpkg"
    processing.runAndLoadResults("lidartrees:volume", {**params, "OUTPUT": str(both),
                                                       "APPROACH": "both"})
    names = {ly.name(): ly for ly in QgsProject.instance().mapLayers().values()
             if str(both) in ly.source()}  # this run's (other tests load tree_tops too)
    assert {"stands", "plots", "tree_tops"} <= set(names), sorted(names)
    assert names["plots"].labelsEnabled() and names["plots"].featureCount() == 9
    assert names["tree_tops"].featureCount() > 10000
    plots = gpd.read_file(both, layer="plots")
    assert str(plots["n_trees"].dtype).startswith("int")
    gpd.read_file(tmp_path / "plots.gpkg").iloc[:3].to_file(tmp_path / "three.gpkg")
    bad = tmp_path / "bad.gpkg"
    with pytest.raises(QgsProcessingException, match="at least 5") as e:
        run("volume", {**params, "PLOTS": str(tmp_path / "three.gpkg"), "OUTPUT": str(bad)})
    assert "\n" not in str(e.value).strip()
    assert not bad.exists() and not list(tmp_path.glob("bad_*"))


def test_volume_dialog_pickers_and_help(qgis_app):
    """The id fields are pickers over their layer's fields, the trees table a file picker
    that offers workbooks; the help speaks of the dialog's labels, not the command's flags."""
    from qgis.core import QgsApplication, QgsProcessingOutputFile, QgsProcessingOutputRasterLayer

    alg = QgsApplication.processingRegistry().algorithmById("lidartrees:volume")
    d = {p.name(): p for p in alg.parameterDefinitions()}
    assert d["PLOT_ID"].type() == "field" and d["PLOT_ID"].parentLayerParameterName() == "PLOTS"
    assert d["STAND_ID"].type() == "field" and \
        d["STAND_ID"].parentLayerParameterName() == "STANDS"
    assert d["TREES_TABLE"].type() == "file" and "*.xlsx" in d["TREES_TABLE"].fileFilter()
    trees = QgsApplication.processingRegistry().algorithmById("lidartrees:trees")
    assert {p.name(): p for p in trees.parameterDefinitions()}["STAND_ID"] \
        .parentLayerParameterName() == "STANDS"
    outs = {o.name(): o for o in alg.outputDefinitions()}
    assert isinstance(outs["RASTER"], QgsProcessingOutputRasterLayer)
    assert isinstance(outs["JSON"], QgsProcessingOutputFile) and "PNG" in outs
    help_ = alg.shortHelpString()
    assert "-trees_table" not in help_ and "-plot_radius" not in help_
    assert "<b>Stand id field</b> (STAND_ID)" in help_
