"""Safe outputs: refuse to overwrite without permission, write to a temporary name, rename."""
from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from pathlib import Path

from ..errors import InputError, OutputExistsError


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
    return p


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
