"""Safe outputs: refuse to overwrite without permission, write to a temporary name, rename."""
from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path

from ..errors import InputError, OutputError, OutputExistsError


def check_output(path, overwrite: bool = False, *, param: str = "OUTPUT") -> Path:
    """Refuse an existing output unless ``overwrite``; check its folder exists."""
    p = Path(path)
    if p.exists() and not overwrite:
        raise OutputExistsError(f"{p}: output exists; use -overwrite to replace it")
    if p.is_dir():
        raise InputError(f"{param}: {p} is a directory, expected a file name")
    parent = p.parent if str(p.parent) else Path(".")
    if not parent.exists():
        raise InputError(f"{param}: folder {parent} does not exist")
    try:  # a real probe (os.access says yes to root on a read-only file system)
        fd, probe = tempfile.mkstemp(prefix=".lidartrees-probe.", dir=parent)
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        raise OutputError(f"{param}: cannot write in folder {parent} "
                          f"({exc.strerror or type(exc).__name__})") from None
    return p


def check_outputs(outputs, inputs=(), overwrite: bool = False) -> None:
    """Check every output of a run before any is written: each one as :func:`check_output`
    and :func:`check_not_input`, and no two the same file.

    ``outputs`` is a sequence of ``(path, param)`` or ``(path, param, overwrite)`` (e.g. a
    GeoPackage appended to); ``None`` paths are skipped.
    """
    seen = {}
    for item in outputs:
        path, param = item[:2]
        if path is None:
            continue
        check_output(path, item[2] if len(item) > 2 else overwrite, param=param)
        check_not_input(path, *inputs, param=param)
        key = Path(path).resolve()
        if key in seen:
            raise InputError(f"{param}: {path} is also the {seen[key]} output; give each output "
                             "its own file")
        seen[key] = param


def check_not_input(output, *inputs, param: str = "OUTPUT") -> None:
    """Refuse an output that is one of the inputs (it would be overwritten while read)."""
    if output is None:
        return
    o = Path(output).resolve()
    for i in inputs:
        if i is not None and Path(str(i)).exists() and Path(str(i)).resolve() == o:
            raise InputError(f"{param}: {output} is also an input; write to another file")


@contextlib.contextmanager
def atomic_output(path, overwrite: bool = False, *, param: str = "OUTPUT"):
    """Yield a temporary path beside ``path``; on success rename it to ``path``.

    On any error (or cancel) the temporary file is removed and an existing ``path`` is left
    untouched.
    """
    p = check_output(path, overwrite, param=param)
    fd, tmp = tempfile.mkstemp(prefix=f".{p.stem}.", suffix=f".part{p.suffix}", dir=p.parent or ".")
    os.close(fd)
    os.unlink(tmp)  # let the writer create it
    try:
        yield Path(tmp)
        if p.is_dir():
            shutil.rmtree(p)
        os.replace(tmp, p)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            if os.path.isdir(tmp):
                shutil.rmtree(tmp)
            else:
                os.unlink(tmp)
        raise


@dataclass(frozen=True)
class OutputOptions:
    """How outputs are written (GDAL/OGR's options).

    Attributes
    ----------
    overwrite : bool
        Replace existing outputs (``-overwrite``); otherwise they are refused.
    append : bool
        Add to an existing GeoPackage's layers (``-append``).
    nln : str
        Prefix of the GeoPackage layer names (``-nln``).
    layer_options : dict, optional
        GeoPackage layer creation options (``-lco``).
    creation_options : dict, optional
        GeoTIFF creation options (``-co``).
    table : TableOptions, optional
        How the tables for people (``-csv``, ``-stand_csv``) are written: ``-lco``'s
        ``SEPARATOR``, ``DECIMAL``, ``WRITE_BOM`` over the locale's defaults (None: the
        locale's; see :mod:`lidartrees_gis.io.tables`).
    """

    overwrite: bool = False
    append: bool = False
    nln: str = ""
    layer_options: dict | None = None
    creation_options: dict | None = None
    table: object = None

    def __post_init__(self):
        import re

        # GDAL's GeoPackage driver refuses names beginning with other characters ('/tmp/...')
        if self.nln and not re.fullmatch(r"[^\W]([\w.\-]*)", str(self.nln)):
            raise InputError(f"-nln: {self.nln!r}: a layer name prefix takes letters, digits, "
                             "'_', '-' and '.', and begins with a letter, digit or '_'")
