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
