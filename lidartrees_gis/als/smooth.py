"""CHM smoothing of seed 000 (Castro 2006, §3.3.2.1, §3.5, §4.4): Gaussian masks and flat
grey-level morphology with cross, square and rhombus elements, and their composites.

NaN (nodata) never spreads into valid cells: the Gaussian is a normalised convolution over valid
cells only, erosion ignores NaN neighbours (as +inf) and dilation ignores them (as -inf); cells
that were NaN stay NaN.
"""
from __future__ import annotations

import re

import numpy as np
from scipy import ndimage

from ..errors import InputError

#: seed 000's fine Gaussian mask (sigma² = 0.6, 3 x 3), integer weights / 17
GAUSS_FINE = np.array([[1, 2, 1], [2, 5, 2], [1, 2, 1]], dtype=np.float64) / 17.0
#: seed 000's coarse Gaussian mask (sigma² = 2, 5 x 5), integer weights / 75
GAUSS_COARSE = np.array([[1, 2, 3, 2, 1], [2, 4, 5, 4, 2], [3, 5, 7, 5, 3], [2, 4, 5, 4, 2],
                         [1, 2, 3, 2, 1]], dtype=np.float64) / 75.0
#: default element sizes (cells across): cross and square 3 x 3, rhombus 5 x 5
DEFAULT_SIZE = {"cross": 3, "square": 3, "rhombus": 5}
#: the largest structuring element (cells across) and Gaussian sigma (cells): wider filters
#: are far larger than any crown (and an element of 999 cells ran for minutes)
MAX_ELEMENT = 51
MAX_SIGMA_CELLS = 50.0
COMPOSITES = ("erode", "dilate", "open", "close", "abefec", "fecabe", "fecabefec", "abefecabe")


def footprint(shape: str = "cross", size: int | None = None) -> np.ndarray:
    """Flat structuring element: ``cross`` (4-connected), ``square`` (8-connected) or
    ``rhombus`` (diamond), ``size`` cells across (odd; defaults 3, 3, 5).

    A cross of size 3 is the 4-neighbourhood plus centre; a cross of size 5 is the plus sign of
    arm length 2; a rhombus of size 5 is the diamond of radius 2.
    """
    if shape not in DEFAULT_SIZE:
        raise InputError(f"-smooth: unknown element {shape!r}; use cross, square or rhombus")
    size = DEFAULT_SIZE[shape] if size is None else int(size)
    if size < 1 or size % 2 == 0 or size > MAX_ELEMENT:
        raise InputError(f"-smooth: element size must be odd, >= 1 and <= {MAX_ELEMENT} cells, "
                         f"got {size}")
    r = size // 2
    yy, xx = np.mgrid[-r:r + 1, -r:r + 1]
    if shape == "square":
        return np.ones((size, size), dtype=bool)
    if shape == "cross":
        return (xx == 0) | (yy == 0)
    return (np.abs(xx) + np.abs(yy)) <= r


def gaussian_1d(sigma_cells: float) -> np.ndarray:
    """Normalised 1-D Gaussian of standard deviation ``sigma_cells``, radius 3 sigma (at least
    one cell): the 2-D kernel is its outer product with itself."""
    if not sigma_cells > 0:
        raise InputError(f"-smooth gauss:SIGMA needs SIGMA > 0, got {sigma_cells}")
    if sigma_cells > MAX_SIGMA_CELLS:
        raise InputError(f"-smooth gauss:SIGMA: {sigma_cells:g} cells is over {MAX_SIGMA_CELLS} "
                         "cells (SIGMA is in metres; a crown is a few metres across)")
    r = max(1, int(np.ceil(3 * sigma_cells)))
    x = np.arange(-r, r + 1)
    g = np.exp(-x ** 2 / (2 * sigma_cells ** 2))
    return g / g.sum()


def convolve_nan(image: np.ndarray, kernel) -> np.ndarray:
    """Convolution that ignores NaN cells (normalised by the weights of valid cells).

    ``kernel``: a 2-D array, or a 1-D array ``g`` for the separable kernel ``outer(g, g)``
    (a Gaussian: two 1-D passes per image, 3-4x faster than the 2-D pass at 0.5 m cells)."""
    img = np.asarray(image, dtype=np.float64)
    valid = ~np.isnan(img)
    k = np.asarray(kernel, dtype=np.float64)

    def conv(a):
        if k.ndim == 1:
            a = ndimage.correlate1d(a, k[::-1], axis=0, mode="constant", cval=0.0)
            return ndimage.correlate1d(a, k[::-1], axis=1, mode="constant", cval=0.0)
        return ndimage.convolve(a, k, mode="constant", cval=0.0)

    num = conv(np.where(valid, img, 0.0))
    den = conv(valid.astype(np.float64))
    with np.errstate(invalid="ignore", divide="ignore"):
        out = num / den
    out[~valid] = np.nan
    return out


def erosion(image, fp):
    """Grey-level erosion (local minimum over the flat element); NaN ignored and kept."""
    img = np.asarray(image, dtype=np.float64)
    nan = np.isnan(img)
    out = ndimage.grey_erosion(np.where(nan, np.inf, img), footprint=fp, mode="nearest")
    out[nan] = np.nan
    return out


def dilation(image, fp):
    """Grey-level dilation (local maximum over the flat element); NaN ignored and kept."""
    img = np.asarray(image, dtype=np.float64)
    nan = np.isnan(img)
    out = ndimage.grey_dilation(np.where(nan, -np.inf, img), footprint=fp, mode="nearest")
    out[nan] = np.nan
    return out


def opening(image, fp):
    """Erosion then dilation (removes bright details smaller than the element)."""
    return dilation(erosion(image, fp), fp)


def closing(image, fp):
    """Dilation then erosion (fills dark details smaller than the element)."""
    return erosion(dilation(image, fp), fp)


def abefec(image, fp):
    """Seed 000: abefec(f) = open(close(f))."""
    return opening(closing(image, fp), fp)


def fecabe(image, fp):
    """Seed 000: fecabe(f) = close(open(f))."""
    return closing(opening(image, fp), fp)


def fecabefec(image, fp):
    """Seed 000: fecabefec(f) = close(open(close(f)))."""
    return closing(opening(closing(image, fp), fp), fp)


def abefecabe(image, fp):
    """Seed 000: abefecabe(f) = open(close(open(f)))."""
    return opening(closing(opening(image, fp), fp), fp)


_OPS = {"erode": erosion, "dilate": dilation, "open": opening, "close": closing,
        "abefec": abefec, "fecabe": fecabe, "fecabefec": fecabefec, "abefecabe": abefecabe}


def smooth(chm: np.ndarray, spec: str = "none", *, res: float = 1.0) -> np.ndarray:
    """Smooth a CHM by a named filter.

    Parameters
    ----------
    chm : (M, N) ndarray of float
        NaN = nodata.
    spec : str
        ``none``; ``gauss3`` (seed 000 fine mask); ``gauss5`` (coarse mask); ``gauss:SIGMA``
        (SIGMA in metres); ``OP:ELEMENT[:SIZE]`` with OP in erode, dilate, open, close, abefec,
        fecabe, fecabefec, abefecabe and ELEMENT in cross, square, rhombus (SIZE cells across).
    res : float
        Cell size (m), used by ``gauss:SIGMA``.
    """
    s = (spec or "none").strip().lower()
    if s == "none":
        return np.asarray(chm, dtype=np.float64).copy()
    if s in ("gauss3", "fine"):
        return convolve_nan(chm, GAUSS_FINE)
    if s in ("gauss5", "coarse"):
        return convolve_nan(chm, GAUSS_COARSE)
    m = re.fullmatch(r"gauss:([0-9.]+)", s)
    if m:
        return convolve_nan(chm, gaussian_1d(float(m.group(1)) / res))
    m = re.fullmatch(r"([a-z]+):([a-z]+)(?::(\d+))?", s)
    if m and m.group(1) in _OPS:
        fp = footprint(m.group(2), int(m.group(3)) if m.group(3) else None)
        return _OPS[m.group(1)](chm, fp)
    raise InputError(f"-smooth: unknown filter {spec!r}; use none, gauss3, gauss5, gauss:SIGMA or "
                     f"OP:ELEMENT[:SIZE] with OP in {', '.join(_OPS)} and ELEMENT cross, square, rhombus")
