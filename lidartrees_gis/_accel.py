"""Optional numba acceleration for measured hot loops, with pure-numpy fallbacks.

``HAVE_NUMBA`` says whether the compiled kernels are used. Every kernel has a numpy twin with
the same results so the library also runs where numba is not installed (e.g. QGIS's Python).
"""
from __future__ import annotations

import os

import numpy as np

try:  # pragma: no cover - depends on the environment
    if os.environ.get("LIDARTREES_NO_NUMBA"):
        raise ImportError
    import numba

    HAVE_NUMBA = True
except ImportError:  # pragma: no cover
    numba = None
    HAVE_NUMBA = False


def _jit(fn):
    if HAVE_NUMBA:
        return numba.njit(cache=True, nogil=True)(fn)
    return None


def _accumulate_py(x, y, z, left, bottom, res, height, width, eps, count, mx, mn, sm):
    """One pass: cell index of every point, then count / max / min / sum per cell.

    Arrays ``count``, ``mx``, ``mn``, ``sm`` of length 0 are skipped. Returns the number of points that fall
    outside the grid.
    """
    outside = 0
    do_max = mx.shape[0] > 0
    do_min = mn.shape[0] > 0
    do_sum = sm.shape[0] > 0
    do_count = count.shape[0] > 0
    inv = 1.0 / res
    for i in range(x.shape[0]):
        fc = (x[i] - left) * inv + eps
        fr = (y[i] - bottom) * inv + eps
        if not (fc >= 0.0 and fr >= 0.0):
            outside += 1
            continue
        c = int(fc)
        r = height - 1 - int(fr)
        if c >= width or r < 0:
            outside += 1
            continue
        k = r * width + c
        v = z[i]
        if do_count:
            count[k] += 1
        if do_max and v > mx[k]:  # mx starts at -inf
            mx[k] = v
        if do_min and v < mn[k]:  # mn starts at +inf
            mn[k] = v
        if do_sum:
            sm[k] += v
    return outside


_accumulate_nb = _jit(_accumulate_py)


def accumulate(x, y, z, left, bottom, res, height, width, eps, count, mx, mn, sm) -> int:
    """Fused gridding kernel (numba only; callers use the numpy path when it is missing)."""
    return _accumulate_nb(x, y, z, left, bottom, res, height, width, eps, count, mx, mn, sm)
