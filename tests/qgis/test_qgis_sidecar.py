"""Issue 37: a CHM GeoTIFF opened in QGIS outside Processing (a fresh layer, no provider) is
styled by the .qml written beside it; a GeoPackage opened in QGIS raises no GDAL warning about
its layer_styles' update_time."""
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def _cli(*args):
    exe = ROOT / ".venv" / "bin" / "lidartrees"
    cmd = [str(exe)] if exe.exists() else [sys.executable, "-m", "lidartrees_gis.cli"]
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    subprocess.run(cmd + list(args), check=True, env=env, capture_output=True)


@pytest.fixture
def stand_las(tmp_path):
    from pyproj import CRS

    from lidartrees_gis.io.lasout import write_points
    from lidartrees_gis.synthetic import StandParams, make_stand

    pts, _ = make_stand(StandParams(width=30, height=30))
    f = tmp_path / "s.las"
    write_points(f, pts.x, pts.y, pts.z, crs=CRS.from_epsg(29194),
                 classification=pts.classification)
    return f


@pytest.mark.qgis
def test_chm_geotiff_opens_styled_and_gpkg_without_update_time_warning(qgis_app, stand_las,
                                                                        tmp_path):
    import rasterio
    from qgis.core import QgsApplication, QgsRasterLayer, QgsVectorLayer

    chm, dtm, gpkg = tmp_path / "chm.tif", tmp_path / "dtm.tif", tmp_path / "t.gpkg"
    _cli("chm", str(stand_las), str(chm), "-dtm_out", str(dtm), "-q")
    _cli("trees", str(stand_las), str(gpkg), "-q")
    lyr = QgsRasterLayer(str(chm), "chm")
    assert lyr.isValid() and lyr.renderer().type() == "singlebandpseudocolor"
    items = lyr.renderer().shader().rasterShaderFunction().colorRampItemList()
    with rasterio.open(chm) as ds:
        top = float(ds.read(1, masked=True).max())
    assert items[-1].value >= top > items[-2].value and len(items) >= 3
    assert QgsRasterLayer(str(dtm), "dtm").renderer().type() == "hillshade"
    messages = []
    QgsApplication.messageLog().messageReceived.connect(
        lambda msg, tag, level: messages.append(msg))
    styles = QgsVectorLayer(f"{gpkg}|layername=layer_styles", "styles", "ogr")
    assert styles.isValid() and styles.featureCount() >= 2
    times = [f["update_time"] for f in styles.getFeatures()]
    assert all(t is not None and str(t) for t in times)
    assert not [m for m in messages if "Non-conformant" in m or "update_time" in m], messages
