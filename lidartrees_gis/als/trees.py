"""Tree detection and crown delineation on a CHM: the methods of seeds 000 and 001 behind one
call, :func:`detect_trees`. Parameters are in metres / m² and named as on the CLI.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from .tops import adaptive_maxima, local_maxima, treex_maxima, variable_window_maxima
from ..bounds import check_fields
from ..errors import InputError
from ..grid import GridSpec
from .metrics import tree_table
from .crowns import (keep_top_components, marker_watershed, region_growing, treex_growing,
    vincent_soille)
from .smooth import smooth as smooth_chm

METHODS = ("rg", "treex", "watershed", "mcws")
#: the methods whose papers work on the raw height model (seed 001's TreeX, seed 000's
#: watershed without smoothing): no smoothing unless ``smooth`` is given
RAW_METHODS = ("treex", "watershed")
TOPS = ("auto", "aw", "lm", "strict", "treex", "vwf")
#: -smooth auto: Gaussian sigma in crown scales (see :func:`resolve_auto`)
SIGMA_FACTOR = 0.1
#: adaptive window: default smallest distance between two tops, in CHM cells (1.3 m at 4 pts/m²)
SEPARATION_CELLS = 2.6
#: ... but at most this many crown scales (in-row trees of a 3 x 2 m stand are about 2.9 apart)
SEPARATION_CROWNS = 1.8
#: plantation mode (-spacing): at least this share of the smaller spacing (planted trees stand
#: a spacing apart; closer tops are one tree or a fork)
SEPARATION_PLANTED = 0.6


def parse_spacing(value):
    """``"3x2"`` (row spacing x spacing in the row, m) -> ``(3.0, 2.0)``; ``"auto"`` (found
    under the tops, per stand) stays ``"auto"``; None stays None."""
    if isinstance(value, str) and value.strip().lower() == "auto":
        return "auto"
    if value is None or value == "" or (isinstance(value, (tuple, list)) and len(value) == 2):
        return None if value in (None, "") else (float(value[0]), float(value[1]))
    import re

    text = str(value)
    if re.fullmatch(r"\s*[0-9]+,[0-9]+\s*", text):  # 3,2: 3 x 2 m, or 3.2 m in pt-BR
        raise InputError(f"-spacing {text}: ambiguous (3,2 reads as 3.2 in pt-BR); write the "
                         "rows and the trees in a row with an x: 3x2 (decimal commas allowed "
                         "there: 3,5x2,5)")
    if re.search(r"[xX*×]", text):  # 3,5x2,5: decimal commas beside the x
        text = text.replace(",", ".")
    m = re.fullmatch(r"\s*([0-9.]+)\s*[xX*×;]\s*([0-9.]+)\s*", text)
    try:
        if m:
            r, c = float(m.group(1)), float(m.group(2))
            if r > 0 and c > 0:
                return (r, c)
    except ValueError:
        pass
    raise InputError(f"-spacing: expected ROWSxTREES in metres, e.g. 3x2, or auto, got {value!r}")


@dataclass(frozen=True)
class TreeParams:
    """Parameters of tree detection (defaults: the seeds').

    Attributes
    ----------
    method : {"rg", "treex", "watershed", "mcws"}
        rg = Hyyppä/Castro region growing (seed 000 Annex 2); treex = TreeX priority growing
        (seed 001); watershed = Vincent–Soille on the inverted CHM (seed 000 Annex 1); mcws =
        marker-controlled watershed from the tops.
    smooth : str, optional
        ``auto``: a Gaussian whose sigma is ``SIGMA_FACTOR`` crown scales (none when that is
        under a third of a cell); or a CHM filter of :func:`lidartrees_gis.als.smooth.smooth`,
        e.g. none, gauss3, gauss5, abefec:rhombus (seed 000). Default (None): ``auto``, but
        ``none`` for the seed methods of :data:`RAW_METHODS` (``treex``, ``watershed``), whose
        papers work on the raw height model.
    min_height : float
        Minimum tree height, m (2 m, seed 000).
    step : float
        Region-growing threshold step ``ajuste``, m (0.1, seed 000 Annex 2).
    tops : {"auto", "aw", "lm", "strict", "treex", "vwf"}
        Tree-top finder for rg/mcws/treex: aw = adaptive window (crown scale x height, see
        :func:`lidartrees_gis.als.tops.adaptive_maxima`); lm = 8-neighbour local maxima, one per
        plateau (seed 000); strict = strictly higher than all 8 neighbours (seed 000's literal
        rule); treex = TreeX moving window (seed 001); vwf = window 0.1 h + 0.5 m; auto = treex
        for the treex method, aw with ``smooth="auto"``, else lm (the seeds' behaviour).
    mean_crown_area, sd_crown_area : float
        TreeX window parameters, m² (field data; defaults for 3 x 2 m clonal eucalyptus).
    max_crown_area : float
        TreeX maximum crown area, m².
    min_crown_height : float
        TreeX minimum crown height, m.
    connectivity : {4, 8}
        TreeX growth neighbourhood.
    spacing : str or (float, float), optional
        Planting spacing ``RxC`` (m), e.g. ``3x2``: plantation mode, the planting lattice, the
        stocking report and the planted trees' separation; the crown scale is still measured
        on the CHM (fixing it from the spacing gave false tops on the flanks of wide crowns).
        Runs with stands and no spacing take ``"auto"`` when :attr:`looks_for_lattice`
        (:func:`lidartrees_gis.als.chain.stands_plantation`).
    crown_scale : float, optional
        Crown scale (m) for ``auto``; default measured on the CHM
        (:func:`lidartrees_gis.als.chm.crown_scale`).
    window_factor : float
        Adaptive window radius for a tree of the dominant height, in crown scales.
    dominant_height : float, optional
        Dominant height (m) for the adaptive window; default the 95th percentile of the CHM's
        canopy heights (tiled runs measure it once for the whole area).
    min_separation : float, optional
        Adaptive window: smallest distance (m) between two tops; default ``SEPARATION_CELLS``
        cells (1.3 m at 0.5 m, the cell size of 4 pts/m²), at most ``SEPARATION_CROWNS`` crown
        scales (sparser data, where more cells would join trees of one row); in plantation mode at
        least ``SEPARATION_PLANTED`` x the smaller spacing (1.2 m at 3 x 2 m). 0 = no limit.
    treex_centred : bool
        TreeX: also require a top to be the highest of the window centred on it (drops one of
        two close trees; off as in the seed).
    treex_local : bool
        TreeX: also require a top to be a local maximum of its 8 neighbours (drops flank cells
        and trees that lose every window to a taller neighbour; off as in the seed).
    top_height : float, optional
        Region growing's ``altura_max`` (seed 000 Annex 2): the thresholds are ``top_height -
        k step``. Default the highest value of the smoothed CHM (as Annex 2); the tiles of an
        area take the area's (measured once by the plan).
    window_corner : (float, float), optional
        TreeX: the (x, y) corner where the search windows start, the upper-left corner of the
        area's grid (the image's first pixel, as seed 001 moves its window over the height
        model), set by the chains for every tile of an area; default the global grid's cell 0.
    planting : {"auto", "none"}, optional
        Without ``spacing``: ``auto`` (with stands: ``spacing="auto"``, each stand's lattice)
        looks for a planting lattice under the tops
        (:func:`lidartrees_gis.plantation.stocking.detect_planting`) and, when there is one, looks again
        at its empty positions for trees the tops finder missed (each tile on its own, with its
        buffer); ``none`` does not. Default (None): ``auto`` for the default method
        (:attr:`default_method`), ``none`` with a seed method or configuration, which then
        runs as its paper defines it.
    """

    method: str = "rg"
    smooth: str | None = None
    min_height: float = 2.0
    step: float = 0.1
    tops: str = "auto"
    mean_crown_area: float = 6.0
    sd_crown_area: float = 2.0
    max_crown_area: float = 16.0
    min_crown_height: float = 2.0
    connectivity: int = 4
    spacing: object = None
    crown_scale: float | None = None
    window_factor: float = 0.9
    treex_centred: bool = False
    treex_local: bool = False
    dominant_height: float | None = None
    min_separation: float | None = None
    top_height: float | None = None
    planting: str | None = None
    window_corner: tuple | None = None

    def __post_init__(self):
        check_fields(self, {**dict.fromkeys(("min_height", "step", "min_crown_height", "crown_scale",
                                             "dominant_height", "min_separation", "top_height"),
                                            "m"),
                            **dict.fromkeys(("mean_crown_area", "sd_crown_area",
                                             "max_crown_area"), "m²")})
        if self.method not in METHODS:
            raise InputError(f"-method: unknown method {self.method!r}; use {', '.join(METHODS)}")
        if self.smooth in (None, ""):  # the seed methods work on the raw surface
            object.__setattr__(self, "smooth", "none" if self.method in RAW_METHODS else "auto")
        if self.tops not in TOPS:
            raise InputError(f"-tops: unknown tree-top finder {self.tops!r}; use {', '.join(TOPS)}")
        if not np.isfinite(self.min_height):
            raise InputError("-min_height must be a number")
        if self.connectivity not in (4, 8):
            raise InputError(f"-connectivity must be 4 or 8, got {self.connectivity}")
        object.__setattr__(self, "spacing", parse_spacing(self.spacing))
        if self.crown_scale is not None and not (np.isfinite(self.crown_scale)
                                                 and 0 < self.crown_scale <= 50):
            raise InputError(f"-crown_scale must be > 0 and <= 50 (m), got {self.crown_scale}")
        if not (np.isfinite(self.window_factor) and 0 < self.window_factor <= 20):
            raise InputError(f"-window_factor must be > 0 and <= 20 (crown scales), got "
                             f"{self.window_factor}")
        if self.min_separation is not None and not (np.isfinite(self.min_separation)
                                                    and 0 <= self.min_separation <= 100):
            raise InputError(f"-min_separation must be >= 0 and <= 100 (m), got "
                             f"{self.min_separation}")
        if self.planting not in (None, "auto", "none"):
            raise InputError(f"-planting: expected auto or none, got {self.planting!r}")
        if not (np.isfinite(self.step) and self.step > 0):
            raise InputError(f"-step must be > 0 (m), got {self.step}")
        if str(self.smooth).strip().lower() != "auto":  # its name and size, before the run
            smooth_chm(np.zeros((1, 1)), self.smooth, res=1.0)

    def as_dict(self) -> dict:
        d = asdict(self)
        d["spacing"] = self.spacing if self.spacing in (None, "auto") else \
            f"{self.spacing[0]:g}x{self.spacing[1]:g}"
        return d

    @property
    def looks_at_planting(self) -> bool:
        """Whether the trees get a second look at the empty planting positions (``spacing``
        given, or :attr:`looks_for_lattice`): it needs the highest return of each cell."""
        return self.spacing is not None or self.looks_for_lattice

    @property
    def default_method(self) -> bool:
        """The defaults' method: region growing after the adaptive window on ``-smooth auto``
        (not one of the seeds' configurations)."""
        return self.method == "rg" and self.smooth == "auto" and self.tops in ("auto", "aw")

    @property
    def looks_for_lattice(self) -> bool:
        """Without ``spacing``: whether the tops' planting lattice is looked for (``planting``,
        by default only with the :attr:`default_method`)."""
        if self.planting is not None:
            return self.planting == "auto"
        return self.default_method

    @property
    def tops_finder(self) -> str:
        """The tree-top finder ``tops="auto"`` stands for."""
        if self.tops != "auto":
            return self.tops
        if self.method == "treex":
            return "treex"
        return "aw" if self.smooth == "auto" else "lm"


def resolve_auto(chm, res: float, p: TreeParams) -> dict:
    """What ``-smooth auto`` and the adaptive window use on this CHM.

    * crown scale L (m): ``p.crown_scale``, else measured on the CHM (also in plantation
      mode) (:func:`lidartrees_gis.als.chm.crown_scale`);
    * dominant height: 95th percentile of the canopy heights >= ``min_height``;
    * Gaussian sigma = ``SIGMA_FACTOR`` x L, applied when at least a third of a cell.
    """
    from .chm import crown_scale

    a = np.asarray(chm, np.float64)
    canopy = a[np.isfinite(a) & (a >= p.min_height)]
    if p.crown_scale is not None:
        L, src = float(p.crown_scale), "given"
    else:
        L, src = crown_scale(a, res, min_height=p.min_height), "measured"
        if not np.isfinite(L):
            L, src = 2.0 * res, "default (no canopy to measure)"
    if p.dominant_height is not None:
        hd = float(p.dominant_height)
    else:
        hd = float(np.percentile(canopy, 95)) if canopy.size else max(p.min_height, 1.0)
    smooth, sigma = auto_smoothing(L, res)
    return {"crown_scale": float(L), "crown_scale_source": src, "dominant_height": hd,
            "sigma": sigma, "smooth": smooth}


def auto_smoothing(crown_scale: float, res: float) -> tuple:
    """``-smooth auto``: ``(filter, sigma)``, a Gaussian of ``SIGMA_FACTOR`` crown scales
    (``gauss:SIGMA``), or ``none`` when that is under a third of a cell."""
    sigma = SIGMA_FACTOR * float(crown_scale)
    if sigma / res >= 1.0 / 3.0:
        return f"gauss:{sigma:.3f}", sigma
    return "none", 0.0


def find_tops(chm_s, res, p: TreeParams, auto: dict | None = None, origin=(0, 0)):
    """Tree tops on the smoothed CHM by ``p.tops`` (see :attr:`TreeParams.tops_finder`);
    ``origin``: the (row, column) of the CHM's upper-left cell in the global grid (TreeX's
    window positions)."""
    which = p.tops_finder
    if which == "treex":
        return treex_maxima(chm_s, res, mean_crown_area=p.mean_crown_area,
                            sd_crown_area=p.sd_crown_area, min_height=p.min_height,
                            centred=p.treex_centred, local=p.treex_local, origin=origin)
    if which == "vwf":
        return variable_window_maxima(chm_s, res, min_height=p.min_height)
    if which == "aw":
        auto = auto or resolve_auto(chm_s, res, p)
        sep = p.min_separation
        if sep is None:
            sep = min(SEPARATION_CELLS * res, SEPARATION_CROWNS * auto["crown_scale"])
            if isinstance(p.spacing, tuple):
                sep = max(sep, SEPARATION_PLANTED * min(p.spacing))
        return adaptive_maxima(chm_s, res, crown_scale=auto["crown_scale"],
                               dominant_height=auto["dominant_height"], min_height=p.min_height,
                               factor=p.window_factor, min_separation=sep)
    return local_maxima(chm_s, min_height=p.min_height, strict=(which == "strict"))


def _global_origin(spec) -> tuple:
    """(row, column) of the grid's upper-left cell in the global grid of its cells (row 0 at
    y = 0, rows growing southwards), (0, 0) for a grid off that lattice."""
    o = spec.origin_cells()
    if o is None:
        return (0, 0)
    col, bottom = o
    return (-int(bottom) - spec.height, int(col))


def window_origin(spec, p: TreeParams) -> tuple:
    """(row, column) of the grid's upper-left cell counted from where TreeX's windows start:
    :attr:`TreeParams.window_corner`, else the global grid's cell 0."""
    if p.window_corner is None:
        return _global_origin(spec)
    x0, y0 = p.window_corner
    return (int(round((y0 - spec.top) / spec.res)), int(round((spec.left - x0) / spec.res)))


def area_window_corner(area, res: float) -> tuple:
    """The upper-left corner (x, y) of an area's grid: a CHM raster's own, else the grid
    aligned to multiples of ``res`` that holds the area's extent (the CHM ``chm`` writes);
    TreeX's windows start there (:attr:`TreeParams.window_corner`)."""
    spec = getattr(area, "spec", None)
    if spec is None:
        spec = GridSpec.from_bounds(*area.extent, res)
    return (float(spec.left), float(spec.top))


def _watershed_tops(labels, chm_s, min_height):
    """Basins of the Vincent–Soille watershed to (labels 1..n, top rows, top cols): the top of a
    basin is its highest cell (first in row order on ties); basins lower than ``min_height`` and
    cells below it are dropped."""
    a = np.where(np.isnan(chm_s), -np.inf, chm_s)
    lab = np.where(a >= min_height, labels, 0)
    n = int(labels.max())
    if n == 0:
        return lab, np.empty(0, np.int64), np.empty(0, np.int64)
    flat = lab.ravel()
    idx = np.nonzero(flat)[0]
    # highest cell per basin: sort by (label, -height, index)
    o = np.lexsort((idx, -a.ravel()[idx], flat[idx]))
    sel = idx[o]
    first = np.ones(sel.size, bool)
    first[1:] = flat[sel][1:] != flat[sel][:-1]
    tops = sel[first]
    tops = np.sort(tops)
    rows, cols = np.divmod(tops, lab.shape[1])
    remap = np.zeros(n + 1, np.int64)
    remap[flat[tops]] = np.arange(1, tops.size + 1)
    return remap[lab], rows.astype(np.int64), cols.astype(np.int64)


def detect_trees(chm, spec: GridSpec, params: TreeParams | None = None, *, heights=None,
                 tops=None) -> dict:
    """Tree tops, crowns and per-tree measures on a CHM.

    Parameters
    ----------
    chm : (M, N) ndarray of float
        Canopy heights (m); NaN = nodata.
    spec : GridSpec
        Georeferencing of ``chm``.
    params : TreeParams
    heights : (M, N) ndarray of float, optional
        Where tree heights are read (highest value in the crown); default ``chm``. From points,
        the pit-free CHM or the highest return of the cell, whichever is higher. The adaptive
        window (``tops="aw"``) also finds the tops on it, smoothed as the CHM.
    tops : (rows, cols) of int, optional
        Grow the crowns from these tops (cells of the grid) instead of finding them (plantation
        mode adds the trees found at empty planting positions). The method's own growing is
        used; the watershed method grows marker-controlled basins from them.

    Returns
    -------
    dict with ``table`` (per-tree arrays, see :func:`lidartrees_gis.als.metrics.tree_table`),
    ``labels`` (crown label grid, crown ``i + 1`` belongs to row ``i`` of the table),
    ``smoothed`` (the filtered CHM) and ``params``.
    Every crown holds exactly its own top; heights come from the unsmoothed ``chm``.
    """
    p = params or TreeParams()
    # a raster CHM comes with itself as its heights: nothing more to smooth or search
    same = heights is None or heights is chm
    chm = np.asarray(chm, dtype=np.float64)
    auto = None
    if p.smooth == "auto" or p.tops_finder == "aw":
        auto = resolve_auto(chm, spec.res, p)
    smooth = auto["smooth"] if p.smooth == "auto" else p.smooth
    chm_s = smooth_chm(chm, smooth, res=spec.res)
    if tops is not None:
        rows, cols = (np.asarray(a, np.int64) for a in tops)
        labels = _grow(chm_s, rows, cols, spec.res, p)
    elif p.method == "watershed":
        labels, rows, cols = _watershed_tops(vincent_soille(chm_s), chm_s, p.min_height)
    else:
        surface = chm_s
        if not same and p.tops_finder == "aw":
            # the adaptive window looks for tops on the tree heights (the highest return where a
            # cell has one, else the CHM): in sparse data the CHM's triangles bridge from a
            # lower crown's apex to a taller neighbour and hide it
            hs = np.asarray(heights, np.float64)
            if hs.shape != chm.shape:
                raise InputError(f"heights: shape {hs.shape} differs from the CHM's {chm.shape}")
            surface = smooth_chm(hs, smooth, res=spec.res)
        rows, cols = find_tops(surface, spec.res, p, auto, origin=window_origin(spec, p))
        if surface is not chm_s:
            # a single return over low vegetation is no tree: the crown must reach min_height
            ok = np.nan_to_num(chm_s[rows, cols], nan=-np.inf) >= p.min_height
            rows, cols = rows[ok], cols[ok]
        labels = _grow(chm_s, rows, cols, spec.res, p)
    labels = keep_top_components(labels, rows, cols)
    table = tree_table(labels, rows, cols, chm if heights is None else heights, spec)
    table["method"] = np.array([crown_method(p, tops is not None)] * len(rows), dtype=object)
    return {"table": table, "labels": labels, "smoothed": chm_s, "params": p, "auto": auto,
            "tops": p.tops_finder if p.method != "watershed" else "watershed basins"}


def crown_method(p: TreeParams, given_tops: bool) -> str:
    """The method that really grew the crowns: ``p.method``, but ``mcws`` (a marker-controlled
    watershed) for the watershed method's crowns grown again from given tops (plantation mode's
    second look), since Vincent-Soille's basins are then not the crowns."""
    return "mcws" if given_tops and p.method == "watershed" else p.method


def _grow(chm_s, rows, cols, res: float, p: TreeParams):
    """Crowns grown from the tops by ``p.method`` (region growing, TreeX, else marker watershed)."""
    if p.method == "rg":
        return region_growing(chm_s, rows, cols, step=p.step, min_height=p.min_height,
                              top=p.top_height)
    if p.method == "treex":
        return treex_growing(chm_s, rows, cols, res, max_crown_area=p.max_crown_area,
                             min_crown_height=p.min_crown_height, connectivity=p.connectivity)
    return marker_watershed(chm_s, rows, cols, min_height=p.min_height)


