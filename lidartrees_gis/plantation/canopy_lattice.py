"""A planting lattice from the canopy heights' spectrum, where the tops of a closed canopy
show none (:func:`canopy_planting`, for :func:`lidartrees_gis.plantation.positions.fit_stand_grids`
with ``-spacing auto``)."""
from __future__ import annotations

import numpy as np

from .spectrum import MIN_PERIOD_CELLS, SPECTRAL_PERIODS, _spectral_guess
from .lattice import _sample, _spacing_along
from .stocking import fit_planting_grid


#: :func:`canopy_spectrum`'s polar grid: directions (0.5° steps) ...
CANOPY_THETAS = np.radians(np.arange(0.0, 180.0, 0.5))
#: ... and frequencies (cycles per metre) of the planting periods of :data:`SPECTRAL_PERIODS`
CANOPY_FREQS = np.arange(1.0 / SPECTRAL_PERIODS[1], 1.0 / SPECTRAL_PERIODS[0], 0.0025)
#: a canopy spectrum's first axis must beat what a canopy without rows reaches with this
#: chance; the second, searched only at right angles to the first (within 1°), this one (a
#: canopy without rows passes both with a chance below 1e-8)
CANOPY_CHANCE = (1e-6, 1e-2)
#: variations of the canopy height longer than this (m) are left out (stand edges, roads)
CANOPY_HIGHPASS = 10.0
#: the heights are tapered to 0 over about this (m) at the edges of the stand and the data
CANOPY_TAPER = 2.0


def canopy_spectrum(chm, res: float, mask=None) -> np.ndarray:
    """Power of the canopy heights' variations on the polar grid (:data:`CANOPY_THETAS` x
    :data:`CANOPY_FREQS`): direction ``theta`` (azimuth of the wave vector, clockwise from
    north) and frequency ``f``. The heights (NaN and the cells outside ``mask`` at their mean)
    lose their variations longer than :data:`CANOPY_HIGHPASS` and are tapered by a Hann
    window; tiles' spectra of one stand add up (an averaged periodogram).

    A planting lattice is periodic in the canopy even where the crowns close and the tops
    cannot be told apart: the row spacing across the rows, the plant spacing along them."""
    from scipy import ndimage

    a = np.asarray(chm, float)
    valid = np.isfinite(a) if mask is None else np.isfinite(a) & np.asarray(mask, bool)
    out = np.zeros((CANOPY_THETAS.size, CANOPY_FREQS.size))
    if valid.sum() < 64:
        return out
    fill = np.where(valid, a, float(a[valid].mean()))
    hp = fill - ndimage.gaussian_filter(fill, CANOPY_HIGHPASS / res, mode="nearest")
    hp = np.where(valid, hp - hp[valid].mean(), 0.0)
    H, W = hp.shape
    # tapered at the stand's (and the data's) edges too, over a few metres: a cut edge's steps
    # would spread their power over every frequency
    taper = ndimage.gaussian_filter(valid.astype(float), CANOPY_TAPER / res, mode="constant")
    hp *= np.where(valid, taper, 0.0) * np.outer(np.hanning(H), np.hanning(W))
    sh, sw = 2 * H, 2 * W
    power = np.fft.fftshift(np.abs(np.fft.fft2(hp, s=(sh, sw))) ** 2)
    T, F = np.meshgrid(CANOPY_THETAS, CANOPY_FREQS, indexing="ij")
    # a wave vector (east, north) = f (sin t, cos t); the grid's rows run southwards
    rows = sh // 2 - F * np.cos(T) * sh * res
    cols = sw // 2 + F * np.sin(T) * sw * res
    inside = (rows >= 0) & (rows <= sh - 1) & (cols >= 0) & (cols <= sw - 1)
    out[inside] = ndimage.map_coordinates(power, [rows[inside], cols[inside]], order=1)
    return out


def canopy_peaks(chm, spec, mask=None, min_height: float = 2.0) -> tuple:
    """``(x, y)`` of the canopy's local maxima (the highest cell of its 3 x 3, at least
    ``min_height``) within ``mask``: where a closed canopy's tops still lie along its rows
    when the heights' spectrum does not show them (:func:`peaks_lattice_guess`)."""
    from scipy import ndimage

    a = np.asarray(chm, float)
    b = np.where(np.isfinite(a), a, -np.inf)
    keep = (b == ndimage.maximum_filter(b, 3, mode="nearest")) & (b >= min_height)
    if mask is not None:
        keep &= np.asarray(mask, bool)
    r, c = np.nonzero(keep)
    x, y = spec.xy(r, c)
    return np.asarray(x, float), np.asarray(y, float)


#: a stand's canopy is read whole (:func:`canopy_crop`, :func:`stand_spectrum`) up to this many
#: cells (its bounding box: 100 ha at 0.5 m cells; its periodogram, padded to twice each side,
#: takes about 0.5 GB in the calling process); a larger one (an area without stands) as the
#: sum of its tiles' periodograms
CANOPY_MAX_CELLS = 4_000_000


def canopy_crop(chm, spec, mask):
    """The CHM cells of ``mask`` in their bounding box (NaN elsewhere), placed on the global
    grid of ``spec.res`` cells: ``(top row, left column, array)``, the rows counted down from
    ``y = 0`` and the columns from ``x = 0`` in cells; None for an empty mask. A stand's crops
    from its tiles' cores (disjoint) make its whole canopy (:func:`stand_spectrum`)."""
    m = np.asarray(mask, bool)
    if not m.any():
        return None
    r, c = np.nonzero(m)
    r0, r1, c0, c1 = int(r.min()), int(r.max()) + 1, int(c.min()), int(c.max()) + 1
    a = np.asarray(chm)[r0:r1, c0:c1]
    win = np.where(m[r0:r1, c0:c1], a, np.nan)
    top = int(round(spec.top / spec.res)) - r0
    left = int(round(spec.left / spec.res)) + c0
    return top, left, win


def _mosaic(crops) -> np.ndarray:
    """The crops (:func:`canopy_crop`) of a stand's tiles as one array over their bounding box
    (NaN where none holds a cell)."""
    top = max(t for t, _, _ in crops)
    left = min(c for _, c, _ in crops)
    bottom = min(t - w.shape[0] for t, _, w in crops)
    right = max(c + w.shape[1] for _, c, w in crops)
    out = np.full((top - bottom, right - left), np.nan)
    for t, c, w in crops:
        view = out[top - t:top - t + w.shape[0], c - left:c - left + w.shape[1]]
        np.copyto(view, w, where=np.isfinite(w))
    return out


def stand_spectrum(powers, peaks=None, res: float | None = None) -> dict:
    """The spectrum of a stand from its tiles' parts (each over the tile's core, disjoint):
    their crops of its canopy (:func:`canopy_crop`, tuples) made one (the spectrum of the
    stand's whole canopy, :func:`canopy_spectrum` with cells of ``res``: the same in any
    tiling, ``looks`` 1), or their :func:`canopy_spectrum` (arrays: ``power`` their sum and
    ``looks`` how many independent periodograms it averages, ``(sum m)² / sum m²`` of their
    median powers ``m``); ``peaks``: the tiles' :func:`canopy_peaks`, gathered (kept as
    ``peaks``)."""
    out = {}
    if peaks:
        out["peaks"] = tuple(np.concatenate([np.asarray(p[i], float) for p in peaks])
                             for i in (0, 1))
    crops = [p for p in powers if isinstance(p, tuple)]
    if crops:
        return {"power": canopy_spectrum(_mosaic(crops), res), "looks": 1.0, **out}
    powers = [np.asarray(p, float) for p in powers if p is not None and np.asarray(p).any()]
    if not powers:
        return {"power": np.zeros((CANOPY_THETAS.size, CANOPY_FREQS.size)), "looks": 1.0,
                **out}
    m = np.array([np.median(p[p > 0]) for p in powers])
    return {"power": np.sum(powers, axis=0), "looks": float(m.sum() ** 2 / (m ** 2).sum()),
            **out}


def _level(cells: int, chance: float, looks: float) -> float:
    """The ratio to the median that the largest of ``cells`` values reaches with ``chance``
    when each is the mean of ``looks`` independent periodogram values of a canopy without
    rows (a Gamma of shape ``looks``; 1: an exponential, ``log2(cells / chance)``)."""
    from scipy.stats import gamma

    return float(gamma.isf(chance / cells, looks) / gamma.median(looks))


def _first_axis(power, cell: float, looks: float):
    """The spectrum's powers over their median per frequency, the frequencies looked at, and
    the polar cell of the strongest peak when it passes :data:`CANOPY_CHANCE`'s first level;
    None when none does."""
    p = np.asarray(power, float)
    keep = CANOPY_FREQS <= 1.0 / max(SPECTRAL_PERIODS[0], MIN_PERIOD_CELLS * cell)
    if not keep.any() or not p.any():
        return None
    p = p[:, keep]
    med = np.median(p, axis=0)
    r = p / np.where(med > 0, med, np.inf)[None, :]
    i, j = np.unravel_index(int(np.argmax(r)), r.shape)
    if r[i, j] < _level(r.size, CANOPY_CHANCE[0], looks):
        return None
    return r, CANOPY_FREQS[keep], int(i), int(j)


#: :func:`canopy_rows_only` names rows at least this far apart (m): planting rows are 2.5-4 m
#: apart; a canopy's strongest period near 1 m (a natural forest's, across a flight line) is
#: not a row
CANOPY_ROW_MIN = 2.0


def canopy_rows_only(spectrum, cell: float = 0.0) -> str | None:
    """Why a stand's canopy gave no lattice when it shows its rows: the rows' spacing and
    direction in words (for the ``lattice`` field), or None when the canopy shows no row
    beyond chance either. The rows' wave vector is the spectrum's strongest peak
    (:func:`canopy_lattice_guess`'s first axis), at least :data:`CANOPY_ROW_MIN` long; no
    spacing along them is seen."""
    if not isinstance(spectrum, dict):
        spectrum = {"power": spectrum, "looks": 1.0}
    first = _first_axis(spectrum["power"], cell, spectrum.get("looks", 1.0))
    if first is None:
        return None
    _, freqs, i, j = first
    apart = 1.0 / float(freqs[j])
    if apart < CANOPY_ROW_MIN:
        return None
    rows = (float(np.degrees(CANOPY_THETAS[i])) + 90.0) % 180.0
    return (f"no planting lattice: the canopy shows rows {apart:.1f} m apart "
            f"at {rows:.0f}°, but no plant spacing along them (crowns merged): give the spacing, "
            "-spacing RxC")


#: :func:`canopy_rows` reads at most this square (m) of a canopy, its centre's
CANOPY_ROWS_SIDE = 150.0
#: :func:`canopy_rows_seen` reads squares of this side (m): a small square holds one
#: planting's rows (two at right angles to each other share a larger one's power) ...
CANOPY_ROWS_PART = 60.0
#: ... at most this many a side
CANOPY_ROWS_PARTS = 3
#: :func:`canopy_rows`' peak must also beat its direction's median over the row periods this
#: many times: a straight line (a road's edge, the seam between two files) puts power in one
#: direction at every frequency, planting rows at their period
CANOPY_ROWS_RIDGE = 8.0


def canopy_rows_seen(chm, res: float) -> list:
    """The planting rows (:func:`canopy_rows`) of a canopy and of squares of
    :data:`CANOPY_ROWS_PART` m spread over it (at most :data:`CANOPY_ROWS_PARTS` a side),
    those that show any: ``[(apart m, azimuth °), ...]``."""
    a = np.asarray(chm, float)
    n = max(8, int(round(CANOPY_ROWS_PART / res)))
    whole = canopy_rows(a, res)
    out = [] if whole is None else [whole]
    for r0 in np.unique(np.linspace(0, max(a.shape[0] - n, 0), CANOPY_ROWS_PARTS).astype(int)):
        for c0 in np.unique(np.linspace(0, max(a.shape[1] - n, 0),
                                        CANOPY_ROWS_PARTS).astype(int)):
            part = a[r0:r0 + n, c0:c0 + n]
            if np.isfinite(part).mean() >= 0.5:
                found = canopy_rows(part, res)
                if found is not None:
                    out.append(found)
    return out


def canopy_rows(chm, res: float):
    """The planting rows a canopy shows beyond chance, ``(apart m, azimuth °)``, or None: its
    spectrum's strongest peak among the periods of planting rows (:data:`CANOPY_ROW_MIN` to
    :data:`SPECTRAL_PERIODS`' longest), each frequency's powers over their median over the
    directions, beyond :data:`CANOPY_CHANCE`'s first level (as :func:`canopy_lattice_guess`
    reads its first axis) and :data:`CANOPY_ROWS_RIDGE` times its direction's median; at
    most the central :data:`CANOPY_ROWS_SIDE` metres are read."""
    a = np.asarray(chm, float)
    n = max(8, int(round(CANOPY_ROWS_SIDE / res)))
    r0, c0 = max(0, (a.shape[0] - n) // 2), max(0, (a.shape[1] - n) // 2)
    p = canopy_spectrum(a[r0:r0 + n, c0:c0 + n], res)
    keep = (CANOPY_FREQS >= 1.0 / SPECTRAL_PERIODS[1]) & (CANOPY_FREQS <= 1.0 / CANOPY_ROW_MIN)
    p = p[:, keep]
    if not p.any():
        return None
    med = np.median(p, axis=0)
    r = p / np.where(med > 0, med, np.inf)[None, :]
    i, j = np.unravel_index(int(np.argmax(r)), r.shape)
    if r[i, j] < _level(r.size, CANOPY_CHANCE[0], 1.0) \
            or r[i, j] < CANOPY_ROWS_RIDGE * np.median(r[i, :]):
        return None
    return 1.0 / float(CANOPY_FREQS[keep][j]), (float(np.degrees(CANOPY_THETAS[i])) + 90.0) % 180.0


def peaks_lattice_guess(peaks, cell: float = 0.0):
    """Row direction and spacings (as :func:`canopy_lattice_guess`) from the canopy's local
    maxima ``peaks`` (:func:`canopy_peaks`), for a closed canopy whose heights hardly dip
    between two tops of a row (the spectrum shows the rows only) and whose tops found merge
    neighbours: the maxima still lie along the rows at the plant spacing. Their projections'
    spectrum (:func:`~lidartrees_gis.plantation.spectrum._spectral_guess`) must be periodic
    on two axes at right angles beyond chance; None otherwise. The same maxima whether made
    whole or in tiles, so a run in tiles finds the same lattice."""
    px, py = (np.asarray(v, float) for v in peaks)
    if px.size < 10:
        return None
    return _spectral_guess(px - px.mean(), py - py.mean(), cell)


def canopy_lattice_guess(power, cell: float = 0.0, looks: float = 1.0):
    """Row direction (radians, as :func:`_spectral_guess`) and the periods across and along
    the rows from a :func:`canopy_spectrum` (summed over a stand's tiles), or None when the
    canopy is not periodic beyond chance on two axes at right angles.

    Each frequency's powers are divided by their median over the directions (a canopy without
    rows spreads its power evenly over them; a periodogram's values then fall off as
    ``exp(-r ln 2)``; the mean of ``looks`` of them, tiles of one stand, as a Gamma); the
    strongest peak must pass the level that the grid's
    directions x frequencies reach with chance :data:`CANOPY_CHANCE`'s first, the strongest at
    right angles to it (within 1°) the second's. ``cell``: periods shorter than
    :data:`MIN_PERIOD_CELLS` cells are not looked at."""
    first = _first_axis(power, cell, looks)
    if first is None:
        return None
    r, freqs, i, j = first
    n_t = CANOPY_THETAS.size
    perp = (i + n_t // 2 + np.arange(-2, 3)) % n_t
    sub = r[perp]
    level2 = _level(sub.size, CANOPY_CHANCE[1], looks)
    i2, j2 = np.unravel_index(int(np.argmax(sub)), sub.shape)
    if sub[i2, j2] < level2:
        return None

    def vector(t, k):  # a peak's wave vector (east, north), its frequency refined
        row = r[t]
        shift = 0.0
        if 0 < k < row.size - 1:
            a, b, c = row[k - 1], row[k], row[k + 1]
            den = a - 2 * b + c
            shift = float(np.clip(0.5 * (a - c) / den, -0.5, 0.5)) if den < 0 else 0.0
        f = freqs[k] + shift * (freqs[1] - freqs[0])
        return f * np.array([np.sin(CANOPY_THETAS[t]), np.cos(CANOPY_THETAS[t])])

    def peak_at(v):  # the polar cell of a wave vector, when it is a peak beyond chance
        v = v if v[1] > 0 or (v[1] == 0 and v[0] >= 0) else -v
        f = float(np.hypot(*v))
        if not freqs[0] <= f <= freqs[-1]:
            return None
        t = int(round(np.degrees(np.arctan2(v[0], v[1])) / 0.5)) % n_t
        k = int(round((f - freqs[0]) / (freqs[1] - freqs[0])))
        ts, ks = (t + np.arange(-1, 2)) % n_t, np.clip(k + np.arange(-1, 2), 0, freqs.size - 1)
        sub = r[np.ix_(ts, ks)]
        a, b = np.unravel_index(int(np.argmax(sub)), sub.shape)
        return (int(ts[a]), int(ks[b])) if sub[a, b] >= level3 else None

    # the strongest peaks may be a harmonic (crowns flat between their tops) or the lattice's
    # diagonals (a square lattice's at 45°, a finer lattice at right angles): halves, thirds
    # and half sums of the pair that are peaks too make the pair, until none is
    level3 = _level(6 * 9, CANOPY_CHANCE[1], looks)
    cells = [(int(i), int(j)), (int(perp[i2]), int(j2))]
    for _ in range(4):
        k1, k2 = vector(*cells[0]), vector(*cells[1])
        tries = ((k1 / 2, 0), (k1 / 3, 0), (k2 / 2, 1), (k2 / 3, 1))
        new = None
        for v, which in tries:
            c = peak_at(v)
            if c is not None:
                new = list(cells)
                new[which] = c
                break
        if new is None:
            c1, c2 = peak_at((k1 + k2) / 2), peak_at((k1 - k2) / 2)
            if c1 is not None and c2 is not None:
                new = [c1, c2]
        if new is None:
            break
        cells = new
    k1, k2 = vector(*cells[0]), vector(*cells[1])
    p1, p2 = 1.0 / float(np.hypot(*k1)), 1.0 / float(np.hypot(*k2))
    t1, t2 = float(CANOPY_THETAS[cells[0][0]]), float(CANOPY_THETAS[cells[1][0]])
    # the wave vector of the shorter period points along the rows
    if p2 <= p1:
        return t2 % np.pi, p1, p2
    return t1 % np.pi, p2, p1


#: :func:`canopy_planting` keeps a lattice when its ``N`` tops' fit reaches this over ``N``:
#: the mean resultant length ``r`` of ``N`` random phases exceeds ``t`` with chance
#: ``exp(-N t²)``; the fit is the product of the two axes' ``r`` (taken as one ``r²``), over
#: about a thousand azimuths and spacings tried, at a chance of one in a thousand
CANOPY_FIT_LEVEL = float(np.log(1e6))


#: :func:`canopy_planting` refines the spectrum's spacings within this share of them, on
#: multiples of ``PERIOD_STEP`` (m): the same candidates whatever the guess, so a stand's
#: tiles' spectrum and its whole canopy's give it the same lattice
PERIOD_REACH, PERIOD_STEP = 0.015, 0.0005


def canopy_planting(x, y, spectrum, cell: float = 0.0):
    """The planting lattice of a stand whose tops show none, from its canopy's spectrum
    (:func:`canopy_spectrum`): the direction and spacings of
    :func:`canopy_lattice_guess`, the lattice's offset (and the
    direction to 0.05°, within 1° of the spectrum's) fitted on the tops ``x, y`` (at least 10)
    by :func:`fit_planting_grid`. Where that gives none and ``spectrum`` holds the canopy's
    ``peaks`` (:func:`canopy_peaks`), the lattice comes from those
    (:func:`peaks_lattice_guess`: the spectrum may show the rows only) and is fitted on
    them. None when the canopy is not periodic beyond chance, or the tops do not gather on
    the lattice beyond chance (:data:`CANOPY_FIT_LEVEL`)."""
    if not isinstance(spectrum, dict):
        spectrum = {"power": spectrum, "looks": 1.0}
    looks = spectrum.get("looks", 1.0)
    guess = canopy_lattice_guess(spectrum["power"], cell, looks)
    g = None if guess is None else _fit_guess(x, y, guess)
    if g is None and spectrum.get("peaks") is not None:
        # the plants along the rows not in the heights, or the tops found (neighbours merged)
        # not on the lattice: the canopy's local maxima, the positions it is then fitted on
        px, py = (np.asarray(v, float) for v in spectrum["peaks"])
        o = np.lexsort((py, px))  # in an order of their own: tiles' peaks as the whole's
        px, py = px[o], py[o]
        guess = peaks_lattice_guess((px, py), cell)
        g = None if guess is None else _fit_guess(px, py, guess)
    return g


def _fit_guess(x, y, guess):
    """:func:`canopy_planting`'s lattice on the positions ``x, y`` (at least 10) from a
    spectral ``guess`` ``(azimuth, row, tree)``, or None when they do not gather on it beyond
    chance."""
    if np.asarray(x).size < 10:
        return None
    a, row, tree = guess
    x, y = np.asarray(x, float), np.asarray(y, float)
    sx, sy = _sample(x, y)
    dx, dy = sx - sx.mean(), sy - sy.mean()

    def periods(az):  # the spacings to 0.05 % on the tops along ``az`` (degrees): a period
        b = np.radians(az)  # 0.3 % off drifts 0.3 m over 100 m
        return (_spacing_along(dx * np.cos(b) - dy * np.sin(b), row,
                               PERIOD_REACH, PERIOD_STEP),
                _spacing_along(dx * np.sin(b) + dy * np.cos(b), tree,
                               PERIOD_REACH, PERIOD_STEP))

    # every step on fixed grids (the spectrum's 0.5° directions, multiples of PERIOD_STEP), so
    # the spectra of a stand's tiles and of its whole canopy lead to the same lattice
    az0 = round(float(np.degrees(a)) / 0.5) * 0.5
    g = fit_planting_grid(x, y, *periods(az0), azimuths=(az0 + np.arange(-1.0, 1.001, 0.25))
                          % 180.0)
    for _ in range(6):  # to the lattice that its own spacings and direction give again
        g2 = fit_planting_grid(x, y, *periods(g.azimuth),
                               azimuths=(g.azimuth + np.arange(-0.5, 0.501, 0.25)) % 180.0)
        if g2.fit <= g.fit or (g2.row_spacing, g2.tree_spacing, g2.azimuth) == \
                (g.row_spacing, g.tree_spacing, g.azimuth):
            break
        g = g2
    # the tops must still gather on it beyond chance (merged neighbours' tops lie between two
    # positions, so the fit is low, but not as low as random tops')
    return g if x.size * g.fit >= CANOPY_FIT_LEVEL else None
