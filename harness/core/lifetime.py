"""A child process's lifetime tied to its parent's, and termination signals as interrupts.

A worker forked by the harness must not outlive the command that started it:
killed with SIGKILL, a parent runs no cleanup, and an orphaned worker waits on
its task queue forever (the other workers hold the queue's write end open).
On Linux the kernel can send the child a signal when its parent dies
(``prctl(PR_SET_PDEATHSIG)``, man 2 prctl); a parent that died before the
child asked is caught by comparing ``getppid()`` with the pid that forked it.

SIGTERM (what ``timeout``, ``docker stop`` and CI cancellation send) takes the
path of Ctrl-C: :class:`Terminated` is a ``KeyboardInterrupt``, so everything
that stops workers and removes temporary files on an interrupt does so on
SIGTERM too, and the command exits 128 + 15 = 143, as a process killed by it.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import signal
import sys
import threading
from collections.abc import Iterator

__all__ = ["Terminated", "die_with_parent", "exit_code", "sigterm_as_interrupt"]

PR_SET_PDEATHSIG = 1  # linux/prctl.h


class Terminated(KeyboardInterrupt):
    """A termination signal (SIGTERM) received by the command: stop as on Ctrl-C, exit 128 + signal."""

    def __init__(self, signum: int) -> None:
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


def die_with_parent(parent: int) -> None:
    """Have the kernel kill this process (SIGKILL) when its parent ``parent`` dies; exit at once if it
    already has. Linux only (elsewhere nothing is done)."""
    if not sys.platform.startswith("linux"):
        return
    with contextlib.suppress(OSError, AttributeError):
        ctypes.CDLL(None).prctl(PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0)
    if os.getppid() != parent:  # the parent died before the request: no signal will come
        os._exit(1)


def _raise_terminated(signum: int, _frame: object) -> None:
    raise Terminated(signum)


@contextlib.contextmanager
def sigterm_as_interrupt() -> Iterator[None]:
    """Within the block, SIGTERM raises :class:`Terminated` in the main thread (elsewhere, where no handler
    can be installed, nothing changes); the previous handler is restored after."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGTERM, _raise_terminated)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def exit_code(interrupt: KeyboardInterrupt) -> int:
    """The exit status of a command stopped by ``interrupt``: 128 + the signal (130 for Ctrl-C)."""
    return 128 + getattr(interrupt, "signum", int(signal.SIGINT))
