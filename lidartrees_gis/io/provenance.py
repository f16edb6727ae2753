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


def _operations(src) -> list:
    """The distinct ``-t_srs`` operations of ``src`` (a file, or a catalog whose files may be in
    different CRSs), each with the files it applies to: ``[(Reprojection, [file, ...])]``."""
    repros = getattr(src, "repros", None)
    if not repros:
        r = getattr(src, "repro", None)
        return [(r, [str(getattr(src, "path", ""))])] if r is not None else []
    ops = {}
    for f, r in zip(src.files, repros):
        if r is not None:
            ops.setdefault(r.report(), (r, []))[1].append(str(f))
    return list(ops.values())


def repro_report(src: PointSource):
    """The ``-t_srs`` operation in words (None without a reprojection); a folder whose files
    were in different CRSs gets each operation with its number of files."""
    ops = _operations(src)
    if not ops:
        return None
    if len(ops) == 1:
        return ops[0][0].report()
    return "; ".join(f"{r.report()} [{len(files)} file(s)]" for r, files in ops)


def repro_meta(src: PointSource) -> dict:
    """Source CRS, operation and its accuracy of a ``-t_srs`` reprojection (empty without);
    files from several CRSs: each operation (``; `` between them), the worst accuracy, and
    ``reprojection_files``: each file's operation and accuracy (JSON)."""
    import json

    ops = _operations(src)
    if not ops:
        return {}
    accs = [r.accuracy for r, _ in ops]
    known = [a for a in accs if a is not None and a >= 0]
    acc = "unknown" if len(known) < len(accs) else f"{max(known):g}"
    meta = {"reprojection_source_crs": "; ".join(crs_label(r.src) for r, _ in ops),
            "reprojection_operation": "; ".join(r.description for r, _ in ops),
            "reprojection_accuracy_m": acc,
            "reprojection_note": "; ".join(r.note.lstrip("; ") for r, _ in ops if r.note) or None}
    if len(ops) > 1:
        meta["reprojection_files"] = json.dumps(
            {f: {"source_crs": crs_label(r.src), "operation": r.description,
                 "accuracy_m": None if r.accuracy is None or r.accuracy < 0 else r.accuracy}
             for r, files in ops for f in files})
    return meta
