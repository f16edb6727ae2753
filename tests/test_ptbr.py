"""Issue 27: Brazilian inputs: Portuguese column names in XYZ text and tree tables, pt-BR
spreadsheet CSV (semicolons, decimal commas, Windows-1252)."""
import json

import numpy as np
import pytest
import rasterio

from lidartrees_gis.cli import main
from lidartrees_gis.io.names import POINT_COLUMNS, match_column, normalise


@pytest.fixture(scope="module")
def stand_txt(tmp_path_factory):
    """A 30 x 30 m synthetic stand as seed 000's text (tab, decimal comma) with a Portuguese
    header, class 2 ground and five class-7 noise points 300 m up."""
    from lidartrees_gis.synthetic import StandParams, make_stand

    pts, truth = make_stand(StandParams(width=30, height=30))
    x, y, z = np.r_[pts.x, pts.x[:5]], np.r_[pts.y, pts.y[:5]], np.r_[pts.z, pts.z[:5] + 300]
    cls = np.r_[pts.classification, [7] * 5]
    f = tmp_path_factory.mktemp("pt") / "voo.txt"
    with open(f, "w", encoding="utf-8") as fh:
        fh.write("Este\tNorte\tCota\tIntensidade\tClasse\n")
        for a, b, c, k in zip(x, y, z, cls):
            fh.write(f"{a:.2f}\t{b:.2f}\t{c:.3f}\t100\t{k}\n".replace(".", ","))
    return f, truth


@pytest.mark.parametrize("name, attr", [("Este", "x"), ("LESTE", "x"), ("Norte", "y"),
                                        ("Cota", "z"), ("Altitude", "z"),
                                        ("Classe", "classification"),
                                        ("Classificação", "classification"),
                                        ("classificacao", "classification"),
                                        ("Intensidade", "intensity"),
                                        ("Retorno", "return_number"),
                                        ("Número de retornos", "number_of_returns"),
                                        ("Foo", None)])
def test_portuguese_column_names(name, attr):
    assert match_column(name, POINT_COLUMNS) == attr
    assert normalise("Número de retornos") == "numeroderetornos"


def test_portuguese_header_keeps_the_classes(stand_txt, tmp_path):
    """The classes of a `Classe` column are read: the noise (class 7) is dropped and the
    ground (class 2) makes the DTM. The library once ignored the column silently."""
    f, _ = stand_txt
    out = tmp_path / "chm.tif"
    assert main(["chm", str(f), str(out), "-a_srs", "EPSG:31984", "-q"]) == 0
    with rasterio.open(out) as ds:
        p = json.loads(ds.tags()["LIDARTREES_PARAMETERS"])
        chm = ds.read(1, masked=True)
    assert p["dtm"] == "auto (ground)"
    assert float(chm.max()) < 30  # the noise 300 m up is not in the canopy
    from lidartrees_gis.api import find_trees

    _, _, s = find_trees(f, a_srs="EPSG:31984")
    assert s["dropped_classes"] == "7:5" and s["trees"] > 100


def test_unknown_header_columns_are_named(tmp_path):
    from lidartrees_gis.errors import DataWarning
    from lidartrees_gis.io.xyz import sniff_xyz

    f = tmp_path / "a.txt"
    f.write_text("Este;Norte;Cota;Talhao\n1;2;3;4\n5;6;7;8\n", encoding="utf-8")
    with pytest.warns(DataWarning, match="Talhao"):
        d = sniff_xyz(f)
    assert d.columns[:3] == ("x", "y", "z") and d.columns[3] is None


def test_evaluate_reads_a_ptbr_reference_csv(stand_txt, tmp_path):
    """A reference exported by a pt-BR spreadsheet (semicolons, decimal commas, Windows-1252,
    Portuguese names) evaluates like the same table in English."""
    f, truth = stand_txt
    gpkg = tmp_path / "t.gpkg"
    assert main(["trees", str(f), str(gpkg), "-a_srs", "EPSG:31984", "-q"]) == 0
    en, pt = tmp_path / "ref_en.csv", tmp_path / "ref_pt.csv"
    with open(en, "w", encoding="utf-8") as fh:
        fh.write("x,y,height\n")
        for a, b, h in zip(truth["x"], truth["y"], truth["height"]):
            fh.write(f"{a:.3f},{b:.3f},{h:.2f}\n")
    with open(pt, "w", encoding="cp1252") as fh:
        fh.write("Árvore;Este;Norte;Altura total (m)\n")
        for i, (a, b, h) in enumerate(zip(truth["x"], truth["y"], truth["height"])):
            fh.write(f"{i + 1};{a:.3f};{b:.3f};{h:.2f}\n".replace(".", ","))
    reports = []
    for ref in (en, pt):
        rep = tmp_path / f"{ref.stem}.json"
        assert main(["evaluate", str(gpkg), str(ref), "-o", str(rep), "-q"]) == 0
        reports.append(json.loads(rep.read_text()))
    assert reports[0]["all"] == reports[1]["all"]
    assert reports[1]["all"]["f_score"] > 0.9 and reports[1]["all"]["height_rmse"] < 1.0


def test_a_delivery_folder_with_a_readme_and_an_index_runs(stand_txt, tmp_path, capsys):
    """A delivery folder: point files plus a LEIAME.txt, a tile index CSV and a list of paths.
    The point files are read; the others are named once as not point data. The library once
    read every .txt/.csv as points and stopped."""
    import shutil

    from lidartrees_gis.catalog.inputs import expand_inputs
    from lidartrees_gis.errors import DataWarning

    f, _ = stand_txt
    d = tmp_path / "entrega"
    d.mkdir()
    shutil.copy(f, d / "voo_01.txt")
    (d / "LEIAME.txt").write_text("Levantamento LiDAR, fazenda Rosa Helena.\nSistema: SIRGAS "
                                  "2000 / UTM 24S.\nContato: 12 3456-7890\n", encoding="utf-8")
    (d / "indice.csv").write_text("arquivo;xmin;ymin;xmax;ymax\nvoo_01.txt;412300;7952400;"
                                  "412330;7952430\n", encoding="utf-8")
    (d / "lista.txt").write_text("voo_01.txt\n", encoding="utf-8")
    with pytest.warns(DataWarning, match="LEIAME.txt") as rec:
        files = expand_inputs(d)
    assert [q.name for q in files] == ["voo_01.txt"]
    assert all(n in str(rec[0].message) for n in ("indice.csv", "lista.txt", "3 file(s)"))
    out = tmp_path / "t.gpkg"
    assert main(["trees", str(d), str(out), "-a_srs", "EPSG:31984", "-q"]) == 0
    import pyogrio

    assert pyogrio.read_info(out, layer="tree_tops")["features"] > 100


@pytest.mark.realdata
def test_api_and_info_take_what_the_commands_take(data, tmp_path, capsys):
    """Folders and globs in `info`, `point_info`, `canopy_height` and `find_trees`, as in
    `trees`. The library once refused them in `info`."""
    import lidartrees_gis as lt

    folder = data("lasR_bcts/bcts_1.laz").parent
    assert main(["info", str(folder), "-q"]) == 0
    out = capsys.readouterr().out
    assert "files: 4" in out and "points: 2834350" in out
    two = lt.point_info(str(folder / "bcts_[12].laz"))
    assert two["files"] == 2 and two["points"] == 531662 + 823945
    one = lt.point_info(folder / "bcts_1.laz")
    assert one["points"] == 531662
    chm, prof = lt.canopy_height(str(folder / "bcts_[12].laz"))
    assert chm.shape[0] * prof["transform"].a > 500  # both files, 540 m north to south
    tops, crowns, summary = lt.find_trees(str(folder / "bcts_[12].laz"))
    assert len(tops) == len(crowns) == summary["trees"] and tops["y"].max() > 629600


def test_a_decimal_comma_table_gets_the_bom_a_spreadsheet_needs():
    """-lco DECIMAL=COMMA on any locale: a BOM unless WRITE_BOM=NO (Excel reads UTF-8 without
    one as Windows-1252: São -> SÃ£o); a point-decimal table none."""
    from lidartrees_gis.io.tables import TableOptions

    en = {"LANG": "en_US.UTF-8"}
    assert TableOptions.from_options({"SEPARATOR": "SEMICOLON", "DECIMAL": "COMMA"}, en) \
        == TableOptions(";", ",", True)
    assert TableOptions.from_options({"DECIMAL": "COMMA", "WRITE_BOM": "NO"}, en).write_bom \
        is False
    assert TableOptions.from_options({"SEPARATOR": "SEMICOLON"}, en).write_bom is False
    assert TableOptions.from_options({}, en) == TableOptions(",", ".", False)
