"""Writing classified LAS/LAZ files (laspy), atomically."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import InputError
from .output import atomic_output


#: user id of the VLR that holds lidartrees' provenance (JSON text) in the LAS files it writes
PROVENANCE_VLR = ("lidartrees", 1)


def provenance_vlr(metadata: dict):
    """A LAS VLR holding ``metadata`` as JSON (command, parameters, ``-t_srs`` source CRS,
    operation and accuracy); read it back with :func:`read_provenance`."""
    import json

    import laspy

    body = json.dumps({k: v for k, v in metadata.items() if v is not None}, default=str,
                      ensure_ascii=True).encode("ascii")
    return laspy.VLR(user_id=PROVENANCE_VLR[0], record_id=PROVENANCE_VLR[1],
                     description="lidartrees_gis provenance", record_data=body)


def read_provenance(path) -> dict:
    """The provenance a lidartrees LAS/LAZ output holds ({} when it holds none)."""
    import json

    import laspy

    with laspy.open(str(path)) as fh:
        for v in fh.header.vlrs:
            if (v.user_id, v.record_id) == PROVENANCE_VLR:
                return json.loads(bytes(v.record_data).decode("ascii"))
    return {}


def write_classified(path, src, classification, *, overwrite=False, extra=None,
                     metadata=None) -> None:
    """Write the points of ``src`` (a PointSource) to LAS/LAZ with a new classification.

    A LAS/LAZ input is copied with every attribute kept; an XYZ input becomes LAS 1.4 point
    format 6 with 1 mm scales and the source CRS. ``extra`` maps name -> array for extra
    dimensions (e.g. a section id). ``metadata`` (a dict) is stored as a provenance VLR.
    """
    import laspy

    p = Path(path)
    if p.suffix.lower() not in (".las", ".laz"):
        raise InputError(f"OUTPUT: {p}: expected a .las or .laz file name")
    cls = np.asarray(classification, dtype=np.uint8)
    if src.format == "las" and src.repro is None:
        las = laspy.read(src.path)
        if len(las.points) != cls.size:
            raise InputError(f"{src.path}: {len(las.points)} points in the file, {cls.size} classes")
        las.classification = cls
    else:
        pts = src.read_all()
        header = laspy.LasHeader(point_format=6, version="1.4")
        header.scales = np.array([0.001, 0.001, 0.001])
        header.offsets = np.array([np.floor(pts.x.min()), np.floor(pts.y.min()), np.floor(pts.z.min())])
        if src.crs is not None:
            header.add_crs(src.crs)
        las = laspy.LasData(header)
        las.x, las.y, las.z = pts.x, pts.y, pts.z
        las.classification = cls
    for name, arr in (extra or {}).items():
        arr = np.asarray(arr)
        las.add_extra_dim(laspy.ExtraBytesParams(name=name, type=arr.dtype))
        setattr(las, name, arr)
    from .._version import __version__

    if metadata:
        las.header.vlrs = [v for v in las.header.vlrs
                           if (getattr(v, "user_id", ""), getattr(v, "record_id", 0)) != PROVENANCE_VLR]
        las.header.vlrs.append(provenance_vlr(metadata))
    las.header.generating_software = f"lidartrees_gis {__version__}"[:32]
    sysid = las.header.system_identifier
    if isinstance(sysid, bytes):
        sysid = sysid.decode("latin-1")
    las.header.system_identifier = str(sysid or "").encode("ascii", "ignore").decode()[:32]
    with atomic_output(p, overwrite) as tmp:
        try:
            las.write(str(tmp))
        except UnicodeError as exc:  # text in a VLR of the input that LAS cannot hold
            raise InputError(f"{src.path}: a header text of the input cannot be written to "
                             f"LAS ({exc})") from None


def write_points(path, x, y, z, *, crs=None, classification=None, extra=None, overwrite=False):
    """Write points (with optional classification and extra dimensions) to a new LAS 1.4 /
    point format 6 file (.las or .laz), 1 mm scales, atomically."""
    import laspy

    p = Path(path)
    if p.suffix.lower() not in (".las", ".laz"):
        raise InputError(f"OUTPUT: {p}: expected a .las or .laz file name")
    x, y, z = (np.asarray(a, dtype=np.float64) for a in (x, y, z))
    header = laspy.LasHeader(point_format=6, version="1.4")
    header.scales = np.array([0.001, 0.001, 0.001])
    if x.size:
        header.offsets = np.array([np.floor(x.min()), np.floor(y.min()), np.floor(z.min())])
    if crs is not None:
        header.add_crs(crs)
    for name, arr in (extra or {}).items():
        header.add_extra_dim(laspy.ExtraBytesParams(name=name, type=np.asarray(arr).dtype))
    las = laspy.LasData(header)
    las.x, las.y, las.z = x, y, z
    if classification is not None:
        las.classification = np.asarray(classification, dtype=np.uint8)
    for name, arr in (extra or {}).items():
        setattr(las, name, np.asarray(arr))
    with atomic_output(p, overwrite) as tmp:
        las.write(str(tmp))
