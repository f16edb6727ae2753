"""Safe outputs: refuse to overwrite without permission, write to a temporary name, rename."""
from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path

from ..errors import InputError, OutputError, OutputExistsError
from .claim import claim_output, place


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
def atomic_output(path, overwrite: bool = False, *, param: str = "OUTPUT", append: bool = False):
    """Yield a temporary path beside ``path``; on success rename it to ``path``.

    The output is claimed for the whole time (:func:`~lidartrees_gis.io.claim.claim_output`:
    another run writing it makes this one fail in one line, or wait with ``append``), and the
    rename never replaces a file unless ``overwrite``, or ``append`` to a file that was there
    when the claim was taken (the caller copies it first). On any error (or cancel) the
    temporary file is removed and an existing ``path`` is left untouched.
    """
    with claim_output(path, wait=append, param=param):
        p = check_output(path, overwrite or append, param=param)
        replace = overwrite or (append and p.exists())
        fd, tmp = tempfile.mkstemp(prefix=f".{p.stem}.", suffix=f".part{p.suffix}",
                                   dir=p.parent or ".")
        os.close(fd)
        os.unlink(tmp)  # let the writer create it
        try:
            yield Path(tmp)
            if replace and p.is_dir():
                shutil.rmtree(p)
            place(tmp, p, replace, param)
        except BaseException:
            with contextlib.suppress(FileNotFoundError):
                if os.path.isdir(tmp):
                    shutil.rmtree(tmp)
                else:
                    os.unlink(tmp)
            raise


@contextlib.contextmanager
def claim_outputs(outputs, overwrite: bool = False, append_to=None):
    """Claim every output of a run (``(path, param)`` or ``(path, param, overwrite)`` items as
    for :func:`~lidartrees_gis.io.output.check_outputs`; ``None`` paths skipped), in one order
    so two runs never wait for each other, each checked again once claimed (another run may
    have written it meanwhile). ``append_to``: the GeoPackage appended to, waited for."""
    app = None if append_to is None else Path(append_to).resolve()
    items = sorted((str(Path(o[0]).resolve()), o) for o in outputs if o[0] is not None)
    with contextlib.ExitStack() as stack:
        for key, (path, param, *own) in items:
            wait = app is not None and Path(key) == app
            stack.enter_context(claim_output(path, wait=wait, param=param))
            check_output(path, own[0] if own else overwrite, param=param)
        yield


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
