"""Issue 11 items fixed so far: -co, --help defaults, info -q, XYZ edge cases, refused grids
and outputs. Each failed before its fix."""
import numpy as np
import pytest
import rasterio
from pyproj import CRS

from lidartrees_gis.cli import main
from lidartrees_gis.io.lasout import write_points


@pytest.fixture
def small_las(tmp_path):
    rng = np.random.default_rng(0)
    x = 500_000 + rng.random(4000) * 40
    y = 7_000_000 + rng.random(4000) * 40
    z = 100 + rng.random(4000) * 20
    f = tmp_path / "s.las"
    write_points(f, x, y, z, crs=CRS.from_epsg(31984), classification=np.full(4000, 1, np.uint8))
    return f


def test_creation_options_reach_the_geotiff(small_las, tmp_path):
    out = tmp_path / "c.tif"
    assert main(["chm", str(small_las), str(out), "-co", "COMPRESS=LZW", "-co", "BLOCKXSIZE=128",
                 "-co", "BLOCKYSIZE=128", "-q"]) == 0
    with rasterio.open(out) as ds:
        assert ds.profile["compress"] == "lzw" and ds.block_shapes[0] == (128, 128)
    assert main(["chm", str(small_las), str(tmp_path / "d.tif"), "-co", "LZW", "-q"]) == 1


def test_help_shows_every_default(capsys):
    with pytest.raises(SystemExit):
        main(["trees", "--help"])
    out = capsys.readouterr().out.replace("\n", " ")
    out = " ".join(out.split())
    for text in ("(default: auto)", "(default: 7,18)", "(default: 2.0)", "(default: pitfree)",
                 "(default: 0.9)"):
        assert text in out


def test_info_quiet_still_prints_the_result(small_las, capsys):
    assert main(["info", str(small_las), "-q"]) == 0
    assert "points: 4000" in capsys.readouterr().out


def test_xyz_bom_is_dropped(tmp_path):
    f = tmp_path / "bom.xyz"
    f.write_bytes("\ufeff1.0 2.0 3.0\n4.0 5.0 6.0\n7.0 8.5 9.0\n".encode("utf-8"))
    from lidartrees_gis.io.points import open_points

    pts = open_points(f).read_all()
    assert len(pts) == 3 and pts.x[0] == 1.0


@pytest.mark.parametrize("bad", ["1_000", "\u0661\u0662\u0663"])  # underscores, Arabic-Indic digits
def test_xyz_numbers_python_would_take_are_refused(tmp_path, capsys, bad):
    f = tmp_path / "n.xyz"
    f.write_text("1.0 2.0 3.0\n" * 5 + f"{bad} 2.0 3.0\n", encoding="utf-8")
    assert main(["info", str(f), "-a_srs", "EPSG:31984", "-q"]) == 1
    err = capsys.readouterr().err
    assert "n.xyz:6" in err and "not a number" in err and len(err.strip().splitlines()) == 1


def test_geographic_crs_is_refused_for_grids(tmp_path, capsys):
    f = tmp_path / "g.xyz"
    f.write_text("".join(f"{-40.1 + i * 1e-5:.6f} {-19.5 + i * 1e-5:.6f} 10\n" for i in range(50)))
    assert main(["chm", str(f), str(tmp_path / "g.tif"), "-a_srs", "EPSG:4674", "-q"]) == 1
    assert "geographic" in capsys.readouterr().err
    assert not (tmp_path / "g.tif").exists()


def test_absurd_grids_are_refused_with_the_extent(tmp_path, capsys):
    f = tmp_path / "far.las"
    write_points(f, [500_000.0, 544_000.0, 500_010.0], [7_000_000.0, 7_000_005.0, 7_000_010.0],
                 [10.0, 11.0, 12.0], crs=CRS.from_epsg(31984))
    for tr in ("0.001", "5e-324"):
        assert main(["grid", str(f), str(tmp_path / "g.tif"), "-tr", tr, "-q"]) == 1
        err = capsys.readouterr().err
        assert "cells" in err and "44000 x 10 m" in err
    assert not (tmp_path / "g.tif").exists()


def test_output_equal_to_input_is_refused(small_las, capsys):
    before = small_las.read_bytes()
    assert main(["grid", str(small_las), str(small_las), "-overwrite", "-q"]) == 1
    assert "also an input" in capsys.readouterr().err and small_las.read_bytes() == before
