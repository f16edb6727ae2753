"""Each tile's result kept beside the output as a run goes, so a killed run can be continued
(``-resume``) from the tiles already done, with the same final result as one run.

The results are kept in a hidden folder ``.<output name>.tiles`` beside the output, one
``.npz`` per tile (:mod:`lidartrees_gis.io.store`: arrays and WKB bytes with a JSON
description, read without pickle, so a file planted there cannot run code) written to a
temporary name and renamed (a kill leaves whole files only), with the run's fingerprint (inputs
with their sizes and the content of their first and last blocks, options, the plan): a
``-resume`` whose fingerprint differs is refused rather than mixing two runs. A kept file that
is damaged, foreign or of another run or tile is ignored with a warning and its tile runs
again. The folder is removed when the run has written its outputs.
"""
from __future__ import annotations

import hashlib
import os
import shutil
import warnings
from pathlib import Path

from ..errors import DataWarning, InputError
from ..io.store import StoreError, load, save

FINGERPRINT = "fingerprint.txt"


#: bytes hashed at each end of a large input file, and the samples between them
END_BLOCK, SAMPLES, SAMPLE_BLOCK = 64 * 1024, 64, 4096
#: files up to this size are hashed whole
WHOLE_BYTES = 16 * 2 ** 20


def file_digest(path) -> str:
    """A digest of a file's content as :func:`run_fingerprint` takes it: the whole file up to
    :data:`WHOLE_BYTES`; for larger ones its size, its first and last :data:`END_BLOCK` bytes
    (a LAS/LAZ header, its VLRs, a LAZ chunk table, whose chunk sizes change with any point) and
    :data:`SAMPLES` blocks evenly spread between them, so that a file replaced by another of the
    same size and time stamp is told apart without reading a large flight twice."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        size = os.fstat(fh.fileno()).st_size
        h.update(f"{size};".encode())
        if size <= WHOLE_BYTES:
            for block in iter(lambda: fh.read(2 ** 20), b""):
                h.update(block)
            return h.hexdigest()
        offsets = [0, size - END_BLOCK]
        offsets += [int(size * (i + 1) / (SAMPLES + 1)) for i in range(SAMPLES)]
        for k, at in enumerate(offsets):
            fh.seek(at)
            h.update(fh.read(END_BLOCK if k < 2 else SAMPLE_BLOCK))
    return h.hexdigest()


def run_fingerprint(files, *parts) -> str:
    """A digest of what makes a run's tiles, in two parts ``INPUTS:REST``: the input ``files``
    (path, size, time and :func:`file_digest` of their content), and ``repr`` of the ``parts``
    (dataclasses of options, the plan, which may also follow from the inputs)."""
    h = hashlib.sha256()
    for p in files:
        st = os.stat(p)
        h.update(f"{os.path.abspath(p)}|{st.st_size}|{st.st_mtime_ns}|{file_digest(p)};"
                 .encode())
    rest = hashlib.sha256()
    for part in parts:
        rest.update(repr(part).encode())
        rest.update(b"\0")
    return f"{h.hexdigest()}:{rest.hexdigest()}"


class Checkpoint:
    """The tiles of one run kept in ``folder``.

    Parameters
    ----------
    folder : Path
        Where the tiles' results go.
    fingerprint : str
        :func:`run_fingerprint` of the run.
    resume : bool
        Continue from the tiles in ``folder`` (``-resume``); else start again (the folder of an
        earlier killed run is emptied).
    """

    def __init__(self, folder, fingerprint: str, resume: bool = False):
        self.folder, self.fingerprint, self.resume = Path(folder), fingerprint, resume
        self.resumed = 0

    @classmethod
    def beside(cls, output, fingerprint: str, resume: bool = False) -> "Checkpoint":
        """The checkpoint of a run writing ``output``."""
        out = Path(output)
        return cls(out.parent / f".{out.name}.tiles", fingerprint, resume)

    def load(self, n: int) -> dict:
        """The results kept of tiles ``0..n-1`` (``resume``), else none; the folder is made
        ready for this run."""
        fp = self.folder / FINGERPRINT
        kept = {}
        if self.resume:
            if not fp.exists():
                warnings.warn(DataWarning(f"-resume: no tiles of an earlier run in {self.folder}; "
                                          "starting from the first tile"), stacklevel=3)
            elif _changed_inputs(fp.read_text().strip(), self.fingerprint):
                warnings.warn(DataWarning(
                    f"-resume: the input files changed since the tiles in {self.folder} were "
                    "kept (their content differs); starting from the first tile"), stacklevel=3)
            elif fp.read_text().strip() != self.fingerprint:
                raise InputError(f"-resume: the tiles kept in {self.folder} are of another run "
                                 "(other input files or options); run the same command as "
                                 "before, or without -resume to start again")
            else:
                kept = self._kept(n)
                self.resumed = len(kept)
        if not kept and self.folder.exists():
            shutil.rmtree(self.folder, ignore_errors=True)
        self.folder.mkdir(parents=True, exist_ok=True)
        fp.write_text(self.fingerprint + "\n")
        return kept

    def _kept(self, n: int) -> dict:
        """The valid kept tiles; any other file is named once and ignored (its tile runs
        again)."""
        kept, bad = {}, []
        for f in sorted(self.folder.iterdir()):
            if f.name == FINGERPRINT or f.name.endswith(".part"):
                continue
            k = _tile_index(f.name)
            if k is None or k >= n:
                bad.append(f.name)
                continue
            try:
                kept[k], _ = load(f, check=self._check(k))
            except (OSError, StoreError, RecursionError, MemoryError):
                bad.append(f.name)
        if bad:
            warnings.warn(DataWarning(
                f"-resume: {len(bad)} file(s) in {self.folder} ignored (damaged, or not tiles "
                f"of this run: {', '.join(bad[:3])}{', ...' if len(bad) > 3 else ''}); their "
                "tiles run again"), stacklevel=4)
        return kept

    def _check(self, k: int):
        def check(value, meta):
            if meta.get("tile") != k or meta.get("fingerprint") != self.fingerprint:
                raise StoreError("another tile or run")
            if not isinstance(value, dict) or sorted(map(str, value)) != meta.get("keys"):
                raise StoreError("not a tile's result")
        return check

    def save(self, k: int, result) -> None:
        """Keep tile ``k``'s result (written whole or not at all)."""
        meta = {"tile": k, "fingerprint": self.fingerprint,
                "keys": sorted(map(str, result)) if isinstance(result, dict) else None}
        try:
            save(self.folder / f"tile_{k}.npz", result, meta)
        except (OSError, TypeError) as exc:  # a full disk must not stop the run: it only
            # loses -resume
            why = getattr(exc, "strerror", None) or exc
            warnings.warn(DataWarning(f"{self.folder}: cannot keep tile {k} for -resume "
                                      f"({why})"), stacklevel=2)

    def done(self) -> int:
        """Tiles kept so far."""
        return len(list(self.folder.glob("tile_*.npz")))

    def finish(self) -> None:
        """The run wrote its outputs: the kept tiles go."""
        shutil.rmtree(self.folder, ignore_errors=True)


def _changed_inputs(kept: str, now: str) -> bool:
    """Other inputs (or the same files with other content): the kept tiles are of data that is
    no longer there (whatever the options), so the run starts again rather than refuse."""
    a, b = kept.split(":"), now.split(":")
    return len(a) == len(b) == 2 and a[0] != b[0]


def _tile_index(name: str):
    """``k`` of a file named ``tile_k.npz``, else None."""
    if name.startswith("tile_") and name.endswith(".npz") and name[5:-4].isdigit():
        return int(name[5:-4])
    return None
