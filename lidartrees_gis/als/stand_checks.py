"""What a trees run checks of its stands and spacing and says in one line: a spacing the
stands' tops do not lie on, plantation mode on a CHM, the stands' own summary figures."""
from __future__ import annotations

import warnings

from ..errors import DataWarning, InputError, listing
from .trees import TreeParams


def _warn(message: str) -> None:
    warnings.warn(DataWarning(message), stacklevel=3)


def check_chm_plantation(p: TreeParams, stands, label: str) -> None:
    """Plantation mode reads each empty planting position's returns (a missing tree, or a
    neighbour's crown over it): refused on a CHM, which holds none (every empty position
    would be uncertain and the stocking far below the truth); with stands and no spacing,
    the stands get the defaults' trees, and a warning says so."""
    if p.spacing is not None:
        raise InputError(f"-spacing: {label} is a canopy height model: plantation mode reads "
                         "the returns at each empty planting position; give the point files")
    if stands is not None:
        _warn(f"-stands: {label} is a canopy height model: the stands get the defaults' "
              "trees, without their planting lattice or stocking (which the point files give)")


def stands_summary(row: dict, srows: list) -> None:
    """With the user's stands, the summary's figures that would describe the points' whole
    extent (its roads and clearings) or one lattice for stands of several: the trees per ha
    of the stands' covered area (``stands_trees_per_ha``, the quick look's title), and the
    spacing ``per stand`` (with each) when the stands' lattices differ."""
    trees = sum(int(r.get("trees") or 0) for r in srows)
    ha = sum(float(r["area_ha"]) * float(r.get("data_cover_pct") or 0.0) / 100.0
             for r in srows)
    if ha > 0:
        row["stands_trees_per_ha"] = trees / ha
    found = sorted({str(r["spacing"]) for r in srows if r.get("lattice") == "found"
                    and r.get("spacing")})
    if len(found) > 1 and "spacing" in row:
        row["spacing"] = f"per stand ({', '.join(found)})"
        row["row_azimuth"] = None
        row["numbering"] = "per stand (the stands layer's lattice of each)"


def warn_other_lattices(other: dict, spacing, stands) -> None:
    """A :class:`DataWarning` naming the stands (or the area, without stands: key ``"all"``)
    whose tops lie on another planting lattice than the ``-spacing`` given (``other``: the
    tiles' ``lattice_other``, :func:`~lidartrees_gis.plantation.positions.fit_stand_grids`):
    a farm of 3 x 2 and 3 x 3 m stands run with one spacing has the other stands' trees and
    stocking read on a lattice they were not planted on."""
    if not other or not isinstance(spacing, tuple):
        return
    names = [("the area's" if k == "all" or stands is None else f"stand {stands.ids[k]}'s")
             + f" on {v}" for k, v in sorted(other.items(), key=lambda kv: str(kv[0]))]
    _warn(f"-spacing {spacing[0]:g}x{spacing[1]:g}: the tops lie on another lattice: "
          f"{listing(names, 6)}; their trees and stocking are read on a lattice they were not "
          "planted on: -spacing auto finds each stand's own")
