"""Each tile's result kept beside the output as a run goes, so a killed run can be continued
(``-resume``) from the tiles already done, with the same final result as one run.

The results are kept in a hidden folder ``.<output name>.tiles`` beside the output, one pickle
per tile written to a temporary name and renamed (a kill leaves whole files only), with the
run's fingerprint (inputs with their sizes and times, options, the plan): a ``-resume`` whose
fingerprint differs is refused rather than mixing two runs. The folder is removed when the run
has written its outputs.
"""
from __future__ import annotations

import hashlib
import os
import pickle
import shutil
import warnings
from pathlib import Path

from ..errors import DataWarning, InputError

FINGERPRINT = "fingerprint.txt"


def run_fingerprint(files, *parts) -> str:
    """A digest of what makes a run's tiles: the input ``files`` with their sizes and
    modification times, and ``repr`` of the ``parts`` (dataclasses of options, the plan)."""
    h = hashlib.sha256()
    for p in files:
        st = os.stat(p)
        h.update(f"{os.path.abspath(p)}|{st.st_size}|{st.st_mtime_ns};".encode())
    for part in parts:
        h.update(repr(part).encode())
        h.update(b"\0")
    return h.hexdigest()


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
            elif fp.read_text().strip() != self.fingerprint:
                raise InputError(f"-resume: the tiles kept in {self.folder} are of another run "
                                 "(other input files or options); run the same command as "
                                 "before, or without -resume to start again")
            else:
                for k in range(n):
                    f = self.folder / f"tile_{k}.pkl"
                    if f.exists():
                        try:
                            with open(f, "rb") as fh:
                                kept[k] = pickle.load(fh)
                        except Exception:  # noqa: BLE001 - a damaged file: the tile runs again
                            continue
                self.resumed = len(kept)
        if not kept and self.folder.exists():
            shutil.rmtree(self.folder, ignore_errors=True)
        self.folder.mkdir(parents=True, exist_ok=True)
        fp.write_text(self.fingerprint + "\n")
        return kept

    def save(self, k: int, result) -> None:
        """Keep tile ``k``'s result (written whole or not at all)."""
        tmp = self.folder / f".tile_{k}.pkl.tmp"
        try:
            with open(tmp, "wb") as fh:
                pickle.dump(result, fh, protocol=pickle.HIGHEST_PROTOCOL)
            os.replace(tmp, self.folder / f"tile_{k}.pkl")
        except OSError as exc:  # a full disk must not stop the run: it only loses -resume
            warnings.warn(DataWarning(f"{self.folder}: cannot keep tile {k} for -resume "
                                      f"({exc.strerror or exc})"), stacklevel=2)

    def done(self) -> int:
        """Tiles kept so far."""
        return len(list(self.folder.glob("tile_*.pkl")))

    def finish(self) -> None:
        """The run wrote its outputs: the kept tiles go."""
        shutil.rmtree(self.folder, ignore_errors=True)
