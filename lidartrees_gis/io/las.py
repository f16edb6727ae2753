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
    if b[104] & 0x80:  # LAZ: the chunk table the decoder will trust
        _check_laz_chunk_table(path, b, hsize, offset, nvlr, size)
    return b


#: LAZ chunks hold 50,000 points as written by LASzip and lazrs; a laszip VLR saying more than
#: this and more than the file's points is corrupt (the decoder would allocate the chunk whole
#: and abort the process when that fails)
MAX_LAZ_CHUNK = 5_000_000


def _check_laz_chunk_table(path, b, hsize: int, offset: int, nvlr: int, size: int) -> None:
    """Refuse a LAZ file whose chunk table cannot be true (the decoder would allocate what it
    says and abort the process): its offset beyond the file, a version other than 0, or more
    chunks than the points (or the file's bytes) allow."""
    import struct

    legacy, = struct.unpack_from("<I", b, 107)
    count = struct.unpack_from("<Q", b, 247)[0] if b[25] >= 4 and len(b) >= 255 else 0
    count = int(count or legacy)
    chunk_size = None
    with open(path, "rb") as fh:
        fh.seek(hsize)
        for _ in range(nvlr):  # the laszip VLR gives the points per chunk
            vh = fh.read(54)
            if len(vh) < 54:
                break
            user, rec, length = vh[2:18].rstrip(b"\0"), *struct.unpack_from("<HH", vh, 18)
            body = fh.read(length)
            if user == b"laszip encoded" and rec == 22204 and len(body) >= 16:
                chunk_size, = struct.unpack_from("<I", body, 12)
        if chunk_size is not None and chunk_size != 0xFFFFFFFF \
                and chunk_size > max(count, MAX_LAZ_CHUNK):  # the decoder allocates a chunk
            raise ReadError(f"{path}: the LAZ file is corrupt (its laszip VLR says {chunk_size:,} "
                            f"points per chunk, for {count:,} points)")
        fh.seek(offset)
        raw = fh.read(8)
        if len(raw) < 8:
            raise ReadError(f"{path}: the LAZ point data is missing (file of {size} bytes)")
        ct, = struct.unpack("<q", raw)
        if ct == -1:  # no chunk table written: the decoder scans the chunks itself
            return
        if not (offset + 8 <= ct <= size - 8):
            raise ReadError(f"{path}: the LAZ file is truncated or corrupt (its chunk table is "
                            f"said to start at byte {ct}, outside the {size}-byte file)")
        fh.seek(ct)
        version, nchunks = struct.unpack("<II", fh.read(8))
    if version != 0:
        raise ReadError(f"{path}: the LAZ chunk table is corrupt (version {version}, not 0)")
    most = size - ct  # every chunk's entry takes at least a byte of the table
    if chunk_size and chunk_size != 0xFFFFFFFF:
        most = min(most, count // max(chunk_size, 1) + 2)
    if nchunks > max(most, 1):
        raise ReadError(f"{path}: the LAZ chunk table is corrupt ({nchunks:,} chunks for "
                        f"{count:,} points in a {size:,}-byte file)")


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


#: set by :func:`one_thread`: decompress on the calling thread only
_ONE_THREAD = []


class one_thread:
    """Within it, LAZ files are decompressed on the calling thread (no thread pool started):
    a process that may fork its Dask workers afterwards reads this way, since a forked child
    inherits a thread pool's locks but not its threads and hangs on them."""

    def __enter__(self):
        _ONE_THREAD.append(True)
        return self

    def __exit__(self, *exc):
        _ONE_THREAD.pop()
        return False


def laz_backend():
    """LAZ decompressor for this process: laspy's default (lazrs on all cores) in a single
    process, one thread inside a Dask worker, whose siblings already use the other cores (a
    parallel decompressor per worker only oversubscribes them), and within :class:`one_thread`."""
    if _ONE_THREAD:
        import laspy

        return laspy.LazBackend.Lazrs if laspy.LazBackend.Lazrs.is_available() else None
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


class _DecoderStderr:
    """Silence the process's stderr (fd 2) while the LAZ decoder runs: a decoder panic prints
    its message and backtrace there before it becomes a Python exception, which is reported as
    one line naming the file. Only the decoder's calls are wrapped."""

    def __enter__(self):
        import os
        import sys

        try:
            sys.stderr.flush()
            self.saved = os.dup(2)
            self.null = os.open(os.devnull, os.O_WRONLY)
            os.dup2(self.null, 2)
        except OSError:  # no fd 2 (e.g. a GUI): nothing to silence
            self.saved = None
        return self

    def __exit__(self, *exc):
        import os

        if self.saved is not None:
            os.dup2(self.saved, 2)
            os.close(self.saved)
            os.close(self.null)
        return False


def las_chunks(src, progress):
    """Yield the points of the LAS/LAZ source ``src`` in chunks (x, y, z, classes, returns,
    intensity); non-finite coordinates are dropped and counted in ``src.skipped``."""
    import laspy

    prog = as_progress(progress)
    try:
        out_hdr = 0
        with _DecoderStderr():  # a LAZ reader reads the chunk table when it opens
            reader = laspy.open(src.path, laz_backend=laz_backend())
        with reader:
            total = max(int(reader.header.point_count), 1)
            done = 0
            dims = set(reader.header.point_format.dimension_names)
            chunks = reader.chunk_iterator(src.chunk_size)
            while True:
                with _DecoderStderr():
                    pts = next(chunks, None)
                if pts is None:
                    break
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
    except BaseException as exc:  # noqa: BLE001 - laspy, lazrs (a Rust panic is a
        # BaseException), struct, EOF: a broken file
        if isinstance(exc, (KeyboardInterrupt, SystemExit, GeneratorExit)):
            raise
        kind = "LAZ" if src.path.suffix.lower() == ".laz" else "LAS"
        raise ReadError(f"{src.path}: cannot read {kind} points, the file is truncated or "
                        f"corrupt ({type(exc).__name__}: {str(exc)[:120]})") from None


def _crs_records(h) -> list:
    """``(kind, CRS or None)`` of each CRS record of a LAS header, in file order (VLRs, then
    EVLRs): ``geokeys`` (GeoKeyDirectory, 34735) and ``wkt`` (OGC WKT, 2112)."""
    from laspy.vlrs.known import GeoKeyDirectoryVlr, WktCoordinateSystemVlr

    recs = list(h.vlrs) + list(getattr(h, "evlrs", None) or [])
    out = []
    for rec in recs:
        kind = ("wkt" if isinstance(rec, WktCoordinateSystemVlr) else
                "geokeys" if isinstance(rec, GeoKeyDirectoryVlr) else None)
        if kind is None:
            continue
        try:
            crs = rec.parse_crs()
        except Exception:  # noqa: BLE001 - an unreadable record counts as no CRS
            crs = None
        out.append((kind, crs))
    return out


def las_crs(h, path):
    """The CRS of a LAS header by the rule of the LAS specification, warning in one line when
    its CRS records disagree (which one is used and why).

    LAS 1.4 with the WKT bit of the global encoding set (required for point formats 6-10) is
    described by its (first readable) OGC WKT record; a LAS 1.0-1.3 file, or a 1.4 file without
    the bit, by its GeoKeys (WKT records are not part of those). When the record the rule names
    is absent or unreadable, the other kind is used. None when the file holds no readable CRS.
    """
    recs = _crs_records(h)
    found = [(k, c) for k, c in recs if c is not None]
    if not found:
        return None
    minor = int(str(h.version).split(".")[-1])
    wkt_bit = minor >= 4 and bool(getattr(h.global_encoding, "wkt", False))
    want, why = ("wkt", f"LAS 1.{minor} with the WKT bit of the global encoding set") if wkt_bit \
        else ("geokeys", f"LAS 1.{minor}" + (" without the WKT bit" if minor >= 4 else ""))
    chosen = next(((k, c) for k, c in found if k == want), found[0])
    others = {c.to_wkt(): (k, c) for k, c in found
              if not c.equals(chosen[1], ignore_axis_order=True)}
    if others:
        from ..crs import crs_label
        from ..errors import DataWarning

        names = {"wkt": "WKT record", "geokeys": "GeoKeys"}
        rule = (f"its {names[chosen[0]]}, as {why} requires" if chosen[0] == want else
                f"its {names[chosen[0]]}: {why}, but no readable {names[want]}")
        other = "; ".join(f"{names[k]} {crs_label(c)}" for k, c in others.values())
        warnings.warn(DataWarning(
            f"{path}: the file's CRS records disagree; using {crs_label(chosen[1])} ({rule}), "
            f"not {other}; give -a_srs if the other is right"), stacklevel=2)
    return chosen[1]
