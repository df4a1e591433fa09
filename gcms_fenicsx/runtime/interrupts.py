"""SIGINT and SIGTERM as exceptions, so every ``finally`` and context manager cleans up.

Python turns SIGINT into KeyboardInterrupt only while its own handler is installed, and
SIGTERM kills the process outright: a staged output folder would stay behind. Importing
Gmsh's Python API even resets SIGINT to the default action (the process dies at once).
:func:`interruptible` installs handlers that raise :class:`Interrupted` for both, for the
duration of a command; the command line turns it into one line and exit status 128 + n.

A signal arriving inside a long C call (a MUMPS factorisation) is handled when the call
returns; Gmsh meshing runs in a child process for that reason (``fe.meshing``).
"""
from __future__ import annotations

import signal
from collections.abc import Iterator
from contextlib import contextmanager

SIGNALS = (signal.SIGINT, signal.SIGTERM)


class Interrupted(BaseException):
    """The process received SIGINT or SIGTERM (``signum``); a BaseException, like
    KeyboardInterrupt, so that ``except Exception`` clauses let it through."""

    def __init__(self, signum: int) -> None:
        super().__init__(signal.Signals(signum).name)
        self.signum = signum

    @property
    def exit_status(self) -> int:
        """128 + the signal number: 130 for SIGINT, 143 for SIGTERM (shell convention)."""
        return 128 + self.signum


def _raise(signum: int, frame: object) -> None:
    raise Interrupted(signum)


@contextmanager
def interruptible() -> Iterator[None]:
    """Raise :class:`Interrupted` on SIGINT and SIGTERM inside the block; the previous
    handlers are restored after it."""
    previous = {s: signal.signal(s, _raise) for s in SIGNALS}
    try:
        yield
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler if handler is not None else signal.SIG_DFL)


@contextmanager
def deferred() -> Iterator[None]:
    """Hold SIGINT and SIGTERM back during the block (a few renames that must all happen);
    one that arrived meanwhile is delivered when the block ends."""
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, SIGNALS)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)


def reinstall() -> None:
    """Install the raising handlers again if something replaced them (Gmsh's import and
    finalize reset SIGINT). Does nothing outside :func:`interruptible`."""
    if signal.getsignal(signal.SIGTERM) is _raise:
        signal.signal(signal.SIGINT, _raise)
