import json
import os
import re
import subprocess
import sys
import zipfile
from pathlib import Path

import geopandas as gpd
import numpy as np
import pytest
import rasterio

from lidartrees_gis.cli import build_parser, main
from lidartrees_gis.cli.commands import COMMANDS

pytestmark = pytest.mark.qgis
ROOT = Path(__file__).resolve().parents[2]


def run(alg, params, feedback=None):
    import processing
    from qgis.core import QgsProcessingFeedback

    return processing.run(f"lidartrees:{alg}", params, feedback=feedback or QgsProcessingFeedback())


def test_provider_lists_every_command(qgis_app):
    from qgis.core import QgsApplication

    prov = QgsApplication.processingRegistry().providerById("lidartrees")
    assert prov is not None and prov.name() == "LiDAR Trees"
    assert {a.name() for a in prov.algorithms()} == set(COMMANDS)
    for a in prov.algorithms():
        ok, msg = a.canExecute()
        assert ok, msg
        assert a.group() and a.shortHelpString()
        if a.name() != "demo" and a.name() != "info":
            assert "Reference:" in a.shortHelpString(), a.name()


def test_every_algorithm_has_the_cli_parameters(qgis_app):
    """Provider and CLI cannot drift: same names, same defaults, same choices."""
    from qgis.core import QgsApplication, QgsProcessingParameterEnum

    sub = build_parser()._subparsers._group_actions[0].choices
    for alg in QgsApplication.processingRegistry().providerById("lidartrees").algorithms():
        cli = {a.dest: a for a in sub[alg.name()]._actions
               if a.dest not in ("help", "quiet", "json", "progress_lines", "result_json")}
        qg = {d.name().lower(): d for d in alg.parameterDefinitions()}
        if "input_layer" in qg:  # the point-cloud layer alternative to the INPUT file
            assert qg.pop("input_layer").type() == "pointcloud" and "input" in qg
        assert set(qg) == set(cli), alg.name()
        for name, d in qg.items():
            a = cli[name]
            if isinstance(d, QgsProcessingParameterEnum):
                assert d.usesStaticStrings() and list(d.options()) == list(a.choices)
                assert d.defaultValue() == a.default
            elif d.type() == "number":
                if a.default is None:
                    assert d.defaultValue() is None
                else:
                    assert d.defaultValue() == pytest.approx(float(a.default))


def test_chm_matches_cli(qgis_app, tmp_path, data):
    f = data("lasR_bcts/bcts_1.laz")
    r = run("chm", {"INPUT": str(f), "OUTPUT": str(tmp_path / "q.tif"), "RES": "0.5"})
    assert main(["chm", str(f), str(tmp_path / "c.tif"), "-tr", "0.5", "-q"]) == 0
    with rasterio.open(r["OUTPUT"]) as q, rasterio.open(tmp_path / "c.tif") as c:
        assert q.crs.to_epsg() == 3005
        np.testing.assert_array_equal(q.read(1), c.read(1))


def test_trees_same_trees_as_cli(qgis_app, tmp_path, data):
    f = data("lidR_extdata/MixedConifer.laz")
    q = tmp_path / "q.gpkg"
    r = run("trees", {"INPUT": str(f), "OUTPUT": str(q), "RES": "0.5", "METHOD": "watershed",
                      "SMOOTH": "abefec:rhombus"})
    c = tmp_path / "c.gpkg"
    assert main(["trees", str(f), str(c), "-tr", "0.5", "-method", "watershed", "-smooth",
                 "abefec:rhombus", "-q"]) == 0
    qt, ct = gpd.read_file(q, layer="tree_tops"), gpd.read_file(c, layer="tree_tops")
    assert r["TREES"] == len(qt) == len(ct)
    assert set(qt.tree_id) == set(ct.tree_id)
    qc = gpd.read_file(q, layer="crowns")
    assert qc.crs.to_epsg() == 26912 and set(qc.tree_id) == set(qt.tree_id)
    assert {"tree_id", "height", "crown_area", "crown_diameter"} <= set(qc.columns)


def test_info_grid_compare_demo(qgis_app, tmp_path, data):
    f = data("lasR_bcts/bcts_2.laz")
    r = run("info", {"INPUT": str(f)})
    assert r["POINTS"] == 823945 and json.loads(r["JSON"])["crs"].startswith("EPSG:3005")
    r = run("grid", {"INPUT": str(f), "OUTPUT": str(tmp_path / "n.tif"), "RES": "1", "STAT": "count"})
    with rasterio.open(r["OUTPUT"]) as ds:
        assert int(ds.read(1).sum()) == 823945
    r = run("compare", {"INPUT": str(data("lidR_extdata/MixedConifer.laz")),
                        "OUTPUT": str(tmp_path / "t.csv"), "RES": "0.5"})
    assert len(Path(r["OUTPUT"]).read_text().strip().splitlines()) == 11
    r = run("demo", {"OUTDIR": str(tmp_path / "demo")})
    with rasterio.open(tmp_path / "demo" / "chm.tif") as ds:
        assert ds.crs.to_epsg() == 29194


def test_library_error_becomes_processing_exception(qgis_app, tmp_path, data):
    from qgis.core import QgsProcessingException

    with pytest.raises(QgsProcessingException, match="'Cell size \\(m\\)': resolution") as e:
        run("chm", {"INPUT": str(data("lasR_bcts/bcts_1.laz")), "OUTPUT": str(tmp_path / "x.tif"),
                    "RES": "-1"})
    assert "-tr" not in str(e.value)  # QGIS words, not CLI flags
    assert not (tmp_path / "x.tif").exists()
    out = tmp_path / "exists.tif"
    out.write_bytes(b"x")
    with pytest.raises(QgsProcessingException) as e:
        run("chm", {"INPUT": str(data("lasR_bcts/bcts_1.laz")), "OUTPUT": str(out)})
    assert "-overwrite" not in str(e.value) and "'Replace existing outputs'" in str(e.value)


def test_parameter_labels_are_readable(qgis_app):
    from qgis.core import QgsApplication

    for alg in QgsApplication.processingRegistry().providerById("lidartrees").algorithms():
        for d in alg.parameterDefinitions():
            label, name = d.description(), d.name().lower()
            mechanical = name.replace("_", " ").capitalize()
            if name in ("a_srs", "t_srs", "dtm", "chm", "res", "dtm_out", "dsm_out", "chm_out",
                        "allow_no_crs", "w_growth", "tin_cell", "gshift", "treex_centred"):
                assert label.split(" (")[0] != mechanical, (alg.name(), name, label)
            assert not re.search(r"seed \d", label.lower()), (alg.name(), label)
        # names and help cite authors, not the project's seed numbers
        for text in (alg.displayName(), alg.shortHelpString()):
            assert not re.search(r"seed \d", text.lower()), (alg.name(), text)
    chm = QgsApplication.processingRegistry().algorithmById("lidartrees:chm")
    labels = {d.name().lower(): d.description() for d in chm.parameterDefinitions()}
    assert labels["a_srs"] == "CRS of the input (assign)" and labels["dtm"] == "Terrain model (DTM)"


def test_progress_moves_and_cancel_leaves_no_output(qgis_app, tmp_path, data):
    from qgis.core import QgsProcessingFeedback

    f = str(data("lasR_bcts/bcts_3.laz"))
    fb = QgsProcessingFeedback()
    seen = []
    fb.progressChanged.connect(seen.append)
    run("chm", {"INPUT": f, "OUTPUT": str(tmp_path / "a.tif"), "RES": "0.5"}, fb)
    assert max(seen) == pytest.approx(100) and len(set(seen)) > 3

    class CancelSoon(QgsProcessingFeedback):
        pass

    fb2 = CancelSoon()
    fb2.progressChanged.connect(lambda v: fb2.cancel() if v > 10 else None)
    out = tmp_path / "b.tif"
    r = run("chm", {"INPUT": f, "OUTPUT": str(out), "RES": "0.5"}, fb2)
    assert r == {} or not out.exists()
    assert not out.exists()
    assert not [p for p in tmp_path.iterdir() if ".part" in p.name]


def test_styles_load_and_apply_to_loaded_outputs(qgis_app, tmp_path, data):
    import processing
    from qgis.core import QgsProject, QgsRasterLayer, QgsVectorLayer

    chm = tmp_path / "chm.tif"
    assert main(["chm", str(data("lasR_bcts/bcts_1.laz")), str(chm), "-tr", "2", "-q"]) == 0
    for qml in ("chm.qml", "dtm_hillshade.qml"):
        lyr = QgsRasterLayer(str(chm), "r")
        msg, ok = lyr.loadNamedStyle(str(ROOT / "styles" / qml))
        assert ok, msg
    processing.runAndLoadResults("lidartrees:trees", {
        "INPUT": str(data("lidR_extdata/MixedConifer.laz")), "OUTPUT": str(tmp_path / "t.gpkg"),
        "RES": "0.5", "SMOOTH": "gauss5"})
    crowns = QgsProject.instance().mapLayersByName("crowns")
    tops = QgsProject.instance().mapLayersByName("tree_tops")
    assert crowns and tops
    assert crowns[0].renderer().type() == "graduatedSymbol"
    assert crowns[0].renderer().classAttribute() == "crown_diameter"
    assert tops[0].renderer().classAttribute() == "height"
    v = QgsVectorLayer(f"{tmp_path / 't.gpkg'}|layername=tree_tops", "v", "ogr")
    msg, ok = v.loadNamedStyle(str(ROOT / "styles" / "tree_tops.qml"))
    assert ok, msg


def test_plugin_zip_installs_and_runs_in_qgis_process(qgis_app, tmp_path, data):
    sys.path.insert(0, str(ROOT / "scripts"))
    from build_plugin import build

    z = build(tmp_path / "lidartrees_qgis.zip")
    plugins = tmp_path / "plugins"
    with zipfile.ZipFile(z) as zf:
        zf.extractall(plugins)
    import configparser

    import lidartrees_gis

    meta = configparser.ConfigParser()
    meta.read(plugins / "lidartrees_qgis" / "metadata.txt", encoding="utf-8")
    g = meta["general"]
    # true metadata: the package's version, how the plugin really finds the command, no
    # placeholder links (the project has no public repository yet, so none are given)
    assert g["version"] == lidartrees_gis.__version__ and g["qgisMinimumVersion"] == "3.22"
    assert "~/.venvs/lidartrees" in g["about"] and "subprocess" in g["about"]
    assert "example." not in open(plugins / "lidartrees_qgis" / "metadata.txt").read()
    for key in ("homepage", "repository", "tracker"):
        assert not g.get(key, "") or g[key].startswith("https://"), key
    lic = (plugins / "lidartrees_qgis" / "LICENSE").read_text()
    assert "GNU GENERAL PUBLIC LICENSE" in lic and "Version 3" in lic
    home = tmp_path / "home"
    home.mkdir(mode=0o700)
    # a fresh profile; the plugin finds the lidartrees command through LIDARTREES_EXE
    env = dict(os.environ, QGIS_PLUGINPATH=str(plugins), HOME=str(home), XDG_RUNTIME_DIR=str(home),
               QT_QPA_PLATFORM="offscreen")
    env.pop("PYTHONPATH", None)
    qp = "/usr/bin/qgis_process.bin"
    if not os.path.exists(qp):
        pytest.skip("qgis_process.bin not installed (Debian package qgis)")
    r = subprocess.run([qp, "plugins", "enable", "lidartrees_qgis"], env=env, capture_output=True,
                       text=True, timeout=120)
    assert r.returncode == 0, r.stdout + r.stderr
    r = subprocess.run([qp, "list"], env=env, capture_output=True, text=True, timeout=120)
    for name in COMMANDS:
        assert f"lidartrees:{name}" in r.stdout, r.stdout[-2000:] + r.stderr[-2000:]
    out = tmp_path / "qp.gpkg"
    r = subprocess.run([qp, "--json", "run", "lidartrees:trees", "--",
                        f"INPUT={data('lidR_extdata/MixedConifer.laz')}", f"OUTPUT={out}",
                        "RES=0.5", "SMOOTH=gauss5"], env=env, capture_output=True, text=True,
                       timeout=300)
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:]
    res = json.loads(r.stdout[r.stdout.index("{"):])
    assert res["results"]["TREES"] == len(gpd.read_file(out, layer="tree_tops")) > 100


def test_ground_and_dtm_quality_algorithms(qgis_app, tmp_path, data):
    import laspy

    f = data("isprs_filtertest_dev/samp21-utm.laz")
    r = run("ground", {"INPUT": str(f), "OUTPUT": str(tmp_path / "g.laz"),
                       "DTM_OUT": str(tmp_path / "dtm.tif")})
    cls = np.asarray(laspy.read(r["OUTPUT"]).classification)
    assert cls.size == 12960 and (cls == 2).sum() > 5000
    c = tmp_path / "c.laz"
    assert main(["ground", str(f), str(c), "-q"]) == 0
    assert ((np.asarray(laspy.read(c).classification) == 2) == (cls == 2)).all()
    with rasterio.open(r["DTM_OUT"]) as ds:
        assert ds.crs.to_epsg() == 32632
    r = run("dtm-quality", {"INPUT": str(f), "OUTDIR": str(tmp_path / "q"), "G": "-2:-1:0.5",
                            "W": "1:2:0.5", "RES": "2"})
    rows = (tmp_path / "q" / "dtm_quality.csv").read_text().strip().splitlines()
    assert len(rows) == 10


def test_stem_and_profile_algorithms(qgis_app, tmp_path, data):
    f = data("TreeLS_tls/pine.laz")
    r = run("stem", {"INPUT": str(f), "PREFIX": str(tmp_path / "stem"), "ALLOW_NO_CRS": True})
    s = json.loads((tmp_path / "stem" / "pine_summary.json").read_text())
    assert main(["stem", str(f), str(tmp_path / "cli"), "--allow-no-crs", "-q"]) == 0
    c = json.loads((tmp_path / "cli_summary.json").read_text())
    assert s["dbh_cm"] == pytest.approx(c["dbh_cm"]) and s["trunk_points"] == c["trunk_points"]
    r = run("profile", {"INPUT": str(f), "OUTPUT": str(tmp_path / "parts.laz"),
                        "ALLOW_NO_CRS": True})
    b = json.loads((tmp_path / "parts_boundaries.json").read_text())
    assert b["stem_start"] < b["canopy_start"] and Path(r["OUTPUT"]).exists()


def test_plantation_mode_loads_gaps_and_evaluate_runs(qgis_app, tmp_path, stand):
    """Issue 9 in QGIS: trees with SPACING loads a styled gaps layer; evaluate reports F."""
    import processing
    from pyproj import CRS
    from qgis.core import QgsProject

    from lidartrees_gis.io.lasout import write_points
    from lidartrees_gis.synthetic import write_truth_csv

    pts, truth = stand
    las = tmp_path / "stand.las"
    write_points(las, pts.x, pts.y, pts.z, crs=CRS.from_epsg(29194),
                 classification=pts.classification)
    gpkg = tmp_path / "t.gpkg"
    res = processing.runAndLoadResults("lidartrees:trees", {
        "INPUT": str(las), "OUTPUT": str(gpkg), "SPACING": "3x2"})
    assert res["TREES"] > 560
    gaps = QgsProject.instance().mapLayersByName("gaps")
    assert gaps and gaps[0].featureCount() >= 8 and gaps[0].crs().authid() == "EPSG:29194"
    rend = gaps[0].renderer()
    assert rend.type() == "categorizedSymbol" and rend.classAttribute() == "status"
    assert {c.value() for c in rend.categories()} == {"missing", "suppressed", "uncertain"}
    # every feature falls in a category, with the evidence beside it
    fields = gaps[0].fields().names()
    assert {"status", "crown_share", "returns"} <= set(fields)
    assert {f["status"] for f in gaps[0].getFeatures()} <= {"missing", "suppressed", "uncertain"}
    ref = tmp_path / "truth.csv"
    write_truth_csv(ref, truth)
    rep = tmp_path / "report.json"
    run("evaluate", {"DETECTED": str(gpkg), "REFERENCE": str(ref), "REPORT": str(rep)})
    r = json.loads(rep.read_text())
    assert r["all"]["f_score"] >= 0.97 and r["all"]["reference"] == len(truth["x"])


def test_data_warnings_reach_the_feedback_as_warnings(qgis_app, tmp_path):
    """Plantation mode on 2 pts/m²: the CLI's warning that the stocking is unreliable is a
    warning in QGIS's log, not console noise."""
    from pyproj import CRS
    from qgis.core import QgsProcessingFeedback

    from lidartrees_gis.io.lasout import write_points
    from lidartrees_gis.synthetic import StandParams, make_stand

    pts, _ = make_stand(StandParams(seed=3, density=2.0))
    las = tmp_path / "sparse.las"
    write_points(las, pts.x, pts.y, pts.z, crs=CRS.from_epsg(29194),
                 classification=pts.classification)

    class Recording(QgsProcessingFeedback):
        def __init__(self):
            super().__init__()
            self.warnings = []

        def pushWarning(self, text):  # noqa: N802
            self.warnings.append(text)

    fb = Recording()
    res = run("trees", {"INPUT": str(las), "OUTPUT": str(tmp_path / "t.gpkg"), "SPACING": "3x2"},
              fb)
    assert res["TREES"] > 400
    assert len(fb.warnings) == 1 and "stocking and the gaps are unreliable" in fb.warnings[0]


def test_ground_declares_a_las_output_and_takes_a_temporary_one(qgis_app, tmp_path, data):
    import laspy
    from qgis.core import QgsApplication, QgsProcessingParameterFileDestination

    alg = QgsApplication.processingRegistry().algorithmById("lidartrees:ground")
    out = alg.parameterDefinition("OUTPUT")
    assert isinstance(out, QgsProcessingParameterFileDestination)
    assert out.defaultFileExtension() == "laz" and "*.las" in out.fileFilter()
    f = data("isprs_filtertest_dev/samp21-utm.laz")
    r = run("ground", {"INPUT": str(f), "OUTPUT": "TEMPORARY_OUTPUT"})
    assert r["OUTPUT"].endswith(".laz") and os.path.exists(r["OUTPUT"])
    cls = np.asarray(laspy.read(r["OUTPUT"]).classification)
    assert cls.size == 12960 and (cls == 2).sum() > 5000


def test_a_loaded_point_cloud_layer_is_an_input(qgis_app, tmp_path, data):
    """A point cloud loaded in QGIS 3.22 is an EPT index (what QGIS builds for a LAS/LAZ) or the
    LAS/LAZ itself (PDAL layers): either one is read through the layer's source."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from ept_util import write_ept
    from qgis.core import QgsPointCloudLayer, QgsProcessingException, QgsProject

    f = data("lasR_bcts/bcts_1.laz")
    ept = write_ept(f, tmp_path / "ept_bcts_1")
    layer = QgsPointCloudLayer(str(ept), "bcts_1", "ept")
    assert layer.isValid()
    QgsProject.instance().addMapLayer(layer)
    try:
        r = run("chm", {"INPUT_LAYER": layer.id(), "OUTPUT": str(tmp_path / "q.tif"),
                        "TILE_SIZE": "none"})
    finally:
        QgsProject.instance().removeMapLayer(layer.id())
    assert main(["chm", str(f), str(tmp_path / "c.tif"), "-q"]) == 0
    with rasterio.open(r["OUTPUT"]) as q, rasterio.open(tmp_path / "c.tif") as c:
        assert q.crs.to_epsg() == 3005 and q.transform == c.transform
        np.testing.assert_array_equal(q.read(1), c.read(1))  # the same points, the same CHM
    # a PDAL layer's source is the LAS/LAZ (no PDAL in Debian's QGIS: the layer is not valid
    # here, but its source is what the algorithm reads)
    las_layer = QgsPointCloudLayer(str(f), "bcts_1 las", "pdal")
    r = run("info", {"INPUT_LAYER": las_layer})
    assert r["POINTS"] == 531662
    with pytest.raises(QgsProcessingException, match="point-cloud layer loaded in QGIS"):
        run("info", {})
    # info takes what the commands take (issue 27): an EPT index is a catalog of its nodes
    r = run("info", {"INPUT_LAYER": QgsPointCloudLayer(str(ept), "e", "ept")})
    assert r["POINTS"] == 531662 and json.loads(r["JSON"])["files"] > 1


def test_algorithms_leave_no_resource_warning(qgis_app, tmp_path, data):
    """Every file, pipe and process an algorithm opens is closed (ResourceWarning otherwise)."""
    import gc
    import warnings

    f = data("lasR_bcts/bcts_2.laz")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ResourceWarning)
        run("info", {"INPUT": str(f)})
        run("trees", {"INPUT": str(f), "OUTPUT": str(tmp_path / "t.gpkg")})
        with pytest.raises(Exception):
            run("chm", {"INPUT": str(tmp_path / "missing.laz"), "OUTPUT": str(tmp_path / "c.tif")})
        gc.collect()
    res = [w for w in caught if issubclass(w.category, ResourceWarning)]
    assert not res, [str(w.message) for w in res]


def test_styles_render_readably_on_the_chm(qgis_app, tmp_path, data):
    """Run trees from the toolbox with the outputs loaded, render CHM, crowns and tops through
    PyQGIS to a PNG (kept for a look: tests/qgis/... tmp folder) and check what a reader sees:
    the CHM classes fitted to its own range, tops and crowns in hues the CHM does not have."""
    import processing
    from PIL import Image
    from qgis.core import (QgsMapRendererSequentialJob, QgsMapSettings, QgsProject,
                           QgsRasterLayer)
    from qgis.PyQt.QtCore import QSize

    QgsProject.instance().removeAllMapLayers()
    chm_path = tmp_path / "chm.tif"
    processing.runAndLoadResults("lidartrees:trees", {
        "INPUT": str(data("lidR_extdata/MixedConifer.laz")), "OUTPUT": str(tmp_path / "t.gpkg"),
        "CHM_OUT": str(chm_path)})
    layers = {lyr.name(): lyr for lyr in QgsProject.instance().mapLayers().values()}
    chm = next(lyr for lyr in layers.values()
               if isinstance(lyr, QgsRasterLayer) and lyr.source() == str(chm_path))
    items = chm.renderer().shader().rasterShaderFunction().colorRampItemList()
    top = chm.dataProvider().bandStatistics(1).maximumValue
    limits = [it.value for it in items]
    # a few classes of a round width, the last one just above the CHM's highest cell
    assert 3 <= len(items) <= 7 and limits[-1] >= top > limits[-2]
    assert len({round(b - a, 6) for a, b in zip([0] + limits, limits)}) == 1
    assert all(it.label.endswith(" m") for it in items)
    chm_rgb = np.array([[it.color.red(), it.color.green(), it.color.blue()] for it in items])

    def colours(layer):
        return np.array([[s.symbol().color().red(), s.symbol().color().green(),
                          s.symbol().color().blue()] for s in layer.renderer().ranges()])

    for name in ("tree_tops", "crowns"):
        c = colours(layers[name])
        dist = np.sqrt(((c[:, None, :] - chm_rgb[None, :, :]) ** 2).sum(-1))
        assert dist.min() > 120, (name, dist.min())  # far from every CHM class colour
    ms = QgsMapSettings()
    ms.setLayers([layers["tree_tops"], layers["crowns"], chm])
    ms.setDestinationCrs(chm.crs())
    ms.setExtent(chm.extent())
    ms.setOutputSize(QSize(900, 900))
    job = QgsMapRendererSequentialJob(ms)
    job.start()
    job.waitForFinished()
    png = tmp_path / "render.png"
    assert job.renderedImage().save(str(png), "PNG")
    QgsProject.instance().removeAllMapLayers()
    rgb = np.asarray(Image.open(png).convert("RGB")).astype(int)
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    green = (g > r + 30) & (g > b + 20)
    magenta = (r > 120) & (b > 60) & (g < 80) & (r - g > 80)
    red = (r > 150) & (g < 60) & (b < 60)
    assert green.mean() > 0.2, green.mean()
    assert magenta.mean() > 0.02 and red.sum() > 200, (magenta.mean(), red.sum())
    print("rendered", png)


def test_stands_layer_parameter_loads_a_styled_stands_layer(qgis_app, tmp_path, stand):
    """Issue 23 in QGIS: a polygon layer (a file layer, and a memory layer saved for the
    command) as STANDS; the stands layer is loaded with its outline and labels."""
    import processing
    import shapely
    from pyproj import CRS
    from qgis.core import QgsFeature, QgsGeometry, QgsProject, QgsVectorLayer

    from lidartrees_gis.io.lasout import write_points

    pts, truth = stand
    las = tmp_path / "stand.las"
    write_points(las, pts.x, pts.y, pts.z, crs=CRS.from_epsg(29194),
                 classification=pts.classification)
    x0, y0, x1, y1 = pts.x.min(), pts.y.min(), pts.x.max(), pts.y.max()
    mid = (x0 + x1) / 2
    halves = [shapely.box(x0, y0, mid, y1), shapely.box(mid, y0, x1, y1)]
    gpd.GeoDataFrame({"talhao": ["W", "E"]}, geometry=halves, crs="EPSG:29194").to_file(
        tmp_path / "talhoes.gpkg", layer="talhoes")
    file_layer = QgsVectorLayer(f"{tmp_path / 'talhoes.gpkg'}|layername=talhoes", "talhoes",
                                "ogr")
    assert file_layer.isValid()
    gpkg = tmp_path / "t.gpkg"
    res = processing.runAndLoadResults("lidartrees:trees", {
        "INPUT": str(las), "OUTPUT": str(gpkg), "STANDS": file_layer,
        "STAND_CSV": str(tmp_path / "s.csv")})
    layers = QgsProject.instance().mapLayersByName("stands")
    assert layers, "no stands layer loaded"
    lyr = layers[-1]
    assert lyr.featureCount() == 2 and lyr.crs().authid() == "EPSG:29194"
    assert lyr.labelsEnabled() and lyr.renderer().type() == "singleSymbol"
    assert "trees_per_ha" in lyr.labeling().settings().fieldName
    got = {f["stand_id"]: f["trees"] for f in lyr.getFeatures()}
    assert set(got) == {"W", "E"} and sum(got.values()) == res["TREES"]
    west = int((truth["x"] < mid).sum())
    assert abs(got["W"] - west) <= 0.03 * west
    # a memory layer has no file: it is saved for the command
    mem = QgsVectorLayer("Polygon?crs=EPSG:29194&field=stand_id:string", "mem", "memory")
    f = QgsFeature(mem.fields())
    f.setAttributes(["all"])
    f.setGeometry(QgsGeometry.fromWkt(shapely.box(x0, y0, x1, y1).wkt))
    mem.dataProvider().addFeatures([f])
    out2 = tmp_path / "m.gpkg"
    run("trees", {"INPUT": str(las), "OUTPUT": str(out2), "STANDS": mem})
    st = gpd.read_file(out2, layer="stands")
    assert list(st["stand_id"]) == ["all"] and st["trees"].iloc[0] == res["TREES"]
