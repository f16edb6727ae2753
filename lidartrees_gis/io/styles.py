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
    update_time DATETIME DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now')))"""
#: ``layer_styles.update_time`` as ISO 8601 with milliseconds, UTC (``2026-11-27T10:00:00.000Z``):
#: SQLite's CURRENT_TIMESTAMP (``2026-11-27 10:00:00``) makes GDAL warn "Non-conformant
#: content for record ... in column update_time" on every open
_NOW_ISO = "strftime('%Y-%m-%dT%H:%M:%fZ', 'now')"


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
                        "useAsDefault, description, owner, ui, update_time) VALUES ('', '', ?, "
                        f"?, ?, ?, '', 1, ?, '', '', {_NOW_ISO})",
                        (layer, geom[layer], layer, text, f"lidartrees_gis style {qml}"))
            done.append(layer)
        con.commit()
    finally:
        con.close()
    return done


#: the colours of the CHM style's ramp (ColorBrewer YlGn, as styles/make_styles.py): the
#: classes of a CHM take them spread over its own classes
CHM_COLOURS = ("#ffffe5", "#d9f0a3", "#addd8e", "#78c679", "#31a354", "#006837", "#004529")


def _ramp_colour(t: float) -> str:
    """The colour at ``t`` (0-1) of :data:`CHM_COLOURS`, linear in RGB (as the toolbox's)."""
    rgb = [tuple(int(c[k:k + 2], 16) for k in (1, 3, 5)) for c in CHM_COLOURS]
    x = t * (len(rgb) - 1)
    k = min(int(x), len(rgb) - 2)
    f = x - k
    return "#" + "".join(f"{round(a + (b - a) * f):02x}" for a, b in zip(rgb[k], rgb[k + 1]))


def chm_style_text(limits) -> str:
    """The CHM style (``chm.qml``) with its discrete classes set to the upper ``limits`` (m),
    labelled ``lo - hi m``, in the ramp's colours."""
    import re

    text = style_path("chm.qml").read_text(encoding="utf-8")
    lows = [0.0] + list(limits[:-1])
    n = len(limits)
    items = "\n".join(f'          <item label="{lo:g} - {hi:g} m" alpha="255" value="{hi:g}" '
                      f'color="{_ramp_colour(i / max(n - 1, 1))}"/>'
                      for i, (lo, hi) in enumerate(zip(lows, limits)))
    text = re.sub(r"(<colorrampshader[^>]*>)(.*?)(\s*</colorrampshader>)",
                  lambda m: m.group(1) + "\n" + items + m.group(3), text, count=1, flags=re.S)
    return re.sub(r'maximumValue="[^"]*"', f'maximumValue="{limits[-1]:g}"', text, count=1)


def write_sidecar_style(raster, qml: str, overwrite: bool = False, limits=None):
    """Write the style ``qml`` beside the GeoTIFF ``raster`` (``chm.tif`` -> ``chm.qml``), which
    QGIS loads as the layer's default style wherever the file is opened; the CHM's classes fit
    to ``limits`` (:func:`chm_style_text`). An existing sidecar is kept unless ``overwrite``.
    Returns the sidecar's path, or None when one was kept."""
    from .output import atomic_output

    side = Path(raster).with_suffix(".qml")
    if side.exists() and not overwrite:
        return None
    text = chm_style_text(limits) if qml == "chm.qml" and limits else \
        style_path(qml).read_text(encoding="utf-8")
    with atomic_output(side, overwrite=True, param="style") as tmp:
        Path(tmp).write_text(text, encoding="utf-8")
    return side
