"""An area given without its stands whose canopy shows planting rows: its planted blocks
(:func:`lidartrees_gis.plantation.blocks.planted_blocks`) stand in for the stands, each with
its own planting lattice (``-spacing auto``), from the tops of a first pass over the area's
tiles (:func:`lidartrees_gis.als.tile.tile_first_tops`, the pass plantation mode makes anyway:
it is handed on, not made again)."""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from .area import AreaPlan
from .tile import tile_first_tops
from .trees import TreeParams, detect_trees

#: :attr:`lidartrees_gis.plantation.stands.Stands.source` of the blocks
BLOCKS_SOURCE = "planted blocks (no -stands: the canopy between roads)"


def wants_blocks(p: TreeParams, plan: AreaPlan) -> bool:
    """Whether a run without stands looks for planted blocks: ``-spacing auto``, or the
    defaults' method and no spacing (:attr:`TreeParams.looks_for_lattice`), and a canopy
    that shows planting rows (:attr:`AreaPlan.canopy_rows`)."""
    wanted = p.spacing == "auto" or (p.spacing is None and p.looks_for_lattice)
    return wanted and bool(plan.canopy_rows)


def planted_stands(runner, area, p: TreeParams, plan: AreaPlan, surface, ready=None,
                   progress=None) -> tuple:
    """``(stands, first)``: the area's planted blocks as
    :class:`~lidartrees_gis.plantation.stands.Stands` (ids ``B01``, ...; None when there is
    none) and the first pass's results (the tiles' :func:`tile_first_tops`, None for an area
    of one tile, whose tops are found on its surfaces ``ready``)."""
    from ..plantation.blocks import block_ids, planted_blocks
    from ..plantation.stands import Stands

    auto = replace(p, spacing="auto")
    first = None
    if ready is not None:
        t = detect_trees(ready["chm"], ready["spec"], auto, heights=ready["heights"])["table"]
        x, y = np.asarray(t["x"], float), np.asarray(t["y"], float)
    else:
        first = list(runner.map(tile_first_tops, list(plan.tiles),
                                (area, auto, plan, surface, None), progress=progress,
                                inner_progress=True, label="lattice tile"))
        x, y = (np.concatenate([np.asarray(r[k], float) for r in first] or [np.empty(0)])
                for k in ("x", "y"))
    import shapely

    rows = float(np.median([a for a, _ in plan.canopy_rows]))  # one window's may be off
    box = shapely.box(*area.extent)  # a block reaches past its outer tops, not the data's
    polys = [g for g in (shapely.intersection(p, box) for p in planted_blocks(x, y, rows))
             if not g.is_empty]
    if not polys:
        return None, first
    return Stands(block_ids(len(polys)), np.asarray(polys, dtype=object), "",
                  BLOCKS_SOURCE), first
