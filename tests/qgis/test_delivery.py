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
