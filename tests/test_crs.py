import numpy as np
import pyproj
import pytest

from lidartrees_gis.crs import parse_crs, reprojection
from lidartrees_gis.errors import CRSError


@pytest.mark.parametrize("text,epsg", [
    ("EPSG:29194", 29194), ("29194", 29194), ("SAD69/UTM24S", 29194), ("SAD69 24K", 29194),
    ("sad-69 / utm 23s", 29193), ("SIRGAS2000/UTM24S", 31984), ("SIRGAS 2000 24K", 31984),
    ("WGS84/UTM23S", 32723), ("+proj=utm +zone=24 +south +ellps=GRS80 +units=m +no_defs", None),
])
def test_parse_crs_forms(text, epsg):
    crs = parse_crs(text)
    if epsg:
        assert crs.to_epsg() == epsg
    else:
        assert crs.is_projected


def test_parse_crs_bad_text_names_parameter():
    with pytest.raises(CRSError, match="-a_srs: cannot understand CRS 'EPSG:99999999'"):
        parse_crs("EPSG:99999999")


def test_sad69_to_sirgas_matches_pyproj_and_reports_operation():
    r = reprojection("EPSG:29194", "EPSG:31984")
    x, y = r(412955.63, 7952505.99)
    ex, ey = pyproj.Transformer.from_crs(29194, 31984, always_xy=True).transform(412955.63, 7952505.99)
    assert (x, y) == pytest.approx((ex, ey), abs=1e-6)
    # SAD69 -> SIRGAS shifts tens of metres
    assert 20 < abs(x - 412955.63) + abs(y - 7952505.99) < 200
    rep = r.report()
    assert "EPSG:29194" in rep and "EPSG:31984" in rep
    grid_here = not pyproj.transformer.TransformerGroup(29194, 31984).unavailable_operations
    if grid_here:
        assert "1 m" in rep
    else:
        assert "5 m" in rep and "br_ibge_SAD69_003.tif" in rep


def test_a_geographic_t_srs_is_refused_with_the_points_utm_zone(tmp_path, capsys):
    """-t_srs EPSG:4674 (degrees): the grids need metres; the error names -t_srs (not the
    points) and suggests the zone the points lie in (23S here, not another)."""
    from lidartrees_gis.cli import main
    from lidartrees_gis.crs import utm_hint
    from lidartrees_gis.io.lasout import write_points

    x = np.array([412000.0, 412050.0, 412100.0])
    y = np.array([7456000.0, 7456050.0, 7456100.0])
    write_points(tmp_path / "p.laz", x, y, np.array([800.0, 801.0, 802.0]),
                 crs=pyproj.CRS.from_epsg(31983))
    capsys.readouterr()
    assert main(["chm", str(tmp_path / "p.laz"), str(tmp_path / "c.tif"), "-t_srs",
                 "EPSG:4674"]) != 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "-t_srs EPSG:4674: " in err[0] and "geographic" in err[0], err
    assert "-t_srs EPSG:31983 (SIRGAS 2000 / UTM 23S" in err[0], err
    assert not (tmp_path / "c.tif").exists()
    # north of the equator and outside Brazil's zones: WGS 84's
    assert utm_hint(pyproj.CRS.from_epsg(4326), 9.2, 45.5).startswith("EPSG:32632 ")
