"""What stands at each planting position of a plantation: a lattice fitted per stand
(:func:`stocking_by_stand`) and each empty position told apart as holding a suppressed tree or
none (:func:`classify_gaps`)."""
from __future__ import annotations

import numpy as np

from .stocking import PlantingGrid, fit_planting_grid, mask_radius, stand_mask, stocking
from .table import Positions


#: a stand with fewer tops than this takes the lattice fitted to all the tops instead of its own
#: (a corner of a stand)
STAND_FIT_MIN_TOPS = 30


def _empty(n_tops: int) -> dict:
    """:func:`stocking_by_stand`'s answer when no lattice was found (``-spacing auto``)."""
    z = np.zeros(n_tops, np.int64)
    e = np.empty(0, np.int64)
    return {"grid": None, "spacing": None, "expected": 0, "stocked": 0, "missing": 0, "extra": 0,
            "planted_area_ha": 0.0, "stocking_pct": float("nan"), "planted_per_ha": float("nan"),
            "gaps": Positions.empty().with_columns(i=e, j=e, row=e, plant=e,
                                                   edge=np.zeros(0, bool), zone=e),
            "looks": Positions.empty().with_columns(zone=e), "tops_row": z, "tops_plant": z.copy(),
            "shares": np.zeros(n_tops, bool),
            "numbering": "", "zones": {}}


def _canonical(tx, ty):
    """The tops in an order that does not depend on how they were found (a tile's or the whole
    area's): by position, rounded to the millimetre."""
    return np.lexsort((np.round(ty, 3), np.round(tx, 3)))


def fit_stand_grids(top_x, top_y, top_zone, spacing, grid: PlantingGrid | None = None, *,
                    zones=None, whole: bool = False, cell: float = 0.0, spectra=None,
                    fits=None, scan=None) -> dict:
    """The planting lattice of every stand: ``{zone: PlantingGrid or None}``, and ``"all"``
    (the lattice of all the tops: that of an area without stands, and of a stand with too few
    tops of its own) where one needs it or ``whole`` asks for it.

    ``top_zone``: each top's stand index (-1 outside every stand), or None (no stands);
    ``zones``: the stands wanted (default: those of the tops). A stand is fitted on its own tops
    when it has :data:`STAND_FIT_MIN_TOPS` of them
    (:data:`~lidartrees_gis.plantation.stocking.PLANTING_MIN_TREES` with ``spacing="auto"``, whose
    spacing is found per stand by :func:`~lidartrees_gis.plantation.stocking.detect_planting`);
    ``grid``: the lattice of all the tops when already found. The tops are taken in an order
    of their own (:func:`_canonical`), so a whole area's tops and the same tops gathered from
    its tiles give the same lattices: a run in tiles fits each stand once, from all its tiles'
    tops, and every tile counts its positions on that lattice. ``cell``: the CHM's cell size
    (see :func:`~lidartrees_gis.plantation.stocking.detect_planting`). ``spectra``: with
    ``spacing="auto"``, a function that gives ``{key: canopy spectrum}``
    (:func:`~lidartrees_gis.plantation.canopy_lattice.canopy_spectrum`) for a list of keys (stand indices,
    ``"all"``): a stand whose tops show no lattice (a closed canopy, where the tops of
    neighbours merge) is given the lattice of its canopy's spectrum
    (:func:`~lidartrees_gis.plantation.canopy_lattice.canopy_planting`) when there is one;
    where its canopy shows rows but no plants along them, ``("why", key)`` says so in words
    (:func:`~lidartrees_gis.plantation.canopy_lattice.canopy_rows_only`). ``fits``:
    a function ``fits(jobs, spacing, cell, scan)`` that gives :func:`fit_lattice` of each
    ``(x, y)`` of ``jobs``, in order (a run's workers, one stand each); by default fitted here
    in turn. ``scan``: the returns' scan waves (:func:`~lidartrees_gis.plantation.scan.
    merge_waves` of the tiles'): a lattice with their period along its rows is the scanner's;
    a stand whose tops show no other has none, and ``("why", key)`` says so.
    """
    from .scan import scan_period
    from .canopy_lattice import canopy_planting, canopy_rows_only
    from .rows import choose, same_rows
    from .stocking import PLANTING_MIN_TREES

    tx, ty = np.asarray(top_x, float), np.asarray(top_y, float)
    o = _canonical(tx, ty)
    tx, ty = tx[o], ty[o]
    auto = isinstance(spacing, str)
    out = {}
    zone = None if top_zone is None else np.asarray(top_zone)[o]
    keys = [] if zone is None else [int(k) for k in (np.unique(zone) if zones is None
                                                     else zones)]

    def tops_of(k):
        return (tx, ty) if k == "all" else (tx[zone == k], ty[zone == k])

    def fit(x, y):
        return fit_lattice((x, y), spacing, cell, scan)

    def scanned(g):  # a lattice with the scan lines' period along its rows
        return g is not None and scan_period(g.tree_spacing, g.azimuth, scan) is not None

    def enough(k):
        return tops_of(k)[0].size >= (PLANTING_MIN_TREES if auto else STAND_FIT_MIN_TOPS)

    own = {}
    if grid is not None:
        own["all"] = grid
    todo = (["all"] if (top_zone is None or whole) and grid is None else []) + \
        [k for k in keys if enough(k)]
    found = fits([tops_of(k) for k in todo], spacing, cell, scan) if fits is not None and \
        todo else [fit(*tops_of(k)) for k in todo]
    # the stands whose tops showed the scanner's lattice only: none of theirs, but its rows
    scan_only = {}
    for k, g in zip(todo, found):
        if isinstance(g, tuple):
            out[("why", k)] = scan_why(g)
            scan_only[k] = g[2]
            g = None
        own[k] = g
    own.update({k: None for k in keys if k not in own})
    if auto and spectra is not None:
        # where the tops show no aligned lattice: the canopy's spectrum (one more pass for
        # them only); where the tops showed rows with their own phases, the one of the two
        # :func:`~.rows.choose` keeps
        lost = [k for k, g in own.items() if (g is None or not g.aligned)
                and tops_of(k)[0].size >= 10]
        if zone is not None and lost == ["all"]:
            lost = []  # with stands, the area's lattice is a fallback only: no pass for it alone
        if lost:
            powers = spectra(lost)
            for k in lost:
                if powers.get(k) is None:
                    continue
                rows = own[k]
                own[k] = canopy_planting(*tops_of(k), powers[k], cell)
                if scanned(own[k]):  # the canopy's heights peak on the scan lines too
                    own[k] = None
                if rows is not None:
                    own[k] = choose(rows, own[k], *tops_of(k))
                    continue
                if k in scan_only and own[k] is not None:
                    # the tops' rows hold (their plants were the scanner's): the canopy's
                    # plants along the same rows, or none
                    if same_rows(scan_only[k], own[k]):
                        out.pop(("why", k), None)
                        del scan_only[k]
                    else:
                        own[k] = None
                why = None if own[k] is not None else canopy_rows_only(powers[k], cell)
                if why and k in scan_only:  # both: the tops' period and the canopy's rows
                    why = f"{out[('why', k)]}; {why.removeprefix('no planting lattice: ')}"
                if why:
                    out[("why", k)] = why

    if not auto and todo:
        _other_lattices(out, todo, [tops_of(k) for k in todo], spacing, cell, scan, fits)
    refused = set()
    if auto:  # a stand whose tops leave its lattice's rows in a part of it has none
        from .blocks import OFF_ROWS_MAX, off_rows_share

        for k in keys:
            share = off_rows_share(own[k], *tops_of(k)) if own.get(k) is not None else 0.0
            if share > OFF_ROWS_MAX:
                own[k] = None
                refused.add(k)
                out[("why", k)] = (f"no planting lattice: {100 * share:.0f} % of its tops lie "
                                   "in parts off the rows the others follow (two plantings "
                                   "with no road between them, or rows that bend)")

    def all_tops():
        if "all" not in out:
            if "all" not in own:
                own["all"] = fit(tx, ty)
                if isinstance(own["all"], tuple):
                    out[("why", "all")] = scan_why(own["all"])
                    own["all"] = None
            out["all"] = own["all"]
            if out["all"] is not None:
                out[("span", "all")] = row_spans(out["all"], tx, ty)
        return out["all"]

    if top_zone is None or whole:
        all_tops()
    if top_zone is None:
        return out
    for k in keys:
        out[k] = own[k] if own[k] is not None or k in scan_only or k in refused \
            else all_tops()
        if out[k] is not None:
            out[("span", k)] = row_spans(out[k], *tops_of(k))
    return out


#: a lattice found under a stand's tops is another design than an explicit spacing when
#: either of its spacings differs from the given one by more than this share
OTHER_SPACING = 0.1


def _other_lattices(out: dict, keys, tops, spacing, cell, scan, fits) -> None:
    """With an explicit ``spacing``: ``out[("other", key)]`` for each stand (or ``"all"``)
    whose tops, looked at as ``spacing="auto"`` looks, lie on another lattice (a farm of 3 x 2
    and 3 x 3 m stands given one spacing)."""
    from .stocking import PLANTING_MIN_TREES

    pick = [i for i, (x, _) in enumerate(tops) if np.asarray(x).size >= PLANTING_MIN_TREES]
    if not pick:
        return
    jobs = [tops[i] for i in pick]
    found = fits(jobs, "auto", cell, scan) if fits is not None else \
        [fit_lattice(t, "auto", cell, scan) for t in jobs]
    for i, g in zip(pick, found):
        if g is None or isinstance(g, tuple):
            continue
        if abs(g.row_spacing / spacing[0] - 1) > OTHER_SPACING or \
                abs(g.tree_spacing / spacing[1] - 1) > OTHER_SPACING:
            out[("other", keys[i])] = (f"{g.row_spacing:.2f} x {g.tree_spacing:.2f} m (rows at "
                                       f"{g.azimuth % 180:.0f}°)")


def fit_lattice(tops, spacing, cell: float = 0.0, scan=None):
    """One stand's lattice under its ``tops`` ``(x, y)``: found
    (:func:`~lidartrees_gis.plantation.stocking.detect_planting`, None where there is none) with
    ``spacing="auto"``, else fitted at ``spacing`` ``(R, C)``. ``scan``: the returns' scan
    waves; where the only lattice the tops show has the scan lines' period along its rows,
    ``("scan", (plant spacing, scan period, azimuth), that lattice)`` instead of None (its
    rows are the tops', its plants the scanner's)."""
    from .stocking import detect_planting

    x, y = tops
    if isinstance(spacing, str):
        notes = {}
        g = detect_planting(x, y, cell=cell, scan=scan, notes=notes)
        return g if g is not None or "scan" not in notes else ("scan", notes["scan"],
                                                                notes["scan_grid"])
    return fit_planting_grid(x, y, *spacing)


def scan_why(found) -> str:
    """The ``lattice`` field's words for a lattice taken for the scanner's
    (:func:`fit_lattice`'s ``("scan", ...)``)."""
    tree, period, az = found[1]
    return (f"no planting lattice: the plants' period its tops show, {tree:.2f} m along rows "
            f"at {az % 180:.0f}°, is the returns' scan lines' ({period:.2f} m along them)")


def row_spans(grid: PlantingGrid, x, y) -> tuple:
    """Where a stand was planted, from its tops: each lattice row ``j`` that holds a top (within
    half the smaller spacing of a position) and, in it, the first and last such position ``i``,
    reaching as far as the neighbouring rows say (:func:`row_ends_from_neighbours`).
    Returns ``(rows, first, last, first_out, last_out)`` (int64 arrays, rows sorted): positions
    beyond a row's first and last trees, and rows beyond the outermost planted ones, are no
    planting positions (a stand polygon is drawn along roads and firebreaks, its first row some
    way inside it); those out to ``first_out`` and ``last_out`` (:func:`row_reach`) may be, and
    count where a tree stands there."""
    fi, fj = grid.to_lattice(np.asarray(x, float), np.asarray(y, float))
    ri, rj = np.rint(fi), np.rint(fj)
    near = np.hypot((fi - ri) * grid.tree_spacing, (fj - rj) * grid.row_spacing) \
        <= 0.5 * min(grid.row_spacing, grid.tree_spacing)
    ri, rj = ri[near].astype(np.int64), rj[near].astype(np.int64)
    if not rj.size:
        e = np.empty(0, np.int64)
        return e, e, e, e, e
    rows, inv = np.unique(rj, return_inverse=True)
    first = np.full(rows.size, np.iinfo(np.int64).max)
    last = np.full(rows.size, np.iinfo(np.int64).min)
    np.minimum.at(first, inv, ri)
    np.maximum.at(last, inv, ri)
    first = -row_ends_from_neighbours(rows, -first)
    last = row_ends_from_neighbours(rows, last)
    return rows, first, last, -row_reach(rows, -first), row_reach(rows, last)


#: how many rows on each side :func:`row_ends_from_neighbours` reads a row's end from
ROW_END_DEPTH = 3


def row_ends_from_neighbours(rows, last, depth: int = ROW_END_DEPTH):
    """Each row's last planted position from its own last tree and its neighbours': a row whose
    last trees are missing still runs as far as the rows on both sides say.

    The reach of row ``j`` is the least of ``floor((last[j - d] + last[j + d]) / 2)`` over
    ``d = 1..depth`` (rows not both present say nothing), where both lines, through rows
    ``j - 3, j - 1`` and through ``j + 3, j + 1``, pass the row's last tree, and no farther
    than the farther of them. For a
    convex planted area (an edge straight, or bent outwards, at any angle to the rows) the
    reach never passes the row's true end, its staircase included, so no position beyond the
    planting is added; the lines keep a corner bent inwards, or a step in the edge, from adding
    any either. A row's missing end trees are recovered but for one or two at most. ``rows``: sorted row indices;
    ``last``: their last positions (negate both ends for a row's first)."""
    rows = np.asarray(rows, np.int64)
    last = np.asarray(last, np.int64)
    n = rows.size
    if n < 3:
        return last
    big = np.iinfo(np.int64).max

    def at(d):
        return _row_at(rows, d)

    reach = np.full(n, big)
    for d in range(1, depth + 1):
        (lo, has_lo), (hi, has_hi) = at(-d), at(d)
        both = has_lo & has_hi
        reach = np.where(both, np.minimum(reach, (last[lo] + last[hi]) // 2), reach)
    (l1, h1), (l3, h3), (r1, g1), (r3, g3) = at(-1), at(-3), at(1), at(3)
    lines = h1 & h3 & g1 & g3
    left, right = (3 * last[l1] - last[l3]) // 2, (3 * last[r1] - last[r3]) // 2
    beyond = lines & (np.minimum(left, right) > last)  # both sides say the row runs on
    reach = np.where(beyond, np.minimum(reach, np.maximum(left, right)), big)
    return np.where(reach < big, np.maximum(last, reach), last)


#: how many positions beyond a row's end :func:`row_reach` may reach
ROW_REACH_BEYOND = 2


def row_reach(rows, last, depth: int = ROW_END_DEPTH, beyond: int = ROW_REACH_BEYOND):
    """How far each row may run at most: the farthest of ``ceil((last[j - d] + last[j + d]) /
    2)`` over ``d = 1..depth`` (the neighbours' mean end rounded out; on a straight edge it is
    never short of the row's true end, its staircase included), at least one position and at
    most ``beyond`` positions beyond ``last``. The positions between a row's end
    (:func:`row_ends_from_neighbours`) and its reach are the ones the returns must settle: a
    tree standing there (suppressed, uncertain) makes one a planting position; an empty one
    is either a missing tree at the row's end or no planting, and the stocking's interval
    counts it both ways (``edge_unresolved``). ``rows``, ``last``: as
    :func:`row_ends_from_neighbours`'s (negate both ends for a row's first)."""
    rows = np.asarray(rows, np.int64)
    last = np.asarray(last, np.int64)
    n = rows.size
    reach = last + 1
    for d in range(1, depth + 1):
        (lo, has_lo), (hi, has_hi) = _row_at(rows, -d), _row_at(rows, d)
        both = has_lo & has_hi
        reach = np.where(both, np.maximum(reach, -((-(last[lo] + last[hi])) // 2)), reach)
    return np.minimum(reach, last + beyond)


def _row_at(rows, d: int) -> tuple:
    """For each of the sorted ``rows``: the index of row ``j + d`` and whether it exists."""
    k = np.clip(np.searchsorted(rows, rows + d), 0, max(rows.size - 1, 0))
    return k, rows[k] == rows + d if rows.size else np.zeros(0, bool)


def own_spacings(st: dict, zone, larger: bool = False):
    """The smaller (``larger``: the larger) spacing of each position's own stand lattice
    (``zone``: each position's zone in :func:`stocking_by_stand`'s ``zones``), or None without
    zones."""
    if not st.get("zones") or zone is None:
        return None
    pick = max if larger else min
    own = {k: pick(z["spacing"]) for k, z in st["zones"].items() if z.get("spacing")}
    return np.array([own.get(int(k), pick(st["spacing"])) for k in zone], float)


def lattice_anchor(grid: PlantingGrid, region, res: float) -> tuple:
    """Where a stand's row and plant numbers start: ``(j0, first)``, the first row of the
    lattice nodes that lie in ``region`` (a shapely polygon: the stand, or the area's extent)
    and each row's first node (``first[k]``: row ``j0 + k``; a huge value for a row with
    none), in :func:`~lidartrees_gis.plantation.stocking.crew_numbers`'s signed indices. A node lies
    in the region when the centre of its cell (a grid of ``res`` aligned to multiples of
    ``res``, as every tile's) does, as a stand's cells are found
    (:func:`lidartrees_gis.plantation.stands.zones`). It depends on the lattice and the region only,
    so every tile of a run numbers a stand's trees alike."""
    import shapely

    from ..grid import EDGE_EPS
    from .stocking import row_heading

    s, _ = row_heading(grid)
    x0, y0, x1, y1 = region.bounds
    ci, cj = grid.to_lattice(np.array([x0, x0, x1, x1]), np.array([y0, y1, y0, y1]))
    ia = np.arange(np.floor(ci.min()) - 1, np.ceil(ci.max()) + 2)
    ja = np.arange(np.floor(cj.min()) - 1, np.ceil(cj.max()) + 2)
    big = np.iinfo(np.int64).max
    shapely.prepare(region)
    rows_j, rows_i = [], []
    for block in np.array_split(ja, max(1, ja.size * ia.size // 1_000_000 + 1)):
        ii, jj = np.meshgrid(ia, block)
        nx, ny = grid.to_map(ii.ravel(), jj.ravel())
        cx = (np.floor(nx / res + EDGE_EPS) + 0.5) * res
        cy = (np.floor(ny / res + EDGE_EPS) + 0.5) * res
        inside = shapely.contains_xy(region, cx, cy)
        rows_j.append(np.round(s * jj.ravel()[inside]).astype(np.int64))
        rows_i.append(np.round(s * ii.ravel()[inside]).astype(np.int64))
    sj, si = np.concatenate(rows_j), np.concatenate(rows_i)
    if not sj.size:
        return 0, np.empty(0, np.int64)
    j0 = int(sj.min())
    first = np.full(int(sj.max()) - j0 + 1, big, np.int64)
    np.minimum.at(first, sj - j0, si)
    return j0, first


def add_anchors(grids: dict, regions: dict, res: float, zones=None) -> dict:
    """Add to ``grids`` (:func:`fit_stand_grids`) where each stand's row and plant numbers
    start, as ``grids[("anchor", zone)]`` (:func:`lattice_anchor` of the zone's lattice over
    ``regions[zone]``, the extent's -1 for a zone with no region of its own); ``zones``: those
    wanted (default: every one of ``grids``). Kept once made: a run in tiles makes them once,
    with the lattices."""
    want = [k for k in grids if isinstance(k, int)] if zones is None else zones
    for k in want:
        key = ("anchor", int(k))
        g = grids.get(int(k), grids.get("all"))
        region = regions.get(int(k), regions.get(-1))
        if key in grids or g is None or region is None:
            continue
        span = grids.get(("span", int(k)))
        grids[key] = span_anchor(g, span) if span is not None and len(span[0]) \
            else lattice_anchor(g, region, res)
    return grids


def span_anchor(grid: PlantingGrid, span) -> tuple:
    """Where a stand's row and plant numbers start, from where it was planted
    (:func:`row_spans`): row 1 is its outermost planted row, plant 1 each row's first planted
    position, as a crew counts them (the nodes between the polygon's edge and the first row, a
    road or firebreak, are not counted). ``(j0, first)`` as :func:`lattice_anchor`'s."""
    from .stocking import row_heading

    s = int(row_heading(grid)[0])
    rows, first, last = (np.asarray(a, np.int64) for a in span[:3])
    sj = s * rows
    si = first if s > 0 else -last
    j0 = int(sj.min())
    out = np.full(int(sj.max()) - j0 + 1, np.iinfo(np.int64).max, np.int64)
    out[sj - j0] = si  # one span per row
    return j0, out


def top_zones(top_x, top_y, zone, spec) -> np.ndarray:
    """The stand index (``zone``, per cell of ``spec``) of each top; -1 outside the grid."""
    tx, ty = np.asarray(top_x, float), np.asarray(top_y, float)
    r, c = spec.cell_index(tx, ty)
    inside = (r >= 0) & (r < spec.height) & (c >= 0) & (c < spec.width)
    out = np.full(tx.size, -1, np.int64)
    out[inside] = np.asarray(zone)[r[inside], c[inside]]
    return out


def stocking_by_stand(top_x, top_y, chm, spec, spacing, zone, *, min_height: float = 2.0,
                      grid: PlantingGrid | None = None, within=None,
                      grids: dict | None = None, regions: dict | None = None,
                      masks: dict | None = None) -> dict:
    """:func:`stocking` with a planting lattice fitted per stand.

    ``zone``: the stand index of every cell of ``spec`` (-1 outside every stand; see
    :func:`lidartrees_gis.plantation.stands.zones`), or None for one stand. Each stand's positions are
    those of the lattice fitted to the tops inside it (:data:`STAND_FIT_MIN_TOPS`), in its part
    of the planted area; the cells outside every stand are one more zone, so the sums over the
    zones are the whole tile's. ``spacing``: ``(R, C)``, or ``"auto"``: each stand's spacing
    found under its tops too (:func:`lidartrees_gis.plantation.stocking.detect_planting`; a stand
    where none is found has no positions). Returns :func:`stocking`'s dict (counts summed, gaps
    and the tops' row and plant numbers of every zone; the ``gaps`` and ``looks`` tables with
    each position's ``zone``) with ``spacing`` and
    ``zones`` (per zone index: ``expected, stocked, missing, extra, planted_area_ha, azimuth,
    spacing``); ``grid`` and ``spacing`` are those of the zone with the most positions.
    ``grids``: the lattices (:func:`fit_stand_grids`) when already fitted (by default fitted
    here, on these tops); returned as ``grids``. ``regions``: ``{zone: polygon}`` (each
    stand's polygon, and -1: the area's extent) where the stands' row and plant numbers start
    (:func:`add_anchors`: kept in ``grids``, so that every tile numbers a stand alike).
    ``masks``: the planted-area masks already made on this CHM (:func:`stand_mask`, by
    :func:`~lidartrees_gis.plantation.stocking.mask_radius`; returned as ``masks`` for the next call
    on the same CHM).
    """
    tx, ty = np.asarray(top_x, float), np.asarray(top_y, float)
    zoned = zone is not None and bool((np.asarray(zone) >= 0).any())
    zone = np.asarray(zone) if zoned else np.full(spec.shape, -1, np.int32)
    top_zone = top_zones(tx, ty, zone, spec)
    a = np.asarray(chm, float)
    present = np.unique(zone[np.isfinite(a) & (a >= min_height)]).tolist()
    if grids is None:
        def spectra(keys):  # -spacing auto: the canopies of the stands whose tops show none
            from .canopy_lattice import canopy_peaks, canopy_spectrum

            masks = {k: None if k == "all" else zone == k for k in keys}
            return {k: {"power": canopy_spectrum(a, spec.res, masks[k]), "looks": 1.0,
                        "peaks": canopy_peaks(a, spec, masks[k], min_height)} for k in keys}

        grids = fit_stand_grids(tx, ty, top_zone if zoned else None, spacing, grid,
                                zones=present if zoned else None, cell=spec.res,
                                spectra=spectra)
    if regions:
        add_anchors(grids, regions, spec.res, present)
    masks = {} if masks is None else masks

    def planted(sp):
        r = mask_radius(spec.res, *sp)
        if r not in masks:
            masks[r] = stand_mask(chm, spec.res, *sp, min_height=min_height)
        return masks[r]

    parts = {}
    for k in present:
        own = top_zone == k
        g = grids[k] if k in grids else grids["all"]
        if g is None:
            continue
        sp = (g.row_spacing, g.tree_spacing)
        span = grids.get(("span", k)) if k in grids else grids.get(("span", "all"))
        mine = zone == k
        parts[k] = stocking(tx, ty, a, spec, sp, min_height=min_height, grid=g, within=within,
                            planted=planted(sp) & mine, own=own if zoned else None,
                            anchor=grids.get(("anchor", k)), span=span,
                            area=mine & np.isfinite(a))
        parts[k]["spacing"] = sp
    if not parts:
        return {**_empty(tx.size), "grids": grids, "masks": masks}
    main = max(parts.values(), key=lambda p: p["expected"])
    out = {k: sum(p[k] for p in parts.values()) for k in ("expected", "stocked", "missing",
                                                           "extra", "planted_area_ha",
                                                           "edge_cut")}
    cat = {key: Positions.concat(p[key].with_columns(zone=np.full(len(p[key]), k))
                                 for k, p in parts.items()) for key in ("gaps", "looks")}
    tops_row = np.zeros(tx.size, np.int64)
    tops_plant = np.zeros(tx.size, np.int64)
    shares = np.zeros(tx.size, bool)
    for p in parts.values():
        took = p["tops_row"] > 0
        tops_row[took], tops_plant[took] = p["tops_row"][took], p["tops_plant"][took]
        shares |= p["shares"]
    shares &= tops_row == 0  # a top that took a position in its own stand keeps it
    e = out["expected"]
    R, C = main["spacing"]
    out.update(cat, grid=main["grid"], spacing=main["spacing"], numbering=main["numbering"],
               tops_row=tops_row, tops_plant=tops_plant, shares=shares,
               planted_per_ha=1e4 / (R * C),
               stocking_pct=100.0 * out["stocked"] / e if e else float("nan"),
               zones={k: {**{f: p[f] for f in ("expected", "stocked", "missing", "extra",
                                               "planted_area_ha", "spacing", "edge_cut")},
                          "azimuth": p["grid"].azimuth} for k, p in parts.items()},
               grids=grids, masks=masks)
    return out
