"""Running tasks over tiles: in this process, on a local ``dask.distributed`` cluster or on an
existing one (lidR's ``future`` plan, Dask here). The task functions know nothing of where they
run; the runner sends the catalog to the workers once and hands results back as they finish."""
from __future__ import annotations

import os

from ..progress import SubProgress, as_progress, check_cancel
from .catalog import Catalog
from .source import READ_CACHE


#: below this many points a run stays in the calling process unless ``workers`` or
#: ``scheduler`` say otherwise: starting a local cluster (0.6 s forked, 1.2 s spawned) costs
#: more than the second core saves. Measured on 2 cores with forked workers, Megaplot copies:
#: 0.16 M points 1.5-1.6 s in one process, 2.0 s on two workers; 0.49 M 2.2 / 2.3-2.5 s;
#: 0.98 M 3.4-3.6 / 3.0-3.4 s; 2.0 M 6.0 / 4.9 s (spawned workers: 3.2 s at 0.16 M)
LOCAL_BELOW_POINTS = 1_000_000


def default_workers(workers, scheduler, count: int):
    """``workers`` as given; when neither it, ``scheduler`` nor ``LIDARTREES_WORKERS`` is set,
    1 (this process) for fewer than :data:`LOCAL_BELOW_POINTS` points, else None (all cores)."""
    if workers or scheduler or os.environ.get("LIDARTREES_WORKERS"):
        return workers
    return 1 if count < LOCAL_BELOW_POINTS else None


#: a process using more memory than this (bytes) spawns its local workers instead of forking
#: them: a forked worker's resident size counts the pages it shares with this process, and
#: Dask's memory monitor would take them for the worker's own (the command itself uses about
#: 300 MB when it starts the cluster)
FORK_MAX_RSS = 1 << 30


def worker_start_method() -> str:
    """How a local cluster starts its worker processes: Dask's own setting when it is not the
    default ``spawn``; else ``fork`` where it is safe (Linux, no other Python thread, no Qt and
    less than :data:`FORK_MAX_RSS` resident in this process: the workers inherit its imported
    library instead of starting a new interpreter and importing it again, which on 2 cores took
    CPU from the tiles), else ``spawn``. Measured at 16 M points on 2 workers: 26.1-26.8 s
    forked, 27.6-27.8 s spawned (the workers' CPU 44.7-44.8 s against 46.0-47.5 s)."""
    import sys
    import threading

    import dask
    import psutil

    method = dask.config.get("distributed.worker.multiprocessing-method", "spawn")
    if method != "spawn":
        return method
    safe = (sys.platform.startswith("linux") and threading.active_count() == 1
            and not any(m in sys.modules for m in ("PyQt5", "PyQt6", "qgis"))
            and psutil.Process().memory_info().rss < FORK_MAX_RSS)
    return "fork" if safe else "spawn"


def _client(workers, scheduler):
    from dask.distributed import Client, LocalCluster

    if scheduler:
        return Client(scheduler), None
    import logging

    import dask

    # glibc's own malloc settings in the workers: the nanny's MALLOC_TRIM_THRESHOLD_ (memory
    # back to the system at once) also fixes the mmap threshold, so every array of a tile was a
    # fresh mapping to fault in (5x the page faults, each task a third slower than in one
    # process); and no statistical profiler sampling the task's stack every 10 ms
    env = {k: v for k, v in (dask.config.get("distributed.nanny.pre-spawn-environ") or {}).items()
           if k != "MALLOC_TRIM_THRESHOLD_"}
    with dask.config.set({"distributed.worker.profile.enabled": False,
                          "distributed.nanny.pre-spawn-environ": env,
                          "distributed.worker.multiprocessing-method": worker_start_method()}):
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                               dashboard_address=None, silence_logs=logging.ERROR)
    return Client(cluster), cluster


class TileRunner:
    """Runs tasks ``fn(item, *args)``: in this process (``workers=1``), on a local Dask cluster
    of ``workers`` processes (default: all cores) or on an existing cluster (``scheduler``).
    Use it as a context manager so the cluster is started once for a whole run (the area's
    windows, then the tiles) and closed at the end. A local cluster is started when there are
    tasks to share (two or more at once): a run of one task stays in this process."""

    def __init__(self, workers=None, scheduler=None):
        self.workers = int(workers or os.environ.get("LIDARTREES_WORKERS", 0) or os.cpu_count() or 1)
        self.scheduler = scheduler or None
        self.client = self.cluster = None

    def __enter__(self):
        if self.scheduler:
            self.start()
        return self

    def start(self) -> None:
        """Connect to the scheduler or start the local cluster (once)."""
        if self.client is None and (self.workers > 1 or self.scheduler):
            self.client, self.cluster = _client(self.workers, self.scheduler)

    def __exit__(self, *exc):
        READ_CACHE.clear()  # this process's decompressed files (workers end with the cluster)
        if self.client is not None:
            self.client.close()
        if self.cluster is not None:
            self.cluster.close()
        self.client = self.cluster = None

    def map(self, fn, items, args=(), *, progress=None, ordered=False, label="tile",
            inner_progress=False):
        """Yield ``fn(item, *args)`` for every item, as they finish (``ordered``: in order).
        A cancel (or Ctrl-C) cancels the remaining tasks. With ``inner_progress``, tasks run in
        this process get ``progress=`` their share of ``progress`` (a task on Dask reports when
        it ends)."""
        prog = as_progress(progress)
        n = len(items)
        if n > 1:
            self.start()
        if self.client is None:
            for k, it in enumerate(items):
                check_cancel(prog)
                kw = {"progress": SubProgress(prog, k / n, (k + 1) / n)} if inner_progress else {}
                yield fn(it, *args, **kw)
                prog.update((k + 1) / n, f"{label} {k + 1}/{n}")
            return
        from dask.distributed import as_completed

        futs = []
        try:
            # the arguments (the catalog above all) go to the workers once, not with every
            # task: the client and scheduler held a copy per task, files x tiles in all
            shared = [self.client.scatter(a, broadcast=True, hash=False)
                      if isinstance(a, Catalog) else a for a in args]
            # each worker takes a contiguous run of the (row by row) tiles, so the files it
            # decompressed for one tile are still in its read cache for the next; idle workers
            # still take over the others' tasks at the end
            addrs = sorted(self.client.scheduler_info(n_workers=-1)["workers"])
            block = max(1, -(-n // max(len(addrs), 1)))
            futs = [self.client.submit(fn, it, *shared, pure=False,
                                       workers=[addrs[k // block]] if addrs else None,
                                       allow_other_workers=True)
                    for k, it in enumerate(items)]
            for k, f in enumerate(futs if ordered else as_completed(futs)):
                check_cancel(prog)
                yield f.result()
                f.release()
                prog.update((k + 1) / n, f"{label} {k + 1}/{n}")
        finally:
            if futs:
                self.client.cancel(futs)
