"""GeoPackage output (pyogrio): tree tops, crowns and a summary table, atomically."""
from __future__ import annotations

import json
import shutil
from pathlib import Path

from ..errors import InputError, OutputExistsError
from .output import atomic_output
from .styles import GPKG_DATASET_OPTIONS, embed_styles


def _layers(p):
    import pyogrio

    return [name for name, _ in pyogrio.list_layers(p)]


def start_from_existing(p, tmp, append) -> set:
    """Begin the temporary copy of GeoPackage ``p`` from the existing file, if any: ``-append``
    adds to its layers (their names are returned), ``-overwrite`` replaces only the layers then
    written (as ogr2ogr) and keeps the others. A file that is not a GeoPackage is replaced, or
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
    shutil.copyfile(p, tmp)
    return names if append else set()


def write_gpkg(path, layers: dict, *, overwrite=False, append=False, layer_options=None,
               metadata=None, styles=None) -> None:
    """Write several layers (name -> GeoDataFrame or DataFrame) to one GeoPackage.

    ``append`` adds the layers to an existing file (features appended to same-named layers);
    ``overwrite`` replaces the layers written and keeps the file's other layers (as ogr2ogr
    -overwrite). Work happens on a temporary copy renamed at the end. ``styles``: ``{layer:
    qml file}`` stored as the layers' default QGIS styles (:mod:`lidartrees_gis.io.styles`).
    """
    import pyogrio

    p = Path(path)
    if p.suffix.lower() != ".gpkg":
        raise InputError(f"OUTPUT: {p}: expected a .gpkg file name")
    if p.exists() and not (overwrite or append):
        raise OutputExistsError(f"{p}: output exists; use -overwrite to replace it or -append")
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
    with atomic_output(p, overwrite=True) as tmp:
        existing = start_from_existing(p, tmp, append)
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
