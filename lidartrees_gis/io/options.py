"""How point files are opened: the reading options every command shares (CRS, XYZ dialect) and
the class filter (``-drop_class``, ``-keep_class``), as one small dataclass."""
from __future__ import annotations

from dataclasses import asdict, dataclass, replace

from ..errors import InputError
from .points import PointSource, open_points

#: LAS classes dropped by default: 7 low noise, 18 high noise (ASPRS)
NOISE_CLASSES = (7, 18)


def parse_classes(value, param="-drop_class"):
    """``"7,18"``, ``"7 18"``, ``[7, 18]``, ``"none"`` -> tuple of ints (empty for none)."""
    if value is None:
        return None
    if isinstance(value, (list, tuple)):
        items = [str(v) for v in value]
    else:
        text = str(value).strip().lower()
        if text in ("", "none", "-"):
            return ()
        items = text.replace(",", " ").split()
    try:
        out = tuple(int(v) for v in items)
    except ValueError:
        raise InputError(f"{param}: expected class numbers such as 7,18 (or none), got {value!r}") from None
    if any(c < 0 or c > 255 for c in out):
        raise InputError(f"{param}: classes are 0-255, got {value!r}")
    return out


@dataclass(frozen=True)
class ReadOptions:
    """How the points of every input file are read.

    Attributes
    ----------
    a_srs : str, optional
        Assign this CRS (EPSG code, WKT, PROJ or a Brazilian alias such as ``SAD69 24K``).
    t_srs : str, optional
        Reproject the points to this CRS as they are read.
    delimiter, decimal_comma, columns
        The XYZ text dialect, detected when not given.
    skip_invalid : bool
        Skip malformed XYZ lines (counted) instead of failing.
    require_crs : bool
        Refuse inputs without a CRS (the commands whose outputs are georeferenced).
    drop_class : tuple of int
        LAS classes left out (default 7 and 18, noise), as LAStools' ``-drop_class``.
    keep_class : tuple of int, optional
        Only these LAS classes are used (``-keep_class``).

    Class lists may be given as text (``"7,18"``, ``"none"``).
    """

    a_srs: str | None = None
    t_srs: str | None = None
    delimiter: str | None = None
    decimal_comma: bool | None = None
    columns: str | None = None
    skip_invalid: bool = False
    require_crs: bool = False
    drop_class: tuple = NOISE_CLASSES
    keep_class: tuple | None = None

    def __post_init__(self):
        object.__setattr__(self, "drop_class", parse_classes(self.drop_class) or ())
        object.__setattr__(self, "keep_class", parse_classes(self.keep_class, "-keep_class"))

    def open_kw(self) -> dict:
        """Keyword arguments of :func:`~lidartrees_gis.io.points.open_points`."""
        return {k: v for k, v in asdict(self).items()
                if k not in ("drop_class", "keep_class") and v is not None}

    def open(self, path, *, filtered: bool = True, **kw) -> PointSource:
        """Open one point file; with ``filtered`` its class filter is set."""
        src = open_points(path, **self.open_kw(), **kw)
        if filtered:
            src.set_class_filter(drop=self.drop_class, keep=self.keep_class)
        return src

    def with_crs(self, a_srs) -> "ReadOptions":
        return replace(self, a_srs=a_srs)

    def describe(self) -> dict:
        """The class filter as recorded in outputs."""
        return {"drop_class": ",".join(map(str, self.drop_class)),
                "keep_class": None if self.keep_class is None else
                ",".join(map(str, self.keep_class))}


def filter_report(dropped: dict) -> dict:
    """Points per dropped class, as results report them (None when nothing was dropped)."""
    return {"dropped_classes": {str(k): v for k, v in sorted(dropped.items())} or None}
