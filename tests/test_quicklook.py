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


def _figure_with_a_stand_beyond_the_data(**kw):
    import shapely

    from lidartrees_gis.grid import GridSpec
    from lidartrees_gis.report.quicklook import quicklook_figure

    spec = GridSpec.from_bounds(412300.0, 7952400.0, 412380.0, 7952480.0, 0.5)
    chm = np.full(spec.shape, 20.0)
    labels = np.ones(spec.shape, np.int64)
    stands = (["T-01", "T-02"], [shapely.box(412300, 7952400, 412340, 7952480),
                                 shapely.box(412340, 7952370, 412410, 7952480)])
    return quicklook_figure(chm, labels, [30, 60], [30, 60], spec=spec, stands=stands,
                            gaps=([412310.0], [7952410.0]),
                            suppressed=([412320.0, 412330.0], [7952420.0, 7952420.0]),
                            uncertain=([412350.0], [7952450.0]), **kw)


def test_quicklook_legend_ticks_stands_and_suppressed_trees():
    """Issue 37: the legend lies inside the figure (it was cut at the right edge), the lowest
    ticks of the two axes do not meet in the corner, a stand reaching beyond the data is drawn
    whole, and the suppressed trees are marked and counted."""
    fig, counts = _figure_with_a_stand_beyond_the_data(title="Fazenda Rosa")
    fig.canvas.draw()
    r = fig.canvas.get_renderer()
    whole = fig.bbox
    leg = fig.legends[0]
    b = leg.get_window_extent(r)
    assert b.x0 >= whole.x0 and b.x1 <= whole.x1 and b.y0 >= whole.y0 and b.y1 <= whole.y1
    texts = [t.get_text() for t in leg.get_texts()]
    assert "suppressed trees (2)" in texts and "missing trees (1)" in texts
    assert counts == (2, 1, 2)
    ax = fig.axes[0]
    assert ax.get_xlim()[1] >= 412410 and ax.get_ylim()[0] <= 7952370  # the stand, whole
    xs = [t.get_window_extent(r) for t in ax.get_xticklabels() if t.get_text()]
    ys = [t.get_window_extent(r) for t in ax.get_yticklabels() if t.get_text()]
    assert xs and ys and not any(a.overlaps(b) for a in xs for b in ys)
    assert fig._suptitle.get_text() == "Fazenda Rosa"


def test_trees_title_option_titles_the_quick_look(tmp_path):
    from PIL import Image
    from pyproj import CRS

    from lidartrees_gis.cli import main
    from lidartrees_gis.io.lasout import write_points
    from lidartrees_gis.synthetic import StandParams, make_stand

    pts, _ = make_stand(StandParams(width=30, height=30))
    stand_las_small = tmp_path / "s.las"
    write_points(stand_las_small, pts.x, pts.y, pts.z, crs=CRS.from_epsg(29194),
                 classification=pts.classification)
    png = tmp_path / "q.png"
    assert main(["trees", str(stand_las_small), str(tmp_path / "t.gpkg"), "-png", str(png),
                 "-title", "Fazenda Rosa, talhão 7", "-q"]) == 0
    text = Image.open(png).text
    assert text["Title"] == "Fazenda Rosa, talhão 7"
    assert "trees" in text["Description"].split("\n")[1]
