"""Progress reporting shared by the stages, without coupling them to a user interface.

Long loops call :func:`report` ``(done, total, what)``; it does nothing unless a caller installed a
callback with :func:`reporting` (the pipeline does, with tqdm bars, unless ``--quiet``).  The callback is
looked up in a context variable, so stages stay plain functions and tests see no output.
"""

from __future__ import annotations

import contextvars
from contextlib import contextmanager
from typing import Callable

_callback: contextvars.ContextVar[Callable[[int, int, str], None] | None] = contextvars.ContextVar(
    "fem2tmm_progress", default=None)


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
