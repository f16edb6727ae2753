"""What an output records of how it was made: command, input, parameters, CRS, tool version and
the ``-t_srs`` reprojection (GeoTIFF tags, GeoPackage and LAS metadata), as PDAL does."""
from __future__ import annotations

from typing import TYPE_CHECKING

from .._version import __version__
from ..crs import crs_label

if TYPE_CHECKING:
    from .points import PointSource


def raster_tags(command: str, src: PointSource, params: dict, input=None) -> dict:
    """GeoTIFF tags of an output made by ``command`` from ``src`` (a point source or a catalog;
    ``input``: the input as the user named it, default ``src.path``)."""
    tags = {"LIDARTREES_COMMAND": command,
            "LIDARTREES_INPUT": str(src.path if input is None else input),
            "LIDARTREES_PARAMETERS": {k: v for k, v in params.items() if v is not None},
            "LIDARTREES_CRS": crs_label(src.crs), "LIDARTREES_TOOL": f"lidartrees_gis {__version__}"}
    tags.update({k.upper().replace("REPROJECTION_", "LIDARTREES_"): v
                 for k, v in repro_meta(src).items()})
    return tags


def repro_report(src: PointSource):
    """The ``-t_srs`` operation in words (None without a reprojection)."""
    return src.repro.report() if getattr(src, "repro", None) else None


def repro_meta(src: PointSource) -> dict:
    """Source CRS, operation and its accuracy of a ``-t_srs`` reprojection (empty without)."""
    r = getattr(src, "repro", None)
    if r is None:
        return {}
    acc = None if r.accuracy is None or r.accuracy < 0 else r.accuracy
    return {"reprojection_source_crs": crs_label(r.src), "reprojection_operation": r.description,
            "reprojection_accuracy_m": "unknown" if acc is None else f"{acc:g}",
            "reprojection_note": r.note.lstrip("; ") or None}
