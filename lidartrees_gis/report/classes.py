"""Round class limits for legends and scale bars (the quick look's CHM legend and the QGIS CHM
style use the same classes). Standard library only: the QGIS provider imports it."""
from __future__ import annotations

import math


def nice_step(span: float, classes: int = 6) -> float:
    """A round class width (1, 2 or 5 times a power of ten) that cuts ``span`` into the number
    of classes nearest to ``classes`` (the more classes on a tie): the CHM legends of the quick
    look and of the QGIS style. A 36 m CHM gets 5 m classes (8), a 27 m one 5 m classes (6)."""
    span = max(float(span), 1e-9)
    mag = 10.0 ** math.floor(math.log10(span / classes))
    cands = [m * mag * f for f in (0.1, 1.0, 10.0) for m in (1.0, 2.0, 5.0)]
    return float(min(cands, key=lambda st: (abs(math.ceil(span / st - 1e-9) - classes), st)))


def height_classes(top: float, classes: int = 6) -> list:
    """Upper limits of the CHM legend's classes: a round width (:func:`nice_step`) from 0 to
    just above ``top``, at least two classes (quick look, QGIS style)."""
    step = nice_step(max(float(top), 1.0), classes)
    n = max(2, math.ceil(float(top) / step - 1e-9))
    return [(i + 1) * step for i in range(n)]


def round_length(length: float) -> float:
    """The largest 1, 2 or 5 times a power of ten not above ``length`` (scale bars)."""
    length = max(float(length), 1e-9)
    mag = 10.0 ** math.floor(math.log10(length))
    return float(max(m * mag for m in (1.0, 2.0, 5.0) if m * mag <= length * (1 + 1e-9)))
