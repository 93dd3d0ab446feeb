"""One progress display for a run of several phases of keyed jobs, with the time the run has left.

:class:`RunProgress` is the ``display`` of a :class:`fitdf.executor.Executor`: the executor tells
it when each of its runs (a phase) begins, and when each job starts and finishes. It draws one
tqdm bar for the whole run on stderr, ``1/3 least squares 14/56 jobs`` on its left, and on its
right the time elapsed and the time left.

How much is done and what is left
    Every job has an expected cost, its seconds on a reference machine (``expected(key)``).
    The bar's percentage is the share of the run's expected seconds done, not of its jobs:
    one chain can weigh as much as a hundred fits. A phase whose jobs are not known yet (they
    depend on the previous phase's results) is planned: ``Phase.planned`` lists its jobs'
    kinds and expected seconds, replaced by its real jobs when it begins.
Calibration to this machine
    As jobs finish, measured over expected seconds -- for each kind of job (``kind(key)``),
    or over all the jobs measured so far for a kind none of whose jobs has finished yet --
    scales the expected seconds of what is left. Before the first job finishes the
    estimate is the reference machine's, and the display says so; jobs taken from a cache
    count as done and are not measured.
Time left
    The length of a schedule: the running jobs' expected remainders (at least a twentieth of
    their expected cost: a job running late is not assumed about to end), then the jobs
    still waiting, in the order they are submitted, each to the first free worker; then each
    later phase the same way (the phases run one after the other).

A fake ``clock`` and ``enabled=False`` give the numbers without a bar or a thread
(tests/test_progress.py).
"""

from __future__ import annotations

import heapq
import shutil
import sys
import textwrap
import threading
import time
from dataclasses import dataclass

from tqdm import tqdm

from fitdf._text import TEXT_WIDTH

__all__ = ["Phase", "RunProgress", "schedule_length", "duration_text"]

#: A running job is expected to need at least this share of its expected cost still.
_LEAST_LEFT = 0.05


@dataclass(frozen=True)
class Phase:
    """A phase of a run as planned: its label and ``(kind, expected seconds)`` of its jobs in
    the order they will be submitted (an estimate where the jobs are not known yet)."""

    label: str
    planned: tuple = ()


def schedule_length(costs, workers: int, busy=()) -> float:
    """Seconds until ``costs`` are done when each goes, in order, to the first free worker.

    Parameters
    ----------
    costs : iterable of float
        Seconds of the jobs, in the order they are submitted.
    workers : int
        Workers running them (at least 1).
    busy : iterable of float
        Seconds until each busy worker is free (the remainders of its running jobs).

    Returns
    -------
    float
        When the last job ends, counted from now (0 for nothing to do).

    Examples
    --------
    >>> schedule_length([4.0, 1.0, 1.0, 1.0], workers=2)
    4.0
    >>> schedule_length([3.0], workers=2, busy=[5.0, 1.0])
    5.0
    """
    free = sorted(float(b) for b in busy)
    free += [0.0] * max(int(workers) - len(free), 0)
    if not free:
        free = [0.0]
    heapq.heapify(free)
    end = max(free)
    for cost in costs:
        t = heapq.heappop(free) + float(cost)
        end = max(end, t)
        heapq.heappush(free, t)
    return end


def duration_text(seconds: float) -> str:
    """A rounded duration for a person: ``40 s``, ``12 min``, ``1 h 57 min``."""
    s = max(float(seconds), 0.0)
    if s < 90:
        return f"{s:.0f} s"
    if s < 90 * 60:
        return f"{s / 60:.0f} min"
    h, m = divmod(round(s / 60), 60)
    return f"{h} h {m:02d} min"


#: The bar's format, and its text before the display's own (``left``) at 100 %.
_BAR_FORMAT = "{percentage:3.0f}%|{bar:16}| {left}"
_BAR_HEAD = "100%|" + 16 * " " + "| "


class _Bar(tqdm):
    """A tqdm bar with one more field for its format: ``{left}``, the display's own text."""

    def __init__(self, *args, left="", **kwargs):
        self.left = left  # (before tqdm draws the bar the first time)
        super().__init__(*args, **kwargs)

    @property
    def format_dict(self):
        return {**super().format_dict, "left": self.left}


class RunProgress:
    """One display of a run's phases (see the module docstring); a context manager.

    Parameters
    ----------
    phases : sequence of Phase
        The run's phases in order; ``Executor.run(jobs, desc)`` begins the phase labelled
        ``desc`` (a label not planned is added as a phase of its own).
    expected : callable
        ``expected(key) -> seconds`` of a job on the reference machine.
    workers : int
        Workers the jobs run on.
    kind : callable
        ``kind(key) -> str``: the jobs whose measured times calibrate each other.
    enabled : bool
        Draw the bar (on ``file``, default stderr) and refresh it every ``refresh_s`` seconds
        from a thread (a job can run for an hour); False keeps the numbers only.
    clock : callable
        Seconds, monotonic (a fake one in tests).
    reference : str
        What the expected seconds are the times of, for the display before a job has finished
        (``"at the committed machine's speed"``).
    width : int, optional
        The widest line, bar included (default: 100 columns, or the terminal's width if
        narrower): a longer bar would wrap, and each redraw would leave a line behind.
    """

    def __init__(
        self,
        phases,
        expected,
        workers: int,
        *,
        kind=lambda key: "",
        enabled: bool = True,
        file=None,
        clock=time.monotonic,
        refresh_s: float = 1.0,
        reference: str = "at the reference machine's speed",
        width: int | None = None,
    ):
        self.phases = list(phases)
        self.expected = expected
        self.kind = kind
        self.workers = max(1, int(workers))
        self.clock = clock
        self.reference = reference
        self.width = width or min(TEXT_WIDTH, shutil.get_terminal_size().columns)
        self.index = -1  # the phase running
        self._jobs = {}  # key -> (kind, expected seconds) of the phase running, in order
        self._waiting = {}  # keys of the phase running not started yet (ordered)
        self._running = {}  # key -> clock when it started
        self._done_work = 0.0  # expected seconds of the jobs finished or cached, all phases
        self._ended_work = 0.0  # expected seconds of the jobs of the phases that ended
        self._measured = {}  # kind -> [measured seconds, expected seconds] of jobs run here
        self._n_measured = 0
        self._n_done = 0  # jobs of the phase running finished or cached
        self._start = clock()
        self._phase_start = self._start
        self._lock = threading.RLock()
        self._file = file or sys.stderr
        self._enabled = bool(enabled)
        self._bar = None  # drawn when the first phase begins
        self._stop = threading.Event()
        self._thread = None
        if enabled and refresh_s:
            self._thread = threading.Thread(target=self._tick, args=(refresh_s,), daemon=True)
            self._thread.start()

    # ------------------------------------------------------------------ the executor's calls
    def begin(self, desc, keys, cached=()) -> None:
        """The phase labelled ``desc`` begins with the jobs ``keys`` (``cached``: already done)."""
        with self._lock:
            if self.index >= 0:
                self._end_phase()
                self._ended_work += sum(s for _, s in self._jobs.values())
            nxt = next(
                (
                    i
                    for i in range(self.index + 1, len(self.phases))
                    if self.phases[i].label == desc
                ),
                None,
            )
            if nxt is None:
                self.phases.insert(self.index + 1, Phase(desc))
                nxt = self.index + 1
            del self.phases[self.index + 1 : nxt]  # planned phases the run skipped
            self.index = self.index + 1
            self._jobs = {key: (self.kind(key), float(self.expected(key))) for key in keys}
            cached = set(cached)
            self._waiting = dict.fromkeys(k for k in self._jobs if k not in cached)
            self._running = {}
            self._n_done = len(cached)
            self._done_work += sum(self._jobs[k][1] for k in cached)
            self._phase_start = self.clock()
            self._draw()

    def started(self, key) -> None:
        with self._lock:
            self._waiting.pop(key, None)
            self._running[key] = self.clock()
            self._draw()

    def finished(self, key, seconds: float) -> None:
        with self._lock:
            self._waiting.pop(key, None)
            self._running.pop(key, None)
            kind, exp = self._jobs.get(key, (self.kind(key), float(self.expected(key))))
            m = self._measured.setdefault(kind, [0.0, 0.0])
            m[0] += float(seconds)
            m[1] += exp
            self._n_measured += 1
            self._n_done += 1
            self._done_work += exp
            self._draw()

    def close(self, stopped: bool = False) -> None:
        """End the display (its last line stays); ``stopped``: the run ended early."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join()
            self._thread = None
        with self._lock:
            if self._bar is None:
                return
            elapsed = tqdm.format_interval(self.clock() - self._start)
            if stopped:
                self._bar.left = f"{elapsed} elapsed | {self.label()} | stopped"
            else:
                self._end_phase()
                self._bar.n = 1000
                self._bar.left = f"{elapsed} for {self.index + 1} phase{'s' if self.index else ''}"
            self._bar.close()
            self._bar = None

    def __enter__(self):
        return self

    def __exit__(self, exc_type, exc, tb):
        self.close(stopped=exc_type is not None)
        return False

    # ------------------------------------------------------------------ the numbers
    def ratio(self, kind=None) -> float | None:
        """Measured over expected seconds of the jobs of ``kind`` run here, else of all of
        them; None before any job has finished."""
        pairs = [self._measured[kind]] if kind in self._measured else self._measured.values()
        measured = sum(p[0] for p in pairs)
        expected = sum(p[1] for p in pairs)
        return measured / expected if expected > 0 else None

    def _scaled(self, kind, seconds) -> float:
        r = self.ratio(kind)
        return seconds * (1.0 if r is None else r)

    def remaining(self) -> float:
        """Seconds the run has left (see the module docstring)."""
        with self._lock:
            now = self.clock()
            busy = []
            for key, t in self._running.items():
                need = self._scaled(*self._jobs[key])
                busy.append(max(need - (now - t), _LEAST_LEFT * need))
            left = schedule_length(
                (self._scaled(*self._jobs[k]) for k in self._waiting), self.workers, busy
            )
            for phase in self.phases[self.index + 1 :]:
                left += schedule_length(
                    (self._scaled(k, s) for k, s in phase.planned), self.workers
                )
            return left

    def total_work(self) -> float:
        """Expected seconds of every job of the run (the phases to come as planned)."""
        later = sum(s for p in self.phases[self.index + 1 :] for _, s in p.planned)
        return self._ended_work + sum(s for _, s in self._jobs.values()) + later

    def fraction_done(self) -> float:
        """Share of the run's expected seconds done: the jobs finished (or cached), and of
        each running job the share of its expected time it has run (at most 90 %)."""
        with self._lock:
            now = self.clock()
            running = sum(
                min((now - t) / max(self._scaled(*self._jobs[k]), 1e-9), 0.9) * self._jobs[k][1]
                for k, t in self._running.items()
            )
            total = self.total_work()
            return min((self._done_work + running) / total, 1.0) if total > 0 else 0.0

    def basis(self) -> str:
        """What the time left is based on."""
        r = self.ratio()
        if r is None:
            return self.reference
        jobs = f"{self._n_measured} job{'s' if self._n_measured != 1 else ''}"
        return f"this machine: {r:.2f} x the committed job times, from {jobs}"

    def label(self) -> str:
        """``2/3 MCMC, ...: 12/103 jobs`` of the phase running."""
        if not 0 <= self.index < len(self.phases):
            return ""
        return (
            f"{self.index + 1}/{len(self.phases)} {self.phases[self.index].label}: "
            f"{self._n_done}/{len(self._jobs)} jobs"
        )

    # ------------------------------------------------------------------ drawing
    def _draw(self) -> None:
        if not self._enabled or self.index < 0:
            return
        elapsed = self.clock() - self._start
        left = (
            f"{tqdm.format_interval(elapsed)} elapsed, about {duration_text(self.remaining())} "
            f"left | {self.label()}"
        )
        # the basis of the estimate when the line has room (each phase's last line says it)
        if len(_BAR_HEAD) + len(left) + 3 + len(self.basis()) < self.width:
            left += f" | {self.basis()}"
        n = round(1000 * self.fraction_done())
        if self._bar is None:
            self._bar = _Bar(
                total=1000,
                initial=n,
                file=self._file,
                leave=True,
                bar_format=_BAR_FORMAT,
                left=left,
                ncols=self.width - 1,  # (tqdm cuts a longer line: it never wraps)
            )
            return
        self._bar.n, self._bar.left = n, left
        self._bar.refresh()

    def _end_phase(self) -> None:
        """One line for the phase that ended, above the bar."""
        if self._bar is None:
            return
        took = duration_text(self.clock() - self._phase_start)
        later = self.phases[self.index + 1 :]
        text = (
            f"{self.label()} done in {took}; the rest: about "
            f"{duration_text(self.remaining())} ({self.basis()})"
            if later
            else f"{self.label()} done in {took}"
        )
        lines = textwrap.wrap(text, self.width - 1, subsequent_indent="  ")
        self._bar.write("\n".join(lines), file=self._file)

    def _tick(self, every: float) -> None:
        while not self._stop.wait(every):
            with self._lock:
                self._draw()
