"""Issue 26: what a user gets when the input or an option is wrong: refusals instead of hangs,
hints that fit the file, the right advice for mixed datums."""
import json

import numpy as np
import pytest
from pyproj import CRS, Transformer

from lidartrees_gis.cli import main


@pytest.mark.parametrize("size", ["0.5", "1e-3", "9", "39"])
def test_tiny_tiles_are_refused_at_once(size, tmp_path, capsys, data):
    """-tile_size 0.5 and 1e-3 ran until killed (millions of tiles): a tile smaller than 20
    cells or than twice the buffer (chm: 20 m) is refused, naming the smallest allowed."""
    out = tmp_path / "c.tif"
    assert main(["chm", str(data("lidR_extdata/MixedConifer.laz")), str(out), "-tile_size", size,
                 "-q"]) == 1
    err = capsys.readouterr().err
    assert "-tile_size" in err and "at least 40 m" in err and not out.exists()
    if size == "39":  # a smaller buffer allows it
        assert main(["chm", str(data("lidR_extdata/MixedConifer.laz")), str(out), "-tile_size",
                     size, "-buffer", "15", "-q"]) == 0 and out.exists()


def test_missing_crs_hint_fits_the_coordinates(tmp_path, capsys):
    """No SAD-69 zone suggested for every file: UTM-like coordinates get no guessed zone,
    longitude/latitude get a geographic CRS."""
    utm = tmp_path / "utm.xyz"
    utm.write_text("".join(f"{300000 + i} {4100000 + i} 10\n" for i in range(50)))
    assert main(["chm", str(utm), str(tmp_path / "a.tif"), "-q"]) == 1
    err = capsys.readouterr().err
    assert "look like UTM" in err and "29194" not in err and "-a_srs" in err
    ll = tmp_path / "ll.xyz"
    ll.write_text("".join(f"{-43.2 + i * 1e-5} {-22.9 + i * 1e-5} 10\n" for i in range(50)))
    assert main(["chm", str(ll), str(tmp_path / "b.tif"), "-q"]) == 1
    assert "EPSG:4674" in capsys.readouterr().err


def test_a_folder_mixing_datums_is_told_to_use_t_srs(tmp_path, capsys):
    """Half a stand in SIRGAS 2000 / UTM 24S and half in SAD69 / UTM 24S: the error advises
    -t_srs (never -a_srs, which would put the SAD-69 half about 60 m off); with -t_srs the
    trees are those of the whole stand in SIRGAS 2000."""
    import pyogrio

    from lidartrees_gis.io.lasout import write_points
    from lidartrees_gis.synthetic import StandParams, make_stand

    pts, _ = make_stand(StandParams(width=40, height=40))
    d = tmp_path / "voo"
    d.mkdir()
    west = pts.x < np.median(pts.x)
    sirgas, sad = CRS.from_epsg(31984), CRS.from_epsg(29194)
    write_points(d / "a.las", pts.x[west], pts.y[west], pts.z[west], crs=sirgas,
                 classification=pts.classification[west])
    tx, ty = Transformer.from_crs(sirgas, sad, always_xy=True).transform(pts.x[~west], pts.y[~west])
    write_points(d / "b.las", tx, ty, pts.z[~west], crs=sad,
                 classification=pts.classification[~west])
    assert main(["trees", str(d), str(tmp_path / "x.gpkg"), "-q"]) == 1
    err = capsys.readouterr().err
    assert "-t_srs" in err and "give -a_srs" not in err
    whole = tmp_path / "whole.las"
    write_points(whole, pts.x, pts.y, pts.z, crs=sirgas, classification=pts.classification)
    capsys.readouterr()
    assert main(["trees", str(d), str(tmp_path / "t.gpkg"), "-t_srs", "EPSG:31984", "-q"]) == 0
    # each file's operation is recorded (the report named only the first file's, a no-op)
    line = [ln for ln in capsys.readouterr().out.splitlines() if ln.startswith("reprojection:")]
    assert len(line) == 1 and "SAD69" in line[0] and "[1 file(s)]" in line[0]
    meta = pyogrio.read_info(tmp_path / "t.gpkg", layer="tree_tops")["layer_metadata"]
    files = json.loads(meta["reprojection_files"])
    assert "SAD69" in files[str(d / "b.las")]["source_crs"]
    assert "SAD69 to SIRGAS 2000" in files[str(d / "b.las")]["operation"]
    assert "SIRGAS 2000" in files[str(d / "a.las")]["source_crs"]
    assert float(meta["reprojection_accuracy_m"]) >= files[str(d / "b.las")]["accuracy_m"] > 0
    assert main(["trees", str(whole), str(tmp_path / "w.gpkg"), "-q"]) == 0
    a = pyogrio.read_dataframe(tmp_path / "t.gpkg", layer="tree_tops")
    b = pyogrio.read_dataframe(tmp_path / "w.gpkg", layer="tree_tops")
    assert abs(len(a) - len(b)) <= 2 and len(b) > 200
    from scipy.spatial import cKDTree

    dist, _ = cKDTree(np.c_[b.geometry.x, b.geometry.y]).query(np.c_[a.geometry.x, a.geometry.y])
    assert np.median(dist) < 0.3


def _corrupt_laz(src, kind):
    import struct

    b = bytearray(src.read_bytes())
    off, = struct.unpack_from("<I", b, 96)
    ct, = struct.unpack_from("<q", b, off)
    if kind == "table_overwritten":
        b[ct:ct + 64] = b"\xff" * 64
    elif kind == "offset_doubled":
        struct.pack_into("<I", b, 96, off * 2)
    elif kind == "billion_chunks":
        struct.pack_into("<II", b, ct, 0, 10 ** 9)
    elif kind == "entries_garbage":
        struct.pack_into("<II", b, ct, 0, 2)
        b[ct + 8:] = b"\xff" * (len(b) - ct - 8)
    elif kind == "points_zeroed":
        b[5000:9000] = b"\x00" * 4000
    return bytes(b)


@pytest.mark.realdata
@pytest.mark.parametrize("kind", ["table_overwritten", "offset_doubled", "billion_chunks",
                                  "entries_garbage", "points_zeroed"])
def test_a_corrupt_laz_is_one_line_never_an_abort(kind, data, tmp_path):
    """The LAZ decoder aborted the process (SIGABRT and a Rust backtrace of 125 lines) on a
    chunk table overwritten; now the chunk table is checked before decoding and a decoder
    panic is one line naming the file. Run in a subprocess: an abort would kill pytest."""
    import os
    import subprocess
    import sys

    f = tmp_path / f"{kind}.laz"
    f.write_bytes(_corrupt_laz(data("lidR_extdata/MixedConifer.laz"), kind))
    env = dict(os.environ, RUST_BACKTRACE="1")
    for args in (["info", str(f)], ["chm", str(f), str(tmp_path / "c.tif")]):
        p = subprocess.run([sys.executable, "-m", "lidartrees_gis.cli", *args, "-q"],
                           capture_output=True, text=True, env=env, timeout=120)
        lines = [ln for ln in p.stderr.splitlines() if ln.strip()]
        assert p.returncode == 1, (kind, args[0], p.returncode, p.stderr[-300:])
        assert len(lines) == 1 and str(f) in lines[0] and "error:" in lines[0], lines[:3]
    assert not (tmp_path / "c.tif").exists()


def test_thousands_separators_are_read_and_named(tmp_path, capsys):
    """412.955,63 (pt-BR: dots between thousands, a decimal comma) was read as 412.955 with
    exit 0; now the dots are dropped and the columns that use them are named."""
    from lidartrees_gis.io.points import open_points

    f = tmp_path / "voo.txt"
    f.write_text("X\tY\tZ\n" + "".join(f"412.{955 + i:03d},63\t7.952.{505 + i:03d},99\t25,46\n"
                                       for i in range(20)), encoding="utf-8")
    with pytest.warns(Warning, match="x, y group thousands"):
        p = open_points(f).read_all()
    # coordinates to the centimetre: a relative tolerance would let UTM y be 7.95 m off
    assert p.x[0] == pytest.approx(412955.63, abs=0.01)
    assert p.y[-1] == pytest.approx(7952524.99, abs=0.01)
    assert p.z[0] == pytest.approx(25.46, abs=0.01)
    assert main(["info", str(f), "-a_srs", "EPSG:31984", "-q"]) == 0
    c = capsys.readouterr()
    assert "412955.63" in c.out and "thousands" in c.err


@pytest.mark.realdata
def test_isolated_low_and_high_points_are_removed_and_counted(data, tmp_path, capsys):
    """Two class-2 returns 500 m below the ground pulled the DTM down (and the canopy up) without
    a word; three returns 10 km above the canopy must not reach the CHM either. Both are left
    out and counted in outlier_points."""
    import laspy
    import rasterio

    src = data("lidR_extdata/MixedConifer.laz")
    base = tmp_path / "base.tif"
    assert main(["chm", str(src), str(base), "-dtm_out", str(tmp_path / "bd.tif"), "-q"]) == 0
    for kind, idx, dz in (("low", [5, 15000], -500.0), ("high", [100, 20000, 30000], 1e4)):
        las = laspy.read(src)
        z = np.asarray(las.z).copy()
        if kind == "low":
            idx = [int(i) for i in np.nonzero(np.asarray(las.classification) == 2)[0][[5, 900]]]
        z[idx] += dz
        las.z = z
        las.update_header()
        f = tmp_path / f"{kind}.laz"
        las.write(str(f))
        out = tmp_path / f"{kind}.tif"
        assert main(["chm", str(f), str(out), "-dtm_out", str(tmp_path / f"{kind}_d.tif")]) == 0
        assert f"outlier_points: {len(idx)}" in capsys.readouterr().out
        with rasterio.open(out) as a, rasterio.open(base) as b:
            assert abs(float(a.read(1, masked=True).max()) - float(b.read(1, masked=True).max())) < 0.01
        with rasterio.open(tmp_path / f"{kind}_d.tif") as a, rasterio.open(tmp_path / "bd.tif") as b:
            assert float(a.read(1, masked=True).min()) > float(b.read(1, masked=True).min()) - 0.01


def _one_point_100_km_east(data, tmp_path):
    """MixedConifer with its first point moved 100 km east: the LAS file and the points."""
    import laspy

    las = laspy.read(data("lidR_extdata/MixedConifer.laz"))
    x = np.asarray(las.x).copy()
    x[0] += 100_000
    las.x = x
    las.update_header()
    f = tmp_path / "far.las"
    las.write(str(f))
    return f, las


@pytest.mark.realdata
def test_one_point_far_from_the_rest_is_left_out_with_a_warning(data, tmp_path, capsys):
    """A LAS with one point 100 km east of the rest was refused (without -tr) or stretched the
    outputs 1,112 times (with -tr): now it is left out of every output, one warning names it,
    the summary counts it and the trees are those of the file without it (issue 42)."""
    f, _ = _one_point_100_km_east(data, tmp_path)
    ref = main(["trees", str(data("lidR_extdata/MixedConifer.laz")), str(tmp_path / "r.gpkg"),
                "-q"])
    ref_out = capsys.readouterr().out
    assert ref == 0
    assert main(["trees", str(f), str(tmp_path / "t.gpkg"), "-q"]) == 0
    c = capsys.readouterr()
    assert "1 point(s) lie far from the other 37,656" in c.err and "left out" in c.err
    assert "far_points: 1" in c.out
    trees = [line for line in c.out.splitlines() if line.startswith("trees:")]
    assert trees == [line for line in ref_out.splitlines() if line.startswith("trees:")]


@pytest.mark.realdata
def test_a_far_point_with_a_given_cell_size_is_left_out(data, tmp_path, capsys):
    """With -tr given the far point was accepted without a word and stretched the outputs
    1,112 times: it is left out, the CHM covers the others only. Two halves of a file far
    apart (two farms) are not "a few points" and are kept."""
    import rasterio

    from lidartrees_gis.als.area import far_points

    f, las = _one_point_100_km_east(data, tmp_path)
    assert main(["chm", str(f), str(tmp_path / "c.tif"), "-tr", "0.5"]) == 0
    err = capsys.readouterr().err
    assert "1 point(s) lie far from the other 37,656" in err
    with rasterio.open(tmp_path / "c.tif") as ds:
        assert ds.width <= 182 and ds.height <= 182  # 90 m at 0.5 m, not 100 km
    x = np.asarray(las.x)
    y = np.asarray(las.y)
    assert far_points(x, y)[0].sum() == 1
    two = np.where(np.arange(x.size) % 2 == 0, x, x + 50_000)  # two farms 50 km apart
    assert far_points(two, y)[0].sum() == 0


@pytest.mark.realdata
def test_a_single_file_with_scheduler_says_why_it_runs_here(data, tmp_path, capsys):
    """A single small file with --scheduler ran locally without a word: it is one tile, run in
    this process, and a warning says so (no connection is tried)."""
    out = tmp_path / "t.gpkg"
    assert main(["trees", str(data("lidR_extdata/MixedConifer.laz")), str(out),
                 "--scheduler", "tcp://127.0.0.1:9", "-q"]) == 0
    err = capsys.readouterr().err
    assert "one tile, run in this process" in err and "--scheduler tcp://127.0.0.1:9" in err


def test_findings_of_the_independent_fuzzer_are_one_line_errors(tmp_path, capsys):
    """benchmarks/fuzz_independent.py found: an empty number (`-min_height ""`, as QGIS sends
    an unset field) raised a TypeError; `-refine inf` an OverflowError; `-window_factor 1e9` a
    numpy "array is too big"; `profile`/`stem` on points spanning kilometres in z ran until
    killed (millions of bins). Now: empty = not given, the others one-line errors."""
    from lidartrees_gis.als.trees import TreeParams
    from lidartrees_gis.cli.actions import _kp_params, _tree_params
    from lidartrees_gis.io.lasout import write_points

    assert _tree_params({"min_height": "", "connectivity": "", "window_factor": ""}) == TreeParams()
    assert _kp_params({"refine": "", "g": ""}).refine == 10
    rng = np.random.default_rng(0)
    f = tmp_path / "t.las"
    z = rng.random(500) * 20
    z[0] = 400_000.0  # one wrong digit run wild
    write_points(f, rng.random(500), rng.random(500), z, crs=CRS.from_epsg(31984))
    cases = [(["ground", str(f), str(tmp_path / "g.tif"), "-refine", "inf"], "-refine"),
             (["trees", str(f), str(tmp_path / "t.gpkg"), "-window_factor", "1e9"],
              "-window_factor must be > 0 and <= 20"),
             (["profile", str(f), str(tmp_path / "p.las")], "span 400,000 m in z"),
             (["stem", str(f), str(tmp_path / "s")], "one tree spans at most 300 m")]
    for argv, words in cases:
        assert main(argv + ["-q"]) == 1, argv
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and words in err[0] and "Traceback" not in err[0], (argv, err)
    assert sorted(q.name for q in tmp_path.iterdir()) == ["t.las"]  # nothing written


def test_ground_on_a_strip_one_refinement_cell_wide():
    """Found by the independent fuzzer (`ground` on a stem's scan with -tin_cell 0): the
    densification's TIN grid was one cell wide and np.gradient raised. A strip is ground too."""
    from lidartrees_gis.ground.filter import KrausPfeifer, kraus_pfeifer

    rng = np.random.default_rng(4)
    n = 3000
    x = rng.random(n) * 0.3  # 30 cm wide, 40 m long: less than one refinement cell across
    y = rng.random(n) * 40
    z = 0.05 * y + rng.normal(0, 0.02, n)
    z[::10] += 5 + rng.random(n // 10) * 10  # vegetation above every tenth point
    ground, _ = kraus_pfeifer(x, y, z, KrausPfeifer(tin_cell=0))
    veg = np.zeros(n, bool)
    veg[::10] = True
    assert not ground[veg].any()
    assert ground[~veg].mean() > 0.9


def test_second_round_of_the_independent_fuzzer(tmp_path, capsys):
    """Its 10,000-case runs found: a laszip VLR whose chunk size was overwritten (3.7 billion
    points a chunk) aborted the process (the decoder allocated 205 GB); -iterations 1e9 ran
    until killed; -nln /tmp/x raised GDAL's error as a traceback; stem -hspacing inf an
    IndexError; profile -sigma inf an OverflowError. Now one line each (no option takes nan or
    inf), nothing written."""
    import struct

    from lidartrees_gis.io.lasout import write_points

    rng = np.random.default_rng(1)
    laz = tmp_path / "a.laz"
    write_points(laz, rng.random(2000) * 50, rng.random(2000) * 50, rng.random(2000) * 20,
                 crs=CRS.from_epsg(31984))
    b = bytearray(laz.read_bytes())
    hsize, = struct.unpack_from("<H", b, 94)
    offset, nvlr = struct.unpack_from("<II", b, 96)
    pos = hsize
    for _ in range(nvlr):  # the laszip VLR's chunk size, 12 bytes into its body
        user, rec, length = bytes(b[pos + 2:pos + 18]).rstrip(b"\0"), *struct.unpack_from(
            "<HH", b, pos + 18)
        if user == b"laszip encoded" and rec == 22204:
            struct.pack_into("<I", b, pos + 54 + 12, 3_674_260_304)
        pos += 54 + length
    bad = tmp_path / "bad.laz"
    bad.write_bytes(bytes(b))
    cases = [(["info", str(bad)], "points per chunk"),
             (["grid", str(bad), str(tmp_path / "g.tif")], "points per chunk"),
             (["ground", str(laz), str(tmp_path / "g.laz"), "-iterations", "1e9"],
              "-iterations must be 1 to 100"),
             (["trees", str(laz), str(tmp_path / "t.gpkg"), "-nln", "/tmp/x"],
              "-nln: '/tmp/x'"),
             (["stem", str(laz), str(tmp_path / "s"), "-hspacing", "inf"],
              "-hspacing: expected a finite number"),
             (["stem", str(laz), str(tmp_path / "s"), "-hspacing", "2"],
              "-hspacing 2 m is wider than the search window"),
             (["profile", str(laz), str(tmp_path / "p.laz"), "-sigma", "inf"],
              "-sigma: expected a finite number"),
             (["profile", str(laz), str(tmp_path / "p.laz"), "-sigma", "1e6"],
              "-sigma must be > 0 and <= 10 m")]
    for argv, words in cases:
        assert main(argv + ["-q"]) == 1, argv
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and words in err[0], (argv, err)
    assert sorted(q.name for q in tmp_path.iterdir()) == ["a.laz", "bad.laz"]
