"""Progress and cancellation protocol.

Library functions take ``progress=None`` or an object with ``update(fraction, message="")``
and ``canceled()``. Adapters: :class:`NullProgress` (silent), :class:`TqdmProgress` (a bar on
stderr for the CLI) and, in the QGIS provider, one over ``QgsProcessingFeedback``.
"""
from __future__ import annotations

import sys

from .errors import Cancelled


class NullProgress:
    """Progress sink that reports nothing and is never cancelled."""

    def update(self, fraction: float, message: str = "") -> None:  # noqa: D401
        pass

    def canceled(self) -> bool:
        return False


class TqdmProgress(NullProgress):
    """A progress bar on stderr (tqdm), 0-100 %."""

    def __init__(self, desc: str = "", disable: bool = False):
        from tqdm import tqdm

        class _Bar(tqdm):
            # no monitor thread: the bar is refreshed by update(), and a second thread would
            # keep the local Dask workers from being forked (tiled.worker_start_method)
            monitor_interval = 0

        self._bar = _Bar(total=100, desc=desc, file=sys.stderr, disable=disable,
                         bar_format="{l_bar}{bar}| {n:.0f}% [{elapsed}] {postfix}", leave=False)

    def update(self, fraction: float, message: str = "") -> None:
        n = max(0.0, min(100.0, 100.0 * float(fraction)))
        self._bar.n = n
        if message:
            self._bar.set_postfix_str(message, refresh=False)
        self._bar.refresh()

    def close(self) -> None:
        self._bar.close()


class SubProgress(NullProgress):
    """Maps 0-1 of a sub-task onto ``[start, stop]`` of a parent progress."""

    def __init__(self, parent, start: float, stop: float):
        self.parent = as_progress(parent)
        self.start, self.stop = start, stop

    def update(self, fraction: float, message: str = "") -> None:
        self.parent.update(self.start + (self.stop - self.start) * fraction, message)

    def canceled(self) -> bool:
        return self.parent.canceled()


def as_progress(progress) -> NullProgress:
    """Return ``progress`` or a :class:`NullProgress` when it is None."""
    return NullProgress() if progress is None else progress


def check_cancel(progress) -> None:
    """Raise :class:`Cancelled` when ``progress`` reports a cancel request."""
    if progress is not None and progress.canceled():
        raise Cancelled("cancelled by the user")


class LineProgress(NullProgress):
    """Machine-readable progress for a parent process: ``PROGRESS <percent> <message>`` lines on
    stderr (used by the QGIS provider, which runs the CLI in a subprocess)."""

    def __init__(self, stream=None):
        self.stream = stream or sys.stderr
        self._last = None

    def update(self, fraction: float, message: str = "") -> None:
        pct = round(max(0.0, min(100.0, 100.0 * float(fraction))), 1)
        if (pct, message) != self._last:
            self._last = (pct, message)
            print(f"PROGRESS {pct:.1f} {message}", file=self.stream, flush=True)
