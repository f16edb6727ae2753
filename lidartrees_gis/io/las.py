"""LAS/LAZ 1.0-1.4: the header checked before the decoder trusts it, and the points read in
chunks (laspy with lazrs)."""
from __future__ import annotations

import sys
import warnings
from pathlib import Path

import numpy as np

from ..errors import LidarTreesError, ReadError
from ..progress import as_progress, check_cancel
from .chunk import PointChunk


def _check_las_raw(path):
    """Check the fixed LAS header fields that tell the reader how much to read (signature,
    version, header size, VLR and EVLR counts) before laspy trusts them; returns the header
    bytes."""
    import struct

    size = path.stat().st_size
    with open(path, "rb") as fh:
        b = fh.read(375)
    if len(b) < 227 or b[:4] != b"LASF":
        raise ReadError(f"{path}: not a LAS/LAZ file (no LASF signature, or shorter than a header)")
    major, minor = b[24], b[25]
    if major != 1 or minor > 4:
        raise ReadError(f"{path}: LAS version {major}.{minor} is not LAS 1.0-1.4")
    hsize, = struct.unpack_from("<H", b, 94)
    offset, nvlr = struct.unpack_from("<II", b, 96)
    if hsize < 227 or hsize > offset or offset > size:
        raise ReadError(f"{path}: the LAS header is corrupt (header size {hsize}, point data at "
                        f"byte {offset}, file of {size} bytes)")
    if nvlr * 54 > offset - hsize:
        raise ReadError(f"{path}: the LAS header lists {nvlr:,} VLRs, more than fit before the "
                        f"point data (byte {offset}); the header is corrupt")
    if minor >= 4 and len(b) >= 255:
        start, nevlr = struct.unpack_from("<QI", b, 235)
        if nevlr and (start > size or nevlr * 60 > size - start):
            raise ReadError(f"{path}: the LAS header lists {nevlr:,} extended VLRs from byte "
                            f"{start}, beyond the {size}-byte file; the header is corrupt")
    return b


def las_point_count(path) -> int:
    """Point count from a LAS/LAZ header, after :func:`_check_las_raw`."""
    import struct

    b = _check_las_raw(Path(path))
    legacy, = struct.unpack_from("<I", b, 107)
    if b[25] >= 4 and len(b) >= 255:
        n, = struct.unpack_from("<Q", b, 247)
        return int(n or legacy)
    return int(legacy)


def _check_las_header(path, h, count):
    """Refuse a LAS/LAZ header whose scale, offset, bounds or point count cannot be true."""
    import math

    size = path.stat().st_size
    scales, offsets = [float(v) for v in h.scales], [float(v) for v in h.offsets]
    if not all(math.isfinite(v) and 1e-9 <= abs(v) <= 1e3 for v in scales):
        raise ReadError(f"{path}: the LAS header has an impossible scale {scales}")
    if not all(math.isfinite(v) and abs(v) <= 1e12 for v in offsets):
        raise ReadError(f"{path}: the LAS header has an impossible offset {offsets}")
    mins, maxs = [float(v) for v in h.mins], [float(v) for v in h.maxs]
    if not all(math.isfinite(v) and abs(v) <= 1e12 for v in mins + maxs):
        raise ReadError(f"{path}: the LAS header has impossible bounds {mins} .. {maxs}")
    rec = int(h.point_format.size)
    if path.suffix.lower() == ".las":
        need = int(h.offset_to_point_data) + count * rec
        if need > size:
            raise ReadError(f"{path}: the header says {count:,} points ({need:,} bytes) but the "
                            f"file has {size:,} bytes; it is truncated or the header is wrong")
        evlr = int(getattr(h, "start_of_first_evlr", 0) or 0)
        end = evlr if evlr > int(h.offset_to_point_data) else size
        held = (end - int(h.offset_to_point_data)) // rec
        if held > count:

            from ..errors import DataWarning

            warnings.warn(DataWarning(
                f"{path}: the file holds {held:,} point records but the header says {count:,}; "
                f"only {count:,} are read"), stacklevel=2)
    elif count > 100 * size:  # LAZ: no point takes less than a bit or so
        raise ReadError(f"{path}: the header says {count:,} points, impossible in a "
                        f"{size:,}-byte LAZ file; the header is wrong")


def laz_backend():
    """LAZ decompressor for this process: laspy's default (lazrs on all cores) in a single
    process, one thread inside a Dask worker, whose siblings already use the other cores (a
    parallel decompressor per worker only oversubscribes them)."""
    if "distributed" in sys.modules:
        from distributed import get_worker

        try:
            get_worker()
        except ValueError:  # not in a worker
            return None
        import laspy

        if laspy.LazBackend.Lazrs.is_available():
            return laspy.LazBackend.Lazrs
    return None


def las_chunks(src, progress):
    """Yield the points of the LAS/LAZ source ``src`` in chunks (x, y, z, classes, returns,
    intensity); non-finite coordinates are dropped and counted in ``src.skipped``."""
    import laspy

    prog = as_progress(progress)
    try:
        out_hdr = 0
        with laspy.open(src.path, laz_backend=laz_backend()) as reader:
            total = max(int(reader.header.point_count), 1)
            done = 0
            dims = set(reader.header.point_format.dimension_names)
            for pts in reader.chunk_iterator(src.chunk_size):
                check_cancel(progress)
                x = np.asarray(pts.x, dtype=np.float64)
                y = np.asarray(pts.y, dtype=np.float64)
                z = np.asarray(pts.z, dtype=np.float64)
                chunk = PointChunk(
                    x, y, z,
                    np.asarray(pts.classification, dtype=np.uint8),
                    np.asarray(pts.return_number, dtype=np.uint8),
                    np.asarray(pts.number_of_returns, dtype=np.uint8),
                    np.asarray(pts.intensity, dtype=np.uint16) if "intensity" in dims else None,
                )
                hb = src.header_info.get("bounds")
                if hb is not None:
                    zr = src.header_info.get("zrange", (-np.inf, np.inf))
                    tol = 0.01
                    out_hdr += int(((x < hb[0] - tol) | (x > hb[2] + tol) | (y < hb[1] - tol)
                                    | (y > hb[3] + tol) | (z < zr[0] - tol)
                                    | (z > zr[1] + tol)).sum())
                bad = ~(np.isfinite(x) & np.isfinite(y) & np.isfinite(z))
                if bad.any():
                    chunk = chunk.subset(~bad)
                    src.skipped += int(bad.sum())
                done += len(pts)
                prog.update(done / total, "reading points")
                yield chunk
        if out_hdr:

            from ..errors import DataWarning

            warnings.warn(DataWarning(
                f"{src.path}: {out_hdr:,} of {done:,} points lie outside the bounds the LAS "
                "header states; the header is stale (the points were used)"), stacklevel=2)
    except LidarTreesError:
        raise
    except Exception as exc:  # noqa: BLE001 - laspy, lazrs, struct, EOF: a broken file
        kind = "LAZ" if src.path.suffix.lower() == ".laz" else "LAS"
        raise ReadError(f"{src.path}: cannot read {kind} points, the file is truncated or "
                        f"corrupt ({type(exc).__name__}: {str(exc)[:120]})") from None
