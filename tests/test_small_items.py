"""Issue 37's smaller items, each seen by a user: the QGIS plugin's install hint, the CHM's
style beside the GeoTIFF, ISO 8601 times in the GeoPackages' layer_styles, row azimuths as
one axis convention, printed figures rounded to what they mean, decimal commas in options."""
import re
import sqlite3
from pathlib import Path

import numpy as np
import pytest
from pyproj import CRS

from lidartrees_gis.cli import main

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def stand_las(tmp_path_factory):
    from lidartrees_gis.io.lasout import write_points
    from lidartrees_gis.synthetic import StandParams, make_stand

    pts, truth = make_stand(StandParams(width=40, height=40, missing_fraction=0.05))
    f = tmp_path_factory.mktemp("small") / "s.las"
    write_points(f, pts.x, pts.y, pts.z, crs=CRS.from_epsg(29194),
                 classification=pts.classification)
    return f, truth


def test_chm_and_dtm_geotiffs_get_a_style_beside_them(stand_las, tmp_path):
    import xml.etree.ElementTree as ET

    import rasterio

    f, _ = stand_las
    chm, dtm = tmp_path / "chm.tif", tmp_path / "dtm.tif"
    assert main(["chm", str(f), str(chm), "-dtm_out", str(dtm), "-q"]) == 0
    qml = tmp_path / "chm.qml"
    assert qml.exists() and (tmp_path / "dtm.qml").exists()
    items = ET.parse(qml).getroot().findall(".//colorrampshader/item")
    with rasterio.open(chm) as ds:
        top = float(ds.read(1, masked=True).max())
    limits = [float(i.get("value")) for i in items]
    assert limits[-1] >= top > limits[-2]  # the classes fit this CHM
    assert len({i.get("color") for i in items}) == len(items) and items[0].get("label") == \
        f"0 - {limits[0]:g} m"
    assert "hillshade" in (tmp_path / "dtm.qml").read_text()
    # a sidecar the user has is kept without -overwrite, replaced with it
    qml.write_text("mine")
    assert main(["chm", str(f), str(tmp_path / "chm2.tif"), "-q"]) == 0
    assert main(["chm", str(f), str(chm), "-q", "-overwrite"]) == 0
    assert qml.read_text() != "mine"
    out = tmp_path / "t.gpkg"
    assert main(["trees", str(f), str(out), "-chm_out", str(tmp_path / "c3.tif"), "-q"]) == 0
    assert (tmp_path / "c3.qml").exists()


def test_layer_styles_update_time_is_iso_8601(stand_las, tmp_path):
    f, _ = stand_las
    out = tmp_path / "t.gpkg"
    assert main(["trees", str(f), str(out), "-q"]) == 0
    con = sqlite3.connect(out)
    times = [r[0] for r in con.execute("SELECT update_time FROM layer_styles")]
    con.close()
    assert times and all(re.fullmatch(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d\.\d{3}Z", t)
                         for t in times), times


def test_row_azimuths_are_one_axis_in_0_180():
    from lidartrees_gis.plantation.stocking import axial_round, stocking_fields

    for a, want in ((179.96, 0.0), (-0.04, 0.0), (180.0, 0.0), (359.97, 0.0), (0.04, 0.0),
                    (145.04, 145.0), (-35.0, 145.0), (179.9, 179.9), (179.95, 0.0)):
        assert axial_round(a) == want, a
    st = {"expected": 10, "stocked": 9, "missing": 1, "extra": 0, "planted_area_ha": 0.1}
    assert stocking_fields((3, 2), 179.97, st)["row_azimuth"] == 0.0  # was 179.97: "180.0"
    assert f"{stocking_fields((3, 2), 179.97, st)['row_azimuth']:.1f}" == "0.0"


def test_printed_figures_are_rounded_to_what_they_mean(stand_las, tmp_path, capsys):
    import pandas as pd

    f, truth = stand_las
    out = tmp_path / "t.gpkg"
    assert main(["trees", str(f), str(out)]) == 0
    printed = capsys.readouterr().out
    ref = tmp_path / "ref.csv"
    pd.DataFrame({"x": truth["x"], "y": truth["y"], "height": truth["height"]}).to_csv(ref)
    assert main(["evaluate", str(out), str(ref)]) == 0
    printed += capsys.readouterr().out
    lines = dict(ln.split(": ", 1) for ln in printed.splitlines() if ": " in ln)

    def decimals(key):
        v = lines[key]
        return len(v.split(".")[1]) if "." in v else 0

    assert decimals("trees_per_ha") <= 1 and decimals("mean_height") <= 2
    assert decimals("all.height_bias") <= 2 and decimals("all.height_rmse") <= 2
    assert decimals("all.recall") <= 4 and decimals("all.f_score") <= 4
    assert all(len(m) <= 4 for m in re.findall(r"\.(\d+)\b", printed.split("| trees")[0])
               if m), printed


def test_decimal_commas_in_options(stand_las, tmp_path, capsys):
    import rasterio

    f, _ = stand_las
    assert main(["chm", str(f), str(tmp_path / "c.tif"), "-tr", "0,5", "-q"]) == 0
    with rasterio.open(tmp_path / "c.tif") as ds:
        assert ds.res == (0.5, 0.5)
    capsys.readouterr()
    # 3,2 is 3.2 to a pt-BR reader and 3 x 2 to others: refused with a one-line hint
    assert main(["trees", str(f), str(tmp_path / "t.gpkg"), "-spacing", "3,2", "-q"]) != 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "3x2" in err[0] and "ambiguous" in err[0]
    assert not (tmp_path / "t.gpkg").exists()
    from lidartrees_gis.als.trees import parse_spacing

    assert parse_spacing("3x2") == (3.0, 2.0) and parse_spacing("3,5x2,5") == (3.5, 2.5)
    assert parse_spacing("3 × 2") == (3.0, 2.0)
    assert main(["trees", str(f), str(tmp_path / "t.gpkg"), "-spacing", "3x2",
                 "-min_height", "2,5", "-q"]) == 0


def test_numbering_text_and_layers_give_the_same_row_azimuth(stand_las, tmp_path):
    """The summary's numbering rule once said 'at 359.9°' beside a row_azimuth of 0.0 (or
    179.95) for the same rows: both now give the axis in [0, 180) to 0.1°."""
    import pyogrio

    f, _ = stand_las
    out = tmp_path / "t.gpkg"
    assert main(["trees", str(f), str(out), "-spacing", "3x2", "-q"]) == 0
    s = pyogrio.read_dataframe(out, layer="summary").iloc[0]
    az = float(s["row_azimuth"])
    assert 0.0 <= az < 180.0 and round(az, 1) == az
    m = re.search(r"row azimuth ([0-9.]+)°", s["numbering"])
    assert m and float(m.group(1)) == az, s["numbering"]
    assert min(az, 180 - az) < 1.0  # the generator's north-south rows
