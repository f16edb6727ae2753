import gzip

import numpy as np
import pytest

from lidartrees_gis.errors import CRSError, InputError, ReadError
from lidartrees_gis.io.points import open_points, sniff_xyz

SEED_LINES = ["412955,63\t7952505,99\t25,4654", "412955,83\t7952506,19\t24,1000",
              "412956,03\t7952506,39\t3,5"]


def _write(tmp_path, name, text, gz=False):
    p = tmp_path / name
    if gz:
        with gzip.open(p, "wt") as fh:
            fh.write(text)
    else:
        p.write_text(text)
    return p


def test_seed_dialect_tab_decimal_comma(tmp_path):
    p = _write(tmp_path, "a.xyz", "\n".join(SEED_LINES) + "\n")
    d = sniff_xyz(p)
    assert d.delimiter == "\t" and d.decimal_comma and not d.header
    pts = open_points(p, a_srs="EPSG:29194").read_all()
    np.testing.assert_allclose(pts.x, [412955.63, 412955.83, 412956.03])
    np.testing.assert_allclose(pts.z, [25.4654, 24.1, 3.5])


@pytest.mark.parametrize("text,delim,dc", [
    ("1.5 2.5 3.5\n4 5 6\n", None, False),
    ("1.5,2.5,3.5\n4,5,6\n", ",", False),
    ("1,5;2,5;3,5\n4;5;6\n", ";", True),
    ("1,5  2,5\t 3,5\n4 5 6\n", None, True),
])
def test_dialects_detected(tmp_path, text, delim, dc):
    p = _write(tmp_path, "p.txt", text)
    d = sniff_xyz(p)
    assert d.delimiter == delim and d.decimal_comma == dc
    pts = open_points(p).read_all()
    np.testing.assert_allclose(np.c_[pts.x, pts.y, pts.z], [[1.5, 2.5, 3.5], [4, 5, 6]])


def test_header_maps_extra_columns(tmp_path):
    p = _write(tmp_path, "h.csv", "Z,X,Y,Intensity,Classification\n3,1,2,100,2\n6,4,5,50,1\n")
    pts = open_points(p).read_all()
    assert pts.x.tolist() == [1, 4] and pts.z.tolist() == [3, 6]
    assert pts.intensity.tolist() == [100, 50] and pts.classification.tolist() == [2, 1]


def test_forced_columns_and_delimiter(tmp_path):
    p = _write(tmp_path, "c.txt", "7|1|2|3\n8|4|5|6\n")
    pts = open_points(p, delimiter="|", columns="return_number,x,y,z").read_all()
    assert pts.return_number.tolist() == [7, 8] and pts.z.tolist() == [3, 6]


def test_gzip_input(tmp_path):
    p = _write(tmp_path, "g.xyz.gz", "\n".join(SEED_LINES) + "\n", gz=True)
    assert len(open_points(p).read_all()) == 3


def test_chunks_bound_memory(tmp_path):
    rows = "\n".join(f"{i}.5 {i}.25 {i}" for i in range(1000))
    p = _write(tmp_path, "many.xyz", rows + "\n")
    src = open_points(p, chunk_size=64)
    sizes = [len(c) for c in src.chunks()]
    assert max(sizes) == 64 and sum(sizes) == 1000 and len(sizes) == 16


def test_malformed_line_named_with_number_and_text(tmp_path):
    lines = [f"{i}.0 {i}.0 1.0" for i in range(1, 2000)]
    lines[1233] = "12.0 abc 1.0"  # line 1234
    p = _write(tmp_path, "bad.xyz", "\n".join(lines) + "\n")
    with pytest.raises(InputError, match=r"bad.xyz:1234: .*'12.0 abc 1.0'"):
        open_points(p, chunk_size=500).read_all()
    src = open_points(p, skip_invalid=True, chunk_size=500)
    assert len(src.read_all()) == 1998 and src.skipped == 1


def test_nan_and_inf_values_rejected(tmp_path):
    p = _write(tmp_path, "n.xyz", "1 2 3\n4 nan 6\n7 8 inf\n")
    with pytest.raises(InputError, match=":2: value is NaN"):
        open_points(p).read_all()
    src = open_points(p, skip_invalid=True)
    assert len(src.read_all()) == 1 and src.skipped == 2


def test_too_few_columns(tmp_path):
    p = _write(tmp_path, "t.xyz", "1 2\n3 4\n")
    with pytest.raises(InputError, match="need at least x, y, z"):
        open_points(p)


@pytest.mark.parametrize("text", ["", "# only a comment\n\n"])
def test_empty_files(tmp_path, text):
    p = _write(tmp_path, "e.xyz", text)
    with pytest.raises(InputError, match="e.xyz"):
        open_points(p).read_all()


def test_missing_file_is_read_error(tmp_path):
    with pytest.raises(ReadError, match="no such file"):
        open_points(tmp_path / "nope.laz")


def test_t_srs_needs_source_crs(tmp_path):
    p = _write(tmp_path, "a.xyz", "\n".join(SEED_LINES) + "\n")
    with pytest.raises(CRSError, match="-a_srs"):
        open_points(p, t_srs="EPSG:31984")
    with pytest.raises(CRSError, match="-a_srs"):
        open_points(p, require_crs=True)


def test_sidecar_prj_gives_crs(tmp_path):
    import pyproj

    p = _write(tmp_path, "a.xyz", "\n".join(SEED_LINES) + "\n")
    (tmp_path / "a.prj").write_text(pyproj.CRS.from_epsg(29194).to_wkt())
    assert open_points(p).crs.to_epsg() == 29194


@pytest.mark.realdata
@pytest.mark.parametrize("name,count", [
    ("ITSMe_tree_1_pc.txt", 30826), ("ITSMe_tree_2_pc.txt", 51750), ("ITSMe_dtm.txt", 11415),
    ("rTLS_pc_tree.txt", 75812), ("rTwig_cloud.txt", 14667)])
def test_real_xyz_text_files(data, name, count):
    src = open_points(data(f"xyz_text/{name}"), chunk_size=20_000)
    st = src.scan()
    assert st.count == count and st.skipped == 0
    assert st.zrange[1] > st.zrange[0]


@pytest.mark.realdata
def test_las_crs_classes_and_returns(data):
    src = open_points(data("lidR_extdata/Topography.laz"), chunk_size=10_000)
    assert src.crs.to_epsg() == 2949
    st = src.scan()
    assert st.count == 73403
    assert st.classes == {1: 61347, 2: 8159, 9: 3897}
    assert max(st.returns) == 6


def test_class_filter_drops_and_counts(tmp_path):
    import numpy as np

    from lidartrees_gis.io.lasout import write_points
    from lidartrees_gis.io.points import open_points

    f = tmp_path / "c.las"
    cls = np.array([1] * 10 + [2] * 5 + [7] * 3 + [18] * 2, np.uint8)
    write_points(f, np.arange(20.0), np.arange(20.0), np.arange(20.0), classification=cls)
    src = open_points(f)
    src.set_class_filter(drop=(7, 18))
    pts = src.read_all()
    assert len(pts) == 15 and src.dropped == {7: 3, 18: 2}
    src.set_class_filter(keep=(2,))
    assert len(src.read_all()) == 5 and src.dropped == {1: 10, 7: 3, 18: 2}
    src.set_class_filter()
    assert len(src.read_all()) == 20 and src.dropped == {}
