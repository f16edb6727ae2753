"""GeoPackage output (pyogrio): tree tops, crowns and a summary table, atomically."""
from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

from ..errors import InputError, OutputExistsError
from .claim import claim_output
from .output import atomic_output
from .styles import GPKG_DATASET_OPTIONS, embed_styles


def _layers(p):
    import pyogrio

    return [name for name, _ in pyogrio.list_layers(p)]


def start_from_existing(p, tmp, append, owned=()) -> set:
    """Begin the temporary copy of GeoPackage ``p`` from the existing file, if any: ``-append``
    adds to its layers (their names are returned), ``-overwrite`` replaces the layers
    ``owned`` (those the command writes; dropped from the copy even where this run writes
    none) and keeps the others, as ogr2ogr; a file holding only those layers (and their
    styles) is not copied but written anew. A file that is not a GeoPackage is replaced, or
    refused with ``append``."""
    p = Path(p)
    if not p.exists():
        return set()
    try:
        names = set(_layers(p))
    except Exception:  # noqa: BLE001 - not a GeoPackage
        if append:
            raise InputError(f"{p}: -append: the file is not a GeoPackage") from None
        return set()
    owned = set(owned)
    if not append and names <= owned | {"layer_styles"}:
        return set()
    shutil.copyfile(p, tmp)
    if append:
        return names
    drop_layers(tmp, names & owned)
    return set()


def drop_layers(gpkg, layers) -> None:
    """Remove the tables ``layers`` from GeoPackage ``gpkg`` with their spatial indexes,
    registrations, column descriptions, metadata links and styles."""
    import sqlite3

    if not layers:
        return
    con = sqlite3.connect(str(gpkg))
    try:
        have = {r[0] for r in con.execute("SELECT name FROM sqlite_master WHERE type='table'")}
        refs = {"gpkg_metadata", "gpkg_metadata_reference"} <= have
        for t in layers:
            md = [r[0] for r in con.execute("SELECT md_file_id FROM gpkg_metadata_reference "
                                            "WHERE table_name = ?", (t,))] if refs else []
            for (col,) in con.execute("SELECT column_name FROM gpkg_geometry_columns WHERE "
                                      "table_name = ?", (t,)).fetchall():
                con.execute(f'DROP TABLE IF EXISTS "rtree_{t}_{col}"')
            con.execute(f'DROP TABLE IF EXISTS "{t}"')
            for meta, key in (("gpkg_geometry_columns", "table_name"),
                              ("gpkg_extensions", "table_name"),
                              ("gpkg_data_columns", "table_name"),
                              ("gpkg_metadata_reference", "table_name"),
                              ("gpkg_ogr_contents", "table_name"),
                              ("layer_styles", "f_table_name"), ("gpkg_contents", "table_name")):
                if meta in have:
                    con.execute(f"DELETE FROM {meta} WHERE {key} = ?", (t,))
            for i in md:  # the table's own metadata, unless another reference holds it
                con.execute("DELETE FROM gpkg_metadata WHERE id = ? AND id NOT IN (SELECT "
                            "md_file_id FROM gpkg_metadata_reference)", (i,))
        con.commit()
    finally:
        con.close()


def write_gpkg(path, layers: dict, *, overwrite=False, append=False, layer_options=None,
               metadata=None, styles=None, owned=()) -> None:
    """Write several layers (name -> GeoDataFrame or DataFrame) to one GeoPackage.

    ``append`` adds the layers to an existing file (features appended to same-named layers);
    ``overwrite`` replaces the layers written and keeps the file's other layers (as ogr2ogr
    -overwrite). Work happens on a temporary copy renamed at the end. ``styles``: ``{layer:
    qml file}`` stored as the layers' default QGIS styles (:mod:`lidartrees_gis.io.styles`).
    ``owned``: the command's other layers, dropped by ``overwrite`` even where this run writes
    none (a run without trees leaves no earlier run's trees beside its stands).
    """
    import pyogrio

    p = Path(path)
    if p.suffix.lower() != ".gpkg":
        raise InputError(f"OUTPUT: {p}: expected a .gpkg file name")
    if p.exists() and not (overwrite or append):
        raise OutputExistsError(f"{p}: output exists; use -overwrite to replace it or -append")
    with claim_output(p, wait=append):  # the layers read below are those appended to
        _write_gpkg(p, layers, overwrite, append, layer_options, metadata, styles,
                    set(layers) | set(owned))


def _write_gpkg(p, layers, overwrite, append, layer_options, metadata, styles, owned) -> None:
    import pyogrio

    try:
        appended = set(_layers(p)) if append and p.exists() else set()
    except Exception:  # noqa: BLE001 - not a GeoPackage: refused below
        appended = set()
    for name, df in layers.items():  # -append of the same trees twice (e.g. the same tile)
        if name in appended and "tree_id" in getattr(df, "columns", ()) and len(df):
            old = pyogrio.read_dataframe(p, layer=name, columns=["tree_id"], read_geometry=False)
            if "tree_id" in old.columns:
                dup = len(set(old["tree_id"].tolist()) & set(df["tree_id"].tolist()))
                if dup:
                    raise OutputExistsError(
                        f"{p}: -append: layer {name} already holds {dup:,} of these "
                        f"{len(df):,} trees (same tree_id: the same area twice?); use -overwrite "
                        "to replace the layers, or append other areas only")
    with atomic_output(p, overwrite, append=append) as tmp:
        existing = start_from_existing(p, tmp, append, owned=owned)
        meta = {k: (v if isinstance(v, str) else json.dumps(v, default=str))
                for k, v in (metadata or {}).items()}
        import warnings

        for name, df in layers.items():
            with warnings.catch_warnings():  # a TLS tree in local coordinates has no CRS
                warnings.filterwarnings("ignore", message="'crs' was not provided")
                pyogrio.write_dataframe(df, tmp, layer=name, driver="GPKG",
                                        append=name in existing,
                                        layer_options=layer_options or None,
                                        layer_metadata=meta or None,
                                        dataset_options=None if Path(tmp).exists()
                                        else GPKG_DATASET_OPTIONS)
        if styles:
            embed_styles(tmp, styles)


def read_polygons(source, *, param: str):
    """The features of a polygon vector source: any OGR file (GeoPackage, shapefile, GeoJSON,
    ...) given as ``PATH`` or ``PATH:LAYER``. Returns ``(GeoDataFrame, description)``; errors
    name ``param`` and the file."""
    import geopandas as gpd

    text = str(source).strip()
    path, layer = text, None
    if not Path(path).exists() and ":" in text:
        path, layer = text.rsplit(":", 1)
    if not Path(path).exists():
        raise InputError(f"{param}: {text}: no such file")
    try:
        gdf = gpd.read_file(path, layer=layer or None)
    except Exception as exc:  # noqa: BLE001 - GDAL says why
        from ..errors import ReadError

        raise ReadError(f"{param}: {path}: cannot read as a vector file "
                        f"({str(exc).splitlines()[0] if str(exc) else type(exc).__name__})") from None
    gdf = _windows_text(gdf, path)
    if not isinstance(gdf, gpd.GeoDataFrame) or gdf.geometry.name not in gdf.columns:
        raise InputError(f"{param}: {path}: a table without geometries; give a vector layer "
                         "(GeoPackage, shapefile) of polygons or of points (in QGIS: Add "
                         "Delimited Text Layer, then save it as a GeoPackage)")
    return gdf, f"{path}{':' + layer if layer else ''}"


_C1 = re.compile("[\x80-\x9f]")


def _c1_to_cp1252(text):
    """A text read as Latin-1 that holds C1 control characters, read again as Windows-1252
    (``\x93Açaí\x94`` is “Açaí”); any other value as it is."""
    if not isinstance(text, str) or not _C1.search(text):
        return text
    try:
        return text.encode("latin-1").decode("cp1252")
    except (UnicodeEncodeError, UnicodeDecodeError):
        return text


def _windows_text(gdf, path):
    """A shapefile without a ``.cpg`` is read by GDAL as Latin-1 (its DBF names no code page);
    the Windows exports users bring are Windows-1252, whose dashes, quotes and € Latin-1 reads
    as control characters: those texts, and field names, are read again as Windows-1252."""
    import pandas as pd

    p = Path(path)
    if p.suffix.lower() not in (".shp", ".dbf") or p.with_suffix(".cpg").exists() \
            or p.with_suffix(".CPG").exists():
        return gdf
    names = {c: _c1_to_cp1252(c) for c in gdf.columns}
    if any(k != v for k, v in names.items()):
        gdf = gdf.rename(columns=names)
    for c in gdf.columns:
        if c != gdf.geometry.name and (gdf[c].dtype == object
                                        or pd.api.types.is_string_dtype(gdf[c].dtype)):
            gdf[c] = gdf[c].map(_c1_to_cp1252)
    return gdf


_EXT_SQL = ("CREATE TABLE IF NOT EXISTS gpkg_extensions (table_name TEXT, column_name TEXT, "
            "extension_name TEXT NOT NULL, definition TEXT NOT NULL, scope TEXT NOT NULL, "
            "CONSTRAINT ge_tce UNIQUE (table_name, column_name, extension_name))")
_DATA_COLUMNS_SQL = ("CREATE TABLE IF NOT EXISTS gpkg_data_columns (table_name TEXT NOT NULL, "
                     "column_name TEXT NOT NULL, name TEXT, title TEXT, description TEXT, "
                     "mime_type TEXT, constraint_name TEXT, CONSTRAINT pk_gdc PRIMARY KEY "
                     "(table_name, column_name), CONSTRAINT gdc_tn UNIQUE (table_name, name))")


def describe_columns(gpkg, layer: str, docs: dict) -> None:
    """Write each column's description (``{column: text}``) into the GeoPackage's
    ``gpkg_data_columns`` table (the GeoPackage schema extension; GDAL and QGIS show it as
    the field's comment)."""
    import sqlite3

    con = sqlite3.connect(str(gpkg))
    try:
        cols = [r[1] for r in con.execute(f'PRAGMA table_info("{layer}")')]
        con.execute(_EXT_SQL)
        con.execute(_DATA_COLUMNS_SQL)
        con.execute("INSERT OR IGNORE INTO gpkg_extensions VALUES ('gpkg_data_columns', NULL, "
                    "'gpkg_schema', 'http://www.geopackage.org/spec/#extension_schema', "
                    "'read-write')")
        for c in cols:
            if c in docs:
                con.execute("INSERT OR REPLACE INTO gpkg_data_columns (table_name, column_name, "
                            "name, description) VALUES (?, ?, ?, ?)", (layer, c, c, docs[c]))
        con.commit()
    finally:
        con.close()
