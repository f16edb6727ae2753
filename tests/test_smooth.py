import numpy as np
import pytest

from lidartrees_gis.errors import InputError
from lidartrees_gis.als.smooth import (GAUSS_COARSE, GAUSS_FINE, abefec, closing, dilation,
    erosion, footprint, opening, smooth)


def test_seed_masks_exact():
    assert (GAUSS_FINE * 17).astype(int).tolist() == [[1, 2, 1], [2, 5, 2], [1, 2, 1]]
    assert (np.rint(GAUSS_COARSE * 75)).astype(int).tolist() == [
        [1, 2, 3, 2, 1], [2, 4, 5, 4, 2], [3, 5, 7, 5, 3], [2, 4, 5, 4, 2], [1, 2, 3, 2, 1]]
    assert GAUSS_FINE.sum() == pytest.approx(1) and GAUSS_COARSE.sum() == pytest.approx(1)


def test_gauss3_of_impulse_is_the_mask():
    img = np.zeros((5, 5))
    img[2, 2] = 17.0
    np.testing.assert_allclose(smooth(img, "gauss3")[1:4, 1:4], [[1, 2, 1], [2, 5, 2], [1, 2, 1]])


def test_elements():
    assert footprint("cross").astype(int).tolist() == [[0, 1, 0], [1, 1, 1], [0, 1, 0]]
    assert footprint("square").sum() == 9
    assert footprint("rhombus").sum() == 13 and footprint("rhombus").shape == (5, 5)
    with pytest.raises(InputError):
        footprint("circle")


@pytest.mark.parametrize("shape", ["cross", "square", "rhombus"])
def test_morphology_identities(shape):
    rng = np.random.default_rng(0)
    f = rng.random((30, 40)) * 20
    b = footprint(shape)
    o = opening(f, b)
    c = closing(f, b)
    assert np.all(o <= f + 1e-12)                         # opening is anti-extensive
    assert np.all(c >= f - 1e-12)                         # closing is extensive
    np.testing.assert_allclose(opening(o, b), o)          # idempotent
    np.testing.assert_allclose(closing(c, b), c)
    np.testing.assert_allclose(erosion(f, b), -dilation(-f, b))   # duality
    np.testing.assert_allclose(opening(f, b), -closing(-f, b))
    np.testing.assert_allclose(abefec(f, b), opening(closing(f, b), b))


def test_nan_never_spreads():
    f = np.full((7, 7), 10.0)
    f[3, 3] = np.nan
    for spec in ("gauss3", "gauss5", "gauss:0.5", "open:cross", "abefec:rhombus", "close:square"):
        g = smooth(f, spec, res=0.25)
        assert np.isnan(g[3, 3]) and np.isfinite(np.delete(g.ravel(), 24)).all()
        np.testing.assert_allclose(np.delete(g.ravel(), 24), 10.0)


def test_more_smoothing_fewer_maxima():
    from lidartrees_gis.als.tops import local_maxima

    rng = np.random.default_rng(1)
    f = rng.random((60, 60)) * 5 + 10
    n = [len(local_maxima(smooth(f, s))[0]) for s in ("none", "gauss3", "gauss5")]
    assert n[0] > n[1] > n[2]


def test_unknown_filter_names_parameter():
    with pytest.raises(InputError, match="-smooth"):
        smooth(np.zeros((3, 3)), "median:3")
