"""Scan lines in the returns: a plant period the tops show that is the scanner's, not the
planting's.

A scanner lays its returns in lines across the flight, a fraction of a metre to a metre or so
apart, so the returns' density is a plane wave over a flight line: one wave vector ``k`` (and
its harmonics) for the whole line. The tops follow it where crowns are narrower than their
spacing (a crown's apex is sampled where a line crosses it), and along rows of azimuth ``a``
the lines then read as a period ``2 pi / |k . u|`` (``u`` the rows' direction), which may lie
among the plants' (1.2-3.5 m). The returns' density tells the two apart: a scan wave's
normalised amplitude ``|sum exp(i k . p)| / N`` is tens of times a planting's (the volume
generator's farms: 0.16-0.77 at the scan's wave vector, 0.005-0.053 at the plants'), so a plant
period that is a strong density wave's projection on the rows is taken for the scanner's
(:func:`scan_period`).
"""
from __future__ import annotations

import numpy as np

#: cell of the density grid (m): two cells a period at 0.25 m, so a line spacing's second
#: harmonic is seen from lines 0.5 m apart
SCAN_RES = 0.125
#: the periods looked at (m): scan lines 0.5-6 m apart, or so projected on the rows
SCAN_PERIODS = (0.5, 6.0)
#: a density wave is the scanner's from this normalised amplitude (the plants' crowns modulate
#: the density by 0.005-0.055 at their own wave vector over a stand of the volume generator's
#: farms, 0.11 in one tile of its young farm; its scan lines by 0.16-0.87)
SCAN_MIN_AMPLITUDE = 0.1
#: ... with its second harmonic reaching this amplitude (or being itself the second harmonic
#: of such a wave): a line of footprints is narrower than the gap between lines, a crown's
#: rise in density is as wide as the plants' spacing and smooth (the young farm's tile wave of
#: 0.11 along 3 m rows: its harmonic under this)
SCAN_HARMONIC_AMPLITUDE = 0.05
#: at most this many waves kept per window (the fundamental, its harmonics, a second flight)
SCAN_MAX_WAVES = 6
#: the side of the window read (m): scan lines run over a whole flight line, a window of this
#: size centred in a larger tile reads them as well and keeps the FFT small
SCAN_WINDOW = 128.0
#: a plant period within this share of a scan wave's projection on the rows is the scanner's
SCAN_REACH = 0.03
#: ... when the wave's own period is at least this share of it: lines much closer than the
#: plants cross every crown several times and its apex is found between them (the volume
#: generator's pulses 0.57 m apart along its lines, at 77° to 3 x 2.5 m rows, project on them
#: at 2.57 m; the tops do not follow them)
SCAN_MIN_SHARE = 0.5


def scan_waves(x, y, box=None, res: float = SCAN_RES) -> np.ndarray:
    """The scan lines' waves in the density of the returns ``x, y`` inside ``box``
    (``xmin, ymin, xmax, ymax``; default their bounds; its central :data:`SCAN_WINDOW` square at
    most): ``(M, 3)`` rows of ``kx, ky`` (radians per metre) and the normalised amplitude, the
    local peaks of the density's spectrum at periods of :data:`SCAN_PERIODS` reaching
    :data:`SCAN_MIN_AMPLITUDE` whose second harmonic reaches :data:`SCAN_HARMONIC_AMPLITUDE` or
    who are such a wave's second harmonic, strongest first (at most
    :data:`SCAN_MAX_WAVES`)."""
    from scipy.ndimage import maximum_filter

    x, y = np.asarray(x, float), np.asarray(y, float)
    none = np.empty((0, 3))
    if box is None:
        if x.size == 0:
            return none
        box = (x.min(), y.min(), x.max(), y.max())
    x0, y0, x1, y1 = (float(v) for v in box)
    cx, cy, h = (x0 + x1) / 2, (y0 + y1) / 2, SCAN_WINDOW / 2
    x0, x1 = max(x0, cx - h), min(x1, cx + h)
    y0, y1 = max(y0, cy - h), min(y1, cy + h)
    nx, ny = int((x1 - x0) / res), int((y1 - y0) / res)
    if nx < 8 or ny < 8:
        return none
    inside = (x >= x0) & (x < x0 + nx * res) & (y >= y0) & (y < y0 + ny * res)
    n = int(inside.sum())
    if n < 100:
        return none
    col = ((x[inside] - x0) / res).astype(np.int64)
    row = ((y[inside] - y0) / res).astype(np.int64)
    g = np.bincount(row * nx + col, minlength=nx * ny).reshape(ny, nx).astype(np.float64)
    amp = np.abs(np.fft.rfft2(g - g.mean())) / n
    fy = np.fft.fftfreq(ny, 1.0 / ny).astype(np.int64)  # each row's frequency index
    ky = 2 * np.pi * fy / (ny * res)
    kx = 2 * np.pi * np.arange(amp.shape[1]) / (nx * res)
    k = np.hypot(kx[None, :], ky[:, None])
    band = (k >= 2 * np.pi / SCAN_PERIODS[1]) & (k <= 2 * np.pi / SCAN_PERIODS[0])
    # the spectrum is periodic along ky: wrap it so a peak on the edge is a peak
    peak = (amp >= maximum_filter(amp, size=3, mode=("wrap", "nearest"))) & band & \
        (amp >= SCAN_MIN_AMPLITUDE)
    r, c = np.nonzero(peak)

    def near(fr, fc):  # the highest amplitude within a bin of frequency (fr, fc), 0 beyond
        best = 0.0
        for dr in (-1, 0, 1):
            for dc in (-1, 0, 1):
                a, b = fr + dr, fc + dc
                if b < 0:
                    a, b = -a, -b  # the half-plane's mirror
                if 0 <= b < amp.shape[1] and abs(a) < ny // 2:
                    best = max(best, float(amp[a % ny, b]))
        return best

    lines = [i for i in range(r.size)
             if near(2 * fy[r[i]], 2 * c[i]) >= SCAN_HARMONIC_AMPLITUDE
             or (fy[r[i]] % 2 == 0 and c[i] % 2 == 0
                 and near(fy[r[i]] // 2, c[i] // 2) >= SCAN_MIN_AMPLITUDE)]
    if not lines:
        return none
    r, c = r[lines], c[lines]
    order = np.argsort(-amp[r, c])[:SCAN_MAX_WAVES]
    r, c = r[order], c[order]
    return np.column_stack([kx[c], ky[r], amp[r, c]])


def merge_waves(parts) -> np.ndarray:
    """The waves of several windows (:func:`scan_waves`) as one list, strongest first, a wave
    within :data:`SCAN_REACH` of a stronger one's wave vector (or its opposite) left out."""
    parts = [np.asarray(p, float).reshape(-1, 3) for p in parts if p is not None and len(p)]
    if not parts:
        return np.empty((0, 3))
    w = np.concatenate(parts)
    w = w[np.argsort(-w[:, 2], kind="stable")]
    keep = []
    for row in w:
        k = np.hypot(row[0], row[1])
        if not any(min(np.hypot(*(row[:2] - q[:2])), np.hypot(*(row[:2] + q[:2])))
                   <= SCAN_REACH * k for q in keep):
            keep.append(row)
    return np.array(keep)


def along_rows(waves, azimuth: float) -> np.ndarray:
    """The periods (m) the scan ``waves`` show along rows of ``azimuth`` (degrees from north)."""
    w = np.asarray(waves, float).reshape(-1, 3)
    a = np.radians(azimuth)
    ku = np.abs(w[:, 0] * np.sin(a) + w[:, 1] * np.cos(a))
    with np.errstate(divide="ignore"):
        return np.where(ku > 0, 2 * np.pi / np.maximum(ku, 1e-12), np.inf)


def _matches(periods, azimuth: float, waves) -> np.ndarray:
    """For each plant period (m), the index of the first wave that is the scanner's at it along
    rows of ``azimuth`` (:func:`scan_period`'s rule), -1 where none is."""
    c = np.atleast_1d(np.asarray(periods, float))
    if waves is None or len(waves) == 0:
        return np.full(c.size, -1)
    w = np.asarray(waves, float).reshape(-1, 3)
    p = along_rows(w, azimuth)[None, :]
    own = (2 * np.pi / np.hypot(w[:, 0], w[:, 1]))[None, :]
    near = (np.abs(p - c[:, None]) <= SCAN_REACH * c[:, None]) & \
        (own >= SCAN_MIN_SHARE * c[:, None])
    return np.where(near.any(axis=1), near.argmax(axis=1), -1)


def scan_free(periods, azimuth: float, waves) -> np.ndarray:
    """Which of the plant ``periods`` (m) are not the scan lines' along rows of ``azimuth``
    (:func:`scan_period`), as a boolean array."""
    return _matches(periods, azimuth, waves) < 0


def scan_period(period: float, azimuth: float, waves) -> float | None:
    """The scan lines' period along rows of ``azimuth`` within :data:`SCAN_REACH` of the plant
    ``period`` (m), of a wave whose own period is :data:`SCAN_MIN_SHARE` of it at least, or
    None (no such wave; none given)."""
    k = int(_matches(period, azimuth, waves)[0])
    return None if k < 0 else float(along_rows(waves, azimuth)[k])
