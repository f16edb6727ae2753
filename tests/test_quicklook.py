"""Legends and scale bars with round numbers (quick-look PNG and the QGIS CHM style)."""
import numpy as np
import pytest

from lidartrees_gis.report.classes import nice_step, round_length
from lidartrees_gis.report.quicklook import write_quicklook


@pytest.mark.parametrize("span, step", [(36, 5), (27.2, 5), (12, 2), (60, 10), (3, 0.5),
                                        (0.5, 0.1), (30, 5), (100, 20)])
def test_class_width_is_round_and_near_six_classes(span, step):
    assert nice_step(span) == pytest.approx(step)
    assert 4 <= np.ceil(span / step - 1e-9) <= 8


@pytest.mark.parametrize("length, bar", [(18, 10), (12.3, 10), (250, 200), (0.7, 0.5), (5, 5)])
def test_scale_bar_is_the_largest_round_length_that_fits(length, bar):
    assert round_length(length) == pytest.approx(bar)


def test_quicklook_without_georeferencing_is_in_cells(tmp_path):
    from PIL import Image

    chm = np.zeros((60, 80))
    chm[20:30, 20:30] = 18.0
    labels = np.zeros((60, 80), np.int64)
    labels[18:32, 18:32] = 1
    write_quicklook(tmp_path / "q.png", chm, labels, [25], [25], title="one tree\n1 trees")
    png = Image.open(tmp_path / "q.png")
    assert png.text["Title"] == "one tree" and png.text["Description"] == "one tree\n1 trees"
    rgb = np.asarray(png.convert("RGB")).astype(int)
    assert ((rgb[..., 0] > 180) & (rgb[..., 1] < 70) & (rgb[..., 2] < 70)).sum() > 5  # the top
    with pytest.raises(FileExistsError):
        write_quicklook(tmp_path / "q.png", chm, labels, [25], [25])


def test_quicklook_marks_missing_and_uncertain_positions_apart(tmp_path):
    """Plantation mode's quick look: missing trees as black crosses, the positions left to a
    field check as orange triangles, each counted in the legend."""
    from PIL import Image

    from lidartrees_gis.grid import GridSpec

    spec = GridSpec.from_bounds(500000.0, 7500000.0, 500040.0, 7500030.0, 0.5)
    chm = np.full(spec.shape, 20.0)
    labels = np.ones(spec.shape, np.int64)

    def orange(path):
        rgb = np.asarray(Image.open(path).convert("RGB")).astype(int)
        return ((np.abs(rgb[..., 0] - 255) < 30) & (np.abs(rgb[..., 1] - 127) < 30)
                & (rgb[..., 2] < 50)).sum()

    gaps = ([500010.0], [7500010.0])
    write_quicklook(tmp_path / "a.png", chm, labels, [30], [30], spec=spec, gaps=gaps)
    write_quicklook(tmp_path / "b.png", chm, labels, [30], [30], spec=spec, gaps=gaps,
                    uncertain=([500020.0, 500030.0], [7500020.0, 7500020.0]))
    # the CHM's own ramp may hold orange: the triangles add to it
    assert orange(tmp_path / "b.png") > orange(tmp_path / "a.png") + 20
