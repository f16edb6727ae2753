"""Issue 27: a GeoPackage from `trees`, opened as a manager would (a fresh layer in QGIS, no
provider, no plugin), shows the project's styles: they travel inside the file."""
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT.parent / "shared" / "data"


@pytest.mark.qgis
@pytest.mark.realdata
def test_trees_geopackage_opens_styled_in_qgis(qgis_app, tmp_path):
    from qgis.core import QgsApplication, QgsVectorLayer

    f = DATA / "lidR_extdata" / "MixedConifer.laz"
    if not f.exists():
        pytest.skip("no shared data")
    out = tmp_path / "arvores.gpkg"
    exe = ROOT / ".venv" / "bin" / "lidartrees"
    cmd = [str(exe)] if exe.exists() else [sys.executable, "-m", "lidartrees_gis.cli"]
    subprocess.run(cmd + ["trees", str(f), str(out), "-nln", "talhao1_", "-q"], check=True)
    warnings = []
    QgsApplication.messageLog().messageReceived.connect(
        lambda msg, tag, level: warnings.append(msg))
    for layer, renderer, field in (("talhao1_tree_tops", "graduatedSymbol", "height"),
                                   ("talhao1_crowns", "graduatedSymbol", "crown_diameter")):
        lyr = QgsVectorLayer(f"{out}|layername={layer}", layer, "ogr")
        assert lyr.isValid(), layer
        r = lyr.renderer()
        assert r.type() == renderer and r.classAttribute() == field, (layer, r.type())
        assert len(r.ranges()) >= 5
    summary = QgsVectorLayer(f"{out}|layername=talhao1_summary", "s", "ogr")
    assert summary.isValid() and summary.featureCount() == 1
    assert not [w for w in warnings if "1.4" in w or "partially supported" in w]


def _xyz_stand(tmp_path):
    """A small synthetic stand as seed 000's text (no CRS: the XYZ needs one given)."""
    from lidartrees_gis.synthetic import StandParams, make_stand, write_xyz_seed_dialect

    pts, _ = make_stand(StandParams(width=30, height=30))
    f = tmp_path / "voo.xyz"
    write_xyz_seed_dialect(f, pts)
    return f


@pytest.mark.qgis
def test_qgis_rough_edges(qgis_app, tmp_path):
    """Every CRS spelling the CLI takes ('SAD69 24K') works in the CRS parameter; outputs load
    under their file names; the log has no `None` lines; an unknown parameter id is refused."""
    import processing
    from qgis.core import (QgsProcessingContext, QgsProcessingException,
                           QgsProcessingFeedback, QgsProject)

    f = _xyz_stand(tmp_path)

    class Recording(QgsProcessingFeedback):
        def __init__(self):
            super().__init__()
            self.lines = []

        def pushInfo(self, text):  # noqa: N802
            self.lines.append(text)

    fb = Recording()
    chm = tmp_path / "altura_copas.tif"
    ctx = QgsProcessingContext()
    ctx.setProject(QgsProject.instance())
    res = processing.run("lidartrees:chm", {"INPUT": str(f), "OUTPUT": str(chm),
                                           "A_SRS": "SAD69 24K"}, context=ctx, feedback=fb)
    import rasterio

    with rasterio.open(res["OUTPUT"]) as ds:
        assert ds.crs.to_epsg() == 29194
    assert not [ln for ln in fb.lines if ln.rstrip().endswith(": None")]
    assert ctx.willLoadLayerOnCompletion(str(chm)) is False or \
        ctx.layerToLoadOnCompletionDetails(str(chm)).name == "altura_copas"
    processing.runAndLoadResults("lidartrees:chm", {"INPUT": str(f), "A_SRS": "SAD69 24K",
                                                    "OUTPUT": str(tmp_path / "chm_talhao.tif")})
    assert QgsProject.instance().mapLayersByName("chm_talhao")
    with pytest.raises(QgsProcessingException, match="RESOLUTION"):
        processing.run("lidartrees:chm", {"INPUT": str(f), "OUTPUT": str(tmp_path / "x.tif"),
                                          "A_SRS": "EPSG:29194", "RESOLUTION": "0.5"})
    assert not (tmp_path / "x.tif").exists()
    with pytest.raises(QgsProcessingException, match="SAD69 99Z|CRS"):
        processing.run("lidartrees:chm", {"INPUT": str(f), "OUTPUT": str(tmp_path / "y.tif"),
                                          "A_SRS": "SAD69 99Z"})


@pytest.mark.qgis
@pytest.mark.parametrize("top", [9.0, 23.4, 34.0, 38.0, 47.0, 71.0])
def test_chm_style_gives_every_class_its_own_colour(qgis_app, tmp_path, top):
    """The CHM style re-fitted to a layer's range: every class a colour of its own, clearly
    apart from the others (two classes, 10-15 and 15-20 m, once shared one)."""
    import itertools

    import numpy as np
    import rasterio
    from qgis.core import QgsRasterLayer
    from rasterio.transform import from_origin

    from provider.algorithm import fit_chm_classes

    f = tmp_path / "chm.tif"
    a = np.linspace(0, top, 100 * 100).reshape(100, 100).astype("float32")
    with rasterio.open(f, "w", driver="GTiff", width=100, height=100, count=1, dtype="float32",
                       crs="EPSG:31984", transform=from_origin(0, 100, 1, 1)) as ds:
        ds.write(a, 1)
    lyr = QgsRasterLayer(str(f), "chm")
    msg, ok = lyr.loadNamedStyle(str(ROOT / "styles" / "chm.qml"))
    assert ok, msg
    limits = fit_chm_classes(lyr)
    items = lyr.renderer().shader().rasterShaderFunction().colorRampItemList()
    assert len(items) == len(limits) >= 2 and items[-1].value >= top
    rgb = [(it.color.red(), it.color.green(), it.color.blue()) for it in items]
    gaps = [np.linalg.norm(np.subtract(p, q)) for p, q in itertools.combinations(rgb, 2)]
    assert min(gaps) >= 20, (top, rgb)


def _render(layer, width, height):
    """The layer drawn by QGIS's map renderer at ``width`` x ``height`` pixels over its extent,
    as a grey-level array."""
    import numpy as np
    from qgis.core import QgsMapRendererSequentialJob, QgsMapSettings
    from qgis.PyQt.QtCore import QSize
    from qgis.PyQt.QtGui import QColor

    ms = QgsMapSettings()
    ms.setLayers([layer])
    ms.setDestinationCrs(layer.crs())
    ms.setExtent(layer.extent())
    ms.setOutputSize(QSize(width, height))
    ms.setBackgroundColor(QColor(255, 255, 255))
    job = QgsMapRendererSequentialJob(ms)
    job.start()
    job.waitForFinished()
    img = job.renderedImage()
    ptr = img.constBits()
    ptr.setsize(img.byteCount())
    a = np.frombuffer(ptr, np.uint8).reshape(img.height(), img.bytesPerLine() // 4, 4)
    return a[:, :width, :3].mean(axis=2)  # BGRA -> grey


@pytest.mark.qgis
@pytest.mark.parametrize("zoom", [1, 3])
def test_dtm_hillshade_style_matches_gdaldem(qgis_app, tmp_path, zoom):
    """The DTM style is the hillshade `gdaldem hillshade` draws (azimuth 315°, altitude 45°, z
    factor 1, one light), smooth when zoomed in: the data are resampled bilinearly before the
    shading (shading nearest-neighbour blocks drew stripes)."""
    import numpy as np
    import rasterio
    from osgeo import gdal
    from qgis.core import QgsRasterLayer
    from rasterio.transform import from_origin
    from scipy import ndimage

    n = 120
    yy, xx = np.mgrid[0:n, 0:n] + 0.5
    dtm = 600 + 8 * np.sin(xx / 17) * np.cos(yy / 23) + 0.05 * xx  # hills, 1 m cells
    f = tmp_path / "dtm.tif"
    with rasterio.open(f, "w", driver="GTiff", width=n, height=n, count=1, dtype="float32",
                       crs="EPSG:31984", transform=from_origin(0, n, 1, 1)) as ds:
        ds.write(dtm.astype("float32"), 1)
    ref = tmp_path / "hs.tif"
    gdal.DEMProcessing(str(ref), str(f), "hillshade", azimuth=315, altitude=45, zFactor=1,
                       computeEdges=True)
    with rasterio.open(ref) as ds:
        want = ds.read(1).astype(float)
    lyr = QgsRasterLayer(str(f), "dtm")
    msg, ok = lyr.loadNamedStyle(str(ROOT / "styles" / "dtm_hillshade.qml"))
    assert ok, msg
    got = _render(lyr, n * zoom, n * zoom)
    if zoom > 1:  # gdaldem on the grid, upsampled bilinearly to the rendered pixels
        want = ndimage.zoom(want, zoom, order=1)
    inner = (slice(4 * zoom, -4 * zoom),) * 2
    d = got[inner] - want[inner]
    assert np.abs(d).mean() < 6, np.abs(d).mean()
    # no stripes: the rendered shading varies as smoothly as gdaldem's from pixel to pixel
    rough_got = np.abs(np.diff(got[inner], axis=0)).mean() + np.abs(np.diff(got[inner], axis=1)).mean()
    rough_want = np.abs(np.diff(want[inner], axis=0)).mean() + np.abs(np.diff(want[inner], axis=1)).mean()
    assert rough_got < 1.5 * rough_want + 0.5, (rough_got, rough_want)
