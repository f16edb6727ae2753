"""XYZ text: the dialect (delimiter, decimal comma, header, columns) detected from the first
lines, and the points read block by block, with the file, line and text of a bad line."""
from __future__ import annotations

import gzip
import io
import re
import warnings
import zlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError, LidarTreesError, ReadError
from ..progress import as_progress, check_cancel
from .chunk import PointChunk
from .names import POINT_COLUMNS, match_column, normalise


_INT_TOKEN = re.compile(r"^[+-]?[0-9]+$")


#: a plain ASCII decimal number (what the XYZ readers accept)
_ASCII_NUMBER = re.compile(r"[+-]?(?:(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?|nan|inf|infinity)\Z",
                           re.IGNORECASE)


#: names accepted in an XYZ header or ``columns=`` for each attribute (English and Portuguese;
#: compared without case or accents, see :mod:`lidartrees_gis.io.names`)
COLUMN_ALIASES = POINT_COLUMNS


_ATTR_DTYPES = {"intensity": np.uint16, "return_number": np.uint8,
                "number_of_returns": np.uint8, "classification": np.uint8}


@dataclass
class XYZDialect:
    """How an XYZ text file is written."""

    delimiter: str | None  # None = runs of white space
    decimal_comma: bool
    header: bool
    columns: tuple  # attribute name per column, or None for ignored columns
    thousands: bool = False  # '.' groups thousands (pt-BR: 412.955,63 = 412955.63)
    encoding: str = "utf-8-sig"  # detected: utf-8-sig (with or without BOM), cp1252, latin-1

    def describe(self) -> str:
        d = {None: "whitespace", "\t": "tab", ",": "comma", ";": "semicolon", " ": "space"}.get(
            self.delimiter, repr(self.delimiter))
        cols = ",".join(c or "-" for c in self.columns)
        return (f"delimiter={d} decimal={'comma' if self.decimal_comma else 'point'} "
                f"header={self.header} columns={cols} encoding={self.encoding}")


def _is_gzip(path: Path) -> bool:
    with open(path, "rb") as fh:
        return fh.read(2) == b"\x1f\x8b"


def detect_encoding(path, sample_bytes: int = 1 << 16) -> str:
    """The text encoding of a (possibly gzip-compressed) text file, from its first bytes:
    ``utf-8-sig`` (UTF-8 with or without a BOM, and plain ASCII), else ``cp1252`` (Windows
    exports: ``Elevação`` as one byte per letter), else ``latin-1`` (bytes cp1252 leaves
    undefined). A UTF-8 character cut at the end of the sample is not held against UTF-8."""
    path = Path(path)
    opener = gzip.open if _is_gzip(path) else open
    with opener(path, "rb") as fh:
        raw = fh.read(sample_bytes)
    try:
        raw.decode("utf-8-sig")
        return "utf-8-sig"
    except UnicodeDecodeError as exc:
        if exc.start >= len(raw) - 3 and len(raw) == sample_bytes:
            try:
                raw[:exc.start].decode("utf-8-sig")
                return "utf-8-sig"
            except UnicodeDecodeError:
                pass
    try:
        raw.decode("cp1252")
        return "cp1252"
    except UnicodeDecodeError:
        return "latin-1"


def _open_text(path: Path, encoding: str = "utf-8-sig"):
    if _is_gzip(path):
        return gzip.open(path, "rt", encoding=encoding, errors="replace", newline=None)
    return open(path, "r", encoding=encoding, errors="replace", newline=None)  # BOM dropped


_DELIMS = {"tab": "\t", "\\t": "\t", "\t": "\t", "space": None, "whitespace": None, " ": None,
           "comma": ",", ",": ",", "semicolon": ";", ";": ";", "pipe": "|", "|": "|"}


def _split(line: str, delimiter):
    return line.split(delimiter) if delimiter is not None else line.split()


def _is_number(tok: str, decimal_comma: bool) -> bool:
    t = tok.strip()
    if decimal_comma:
        if _THOUSANDS.match(t):  # 412.955,63
            return True
        t = t.replace(",", ".")
    try:
        float(t)
        return True
    except ValueError:
        return False


def parse_columns(spec, ncols: int | None = None) -> tuple:
    """Map a column list (``"x,y,z,intensity,-,classification"``) to attribute names."""
    if isinstance(spec, str):
        spec = [s.strip() for s in re.split(r"[,\s]+", spec.strip()) if s.strip()]
    out = []
    for i, name in enumerate(spec):
        key = name.strip().lower()
        if key in ("-", "_", "skip", "none", ""):
            out.append(None)
            continue
        attr = match_column(name, COLUMN_ALIASES)
        if attr is not None and attr in out:
            raise InputError(f"columns: {attr!r} given twice in {spec!r}")
        out.append(attr)  # an unknown column (None) is kept out
    for need in ("x", "y", "z"):
        if need not in out:
            raise InputError(f"columns: no {need!r} column in {list(spec)!r}; "
                             "give e.g. --columns x,y,z,intensity")
    return tuple(out)


def _warn_comma_pairs(path, lines) -> None:
    """Warn when a comma-delimited file looks like decimal commas written with comma delimiters
    (``412955,63,7952505,99,25,46``): every field an integer, and either the field count varies
    between lines, or short integers (the decimals) follow long ones in columns 1 and 3."""
    rows = [[t.strip() for t in ln.split(",")] for ln in lines]
    data = [r for r in rows if r and all(_INT_TOKEN.match(t) for t in r)]
    if len(data) < max(1, len(rows) - 1):
        return
    counts = {len(r) for r in data}
    digits = lambda t: len(t.lstrip("+-"))  # noqa: E731
    pairs = [r for r in data if len(r) >= 6 and len(r) % 2 == 0 and digits(r[0]) >= 5
             and digits(r[1]) <= 4 and digits(r[3]) <= 4 and digits(r[2]) > digits(r[3])]
    if len(counts) == 1 and len(pairs) < len(data):
        return
    from ..errors import DataWarning

    r = data[0]
    looks = len(pairs) if len(counts) == 1 else sum(len(x) != len(data[0]) for x in data) + 1
    warnings.warn(DataWarning(
        f"{path}: {looks:,} of the first {len(rows):,} lines look like decimal commas written "
        f"with comma delimiters ({lines[-1][:60]!r}); they are read as x={r[0]}, y={r[1]}, "
        f"z={r[2]}. Re-export with tabs or semicolons between the fields (both are read with "
        "decimal commas), or name the columns with --columns if this is right"), stacklevel=2)


def sniff_xyz(path, *, delimiter=None, decimal_comma=None, header=None, columns=None,
              sample_lines: int = 50) -> XYZDialect:
    """Detect an XYZ file's delimiter, decimal mark, header and columns.

    Rules: a tab, then a semicolon, then white space, then a comma is the delimiter (the first
    one found in every sampled line). With a tab, semicolon or white-space delimiter, a comma
    inside numbers means a decimal comma (``412955,63<TAB>7952505,99<TAB>25,4654``). A first line
    that is not all numbers is a header whose names map columns (x, y, z, intensity,
    classification, return_number, number_of_returns). Every detected choice can be forced.
    """
    path = Path(path)
    lines = []
    try:
        encoding = detect_encoding(path)
        with _open_text(path, encoding) as fh:
            for line in fh:
                s = line.strip()
                if not s or s.startswith("#"):
                    continue
                lines.append(s)
                if len(lines) >= sample_lines:
                    break
    except (EOFError, OSError, zlib.error, UnicodeError) as exc:
        raise ReadError(f"{path}: cannot read the text, the file is truncated or corrupt "
                        f"({type(exc).__name__}: {str(exc)[:120]})") from None
    if not lines:
        raise InputError(f"{path}: no points (the file is empty or holds only comments)")
    if delimiter is not None:
        if delimiter not in _DELIMS and len(delimiter) != 1:
            raise InputError(f"--delimiter: unknown delimiter {delimiter!r}; use tab, space, comma, "
                             "semicolon or one character")
        delim = _DELIMS.get(delimiter, delimiter)
    else:
        data = lines[1:] or lines
        if all("\t" in ln for ln in data):
            delim = "\t"
        elif all(";" in ln for ln in data):
            delim = ";"
        elif all(re.search(r"\S\s+\S", ln) for ln in data):
            delim = None
        elif all("," in ln for ln in data):
            delim = ","
        else:
            delim = None
    data_line = lines[1] if len(lines) > 1 else lines[0]
    if decimal_comma is None:
        num_comma = re.compile(r"^[+-]?\d*,\d+([eE][+-]?\d+)?$")
        decimal_comma = delim != "," and any(num_comma.match(t.strip())
                                             for ln in lines for t in _split(ln, delim))
    if decimal_comma and delim == ",":
        raise InputError(f"{path}: a decimal comma cannot be used with a comma delimiter")
    numeric = sum(1 for ln in lines
                  if sum(_is_number(t.strip(), decimal_comma) for t in _split(ln, delim)) >= 2)
    if numeric == 0 and len(lines) == 1:
        raise InputError(f"{path}: a header line and no points")
    if numeric < max(1, (len(lines) - 1) / 2):
        raise InputError(f"{path}: only {numeric} of the first {len(lines)} lines hold numbers; "
                         "this is not point data (XYZ text has x y z per line)")
    if delim == "," and not decimal_comma and columns is None:
        _warn_comma_pairs(path, lines)
    first = [t.strip() for t in _split(lines[0], delim)]
    if header is None:
        header = not all(_is_number(t, decimal_comma) for t in first if t)
    ncols = len([t for t in _split(data_line, delim)])
    if columns is not None:
        cols = parse_columns(columns)
    elif header:
        try:
            cols = parse_columns(first)
        except InputError:
            cols = parse_columns(["x", "y", "z"] + ["-"] * (ncols - 3))
        ignored = [t for t, c in zip(first, cols) if c is None and t.strip()]
        lost = [t for t in ignored if _looks_like_classes(t)]
        if lost and "classification" not in cols:
            raise InputError(
                f"{path}: header column {lost[0]!r} looks like the point classes but is not "
                f"read (encoding {encoding}); without it the terrain would not come from the "
                "ground class: name the columns with --columns (e.g. x,y,z,intensity,"
                "classification), '-' skipping a column")
        if ignored:
            from ..errors import DataWarning

            warnings.warn(f"{path}: header column(s) not read: {', '.join(ignored)} (known: "
                          "x/este/leste, y/norte, z/cota/altitude, classe/classificação, "
                          "intensidade, retorno, número de retornos; or give --columns)",
                          DataWarning, stacklevel=2)
    else:
        if ncols < 3:
            raise InputError(f"{path}: line 1 has {ncols} column(s); need at least x, y, z "
                             f"(line: {lines[0][:80]!r}); check --delimiter")
        cols = ("x", "y", "z") + (None,) * (ncols - 3)
        k = _class_column(lines, delim, bool(decimal_comma), ncols)
        if k is not None:
            from ..errors import DataWarning

            cols = cols[:k] + ("classification",) + cols[k + 1:]
            warnings.warn(f"{path}: no header; column {k + 1} read as the point classes (its "
                          "values are ASPRS classes, ground 2 among them); give --columns "
                          "(e.g. x,y,z,intensity) if it is not", DataWarning, stacklevel=2)
    thousands = bool(decimal_comma) and _thousands_columns(path, lines[1:] if header else lines,
                                                           delim, cols)
    return XYZDialect(delim, bool(decimal_comma), bool(header), cols, thousands, encoding)


#: the ASPRS classes (LAS 1.4 standard: 0-18) a headerless column's values must all be for
#: :func:`_class_column` to take it for the point classes
ASPRS_MAX_CLASS = 18


def _class_column(lines, delim, decimal_comma: bool, ncols: int):
    """The column (0-based, beyond x, y, z) of a headerless file whose sampled values look like
    point classes, or None: whole numbers 0-18 with ground (2) among them, and either a class
    a return number cannot be (6 or above) or ground in at least half the lines (a return
    number column is mostly 1; reading it as classes would make the terrain of second
    returns, so a column that could be either is left unread)."""
    for k in range(3, ncols):
        vals = []
        for ln in lines:
            t = _split(ln, delim)
            if k >= len(t):
                return None
            v = t[k].strip().replace(",", ".") if decimal_comma else t[k].strip()
            try:
                f = float(v)
            except ValueError:
                vals = []
                break
            vals.append(f)
        a = np.asarray(vals)
        if not a.size or np.any(a != np.round(a)) or a.min() < 0 or a.max() > ASPRS_MAX_CLASS:
            continue
        ground = np.mean(a == 2)
        if ground > 0 and (a.max() >= 6 or ground >= 0.5):
            return k
    return None


def _looks_like_classes(name) -> bool:
    """Whether an unread header name looks like a classification column (``Classe_LAS``,
    ``Classifica\ufffd\ufffdo`` after a wrong decoding, ``Categoria do ponto``)."""
    key = normalise(name)
    return key.startswith(("clas", "categ", "cls")) or key in ("classif", "cl")


#: a number written with '.' between groups of three digits and a decimal comma
_THOUSANDS = re.compile(r"^[+-]?\d{1,3}(?:\.\d{3})+(?:,\d+)?$")


def _thousands_columns(path, lines, delim, cols) -> bool:
    """Whether a decimal-comma file groups thousands with dots (``412.955,63``); the columns
    that do are named in a warning (their dots are dropped when read)."""
    hits = set()
    for ln in lines:
        for i, t in enumerate(_split(ln, delim)):
            if _THOUSANDS.match(t.strip()):
                hits.add(i)
    if not hits:
        return False
    from ..errors import DataWarning

    names = ", ".join((cols[i] if i < len(cols) and cols[i] else f"column {i + 1}")
                      for i in sorted(hits))
    warnings.warn(f"{path}: {names} group thousands with '.' (e.g. 412.955,63 = 412955.63); "
                  "the dots are dropped when the numbers are read", DataWarning, stacklevel=3)
    return True


def looks_like_points(path, sample: int = 20) -> bool:
    """Whether a text file holds points: its dialect is detected and the x, y and z columns of
    its first ``sample`` data lines are numbers (a README, a tile index or a field sheet in a
    delivery folder is not)."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            d = sniff_xyz(path)
        idx = [d.columns.index(a) for a in ("x", "y", "z")]
        n = 0
        with _open_text(Path(path), d.encoding) as fh:
            for k, line in enumerate(fh):
                s = line.strip()
                if not s or s.startswith("#") or (k == 0 and d.header):
                    continue
                toks = _split(s, d.delimiter)
                if len(toks) <= max(idx) or not all(_is_number(toks[i].strip(), d.decimal_comma)
                                                    for i in idx):
                    return False
                n += 1
                if n >= sample:
                    break
        return n > 0
    except (LidarTreesError, ValueError, OSError, EOFError, zlib.error, UnicodeError):
        return False


def xyz_chunks(src, progress):
    """Yield the points of the XYZ source ``src`` in chunks; bad lines fail with the file,
    line and text, or are skipped and counted in ``src.skipped``."""
    try:
        yield from _xyz_chunks_raw(src, progress)
    except LidarTreesError:
        raise
    except (EOFError, OSError, zlib.error, UnicodeError) as exc:
        raise ReadError(f"{src.path}: cannot read the text, the file is truncated or "
                        f"corrupt ({type(exc).__name__}: {str(exc)[:120]})") from None


def _xyz_chunks_raw(src, progress):
    prog = as_progress(progress)
    d = src.dialect
    usecols = [i for i, c in enumerate(d.columns) if c is not None]
    names = [d.columns[i] for i in usecols]
    ncol_min = max(usecols) + 1
    size = src.path.stat().st_size or 1
    with _open_text(src.path, d.encoding) as fh:
        raw = fh.buffer if hasattr(fh, "buffer") else None
        lineno = 0
        if d.header:
            for line in fh:
                lineno += 1
                if line.strip() and not line.lstrip().startswith("#"):
                    break
        while True:
            check_cancel(progress)
            block = []
            for line in fh:
                block.append(line)
                if len(block) >= src.chunk_size:
                    break
            if not block:
                break
            start = lineno + 1
            lineno += len(block)
            arr = _parse_block(src, block, start, usecols, ncol_min)
            try:
                pos = raw.tell() if raw is not None else None
                if pos is not None:
                    prog.update(min(pos / size, 1.0), "reading points")
            except (OSError, ValueError):
                pass
            if arr.shape[0] == 0:
                continue
            cols = {name: arr[:, j] for j, name in enumerate(names)}
            chunk = PointChunk(
                cols["x"].astype(np.float64), cols["y"].astype(np.float64),
                cols["z"].astype(np.float64),
                *(cols[a].astype(_ATTR_DTYPES[a]) if a in cols else None
                  for a in ("classification", "return_number", "number_of_returns", "intensity")),
            )
            yield chunk
    prog.update(1.0, "reading points")


def _parse_block(src, block, start, usecols, ncol_min):
    d = src.dialect
    text = "".join(block)
    if d.thousands:
        text = text.replace(".", "")
    if d.decimal_comma:
        text = text.replace(",", ".")
    try:
        arr = np.loadtxt(io.StringIO(text), delimiter=d.delimiter, usecols=usecols,
                         ndmin=2, comments="#", dtype=np.float64)
        if arr.shape[0] and np.isfinite(arr).all():
            return arr
    except ValueError:
        pass
    # slow path: find (and skip, or report) the bad lines one by one
    rows = []
    for k, line in enumerate(block):
        s = line.strip()
        if not s or s.startswith("#"):
            continue
        if d.thousands:
            s = s.replace(".", "")
        toks = _split(s.replace(",", ".") if d.decimal_comma else s, d.delimiter)
        why = None
        if len(toks) < ncol_min:
            why = f"{len(toks)} column(s), need {ncol_min}"
        else:
            try:
                if not all(_ASCII_NUMBER.match(toks[i].strip()) for i in usecols):
                    raise ValueError  # Python's float() takes '1_000' and non-ASCII digits
                vals = [float(toks[i]) for i in usecols]
                if not all(np.isfinite(vals)):
                    why = "value is NaN or infinite"
            except (ValueError, IndexError):
                why = "not a number"
        if why is None:
            rows.append(vals)
        elif src.skip_invalid:
            src.skipped += 1
        else:
            raise InputError(f"{src.path}:{start + k}: {why}: {s[:120]!r} "
                             f"(dialect: {d.describe()}; use --skip-invalid to skip bad lines)")
    return np.asarray(rows, dtype=np.float64).reshape(-1, len(usecols))
