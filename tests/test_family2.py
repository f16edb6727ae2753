"""The second stand family (benchmarks/_family2.py) against its own truth (issue 41)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

shapely = pytest.importorskip("shapely")
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import _family2 as fam  # noqa: E402

SMALL = fam._cfg("small_two", [fam._stand((3, 2), 35, 0.45, crown_k=fam.CLOSED, missing=0.12),
                               fam._stand((3.5, 2.5), 120, 0.45, crown_k=fam.OPEN, age=3,
                                          missing=0.08)],
                 density=8, slope=0.2, neighbours=True)


@pytest.fixture(scope="module")
def scene():
    return fam.make_stand(SMALL, seed=3)


def _brute_positions(stand):
    """Lattice nodes inside the planted polygon, enumerated over a wide index range."""
    lat = stand["lattice"]
    u, v = fam._units(lat["azimuth"])
    o = np.array(lat["origin"])
    ii, jj = np.meshgrid(np.arange(-5, 400), np.arange(-5, 400), indexing="ij")
    x = o[0] + ii.ravel() * lat["row_spacing"] * v[0] + jj.ravel() * lat["plant_spacing"] * u[0]
    y = o[1] + ii.ravel() * lat["row_spacing"] * v[1] + jj.ravel() * lat["plant_spacing"] * u[1]
    return int(shapely.contains_xy(shapely.from_wkt(stand["planted"]), x, y).sum())


def test_positions_are_the_lattice_in_the_planted_area(scene):
    _, truth = scene
    assert len(truth["stands"]) == 2
    for st in truth["stands"]:
        pos = st["positions"]
        assert pos.size == st["n_positions"] == _brute_positions(st)
        assert np.unique(pos[["row", "plant"]]).size == pos.size
        lat = st["lattice"]
        u, v = fam._units(lat["azimuth"])
        rel = np.c_[pos["x"], pos["y"]] - np.array(lat["origin"])
        i = rel @ v / lat["row_spacing"]
        j = rel @ u / lat["plant_spacing"]
        assert np.allclose(i, pos["row"], atol=1e-6) and np.allclose(j, pos["plant"], atol=1e-6)
        # spacings recovered from the positions: nearest in-row and across-row neighbours
        from scipy.spatial import cKDTree
        d, _ = cKDTree(np.c_[pos["x"], pos["y"]]).query(np.c_[pos["x"], pos["y"]], k=2)
        assert abs(np.median(d[:, 1]) - min(lat["row_spacing"], lat["plant_spacing"])) < 1e-6
        # the first row stands 0.5 x rows .. a few metres inside the stand polygon
        edge = shapely.from_wkt(st["polygon"]).exterior
        dist = shapely.distance(edge, shapely.points(pos["x"], pos["y"]))
        assert dist.min() >= 0.5 * lat["row_spacing"] - 1e-6
        assert dist.min() <= 4.5 + lat["row_spacing"]


def test_statuses_and_stocking(scene):
    _, truth = scene
    for st, cfg in zip(truth["stands"], SMALL["stands"]):
        pos = st["positions"]
        counts = {s: int((pos["status"] == s).sum()) for s in fam.STATUSES}
        assert counts == st["counts"] and sum(counts.values()) == pos.size
        assert st["stocking_pct"] == pytest.approx(100 * (1 - counts["missing"] / pos.size))
        assert abs(counts["missing"] - cfg["missing"] * pos.size) <= 1
        miss = pos["status"] == "missing"
        assert np.isnan(pos["height"][miss]).all() and np.isfinite(pos["height"][~miss]).all()
        # runs of missing trees along a row: some run is longer than one tree
        key = set(zip(pos["row"][miss].tolist(), pos["plant"][miss].tolist()))
        assert any((r, p + 1) in key for r, p in key)
        # replanted and suppressed trees are shorter than the row's planted trees
        tree = pos["status"] == "tree"
        for s, most in (("replant", 0.85), ("suppressed", 0.6)):
            k = pos["status"] == s
            assert k.any()
            assert np.all(pos["height"][k] < most * np.median(pos["height"][tree]))
    allpos = truth["positions"]
    assert truth["stocking_pct"] == pytest.approx(
        100 * (allpos["status"] != "missing").sum() / allpos.size)


def test_density_and_ground(scene):
    pts, truth = scene
    assert abs(truth["density"] - SMALL["density"]) / SMALL["density"] < 0.2
    g = pts["classification"] == 2
    assert 0.05 < g.mean() < 0.9
    dz = pts["z"][g] - fam.terrain_z(truth, pts["x"][g], pts["y"][g])
    assert abs(np.median(dz)) < 0.05 and np.percentile(np.abs(dz), 95) < 0.25
    # multiple returns: returns of a pulse numbered 1..n, later returns lower
    assert pts["number_of_returns"].max() >= 3
    assert np.all(pts["return_number"] <= pts["number_of_returns"])
    assert np.abs(pts["scan_angle"]).max() <= 20.5
    # the highest returns reach the truth's tallest trees, not beyond
    hag = pts["z"] - fam.terrain_z(truth, pts["x"], pts["y"])
    h = truth["positions"]["height"]
    assert np.nanmax(h) - 1.5 < hag.max() < np.nanmax(h) + 0.5


def test_writers_roundtrip(scene, tmp_path):
    laspy = pytest.importorskip("laspy")
    gpd = pytest.importorskip("geopandas")
    pts, truth = scene
    fam.write_las(pts, tmp_path / "s.las")
    las = laspy.read(tmp_path / "s.las")
    assert len(las.points) == pts["x"].size
    assert las.header.parse_crs().to_epsg() == 31983
    assert np.allclose(np.asarray(las.z), pts["z"], atol=0.001)
    assert np.array_equal(np.asarray(las.classification), pts["classification"])
    fam.write_stands(truth, tmp_path / "s.gpkg")
    gdf = gpd.read_file(tmp_path / "s.gpkg")
    assert list(gdf["talhao"]) == ["T01", "T02"] and gdf.crs.to_epsg() == 31983
    assert gdf.geometry.area.sum() / 1e4 == pytest.approx(
        sum(s["area_ha"] for s in truth["stands"]), rel=1e-6)


@pytest.mark.parametrize("scatter", [0.0, 1.0])
def test_tops_scatter_around_their_planting_positions(scatter):
    """Tops stand on their positions with scatter 0; 0.1-0.6 m off (planting error, lean)."""
    rng = np.random.default_rng(5)
    st = fam._stand((3, 2), 30, crown_k=fam.CLOSED, scatter=scatter)
    poly = fam._rect(0.0, 0.0, 80.0, 60.0, 0.3)
    x, y, i, j = fam._lattice_positions(poly, np.array([0.3, 0.2]), 30.0, 3.0, 2.0)
    row, plant = i - i.min(), j - j.min()
    status, key = fam._statuses(row, plant, st, rng)
    terrain = fam.Terrain.random(rng, 0.0, 0.0, 0.1)
    t, extra = fam._trees(x, y, row, plant, status, key, st, rng, terrain, 30.0)
    has = status != "missing"
    d = np.hypot(extra["top_x"] - x, extra["top_y"] - y)[has]
    assert t["H"].size == has.sum()
    if scatter == 0.0:
        assert d.max() < 1e-9
    else:
        assert 0.1 < np.median(d) < 0.6 and d.max() < 1.6


def _stand_files(cfg, tmp_path):
    """The points (LAS) and the stands (GeoPackage) of configuration ``cfg`` (seed 1), and
    its truth."""
    pts, truth = fam.make_stand(cfg, 1)
    las, stands = tmp_path / "c.las", tmp_path / "c.gpkg"
    fam.write_las(pts, las)
    fam.write_stands(truth, stands)
    return las, stands, truth


def _assert_tiled_same(las, stands, params, st):
    """In 40 m tiles the stand has the same lattice and the same positions as ``st``."""
    from lidartrees_gis import api as lt

    tiled = lt.find_trees(las, params=params, stands=stands, tile_size=40,
                          workers=1)[2]["stands"].iloc[0]
    for key in ("lattice", "spacing", "row_azimuth", "planting_positions", "missing_trees",
                "suppressed_trees", "uncertain_positions", "stocking_pct"):
        assert tiled[key] == st[key], key


def test_a_closed_stand_gets_its_lattice_from_the_canopy_where_the_tops_show_none(tmp_path,
                                                                                 monkeypatch):
    """A 6-year 3 x 2 m stand of closed crowns (1.5 ha, 8 pts/m²): the tops of neighbours in a
    row merge, so no aligned lattice fits them; their rows, each with its own phase, give it
    (to 0.05 m and 1°); without that look the canopy heights' spectrum finds it, and the
    stocking comes within 3 points of the truth; in tiles, the same."""
    import lidartrees_gis.plantation.canopy_lattice as canopy_lattice
    import lidartrees_gis.plantation.stocking as stocking
    from lidartrees_gis import api as lt
    from lidartrees_gis.als.trees import TreeParams

    cfg = fam._cfg("closed", [fam._stand((3, 2), 20, 1.5, crown_k=fam.CLOSED)], slope=0.08)
    las, stands, truth = _stand_files(cfg, tmp_path)
    params = TreeParams(spacing="auto")
    st = lt.find_trees(las, params=params, stands=stands)[2]["stands"].iloc[0]
    assert st["lattice"] == "found" and st["spacing"] == "3x2"
    assert abs((st["row_azimuth"] - 20.0 + 90.0) % 180.0 - 90.0) <= 1.0
    monkeypatch.setattr(stocking, "find_rows", lambda *a, **k: None)
    st = lt.find_trees(las, params=params, stands=stands)[2]["stands"].iloc[0]
    assert st["lattice"] == "found" and st["spacing"] == "3x2"
    assert abs((st["row_azimuth"] - 20.0 + 90.0) % 180.0 - 90.0) <= 1.0
    assert abs(st["stocking_pct"] - truth["stands"][0]["stocking_pct"]) <= 3.0
    # in 40 m tiles (the tiles' spectra summed): the same lattice and the same positions
    _assert_tiled_same(las, stands, params, st)
    monkeypatch.setattr(canopy_lattice, "canopy_planting", lambda *a, **k: None)
    st = lt.find_trees(las, params=params, stands=stands)[2]["stands"].iloc[0]
    assert st["lattice"].startswith("no planting lattice")


def test_a_stand_whose_canopy_shows_its_rows_only_gets_its_plants_from_the_canopy_peaks(
        tmp_path, monkeypatch):
    """A 7-year 3 x 2 m stand of dense crowns with 15 % missing (1.5 ha, 8 pts/m²): the
    canopy heights' spectrum shows the rows beyond chance but not the plants along them, and
    the tops found merge neighbours; the canopy's local maxima show both, and give the lattice
    (to 0.05 m and 1°, the truth inside the stocking interval), the same in 40 m tiles;
    without that look the stand has no lattice."""
    import lidartrees_gis.plantation.canopy_lattice as canopy_lattice
    import lidartrees_gis.plantation.stocking as stocking
    from lidartrees_gis import api as lt
    from lidartrees_gis.als.trees import TreeParams

    cfg = fam._cfg("dense7", [fam._stand((3, 2), 65, 1.5, age=7, crown_k=fam.DENSE,
                                         missing=0.15)], slope=0.15)
    las, stands, truth = _stand_files(cfg, tmp_path)
    params = TreeParams(spacing="auto")
    # the tops' rows, each with its own phase, find this lattice first: left out here
    monkeypatch.setattr(stocking, "find_rows", lambda *a, **k: None)
    seen = []
    from_peaks = canopy_lattice.peaks_lattice_guess
    monkeypatch.setattr(canopy_lattice, "peaks_lattice_guess",
                        lambda *a, **k: seen.append(from_peaks(*a, **k)) or seen[-1])
    st = lt.find_trees(las, params=params, stands=stands)[2]["stands"].iloc[0]
    assert seen and seen[0] is not None  # the spectrum alone found no lattice
    assert st["lattice"] == "found" and st["spacing"] == "3x2"
    assert abs((st["row_azimuth"] - 65.0 + 90.0) % 180.0 - 90.0) <= 1.0
    true = truth["stands"][0]["stocking_pct"]
    assert st["stocking_pct_low"] <= true <= st["stocking_pct_high"]
    _assert_tiled_same(las, stands, params, st)
    monkeypatch.setattr(canopy_lattice, "peaks_lattice_guess", lambda *a, **k: None)
    st = lt.find_trees(las, params=params, stands=stands)[2]["stands"].iloc[0]
    assert st["lattice"].startswith("no planting lattice")


def test_a_stand_whose_canopy_shows_rows_but_no_plants_says_so(tmp_path):
    """4 x 1.2 m of closed crowns (1.5 ha, 8 pts/m²): the tops lean by more than a third of
    the plant spacing, so neither the tops, the canopy's spectrum nor its local maxima show
    the plants along the rows; the stand has no lattice and its ``lattice`` field says that
    the canopy shows rows 4 m apart at 40° (not that the tops lie in no rows), tiled too."""
    from lidartrees_gis import api as lt
    from lidartrees_gis.als.trees import TreeParams

    cfg = fam._cfg("rows_only", [fam._stand((4, 1.2), 40, 1.5, crown_k=fam.CLOSED)],
                   slope=0.06)
    las, stands, truth = _stand_files(cfg, tmp_path)
    for kw in ({}, {"tile_size": 60, "workers": 1}):
        st = lt.find_trees(las, params=TreeParams(spacing="auto"), stands=stands,
                           **kw)[2]["stands"].iloc[0]
        assert st["lattice"].startswith("no planting lattice: the canopy shows rows 4.0 m "
                                        "apart at 40°"), st["lattice"]
        assert st["stocking_pct"] is None or np.isnan(st["stocking_pct"])  # empty


def _tree_f(tops, st) -> float:
    """F of the tops against a truth stand's trees (one-to-one, within min(1.5 m, half the
    plant spacing) of their tops), as ``benchmarks/bench_stands2.py`` scores them."""
    from bench_stands2 import _match

    pos = st["positions"]
    has = pos["status"] != "missing"
    m = _match(pos["top_x"][has], pos["top_y"][has], tops.geometry.x.to_numpy(),
               tops.geometry.y.to_numpy(), min(1.5, 0.5 * st["lattice"]["plant_spacing"]))
    p, r = m / max(len(tops), 1), m / max(int(has.sum()), 1)
    return 2 * p * r / (p + r) if p + r else 0.0


def test_the_defaults_with_stands_look_for_each_stands_lattice(tmp_path):
    """A closed 3 x 2 m stand (1.5 ha, 8 pts/m²): with its stand polygon and no -spacing, the
    defaults give the trees and the stand figures of -spacing auto (its lattice found, the
    stocking's interval holding the truth), whose tops are much closer to the truth than
    the defaults' tops alone (-planting none, the same as without stands): on these porous,
    overlapping crowns those read the returns' noise as much as the trees."""
    from lidartrees_gis import api as lt
    from lidartrees_gis.als.trees import TreeParams

    cfg = fam._cfg("closed", [fam._stand((3, 2), 20, 1.5, crown_k=fam.CLOSED)], slope=0.08)
    las, stands, truth = _stand_files(cfg, tmp_path)
    true = truth["stands"][0]
    tops, _, summary = lt.find_trees(las, stands=stands)
    auto, _, summary_auto = lt.find_trees(las, params=TreeParams(spacing="auto"), stands=stands)
    assert sorted(tops["tree_id"]) == sorted(auto["tree_id"])
    st = summary["stands"].iloc[0]
    assert st["lattice"] == "found" and st["spacing"] == "3x2"
    assert st["stocking_pct"] == summary_auto["stands"].iloc[0]["stocking_pct"]
    assert st["stocking_pct_low"] <= true["stocking_pct"] <= st["stocking_pct_high"]
    plain, _, summary_plain = lt.find_trees(las, params=TreeParams(planting="none"),
                                            stands=stands)
    alone = lt.find_trees(las, params=TreeParams(planting="none"))[0]
    assert sorted(plain["tree_id"]) == sorted(alone["tree_id"])
    assert pd_isna(summary_plain["stands"].iloc[0].get("stocking_pct"))
    f, f_plain = _tree_f(tops, true), _tree_f(plain, true)
    assert f >= 0.9 and f_plain <= 0.85, (f, f_plain)
    n_true = int((true["positions"]["status"] != "missing").sum())
    assert abs(len(tops) / n_true - 1) <= 0.08 and len(plain) / n_true <= 0.9


def pd_isna(v) -> bool:
    import pandas as pd

    return v is None or bool(pd.isna(v))


def test_without_stands_a_plantation_whose_tops_show_no_lattice_is_warned_of(
        tmp_path, data, stand, monkeypatch):
    """The closed 3 x 2 m stand without its polygon: its planted block gets its lattice (3 x 2
    m at 20°). Were no block found there, the canopy showing its rows (3 m apart at 20°) and
    the tops no lattice, the run warns in one line and names -stands; a stand of the
    package's generator (its tops on a lattice) and MixedConifer (no rows) do not warn."""
    import warnings

    import lidartrees_gis.als.planted as planted
    from lidartrees_gis import api as lt
    from lidartrees_gis.errors import DataWarning

    cfg = fam._cfg("closed", [fam._stand((3, 2), 20, 1.5, crown_k=fam.CLOSED)], slope=0.08)
    las, _, _ = _stand_files(cfg, tmp_path)
    st = lt.find_trees(las)[2]["stands"]
    assert list(st["stand_id"]) == ["B01"] and st["lattice"].iloc[0] == "found"
    assert st["spacing"].iloc[0] == "3x2"
    assert abs((st["row_azimuth"].iloc[0] - 20.0 + 90.0) % 180.0 - 90.0) <= 1.0

    def said(path, **kw):
        with warnings.catch_warnings(record=True) as w:
            warnings.simplefilter("always")
            lt.find_trees(path, **kw)
        return [str(x.message) for x in w if issubclass(x.category, DataWarning)
                and "planting rows" in str(x.message)]

    import lidartrees_gis.plantation.blocks as blocks

    monkeypatch.setattr(blocks, "planted_blocks", lambda *a, **k: [])
    lines = said(las)
    assert len(lines) == 1 and "\n" not in lines[0]
    assert "3.0 m apart at 20°" in lines[0] and "-stands" in lines[0]
    assert planted.BLOCKS_SOURCE  # the blocks' source, named in the run's summary
    from lidartrees_gis.io.lasout import write_points
    from pyproj import CRS

    pts, _ = stand  # the package's own stand (its tops on a lattice)
    demo = tmp_path / "demo.las"
    write_points(demo, pts.x, pts.y, pts.z, crs=CRS.from_epsg(31984),
                 classification=pts.classification)
    assert said(demo) == []
    assert said(data("lidR_extdata/MixedConifer.laz")) == []
