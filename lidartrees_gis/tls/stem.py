"""Dmax trunk filter (Buck et al. 2014, seed 004): trunk points of a single tree, section by
section, and the diameters they give (DBH at 1.30 m, taper).

For each horizontal section of ``section`` metres from the base:

1. the section's points inside the search square (half-size ``search``) around the current
   centre are taken;
2. first section only: start at their centroid, find the centre that minimises the standard
   deviation of the distances (seed 004) and halve the mean distance; later sections start from
   the previous section's circle;
3. search points are placed on that circle every α = hspacing / r radians
   (x = xc + r sin α, y = yc + r cos α) and the nearest section point of each is selected
   (repeats counted);
4. a circle is fitted to the selected points, e(i) = [xc, yc, r];
5. Dmax loop: keep the section points closer to the centre than Dmax = r + 2s (s = standard
   deviation of the radial residuals), refit, repeat until s no longer changes;
6. the section is accepted when enough points remain, the arc covers at least
   ``min_coverage`` degrees, the residual spread is small (s <= ``max_spread`` r: rejects rings
   of ground or foliage) and the radius stays within ``max_jump`` of the previous one; a
   rejected section keeps the previous circle, and the trunk ends after ``max_gap`` rejected
   sections in a row (whorls, occlusion).

At 1.30 m the section's outline is measured too (:func:`outline_diameter`: the girth a tape
follows, the convex hull's perimeter / pi); when it is more than :data:`BUTTRESS_RATIO` times the
fitted circle's diameter, the section is not round (buttresses, flutes, a fork) and the result
says so: the Dmax circle then fits the inner core. A slice too sparse for the outline (fewer
than :data:`OUTLINE_MIN_SECTORS` of its sectors hold 3 points) has none, and the result's
``warning`` says the roundness was not checked.

The scan's spacings set the search points (``hspacing``) and the points a complete section
holds, ``2 pi r / hspacing x section / vspacing`` (``expected_points`` per section, and its
``completeness``); a section thinner than ``vspacing`` holds at most one scan line and is
refused.

Sections start ``start`` metres above the base (0.5 m: below it, ground, litter and root
collars spoil the circles). The base (``auto``) is the 0.1th percentile of the heights within the search square around the
stem, i.e. the local ground.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from ..bounds import check_fields
from ..errors import InputError
from ..progress import as_progress, check_cancel
from .circle import Circle, fit_circle, min_std_centre


@dataclass(frozen=True)
class DmaxParams:
    """Seed 004's parameters (metres) plus the acceptance rules of a section."""

    section: float = 0.05
    search: float = 0.5
    hspacing: float = 0.005
    vspacing: float = 0.010
    base: str = "auto"
    start: float = 0.5
    min_points: int = 8
    min_coverage: float = 60.0
    max_jump: float = 0.3
    max_spread: float = 0.15
    max_gap: int = 10
    max_iter: int = 50

    def __post_init__(self):
        check_fields(self, dict.fromkeys(("section", "search", "hspacing", "vspacing", "base",
                                          "start", "max_jump", "max_spread"), "m"))
        for name in ("section", "search", "hspacing", "vspacing"):
            v = getattr(self, name)
            if not (v > 0 and np.isfinite(v)):
                raise InputError(f"-{name} must be a number > 0 m, got {v}")
        if not (self.start >= 0 and np.isfinite(self.start)):
            raise InputError(f"-start must be a height >= 0 m above the base, got {self.start}")
        if self.hspacing > self.search:
            raise InputError(f"-hspacing {self.hspacing:g} m is wider than the search window "
                             f"-search {self.search:g} m")
        if self.section < self.vspacing:
            raise InputError(f"-section {self.section:g} m is thinner than the scan's vertical "
                             f"spacing -vspacing {self.vspacing:g} m: a section would hold at "
                             "most one scan line")

    def as_dict(self):
        return asdict(self)


def tree_base(z, base="auto") -> float:
    """Base height: a number, or ``auto`` = the 0.1th percentile of z (robust to low noise)."""
    if isinstance(base, (int, float)) or (isinstance(base, str) and base.strip() not in ("", "auto")):
        try:
            return float(base)
        except ValueError:
            raise InputError(f"-base: expected auto or a height, got {base!r}") from None
    return float(np.percentile(z, 0.1))


def dmax_loop(x, y, circ: Circle, max_iter=50):
    """Seed 004's Dmax loop on section points ``x, y``: returns (kept mask, final circle)."""
    keep = np.ones(x.size, bool)
    s_prev = None
    c = circ
    for _ in range(max_iter):
        d = np.hypot(x - c.xc, y - c.yc)
        keep = d < c.r + 2.0 * max(c.s, 1e-4)
        if keep.sum() < 3:
            return keep, None
        c2 = fit_circle(x[keep], y[keep], start=(c.xc, c.yc, c.r))
        if c2 is None:
            return keep, None
        c = c2
        if s_prev is not None and abs(c.s - s_prev) < 1e-5:
            break
        s_prev = c.s
    d = np.hypot(x - c.xc, y - c.yc)
    return d < c.r + 2.0 * max(c.s, 1e-4), c


#: outline (tape) diameter over the fitted circle's above which 1.30 m is not round
BUTTRESS_RATIO = 1.15


#: the outline's angular sectors, and how many must hold 3 points or more for it to be measured
#: (half the girth: a single scan sees about half of a stem)
OUTLINE_SECTORS, OUTLINE_MIN_SECTORS = 36, 18


def outline_diameter(x, y, centre, search: float, sectors: int = OUTLINE_SECTORS,
                     min_sectors: int = 3, with_sectors: bool = False):
    """Diameter a girth tape gives, robust to scan noise and strays: the section's points
    within ``search`` of ``centre`` (a square, the filter's search region) in ``sectors``
    angular sectors around the centre; in each sector of 3 points or more, the median distance
    to the centre; the perimeter of the convex hull of those sector points, over pi. A round
    stem gives its diameter; buttresses, flutes or a fork a larger one. NaN with fewer than
    ``min_sectors`` such sectors (and fewer than 3). With ``with_sectors``, returns
    ``(diameter, sectors measured, points in the square)``."""
    from scipy.spatial import ConvexHull, QhullError

    x, y = np.asarray(x, float), np.asarray(y, float)
    m = (np.abs(x - centre[0]) <= search) & (np.abs(y - centre[1]) <= search)
    dx, dy = x[m] - centre[0], y[m] - centre[1]
    d = np.hypot(dx, dy)
    k = np.minimum(((np.arctan2(dy, dx) + np.pi) / (2 * np.pi) * sectors).astype(int), sectors - 1)
    pts = []
    for i in range(sectors):
        di = d[k == i]
        if di.size >= 3:
            a = -np.pi + (i + 0.5) * 2 * np.pi / sectors
            pts.append((np.median(di) * np.cos(a), np.median(di) * np.sin(a)))
    out = float("nan")
    if len(pts) >= max(3, min_sectors):
        try:
            out = float(ConvexHull(np.asarray(pts)).area / np.pi)  # 2-D "area" is the perimeter
        except QhullError:
            pass
    return (out, len(pts), int(m.sum())) if with_sectors else out


def _stem_centre(x, y, z, p: DmaxParams) -> tuple:
    """The stem's position near the base: the median x, y of the points 0.5-2.0 m above it."""
    z0 = tree_base(z, "auto")
    m = (z - z0 >= 0.5) & (z - z0 <= 2.0)
    if m.sum() < p.min_points:
        m = z - z0 <= max(2.0, 0.2 * (z.max() - z0))
    return float(np.median(x[m])), float(np.median(y[m]))


def _fit_section(sx, sy, cur, p: DmaxParams, row: dict):
    """One section's circle (seed 004): search points every alpha on the previous circle (the
    first section: the min-std centre, radius halved), the nearest point to each, a circle fitted
    to those and the Dmax loop; when branches pull the fit away, the Dmax loop again from the
    last circle. Returns ``(kept points mask, Circle or None, accepted)``; ``row`` gets the
    selection counts."""
    from scipy.spatial import cKDTree

    if cur is None:
        xc, yc, r = min_std_centre(sx, sy, (sx.mean(), sy.mean()))
        start = Circle(xc, yc, r / 2.0, 0.0, 0.0, sx.size)
    else:
        start = cur
    n_s = max(8, int(np.ceil(2 * np.pi * start.r / p.hspacing)))
    alpha = np.arange(n_s) * (2 * np.pi / n_s)
    sp = np.c_[start.xc + start.r * np.sin(alpha), start.yc + start.r * np.cos(alpha)]
    _, nn = cKDTree(np.c_[sx, sy]).query(sp)
    sel = np.unique(nn)
    row.update(selected=int(sel.size), repeated=float(1 - sel.size / nn.size))
    e = fit_circle(sx[sel], sy[sel], start=(start.xc, start.yc, max(start.r, 1e-3)))
    keep, c = (None, None) if e is None else dmax_loop(sx, sy, e, p.max_iter)

    def accept(keep, c):
        good = c is not None and keep.sum() >= p.min_points and c.coverage >= p.min_coverage \
            and c.r < p.search and c.s <= p.max_spread * c.r
        if good and cur is not None:
            good = abs(c.r - cur.r) <= p.max_jump * cur.r
        return good

    if accept(keep, c):
        return keep, c, True
    if cur is not None:  # branches pulled the fit away: the Dmax loop from the last circle
        keep2, c2 = dmax_loop(sx, sy, Circle(cur.xc, cur.yc, cur.r, cur.s, 0.0, 0), p.max_iter)
        if accept(keep2, c2):
            return keep2, c2, True
    return keep, c, False


def dmax_filter(x, y, z, params: DmaxParams | None = None, *, centre=None, progress=None) -> dict:
    """Run the Dmax trunk filter on one tree.

    Parameters
    ----------
    x, y, z : (N,) ndarray of float
    params : DmaxParams
    centre : (float, float), optional
        Stem position near the base; default: median x, y of the points 0.5-2.0 m above the base.

    Returns
    -------
    dict with ``sections`` (list of dicts: section, z, xc, yc, r, diameter, s, points_in,
    points_kept, selected, repeated, coverage, converged), ``trunk_index`` (indices of kept
    points), ``trunk_section`` (their section ids), ``base``, ``tree_height``,
    ``reached_height``, ``dbh`` (m, NaN when not measured) and ``message``.
    """
    p = params or DmaxParams()
    x, y, z = (np.asarray(a, float) for a in (x, y, z))
    if x.size < p.min_points:
        raise InputError(f"stem: {x.size} points; too few for a trunk")
    if centre is None:
        centre = _stem_centre(x, y, z, p)
    near = (np.abs(x - centre[0]) <= p.search) & (np.abs(y - centre[1]) <= p.search)
    base = tree_base(z[near] if near.sum() >= p.min_points else z, p.base)
    zz = z - base
    height = float(zz.max())
    n_sections = int(np.ceil(height / p.section))
    sec_id = np.floor(zz / p.section).astype(np.int64)
    order = np.argsort(sec_id, kind="stable")
    bounds = np.searchsorted(sec_id[order], np.arange(n_sections + 1))
    prog = as_progress(progress)
    rows, trunk_idx, trunk_sec = [], [], []
    cur = None  # the last accepted circle
    cx, cy = centre
    gap = 0
    for i in range(int(p.start / p.section), n_sections):
        if i % 20 == 0:
            check_cancel(progress)
            prog.update(i / max(n_sections, 1), f"section {i + 1}/{n_sections}")
        idx = order[bounds[i]:bounds[i + 1]]
        idx = idx[(np.abs(x[idx] - cx) <= p.search) & (np.abs(y[idx] - cy) <= p.search)]
        row = {"section": i, "z": (i + 0.5) * p.section, "points_in": int(idx.size),
               "converged": False}
        keep, c, ok = None, None, False
        if idx.size >= p.min_points:
            keep, c, ok = _fit_section(x[idx], y[idx], cur, p, row)
        if c is not None:
            expected = 2 * np.pi * c.r / p.hspacing * max(1.0, p.section / p.vspacing)
            row.update(xc=c.xc, yc=c.yc, r=c.r, diameter=c.diameter, s=c.s, coverage=c.coverage,
                       points_kept=int(keep.sum()), converged=ok,
                       expected_points=int(round(expected)),
                       completeness=min(1.0, keep.sum() / max(expected, 1.0)))
        rows.append(row)
        if ok:
            trunk_idx.append(idx[keep])
            trunk_sec.append(np.full(int(keep.sum()), i, np.int64))
            cur, cx, cy, gap = c, c.xc, c.yc, 0
        elif cur is not None:
            gap += 1
            if gap >= p.max_gap:
                break
    prog.update(1.0, "done")
    conv = [r for r in rows if r["converged"]]
    reached = max((r["z"] + p.section / 2 for r in conv), default=0.0)
    near = [r["diameter"] for r in conv if abs(r["z"] - 1.30) <= 0.10]
    dbh = float(np.median(near)) if len(near) >= 2 else float("nan")
    msg = "" if conv else "no stem section could be fitted (check -base, -search and the input)"
    if conv and not np.isfinite(dbh):
        msg = "the trunk filter did not reach 1.30 m with at least two sections; no DBH"
    outline, warning = float("nan"), ""
    if np.isfinite(dbh):
        at = [r for r in conv if abs(r["z"] - 1.30) <= 0.10]
        ctr = (float(np.median([r["xc"] for r in at])), float(np.median([r["yc"] for r in at])))
        slab = np.abs(zz - 1.30) <= 0.05
        outline, n_sec, n_pts = outline_diameter(x[slab], y[slab], ctr, p.search,
                                                 min_sectors=OUTLINE_MIN_SECTORS, with_sectors=True)
        if not np.isfinite(outline):
            warning = (f"the slice at 1.30 m is too sparse for its outline ({n_pts} points, "
                       f"{n_sec} of {OUTLINE_SECTORS} sectors with 3 or more, "
                       f"{OUTLINE_MIN_SECTORS} needed): whether the stem is round there "
                       "(buttresses, flutes) is not checked")
        elif outline > BUTTRESS_RATIO * dbh:
            warning = (f"the section at 1.30 m is not round (buttresses, flutes or a fork?): "
                       f"its outline gives {100 * outline:.1f} cm (a girth tape), the Dmax "
                       f"circle {100 * dbh:.1f} cm (the inner core); measure above the "
                       "irregular part")
    return {"sections": rows, "trunk_index": np.concatenate(trunk_idx) if trunk_idx else np.empty(0, np.int64),
            "trunk_section": np.concatenate(trunk_sec) if trunk_sec else np.empty(0, np.int64),
            "base": base, "tree_height": height, "reached_height": reached,
            "reached_percent": 100.0 * reached / height if height > 0 else 0.0, "dbh": dbh,
            "dbh_outline": outline, "warning": warning, "message": msg, "params": p.as_dict()}
