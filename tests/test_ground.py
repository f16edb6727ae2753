import numpy as np
import pytest

from lidartrees_gis.errors import InputError
from lidartrees_gis.ground.filter import KrausPfeifer, filter_errors, kp_weights, kraus_pfeifer
from lidartrees_gis.ground.texture import glcm, pca_select, texture_descriptors, to_grey


def test_weight_function_exact():
    v = np.array([-5.0, -2.0, -1.5, -1.0, 0.0, 0.5, 0.51, 3.0])
    p = kp_weights(v, g=-2, w=2.5, a=1, b=4)
    expect = [1, 1, 1 / (1 + 0.5 ** 4), 1 / (1 + 1.0 ** 4), 1 / (1 + 2.0 ** 4), 1 / (1 + 2.5 ** 4), 0, 0]
    np.testing.assert_allclose(p, expect)
    np.testing.assert_allclose(kp_weights([-1.0], g=-2, w=2.5, a=2, b=2), [1 / (1 + 4.0)])


def synthetic_terrain(seed=0):
    """Sloping, bumpy terrain (2 pts/m²) with buildings and trees on it; returns x, y, z, truth."""
    rng = np.random.default_rng(seed)
    n = 2 * 200 * 200
    x, y = rng.random(n) * 200, rng.random(n) * 200

    def terrain(x, y):
        return 300 + 0.08 * x + 0.03 * y + 3 * np.sin(x / 25) * np.cos(y / 30)

    z = terrain(x, y) + rng.normal(0, 0.05, n)
    obj = np.zeros(n, bool)
    for bx, by in [(30, 40), (120, 60), (150, 150), (60, 140)]:  # 16 x 12 m buildings, 8 m high
        m = (x > bx) & (x < bx + 16) & (y > by) & (y < by + 12)
        z[m] += 8
        obj |= m
    trees = rng.random((60, 2)) * 200
    for tx, ty in trees:  # crowns 3 m radius, 6-15 m up; 20 % of returns reach the ground
        d = np.hypot(x - tx, y - ty)
        m = (d < 3) & ~obj & (rng.random(n) > 0.2)
        z[m] = terrain(x[m], y[m]) + 15 - d[m] * 3
        obj |= m
    return x, y, z, ~obj


def test_filter_recovers_ground_on_synthetic_terrain():
    x, y, z, truth = synthetic_terrain()
    ground, w = kraus_pfeifer(x, y, z, KrausPfeifer())
    e = filter_errors(ground, truth)
    assert e["type1"] < 5.0 and e["type2"] < 5.0 and e["kappa"] > 0.85
    assert w.min() >= 0 and w.max() <= 1


def test_filter_errors_counts():
    e = filter_errors([1, 1, 0, 0, 1], [1, 0, 0, 1, 1])
    assert e["type1"] == pytest.approx(100 / 3) and e["type2"] == pytest.approx(50.0)
    assert e["total"] == pytest.approx(40.0)


def test_bad_parameters_name_themselves():
    with pytest.raises(InputError, match="-w"):
        KrausPfeifer(w=0)
    with pytest.raises(InputError, match="-iterations"):
        KrausPfeifer(iterations=0)


@pytest.mark.parametrize("seed", [0, 1])
def test_glcm_and_descriptors_match_scikit_image(seed):
    from skimage.feature import graycomatrix, graycoprops

    rng = np.random.default_rng(seed)
    img = rng.integers(0, 8, (7, 9))
    angles = [0, np.pi / 4, np.pi / 2, 3 * np.pi / 4]
    P = graycomatrix(img.astype(np.uint8), [1], angles, levels=8, symmetric=False, normed=True)
    for k, ang in enumerate((0, 45, 90, 135)):
        np.testing.assert_allclose(glcm(img, ang, levels=8), P[:, :, 0, k], atol=1e-12)
    i, j = np.mgrid[0:8, 0:8]
    for prop in ("contrast", "homogeneity", "dissimilarity"):
        ours = []
        for ang in (0, 45, 90, 135):
            Q = glcm(img, ang, levels=8)
            d = i - j
            ours.append({"contrast": (d ** 2 * Q).sum(), "homogeneity": (Q / (1 + d ** 2)).sum(),
                         "dissimilarity": (np.abs(d) * Q).sum()}[prop])
        np.testing.assert_allclose(ours, graycoprops(P, prop)[0], atol=1e-12)


def test_texture_descriptors_keys_and_grey_levels():
    dtm = np.add.outer(np.arange(10.0), np.arange(12.0))
    g = to_grey(dtm)
    assert g.min() == 0 and g.max() == 255
    d = texture_descriptors(dtm)
    assert len(d) == 12 and d["contrast_0"] > 0 and 0 < d["homogeneity_90"] < 1


def test_pca_selects_correlated_descriptors():
    rng = np.random.default_rng(0)
    t = rng.normal(size=50)
    X = np.c_[t, 2 * t + 0.01 * rng.normal(size=50), rng.normal(size=50) * 0.01 + 5, -t]
    sel, load, var = pca_select(X)
    assert set(sel.tolist()) == {0, 1, 3} and var[0] > 0.7
