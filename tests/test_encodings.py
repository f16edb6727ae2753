"""Issue 37: XYZ text exported on Windows. A Windows-1252 header with CRLF line ends
(``Leste;Norte;Elevação;Intensidade;Classificação;Retorno``) reads all its columns and the
vendor's class 2 ground makes the terrain; UTF-8 with or without a BOM and Latin-1 are detected
too; a classes column that cannot be read is an error, never a silent change of terrain."""
import json
import warnings

import numpy as np
import pytest
import rasterio

from lidartrees_gis.cli import main
from lidartrees_gis.errors import InputError
from lidartrees_gis.io.xyz import detect_encoding, sniff_xyz

HEADER = "Leste;Norte;Elevação;Intensidade;Classificação;Retorno"
COLUMNS = ("x", "y", "z", "intensity", "classification", "return_number")


@pytest.fixture(scope="module")
def cloud():
    """A 30 x 30 m synthetic stand with class 2 ground, plus class 1 low points 4 m under the
    ground (what the lowest returns would take as terrain were the classes lost)."""
    from lidartrees_gis.synthetic import StandParams, make_stand

    pts, _ = make_stand(StandParams(width=30, height=30))
    g = np.flatnonzero(pts.classification == 2)[::7]
    x, y = np.r_[pts.x, pts.x[g]], np.r_[pts.y, pts.y[g]]
    z = np.r_[pts.z, pts.z[g] - 4.0]
    cls = np.r_[pts.classification, np.ones(len(g), int)]
    return x, y, z, cls


def _write(path, cloud, encoding, header=HEADER, newline="\r\n"):
    x, y, z, cls = cloud
    with open(path, "w", encoding=encoding, newline=newline) as fh:
        fh.write(header + "\n")
        for a, b, c, k in zip(x, y, z, cls):
            fh.write(f"{a:.2f};{b:.2f};{c:.3f};120;{k};1\n".replace(".", ","))
    return path


def _chm(src, out, *extra):
    assert main(["chm", str(src), str(out), "-a_srs", "EPSG:31984", "-tr", "0.5", "-q",
                 *extra]) == 0
    with rasterio.open(out) as ds:
        return json.loads(ds.tags()["LIDARTREES_PARAMETERS"]), ds.read(1, masked=True)


def test_cp1252_crlf_header_reads_every_column_and_the_vendor_ground(cloud, tmp_path):
    f = _write(tmp_path / "voo.txt", cloud, "cp1252")
    raw = f.read_bytes()
    assert b"Eleva\xe7\xe3o" in raw and b"\r\n" in raw  # one byte per accented letter
    assert detect_encoding(f) == "cp1252"
    d = sniff_xyz(f)
    assert d.columns == COLUMNS and d.encoding == "cp1252" and d.decimal_comma
    from lidartrees_gis.io.points import open_points

    src = open_points(f, a_srs="EPSG:31984")
    chunks = list(src.chunks())
    cls = np.concatenate([c.classification for c in chunks])
    assert len(cls) == len(cloud[3]) and (cls == cloud[3]).all()
    params, chm = _chm(f, tmp_path / "chm.tif")
    assert params["dtm"] == "auto (ground)"
    # the same points as a LAS file (classes in the file) give the same canopy to the mm
    from lidartrees_gis.io.lasout import write_points
    from pyproj import CRS

    x, y, z, c = cloud
    las = tmp_path / "voo.las"
    write_points(las, np.round(x, 2), np.round(y, 2), np.round(z, 3), crs=CRS.from_epsg(31984),
                 classification=c.astype(np.uint8))
    _, ref = _chm(las, tmp_path / "ref.tif")
    assert chm.shape == ref.shape
    assert float(np.abs(chm - ref).max()) < 1e-3
    # the lost-classes terrain would have been the low points' (about 4 m lower): not taken
    assert float(chm.max()) < float(ref.max()) + 0.01


@pytest.mark.parametrize("encoding, expect", [("utf-8", "utf-8-sig"), ("utf-8-sig", "utf-8-sig"),
                                              ("latin-1", "latin-1")])
def test_utf8_with_or_without_bom_and_latin1_are_detected(cloud, tmp_path, encoding, expect):
    header = HEADER
    if encoding == "latin-1":
        header = HEADER + ";N\x81mero"  # a byte Windows-1252 leaves undefined: Latin-1 only
    f = _write(tmp_path / "voo.txt", tuple(a[:50] for a in cloud), encoding, header=header)
    assert f.read_bytes().startswith(b"\xef\xbb\xbf") == (encoding == "utf-8-sig")
    assert detect_encoding(f) == expect
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        d = sniff_xyz(f)
    assert d.columns[:6] == COLUMNS and d.encoding == expect
    # Latin-1's extra column is named as read (its byte kept), not as replacement characters
    assert all("\ufffd" not in str(w.message) for w in rec)


def test_a_classes_column_that_cannot_be_read_is_an_error(cloud, tmp_path, capsys):
    """A header whose classes column is not recognised (or came through a wrong decoding)
    stops the run naming the column, instead of taking the lowest returns as terrain."""
    for header in ("Leste;Norte;Elevação;Intensidade;Classe_LAS;Retorno",
                   "Leste;Norte;Elevação;Intensidade;Classifica\ufffd\ufffdo;Retorno"):
        f = _write(tmp_path / "voo.txt", tuple(a[:50] for a in cloud), "utf-8", header=header)
        with pytest.raises(InputError, match="looks like the point classes"):
            sniff_xyz(f)
        assert main(["chm", str(f), str(tmp_path / "c.tif"), "-a_srs", "EPSG:31984",
                     "-q"]) != 0
        assert not (tmp_path / "c.tif").exists()
        err = capsys.readouterr().err
        assert "--columns" in err and header.split(";")[4] in err
    # naming the columns reads it
    f = _write(tmp_path / "voo.txt", tuple(a[:50] for a in cloud), "utf-8",
               header="Leste;Norte;Elevação;Intensidade;Classe_LAS;Retorno")
    d = sniff_xyz(f, columns="x,y,z,intensity,classification,return_number")
    assert d.columns == COLUMNS


def test_single_dash_columns_is_accepted_as_the_warning_says(cloud, tmp_path):
    from lidartrees_gis.errors import DataWarning

    f = _write(tmp_path / "voo.txt", tuple(a[:200] for a in cloud), "utf-8",
               header="Leste;Norte;Elevação;Intensidade;Talhao;Retorno")
    with pytest.warns(DataWarning, match="--columns"):
        sniff_xyz(f)
    out = tmp_path / "c.tif"
    assert main(["chm", str(f), str(out), "-a_srs", "EPSG:31984", "-q",
                 "-columns", "x,y,z,intensity,-,return_number"]) == 0
    assert out.exists()


def test_reference_tables_in_latin1_are_read(tmp_path):
    """A tree table with a byte Windows-1252 leaves undefined (Latin-1 only) once failed with
    a NameError (no encoding matched)."""
    from lidartrees_gis.io.names import read_text_table

    f = tmp_path / "ref.csv"
    f.write_bytes("N\x81mero;Este;Norte;Altura\n1;412300,5;7952400,25;21,5\n".encode("latin-1"))
    df = read_text_table(f)
    assert list(df.columns)[1:] == ["Este", "Norte", "Altura"]
    assert df["Este"].iloc[0] == 412300.5 and df["Altura"].iloc[0] == 21.5
