"""QGIS styles shipped inside the GeoPackages written, so that a manager who opens one sees the
project's symbols (QGIS's own ``layer_styles`` table, the style marked as the layer's default),
and the GeoPackage version QGIS 3.22 opens without a warning.

The .qml files are the repository's ``styles/`` (installed with the package).
"""
from __future__ import annotations

import sqlite3
from pathlib import Path

#: the style of each kind of layer (the layer's name without its ``-nln`` prefix)
LAYER_STYLES = {"tree_tops": "tree_tops.qml", "crowns": "crowns.qml", "gaps": "gaps.qml",
                "stands": "stands.qml"}

#: dataset creation options of every GeoPackage written: version 1.2 (QGIS 3.22 warns that
#: 1.4, GDAL's default since 3.10, "may only be partially supported")
GPKG_DATASET_OPTIONS = {"VERSION": "1.2"}

_LAYER_STYLES_SQL = """CREATE TABLE IF NOT EXISTS layer_styles (
    id INTEGER PRIMARY KEY AUTOINCREMENT, f_table_catalog TEXT(256), f_table_schema TEXT(256),
    f_table_name TEXT(256), f_geometry_column TEXT(256), styleName TEXT(30), styleQML TEXT,
    styleSLD TEXT, useAsDefault BOOLEAN, description TEXT, owner TEXT(30), ui TEXT(30),
    update_time DATETIME DEFAULT CURRENT_TIMESTAMP)"""


def style_path(name: str) -> Path:
    """The installed .qml file ``name`` (``tree_tops.qml``, ``chm.qml``, ...)."""
    return Path(__file__).resolve().parents[1] / "styles" / name


def embed_styles(gpkg, layers: dict) -> list:
    """Store the style of each layer (``{layer name: qml file name}``) in ``gpkg``'s
    ``layer_styles`` table as the layer's default (replacing an earlier default), registered
    in ``gpkg_contents`` as QGIS does. Layers absent from the file are skipped. Returns the
    layers styled."""
    con = sqlite3.connect(str(gpkg))
    try:
        geom = dict(con.execute("SELECT table_name, column_name FROM gpkg_geometry_columns"))
        con.execute(_LAYER_STYLES_SQL)
        con.execute("INSERT OR IGNORE INTO gpkg_contents (table_name, data_type, identifier, "
                    "description, last_change) VALUES ('layer_styles', 'attributes', "
                    "'layer_styles', '', strftime('%Y-%m-%dT%H:%M:%fZ', 'now'))")
        done = []
        for layer, qml in layers.items():
            if layer not in geom:
                continue
            text = style_path(qml).read_text(encoding="utf-8")
            con.execute("DELETE FROM layer_styles WHERE f_table_name = ? AND useAsDefault = 1",
                        (layer,))
            con.execute("INSERT INTO layer_styles (f_table_catalog, f_table_schema, "
                        "f_table_name, f_geometry_column, styleName, styleQML, styleSLD, "
                        "useAsDefault, description, owner, ui) VALUES ('', '', ?, ?, ?, ?, '', "
                        "1, ?, '', '')", (layer, geom[layer], layer, text,
                                           f"lidartrees_gis style {qml}"))
            done.append(layer)
        con.commit()
    finally:
        con.close()
    return done
