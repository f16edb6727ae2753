"""Planted blocks: an area given without its stands whose canopy shows planting rows is cut
into the blocks between its roads, and each block gets its own planting lattice as a stand
does (lidartrees_gis/plantation/blocks.py, lidartrees_gis/als/planted.py)."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import _family2 as fam  # noqa: E402

from lidartrees_gis.plantation.blocks import off_rows_share, planted_blocks  # noqa: E402
from lidartrees_gis.plantation.lattice import PlantingGrid  # noqa: E402


def _lattice(x0, y0, w, h, rs, ts, az, seed=0, sd=0.15):
    """Tops of a planting of rows ``rs`` m apart (plants ``ts``) at ``az``° filling a box."""
    rng = np.random.default_rng(seed)
    a = np.radians(az)
    u, v = np.array([np.sin(a), np.cos(a)]), np.array([np.cos(a), -np.sin(a)])
    n = int(2 * max(w, h) / min(rs, ts)) + 2
    i, j = np.meshgrid(np.arange(-n, n), np.arange(-n, n))
    p = np.array([x0 + w / 2, y0 + h / 2]) + i.ravel()[:, None] * ts * u + \
        j.ravel()[:, None] * rs * v
    p = p[(p[:, 0] >= x0) & (p[:, 0] < x0 + w) & (p[:, 1] >= y0) & (p[:, 1] < y0 + h)]
    p = p[rng.random(len(p)) >= 0.08]  # 8 % missing
    return p[:, 0] + rng.normal(0, sd, len(p)), p[:, 1] + rng.normal(0, sd, len(p))


def test_blocks_are_the_plantings_between_roads():
    """Two 3 x 2 m plantings of 80 x 80 m with an 8 m road between them are two blocks (each
    holding its planting's tops); with a 2 m gap they are one; a planting of too few tops is
    none."""
    ax, ay = _lattice(0, 0, 80, 80, 3.0, 2.0, 20.0, seed=1)
    bx, by = _lattice(88, 0, 80, 80, 3.0, 2.0, 110.0, seed=2)
    polys = planted_blocks(np.r_[ax, bx], np.r_[ay, by], 3.0)
    assert len(polys) == 2
    import shapely

    for p, (x, y) in zip(sorted(polys, key=lambda p: p.bounds[0]), ((ax, ay), (bx, by))):
        assert shapely.contains_xy(p, x, y).mean() == 1.0
    cx, cy = _lattice(82, 0, 80, 80, 3.0, 2.0, 110.0, seed=3)
    assert len(planted_blocks(np.r_[ax, cx], np.r_[ay, cy], 3.0)) == 1
    assert planted_blocks(ax[:100], ay[:100], 3.0) == []


def test_a_block_of_two_plantings_is_off_its_lattices_rows_in_part():
    """The share of a block's tops on squares off its lattice's rows: about 0 for one
    planting, about the other planting's share for two that touch."""
    ax, ay = _lattice(0, 0, 120, 120, 3.0, 2.0, 20.0, seed=1, sd=0.3)
    grid = PlantingGrid(3.0, 2.0, 20.0, 60.0, 60.0, 0.5)  # _lattice's, through its centre
    assert off_rows_share(grid, ax, ay) <= 0.02
    bx, by = _lattice(120, 0, 60, 120, 3.0, 2.0, 110.0, seed=2, sd=0.3)
    share = off_rows_share(grid, np.r_[ax, bx], np.r_[ay, by])
    assert abs(share - bx.size / (ax.size + bx.size)) <= 0.08, share


def _files(cfg, tmp_path):
    pts, truth = fam.make_stand(cfg, 1)
    las, stands = tmp_path / f"{cfg['name']}.las", tmp_path / f"{cfg['name']}.gpkg"
    fam.write_las(pts, las)
    fam.write_stands(truth, stands)
    return las, stands, truth


def test_without_stands_each_block_gets_its_own_lattice(tmp_path):
    """Two closed stands (3 x 2 m at 35°, 3.5 x 2.5 m at 120°, 0.8 ha each) across a road,
    no stands given: two blocks, each with its stand's lattice (to 0.05 m and 1°), as many
    trees as with the stands' polygons (to 1 %), the same blocks and lattices in 60 m tiles;
    the defaults' tops alone (-planting none) are far fewer."""
    from lidartrees_gis import api as lt
    from lidartrees_gis.als.trees import TreeParams

    cfg = fam._cfg("two", [fam._stand((3, 2), 35, 0.8, crown_k=fam.CLOSED),
                           fam._stand((3.5, 2.5), 120, 0.8, crown_k=fam.CLOSED)],
                   density=8, slope=0.1)
    las, stands, truth = _files(cfg, tmp_path)
    tops, _, summary = lt.find_trees(las)
    st = summary["stands"]
    assert list(st["stand_id"]) == ["B01", "B02"]
    assert list(st["lattice"]) == ["found", "found"]
    found = sorted(zip(st["spacing"], st["row_azimuth"]))
    for (sp, az), (rs, ts, true_az) in zip(found, sorted([("3x2", 0, 35.0),
                                                          ("3.5x2.5", 0, 120.0)])):
        assert sp == rs and abs((az - true_az + 90.0) % 180.0 - 90.0) <= 1.0
    with_stands = lt.find_trees(las, stands=stands)[0]
    assert abs(len(tops) / len(with_stands) - 1) <= 0.01
    plain = lt.find_trees(las, params=TreeParams(planting="none"))[0]
    assert len(plain) / len(tops) <= 0.9
    tiled = lt.find_trees(las, tile_size=60, workers=1)[2]["stands"]
    assert list(tiled["spacing"]) == list(st["spacing"])
    assert np.allclose(tiled["row_azimuth"], st["row_azimuth"])
    assert np.allclose(tiled["area_ha"], st["area_ha"])


def test_a_block_of_two_plantings_keeps_the_defaults_trees_and_says_why(tmp_path):
    """A stand with another planting beyond a narrow gap (the generator's neighbours), no
    stands given: one block whose tops leave its lattice's rows in part, so it has no
    lattice, says why, and keeps the defaults' trees (those of -planting none)."""
    from lidartrees_gis import api as lt
    from lidartrees_gis.als.trees import TreeParams

    cfg = fam._cfg("nb", [fam._stand((3, 2), 95, 1.0, crown_k=fam.CLOSED)], density=8,
                   slope=0.1, neighbours=True)
    las, _, _ = _files(cfg, tmp_path)
    tops, _, summary = lt.find_trees(las)
    st = summary["stands"]
    assert len(st) == 1 and st["lattice"].iloc[0].startswith("no planting lattice: ")
    assert "two plantings" in st["lattice"].iloc[0]
    plain = lt.find_trees(las, params=TreeParams(planting="none"))[0]
    assert sorted(tops["tree_id"]) == sorted(plain["tree_id"])


@pytest.mark.parametrize("name", ["lidR_extdata/MixedConifer.laz", "lasR_bcts/bcts_1.laz"])
def test_a_natural_forest_gets_no_blocks(data, name):
    """A natural forest's canopy shows no planting rows: no blocks, no stands layer."""
    from lidartrees_gis import api as lt

    summary = lt.find_trees(data(name))[2]
    assert "stands" not in summary


def test_copies_of_a_natural_forest_side_by_side_get_no_blocks(data, tmp_path):
    """Four copies of Megaplot on a 230 m grid (benchmarks/bench_chain.py's): the copies'
    straight clearing edges repeat every 230 m, which puts power in one direction at every
    frequency, but no planting rows: no blocks, and the defaults' trees."""
    import laspy

    from lidartrees_gis import api as lt
    from lidartrees_gis.als.trees import TreeParams

    for i in range(4):
        las = laspy.read(data("lidR_extdata/Megaplot.laz"))
        las.X = las.X + int(round(230.0 * (i % 2) / las.header.scales[0]))
        las.Y = las.Y + int(round(230.0 * (i // 2) / las.header.scales[1]))
        las.write(tmp_path / f"mp_{i}.laz")
    tops, _, summary = lt.find_trees(tmp_path)
    assert "stands" not in summary
    plain = lt.find_trees(tmp_path, params=TreeParams(planting="none"))[0]
    assert len(tops) == len(plain) > 4000
