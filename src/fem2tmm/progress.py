"""Progress reporting shared by the stages, without coupling them to a user interface.

Long loops call :func:`report` ``(done, total, what)``; it does nothing unless a caller installed a
callback with :func:`reporting` (the pipeline does, with the tqdm bars of :class:`Progress`, unless
``--quiet``).  The callback is looked up in a context variable, so stages stay plain functions and tests see
no output.

The executors of :mod:`fem2tmm.compute` report their work units with :func:`report_units`: to the callback
installed by :func:`reporting_units` when there is one (a multi-case run on Dask shows one bar over the units of
all cases, :class:`UnitsBar`), otherwise like :func:`report`.
"""

from __future__ import annotations

import contextvars
import sys
import threading
import time
from contextlib import contextmanager
from typing import Callable

_callback: contextvars.ContextVar[Callable[[int, int, str], None] | None] = contextvars.ContextVar(
    "fem2tmm_progress", default=None)
_units: contextvars.ContextVar[Callable[[int, int, str], None] | None] = contextvars.ContextVar(
    "fem2tmm_units", default=None)


def report(done: int, total: int, what: str) -> None:
    """Tell the installed callback (if any) that ``done`` of ``total`` units of ``what`` are finished."""
    cb = _callback.get()
    if cb is not None:
        cb(done, total, what)


@contextmanager
def reporting(callback: Callable[[int, int, str], None] | None):
    """Install ``callback(done, total, what)`` for the calls to :func:`report` made inside the block."""
    token = _callback.set(callback)
    try:
        yield
    finally:
        _callback.reset(token)


def report_units(done: int, total: int, what: str) -> None:
    """Like :func:`report`, for an executor's work units: ``done`` of the ``total`` units of one
    :func:`~fem2tmm.compute.map_units` call are finished.  Goes to the :func:`reporting_units` callback when one is
    installed, else to :func:`report`."""
    cb = _units.get()
    if cb is not None:
        cb(done, total, what)
    else:
        report(done, total, what)


@contextmanager
def reporting_units(callback: Callable[[int, int, str], None] | None):
    """Install ``callback(done, total, what)`` for the calls to :func:`report_units` made inside the block."""
    token = _units.set(callback)
    try:
        yield
    finally:
        _units.reset(token)


#: seconds between two progress lines on a stream that is not a terminal (a log file)
LOG_EVERY = 30.0


def is_terminal(stream) -> bool:
    """Whether ``stream`` is a terminal (a tqdm bar redraws there with carriage returns; a log gets lines)."""
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):  # no isatty, or a closed stream
        return False


class LogBar:
    """The progress of one kind of work on a stream that is not a terminal: no carriage returns; a line
    ``[fem2tmm]   desc: done/total`` at most every :data:`LOG_EVERY` s while it runs and one when it is closed.
    Has the ``total``, ``n``, ``update``, ``refresh`` and ``close`` of a tqdm bar."""

    def __init__(self, total: int, desc: str, stream):
        self.total, self.desc, self.stream, self.n = total, desc, stream, 0
        self._last = time.monotonic()
        self._open = True

    def _line(self) -> None:
        print(f"[fem2tmm]   {self.desc}: {self.n}/{self.total}", file=self.stream, flush=True)
        self._last = time.monotonic()

    def update(self, k: int = 1) -> None:
        self.n += k
        if time.monotonic() - self._last >= LOG_EVERY:
            self._line()

    def refresh(self) -> None:
        pass

    def close(self) -> None:
        if self._open and self.n > 0:
            self._line()
        self._open = False


def progress_bar(total: int, desc: str, stream, disable: bool = False):
    """A tqdm bar on a terminal, a :class:`LogBar` on any other stream, a disabled tqdm bar when ``disable``."""
    from tqdm.auto import tqdm

    if not disable and not is_terminal(stream):
        return LogBar(total, desc, stream)
    return tqdm(total=total, desc=desc, disable=disable, file=stream, leave=False)


class UnitsBar:
    """One progress bar over the work units of many concurrent :func:`~fem2tmm.compute.map_units` calls (threads):
    units finished / units submitted so far, ``desc`` e.g. "work units on 2 workers".  Use it as the
    :func:`reporting_units` callback; thread-safe.  ``done`` / ``submitted`` count every unit seen (also when
    quiet); ``close()`` ends the bar."""

    def __init__(self, desc: str, quiet: bool = False, stream=None):
        self.desc = desc
        self.quiet = quiet
        self.stream = stream or sys.stderr
        self.done = self.submitted = 0
        self._calls: dict[tuple[int, str], int] = {}  # (thread, what) -> units of that call finished
        self._lock = threading.Lock()
        self._bar = None

    def __call__(self, done: int, total: int, what: str) -> None:
        key = (threading.get_ident(), what)  # one thread makes its map_units calls one after the other
        with self._lock:
            prev = self._calls.get(key)
            if prev is None or done <= prev:  # a new call (a finished one was forgotten; a retried call restarts)
                self.submitted += total
                prev = 0
            self.done += done - prev
            if done >= total:
                self._calls.pop(key, None)
            else:
                self._calls[key] = done
            if self.quiet:
                return
            if self._bar is None:
                self._bar = progress_bar(self.submitted, self.desc, self.stream)
            self._bar.total = self.submitted
            self._bar.update(self.done - self._bar.n)  # tqdm limits the redraw rate
            if self.done >= self.submitted:
                self._bar.refresh()

    def close(self) -> None:
        with self._lock:
            if self._bar is not None:
                self._bar.close()
                self._bar = None


class Progress:
    """Stage timer and tqdm progress (silent when ``quiet``).  ``timings`` maps stage name -> seconds; ``label``
    (a load case's name) prefixes the messages."""

    def __init__(self, quiet: bool = False, stream=None, label: str | None = None):
        self.quiet = quiet
        self.prefix = f"[fem2tmm] {label}:" if label else "[fem2tmm]"  # label: the load case
        self.stream = stream or sys.stderr
        self.timings: dict[str, float] = {}
        self._bars: dict[str, object] = {}

    @contextmanager
    def stage(self, name: str, label: str | None = None):
        """Time the block as stage ``name`` (printing ``label`` before and after unless quiet)."""
        if not self.quiet:
            print(f"{self.prefix} {label or name} …", file=self.stream, flush=True)
        t0 = time.perf_counter()
        try:
            yield
        finally:
            self.close_bars()
        dt = time.perf_counter() - t0
        self.timings[name] = self.timings.get(name, 0.0) + dt
        if not self.quiet:
            print(f"{self.prefix} {label or name}: {dt:.2f} s", file=self.stream, flush=True)

    def note(self, text: str) -> None:
        """Print one line ``[fem2tmm] text`` unless quiet."""
        if not self.quiet:
            print(f"[fem2tmm] {text}", file=self.stream, flush=True)

    def bar(self, total: int, desc: str):
        """A tqdm bar on a terminal, progress lines in a log (:func:`progress_bar`), or a no-op object, with
        ``update(n)`` and ``close()``."""
        return progress_bar(total, desc, self.stream, disable=self.quiet or total <= 1)

    def callback(self):
        """A :func:`report` callback driving one tqdm bar per kind of work (None if quiet).

        Bars still open when a stage ends are closed by :meth:`stage`."""
        if self.quiet:
            return None

        def cb(done: int, total: int, what: str) -> None:
            b = self._bars.get(what)
            if b is None or b.total != total or done < b.n:
                if b is not None:
                    b.close()
                b = self._bars[what] = self.bar(total, what)
            b.update(done - b.n)  # tqdm limits the redraw rate
            if done >= total:
                b.close()
                self._bars.pop(what, None)

        return cb

    def close_bars(self) -> None:
        for b in self._bars.values():
            b.close()
        self._bars.clear()
