"""Outputs claimed by one run at a time: a lock on a hidden file beside each output
(``.<name>.lock``, holding the owner's process id and host) for the whole time a run writes it,
and a final placement that never replaces a file it was not allowed to replace.

The lock is the operating system's (``flock`` on POSIX, ``msvcrt.locking`` on Windows): it goes
with the process that held it, so the lock file a killed run left behind is simply taken over.
A second run on a claimed output either waits for it (``wait``: a ``-append`` to a GeoPackage,
so that every append lands) or fails at once in one line. A claim is re-entrant within one
thread (a chain claims its outputs first, then writes each under :func:`atomic_output
<lidartrees_gis.io.output.atomic_output>`, which claims again).
"""
from __future__ import annotations

import contextlib
import errno
import os
import socket
import threading
import time
import warnings
from pathlib import Path

from ..errors import DataWarning, OutputError, OutputExistsError

#: seconds between two tries of a waiting claim
POLL = 0.2

_HELD: dict = {}  # (resolved path, thread id) -> [fd, depth]
_HELD_LOCK = threading.Lock()


def lock_file(path) -> Path:
    """The hidden lock file of output ``path``."""
    p = Path(path)
    return p.parent / f".{p.name}.lock"


def _try_lock(fd) -> bool:
    """Take the lock on open file ``fd`` without waiting; False when another process holds it."""
    try:
        if os.name == "nt":  # pragma: no cover - Windows
            import msvcrt

            os.lseek(fd, 0, os.SEEK_SET)
            msvcrt.locking(fd, msvcrt.LK_NBLCK, 1)
        else:
            import fcntl

            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except (BlockingIOError, PermissionError):
        return False
    except OSError as exc:  # Windows says EACCES/EDEADLOCK when the byte is locked
        if exc.errno in (errno.EACCES, errno.EAGAIN, getattr(errno, "EDEADLOCK", -1)):
            return False
        raise
    return True


def _holder(lock: Path) -> str:
    """Who holds ``lock``, as its file says (``pid N on HOST``)."""
    try:
        text = lock.read_bytes()[8:200].decode("utf-8", "replace").split()
        return f"process {text[0]} on {text[1]}" if len(text) >= 2 else "another process"
    except OSError:
        return "another process"


def _acquire(path: Path, wait: bool, param: str):
    """The open, locked lock file of ``path`` (its descriptor), or None where the file system
    has no locks (the final placement still never replaces a file unasked)."""
    lock, warned = lock_file(path), False
    while True:
        try:
            fd = os.open(lock, os.O_RDWR | os.O_CREAT, 0o666)
        except OSError:  # a folder we may write outputs in but not lock files: no lock
            return None
        try:
            got = _try_lock(fd)
        except OSError:  # no locks on this file system (some network shares)
            os.close(fd)
            return None
        if not got:
            holder = _holder(lock)
            os.close(fd)
            if not wait:
                raise OutputError(f"{param}: {path} is being written by another run ({holder}); "
                                  "wait for it to end or write to another file")
            if not warned:
                warnings.warn(DataWarning(f"{param}: {path} is being written by another run "
                                          f"({holder}); waiting for it to end"), stacklevel=4)
                warned = True
            time.sleep(POLL)
            continue
        try:  # the file may have been removed by the run that held it: lock the one there now
            same = os.stat(lock).st_ino == os.fstat(fd).st_ino
        except OSError:
            same = False
        if not same:
            os.close(fd)
            continue
        with contextlib.suppress(OSError):
            os.lseek(fd, 8, os.SEEK_SET)  # after the locked byte (Windows locks a range)
            os.write(fd, f"{os.getpid()} {socket.gethostname()}\n".encode().ljust(120))
        return fd


def _release(path: Path, fd) -> None:
    if fd is None:
        return
    lock = lock_file(path)
    with contextlib.suppress(OSError):  # removed while still ours: a waiter then locks anew
        if os.stat(lock).st_ino == os.fstat(fd).st_ino:
            os.unlink(lock)
    os.close(fd)  # drops the lock
    if os.name == "nt":  # pragma: no cover - an open file cannot be removed there
        with contextlib.suppress(OSError):
            os.unlink(lock)


@contextlib.contextmanager
def claim_output(path, *, wait: bool = False, param: str = "OUTPUT"):
    """Hold ``path`` for this run while the block runs.

    Parameters
    ----------
    path : str or Path
        The output.
    wait : bool
        Wait while another run holds it (``-append``); else raise :class:`OutputError` at once.
    param : str
        The option named in the message.
    """
    p = Path(path)
    key = (str(p.parent.resolve() / p.name), threading.get_ident())
    with _HELD_LOCK:
        held = _HELD.get(key)
        if held is not None:
            held[1] += 1
    if held is not None:
        try:
            yield
        finally:
            with _HELD_LOCK:
                held[1] -= 1
        return
    fd = _acquire(p, wait, param)
    with _HELD_LOCK:
        _HELD[key] = [fd, 1]
    try:
        yield
    finally:
        with _HELD_LOCK:
            del _HELD[key]
        _release(p, fd)


#: the errors of a file system (or an output) that takes no hard links
_NO_LINKS = {getattr(errno, n) for n in ("EPERM", "ENOTSUP", "EOPNOTSUPP", "ENOSYS", "EMLINK",
                                         "EXDEV", "EINVAL", "EISDIR") if hasattr(errno, n)}


def place(tmp, path, replace: bool, param: str = "OUTPUT") -> None:
    """Move the finished ``tmp`` to ``path``; unless ``replace``, never over an existing file
    (a hard link fails when the name is taken; where there are none, the check and the rename
    are made under the output's claim)."""
    if replace:
        os.replace(tmp, path)
        return
    try:
        os.link(tmp, path)
    except FileExistsError:
        raise OutputExistsError(f"{param}: {path}: output exists (written meanwhile by another "
                                "run); use -overwrite to replace it") from None
    except OSError as exc:  # no hard links here (FAT, some shares, a folder output)
        if exc.errno not in _NO_LINKS:  # a full disk, no permission: the error as it is
            raise
        if os.path.lexists(path):
            raise OutputExistsError(f"{param}: {path}: output exists (written meanwhile by "
                                    "another run); use -overwrite to replace it") from None
        os.rename(tmp, path)  # Windows: fails rather than replace
        return
    os.unlink(tmp)
