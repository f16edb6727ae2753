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
    from lidartrees_gis.plantation.stands import load_stands

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


@pytest.fixture
def locale(monkeypatch):
    """Set the locale the tables follow (``None``: none set)."""
    def set_(name):
        for var in ("LC_ALL", "LC_NUMERIC", "LANG"):
            monkeypatch.delenv(var, raising=False)
        if name:
            monkeypatch.setenv("LANG", name)
    return set_


@pytest.fixture(scope="module")
def ptbr_run(farm, tmp_path_factory):
    """A plantation run with stands in a pt_BR locale: its GeoPackage, -stand_csv and -csv."""
    import os

    d = tmp_path_factory.mktemp("ptbr")
    saved = {v: os.environ.pop(v, None) for v in ("LC_ALL", "LC_NUMERIC", "LANG")}
    os.environ["LANG"] = "pt_BR.UTF-8"
    try:
        _trees(farm, d / "t.gpkg", "-stands", str(farm["dir"] / "talhoes.gpkg"), "-spacing",
               "3x2", "-stand_csv", str(d / "talhoes.csv"), "-csv", str(d / "arvores.csv"))
    finally:
        os.environ.pop("LANG")
        os.environ.update({k: v for k, v in saved.items() if v is not None})
    return d


def _ptbr(path):
    import pandas as pd

    return pd.read_csv(path, sep=";", decimal=",", encoding="utf-8-sig",
                       dtype={"stand_id": str, "tree_id": str})


def test_stand_csv_round_trips_in_a_ptbr_spreadsheet_reading(ptbr_run):
    from lidartrees_gis.plantation.stands import STAND_DECIMALS

    raw = (ptbr_run / "talhoes.csv").read_bytes()
    assert raw.startswith(b"\xef\xbb\xbf")  # the BOM: Talhão, not TalhÃ£o
    head = raw[3:].decode("utf-8").splitlines()[0]
    assert head.split(";")[:2] == ["stand_id", "Talhão"]
    csv = _ptbr(ptbr_run / "talhoes.csv")
    layer = pyogrio.read_dataframe(ptbr_run / "t.gpkg", layer="stands", read_geometry=False)
    assert list(csv.columns) == list(layer.columns)
    assert len(csv) == 2 and csv["stand_id"].tolist() == ["T-01", "T-02"]
    for c in layer.columns:
        want, got = layer[c], csv[c]
        if c == "Plantio":
            assert [str(v)[:10] for v in want] == got.tolist()
        elif want.dtype.kind == "f":
            n = STAND_DECIMALS.get(c, 6)
            assert np.allclose(np.round(want.to_numpy(float), n), got.to_numpy(float),
                               atol=10.0 ** -n / 2, equal_nan=True), c
            text = raw[3:].decode("utf-8")
            assert "." not in text.split("\n")[1].replace("AEC 144", "")  # decimal commas
        elif want.dtype.kind in "iu":
            assert (want.to_numpy() == got.to_numpy()).all(), c
        else:
            assert want.astype(str).tolist() == got.astype(str).tolist(), c
    # rounded to what they mean: no 10-decimal figures
    for c, n in STAND_DECIMALS.items():
        if c in csv.columns:
            for t in (ptbr_run / "talhoes.csv").read_text("utf-8-sig").splitlines()[1:]:
                v = t.split(";")[list(csv.columns).index(c)]
                assert len(v.split(",")[1]) <= n if "," in v else True, (c, v)


def test_trees_csv_has_planting_row_plant_and_stand_and_text_ids(ptbr_run):
    csv = _ptbr(ptbr_run / "arvores.csv")
    assert list(csv.columns) == ["tree_id", "stand_id", "row_number", "plant_number", "x", "y",
                                 "height", "crown_diameter", "crown_area", "suppressed",
                                 "chm_row", "chm_col"]
    tops = pyogrio.read_dataframe(ptbr_run / "t.gpkg", layer="tree_tops", read_geometry=False)
    assert len(csv) == len(tops)
    csv = csv.set_index("tree_id").loc[tops["tree_id"].astype(str)]
    assert (csv["row_number"].to_numpy() == tops["row_number"].to_numpy()).all()
    assert (csv["plant_number"].to_numpy() == tops["plant_number"].to_numpy()).all()
    assert (csv["stand_id"].to_numpy() == tops["stand_id"].to_numpy()).all()
    assert np.allclose(csv["height"], tops["height"].round(2), atol=0.005)
    assert csv["row_number"].max() > 10  # planting rows, not CHM cells
    line = (ptbr_run / "arvores.csv").read_text("utf-8-sig").splitlines()[1]
    assert line.startswith('"') and len(line.split(";")[0].strip('"')) == 16  # id as text


def test_lco_options_and_plain_csv_outside_ptbr(farm, tmp_path, locale):
    import pandas as pd

    locale("en_US.UTF-8")
    base = ["-stands", str(farm["dir"] / "talhoes.gpkg"), "-overwrite"]
    _trees(farm, tmp_path / "a.gpkg", *base, "-stand_csv", str(tmp_path / "plain.csv"))
    raw = (tmp_path / "plain.csv").read_bytes()
    assert not raw.startswith(b"\xef\xbb\xbf") and raw.split(b"\r\n")[0].count(b",") > 10
    plain = pd.read_csv(tmp_path / "plain.csv")
    _trees(farm, tmp_path / "b.gpkg", *base, "-stand_csv", str(tmp_path / "semi.csv"),
           "-lco", "SEPARATOR=SEMICOLON", "-lco", "DECIMAL=COMMA", "-lco", "WRITE_BOM=YES")
    semi = _ptbr(tmp_path / "semi.csv")
    assert (tmp_path / "semi.csv").read_bytes().startswith(b"\xef\xbb\xbf")
    pd.testing.assert_frame_equal(plain, semi, check_dtype=False)
    locale("pt_BR.UTF-8")  # -lco wins over the locale
    _trees(farm, tmp_path / "c.gpkg", *base, "-stand_csv", str(tmp_path / "c.csv"), "-lco",
           "SEPARATOR=COMMA", "-lco", "WRITE_BOM=NO")
    pd.testing.assert_frame_equal(plain, pd.read_csv(tmp_path / "c.csv"), check_dtype=False)
    assert main(["trees", str(farm["las"]), str(tmp_path / "d.gpkg"), "-q", "-stand_csv",
                 str(tmp_path / "d.csv"), *base, "-lco", "DECIMAL=VIRGULA"]) != 0


def test_stand_csv_as_a_workbook(farm, tmp_path, locale):
    import pandas as pd

    locale(None)
    out = tmp_path / "talhoes.xlsx"
    _trees(farm, tmp_path / "a.gpkg", "-stands", str(farm["dir"] / "talhoes.gpkg"),
           "-stand_csv", str(out), "-csv", str(tmp_path / "arvores.xlsx"))
    book = pd.read_excel(out, dtype={"stand_id": str})
    assert book["stand_id"].tolist() == ["T-01", "T-02"]
    assert book["Espécie"].tolist() == farm["attrs"]["Espécie"]
    import openpyxl

    sheet = openpyxl.load_workbook(tmp_path / "arvores.xlsx").active
    ids = [c.value for c in sheet["A"][1:]]
    assert all(c.data_type == "s" for c in sheet["A"])  # text cells: every digit kept
    tops = pyogrio.read_dataframe(tmp_path / "a.gpkg", layer="tree_tops", read_geometry=False)
    assert set(ids) == set(tops["tree_id"].astype(str)) and len(ids) == len(tops)


def test_evaluate_pairs_follow_the_table_options(farm, tmp_path, locale):
    import pandas as pd

    locale(None)
    gpkg = tmp_path / "t.gpkg"
    _trees(farm, gpkg)
    ref = tmp_path / "ref.csv"
    t = farm["truth"]
    pd.DataFrame({"x": t["x"], "y": t["y"], "height": t["height"]}).to_csv(ref, index=False)
    pairs = tmp_path / "pairs.csv"
    assert main(["evaluate", str(gpkg), str(ref), "-o", str(pairs), "-lco", "DECIMAL=COMMA",
                 "-q"]) == 0
    got = pd.read_csv(pairs, sep=";", decimal=",")
    assert len(got) > 500 and got["distance"].max() <= 2.5
    assert all(len(str(v).split(".")[-1]) <= 2 for v in got["det_x"].head(50))


def _numbered_as_the_generator(tops) -> list:
    """Assert each stand's trees carry the generator's row and plant (row 1 at 1.5 m from the
    stand's west edge, plant 1 at 1 m from the south edge); returns each stand's trees."""
    out = []
    for sid, x0 in (("T-01", OX), ("T-02", OX + 40)):
        own = tops[(tops["stand_id"] == sid) & (tops["row_number"] > 0)]
        want_row = np.round((own["x"] - x0 - 1.5) / 3).astype(int) + 1
        want_plant = np.round((own["y"] - OY - 1.0) / 2).astype(int) + 1
        assert (own["row_number"] == want_row).mean() > 0.99, sid
        assert (own["plant_number"] == want_plant).mean() > 0.99, sid
        out.append(own)
    return out


def test_rows_and_plants_are_numbered_per_stand_in_every_tiling(farm, tmp_path, locale):
    """Every tree and gap gets the same row and plant numbers whether the farm runs as one
    tile or in 30 m tiles: each stand numbered from its own first row and plant (the library
    once restarted the numbers in every tile: the gap that was row 2 plant 28 became plant 15
    of its tile)."""
    locale(None)
    layers = {}
    for name, extra in (("one", []),
                        ("tiled", ["-tile_size", "30", "-buffer", "12", "-workers", "1"])):
        out = tmp_path / f"{name}.gpkg"
        _trees(farm, out, "-stands", str(farm["dir"] / "talhoes.gpkg"), "-spacing", "3x2",
               *extra)
        tops = pyogrio.read_dataframe(out, layer="tree_tops", read_geometry=False)
        gaps = pyogrio.read_dataframe(out, layer="gaps", read_geometry=False)
        summ = pyogrio.read_dataframe(out, layer="summary").iloc[0]
        layers[name] = (tops.set_index("tree_id"), gaps.set_index("gap_id"), summ)
    (t1, g1, s1), (t2, g2, s2) = layers["one"], layers["tiled"]
    assert s2["tiles"] > 4 and s1["tiles"] == 1
    common = t1.index.intersection(t2.index)
    assert len(common) >= 0.99 * len(t1)
    for c in ("row_number", "plant_number", "stand_id"):
        assert (t1.loc[common, c] == t2.loc[common, c]).all(), c
    gc = g1.index.intersection(g2.index)
    assert len(gc) >= 0.95 * len(g1) and len(gc) > 10
    for c in ("row_number", "plant_number", "stand_id"):
        assert (g1.loc[gc, c] == g2.loc[gc, c]).all(), c
    # each stand counts from its own first row: row 1 at 1.5 m from its west edge, plant 1 at
    # 1 m from the south edge (the generator's layout), in both stands
    for own in _numbered_as_the_generator(t1):
        assert own["row_number"].min() == 1 and own["plant_number"].min() == 1
    # stands drawn along the roads around them, 6 m out from the first row and plant: row 1
    # is still the first planted row, plant 1 each row's first tree (once the numbers started
    # at the polygon's edge, row 3 and plant 4 for the first tree)
    roads = [shapely.box(OX - 6, OY - 6, OX + 40, OY + 86),
             shapely.box(OX + 40, OY - 6, OX + 86, OY + 86)]
    gpd.GeoDataFrame({"Talhão": ["T-01", "T-02"]}, geometry=roads,
                     crs="EPSG:31984").to_file(tmp_path / "roads.gpkg")
    _trees(farm, tmp_path / "roads_out.gpkg", "-stands", str(tmp_path / "roads.gpkg"),
           "-spacing", "3x2")
    t3 = pyogrio.read_dataframe(tmp_path / "roads_out.gpkg", layer="tree_tops",
                                read_geometry=False)
    _numbered_as_the_generator(t3)
