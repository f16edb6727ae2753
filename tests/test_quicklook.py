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
