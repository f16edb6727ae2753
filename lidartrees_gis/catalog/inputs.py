"""What a user names as input, expanded to point files: files, folders, glob patterns, text
lists (one path a line), virtual point clouds (``.vpc``, the STAC ItemCollection QGIS and PDAL
write) and Entwine Point Tile indexes (``ept.json``, what QGIS 3.22 builds for a loaded point
cloud)."""
from __future__ import annotations

import glob
import os
import json
from pathlib import Path

from ..errors import InputError, ReadError


POINT_SUFFIXES = (".las", ".laz", ".xyz", ".txt", ".csv", ".pts", ".gz")


def _vpc_files(path: Path) -> list:
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise ReadError(f"{path}: cannot read as a virtual point cloud (JSON): {exc}") from None
    out = []
    for feat in doc.get("features", []):
        href = (feat.get("assets", {}).get("data", {}) or {}).get("href")
        if not href:
            continue
        p = Path(href)
        out.append(p if p.is_absolute() else (path.parent / p).resolve())
    if not out:
        raise InputError(f"{path}: the virtual point cloud lists no files (features[].assets.data.href)")
    return out


def is_ept(path) -> bool:
    """True for an Entwine Point Tile index (``ept.json``), what QGIS makes of a point cloud."""
    return Path(str(path)).name.lower() == "ept.json"


def _ept_doc(path: Path) -> dict:
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise ReadError(f"{path}: cannot read as an Entwine Point Tile index (JSON): {exc}") from None
    if not isinstance(doc, dict) or "schema" not in doc:
        raise InputError(f"{path}: not an Entwine Point Tile index (no schema)")
    return doc


def _ept_files(path: Path) -> list:
    """The data files of an EPT index: every point is in exactly one node, so all the nodes
    together are the whole cloud."""
    doc = _ept_doc(path)
    if doc.get("dataType") != "laszip":
        raise InputError(f"{path}: EPT data type {doc.get('dataType')!r} is not read; only "
                         "'laszip' (LAZ nodes) is. Use the original LAS/LAZ file instead")
    files = sorted((path.parent / "ept-data").glob("*.laz"))
    if not files:
        raise InputError(f"{path}: the EPT index has no data files in ept-data/")
    return files


def ept_crs(path):
    """The CRS an EPT index states (``srs.wkt`` or ``srs.authority:horizontal``), or None."""
    srs = _ept_doc(Path(str(path))).get("srs") or {}
    if srs.get("wkt"):
        return srs["wkt"]
    if srs.get("authority") and srs.get("horizontal"):
        return f"{srs['authority']}:{srs['horizontal']}"
    return None


def expand_inputs(inputs) -> list:
    """Point files named by ``inputs`` (a path or a list of them): files, folders (their point
    files), glob patterns, ``.txt``/``.lst`` lists of paths (one per line, relative to the
    list), ``.vpc`` virtual point clouds and ``ept.json`` Entwine Point Tile indexes (their
    LAZ nodes). Order is kept; duplicates are dropped."""
    items = [inputs] if isinstance(inputs, (str, Path)) else list(inputs)
    out = []
    for it in items:
        s = str(it)
        p = Path(s)
        if any(ch in s for ch in "*?[") and not p.exists():
            hits = sorted(glob.glob(s))
            if not hits:
                raise ReadError(f"{s}: the pattern matches no file")
            out += [Path(h) for h in hits]
        elif p.is_dir():
            out += folder_point_files(p)
        elif p.suffix.lower() == ".vpc":
            out += _vpc_files(p)
        elif is_ept(p) and p.is_file():
            out += _ept_files(p)
        elif p.suffix.lower() in (".lst",) or (p.suffix.lower() == ".txt" and _is_list(p)):
            base = p.parent
            for line in p.read_text(encoding="utf-8").splitlines():
                line = line.strip()
                if line and not line.startswith("#"):
                    q = Path(line)
                    out.append(q if q.is_absolute() else base / q)
        else:
            out.append(p)
    seen, uniq = set(), []
    for q in out:
        k = str(Path(q).resolve())
        if k not in seen:
            seen.add(k)
            # absolute: the workers of a cluster may run in another folder
            uniq.append(Path(os.path.abspath(q)))
    for q in uniq:
        if not q.exists():
            raise ReadError(f"{q}: no such file")
    return uniq


#: suffixes of binary point files, taken by their name
BINARY_SUFFIXES = (".las", ".laz")


def folder_point_files(folder: Path) -> list:
    """The point files of a folder: LAS/LAZ (COPC too) by their suffix, text files (.xyz, .txt,
    .csv, .pts, .gz) when their content parses as points
    (:func:`lidartrees_gis.io.xyz.looks_like_points`). The other files (a LEIAME.txt, a tile
    index CSV, a list of paths) are named once in a warning."""
    import warnings

    from ..errors import DataWarning
    from ..io.xyz import looks_like_points

    found, skipped = [], []
    for q in sorted(folder.iterdir()):
        if not q.is_file():
            continue
        suf = q.suffix.lower()
        if suf in BINARY_SUFFIXES:
            found.append(q)
        elif suf in POINT_SUFFIXES:
            (found if looks_like_points(q) else skipped).append(q)
    if not found:
        raise ReadError(f"{folder}: the folder holds no point file (LAS/LAZ, or XYZ text with x y z"
                        f" per line){'; not point data: ' + ', '.join(q.name for q in skipped) if skipped else ''}")
    if skipped:
        warnings.warn(f"{folder}: {len(skipped)} file(s) are not point data and are left out: "
                      f"{', '.join(q.name for q in skipped[:10])}{' ...' if len(skipped) > 10 else ''}",
                      DataWarning, stacklevel=2)
    return found


def _is_list(p: Path) -> bool:
    """A .txt file whose first non-empty line names an existing point file."""
    try:
        with open(p, encoding="utf-8", errors="replace") as fh:
            for line in fh:
                line = line.strip()
                if line:
                    q = Path(line)
                    q = q if q.is_absolute() else p.parent / q
                    return q.suffix.lower() in POINT_SUFFIXES and q.exists()
    except OSError:
        return False
    return False


def is_catalog_input(inputs) -> bool:
    """True when ``inputs`` names more than one file or a folder, glob, list or .vpc."""
    if not isinstance(inputs, (str, Path)):
        return len(list(inputs)) > 1 or any(is_catalog_input(i) for i in inputs)
    s = str(inputs)
    p = Path(s)
    if p.is_dir() or p.suffix.lower() in (".vpc", ".lst") or is_ept(p):
        return True
    if any(ch in s for ch in "*?[") and not p.exists():
        return True
    return p.suffix.lower() == ".txt" and p.exists() and _is_list(p)
