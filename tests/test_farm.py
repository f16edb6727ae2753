"""Issue 37: a farm's deliverables. The stands layer keeps the user's own attributes and id
field; an id field outside the known names is said; stands outside the points are an error;
row and plant numbers are per stand and the same in every tiling. The farm: the synthetic
stand (rows 3 m apart north-south, plants 2 m apart) 80 x 80 m, as two stands side by side."""
import datetime
import warnings

import geopandas as gpd
import numpy as np
import pyogrio
import pytest
import shapely
from pyproj import CRS

from lidartrees_gis.cli import main
from lidartrees_gis.errors import DataWarning
from lidartrees_gis.io.lasout import write_points
from lidartrees_gis.synthetic import StandParams, make_stand

SP = StandParams(width=80, height=80, density=12, slope_x=0, slope_y=0, missing_fraction=0.05,
                 seed=3)
OX, OY = SP.origin_x, SP.origin_y


@pytest.fixture(scope="module")
def farm(tmp_path_factory):
    d = tmp_path_factory.mktemp("farm")
    pts, truth = make_stand(SP)
    write_points(d / "farm.las", pts.x, pts.y, pts.z, crs=CRS.from_epsg(31984),
                 classification=pts.classification)
    geoms = [shapely.box(OX, OY, OX + 40, OY + 80), shapely.box(OX + 40, OY, OX + 80, OY + 80)]
    attrs = {"Talhão": ["T-01", "T-02"], "Espécie": ["Eucalyptus urograndis", "Pinus taeda"],
             "Clone": ["AEC 144", "—"], "Plantio": [datetime.date(2019, 3, 15),
                                                     datetime.date(2020, 11, 2)],
             "area_ha": [0.33, 0.31]}
    gpd.GeoDataFrame(attrs, geometry=geoms, crs="EPSG:31984").to_file(d / "talhoes.gpkg")
    gpd.GeoDataFrame({"NUM_TALHAO": [101, 102], "Fazenda": ["Rosa", "Rosa"]}, geometry=geoms,
                     crs="EPSG:31984").to_file(d / "num.gpkg")
    gpd.GeoDataFrame({"Fazenda": ["Rosa", "Rosa"]}, geometry=geoms,
                     crs="EPSG:31984").to_file(d / "noid.gpkg")
    far = [shapely.affinity.translate(g, 500_000, 0) for g in geoms]
    gpd.GeoDataFrame({"Talhão": ["T-01", "T-02"]}, geometry=far,
                     crs="EPSG:31984").to_file(d / "far.gpkg")
    return {"dir": d, "las": d / "farm.las", "truth": truth, "attrs": attrs}


def _trees(farm, out, *extra):
    argv = ["trees", str(farm["las"]), str(out), "-q", *extra]
    assert main(argv) == 0, argv


def test_stands_layer_keeps_the_users_attributes_and_id_field(farm):
    out = farm["dir"] / "attrs.gpkg"
    _trees(farm, out, "-stands", str(farm["dir"] / "talhoes.gpkg"), "-overwrite")
    st = pyogrio.read_dataframe(out, layer="stands")
    for name in ("stand_id", "Talhão", "Espécie", "Clone", "Plantio", "area_ha_input",
                 "area_ha", "trees_per_ha"):
        assert name in st.columns, (name, list(st.columns))
    assert st["stand_id"].tolist() == ["T-01", "T-02"] == st["Talhão"].tolist()
    assert st["Espécie"].tolist() == farm["attrs"]["Espécie"]
    assert st["Clone"].tolist() == farm["attrs"]["Clone"]
    assert [str(v)[:10] for v in st["Plantio"]] == ["2019-03-15", "2020-11-02"]
    assert st["area_ha_input"].tolist() == [0.33, 0.31]  # the register's, beside the polygon's
    assert np.allclose(st["area_ha"], [0.32, 0.32])


def test_an_unknown_id_field_is_said_and_used(farm, capsys):
    from lidartrees_gis.als.stands import load_stands

    g = gpd.read_file(farm["dir"] / "num.gpkg")
    with pytest.warns(DataWarning, match="NUM_TALHAO") as rec:
        st = load_stands(g, CRS.from_epsg(31984))
    text = str(rec[0].message)
    assert "Fazenda" in text and "-stand_id FIELD" in text
    assert st.ids == ("101", "102") and st.id_field == "NUM_TALHAO"
    with pytest.warns(DataWarning, match="numbered 1, 2.*Fazenda"):
        st = load_stands(gpd.read_file(farm["dir"] / "noid.gpkg"), CRS.from_epsg(31984))
    assert st.ids == ("1", "2")
    # -stand_id picks one without a warning
    with warnings.catch_warnings():
        warnings.simplefilter("error", DataWarning)
        st = load_stands(g, CRS.from_epsg(31984), "Fazenda")
    assert st.ids == ("Rosa",)


def test_stands_outside_the_points_are_an_error_naming_both_extents(farm, capsys):
    out = farm["dir"] / "far_out.gpkg"
    argv = ["trees", str(farm["las"]), str(out), "-q", "-stands",
            str(farm["dir"] / "far.gpkg")]
    assert main(argv) != 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no stand overlaps the points" in err[0]
    assert f"({OX + 500_000:.1f}, {OY:.1f}" in err[0]  # the stands' extent
    assert f"({OX:.1f}" in err[0].split("points extent")[1]  # and the points'
    assert not out.exists()
