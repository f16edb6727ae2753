"""Triangulated surfaces: a linear TIN of points sampled at the cell centres of a grid.

* :func:`triangulate` — 2-D Delaunay triangulation (startinpy, else scipy's Qhull);
* :func:`tin_surface` — a linear TIN drawn on a :class:`~lidartrees_gis.grid.GridSpec`, long
  edges or wide circumcircles left out; the compiled :func:`_accel.layered_tin` first;
* :func:`interpolate_tin` — a TIN of scattered heights (ground points) over a whole grid, the
  DTMs' interpolator.

Pure functions over numpy arrays; the pit-free CHM (:mod:`lidartrees_gis.als.chm`) and the
ground filter's DTMs are built on them.
"""
from __future__ import annotations

import numpy as np

from . import _accel
from .errors import InputError
from .grid import GridSpec


#: triangles with a wider circumcircle (m) are not drawn: the surface then depends only on the
#: points within two radii of a cell, so tiles with that much buffer agree with the whole area
LOCAL_RADIUS = 10.0


def _centres_where(spec: GridSpec, mask):
    r, c = np.nonzero(mask)
    x, y = spec.xy(r, c)
    return r, c, x, y


def _morton_order(x, y, cell: float = 1.0):
    """Indices that sort points along a Morton curve of ``cell``-metre cells."""
    def spread(v):
        v = v & np.uint64(0xFFFF)
        v = (v | (v << np.uint64(8))) & np.uint64(0x00FF00FF)
        v = (v | (v << np.uint64(4))) & np.uint64(0x0F0F0F0F)
        v = (v | (v << np.uint64(2))) & np.uint64(0x33333333)
        return (v | (v << np.uint64(1))) & np.uint64(0x55555555)

    ix = np.clip((np.asarray(x) - np.min(x)) / cell, 0, 65535).astype(np.uint64)
    iy = np.clip((np.asarray(y) - np.min(y)) / cell, 0, 65535).astype(np.uint64)
    return np.argsort(spread(ix) | (spread(iy) << np.uint64(1)), kind="stable")


def _startinpy():
    """The startinpy module, or None where it is not installed."""
    try:
        import startinpy
    except ImportError:  # pragma: no cover - depends on the environment
        return None
    return startinpy


def _highest_dt(startinpy):
    """An empty startinpy DT in which coincident points keep the highest z. The caller must
    ``del`` it in a ``finally``: a DT must be dropped by the thread that made it (pyo3
    "unsendable"), not later by a garbage collection elsewhere through a traceback that still
    holds the frame."""
    dt = startinpy.DT()
    dt.duplicates_handling = "Highest"
    return dt


def triangulate(x, y, z):
    """2-D Delaunay triangulation: ``(px, py, pz, triangles)``.

    With startinpy (Rust, MIT licence; about 10x faster than Qhull here) coincident points keep
    the highest z; otherwise scipy's Qhull. Coordinates should be local (small numbers). The
    surfaces use the compiled :func:`_accel.layered_tin` first (3-4x faster again, and it draws
    while it triangulates); this is its fallback.
    """
    startinpy = _startinpy()
    if startinpy is not None:
        # insert along a Morton (z-order) curve of 1 m cells: incremental insertion walks from
        # the last point, and points in random order (some XYZ files) made it 70x slower
        order = _morton_order(x, y)
        dt = _highest_dt(startinpy)
        try:
            dt.insert(np.column_stack([x[order], y[order], z[order]]))
            p = np.asarray(dt.points)
            tri = np.asarray(dt.triangles, dtype=np.int64)
        finally:
            del dt  # see _highest_dt
        return p[:, 0], p[:, 1], p[:, 2], tri  # vertex 0 is startin's infinite vertex, unused
    from scipy.spatial import Delaunay

    tri = Delaunay(np.column_stack([x, y]))
    return x, y, z, tri.simplices.astype(np.int64)


def tiebreak(x, y, scale: float = 1e-5):
    """Tiny deterministic offsets (at most ``scale``/2 m) computed from each point's own map
    coordinates: they make exactly cocircular points (frequent on a 1 cm LAS lattice) generic,
    so the Delaunay triangulation, and the surface, of a tile equals that of the whole area."""
    bx = np.ascontiguousarray(x, np.float64).reshape(-1).view(np.uint64)
    by = np.ascontiguousarray(y, np.float64).reshape(-1).view(np.uint64)
    # a splitmix64 hash of the coordinates' bits (integer arithmetic: the compiled pass and
    # the numpy one give the same offsets; the sine hash it replaced spent 1.2 s of a 16 M
    # point chain reducing huge arguments)
    if _hash_nb is not None:
        jx, jy = np.empty(bx.size), np.empty(bx.size)
        _hash_nb(bx, by, float(scale), jx, jy)
        return jx, jy
    h1 = _mix(bx ^ _mix(by + _K0))
    h2 = _mix(h1 ^ _K1)
    return (scale * ((h1 >> _S11).astype(np.float64) * _UNIT - 0.5),
            scale * ((h2 >> _S11).astype(np.float64) * _UNIT - 0.5))


_K0, _K1 = np.uint64(0x632BE59BD9B4E019), np.uint64(0x9E3779B97F4A7C15)
_M1, _M2 = np.uint64(0xBF58476D1CE4E5B9), np.uint64(0x94D049BB133111EB)
_S11, _S27, _S30, _S31 = np.uint64(11), np.uint64(27), np.uint64(30), np.uint64(31)


def _mix(z):
    """splitmix64's finaliser (wrapping uint64 arithmetic)."""
    z = (z ^ (z >> _S30)) * _M1
    z = (z ^ (z >> _S27)) * _M2
    return z ^ (z >> _S31)


_UNIT = 2.0 ** -53


def _hash_py(bx, by, scale, jx, jy):
    """:func:`tiebreak`'s offsets point by point (the same operations)."""
    for i in range(bx.shape[0]):
        a = _mix(bx[i] ^ _mix(by[i] + _K0))
        b = _mix(a ^ _K1)
        jx[i] = scale * (float(a >> _S11) * _UNIT - 0.5)
        jy[i] = scale * (float(b >> _S11) * _UNIT - 0.5)


if _accel.HAVE_NUMBA:
    _mix = _accel._jit(_mix)
    _hash_nb = _accel._jit(_hash_py)
else:  # pragma: no cover
    _hash_nb = None


def tin_surface(x, y, z, spec: GridSpec, *, max_edge: float = 0.0, cells=None,
                out=None, max_radius: float = 0.0) -> np.ndarray:
    """Linear TIN of points ``(x, y, z)`` sampled at the cell centres of ``spec``.

    Parameters
    ----------
    x, y, z : (P,) ndarray of float
    spec : GridSpec
    max_edge : float
        Triangles with an edge longer than this (m) are left out; 0 keeps every triangle.
    cells : (M, N) ndarray of bool, optional
        Ignored (kept for callers): the rasteriser visits only the cells under each triangle.
    out : (M, N) ndarray of float, optional
        Draw into this grid, keeping the higher value in each cell (NaN = empty).
    max_radius : float
        Triangles whose circumcircle is wider than this radius (m) are left out (0: keep all).
        The kept triangles then depend only on the points within two radii, so a tile with that
        much buffer gets the same surface as the whole area.

    Returns
    -------
    (M, N) ndarray of float, NaN outside the triangulation and in dropped triangles.
    """
    from scipy.spatial import QhullError

    if out is None:
        out = np.full(spec.shape, np.nan)
    x, y, z = (np.asarray(a, np.float64) for a in (x, y, z))
    if x.size < 3:
        return out
    # triangulate in local coordinates (large UTM values lose precision)
    x0, y0 = float(x.min()), float(y.min())
    jx, jy = tiebreak(x, y)
    lx, ly = x - x0 + jx, y - y0 + jy
    if max_radius and max_radius > 0 and _accel.HAVE_NUMBA:  # compiled, drawn once built
        order = _morton_order(lx, ly)
        if _accel.layered_tin(lx[order], ly[order], z[order], [x.size], [float(max_edge)],
                              float(max_radius), spec.left - x0, spec.top - y0, spec.res,
                              spec.height, spec.width, out) >= 0:
            return out
    try:  # startinpy (else Qhull), drawn by the compiled rasteriser or its numpy twin
        px, py, pz, simp = triangulate(lx, ly, z)
    except (QhullError, ValueError, RuntimeError):
        return out
    if len(simp):
        _accel.raster_triangles(px, py, pz, np.ascontiguousarray(simp, np.int64),
                                float(max_edge), spec.left - x0, spec.top - y0, spec.res,
                                spec.height, spec.width, out, max_radius=float(max_radius or 0.0))
    return out


#: DTM triangles with a wider circumcircle are not used (cells there take the nearest point)
DTM_MAX_RADIUS = 10.0


def interpolate_tin(x, y, z, spec: GridSpec, *, max_radius: float = DTM_MAX_RADIUS,
                    where=None) -> np.ndarray:
    """Linear interpolation on the Delaunay triangulation of points, sampled at cell centres.

    Triangles whose circumcircle is wider than ``max_radius`` (m) are not used, so
    the surface at a cell depends only on the points within two radii (tiles agree with the
    whole); cells outside the triangles take the value of the nearest point. ``where``: the
    cells that need a value (default all): the others outside the triangles stay NaN (the
    nearest-point search was 1.7 s of a 16 M point chain, mostly for cells far from any data).
    """
    x, y, z = (np.asarray(a, float) for a in (x, y, z))
    if x.size < 3:
        if x.size == 0:
            raise InputError("no points to interpolate a surface from")
        return np.full(spec.shape, float(np.mean(z)))
    lin = tin_surface(x, y, z, spec, max_radius=max_radius)
    bad = np.isnan(lin)
    if where is not None:
        bad &= np.asarray(where, bool)
    if bad.any():  # outside the hull or under a wide triangle: the nearest point
        from scipy.spatial import cKDTree

        rows, cols = np.nonzero(bad)
        cx, cy = spec.xy(rows, cols)
        _, k = cKDTree(np.column_stack([x, y])).query(np.column_stack([cx, cy]))
        lin[rows, cols] = z[k]
    return lin
