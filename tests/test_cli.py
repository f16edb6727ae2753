import json
import re

import numpy as np
import pyproj
import pytest
import rasterio

from lidartrees_gis.cli import main
from lidartrees_gis.synthetic import write_xyz_seed_dialect


@pytest.fixture
def seed_xyz(tmp_path, stand):
    p = tmp_path / "stand.xyz"
    write_xyz_seed_dialect(p, stand[0])
    return p


def test_grid_xyz_seed_dialect_with_a_srs(tmp_path, seed_xyz, stand):
    out = tmp_path / "dsm.tif"
    assert main(["grid", str(seed_xyz), str(out), "-tr", "1", "-a_srs", "EPSG:29194", "-q"]) == 0
    with rasterio.open(out) as ds:
        assert ds.crs.to_epsg() == 29194
        assert ds.res == (1.0, 1.0)
        assert ds.transform.c % 1 == 0 and ds.transform.f % 1 == 0
        a = ds.read(1, masked=True)
        pts = stand[0]
        assert float(a.max()) == pytest.approx(np.round(pts.z, 4).max(), abs=1e-3)
        assert ds.tags()["LIDARTREES_COMMAND"] == "grid"
        assert ds.profile["compress"].lower() == "deflate" and ds.profile["tiled"]


def test_grid_reprojected_to_sirgas_shifted_as_pyproj_says(tmp_path, seed_xyz):
    a, b = tmp_path / "a.tif", tmp_path / "b.tif"
    assert main(["grid", str(seed_xyz), str(a), "-tr", "1", "-a_srs", "SAD69 24K", "-q"]) == 0
    assert main(["grid", str(seed_xyz), str(b), "-tr", "1", "-a_srs", "SAD69 24K",
                 "-t_srs", "EPSG:31984", "-q"]) == 0
    with rasterio.open(a) as da, rasterio.open(b) as db:
        assert db.crs.to_epsg() == 31984
        tr = pyproj.Transformer.from_crs(29194, 31984, always_xy=True)
        # the highest cell moves with the points: compare its centre to pyproj's shift
        ia = np.unravel_index(np.argmax(da.read(1)), da.shape)
        ib = np.unravel_index(np.argmax(db.read(1)), db.shape)
        xa, ya = da.xy(*ia)
        xb, yb = db.xy(*ib)
        ex, ey = tr.transform(xa, ya)
        assert abs(xb - ex) <= 1.0 and abs(yb - ey) <= 1.0
        assert abs(xb - xa) > 5 or abs(yb - ya) > 5


def test_malformed_line_fails_naming_line_and_leaves_no_output(tmp_path, capsys):
    lines = [f"{412000 + i * 0.1:.2f}\t7952000,00\t10,0".replace(".", ",") for i in range(2000)]
    lines[1233] = "412123,4\tX\t10,0"
    p = tmp_path / "bad.xyz"
    p.write_text("\n".join(lines) + "\n")
    out = tmp_path / "out.tif"
    rc = main(["grid", str(p), str(out), "-tr", "1", "-a_srs", "EPSG:29194", "-q"])
    assert rc == 1
    err = capsys.readouterr().err
    assert "bad.xyz:1234" in err and "412123,4" in err
    assert list(tmp_path.iterdir()) == [p]
    assert main(["grid", str(p), str(out), "-tr", "1", "-a_srs", "EPSG:29194", "-q",
                 "--skip-invalid"]) == 0
    assert out.exists()


def test_existing_output_refused_untouched_then_overwritten(tmp_path, seed_xyz, capsys):
    out = tmp_path / "o.tif"
    out.write_bytes(b"keep me")
    rc = main(["chm", str(seed_xyz), str(out), "-tr", "1", "-a_srs", "EPSG:29194", "-q"])
    assert rc == 1 and out.read_bytes() == b"keep me"
    assert "-overwrite" in capsys.readouterr().err
    assert main(["chm", str(seed_xyz), str(out), "-tr", "1", "-a_srs", "EPSG:29194", "-q",
                 "-overwrite"]) == 0
    with rasterio.open(out) as ds:
        assert ds.crs.to_epsg() == 29194


def test_bad_parameter_exit_code_and_message(tmp_path, seed_xyz, capsys):
    rc = main(["grid", str(seed_xyz), str(tmp_path / "x.tif"), "-tr", "-2", "-a_srs", "EPSG:29194", "-q"])
    assert rc == 1 and "-tr" in capsys.readouterr().err
    with pytest.raises(SystemExit) as e:
        main(["grid", str(seed_xyz), str(tmp_path / "x.tif"), "-tr", "1", "-stat", "median"])
    assert e.value.code == 2


def test_info_json(seed_xyz, capsys, stand):
    assert main(["info", str(seed_xyz), "-a_srs", "SAD69/UTM24S", "--json", "-q"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["points"] == len(stand[0])
    assert d["crs"].startswith("EPSG:29194")
    assert d["density_pts_m2"] == pytest.approx(25, rel=0.05)


def test_tr_auto_uses_density(tmp_path, seed_xyz):
    out = tmp_path / "auto.tif"
    assert main(["grid", str(seed_xyz), str(out), "-tr", "auto", "-a_srs", "EPSG:29194", "-q"]) == 0
    with rasterio.open(out) as ds:
        assert ds.res[0] == pytest.approx(0.2, abs=0.005)  # 25 pts/m2 -> 0.2 m


def test_one_point_and_coincident_points(tmp_path):
    p = tmp_path / "one.xyz"
    p.write_text("10.2 20.3 5.0\n")
    out = tmp_path / "one.tif"
    assert main(["grid", str(p), str(out), "-tr", "1", "-q"]) == 1  # no CRS: refused
    assert main(["grid", str(p), str(out), "-tr", "1", "-q", "--allow-no-crs"]) == 0
    with rasterio.open(out) as ds:
        assert ds.shape == (1, 1) and ds.read(1)[0, 0] == 5.0
    q = tmp_path / "same.xyz"
    q.write_text("1 1 1\n1 1 2\n")
    assert main(["grid", str(q), str(tmp_path / "s.tif"), "-tr", "auto", "-q",
                 "--allow-no-crs"]) == 1
    assert not (tmp_path / "s.tif").exists()


def test_external_dtm_geotiff_on_same_grid_gives_same_chm(tmp_path, seed_xyz):
    a, dtm, b = tmp_path / "a.tif", tmp_path / "dtm.tif", tmp_path / "b.tif"
    common = ["-tr", "1", "-a_srs", "EPSG:29194", "-q"]
    assert main(["chm", str(seed_xyz), str(a), "-dtm", "lowest:5", "-dtm_out", str(dtm), *common]) == 0
    assert main(["chm", str(seed_xyz), str(b), "-dtm", str(dtm), *common]) == 0
    with rasterio.open(a) as da, rasterio.open(b) as db:
        np.testing.assert_allclose(db.read(1), da.read(1), atol=1e-3)
    assert main(["chm", str(seed_xyz), str(tmp_path / "c.tif"), "-dtm", "nope.tif", *common]) == 1


def test_external_dtm_that_does_not_cover_the_points_is_an_error(tmp_path, seed_xyz, capsys):
    dtm, half = tmp_path / "dtm.tif", tmp_path / "half.tif"
    common = ["-tr", "1", "-a_srs", "EPSG:29194", "-q"]
    assert main(["chm", str(seed_xyz), str(tmp_path / "a.tif"), "-dtm", "lowest:5", "-dtm_out",
                 str(dtm), *common]) == 0
    with rasterio.open(dtm) as ds:  # keep the western half only
        prof, arr = ds.profile, ds.read(1)
        w = ds.width // 2
        prof.update(width=w)
        with rasterio.open(half, "w", **prof) as out:
            out.write(arr[:, :w], 1)
    capsys.readouterr()
    out = tmp_path / "c.tif"
    assert main(["chm", str(seed_xyz), str(out), "-dtm", str(half), *common]) == 1
    err = capsys.readouterr().err
    assert "does not cover the points" in err and str(half) in err
    assert not out.exists()


def test_progress_lines_and_result_json_for_driving_programs(tmp_path, seed_xyz, capfd):
    res = tmp_path / "r.json"
    assert main(["grid", str(seed_xyz), str(tmp_path / "g.tif"), "-tr", "1", "-a_srs",
                 "EPSG:29194", "--progress-lines", "--result-json", str(res)]) == 0
    err = capfd.readouterr().err.splitlines()
    pct = [float(line.split()[1]) for line in err if line.startswith("PROGRESS ")]
    assert pct[-1] == 100.0 and len(pct) > 2 and pct == sorted(pct)
    assert json.loads(res.read_text())["points"] > 80_000


def test_sigterm_removes_partial_output(tmp_path, seed_xyz):
    import signal
    import subprocess
    import sys
    import time

    big = tmp_path / "big.xyz"
    big.write_text(seed_xyz.read_text() * 30)
    out = tmp_path / "o.tif"
    p = subprocess.Popen([sys.executable, "-m", "lidartrees_gis.cli", "chm", str(big), str(out),
                          "-tr", "0.2", "-a_srs", "EPSG:29194", "--progress-lines"],
                         stderr=subprocess.PIPE, text=True)
    for line in p.stderr:  # wait until it is working
        if line.startswith("PROGRESS") and float(line.split()[1]) > 5:
            break
    time.sleep(0.2)
    p.send_signal(signal.SIGTERM)
    p.communicate(timeout=120)
    assert p.returncode == 130
    assert not out.exists()
    assert not [f for f in tmp_path.iterdir() if ".part" in f.name]


def test_results_are_plain_lines_on_stdout_even_with_q(tmp_path, capsys):
    """Issue 26: the result goes to stdout as `key: value` lines (nested values flattened, no
    Python reprs), printed with -q too; with stderr not a terminal no progress frames are
    written; --json gives JSON."""
    out = tmp_path / "d"
    assert main(["demo", str(out), "-q"]) == 0
    c = capsys.readouterr()
    lines = c.out.splitlines()
    assert "trees_truth: 592" in lines and "accuracy.f_score: 1.0" in lines
    assert not any("{" in ln or "[" in ln for ln in lines)
    assert all(re.match(r"^[\w.]+: ", ln) for ln in lines)
    assert "\r" not in c.err and "%|" not in c.err
    assert main(["demo", str(out), "-overwrite"]) == 0  # no -q: stderr is not a terminal here
    c = capsys.readouterr()
    assert "accuracy.recall: 1.0" in c.out and "\r" not in c.err
    assert main(["info", str(out / "stand.xyz"), "-a_srs", "EPSG:29194", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["points"] > 80000


def test_first_run_note_only_without_the_kernel_cache(monkeypatch, capsys):
    """Issue 25: the first run after an install compiles the numba kernels; a person at a
    terminal is told so in one line, once (the cache then exists)."""
    from lidartrees_gis import _accel
    from lidartrees_gis.cli.app import _first_run_note

    if not _accel.HAVE_NUMBA:
        pytest.skip("numba not importable")
    monkeypatch.setattr(_accel, "kernels_cached", lambda: False)
    _first_run_note()
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and "compiling the numba kernels once" in err[0]
    monkeypatch.setattr(_accel, "kernels_cached", lambda: True)
    _first_run_note()
    assert capsys.readouterr().err == ""
