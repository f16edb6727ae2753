"""A local cluster's workers end with the process that started them."""

from __future__ import annotations

import os

from distributed.diagnostics.plugin import WorkerPlugin


class ParentWatch(WorkerPlugin):
    """A Dask worker plugin for a local cluster's workers: a worker whose calling process is
    gone (killed with SIGKILL, its nannies with it) ends within :attr:`PERIOD` seconds instead
    of trying to reach the lost scheduler for minutes, its comm errors unseen."""

    #: seconds between two looks at the calling process
    PERIOD = 0.5

    def __init__(self, pid: int):
        self.pid = pid

    def setup(self, worker=None) -> None:
        import threading

        threading.Thread(target=self._watch, name="lidartrees-parent-watch", daemon=True).start()

    def _watch(self) -> None:
        import time

        import psutil

        while True:
            try:
                alive = psutil.Process(self.pid).status() != psutil.STATUS_ZOMBIE
            except psutil.Error:
                alive = False
            if not alive:
                os._exit(0)
            time.sleep(self.PERIOD)
