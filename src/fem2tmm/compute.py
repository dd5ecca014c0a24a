"""Where the work units run: in this process (``serial``, the default, never imports Dask) or on a Dask cluster
(``local``: a ``dask.distributed.LocalCluster`` on this machine's cores; an address ``tcp://host:8786``: a
cluster the user already runs, with dask-jobqueue, Kubernetes, SSH ...).

Stages do not know where they run: they call :func:`map_units` ``(fn, items, shared=...)``, which runs
``fn(item, **shared)`` for every item on the executor installed by :func:`using` (serial when none) and
returns the results *in item order*.  A unit's result depends only on its item and the shared data (each unit
seeds its generator from its identity, e.g. ``SeedSequence(seed, spawn_key=(stream, 1, batch))`` in the ray
tracer), and callers combine results in item order, so the output is bit-for-bit the same on every scheduler
and worker count.

On Dask, ``shared`` objects (K, a trace's job ...) are scattered once per call to :data:`REPLICAS` workers (the
others fetch them from their peers when they run a unit), not sent with each task, and objects that many calls
share (the ray scene) once per executor to every worker
(:meth:`DaskExecutor.keep`); a unit whose worker dies is re-run elsewhere (same item, same result); Ctrl-C cancels
the submitted units.  Scenes rebuild their ray-tracing structures where they are unpickled (once per worker).

A :class:`DaskExecutor` may be used from several threads at once (the pipeline runs the load cases of a
multi-case file concurrently, so that the units of several cases are in flight); :meth:`DaskExecutor.cancel`
cancels every call in flight and refuses new ones.
"""

from __future__ import annotations

import contextvars
import logging
import os
import sys
import threading
from contextlib import contextmanager
from typing import Any, Callable, Sequence

from .errors import Fem2TmmError
from .progress import report, report_units

#: seconds to wait for a Dask scheduler before giving up (the whole check stays within 10 s)
CONNECT_TIMEOUT = 3.0
#: how long a local cluster's run waits for all its workers to register (s)
LOCAL_START_TIMEOUT = 60.0
#: a unit that raised is re-run this many times (a unit on a worker that died is always re-run by Dask)
RETRIES = 1
#: workers that hold a copy of each map call's shared data (a trace's job): enough to survive one dead worker
#: without sending every trace's job to every worker (at 10^6 faces a job is ~0.12 GB)
REPLICAS = 2


class SerialExecutor:
    """Runs every unit in this process, in order.  ``workers`` is 1."""

    name = "serial"
    workers = 1
    distributed = False

    def map(self, fn: Callable, items: Sequence, shared: dict | None = None, what: str = "work units") -> list:
        shared = shared or {}
        out = []
        for k, item in enumerate(items):
            out.append(fn(item, **shared))
            report(k + 1, len(items), what)
        return out

    def keep(self, key, obj):
        """``obj`` itself (in this process nothing is sent; :meth:`DaskExecutor.keep` scatters it once)."""
        return obj

    def close(self) -> None:
        pass


class Cancelled(Exception):
    """A :meth:`DaskExecutor.map` call stopped by :meth:`DaskExecutor.cancel` (another thread failed)."""


class DaskExecutor:
    """Runs units as Dask tasks on ``client``'s cluster (``cluster``: a LocalCluster we started and close).
    Thread-safe; progress goes to :func:`~fem2tmm.progress.report_units` (``what`` "... on N workers")."""

    distributed = True

    def __init__(self, client, cluster=None, name: str = "dask"):
        self.client = client
        self.cluster = cluster
        self.name = name
        self._cancelled = threading.Event()
        self._lock = threading.Lock()
        self._inflight: dict[int, list] = {}  # id of a map call -> its futures (tasks and scattered data)
        self._kept: dict = {}  # key -> future of a shared object scattered once for the executor's life (keep)
        self._turn = 0  # which workers receive the next map call's shared data (REPLICAS of them, in turn)

    def cancel(self) -> None:
        """Cancel the units of every :meth:`map` call in flight (they raise :class:`Cancelled`) and refuse new
        calls."""
        self._cancelled.set()
        with self._lock:
            futures = [f for fs in self._inflight.values() for f in fs]
        if futures:
            self.client.cancel(futures, force=True)

    def check_cancelled(self) -> None:
        """Raise :class:`Cancelled` once :meth:`cancel` was called."""
        if self._cancelled.is_set():
            raise Cancelled("cancelled: another load case failed or the run was interrupted")

    def keep(self, key, obj):
        """A future of ``obj`` on every worker, scattered on the first call with this ``key`` and reused by every
        later :meth:`map` of this executor (e.g. a ray scene, by its geometry digest: the traces of all load
        cases and orbit positions send it once).  Scattered again if the workers that held it are gone."""
        with self._lock:
            fut = self._kept.get(key)
            if fut is None or fut.status != "finished":
                fut = self._kept[key] = self.client.scatter(obj, broadcast=True, hash=False)
            return fut

    @property
    def workers(self) -> int:
        """The workers the scheduler has now (asked of it: the client's ``scheduler_info()`` is a copy refreshed every
        few seconds, and a reduction that read one worker of a LocalCluster(2) still starting cut its clusters into 4
        batches instead of 7; tests/test_cases_pipeline.py counts them)."""
        try:
            return len(self.client.nthreads())
        except Exception:  # (a scheduler that does not answer: the last copy)
            return len(self.client.scheduler_info().get("workers", {}))

    def map(self, fn: Callable, items: Sequence, shared: dict | None = None, what: str = "work units") -> list:
        import dask
        from distributed import as_completed

        items = list(items)
        if not items:
            return []
        self.check_cancelled()
        client = self.client
        from distributed import Future

        scattered, futures, call = {}, [], object()
        kept = {k: v for k, v in (shared or {}).items() if isinstance(v, Future)}  # from keep(): not ours to release
        try:
            # on REPLICAS workers (taken in turn, so that the calls spread): one may die; the others fetch the data
            # from them when they run a unit; sent to both in one scatter
            names = sorted(client.scheduler_info().get("workers", {}))
            with self._lock:
                first, self._turn = self._turn, self._turn + 1
            targets = [names[(first + i) % len(names)] for i in range(min(REPLICAS, len(names)))] or None
            for k, v in (shared or {}).items():
                if k not in kept:
                    scattered[k] = client.scatter(v, workers=targets, broadcast=True, hash=False)
            scattered_here = list(scattered.values())
            scattered.update(kept)
            # the items go with the tasks, on purpose: the scheduler re-runs a unit whose worker died from them
            # (a batch of clusters of the local reduction carries its slices of the model, ~10 MB)
            with dask.config.set({"distributed.admin.large-graph-warning-threshold": "64 GiB"}):
                futures = client.map(fn, items, pure=False, retries=RETRIES, **scattered)
            with self._lock:
                self._inflight[id(call)] = futures + scattered_here
            self.check_cancelled()  # cancelled while submitting: cancel() may have missed these
            label = f"{what} on {self.workers} workers"
            for k, _ in enumerate(as_completed(futures)):
                self.check_cancelled()
                report_units(k + 1, len(futures), label)
            self.check_cancelled()
            return client.gather(futures)
        except BaseException:
            client.cancel(futures + [v for k, v in scattered.items() if k not in kept], force=True)
            raise
        finally:
            with self._lock:
                self._inflight.pop(id(call), None)
            del futures
            scattered.clear()

    def release_kept(self) -> None:
        """Drop the objects :meth:`keep` scattered (the workers free them once no task needs them)."""
        with self._lock:
            kept, self._kept = list(self._kept.values()), {}
        for fut in kept:
            fut.release()

    def close(self) -> None:
        self.release_kept()
        try:
            self.client.close()
        finally:
            if self.cluster is not None:
                self.cluster.close()


_current: contextvars.ContextVar[Any] = contextvars.ContextVar("fem2tmm_executor", default=None)


def current():
    """The executor installed by :func:`using`, or a :class:`SerialExecutor`."""
    ex = _current.get()
    return SerialExecutor() if ex is None else ex


@contextmanager
def using(executor):
    """Install ``executor`` for the :func:`map_units` calls made inside the block."""
    token = _current.set(executor)
    try:
        yield executor
    finally:
        _current.reset(token)


def map_units(fn: Callable, items: Sequence, shared: dict | None = None, what: str = "work units") -> list:
    """``[fn(item, **shared) for item in items]`` on the current executor, results in item order.  ``fn`` and
    the items must be picklable (module-level functions, plain data) when the executor is distributed."""
    return current().map(fn, items, shared=shared, what=what)


def open_executor(scheduler: str = "serial", workers: int | None = None, timeout: float = CONNECT_TIMEOUT):
    """An executor for ``scheduler``: "serial", "local" (a LocalCluster of ``workers`` single-threaded processes,
    default one per core) or a Dask scheduler address.  Connection problems raise one :class:`Fem2TmmError`
    within ``timeout`` seconds, before any computation.  Close it with ``.close()``."""
    if scheduler == "serial":
        return SerialExecutor()
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        raise Fem2TmmError(f"scheduler {scheduler!r} needs Dask: pip install \"fem2tmm[cluster]\" "
                           "(or use --scheduler serial)") from None
    if scheduler == "local":
        n = int(workers or os.cpu_count() or 1)
        cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None,
                               silence_logs=logging.ERROR)
        try:
            client = Client(cluster, timeout=f"{timeout}s")
            # every worker registered before the first map (LocalCluster has started them: a formality, given a
            # busy machine's time rather than the connection timeout)
            client.wait_for_workers(n, timeout=max(timeout, LOCAL_START_TIMEOUT))
        except (OSError, TimeoutError) as exc:
            cluster.close()
            raise Fem2TmmError(f"the local Dask cluster of {n} workers did not come up (the client within "
                               f"{timeout:g} s, its workers within {max(timeout, LOCAL_START_TIMEOUT):g} s; "
                               f"{type(exc).__name__}): "
                               "try fewer workers or --scheduler serial") from None
        except BaseException:
            cluster.close()
            raise
        return DaskExecutor(client, cluster, name=f"local ({n} workers)")
    try:
        client = Client(scheduler, timeout=f"{timeout}s")
    except (OSError, TimeoutError) as exc:
        raise Fem2TmmError(f"cannot reach the Dask scheduler at {scheduler} within {timeout:g} s "
                           f"({type(exc).__name__}); start it, check the address, or use --scheduler serial"
                           ) from None
    return DaskExecutor(client, None, name=scheduler)


@contextmanager
def executing(scheduler: str = "serial", workers: int | None = None):
    """``with executing("local") as ex:`` opens an executor, installs it (:func:`using`) and closes it."""
    ex = open_executor(scheduler, workers)
    try:
        with using(ex):
            yield ex
    finally:
        ex.close()


#: load cases in flight at once on a Dask executor, per worker (each holds its FE model in this process)
CASES_PER_WORKER = 2


class CaseStore:
    """One case's view of the shared :class:`~fem2tmm.cache.StageCache`: records the ``(stage, key, how)`` the
    case used, in order, and stops (``check``, e.g. :meth:`~fem2tmm.compute.DaskExecutor.check_cancelled`) before
    computing a stage once the run is cancelled."""

    def __init__(self, store, check):
        self.store, self.check, self.uses = store, check, []

    def get_or_compute(self, stage: str, key: str, compute):
        def checked():
            self.check()
            return compute()

        value, how = self.store.get_or_compute(stage, key, checked)
        self.uses.append((stage, key, how))
        return value, how


def run_concurrently(ex, jobs: list, run_one: Callable, store, quiet: bool) -> list:
    """``[run_one(case, progress, mesh, store_view) for (case, progress, mesh) in jobs]`` (the pipeline's run of one
    case; ``store_view`` its :class:`CaseStore` of the stage cache ``store``, or None) with up to
    :data:`CASES_PER_WORKER` x workers cases in client threads at once, so that the work units of several cases are in flight on the Dask executor ``ex``; results in case
    order, each the same as in a sequential run (units are seeded by their identity; a shared stage is computed
    once, by whichever case gets there first, and each case's ``cache`` status is then set as a sequential run
    sets it: "computed" for the first case in case order that used an entry computed in this run).  One progress
    bar over every work unit.  The first case that fails cancels the others' units, which stop at their next
    unit or stage; its exception is raised (so is Ctrl-C, after cancelling the units)."""
    import contextvars
    from concurrent.futures import FIRST_EXCEPTION, ThreadPoolExecutor, wait

    from .progress import UnitsBar, reporting, reporting_units

    n = ex.workers
    bar = UnitsBar(f"work units on {n} worker{'s' if n != 1 else ''}", quiet=quiet)
    views = [None if store is None else CaseStore(store, ex.check_cancelled) for _ in jobs]

    def one(c, prog, m, view):
        with reporting(prog.callback()), reporting_units(bar):
            return run_one(c, prog, m, view)

    pool = ThreadPoolExecutor(max_workers=max(1, min(len(jobs), CASES_PER_WORKER * max(n, 1))),
                              thread_name_prefix="fem2tmm-case")
    futures = [pool.submit(contextvars.copy_context().run, one, c, prog, m, view)  # sees using(ex), reporting
               for (c, prog, m), view in zip(jobs, views)]
    error = None
    try:
        pending = set(futures)
        while pending and error is None:
            done, pending = wait(pending, timeout=0.25, return_when=FIRST_EXCEPTION)
            failed = [f for f in futures if f in done and f.exception() is not None]
            error = failed[0].exception() if failed else None
    except BaseException as exc:  # Ctrl-C while waiting
        error = exc
    finally:
        if error is not None:
            ex.cancel()
            for f in futures:
                f.cancel()
        pool.shutdown(wait=True)  # the running cases stop at their next unit (Cancelled)
        bar.close()
    if error is not None:
        raise error  # the first case's own exception (Fem2TmmError, KeyboardInterrupt ...), not a Cancelled
    results = [f.result() for f in futures]
    if not quiet:
        print(f"[fem2tmm] {bar.done} work units on {n} worker{'s' if n != 1 else ''}", file=sys.stderr, flush=True)
    if store is not None:  # the status a sequential run reports: the first case (in order) to use it computed it
        computed = {(st, k) for v in views for st, k, how in v.uses if how == "computed"}
        seen = set()
        for v, r in zip(views, results):
            for st, k, _ in v.uses:
                if (st, k) in computed:
                    r.cache[st] = "reused" if (st, k) in seen else "computed"
                    seen.add((st, k))
    return results


def cached_stage(prog, store, status: dict, stage: str, label: str, key, compute):
    """Stage ``stage`` of ``prog`` (:class:`~fem2tmm.progress.Progress`), timed: its value from the stage cache
    ``store`` under ``key()`` or ``compute()``d (and cached); records "computed" or "reused" in ``status``."""
    with prog.stage(stage, label):
        if store is None:
            value, how = compute(), "computed"
        else:
            value, how = store.get_or_compute(stage, key(), compute)
    status[stage] = how
    return value


class SceneShelf:
    """The ray scenes of one :func:`run`, shared by its load cases (and refinement rounds): a scene depends only on
    the geometry (the surface's points and faces, and the quadric fit; the optics come with each trace), so cases
    that share it build it once (on the baffle, a quadric scene is ~1.7 s and its sunlit areas ~0.8 s per case).
    Thread-safe: concurrent cases wanting the same scene wait for the one that builds it.  Keeps the ``size`` most
    recently built scenes (refinement rounds fit new quadrics each round: their older scenes are let go)."""

    def __init__(self, size: int = 4):
        self._scenes: dict = {}
        self._locks: dict = {}
        self._lock = threading.Lock()
        self.size = size

    def get(self, key: tuple, build):
        """The scene under ``key``, ``build()``-ing it on first use."""
        with self._lock:
            lock = self._locks.setdefault(key, threading.Lock())
        with lock:
            scene = self._scenes.get(key)
            if scene is None:
                scene = build()
                with self._lock:
                    self._scenes[key] = scene
                    while len(self._scenes) > self.size:  # the oldest (a case still using it keeps its reference)
                        old = next(iter(self._scenes))
                        self._scenes.pop(old)
                        self._locks.pop(old, None)
            return scene
