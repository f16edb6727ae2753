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
