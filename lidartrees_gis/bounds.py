"""The sizes a number option may take, checked in one place for the command line, QGIS and the
Python API: finite, and within gross limits past which numbers overflow or grids and kernels
exhaust memory. Each option's own check then says its useful range."""

from __future__ import annotations

import dataclasses
import math

from .errors import InputError

#: (largest, smallest other than 0) by unit. Metres: no size is over 10,000 km or under a
#: micrometre; an area is at most a million km²; a count or factor is at most a billion
NUMBER_BOUNDS = {"m": (1e7, 1e-6), "m²": (1e12, 1e-10), "": (1e9, 1e-9)}
#: options with limits of their own: -step's own check says how many passes a tiny step makes
NUMBER_LIMITS = {"step": (1e5, 1e-12)}
#: text options that take a number in metres or a word (auto, none)
NUMBER_OR_WORD = {"tile_size": "m", "base": "m"}
#: words a number-or-word option takes instead of a number
WORDS = ("auto", "none", "")


def check_number(flag: str, value, unit: str = "", name: str | None = None, *,
                 text_ok: bool = True) -> None:
    """Raise :class:`InputError` naming ``flag`` unless ``value`` is a finite number within
    :data:`NUMBER_BOUNDS` for ``unit`` (or 0). Words (auto, none) and ``None`` pass, and other
    text too when ``text_ok`` (a form the option parses itself, e.g. a range)."""
    if value is None or isinstance(value, bool):
        return
    text = str(value).strip()
    if text.lower() in WORDS:
        return
    try:
        f = float(text)
    except ValueError:
        if isinstance(value, str) and text_ok:
            return  # another form the option parses (e.g. a range); its own check reads it
        raise InputError(f"{flag}: expected a number, got {text!r}") from None
    if not math.isfinite(f):
        hint = "; give none for one tile" if name == "tile_size" else ""
        raise InputError(f"{flag}: expected a finite number, got {text!r}{hint}")
    hi, lo = NUMBER_LIMITS.get(name or flag.lstrip("-"),
                               NUMBER_BOUNDS.get(unit, NUMBER_BOUNDS[""]))
    if abs(f) > hi or 0 < abs(f) < lo:
        raise InputError(f"{flag}: {text!r} is out of range: give a size between {lo:g} and "
                         f"{hi:g}{' ' + unit if unit else ''} (or 0 where the option allows it)")


def check_fields(options, units: dict | None = None, skip=()) -> None:
    """Every number field of the dataclass ``options`` (and each number-or-word field of
    :data:`NUMBER_OR_WORD`) through :func:`check_number`, named as its CLI flag ``-<field>``;
    ``units`` maps field names to their unit (default: a count or factor)."""
    units = units or {}
    for f in dataclasses.fields(options):
        if f.name in skip or f.name.startswith("_"):
            continue
        v = getattr(options, f.name)
        if isinstance(v, str) and f.name not in NUMBER_OR_WORD:
            continue
        if isinstance(v, (int, float, str)):
            check_number(f"-{f.name}", v, units.get(f.name, NUMBER_OR_WORD.get(f.name, "")),
                         f.name)
