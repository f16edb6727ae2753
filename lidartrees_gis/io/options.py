"""How point files are opened: the reading options every command shares (CRS, XYZ dialect) and
the class filter (``-drop_class``, ``-keep_class``)."""
from __future__ import annotations

from ..errors import InputError
from .points import PointSource, open_points


def open_input(path, *, a_srs=None, t_srs=None, require_crs=False, **kw) -> PointSource:
    """Open a point file (see :func:`lidartrees_gis.io.points.open_points`)."""
    return open_points(path, a_srs=a_srs, t_srs=t_srs, require_crs=require_crs, **kw)


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


def open_filtered(input, *, a_srs=None, t_srs=None, drop_class=NOISE_CLASSES, keep_class=None,
                  **read_kw) -> PointSource:
    """Open a point file with its class filter set: ``drop_class`` (default 7 and 18, noise)
    and ``keep_class`` (only these; default all), as LAStools' ``-drop_class``/``-keep_class``."""
    src = open_input(input, a_srs=a_srs, t_srs=t_srs, **read_kw)
    src.set_class_filter(drop=parse_classes(drop_class) or (),
                         keep=parse_classes(keep_class, "-keep_class"))
    return src


def filter_report(src, s=None) -> dict:
    out = {"dropped_classes": {str(k): v for k, v in sorted(src.dropped.items())} or None}
    if s is not None:
        out["outlier_points"] = s.get("outlier_points") or None
    return out
