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


def test_top_level_help_lists_every_command(capsys):
    """``lidartrees -h`` (a summary with a per cent sign once broke argparse's formatting)."""
    from lidartrees_gis.cli.commands import COMMANDS

    with pytest.raises(SystemExit) as e:
        main(["-h"])
    assert e.value.code == 0
    out = capsys.readouterr().out
    for name in COMMANDS:
        assert f"    {name} " in out or f"    {name}\n" in out, name
    assert "95 % intervals" in " ".join(out.split())


def test_info_quiet_still_prints_the_result(small_las, capsys):
    assert main(["info", str(small_las), "-q"]) == 0
    out = capsys.readouterr().out
    assert "points: 4000" in out
    # numbers rounded for a reader: no binary artefacts, density and area short
    import re

    assert not re.search(r"\d\.\d*(0000\d|9999\d)", out), out
    dens = re.search(r"density_pts_m2: ([\d.]+)", out).group(1)
    area = re.search(r"area_m2: ([\d.]+)", out).group(1)
    assert len(dens.split(".")[1]) <= 3 and len(area.split(".")[1]) <= 1


def test_xyz_bom_is_dropped(tmp_path):
    f = tmp_path / "bom.xyz"
    f.write_bytes("\ufeff1.0 2.0 3.0\n4.0 5.0 6.0\n7.0 8.5 9.0\n".encode("utf-8"))
    from lidartrees_gis.io.points import open_points

    pts = open_points(f).read_all()
    assert len(pts) == 3 and pts.x[0] == 1.0


def test_header_only_xyz_says_it_has_no_points(tmp_path, capsys):
    f = tmp_path / "h.xyz"
    f.write_text("X\tY\tZ\n", encoding="utf-8")
    assert main(["trees", str(f), str(tmp_path / "h.gpkg"), "-a_srs", "EPSG:31983", "-q"]) == 1
    err = capsys.readouterr().err
    assert "h.xyz: a header line and no points" in err
    assert not (tmp_path / "h.gpkg").exists()


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
    assert main(["grid", str(f), str(tmp_path / "g.tif"), "-tr", "0.001", "-q"]) == 1
    err = capsys.readouterr().err
    assert "cells" in err and "44000 x 10 m" in err
    assert main(["grid", str(f), str(tmp_path / "g.tif"), "-tr", "5e-324", "-q"]) == 1
    assert "-tr: resolution '5e-324' m is below 0.1 mm" in capsys.readouterr().err
    assert not (tmp_path / "g.tif").exists()


def test_output_equal_to_input_is_refused(small_las, capsys):
    before = small_las.read_bytes()
    assert main(["grid", str(small_las), str(small_las), "-overwrite", "-q"]) == 1
    assert "also an input" in capsys.readouterr().err and small_las.read_bytes() == before


def _one_error_line(capsys, *must):
    err = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip()]
    assert len(err) == 1 and err[0].startswith("lidartrees") and "Traceback" not in err[0], err
    for m in must:
        assert m in err[0], err[0]
    return err[0]


def _patched(src, dst, offset, fmt, value):
    import struct

    b = bytearray(src.read_bytes())
    struct.pack_into(fmt, b, offset, value)
    dst.write_bytes(bytes(b))
    return dst


@pytest.mark.parametrize("name, offset, fmt, value, expect", [
    ("scale.las", 131, "<d", 1e300, "impossible scale"),
    ("offset.las", 155 + 8, "<d", 1e300, "impossible offset"),
    ("count.las", 247, "<Q", 2 ** 31, "2,147,483,648 points"),
    ("vlrs.las", 100, "<I", 2 ** 31, "VLRs"),
])
def test_impossible_las_headers_are_refused(small_las, tmp_path, capsys, name, offset, fmt, value,
                                            expect):
    f = _patched(small_las, tmp_path / name, offset, fmt, value)
    assert main(["grid", str(f), str(tmp_path / "o.tif"), "-tr", "1", "-q"]) == 1
    _one_error_line(capsys, expect, str(f))
    assert not (tmp_path / "o.tif").exists()


def test_truncated_laz_and_corrupt_gzip_are_one_line_errors(small_las, tmp_path, capsys):
    import gzip

    import laspy

    laz = tmp_path / "t.laz"
    laspy.read(str(small_las)).write(str(laz))
    cut = tmp_path / "cut.laz"
    cut.write_bytes(laz.read_bytes()[: laz.stat().st_size * 2 // 3])
    assert main(["grid", str(cut), str(tmp_path / "o.tif"), "-tr", "1", "-q"]) == 1
    _one_error_line(capsys, "truncated or corrupt")
    gz = tmp_path / "p.xyz.gz"
    raw = gzip.compress(b"X\tY\tZ\n" + b"500000.0\t7500000.0\t600.0\n" * 2000)
    gz.write_bytes(raw[: len(raw) // 2])
    assert main(["info", str(gz), "-q"]) == 1
    _one_error_line(capsys, "truncated or corrupt")


def test_output_without_crs_is_refused_unless_allowed(tmp_path, capsys):
    f = tmp_path / "p.xyz"
    f.write_text("X\tY\tZ\n" + "".join(f"{500000 + i % 20}.5\t{7500000 + i // 20}.5\t600\n"
                                         for i in range(400)))
    out = tmp_path / "g.tif"
    assert main(["grid", str(f), str(out), "-tr", "1", "-q"]) == 1
    _one_error_line(capsys, "no CRS", "-a_srs", "--allow-no-crs")
    assert not out.exists()
    assert main(["grid", str(f), str(out), "-tr", "1", "-q", "--allow-no-crs"]) == 0
    with rasterio.open(out) as ds:
        assert ds.crs is None and ds.shape == (20, 20)
    assert main(["info", str(f), "-q"]) == 0  # info writes nothing georeferenced


def test_tiny_resolution_and_a_wrong_digit_are_refused(tmp_path, capsys):
    f = tmp_path / "p.xyz"
    rows = [f"{500000 + i % 30}.5\t{7500000 + i // 30}.5\t600\n" for i in range(300)]
    rows[7] = "500007.5\t5500000.5\t600\n"  # a 7 became a 5: 2,000 km away
    f.write_text("X\tY\tZ\n" + "".join(rows))
    assert main(["grid", str(f), str(tmp_path / "a.tif"), "-tr", "5e-324", "-q", "-a_srs",
                 "EPSG:31983"]) == 1
    _one_error_line(capsys, "-tr")
    # issue 42: the point with the wrong digit is left out (one warning naming it), not the
    # reason to refuse the other 299
    assert main(["chm", str(f), str(tmp_path / "b.tif"), "-tr", "1", "-q", "-a_srs",
                 "EPSG:31983"]) == 0
    err = capsys.readouterr().err
    assert "1 point(s) lie far from the other 299" in err and "5500000.50" in err


@pytest.mark.parametrize("tiles", [[], ["-tile_size", "40", "-workers", "1"]])
def test_overwrite_replaces_only_the_layers_written(tmp_path, tiles):
    import geopandas as gpd
    import pyogrio
    import shapely

    from lidartrees_gis.synthetic import make_stand, write_xyz_seed_dialect

    pts, _ = make_stand()
    f = tmp_path / "stand.xyz"
    write_xyz_seed_dialect(f, pts)
    out = tmp_path / "trees.gpkg"
    mine = gpd.GeoDataFrame({"note": ["field plot"]}, geometry=[shapely.Point(412310, 7952410)],
                            crs="EPSG:29194")
    pyogrio.write_dataframe(mine, out, layer="plots")
    pyogrio.write_dataframe(mine, out, layer="tree_tops")  # stale: must be replaced
    crs = ["-a_srs", "EPSG:29194"]
    assert main(["trees", str(f), str(out), "-q", *crs, *tiles]) == 1  # exists, no -overwrite
    assert main(["trees", str(f), str(out), "-overwrite", "-q", *crs, *tiles]) == 0
    layers = {name for name, _ in pyogrio.list_layers(out)}
    assert {"plots", "tree_tops", "crowns", "summary"} <= layers
    assert pyogrio.read_dataframe(out, layer="plots")["note"].tolist() == ["field plot"]
    tops = pyogrio.read_dataframe(out, layer="tree_tops")
    assert len(tops) > 100 and "note" not in tops.columns
    # the stand is a planted block: gaps and stands layers; a run that writes none of them
    # (-planting none) must not leave the earlier run's beside its own trees
    assert {"gaps", "stands"} <= layers
    assert main(["trees", str(f), str(out), "-overwrite", "-q", "-planting", "none", *crs,
                 *tiles]) == 0
    assert {name for name, _ in pyogrio.list_layers(out)} == \
        {"plots", "tree_tops", "crowns", "summary", "layer_styles"}
    assert pyogrio.read_dataframe(out, layer="plots")["note"].tolist() == ["field plot"]
    import sqlite3

    con = sqlite3.connect(out)  # nothing of the dropped layers left behind
    assert con.execute("PRAGMA integrity_check").fetchone() == ("ok",)
    names = " ".join(r[0] for r in con.execute("SELECT name FROM sqlite_master"))
    styled = {r[0] for r in con.execute("SELECT f_table_name FROM layer_styles")}
    con.close()
    assert "gaps" not in names and "stands" not in names and styled == {"tree_tops", "crowns"}
    # a file holding only a trees run's layers is written anew: no earlier layer in it
    only = tmp_path / "only.gpkg"
    assert main(["trees", str(f), str(only), "-q", *crs, *tiles]) == 0
    assert main(["trees", str(f), str(only), "-overwrite", "-q", "-planting", "none", *crs,
                 *tiles]) == 0
    assert {name for name, _ in pyogrio.list_layers(only)} == \
        {"tree_tops", "crowns", "summary", "layer_styles"}


def test_stale_las_header_bounds_and_counts_are_warned(small_las, tmp_path, capsys):
    import struct

    f = _patched(small_las, tmp_path / "bounds.las", 179, "<d", 500_020.0)  # max x too small
    assert main(["grid", str(f), str(tmp_path / "a.tif"), "-tr", "1", "-q"]) == 0
    err = capsys.readouterr().err
    warn = [ln for ln in err.splitlines() if ": warning: " in ln]
    assert len(warn) == 1 and "outside the bounds the LAS header states" in warn[0]
    n = int(warn[0].split(" of ")[0].rsplit(" ", 1)[1].replace(",", ""))
    assert 1500 < n < 2500  # about half of the 4000 points lie beyond x = 500020
    b = bytearray(small_las.read_bytes())
    struct.pack_into("<I", b, 107, 3000)
    struct.pack_into("<Q", b, 247, 3000)
    g = tmp_path / "count.las"
    g.write_bytes(bytes(b))
    assert main(["info", str(g), "-q"]) == 0
    err = capsys.readouterr().err
    assert "holds 4,000 point records but the header says 3,000" in err


@pytest.mark.parametrize("dtm, expect", [("lowest:5", "lowest:5"), ("lowest:7.5", "lowest:7.5"),
                                         ("kp:-1:1", "kp:-1:1"), ("auto", "auto (lowest:5)")])
def test_provenance_stores_the_dtm_parameter_as_given(small_las, tmp_path, dtm, expect):
    import json

    out = tmp_path / "c.tif"
    assert main(["chm", str(small_las), str(out), "-dtm", dtm, "-tr", "1", "-q"]) == 0
    with rasterio.open(out) as ds:
        assert json.loads(ds.tags()["LIDARTREES_PARAMETERS"])["dtm"] == expect


def test_files_that_are_not_point_data_are_refused(small_las, tmp_path, capsys):
    import pyogrio
    import geopandas as gpd
    import shapely

    g = tmp_path / "plots.gpkg"
    pyogrio.write_dataframe(gpd.GeoDataFrame({"a": [1]}, geometry=[shapely.Point(0, 0)],
                                             crs="EPSG:31983"), g)
    shp = tmp_path / "plots.shp"
    pyogrio.write_dataframe(gpd.GeoDataFrame({"a": [1]}, geometry=[shapely.Point(0, 0)],
                                             crs="EPSG:31983"), shp)
    img = tmp_path / "photo.xyz"  # a PNG under a point-file name
    img.write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(300))
    txt = tmp_path / "notes.txt"
    txt.write_text("Field notes, stand 12\nrain in the morning\n" * 30)
    for f, what in ((g, "GeoPackage"), (shp, "shapefile"), (img, "PNG"), (txt, "not point data")):
        assert main(["info", str(f), "-q"]) == 1
        _one_error_line(capsys, what, str(f))


def test_system_errors_are_one_line(small_las, tmp_path, capsys):
    long_name = tmp_path / ("a" * 300 + ".tif")
    assert main(["grid", str(small_las), str(long_name), "-tr", "1", "-q"]) == 1
    _one_error_line(capsys, "File name too long")
    xyz = tmp_path / "p.xyz"
    xyz.write_text("".join(f"{500000 + i}.5 7500000.5 600\n" for i in range(50)))
    (tmp_path / "p.prj").write_bytes(bytes(range(250, 256)) * 20)
    assert main(["info", str(xyz), "-q"]) == 1
    _one_error_line(capsys, "p.prj", "not a text CRS")


def test_absurd_region_growing_step_is_refused_quickly(tmp_path, capsys):
    from lidartrees_gis.synthetic import make_stand, write_xyz_seed_dialect

    pts, _ = make_stand()
    f = tmp_path / "s.xyz"
    write_xyz_seed_dialect(f, pts)
    assert main(["trees", str(f), str(tmp_path / "t.gpkg"), "-a_srs", "EPSG:29194", "-method",
                 "rg", "-step", "1e-9", "-q"]) == 1
    _one_error_line(capsys, "-step", "passes")


def test_t_srs_states_and_stores_the_operation(tmp_path, capsys):
    import pyogrio

    from lidartrees_gis.synthetic import make_stand, write_xyz_seed_dialect

    pts, _ = make_stand()
    f = tmp_path / "s.xyz"
    write_xyz_seed_dialect(f, pts)
    crs = ["-a_srs", "SAD69 24K", "-t_srs", "EPSG:31984"]
    for cmd, out in (("chm", tmp_path / "c.tif"), ("trees", tmp_path / "t.gpkg")):
        assert main([cmd, str(f), str(out), *crs]) == 0
        printed = capsys.readouterr().out  # the result on stdout, messages on stderr
        line = [ln for ln in printed.splitlines() if ln.startswith("reprojection:")]
        assert len(line) == 1 and "SAD69" in line[0] and "SIRGAS 2000" in line[0]
        assert "accuracy" in line[0]
    with rasterio.open(tmp_path / "c.tif") as ds:
        tags = ds.tags()
        assert ds.crs.to_epsg() == 31984
    assert "SAD69" in tags["LIDARTREES_SOURCE_CRS"] and "SAD69 to SIRGAS 2000" in tags["LIDARTREES_OPERATION"]
    assert float(tags["LIDARTREES_ACCURACY_M"]) > 0
    meta = pyogrio.read_info(tmp_path / "t.gpkg", layer="tree_tops")["layer_metadata"]
    assert "SAD69 to SIRGAS 2000" in meta["reprojection_operation"]
    assert float(meta["reprojection_accuracy_m"]) > 0
    # every other command that reads points states it too
    for args in (["info", str(f)], ["compare", str(f), str(tmp_path / "cmp.csv")]):
        assert main(args + crs) == 0
        c = capsys.readouterr()
        line = [ln for ln in (c.out + c.err).splitlines() if ln.startswith("reprojection:")]
        assert len(line) == 1 and "SIRGAS 2000" in line[0] and "accuracy" in line[0], args[0]


def test_compiled_kernels_never_index_outside_their_arrays():
    """NaN, inf and 1e300 coordinates (a LAS scale of 1e300 once wrote outside the grid) are
    counted as outside, in the compiled and in the pure-Python kernel alike; seeds outside the
    CHM are refused before a kernel runs."""
    from lidartrees_gis import _accel
    from lidartrees_gis.errors import InputError
    from lidartrees_gis.als.crowns import region_growing, treex_growing

    bad = [np.inf, -np.inf, np.nan, 1e300, -1e300, 1e19, 9.2e18]
    x = np.array([0.5] + bad + [0.5] * len(bad))
    y = np.array([0.5] + [0.5] * len(bad) + bad)
    z = np.arange(x.size, dtype=float)
    results = []
    kernels = [_accel._accumulate_py] + ([_accel.accumulate] if _accel.HAVE_NUMBA else [])
    for fn in kernels:
        count = np.zeros(4, np.int64)
        mx = np.full(4, -np.inf)
        guard = np.full(8, 7.0)  # sentinel after the grid: must stay untouched
        mn, sm = np.full(4, np.inf), np.zeros(4)
        outside = fn(x, y, z, 0.0, 0.0, 1.0, 2, 2, 1e-9, count, mx, mn, sm)
        assert outside == 2 * len(bad) and count.sum() == 1 and count[2] == 1  # row 1, col 0
        assert mx[2] == 0.0 and np.isinf(mx[[0, 1, 3]]).all() and (guard == 7).all()
        results.append((count.copy(), mx.copy()))
    for c, m in results[1:]:
        assert (c == results[0][0]).all() and np.array_equal(m, results[0][1])

    out = np.full((3, 3), np.nan)
    px = np.array([0.0, 3.0, 0.0, 1e300, np.nan, -np.inf])
    py = np.array([0.0, 0.0, 3.0, 1e300, 1.0, 2.0])
    pz = np.ones(6)
    tri = np.array([[0, 1, 2], [0, 1, 3], [0, 4, 2], [5, 1, 2]], np.int64)
    for fn in [_accel._raster_triangles_py] + ([_accel.raster_triangles] if _accel.HAVE_NUMBA else []):
        o = out.copy()
        with np.errstate(all="ignore"):
            fn(px, py, pz, tri, 0.0, 0.0, 3.0, 1.0, 3, 3, o)
        assert np.nansum(o) == 6  # the first triangle covers the 6 centres on or below its diagonal
    if _accel.HAVE_NUMBA:
        with pytest.raises(ValueError, match="does not exist"):
            _accel.raster_triangles(px, py, pz, np.array([[0, 1, 99]], np.int64), 0.0, 0.0, 3.0,
                                    1.0, 3, 3, out.copy())
    chm = np.full((5, 5), 10.0)
    for fn in (lambda r, c: region_growing(chm, r, c),
               lambda r, c: treex_growing(chm, r, c, 1.0)):
        for r, c in (([5], [0]), ([0], [-1]), ([2**40], [0])):
            with pytest.raises(InputError, match="outside the 5 x 5 CHM"):
                fn(np.array(r), np.array(c))
        assert fn(np.array([2]), np.array([2])).max() == 1


def test_decimal_commas_with_comma_delimiters_are_warned(tmp_path, capsys):
    rng = np.random.default_rng(1)
    rows = [(500_000 + rng.integers(0, 40), rng.integers(0, 100), 7_000_000 + rng.integers(0, 40),
             rng.integers(0, 100), 20 + rng.integers(0, 9), rng.integers(0, 100)) for _ in range(60)]
    f = tmp_path / "pairs.csv"
    f.write_text("".join(",".join(str(v) for v in r) + "\n" for r in rows))
    assert main(["info", str(f), "-a_srs", "EPSG:31984", "-q"]) == 0
    warn = [ln for ln in capsys.readouterr().err.splitlines() if ": warning: " in ln]
    assert len(warn) == 1 and "50 of the first 50 lines look like decimal commas" in warn[0]
    # varying field counts (a value without decimals) are caught too
    g = tmp_path / "ragged.csv"
    g.write_text("".join(f"5000{i % 10}0,5,70000{i % 10}0,25,3{i % 7}" + (",1\n" if i % 3 else "\n")
                         for i in range(40)))
    main(["info", str(g), "-a_srs", "EPSG:31984", "-q"])
    assert "look like decimal commas" in capsys.readouterr().err
    # a real integer CSV (x, y, z, intensity, class, return) is not warned
    h = tmp_path / "ints.csv"
    h.write_text("".join(f"{500000 + i},{7000000 + i},{20 + i % 9},{i % 255},2,1\n" for i in range(40)))
    assert main(["info", str(h), "-a_srs", "EPSG:31984", "-q"]) == 0
    err = capsys.readouterr().err
    assert "decimal commas" not in err and "column 5 read as the point classes" in err


def _read_only_folder():
    """A folder nobody may create files in, root included (sysfs); None where there is none."""
    import os
    import tempfile

    for d in ("/sys", "/proc/self"):
        if os.path.isdir(d):
            try:
                fd, p = tempfile.mkstemp(dir=d)
            except OSError:
                return d
            os.close(fd)
            os.unlink(p)
    return None


def test_every_output_is_checked_before_any_is_written(small_las, tmp_path, capsys):
    ro = _read_only_folder()
    if ro is None:
        pytest.skip("no read-only folder on this machine")
    gpkg = tmp_path / "t.gpkg"
    # the GeoPackage could be written, the PNG could not: nothing is written, nothing computed
    assert main(["trees", str(small_las), str(gpkg), "-png", f"{ro}/q.png", "-q"]) == 1
    _one_error_line(capsys, "-png", f"cannot write in folder {ro}")
    assert not gpkg.exists() and list(tmp_path.iterdir()) == [small_las]
    assert main(["chm", str(small_las), f"{ro}/c.tif", "-q"]) == 1
    _one_error_line(capsys, "cannot write in folder")
    # two outputs of one run may not be the same file
    assert main(["chm", str(small_las), str(tmp_path / "c.tif"), "-dtm_out",
                 str(tmp_path / "c.tif"), "-q"]) == 1
    _one_error_line(capsys, "-dtm_out", "is also the OUTPUT output")
    assert list(tmp_path.iterdir()) == [small_las]


def test_ground_stores_the_t_srs_operation_in_the_las(tmp_path, capsys):
    from lidartrees_gis.io.lasout import read_provenance
    from lidartrees_gis.synthetic import make_stand, write_xyz_seed_dialect

    from lidartrees_gis.synthetic import StandParams

    pts, _ = make_stand(StandParams(width=30, height=30))
    f = tmp_path / "s.xyz"
    write_xyz_seed_dialect(f, pts)
    out = tmp_path / "g.laz"
    assert main(["ground", str(f), str(out), "-a_srs", "SAD69 24K", "-t_srs", "EPSG:31984"]) == 0
    assert any(ln.startswith("reprojection:") for ln in capsys.readouterr().out.splitlines())
    meta = read_provenance(out)
    assert meta["command"] == "ground" and meta["g"] == -2.0 and meta["w"] == 2.5
    assert "SAD69" in meta["reprojection_source_crs"]
    assert "SAD69 to SIRGAS 2000" in meta["reprojection_operation"]
    assert float(meta["reprojection_accuracy_m"]) > 0
    import laspy

    with laspy.open(str(out)) as fh:
        assert fh.header.parse_crs().to_epsg() == 31984
    # a LAS written from a LAS keeps one provenance record, the newest
    out2 = tmp_path / "g2.laz"
    assert main(["ground", str(out), str(out2), "-reclassify", "-q"]) == 0
    meta2 = read_provenance(out2)
    assert meta2["reclassify"] is True and "reprojection_operation" not in meta2


def test_disk_full_is_one_line_and_leaves_no_part_file(small_las, tmp_path, capsys, monkeypatch):
    import errno

    import lidartrees_gis.io.output as output

    def full(*a, **k):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(output.os, "replace", full)  # the disk fills at the last step
    monkeypatch.setattr(output.os, "link", full)  # (a new output is linked into place)
    out = tmp_path / "c.tif"
    assert main(["chm", str(small_las), str(out), "-q"]) == 1
    _one_error_line(capsys, "No space left on device")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.las"]


def test_printed_lines_follow_a_ptbr_locale(small_las, capsys, monkeypatch):
    """Under pt_BR the printed figures take decimal commas (a list's values parted by
    semicolons), as the tables do; names, paths and versions keep their points."""
    import re

    from lidartrees_gis.io.tables import decimal_commas

    assert main(["info", str(small_las), "-q"]) == 0
    plain = capsys.readouterr().out
    monkeypatch.setenv("LC_ALL", "pt_BR.UTF-8")
    assert main(["info", str(small_las), "-q"]) == 0
    out = capsys.readouterr().out
    dens = re.search(r"density_pts_m2: ([\d.]+)", plain).group(1)
    assert f"density_pts_m2: {dens.replace('.', ',')}\n" in out
    bounds = re.search(r"^bounds: (.*)$", plain, re.M).group(1).split(", ")
    assert len(bounds) >= 4 and f"bounds: {'; '.join(b.replace('.', ',') for b in bounds)}" in out
    assert decimal_commas("stand T1: 624.9 m³/ha ±10.2 % (561.0-688.8), ln zq50 -0.0799") == \
        "stand T1: 624,9 m³/ha ±10,2 % (561,0-688,8), ln zq50 -0,0799"
    assert decimal_commas("spacing: 3x1.5, rows 3.5x2.5 and 3x2") == \
        "spacing: 3x1,5, rows 3,5x2,5 and 3x2"
    for keep in ("/data/2.5/v_1.2.gpkg", "lidartrees_gis 0.21.1", "C:\\voo\\3.5\\a.laz",
                 "2.5e-3", "farm.laz", "voo_3x1.5.laz"):
        assert decimal_commas(keep) == keep


def test_headerless_xyz_reads_a_class_column_but_not_return_numbers(tmp_path):
    """x y z class with no header: the classes are read (said in a warning), so the ground
    class and the noise classes count; x y z return_number (mostly 1) is left unread."""
    import warnings

    from lidartrees_gis.errors import DataWarning
    from lidartrees_gis.io.points import open_points

    rng = np.random.default_rng(3)
    n = 60
    xy = rng.uniform(0, 50, (n, 2)) + [412000.0, 7456000.0]
    cls = np.where(np.arange(n) % 3 == 0, 2, 1)
    cls[5] = 7
    f = tmp_path / "c.xyz"
    f.write_text("".join(f"{x:.2f}\t{y:.2f}\t{10 + i % 5:.2f}\t{c}\n".replace(".", ",")
                         for i, ((x, y), c) in enumerate(zip(xy, cls))), encoding="utf-8")
    with pytest.warns(DataWarning, match="column 4 read as the point classes"):
        pts = open_points(f).read_all()
    assert (pts.classification == cls).all()
    ret = np.where(np.arange(n) % 4 == 0, 2, 1)
    g = tmp_path / "r.xyz"
    g.write_text("".join(f"{x:.2f} {y:.2f} {10 + i % 5:.2f} {r}\n"
                         for i, ((x, y), r) in enumerate(zip(xy, ret))), encoding="utf-8")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        pts = open_points(g).read_all()
    assert getattr(pts, "classification", None) is None or \
        not np.array_equal(pts.classification, ret)
