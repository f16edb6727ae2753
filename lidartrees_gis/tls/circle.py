"""Circle fitting for stem sections, robust to partial arcs (single-scan data)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Circle:
    """A fitted circle: centre, radius, std of the radial residuals, arc coverage (degrees)."""

    xc: float
    yc: float
    r: float
    s: float
    coverage: float
    n: int

    @property
    def diameter(self) -> float:
        return 2.0 * self.r


def arc_coverage(x, y, xc, yc) -> float:
    """Degrees of the circle covered by points: 360 minus the largest angular gap."""
    if len(x) < 2:
        return 0.0
    a = np.sort(np.degrees(np.arctan2(np.asarray(y) - yc, np.asarray(x) - xc)))
    gaps = np.diff(np.concatenate([a, [a[0] + 360.0]]))
    return float(360.0 - gaps.max())


def kasa_fit(x, y):
    """Algebraic (Kåsa) circle fit: (xc, yc, r). Fast, biased on short arcs; a start value."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    mx, my = x.mean(), y.mean()
    u, v = x - mx, y - my
    A = np.c_[u, v, np.ones_like(u)]
    b = u ** 2 + v ** 2
    sol, *_ = np.linalg.lstsq(A, b, rcond=None)
    a0, b0 = sol[0] / 2, sol[1] / 2
    r = np.sqrt(max(sol[2] + a0 ** 2 + b0 ** 2, 0.0))
    return a0 + mx, b0 + my, r


def fit_circle(x, y, start=None) -> Circle | None:
    """Geometric least-squares circle (minimises Σ(dist - r)²), started from ``start`` or the
    Kåsa fit; works on partial arcs. None when fewer than 3 points or the fit fails."""
    from scipy.optimize import least_squares

    x, y = np.asarray(x, float), np.asarray(y, float)
    if x.size < 3:
        return None
    x0 = start if start is not None else kasa_fit(x, y)

    def res(p):
        return np.hypot(x - p[0], y - p[1]) - p[2]

    try:
        sol = least_squares(res, np.asarray(x0, float), method="lm")
    except (ValueError, np.linalg.LinAlgError):
        return None
    xc, yc, r = sol.x
    if not np.isfinite(sol.x).all() or r <= 0:
        return None
    d = np.hypot(x - xc, y - yc) - r
    return Circle(float(xc), float(yc), float(abs(r)), float(d.std()), arc_coverage(x, y, xc, yc),
                  int(x.size))


def min_std_centre(x, y, start):
    """Seed 004's first-section centre: the point minimising the standard deviation of the
    distances to the section points (Nelder-Mead from ``start``). Returns (xc, yc, mean dist)."""
    from scipy.optimize import minimize

    x, y = np.asarray(x, float), np.asarray(y, float)
    sol = minimize(lambda p: np.hypot(x - p[0], y - p[1]).std(), np.asarray(start, float),
                   method="Nelder-Mead", options={"xatol": 1e-5, "fatol": 1e-7, "maxiter": 2000})
    xc, yc = sol.x
    return float(xc), float(yc), float(np.hypot(x - xc, y - yc).mean())
