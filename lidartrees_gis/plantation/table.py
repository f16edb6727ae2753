"""One table type for planting positions (:class:`Positions`): the empty positions a stand's
lattice leaves (the ``gaps`` of :func:`lidartrees_gis.plantation.stocking.stocking`), what the
second look finds there (:func:`lidartrees_gis.plantation.status.classify_gaps`) and the
positions a tree is looked for at (``looks``), as columns of one length instead of parallel
arrays in a dict."""
from __future__ import annotations

from dataclasses import dataclass, fields, replace

import numpy as np

from ..io.store import register

#: every column's dtype; ``x, y`` are always there, the others once something sets them
POSITION_DTYPES = {"x": np.float64, "y": np.float64, "i": np.int64, "j": np.int64,
                   "row": np.int64, "plant": np.int64, "edge": bool, "zone": np.int64,
                   "status": np.int8, "share": np.float64, "returns": np.int64,
                   "height": np.float64, "tree_x": np.float64, "tree_y": np.float64}


@register  # a tile's result holding them is kept for -resume
@dataclass(frozen=True, eq=False)
class Positions:
    """Planting positions, one row each.

    Attributes
    ----------
    x, y : ndarray
        The position (its lattice node), map units.
    i, j : ndarray of int64, optional
        Its lattice indices (plant along the row, row).
    row, plant : ndarray of int64, optional
        Row and plant numbers as a crew counts them
        (:func:`~lidartrees_gis.plantation.stocking.crew_numbers`).
    edge : ndarray of bool, optional
        Just beyond its row's first or last tree, within the row's reach
        (:func:`~lidartrees_gis.plantation.positions.row_spans`).
    zone : ndarray of int64, optional
        Its stand's index (-1: none).
    status, share, returns, height, tree_x, tree_y : ndarray, optional
        What stands there (:func:`~lidartrees_gis.plantation.status.position_status`):
        missing, suppressed or uncertain; the share of the returns near it at a suppressed
        tree's height, of how many returns; the tree's height and apex (NaN and the position
        where none leans to a tree).
    """

    x: np.ndarray
    y: np.ndarray
    i: np.ndarray | None = None
    j: np.ndarray | None = None
    row: np.ndarray | None = None
    plant: np.ndarray | None = None
    edge: np.ndarray | None = None
    zone: np.ndarray | None = None
    status: np.ndarray | None = None
    share: np.ndarray | None = None
    returns: np.ndarray | None = None
    height: np.ndarray | None = None
    tree_x: np.ndarray | None = None
    tree_y: np.ndarray | None = None

    def __post_init__(self):
        n = None
        for f in fields(self):
            v = getattr(self, f.name)
            if v is None:
                continue
            a = np.asarray(v, POSITION_DTYPES[f.name]).reshape(-1)
            if n is None:
                n = a.size
            elif a.size != n:
                raise ValueError(f"planting positions: column {f.name!r} has {a.size} rows, "
                                 f"not {n}")
            object.__setattr__(self, f.name, a)

    def __len__(self) -> int:
        return int(self.x.size)

    def columns(self) -> list:
        """The names of the columns set."""
        return [f.name for f in fields(self) if getattr(self, f.name) is not None]

    def take(self, index) -> Positions:
        """The rows ``index`` selects (a boolean mask or indices), every column."""
        return replace(self, **{c: getattr(self, c)[index] for c in self.columns()})

    def with_columns(self, **columns) -> Positions:
        """A copy with these columns set (each as long as the table)."""
        return replace(self, **columns)

    def column(self, name: str, fill) -> np.ndarray:
        """Column ``name``, or ``fill`` on every row when it is not set."""
        v = getattr(self, name)
        if v is not None:
            return v
        return np.full(len(self), fill, POSITION_DTYPES[name])

    @classmethod
    def empty(cls) -> Positions:
        """No position (``x, y`` only)."""
        return cls(np.empty(0), np.empty(0))

    @classmethod
    def concat(cls, parts) -> Positions:
        """The rows of ``parts`` in turn; a column is kept where every part has it."""
        parts = list(parts)
        if not parts:
            return cls.empty()
        names = [c for c in parts[0].columns() if all(getattr(p, c) is not None for p in parts)]
        return cls(**{c: np.concatenate([getattr(p, c) for p in parts]) for c in names})
