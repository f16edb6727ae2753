"""Running tasks over tiles: in this process, on a local ``dask.distributed`` cluster or on an
existing one (lidR's ``future`` plan, Dask here). The task functions know nothing of where they
run; the runner sends the catalog to the workers once and hands results back as they finish."""
from __future__ import annotations

import os

from ..errors import Cancelled, InputError, LidarTreesError, ReadError
from ..progress import SubProgress, as_progress, check_cancel
from .catalog import Catalog
from . import source
from .source import READ_CACHE, SHARED_CACHE_ENV


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
        # the workers' log lines (a task's error with its traceback, a worker dying with the
        # calling process) stay off the user's terminal: a task's error comes back with its
        # result and is told in one line (TileError)
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                               dashboard_address=None, silence_logs=logging.CRITICAL)
    client = Client(cluster)
    from ._watch import ParentWatch

    client.register_plugin(ParentWatch(os.getpid()), name="lidartrees-parent-watch")
    return client, cluster


def _quiet_logs():
    """Silence the log lines of ``distributed`` (and its dashboard's) in this process until the
    returned stack is closed: no raw ``distributed.client - WARNING`` on the user's terminal; what
    matters (a lost worker, a failed tile) is told in one line by the runner."""
    import contextlib
    import logging

    stack = contextlib.ExitStack()
    try:
        from distributed.utils import silence_logging_cmgr
    except ImportError:  # pragma: no cover - an older distributed
        return stack
    for root in ("distributed", "bokeh"):
        stack.enter_context(silence_logging_cmgr(logging.CRITICAL, root=root))
    return stack


#: a shared read cache's folder: this prefix, the process id, a random part
SHARED_PREFIX = "lidartrees-reads-"


def _remove_orphans(folder) -> int:
    """Remove the shared read caches in ``folder`` whose process is gone (a run killed before it
    could remove its own); returns how many."""
    import shutil

    n = 0
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return 0
    for e in entries:
        if not e.name.startswith(SHARED_PREFIX):
            continue
        pid = e.name[len(SHARED_PREFIX):].split("-", 1)[0]
        if not pid.isdigit():
            continue
        try:
            os.kill(int(pid), 0)
            continue  # alive (or another user's process): left alone
        except ProcessLookupError:
            pass
        except OSError:
            continue
        shutil.rmtree(e.path, ignore_errors=True)
        n += 1
    return n


def worker_runs(weights, workers: int) -> list:
    """The worker of each item: ``workers`` contiguous runs of the items (in their order) of
    about equal total weight (each item goes to the run holding the middle of its weight).

    >>> worker_runs([1, 1, 1, 1], 2), worker_runs([3, 1, 1, 1], 2)
    ([0, 0, 1, 1], [0, 1, 1, 1])
    """
    w = [max(float(v), 0.0) for v in weights]
    total = sum(w)
    if not total > 0:
        w, total = [1.0] * len(w), float(len(w))
    out, acc = [], 0.0
    for v in w:
        out.append(min(int((acc + 0.5 * v) / total * workers), workers - 1))
        acc += v
    return out


def tile_name(item, label: str = "tile") -> str:
    """A tile (or a measurement window, a box) in words for messages."""
    core = getattr(item, "core", None)
    if core is None and isinstance(item, tuple) and len(item) == 4:
        core = item
    if core is None:
        return f"{label} {item}"
    x0, y0, x1, y1 = core
    where = (f"(x {x0:.0f} to {x1:.0f}, y {y0:.0f} to {y1:.0f})").replace("inf", "edge")
    if getattr(item, "core", None) is not None:
        return f"{label} {item.index[0]},{item.index[1]} {where}"
    return f"{label} {where}"


def _cause(exc) -> str:
    """An error of a task in one line: a worker lost again and again in words."""
    if type(exc).__name__ == "KilledWorker":
        return ("the workers running it died each time (killed, out of memory or crashed; their "
                "logs tell why)")
    if isinstance(exc, LidarTreesError):
        return str(exc)
    return f"{type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}"


class TileError(LidarTreesError, RuntimeError):
    """A tile failed (twice on Dask): names the tile and the error."""

    def __init__(self, item, exc, label="tile"):
        self.item, self.cause, self.why = item, exc, _cause(exc)
        super().__init__(f"{tile_name(item, label)} failed: {self.why}")


def failures_text(errors, label="tile") -> str:
    """Failed tasks in a few words: grouped by their error, each with the items it struck."""
    groups = {}
    for e in errors:
        groups.setdefault(e.why, []).append(e.item)
    parts = []
    for why, items in groups.items():
        names = [getattr(i, "index", None) for i in items]
        names = [f"{n[0]},{n[1]}" if isinstance(n, tuple) else tile_name(i, label)
                 for n, i in zip(names, items)]
        more = f" and {len(names) - 4} more" if len(names) > 4 else ""
        parts.append(f"{why} ({len(items)} {label}(s): {'; '.join(names[:4])}{more})")
    return " | ".join(parts)


class FailedTiles(LidarTreesError, RuntimeError):
    """``on_error='skip'``: the run wrote what the other tiles gave; these tiles failed.
    ``result`` holds the run's result (its outputs lack the failed tiles' trees or cells)."""

    def __init__(self, failed, result=None, total=None):
        self.failed, self.result = failed, result
        of = f" of {total}" if total else ""
        super().__init__(f"{len(failed)}{of} tiles failed and are missing from the outputs "
                         f"(-on_error skip): {failures_text(failed)}")


def _hold(obj):
    """A task whose result is ``obj`` (the catalog): held by the scheduler's task, so when the
    workers holding it are lost it is computed again (scattered data would be lost for good)."""
    return obj


def _unreadable(paths) -> list:
    """The paths this process (a worker) cannot open for reading, with the reason."""
    bad = []
    for p in paths:
        try:
            with open(p, "rb") as fh:
                fh.read(1)
        except OSError as exc:
            bad.append(f"{p} ({exc.strerror or exc})")
    return bad


class WorkerWatch:
    """Which workers of a cluster left and joined during a run, told in one line at the end;
    and a line when no worker is left. Both come from the scheduler itself: the workers it
    holds now (asked at most once a second; the client's own cached view is refreshed in the
    background without the workers, which once made a run say "no worker is connected" while
    one was, and count workers lost and joined that never were), and the workers it added and
    removed during the run (its event log), so a worker killed between two looks counts too."""

    def __init__(self, client):
        self.client = client
        self.start = self.now = self._workers() or set()
        self.since = self._last_event()
        self.left, self.joined, self._t, self._empty_since = set(), set(), 0.0, None

    def _workers(self):
        """The workers the scheduler holds now, or None when it cannot say (busy, gone)."""
        try:
            try:
                info = self.client.sync(self.client.scheduler.identity, n_workers=-1)
            except TypeError:  # an older scheduler
                info = self.client.sync(self.client.scheduler.identity)
            return set(info["workers"])
        except Exception:  # noqa: BLE001 - the scheduler busy or gone: keep the last view
            return None

    def _events(self):
        """``[(time, action, worker)]`` of the workers the scheduler added and removed, or None."""
        try:
            events = self.client.get_events("all")
        except Exception:  # noqa: BLE001 - no event log (an older scheduler): polls only
            return None
        return [(t, m["action"], m.get("worker")) for t, m in events
                if isinstance(m, dict) and m.get("action") in ("add-worker", "remove-worker")]

    def _last_event(self) -> float:
        ev = self._events()
        return max((t for t, _, _ in ev), default=float("-inf")) if ev is not None else None

    def poll(self, force=False) -> None:
        import time

        t = time.monotonic()
        if not force and t - self._t < 1.0:
            return
        self._t = t
        now = self._workers()
        if now is None:
            return
        self.left |= self.now - now
        self.joined |= now - self.now
        self.now = now
        if not now and self._empty_since is None:
            self._empty_since = t
            _warn(f"no worker is connected to the scheduler {self.client.scheduler.address}; "
                  "the tiles wait for workers (Ctrl-C stops)")
        elif now:
            self._empty_since = None

    def changes(self) -> tuple:
        """``(workers removed, workers added)`` by the scheduler since the start."""
        self.poll(force=True)
        ev = self._events() if self.since is not None else None
        if ev is None:
            return self.left, self.joined
        ev = [e for e in ev if e[0] > self.since and e[2]]
        return ({w for _, a, w in ev if a == "remove-worker"},
                {w for _, a, w in ev if a == "add-worker"})

    def report(self) -> str | None:
        left, joined = self.changes()
        if not left and not joined:
            return None
        return (f"{len(left)} worker(s) lost and {len(joined)} joined during the run "
                f"(started with {len(self.start)}, ended with {len(self.now)}); their tiles ran "
                "again, the results are complete")


def _warn(message: str) -> None:
    import warnings

    from ..errors import DataWarning

    warnings.warn(DataWarning(message), stacklevel=3)


class TileRunner:
    """Runs tasks ``fn(item, *args)``: in this process (``workers=1``), on a local Dask cluster
    of ``workers`` processes (default: all cores) or on an existing cluster (``scheduler``).
    Use it as a context manager so the cluster is started once for a whole run (the area's
    windows, then the tiles) and closed at the end. A local cluster is started when there are
    tasks to share (two or more at once): a run of one task stays in this process.

    On Dask a task that raises is run once more (``retries``); a task whose worker is lost is
    run again elsewhere (up to the scheduler's ``allowed-failures``). A task that still fails
    stops the run with a :class:`TileError` naming it (``on_error='stop'``), or is set aside in
    :attr:`failed` while the others go on (``on_error='skip'``; the chain then raises
    :class:`FailedTiles` once its outputs are written). ``checkpoint`` keeps each result as it
    comes and gives back the ones a killed run already made (``-resume``).
    """

    #: Dask runs a task that raised this many more times before it counts as failed
    RETRIES = 1

    def __init__(self, workers=None, scheduler=None, on_error="stop", checkpoint=None):
        self.workers = int(workers or os.environ.get("LIDARTREES_WORKERS", 0) or os.cpu_count() or 1)
        self.scheduler = scheduler or None
        if on_error not in ("stop", "skip"):
            raise InputError(f"-on_error: expected stop or skip, got {on_error!r}")
        self.on_error, self.checkpoint = on_error, checkpoint
        self.client = self.cluster = self.watch = None
        self.failed, self._left_out = [], []
        self._shared = None  # the folder of this run's shared read cache (see share_reads)
        self._quiet = None  # distributed's log lines silenced while a client runs
        self._told = set()  # the measurement windows already told as left out

    def __enter__(self):
        if self.scheduler:
            self.start()
        return self

    def start(self) -> None:
        """Connect to the scheduler or start the local cluster (once)."""
        if self.client is None and (self.workers > 1 or self.scheduler):
            if self._quiet is None:
                self._quiet = _quiet_logs()
            self.client, self.cluster = _client(self.workers, self.scheduler)
            if self.scheduler:
                self.watch = WorkerWatch(self.client)

    def share_reads(self) -> None:
        """Give this run's local processes a :class:`~lidartrees_gis.catalog.source.
        SharedReadCache` (a temporary folder named in the environment the workers inherit),
        before they start; not on a scheduler's cluster (other machines), nor inside a run
        that has one already. Measured at 16 M points (197 files) on two workers: 263 file
        decompressions without it, 197 with it. The folders of killed runs (their process
        gone) are removed here."""
        import tempfile

        if (self.scheduler or self._shared is not None or os.environ.get(SHARED_CACHE_ENV)
                or source.SHARED_CACHE_BYTES <= 0):
            return
        _remove_orphans(tempfile.gettempdir())
        self._shared = tempfile.mkdtemp(prefix=f"{SHARED_PREFIX}{os.getpid()}-")
        os.environ[SHARED_CACHE_ENV] = self._shared
        # decompressed files go there only for other processes to read (a local cluster)
        os.environ[source.SHARED_POINTS_ENV] = "1" if self.workers > 1 else "0"

    def __exit__(self, *exc):
        READ_CACHE.clear()  # this process's decompressed files (workers end with the cluster)
        if self.watch is not None and exc[0] is None:
            line = self.watch.report()
            if line:
                _warn(line)
        if self.client is not None:
            self.client.close()
        if self.cluster is not None:
            self.cluster.close()
        self.client = self.cluster = self.watch = None
        if self._quiet is not None:
            self._quiet.close()
            self._quiet = None
        if self._shared is not None:
            import shutil

            if os.environ.get(SHARED_CACHE_ENV) == self._shared:
                del os.environ[SHARED_CACHE_ENV]
                os.environ.pop(source.SHARED_POINTS_ENV, None)
            shutil.rmtree(self._shared, ignore_errors=True)
            self._shared = None

    def check_readable(self, files) -> None:
        """On an existing cluster: every worker can read every input file (same absolute path,
        a shared file system), else an error naming the worker and the file."""
        if self.scheduler is None or self.client is None or not files:
            return
        got = self.client.run(_unreadable, [str(f) for f in files])
        for worker, bad in sorted(got.items()):
            if bad:
                more = f" and {len(bad) - 1} more" if len(bad) > 1 else ""
                raise ReadError(f"worker {worker} cannot read {bad[0]}{more}: the workers must "
                                "see the input files at the same absolute path (a shared file "
                                "system)")

    def _failure(self, item, exc, label="tile"):
        """A task failed for good: stop (the error names the tile) or set it aside: a tile is
        missing from the outputs (:attr:`failed`), a measurement window from the area's
        measurements (a sample: the tiles over the same data fail and are named)."""
        if self.on_error != "skip":
            if isinstance(exc, TileError) or (self.client is None and not self.scheduler):
                raise exc
            raise TileError(item, exc, label) from exc
        err = exc if isinstance(exc, TileError) else TileError(item, exc, label)
        (self.failed if label == "tile" else self._left_out).append(err)

    def map(self, fn, items, args=(), *, progress=None, ordered=False, label="tile",
            inner_progress=False, weights=None):
        """See :meth:`_map`; measurement windows set aside (``-on_error skip``) are told in one
        line at the end."""
        self._left_out = []
        yield from self._map(fn, items, args, progress=progress, ordered=ordered, label=label,
                             inner_progress=inner_progress, weights=weights)
        # told once: the same windows are measured twice (the density, then the surfaces)
        new = [e for e in self._left_out if (label, tile_name(e.item, label)) not in self._told]
        self._told |= {(label, tile_name(e.item, label)) for e in new}
        if new:
            _warn(f"{len(new)} of {len(items)} {label}s were left out of the area's "
                  f"measurements (-on_error skip): {failures_text(new, label)}")

    def _map(self, fn, items, args=(), *, progress=None, ordered=False, label="tile",
             inner_progress=False, weights=None):
        """Yield ``fn(item, *args)`` for every item, as they finish (``ordered``: in order).
        A cancel (or Ctrl-C) cancels the remaining tasks. With ``inner_progress``, tasks run in
        this process get ``progress=`` their share of ``progress`` (a task on Dask reports when
        it ends). Items whose task failed for good are left out with ``on_error='skip'``.
        ``weights``: each item's expected work (a tile's points), to give the workers runs of
        equal work (:func:`worker_runs`) rather than of equal length."""
        prog = as_progress(progress)
        items = list(items)
        n = len(items)
        ck = self.checkpoint if label == "tile" and not ordered else None
        done = ck.load(n) if ck is not None else {}
        todo = [k for k in range(n) if k not in done]
        for k in sorted(done):  # what a killed run made (-resume)
            yield done[k]
        finished = len(done)
        if len(todo) > 1:
            self.share_reads()
            self.start()
        if self.client is None:
            for k in todo:
                check_cancel(prog)
                kw = {"progress": SubProgress(prog, finished / n, (finished + 1) / n)} \
                    if inner_progress else {}
                try:
                    r = fn(items[k], *args, **kw)
                except (Exception,) as exc:  # noqa: BLE001 - named, or set aside with skip
                    if isinstance(exc, Cancelled):
                        raise
                    self._failure(items[k], exc, label)
                    continue
                if ck is not None:
                    ck.save(k, r)
                finished += 1
                yield r
                prog.update(finished / n, f"{label} {finished}/{n}")
            return
        from dask.distributed import as_completed

        futs, shared = [], []
        try:
            # the catalog goes to the workers once, not with every task (the client and
            # scheduler held a copy per task, files x tiles in all), as the result of a task:
            # lost with its workers it is computed again, where scattered data is gone for good
            shared = [self.client.submit(_hold, a, pure=False, retries=self.RETRIES)
                      if isinstance(a, Catalog) else a for a in args]
            # each worker takes a contiguous run of the (row by row) tiles, so the files it
            # decompressed for one tile are still in its read cache for the next; idle workers
            # still take over the others' tasks at the end; the runs hold about equal points
            # (weights), not equal counts of tiles: 16 M points on two workers 18.94 s against
            # 19.14 s (three runs each, alternating)
            addrs = sorted(self.client.scheduler_info(n_workers=-1)["workers"])
            run = worker_runs([1.0 if weights is None else float(weights[k]) for k in todo],
                              max(len(addrs), 1))
            # the client keeps every future until its result is written: a lost worker's
            # tasks are run again from them
            futs = [self.client.submit(fn, items[k], *shared, pure=False, retries=self.RETRIES,
                                       workers=[addrs[run[j]]] if addrs else None,
                                       allow_other_workers=True)
                    for j, k in enumerate(todo)]
            index = {f.key: k for f, k in zip(futs, todo)}
            for f in (futs if ordered else as_completed(futs)):
                check_cancel(prog)
                if self.watch is not None:
                    self.watch.poll()
                k = index[f.key]
                try:
                    r = f.result()
                except Exception as exc:  # noqa: BLE001 - named, or set aside with skip
                    self._failure(items[k], exc, label)
                    f.release()
                    continue
                if ck is not None:
                    ck.save(k, r)
                finished += 1
                yield r
                f.release()
                prog.update(finished / n, f"{label} {finished}/{n}")
        finally:
            if futs:
                self.client.cancel(futs + [a for a in shared if type(a).__name__ == "Future"])
