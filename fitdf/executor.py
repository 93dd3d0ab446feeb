"""One executor for the jobs of a report or of ``fitdf fit``: serially, in local processes, or on Dask.

A job is ``(fn, args)`` under a key. :meth:`Executor.run` returns every job's result under
its key, in the jobs' order whatever order they finish in, and records each job's run time
in ``Executor.seconds``; jobs are submitted in the dict's order (put long ones first). Jobs
depend only on their arguments, so where they run changes no number. It knows jobs, not
fits: it sits below every layer, so that ``fitdf fit`` imports it without the report's
plotting stack.

Where the jobs run
    ``workers=1``: in this process. ``workers=N``: in N local processes (spawned: fresh
    interpreters, no state copied from this one). ``scheduler="tcp://host:8786"``: on the Dask
    distributed cluster of that scheduler (``workers`` is then ignored); its workers need
    fitdf installed. Dask is imported only then (``pip install 'fitdf[dask]'``).
Kept results
    With a :class:`~fitdf.jobcache.JobCache`, a job whose result is kept there under its
    function and key is not run (its recorded run time is the one it took), and every job
    that finishes is kept as soon as it does, in this process: a run stopped midway keeps
    what it finished, and the same run again computes only the rest. The cache's salt must
    name everything the arguments are made from (:mod:`fitdf.jobcache`).
Stopping
    Local workers ignore SIGINT (a terminal's Ctrl-C reaches every process of the group; the
    parent handles it) and are terminated, not waited for, as soon as a run stops early for
    any reason (a job's error, Ctrl-C, SIGTERM): leaving the ``with`` block never waits for a
    running job. They talk to the parent over pipes only (no queues or locks), so nothing is
    left behind, and exit by themselves (a second or two once they run a job) if the parent
    is killed outright.
    On a cluster the pending jobs are cancelled; a job already running there finishes on
    its worker and its result is dropped.
"""

from __future__ import annotations

import os
import pickle
import signal
import sys
import threading
import time
import traceback
from contextlib import contextmanager
from importlib.util import find_spec
from multiprocessing import get_context, resource_tracker
from multiprocessing.connection import wait

from tqdm.auto import tqdm

from fitdf.errors import OptionError
from fitdf.jobcache import JobCache

__all__ = ["Executor", "RemoteTraceback"]

#: Seconds a worker gets to exit after the last job, or after being terminated.
_GRACE = 2.0
_SIGMASK = hasattr(signal, "pthread_sigmask")  # POSIX


def timed(fn, *args):
    """``(fn(*args), seconds)``: a job as it runs wherever it runs."""
    start = time.perf_counter()
    return fn(*args), time.perf_counter() - start


class RemoteTraceback(Exception):
    """The traceback of a job that failed in a worker process (the cause of the re-raised error)."""

    def __str__(self):
        return "\n" + self.args[0]


def _exit_with(parent: int) -> None:
    """Exit when the parent is gone (killed outright, nothing could stop us): no orphan
    goes on computing a report nobody will write."""
    while os.getppid() == parent:
        time.sleep(1.0)
    os._exit(1)


def _portable(exc: BaseException) -> BaseException:
    """``exc``, or a RuntimeError naming it where it would not come back out of a pickle
    (lmfit's exceptions pickle but need arguments to unpickle: the parent then saw a
    TypeError about ``MinimizerException.__init__`` instead of the error)."""
    try:
        pickle.loads(pickle.dumps(exc))
        return exc
    except Exception:
        return RuntimeError(f"{type(exc).__module__}.{type(exc).__name__}: {exc}")


def _serve(conn, parent: int) -> None:
    """A local worker: run the jobs the parent sends until it sends None or goes away."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent handles Ctrl-C and stops us
    threading.Thread(target=_exit_with, args=(parent,), daemon=True).start()
    while True:
        try:
            job = conn.recv()
        except (EOFError, OSError):
            return
        if job is None:
            return
        try:
            reply = (True, timed(*job))
        except Exception as exc:
            reply = (False, _portable(exc), traceback.format_exc())
        try:
            conn.send(reply)
        except OSError:  # the parent is gone
            return
        except Exception as exc:  # a result or an error that does not pickle
            conn.send((False, RuntimeError(f"a job's reply could not be sent: {exc!r}"), ""))


def _distributed():
    """The ``distributed`` module (optional and slow to import: only a cluster run imports it)."""
    if find_spec("distributed") is None:
        raise OptionError(
            "a scheduler needs Dask distributed: pip install 'fitdf[dask]' (or 'dask[distributed]')"
        )
    import distributed  # optional dependency (see tests/test_architecture.py)

    return distributed


@contextmanager
def _signals_held():
    """SIGINT blocked in this thread (spawned processes inherit the mask: CPython starts its
    resource tracker so) and, in the main thread, SIGINT and SIGTERM held back: re-raised,
    with the handlers they found, on leaving."""
    held, previous = [], {}
    if threading.current_thread() is threading.main_thread():
        for sig in (signal.SIGINT, signal.SIGTERM):
            previous[sig] = signal.signal(sig, lambda signum, frame: held.append(signum))
    mask = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT}) if _SIGMASK else None
    try:
        yield
    finally:
        if mask is not None:
            signal.pthread_sigmask(signal.SIG_SETMASK, mask)
        for sig, handler in previous.items():
            signal.signal(sig, signal.SIG_DFL if handler is None else handler)
        for sig in dict.fromkeys(held):
            signal.raise_signal(sig)


class _NoDisplay:
    """The display of an :class:`Executor` without one: hears every job, shows nothing."""

    def begin(self, desc, keys, cached):
        pass

    def started(self, key):
        pass

    def finished(self, key, seconds):
        pass


class Executor:
    """Runs dicts of keyed jobs; a context manager (leaving it stops the workers).

    Parameters
    ----------
    workers : int
        Local worker processes (1: run the jobs in this process).
    scheduler : str or None
        Address of a Dask distributed scheduler (``tcp://host:8786``); None runs locally.
    progress : bool
        A tqdm bar per :meth:`run` on stderr (unless a ``display`` shows the progress).
    cache : JobCache or None
        Where finished jobs are kept and looked up (None: every job runs).

    Attributes
    ----------
    display : object or None
        One progress display for several runs instead of a bar per run (e.g.
        :class:`fitdf.report.progress.RunProgress`): told ``begin(desc, keys, cached)`` when
        a run starts (``cached``: the keys taken from the cache), ``started(key)`` when a job
        goes to a worker and ``finished(key, seconds)`` when it is done. On a cluster a job
        counts as started when an earlier one finishes (the scheduler does not say when).
    seconds : dict
        Run time of every job so far, under its key joined by spaces (for a job taken from
        the cache, the time it took when it ran).
    reused : list
        Keys (joined by spaces) of the jobs taken from the cache.
    workers : int
        Processes the jobs run in (on a cluster: its workers when connected).

    Examples
    --------
    >>> with Executor(workers=2) as ex:                       # doctest: +SKIP
    ...     ex.run({("a",): (pow, (2, 3)), ("b",): (pow, (3, 2))}, "powers")
    {('a',): 8, ('b',): 9}
    """

    def __init__(
        self,
        workers: int = 1,
        scheduler: str | None = None,
        progress: bool = False,
        cache: JobCache | None = None,
    ):
        self.workers = max(1, int(workers))
        self.scheduler = scheduler or None
        self.progress = progress
        self.cache = cache
        self.seconds = {}
        self.reused = []
        self.display = None
        self._procs = []  # (process, connection) of the local workers
        self._client = None
        self._dask = None  # the distributed module, on a cluster
        self._futures = []

    # ------------------------------------------------------------------ start, stop
    def __enter__(self):
        if self.scheduler is not None:
            self._connect()
        elif self.workers > 1:
            try:
                self._start_local()
            except BaseException:  # a signal held back while they started, or a failure
                self._stop_local(wait_for_exit=False)
                raise
        return self

    def _start_local(self):
        """Spawn the workers; a signal meanwhile is handled once they all run (none is left
        half-started), and they start with SIGINT blocked, so a terminal's Ctrl-C while they
        import reaches only the parent."""
        ctx = get_context("spawn")
        resource_tracker.ensure_running()  # first: starting it unblocks SIGINT in this thread
        with _signals_held():
            for _ in range(self.workers):
                conn, child = ctx.Pipe()
                proc = ctx.Process(target=_serve, args=(child, os.getpid()), daemon=True)
                proc.start()
                child.close()
                self._procs.append((proc, conn))

    def __exit__(self, exc_type, exc, tb):
        if self._client is not None:
            if self._futures:
                self._client.cancel(self._futures)
            self._client.close()
            self._client = None
        self._stop_local(wait_for_exit=exc_type is None)
        return False

    def _connect(self):
        self._dask = _distributed()
        try:
            self._client = self._dask.Client(self.scheduler, timeout="20s", set_as_default=False)
        except (OSError, ValueError) as exc:
            raise OptionError(f"cannot reach the Dask scheduler {self.scheduler}: {exc}") from exc
        self.workers = max(1, len(self._client.nthreads()))

    def _stop_local(self, wait_for_exit: bool):
        """Ask the workers to exit (after a complete run) or terminate them (any other exit)."""
        procs, self._procs = self._procs, []
        for proc, conn in procs:
            if wait_for_exit:
                try:
                    conn.send(None)
                except OSError:
                    pass
            else:
                proc.terminate()
        for proc, conn in procs:
            proc.join(_GRACE)
            if proc.is_alive():
                proc.kill()
                proc.join(_GRACE)
            conn.close()

    # ------------------------------------------------------------------ running
    def run(self, jobs: dict, desc: str) -> dict:
        """Run ``{key: (fn, args)}``; return ``{key: fn(*args)}`` in the jobs' order.

        A job's exception is raised here (with the worker's traceback as its cause).
        """
        out = {}
        digests = {}
        if self.cache is not None:
            for key, (fn, _) in jobs.items():
                digests[key] = self.cache.digest(fn, key)
                hit, value = self.cache.get(digests[key])
                if hit:
                    out[key] = value
                    self.reused.append(" ".join(map(str, key)))
        todo = {key: job for key, job in jobs.items() if key not in out}
        display = self.display or _NoDisplay()
        display.begin(desc, list(jobs), [key for key in jobs if key in out])

        def finished(key, value):
            out[key] = value
            if self.cache is not None:
                self.cache.put(digests[key], value)
            bar.update(1)
            display.finished(key, value[1])

        with tqdm(
            total=len(jobs),
            initial=len(jobs) - len(todo),
            desc=desc,
            file=sys.stderr,
            disable=not self.progress or self.display is not None,
            leave=True,
        ) as bar:
            if self._client is not None:
                self._run_dask(todo, display.started, finished)
            elif self._procs:
                self._run_local(todo, display.started, finished)
            else:
                for key, (fn, args) in todo.items():
                    display.started(key)
                    finished(key, timed(fn, *args))
        for key in jobs:
            self.seconds[" ".join(map(str, key))] = round(out[key][1], 2)
        return {key: out[key][0] for key in jobs}

    def _run_local(self, jobs: dict, started, finished) -> None:
        todo = iter(jobs.items())
        idle = [conn for _, conn in self._procs]
        busy = {}  # connection -> key of the job it runs
        while True:
            while idle and (item := next(todo, None)) is not None:
                key, (fn, args) = item
                conn = idle.pop()
                conn.send((fn, *args))
                busy[conn] = key
                started(key)
            if not busy:
                return
            for conn in wait(list(busy)):
                key = busy.pop(conn)
                try:
                    reply = conn.recv()
                except (EOFError, OSError):
                    raise RuntimeError(f"a worker process died running job {key}") from None
                if not reply[0]:
                    raise reply[1] from RemoteTraceback(reply[2])
                finished(key, reply[1])
                idle.append(conn)

    def _run_dask(self, jobs: dict, started, finished) -> None:
        self._futures = [
            self._client.submit(timed, fn, *args, pure=False) for fn, args in jobs.values()
        ]
        keys = {fut.key: key for fut, key in zip(self._futures, jobs)}
        waiting = iter(jobs)  # started as the cluster's workers free up (an estimate)
        for _, key in zip(range(self.workers), waiting):  # (range first: no key is lost)
            started(key)
        for fut in self._dask.as_completed(self._futures, loop=self._client.loop):
            finished(keys[fut.key], fut.result())
            if (key := next(waiting, None)) is not None:
                started(key)
        self._futures = []
