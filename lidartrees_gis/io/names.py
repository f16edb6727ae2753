"""Column names in English and Portuguese, and the table dialects of Brazilian spreadsheets.

Brazilian deliveries and field sheets name their columns in Portuguese (``Este``, ``Norte``,
``Cota``, ``Classe``, ``Classificação``, ``Intensidade``, ``Retorno``, ``Altura``) and export
CSV from spreadsheets set to pt-BR: semicolons between fields, a decimal comma, often in
Windows-1252. Names are compared after :func:`normalise` (case, accents, spaces, dots and
underscores ignored).
"""
from __future__ import annotations

import re
import unicodedata
from pathlib import Path

#: the names accepted for each point attribute (normalised, see :func:`normalise`)
POINT_COLUMNS = {
    "x": ("x", "e", "east", "easting", "//x", "este", "leste", "coordx", "coordenadax", "utme",
          "lon", "longitude"),
    "y": ("y", "n", "north", "northing", "norte", "coordy", "coordenaday", "utmn", "lat",
          "latitude"),
    "z": ("z", "h", "height", "elev", "elevation", "alt", "altitude", "cota", "altura",
          "elevacao", "altimetria"),
    "intensity": ("intensity", "i", "int", "intensidade"),
    "return_number": ("return_number", "return", "returnnumber", "rn", "r", "retorno",
                      "numeroderetorno", "numerodoretorno", "nretorno"),
    "number_of_returns": ("number_of_returns", "numberofreturns", "nr", "num_returns",
                          "numeroderetornos", "numretornos", "nretornos", "totalderetornos",
                          "retornos"),
    "classification": ("classification", "class", "c", "cls", "classe", "classificacao",
                       "categoria"),
}

#: the names accepted for a tree table's columns (reference trees, field inventories)
TREE_COLUMNS = {
    "x": ("x", "easting", "east", "e", "xcoord", "lon", "longitude", "este", "leste",
          "coordenadax", "utme"),
    "y": ("y", "northing", "north", "n", "ycoord", "lat", "latitude", "norte", "coordenaday",
          "utmn"),
    "height": ("height", "h", "ht", "z", "treeheight", "zmax", "totalheight", "altura",
               "alturatotal", "htm", "alturam", "alt"),
    "stand": ("standid", "stand", "talhao", "idtalhao", "codtalhao", "codigotalhao"),
}


def plain(name) -> str:
    """A field name as the id-field lookups compare it: no accents, lower case, spaces as
    underscores (``"Talhão ID"`` -> ``"talhao_id"``)."""
    s = unicodedata.normalize("NFKD", str(name)).encode("ascii", "ignore").decode()
    return s.strip().lower().replace(" ", "_")


def normalise(name) -> str:
    """A column name without a unit in brackets, case, accents, spaces, dots, hyphens or
    underscores (but ``//x``, LAStools' header, kept): ``"Classificação"`` ->
    ``"classificacao"``, ``"Altura total (m)"`` -> ``"alturatotal"``."""
    s = re.sub(r"\(.*?\)|\[.*?\]", "", str(name)).strip().lower()  # a unit: "Altura (m)"
    s = unicodedata.normalize("NFKD", s)
    s = "".join(ch for ch in s if not unicodedata.combining(ch))
    if s.startswith("//"):
        return s
    return re.sub(r"[\s._\-()\[\]]+", "", s)


def match_column(name, table: dict):
    """The attribute of ``table`` (e.g. :data:`POINT_COLUMNS`) that ``name`` names, or None."""
    key = normalise(name)
    for attr, aliases in table.items():
        if key in aliases or key == normalise(attr):
            return attr
    return None


def read_text_table(path):
    """A CSV or text table as a pandas DataFrame, in whichever dialect it comes: comma,
    semicolon or tab separated, decimal point or comma (pt-BR spreadsheets: ``;`` and ``,``),
    UTF-8 (with or without BOM), Windows-1252 or Latin-1; or a sheet of an ``.xlsx``
    workbook (``PATH.xlsx:SHEET``, the first by default). Raises ValueError when it cannot be
    read."""
    import pandas as pd

    p, sheet = Path(path), 0
    text = str(path)
    if not p.exists() and ".xlsx:" in text.lower():
        cut = text.lower().rindex(".xlsx:") + 5
        p, sheet = Path(text[:cut]), text[cut + 1:]
    raw = p.read_bytes()
    if p.suffix.lower() == ".xlsx" or raw[:4] == b"PK\x03\x04":
        import io
        import zipfile

        try:  # cells typed as numbers stay numbers, text stays text
            return pd.read_excel(io.BytesIO(raw), sheet_name=sheet, engine="openpyxl")
        except (zipfile.BadZipFile, KeyError, ValueError) as exc:
            raise ValueError(f"not a readable .xlsx workbook ({exc})") from None
    for enc in ("utf-8-sig", "cp1252", "latin-1"):  # latin-1 decodes any byte: the last
        try:
            text = raw.decode(enc)
            break
        except UnicodeDecodeError:
            continue
    lines = [ln for ln in text.splitlines() if ln.strip()][:50]
    if not lines:
        raise ValueError("empty file")
    counts = {d: min(ln.count(d) for ln in lines) for d in (";", "\t", ",")}
    sep = next((d for d in (";", "\t") if counts[d] > 0), None)
    if sep is None:
        sep = "," if counts[","] > 0 else r"\s+"
    body = lines[1:] if len(lines) > 1 else lines
    comma_numbers = sum(bool(re.search(r"(?<![\d,])-?\d+,\d+(?![\d,])", ln)) for ln in body)
    decimal = "," if sep != "," and comma_numbers > len(body) / 2 else "."
    import io

    return pd.read_csv(io.StringIO(text), sep=sep, decimal=decimal,
                       engine="python" if sep == r"\s+" else "c")
