"""Ctrl-C and SIGTERM stop a command cleanly: one exception in the main thread, never lost.

:func:`stop_signals` is the context in which :func:`fitdf.cli.main` runs a command. SIGTERM
raises :class:`Terminated` in the main thread, so that it is cleaned up like Ctrl-C's
``KeyboardInterrupt`` (a report's workers stopped, its temporary folder removed, the previous
report kept), and a stop whose exception a C callback swallowed is raised again. Standard
library only: the command line imports it before anything numerical.
"""

from __future__ import annotations

import _thread
import contextlib
import functools
import signal
import sys
import threading

__all__ = [
    "EXIT_INTERRUPTED",
    "EXIT_TERMINATED",
    "Terminated",
    "raise_terminated",
    "stop_signals",
]

EXIT_INTERRUPTED = 130  # 128 + SIGINT, as a shell reports it
EXIT_TERMINATED = 143  # 128 + SIGTERM


class Terminated(BaseException):
    """SIGTERM, raised in the main thread so that it is cleaned up like Ctrl-C (a report's
    workers stopped, its temporary folder removed, the previous report kept)."""


def raise_terminated(signum, frame):
    """The SIGTERM handler: raise :class:`Terminated` (a second SIGTERM ends the process)."""
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    raise Terminated


def _interrupt_main_soon(signum: int) -> None:
    """Signal ``signum`` to the main thread from a timer thread 0.1 s from now."""
    timer = threading.Timer(0.1, _thread.interrupt_main, args=(signum,))
    timer.daemon = True
    timer.start()


def _raise_swallowed_stop_again(unraisable, fallback=sys.__unraisablehook__) -> None:
    """``sys.unraisablehook`` while a command runs: a Ctrl-C or SIGTERM whose exception was
    raised inside a C callback is printed and dropped by ctypes ("Exception ignored on calling
    ctypes callback function": llvmlite's object-cache callback while numba compiles a
    kernel, as on a first run), and the command would run on. The signal is given to the main
    thread again a moment later, from another thread: raised from here, its exception would be
    dropped with this hook's. Anything else goes to ``fallback``, the hook there before."""
    exc = unraisable.exc_value
    if isinstance(exc, Terminated):
        signal.signal(signal.SIGTERM, raise_terminated)  # the first one had reset it
        signum = signal.SIGTERM
    elif isinstance(exc, KeyboardInterrupt):
        signum = signal.SIGINT
    else:
        fallback(unraisable)
        return
    while True:
        try:
            _interrupt_main_soon(signum)
            return
        except (KeyboardInterrupt, Terminated):  # it came while still in here: once more
            continue


@contextlib.contextmanager
def stop_signals():
    """Ctrl-C and SIGTERM stop a command by an exception the caller catches: SIGTERM raises
    :class:`Terminated` in the main thread, and a stop swallowed by a C callback is raised
    again (:func:`_raise_swallowed_stop_again`). Both restored on the way out; outside the
    main thread (no signal handlers there) only the hook is set."""
    hook = sys.unraisablehook
    try:
        previous = signal.signal(signal.SIGTERM, raise_terminated)
    except ValueError:
        previous = False
    sys.unraisablehook = functools.partial(_raise_swallowed_stop_again, fallback=hook)
    try:
        yield
    finally:
        sys.unraisablehook = hook
        if previous is not False:
            signal.signal(signal.SIGTERM, signal.SIG_DFL if previous is None else previous)
