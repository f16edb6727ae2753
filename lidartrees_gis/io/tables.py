"""Tables for people: the CSV a spreadsheet opens as its user expects, or an ``.xlsx``.

The dialect follows OGR's CSV driver's layer creation options given with ``-lco``
(``SEPARATOR=COMMA|SEMICOLON|TAB|SPACE``, ``WRITE_BOM=YES|NO``, and ``DECIMAL=POINT|COMMA``,
which OGR lacks), else the locale: with ``LC_ALL``, ``LC_NUMERIC`` or ``LANG`` (the first set)
in pt_BR, a semicolon, a decimal comma and UTF-8 with a BOM (what a pt-BR spreadsheet reads
into columns, numbers and accents); otherwise plain CSV (comma, point, UTF-8 without a BOM).
A file named ``.xlsx`` is written as a workbook (openpyxl). Numbers are written with the
decimals their column means (:func:`write_table`'s ``decimals``); ids given as ``text`` are
quoted (a CSV) or text cells (a workbook), so that a spreadsheet does not round them.
"""
from __future__ import annotations

import datetime
import math
import os
import re
from dataclasses import dataclass
from pathlib import Path

from ..errors import InputError

#: the ``-lco`` keys that set a table's dialect (OGR's CSV driver's names, plus DECIMAL)
TABLE_KEYS = ("SEPARATOR", "DECIMAL", "WRITE_BOM")

_SEPARATORS = {"COMMA": ",", "SEMICOLON": ";", "TAB": "\t", "SPACE": " "}
_DECIMALS = {"POINT": ".", "COMMA": ","}


def locale_name(environ=None) -> str:
    """The locale numbers are written for: the first of ``LC_ALL``, ``LC_NUMERIC``, ``LANG``
    that is set (POSIX's order), ``""`` when none is."""
    env = os.environ if environ is None else environ
    for var in ("LC_ALL", "LC_NUMERIC", "LANG"):
        if env.get(var):
            return str(env[var])
    return ""


def is_ptbr(environ=None) -> bool:
    """Whether the locale is Brazilian Portuguese (``pt_BR.UTF-8``, ``pt_BR``, ``pt-BR``)."""
    return locale_name(environ).lower().replace("-", "_").startswith("pt_br")


#: a number's decimal point, not one inside a name, a path or a version (``v_1.2.gpkg``, 0.21.1)
_DECIMAL_POINT = re.compile(r"(?<![\w./\\])(-?\d+)\.(\d+)(?![\w./\\])")


#: a planting spacing, ``3x1.5`` or ``3.5x2.5``, not inside a name
_SPACING = re.compile(r"(?<![\w./\\])(\d+(?:\.\d+)?)x(\d+(?:\.\d+)?)(?![\w./\\])")


def decimal_commas(text: str) -> str:
    """``text`` with each number's decimal point written as a comma (pt-BR: ``92,4 %
    (90,1-94,0)``, a spacing ``3,5x2,5``); names, paths and versions keep theirs."""
    text = _SPACING.sub(lambda m: m.group(0).replace(".", ","), text)
    return _DECIMAL_POINT.sub(r"\1,\2", text)


@dataclass(frozen=True)
class TableOptions:
    """How a CSV table is written.

    Attributes
    ----------
    separator : str
        Between fields: ``,``, ``;``, tab or space (``-lco SEPARATOR=``).
    decimal : str
        The decimal mark: ``.`` or ``,`` (``-lco DECIMAL=POINT|COMMA``).
    write_bom : bool
        Begin the file with UTF-8's byte order mark (``-lco WRITE_BOM=YES``), which tells a
        spreadsheet the text is UTF-8 (``Talhão``, not ``TalhÃ£o``).
    """

    separator: str = ","
    decimal: str = "."
    write_bom: bool = False

    def __post_init__(self):
        if self.separator not in _SEPARATORS.values():
            raise InputError(f"-lco SEPARATOR: {self.separator!r}: use COMMA, SEMICOLON, TAB or "
                             "SPACE")
        if self.decimal not in _DECIMALS.values():
            raise InputError(f"-lco DECIMAL: {self.decimal!r}: use POINT or COMMA")
        if self.separator == self.decimal:
            raise InputError("-lco: a decimal comma needs another separator (SEPARATOR="
                             "SEMICOLON)")

    @classmethod
    def from_options(cls, options: dict | None = None, environ=None) -> "TableOptions":
        """The options ``-lco`` gives (``{"SEPARATOR": "SEMICOLON", ...}``, other keys
        ignored) over the locale's defaults (pt_BR: ``;``, decimal comma, a BOM); a decimal
        comma asked for brings the BOM too unless ``WRITE_BOM=NO``."""
        base = dict(separator=";", decimal=",", write_bom=True) if is_ptbr(environ) else {}
        opts = {str(k).upper(): str(v).strip() for k, v in (options or {}).items()}
        if "SEPARATOR" in opts:
            v = opts["SEPARATOR"].upper()
            if v not in _SEPARATORS:
                raise InputError(f"-lco SEPARATOR={opts['SEPARATOR']}: use COMMA, SEMICOLON, "
                                 "TAB or SPACE")
            base["separator"] = _SEPARATORS[v]
            if "DECIMAL" not in opts and base["separator"] == ",":
                base["decimal"] = "."
        if "DECIMAL" in opts:
            v = opts["DECIMAL"].upper()
            if v not in _DECIMALS:
                raise InputError(f"-lco DECIMAL={opts['DECIMAL']}: use POINT or COMMA")
            base["decimal"] = _DECIMALS[v]
            if base["decimal"] == "," and base.get("separator", ",") == ",":
                if "SEPARATOR" in opts:
                    raise InputError("-lco DECIMAL=COMMA needs another separator than a comma "
                                     "(SEPARATOR=SEMICOLON)")
                base["separator"] = ";"
        if "WRITE_BOM" not in opts and base.get("decimal") == ",":
            # a decimal comma is a table for a pt-BR (or European) spreadsheet, which reads
            # UTF-8 without a BOM as Windows-1252 (São -> SÃ£o)
            base["write_bom"] = True
        if "WRITE_BOM" in opts:
            v = opts["WRITE_BOM"].upper()
            if v not in ("YES", "NO", "TRUE", "FALSE", "ON", "OFF", "1", "0"):
                raise InputError(f"-lco WRITE_BOM={opts['WRITE_BOM']}: use YES or NO")
            base["write_bom"] = v in ("YES", "TRUE", "ON", "1")
        return cls(**base)


def split_table_options(layer_options: dict | None) -> tuple:
    """``-lco`` split into the GeoPackage's options and the tables' (:data:`TABLE_KEYS`)."""
    gpkg, table = {}, {}
    for k, v in (layer_options or {}).items():
        (table if str(k).upper() in TABLE_KEYS else gpkg)[k] = v
    return gpkg, table


def _format(v, ndec, decimal: str) -> str:
    if v is None:
        return ""
    if isinstance(v, bool):
        return str(int(v))
    if hasattr(v, "item") and not isinstance(v, (str, bytes)):
        v = v.item()
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if not math.isfinite(v):
            return ""
        s = f"{v:.{ndec}f}" if ndec is not None else repr(round(v, 6))
        if s.endswith(".0") and ndec is None:
            s = s[:-2]
        return s.replace(".", decimal) if decimal != "." else s
    if isinstance(v, datetime.datetime):
        return v.date().isoformat() if v.time() == datetime.time(0) else v.isoformat()
    if isinstance(v, datetime.date):
        return v.isoformat()
    return str(v)


def _quote(s: str, sep: str, force: bool) -> str:
    if force or any(c in s for c in (sep, '"', "\n", "\r")):
        return '"' + s.replace('"', '""') + '"'
    return s


class TableWriter:
    """A table written row by row: CSV in the dialect of ``options``, or a workbook when
    ``path`` ends in ``.xlsx`` (kept in memory, saved on :meth:`close`).

    Parameters
    ----------
    path : str or Path
    columns : sequence of str
    decimals : dict, optional
        ``{column: decimals}`` for the float columns (others: up to 6 significant decimals).
    text : sequence of str, optional
        Columns written as text (ids): quoted in a CSV, text cells in a workbook.
    options : TableOptions, optional
        Default: :meth:`TableOptions.from_options` (the locale's).
    name : str
        The workbook's sheet name.
    """

    def __init__(self, path, columns, decimals=None, text=(), options=None, name="table"):
        self.path, self.columns = Path(path), list(columns)
        self.decimals, self.text = dict(decimals or {}), set(text)
        self.opts = options or TableOptions.from_options()
        self.xlsx = str(path).lower().endswith(".xlsx")
        if self.xlsx:
            try:
                import openpyxl
            except ImportError:
                raise InputError(f"{path}: an .xlsx table needs openpyxl (pip install openpyxl); "
                                 "or name the file .csv") from None
            self.book = openpyxl.Workbook()
            self.sheet = self.book.active
            self.sheet.title = name[:31]
            self.sheet.append(self.columns)
        else:
            enc = "utf-8-sig" if self.opts.write_bom else "utf-8"
            self.fh = open(self.path, "w", encoding=enc, newline="")
            sep = self.opts.separator
            self.fh.write(sep.join(_quote(c, sep, False) for c in self.columns) + "\r\n")

    def write(self, row) -> None:
        """One row: a dict (missing columns left empty) or a sequence in column order."""
        vals = [row.get(c) for c in self.columns] if isinstance(row, dict) else list(row)
        if self.xlsx:
            self.sheet.append([self._cell(c, v) for c, v in zip(self.columns, vals)])
            return
        sep, dec = self.opts.separator, self.opts.decimal
        self.fh.write(sep.join(_quote(_format(v, self.decimals.get(c), dec), sep,
                                      c in self.text and v is not None)
                               for c, v in zip(self.columns, vals)) + "\r\n")

    def _cell(self, col, v):
        if v is None:
            return None
        if hasattr(v, "item") and not isinstance(v, (str, bytes)):
            v = v.item()
        if col in self.text:
            return str(v)
        if isinstance(v, float):
            if not math.isfinite(v):
                return None
            n = self.decimals.get(col)
            return round(v, n) if n is not None else v
        return v

    def close(self) -> None:
        if self.xlsx:
            self.book.save(self.path)
        else:
            self.fh.close()


def write_table(path, rows, columns=None, decimals=None, text=(), options=None,
                name="table") -> None:
    """Write ``rows`` (dicts) as a table (see :class:`TableWriter`); ``columns`` default to
    every key in the order first met."""
    cols = list(columns) if columns is not None else list(dict.fromkeys(k for r in rows
                                                                          for k in r))
    w = TableWriter(path, cols, decimals, text, options, name)
    try:
        for r in rows:
            w.write(r)
    finally:
        w.close()
