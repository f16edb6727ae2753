"""A stand's area-based figure from its cells and the pieces of cells its border cuts
(lidartrees_gis.inventory.cells): each by its area, a piece by its own returns, so that a
border along the cells' centres, or a millimetre beside them, moves nothing."""
import warnings

import numpy as np
import shapely

from lidartrees_gis.grid import GridSpec
from lidartrees_gis.inventory.cells import CellShares, cell_shares


def test_cells_across_a_border_are_cut_into_pieces_by_area():
    spec = GridSpec(0.0, 60.0, 20.0, 3, 3)  # 3 x 3 cells of 20 m
    for b in (30.0, 30.001, 29.999, 35.0):
        stands = [shapely.box(0, 0, b, 60), shapely.box(b, 0, 60, 60)]
        shares, pieces, piece_cell = cell_shares(spec, stands)
        # column 0 whole in A, column 2 whole in B, column 1 cut in two in each row
        assert len(pieces) == 6 and sorted(piece_cell) == [1, 1, 4, 4, 7, 7]
        whole = shares.cell < 9
        assert sorted(shares.cell[whole & (shares.stand == 0)]) == [0, 3, 6]
        assert sorted(shares.cell[whole & (shares.stand == 1)]) == [2, 5, 8]
        w = np.bincount(shares.stand, weights=shares.weight)
        np.testing.assert_allclose(w, [b * 60 / 400, (60 - b) * 60 / 400], rtol=1e-12)
        # the pieces, stand by stand: A's parts of the middle column, then B's
        np.testing.assert_allclose(shapely.area(pieces), np.repeat([(b - 20) * 20,
                                                                    (40 - b) * 20], 3))
        # units: the 9 cells, then the pieces; a value per unit, means by area
        v = np.r_[np.tile([10.0, np.nan, 1000.0], 3), np.full(len(pieces), 100.0)]
        mean, _ = shares.means(v, 2)
        a1 = (b - 20) / 20
        np.testing.assert_allclose(mean, [(10 + 100 * a1) / (1 + a1),
                                          (1000 + 100 * (1 - a1)) / (2 - a1)], rtol=1e-9)


def test_a_millimetre_moves_the_figures_by_a_millimetre_not_a_cell():
    spec = GridSpec(0.0, 100.0, 20.0, 5, 5)
    rows, cols = np.indices(spec.shape)
    cells = (100.0 * (cols + 1) + 10 * rows).ravel()  # more wood eastwards
    means = []
    for dx in (0.0, 0.001):  # borders on the cells' centres, then beside them
        stands = [shapely.box(10 + dx, 10 + dx, 50 + dx, 90 + dx),
                  shapely.box(50 + dx, 10 + dx, 90 + dx, 90 + dx)]
        shares, pieces, piece_cell = cell_shares(spec, stands)
        v = np.r_[cells, cells[piece_cell]]  # a piece as its cell (a uniform cell)
        means.append(shares.means(v, 2)[0])
    np.testing.assert_allclose(means[0], means[1], rtol=1e-4)
    np.testing.assert_allclose(means[0], [220.0, 420.0], rtol=1e-4)  # the stands' own means
    # whole cells by their centre, as before: a millimetre hands a column of cells over
    old = []
    for dx in (0.0, 0.001):
        cx, cy = spec.xy(*np.indices(spec.shape))
        cs = np.where((cx.ravel() > 10 + dx) & (cx.ravel() < 50 + dx) & (cy.ravel() > 10 + dx)
                      & (cy.ravel() < 90 + dx), 0, -1)
        old.append(CellShares.of(cs).means(cells, 1)[0][0])
    assert abs(old[1] / old[0] - 1) > 0.2


def test_a_stand_is_not_given_its_neighbours_trees_nor_moved_by_a_millimetre(tmp_path):
    """The generated farm's stands (1.21 ha, three cells across) have their borders on the
    cells' centres: moved by 1 mm, every stand's figure stays within 0.1 %; and the low
    stands beside high ones keep their own volume (whole cells across borders, weighted by
    area, gave the lowest one 55 % too much)."""
    import geopandas as gpd

    import lidartrees_gis as lt
    from lidartrees_gis.synthetic import write_volume_example

    truth, _ = write_volume_example(tmp_path, density=4.0, n_plots=9, seed=0)
    st = gpd.read_file(tmp_path / "stands.gpkg")
    st.assign(geometry=st.geometry.translate(0.001, 0.001)).to_file(tmp_path / "moved.gpkg")
    figs = []
    for name in ("stands.gpkg", "moved.gpkg"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            r = lt.volume(tmp_path / "farm.laz", tmp_path / "plots.gpkg", stands=tmp_path / name,
                          trees_table=tmp_path / "arvores.csv", plot_radius=11.28,
                          volume_equation="0.000049,1.85,1.05", resamples=30)
        s = r["layers"]["stands"]
        figs.append(s["volume_m3_ha"].to_numpy(float))
        np.testing.assert_allclose(s["cells"].to_numpy(float), 30.25, atol=1e-3)
    np.testing.assert_allclose(figs[1], figs[0], rtol=1e-3)
    true = np.asarray(truth["stands"]["volume_m3_ha"], float)
    err = figs[0] / true - 1
    low = true < 150
    assert low.sum() == 2 and np.all(np.abs(err[low]) < 0.15), err

