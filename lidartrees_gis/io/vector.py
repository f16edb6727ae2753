"""GeoPackage output (pyogrio): tree tops, crowns and a summary table, atomically."""
from __future__ import annotations

import json
import shutil
from pathlib import Path

from ..errors import InputError, OutputExistsError
from .output import atomic_output


def write_gpkg(path, layers: dict, *, overwrite=False, append=False, layer_options=None,
               metadata=None) -> None:
    """Write several layers (name -> GeoDataFrame or DataFrame) to one GeoPackage.

    ``append`` adds the layers to an existing file (features appended to same-named layers);
    ``overwrite`` replaces the file. Work happens on a temporary copy renamed at the end.
    """
    import pyogrio

    p = Path(path)
    if p.suffix.lower() != ".gpkg":
        raise InputError(f"OUTPUT: {p}: expected a .gpkg file name")
    if p.exists() and not (overwrite or append):
        raise OutputExistsError(f"{p}: output exists; use -overwrite to replace it or -append")
    existing = set()
    if append and p.exists():
        existing = {name for name, _ in pyogrio.list_layers(p)}
    with atomic_output(p, overwrite=True) as tmp:
        if append and p.exists():
            shutil.copyfile(p, tmp)
        meta = {k: (v if isinstance(v, str) else json.dumps(v, default=str))
                for k, v in (metadata or {}).items()}
        import warnings

        for name, df in layers.items():
            with warnings.catch_warnings():  # a TLS tree in local coordinates has no CRS
                warnings.filterwarnings("ignore", message="'crs' was not provided")
                pyogrio.write_dataframe(df, tmp, layer=name, driver="GPKG",
                                        append=name in existing,
                                        layer_options=layer_options or None,
                                        layer_metadata=meta or None)
