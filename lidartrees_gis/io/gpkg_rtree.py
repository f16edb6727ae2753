"""A GeoPackage layer's spatial index built in one pass (a sort-tile-recursive bulk load).

GDAL updates a layer's R-tree feature by feature through the GeoPackage's triggers when a
layer is written in batches: two thirds of the time a trees run spends writing its
GeoPackage. Here the layers are written without an index and the index is made at the end,
from the features' bounds kept as they were written, in the tables GDAL would have made: the
``rtree_<table>_<column>`` virtual table of SQLite's R-tree module (nodes of 51 cells,
coordinates in float32 rounded outwards, as SQLite stores them), the GeoPackage's
``gpkg_rtree_index`` extension row and its seven triggers, so that QGIS and GDAL read and
edit the layer as one of theirs (SQLite's ``rtreecheck`` checks the tree in the tests).
"""
from __future__ import annotations

import numpy as np

#: cells per node, SQLite's RTREE_MAXCELLS: the node size (4 + 24 x 51 bytes) it takes for a
#: 2-D R-tree on 4096-byte pages, and reads back from the root node's length
MAX_CELLS = 51
NODE_BYTES = 4 + 24 * MAX_CELLS

_CELL = np.dtype([("id", ">i8"), ("box", ">f4", (4,))])

_T = 'CREATE TRIGGER "rtree_{t}_{c}_'
#: the triggers GDAL (3.12) writes with a layer's R-tree in a GeoPackage 1.2 (the project's
#: files, which QGIS 3.22 reads in full); {t}: table, {c}: geometry column, {i}: primary key
TRIGGERS_12 = (
    _T + 'delete" AFTER DELETE ON "{t}" WHEN old."{c}" NOT NULL BEGIN DELETE FROM '
    '"rtree_{t}_{c}" WHERE id = OLD."{i}"; END',
    _T + 'insert" AFTER INSERT ON "{t}" WHEN (new."{c}" NOT NULL AND NOT ST_IsEmpty(NEW."{c}")) '
    'BEGIN INSERT OR REPLACE INTO "rtree_{t}_{c}" VALUES (NEW."{i}",ST_MinX(NEW."{c}"), '
    'ST_MaxX(NEW."{c}"),ST_MinY(NEW."{c}"), ST_MaxY(NEW."{c}")); END',
    _T + 'update1" AFTER UPDATE OF "{c}" ON "{t}" WHEN OLD."{i}" = NEW."{i}" AND '
    '(NEW."{c}" NOTNULL AND NOT ST_IsEmpty(NEW."{c}")) BEGIN INSERT OR REPLACE INTO '
    '"rtree_{t}_{c}" VALUES (NEW."{i}",ST_MinX(NEW."{c}"), ST_MaxX(NEW."{c}"),'
    'ST_MinY(NEW."{c}"), ST_MaxY(NEW."{c}")); END',
    _T + 'update2" AFTER UPDATE OF "{c}" ON "{t}" WHEN OLD."{i}" = NEW."{i}" AND '
    '(NEW."{c}" ISNULL OR ST_IsEmpty(NEW."{c}")) BEGIN DELETE FROM "rtree_{t}_{c}" WHERE id = '
    'OLD."{i}"; END',
    _T + 'update3" AFTER UPDATE ON "{t}" WHEN OLD."{i}" != NEW."{i}" AND (NEW."{c}" NOTNULL '
    'AND NOT ST_IsEmpty(NEW."{c}")) BEGIN DELETE FROM "rtree_{t}_{c}" WHERE id = OLD."{i}"; '
    'INSERT OR REPLACE INTO "rtree_{t}_{c}" VALUES (NEW."{i}",ST_MinX(NEW."{c}"), '
    'ST_MaxX(NEW."{c}"),ST_MinY(NEW."{c}"), ST_MaxY(NEW."{c}")); END',
    _T + 'update4" AFTER UPDATE ON "{t}" WHEN OLD."{i}" != NEW."{i}" AND (NEW."{c}" ISNULL OR '
    'ST_IsEmpty(NEW."{c}")) BEGIN DELETE FROM "rtree_{t}_{c}" WHERE id IN (OLD."{i}", '
    'NEW."{i}"); END',
)

#: the same in a GeoPackage 1.4 (GDAL's default since 3.10: update1 and update3 replaced)
TRIGGERS_14 = (
    'CREATE TRIGGER "rtree_{t}_{c}_insert" AFTER INSERT ON "{t}" WHEN (new."{c}" NOT NULL AND '
    'NOT ST_IsEmpty(NEW."{c}")) BEGIN INSERT OR REPLACE INTO "rtree_{t}_{c}" VALUES '
    '(NEW."{i}",ST_MinX(NEW."{c}"), ST_MaxX(NEW."{c}"),ST_MinY(NEW."{c}"), ST_MaxY(NEW."{c}")); END',
    'CREATE TRIGGER "rtree_{t}_{c}_update6" AFTER UPDATE OF "{c}" ON "{t}" WHEN OLD."{i}" = '
    'NEW."{i}" AND (NEW."{c}" NOTNULL AND NOT ST_IsEmpty(NEW."{c}")) AND (OLD."{c}" NOTNULL AND '
    'NOT ST_IsEmpty(OLD."{c}")) BEGIN UPDATE "rtree_{t}_{c}" SET minx = ST_MinX(NEW."{c}"), '
    'maxx = ST_MaxX(NEW."{c}"),miny = ST_MinY(NEW."{c}"), maxy = ST_MaxY(NEW."{c}") WHERE id = '
    'NEW."{i}";END',
    'CREATE TRIGGER "rtree_{t}_{c}_update7" AFTER UPDATE OF "{c}" ON "{t}" WHEN OLD."{i}" = '
    'NEW."{i}" AND (NEW."{c}" NOTNULL AND NOT ST_IsEmpty(NEW."{c}")) AND (OLD."{c}" ISNULL OR '
    'ST_IsEmpty(OLD."{c}")) BEGIN INSERT INTO "rtree_{t}_{c}" VALUES (NEW."{i}",'
    'ST_MinX(NEW."{c}"), ST_MaxX(NEW."{c}"),ST_MinY(NEW."{c}"), ST_MaxY(NEW."{c}")); END',
    'CREATE TRIGGER "rtree_{t}_{c}_update2" AFTER UPDATE OF "{c}" ON "{t}" WHEN OLD."{i}" = '
    'NEW."{i}" AND (NEW."{c}" ISNULL OR ST_IsEmpty(NEW."{c}")) BEGIN DELETE FROM '
    '"rtree_{t}_{c}" WHERE id = OLD."{i}"; END',
    'CREATE TRIGGER "rtree_{t}_{c}_update5" AFTER UPDATE ON "{t}" WHEN OLD."{i}" != NEW."{i}" '
    'AND (NEW."{c}" NOTNULL AND NOT ST_IsEmpty(NEW."{c}")) BEGIN DELETE FROM "rtree_{t}_{c}" '
    'WHERE id = OLD."{i}"; INSERT OR REPLACE INTO "rtree_{t}_{c}" VALUES (NEW."{i}",'
    'ST_MinX(NEW."{c}"), ST_MaxX(NEW."{c}"),ST_MinY(NEW."{c}"), ST_MaxY(NEW."{c}")); END',
    'CREATE TRIGGER "rtree_{t}_{c}_update4" AFTER UPDATE ON "{t}" WHEN OLD."{i}" != NEW."{i}" '
    'AND (NEW."{c}" ISNULL OR ST_IsEmpty(NEW."{c}")) BEGIN DELETE FROM "rtree_{t}_{c}" WHERE '
    'id IN (OLD."{i}", NEW."{i}"); END',
    'CREATE TRIGGER "rtree_{t}_{c}_delete" AFTER DELETE ON "{t}" WHEN old."{c}" NOT NULL '
    'BEGIN DELETE FROM "rtree_{t}_{c}" WHERE id = OLD."{i}"; END',
)


def float32_box(bounds) -> np.ndarray:
    """``(n, 4)`` bounds ``minx, miny, maxx, maxy`` (float64, shapely's order) as an R-tree
    cell's ``minx, maxx, miny, maxy`` in float32, each minimum rounded down and maximum up
    (as SQLite stores them: the box always holds the geometry). Boxes already so (a float32
    array) are returned as they are."""
    if isinstance(bounds, np.ndarray) and bounds.dtype == np.float32:
        return bounds.reshape(-1, 4)
    b = np.asarray(bounds, np.float64).reshape(-1, 4)[:, [0, 2, 1, 3]]
    f = b.astype(np.float32)
    lo, hi = f[:, 0::2], f[:, 1::2]
    lo[:] = np.where(lo.astype(np.float64) > b[:, 0::2], np.nextafter(lo, np.float32(-np.inf)),
                     lo)
    hi[:] = np.where(hi.astype(np.float64) < b[:, 1::2], np.nextafter(hi, np.float32(np.inf)),
                     hi)
    return f


def _str_order(box: np.ndarray, cap: int) -> np.ndarray:
    """Sort-tile-recursive order of the boxes: vertical slices by centre x, each sorted by
    centre y, so that runs of ``cap`` are compact nodes."""
    n = box.shape[0]
    cx = box[:, 0].astype(np.float64) + box[:, 1]
    cy = box[:, 2].astype(np.float64) + box[:, 3]
    nodes = -(-n // cap)
    per_slice = cap * int(np.ceil(np.sqrt(nodes)))
    by_x = np.argsort(cx, kind="stable")
    slice_of = np.empty(n, np.int64)
    slice_of[by_x] = np.arange(n) // per_slice
    return np.lexsort((cy, slice_of))


def rtree_tables(fids, bounds, cap: int = MAX_CELLS) -> tuple:
    """The contents of an R-tree's ``_node``, ``_rowid`` and ``_parent`` tables for features
    ``fids`` with ``bounds`` (``(n, 4)``: minx, miny, maxx, maxy; rows with a NaN left out;
    or :func:`float32_box`'s boxes). Returns ``(nodes, rowid, parent)``: lists of ``(nodeno, blob)``, ``(fid, leaf nodeno)``,
    ``(nodeno, parent nodeno)``; node 1 is the root, whose first two bytes hold the depth."""
    fids = np.asarray(fids, np.int64)
    box = float32_box(bounds)
    ok = np.isfinite(box).all(axis=1)
    ids, box = fids[ok], box[ok]
    if not ids.size:
        return [(1, bytes(NODE_BYTES))], [], []
    levels = []  # per level, from the leaves: (child ids of each node, boxes) in node order
    while True:
        order = _str_order(box, cap)
        ids, box = ids[order], box[order]
        groups = np.arange(ids.size) // cap
        levels.append((ids, box, groups))
        n = int(groups[-1]) + 1
        if n == 1:
            break
        starts = np.arange(0, ids.size, cap)
        up = np.empty((n, 4), np.float32)
        up[:, 0] = np.minimum.reduceat(box[:, 0], starts)
        up[:, 1] = np.maximum.reduceat(box[:, 1], starts)
        up[:, 2] = np.minimum.reduceat(box[:, 2], starts)
        up[:, 3] = np.maximum.reduceat(box[:, 3], starts)
        ids, box = np.arange(n, dtype=np.int64), up  # placeholders: numbered below
    depth = len(levels) - 1
    # number the nodes from the root down (root 1), each level's nodes in order
    counts = [int(g[-1]) + 1 for _, _, g in levels]
    first_no = {}
    nxt = 1
    for lev in range(depth, -1, -1):
        first_no[lev] = nxt
        nxt += counts[lev]
    nodes, rowid, parent = [], [], []
    for lev, (child, cbox, groups) in enumerate(levels):
        if lev > 0:  # the children are the level below's nodes, by their index there
            child = child + first_no[lev - 1]
        cells = np.empty(child.size, _CELL)
        cells["id"], cells["box"] = child, cbox
        raw = cells.tobytes()
        starts = np.r_[0, np.flatnonzero(np.diff(groups)) + 1, child.size]
        for k in range(counts[lev]):
            a, b = starts[k], starts[k + 1]
            no = first_no[lev] + k
            head = np.array([depth if no == 1 else 0, b - a], ">u2").tobytes()
            body = raw[a * _CELL.itemsize:b * _CELL.itemsize]
            nodes.append((no, head + body + bytes(NODE_BYTES - 4 - len(body))))
        if lev == 0:  # each feature's leaf, in fid order (appended to SQLite's b-tree)
            leaf = first_no[0] + groups
            by_fid = np.argsort(child, kind="stable")
            rowid = list(zip(child[by_fid].tolist(), leaf[by_fid].tolist()))
        else:
            parent.extend(zip(child.tolist(), (first_no[lev] + groups).tolist()))
    return nodes, rowid, parent


def add_rtree(con, table: str, column: str, fids, bounds, pk: str = "fid") -> None:
    """Give ``table`` (its geometry ``column``, written without an index) the spatial index
    GDAL would have made, from its features' ``fids`` and ``bounds``, on the open sqlite3
    connection ``con`` (committed by the caller)."""
    name = f"rtree_{table}_{column}"
    con.execute(f'CREATE VIRTUAL TABLE "{name}" USING rtree(id, minx, maxx, miny, maxy)')
    nodes, rowid, parent = rtree_tables(fids, bounds)
    con.execute(f'DELETE FROM "{name}_node"')
    con.executemany(f'INSERT INTO "{name}_node" VALUES (?, ?)', nodes)
    con.executemany(f'INSERT INTO "{name}_rowid" VALUES (?, ?)', rowid)
    con.executemany(f'INSERT INTO "{name}_parent" VALUES (?, ?)', parent)
    con.execute("CREATE TABLE IF NOT EXISTS gpkg_extensions (table_name TEXT, column_name "
                "TEXT, extension_name TEXT NOT NULL, definition TEXT NOT NULL, scope TEXT NOT "
                "NULL, CONSTRAINT ge_tce UNIQUE (table_name, column_name, extension_name))")
    con.execute("INSERT INTO gpkg_extensions (table_name, column_name, extension_name, "
                "definition, scope) VALUES (?, ?, 'gpkg_rtree_index', "
                "'http://www.geopackage.org/spec120/#extension_rtree', 'write-only')",
                (table, column))
    version = con.execute("PRAGMA user_version").fetchone()[0]
    for sql in TRIGGERS_14 if version >= 10400 else TRIGGERS_12:
        con.execute(sql.format(t=table, c=column, i=pk))
