"""Coordinate reference systems: parsing user text, shorthands and reprojection reports.

Accepted CRS text (``-a_srs``, ``-s_srs``, ``-t_srs``):

* ``EPSG:29194``, ``29194``, WKT, PROJ strings, anything :func:`pyproj.CRS.from_user_input` reads;
* Brazilian shorthands: ``SAD69/UTM24S``, ``SIRGAS2000/UTM24S``, ``WGS84/UTM23S``, and the band
  style of the seeds, ``SAD69 24K`` (UTM zone 24, latitude band K, which is south of the equator).
"""
from __future__ import annotations

import re
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pyproj
from pyproj.transformer import TransformerGroup

from .errors import CRSError

_DATUMS = {
    "SAD69": "SAD69",
    "SAD-69": "SAD69",
    "SIRGAS2000": "SIRGAS 2000",
    "SIRGAS-2000": "SIRGAS 2000",
    "SIRGAS": "SIRGAS 2000",
    "WGS84": "WGS 84",
    "WGS-84": "WGS 84",
}
_SHORT = re.compile(
    r"^\s*(?P<datum>SAD[- ]?69|SIRGAS(?:[- ]?2000)?|WGS[- ]?84)\s*[/ ]\s*(?:UTM)?\s*(?:ZONE)?\s*"
    r"(?P<zone>\d{1,2})\s*(?P<hemi>[A-Z])\s*$",
    re.IGNORECASE,
)


def _utm_name(datum: str, zone: int, south: bool) -> str:
    return f"{datum} / UTM zone {zone}{'S' if south else 'N'}"


def parse_crs(text, *, param: str = "-a_srs") -> pyproj.CRS:
    """Parse a CRS given as text, EPSG code, shorthand or an existing CRS object.

    Parameters
    ----------
    text : str, int or pyproj.CRS
        ``EPSG:29194``, ``29194``, WKT, PROJ, ``SAD69/UTM24S`` or ``SAD69 24K``.
    param : str
        Name of the option the text came from, used in error messages.

    Returns
    -------
    pyproj.CRS

    Examples
    --------
    >>> parse_crs("SAD69 24K").to_epsg()
    29194
    >>> parse_crs("SIRGAS2000/UTM24S").to_epsg()
    31984
    """
    if isinstance(text, pyproj.CRS):
        return text
    if text is None or (isinstance(text, str) and not text.strip()):
        raise CRSError(f"{param}: empty CRS; give e.g. EPSG:29194 or SAD69/UTM24S")
    if hasattr(text, "to_wkt"):
        return pyproj.CRS.from_wkt(text.to_wkt())
    s = str(text).strip()
    if s.isdigit():
        s = f"EPSG:{s}"
    m = _SHORT.match(s)
    if m:
        key = m.group("datum").upper().replace("-", "").replace(" ", "")
        datum = _DATUMS.get(key) or _DATUMS["SIRGAS2000"]
        zone = int(m.group("zone"))
        hemi = m.group("hemi").upper()
        if hemi == "S":  # "S" means the southern hemisphere (not latitude band S)
            south = True
        elif hemi in "CDEFGHJKLM":  # latitude bands south of the equator
            south = True
        elif hemi in "NPQRSTUVWX":
            south = False
        else:
            raise CRSError(f"{param}: {text!r}: unknown hemisphere/band letter {hemi!r}")
        if not 1 <= zone <= 60:
            raise CRSError(f"{param}: {text!r}: UTM zone must be 1-60")
        name = _utm_name(datum, zone, south)
        found = pyproj.database.query_crs_info(auth_name="EPSG", pj_types="PROJECTED_CRS")
        for info in found:
            if info.name == name and not info.deprecated:
                return pyproj.CRS.from_epsg(int(info.code))
        raise CRSError(f"{param}: {text!r}: no EPSG CRS named {name!r}")
    try:
        return pyproj.CRS.from_user_input(s)
    except pyproj.exceptions.CRSError as exc:
        raise CRSError(
            f"{param}: cannot understand CRS {text!r} ({exc}); give an EPSG code such as "
            "EPSG:29194, WKT, a PROJ string or a shorthand such as SAD69/UTM24S"
        ) from None


def crs_from_sidecar(path) -> pyproj.CRS | None:
    """Read a CRS from a ``.prj`` file next to ``path`` (``pts.xyz.prj`` or ``pts.prj``)."""
    p = Path(path)
    for cand in (Path(str(p) + ".prj"), p.with_suffix(".prj")):
        if cand.exists():
            try:
                text = cand.read_text(encoding="utf-8-sig").strip()
            except (UnicodeDecodeError, OSError) as exc:
                raise CRSError(f"{cand}: the .prj beside the points is not a text CRS "
                               f"({type(exc).__name__}); fix it or give -a_srs") from None
            try:
                return pyproj.CRS.from_user_input(text)
            except pyproj.exceptions.CRSError as exc:
                raise CRSError(f"{cand}: not a readable CRS ({str(exc)[:160]}); fix it or give "
                               "-a_srs") from None
    return None


def crs_label(crs) -> str:
    """Short label such as ``EPSG:29194 (SAD69 / UTM zone 24S)``; ``none`` for no CRS."""
    if crs is None:
        return "none"
    epsg = crs.to_epsg()
    return f"EPSG:{epsg} ({crs.name})" if epsg else crs.name


@dataclass(frozen=True)
class Reprojection:
    """A coordinate operation chosen to reproject points, with what the user must know."""

    src: pyproj.CRS
    dst: pyproj.CRS
    transformer: pyproj.Transformer
    description: str
    accuracy: float | None
    note: str

    def __call__(self, x, y, z=None):
        if z is None:
            return self.transformer.transform(x, y)
        return self.transformer.transform(x, y, z)

    def report(self) -> str:
        acc = "unknown" if self.accuracy is None or self.accuracy < 0 else f"{self.accuracy:g} m"
        return f"{crs_label(self.src)} -> {crs_label(self.dst)}: {self.description} (accuracy {acc}){self.note}"


def reprojection(src, dst) -> Reprojection:
    """Choose the best available operation from ``src`` to ``dst`` and describe it.

    SAD69 -> SIRGAS 2000 without the IBGE grid (``br_ibge_SAD69_003.tif``) in the PROJ data
    directory uses the Helmert shift (stated accuracy 5 m); with the grid, the grid (about 1 m).
    The note says when a more accurate operation exists but its grid is missing.
    """
    src = parse_crs(src, param="-s_srs")
    dst = parse_crs(dst, param="-t_srs")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # missing grids are reported in the note
            group = TransformerGroup(src, dst, always_xy=True)
    except pyproj.exceptions.ProjError as exc:
        raise CRSError(f"no transformation from {crs_label(src)} to {crs_label(dst)}: {exc}") from None
    if not group.transformers:
        raise CRSError(f"no usable transformation from {crs_label(src)} to {crs_label(dst)}")
    tr = group.transformers[0]
    acc = tr.accuracy if tr.accuracy is not None and tr.accuracy >= 0 else None
    note = ""
    better = [op for op in group.unavailable_operations
              if op.accuracy is not None and op.accuracy >= 0 and (acc is None or op.accuracy < acc)]
    if better:
        grids = sorted({g.short_name for op in better for g in op.grids if not g.available})
        note = (f"; a more accurate operation ({better[0].name}, {better[0].accuracy:g} m) needs grid(s) "
                f"{', '.join(grids)} in the PROJ data directory ({pyproj.datadir.get_data_dir()})")
    return Reprojection(src, dst, tr, tr.description, acc, note)


def transform_points(x: np.ndarray, y: np.ndarray, repro: Reprojection):
    """Transform coordinate arrays with a :class:`Reprojection`; returns new arrays."""
    xx, yy = repro(np.asarray(x, float), np.asarray(y, float))
    return np.asarray(xx), np.asarray(yy)


def missing_crs_hint(x=None, y=None) -> str:
    """What to give for a file without a CRS, from one of its points ``(x, y)``: longitude and
    latitude are recognised; projected coordinates do not say their datum or UTM zone, so no
    zone is guessed (the delivery's metadata says it)."""
    try:
        x, y = float(x), float(y)
    except (TypeError, ValueError):
        x = y = float("nan")
    if abs(x) <= 180 and abs(y) <= 90:
        return ("its coordinates look like longitude/latitude: give e.g. -a_srs EPSG:4674 "
                "(SIRGAS 2000) or -a_srs EPSG:4326 (WGS 84)")
    if 100_000 <= x <= 900_000 and 0 <= y <= 10_000_000:
        return (f"its coordinates (x {x:.0f}, y {y:.0f}) look like UTM, whose datum and zone "
                "they do not say: give the delivery's with -a_srs, as an EPSG code (SIRGAS "
                "2000 / UTM zones 18S-25S are EPSG:31978-31985) or as 'SAD69 23K'")
    return "give the delivery's CRS with -a_srs (an EPSG code, WKT or 'SAD69 23K')"


def utm_hint(crs, x, y) -> str:
    """The projected CRS to suggest for points at ``(x, y)`` in ``crs``: the UTM zone they lie
    in, on SIRGAS 2000 where Brazil's zones are (17S-25S: EPSG:31977-31985), else WGS 84."""
    try:
        lon, lat = pyproj.Transformer.from_crs(crs, "EPSG:4326", always_xy=True).transform(
            float(x), float(y))
    except Exception:  # noqa: BLE001 - no suggestion then
        return "a projected CRS in metres (the UTM zone of the points)"
    if not (np.isfinite(lon) and np.isfinite(lat)):
        return "a projected CRS in metres (the UTM zone of the points)"
    zone = int(np.clip(np.floor((lon + 180.0) / 6.0) + 1, 1, 60))
    if lat < 0 and 17 <= zone <= 25:
        return f"EPSG:{31960 + zone} (SIRGAS 2000 / UTM {zone}S, where the points are)"
    code = (32700 if lat < 0 else 32600) + zone
    return f"EPSG:{code} (WGS 84 / UTM {zone}{'S' if lat < 0 else 'N'}, where the points are)"


#: how far (degrees) the points may lie outside a projected CRS's area of use before their
#: coordinates are taken for degrees mislabelled
AREA_OF_USE_MARGIN = 1.0
#: a projected CRS's points spanning at most this (its units) and within +-180 / +-90 may be
#: degrees (a degree is about 111 km: no acquisition spans more); wider local coordinates are not
DEGREE_SPAN = 1.0
#: points within this of (0, 0) are taken for a local frame (a scanner at the origin), not
#: degrees, whatever CRS they are labelled with
LOCAL_ORIGIN = 2.0


#: what a vector layer whose coordinates are not in its CRS needs (not the points' -a_srs)
LAYER_CRS_FIX = ("give the layer its true CRS (QGIS: Layer Properties > Source > Assigned "
                 "Coordinate Reference System, then save it; or ogr2ogr -a_srs)")


def check_coordinates(crs, bounds, where, *, given: bool = False, layer: bool = False) -> None:
    """Refuse coordinates that cannot be in ``crs``: a geographic CRS (degrees) with x beyond
    +-180 or y beyond +-90 (metres labelled e.g. EPSG:4326), or a projected CRS whose points
    all lie within +-180, +-90 and :data:`DEGREE_SPAN`, away from the origin (:data:`LOCAL_ORIGIN`), and, read in it, fall outside its area of use (longitude and
    latitude in degrees labelled e.g. UTM). ``bounds`` (xmin, ymin, xmax, ymax); ``where``
    names the file; ``given``: the CRS came from -a_srs; ``layer``: the bounds are a vector
    layer's, whose fix is its own CRS (:data:`LAYER_CRS_FIX`), not the points' -a_srs."""
    if crs is None or bounds is None:
        return
    x0, y0, x1, y1 = (float(v) for v in bounds)
    if not all(np.isfinite([x0, y0, x1, y1])):
        return
    label = crs_label(crs)
    source = "-a_srs" if given else "the file"
    what, fix = ("its features", LAYER_CRS_FIX) if layer else ("the points", None)
    extent = f"x {x0:,.2f}..{x1:,.2f}, y {y0:,.2f}..{y1:,.2f}"
    if crs.is_geographic:
        if max(abs(x0), abs(x1)) > 180.0 or max(abs(y0), abs(y1)) > 90.0:
            raise CRSError(
                f"{where}: coordinates cannot be in the declared CRS: {source} says "
                f"{label} (degrees) but {what} span {extent}, beyond longitude +-180 / "
                f"latitude +-90 (metres?); "
                + (fix or "give the delivery's projected CRS with -a_srs"))
        return
    if not crs.is_projected or max(abs(x0), abs(x1)) > 180.0 or max(abs(y0), abs(y1)) > 90.0 \
            or max(x1 - x0, y1 - y0) > DEGREE_SPAN or max(abs(x0), abs(y0)) < LOCAL_ORIGIN:
        return
    aou = crs.area_of_use
    if aou is None or aou.west > aou.east:  # none stated, or across the antimeridian
        return
    try:
        to_geo = pyproj.Transformer.from_crs(crs, crs.geodetic_crs, always_xy=True)
        lon, lat = to_geo.transform((x0 + x1) / 2, (y0 + y1) / 2, errcheck=True)
    except Exception:  # noqa: BLE001 - no inverse there: the point is not in the CRS's domain
        lon = lat = float("nan")
    m = AREA_OF_USE_MARGIN
    if (np.isfinite(lon) and np.isfinite(lat) and aou.west - m <= lon <= aou.east + m
            and aou.south - m <= lat <= aou.north + m):
        return
    raise CRSError(
        f"{where}: coordinates cannot be in the declared CRS: {source} says {label} "
        f"(metres) but {what} span {extent}, which read as metres lie outside its area of use "
        f"(they look like longitude/latitude in degrees); "
        + (fix or f"give -a_srs EPSG:4326 or EPSG:4674 and -t_srs {label.split()[0]}"))
