"""A line on stderr every few seconds while a long phase inside one model runs (a reference's solve, a case's runs),
so that no command is silent for longer than :data:`HEARTBEAT` on any model.

``heartbeat(subject)`` around a phase: after each :data:`HEARTBEAT` seconds it lasts, one line
"mjharness: SUBJECT: STAGE, 20 s so far" (``stage(name)`` names what runs now). Nested, only the outermost prints;
the inner ones name its stage. The line is written by a thread of its own, started and joined by the block; a
process forked meanwhile (a worker pool) starts with no heartbeat and a fresh lock.
"""

from __future__ import annotations

import contextlib
import os
import sys
import threading
import time
from collections.abc import Iterator
from typing import Any

__all__ = ["heartbeat", "stage"]

HEARTBEAT = 8.0
"""Seconds between two lines while a phase lasts: within the 10 s any command may be silent, yet few lines in a
CI log."""

_state: dict[str, Any] = {"depth": 0, "stage": ""}
_lock = threading.Lock()


def _forked() -> None:
    """In a child forked while a heartbeat ran (a worker pool): no heartbeat of its parent's, and a lock no thread
    of the parent's can have left held."""
    global _lock
    _lock = threading.Lock()
    _state.update(depth=0, stage="")


os.register_at_fork(after_in_child=_forked)


def stage(name: str) -> str:
    """Name what the phase now running does (the next line says it); nothing where no phase runs. Returns the
    stage it replaces (to name again when a step inside it ends)."""
    with _lock:
        previous = str(_state["stage"])
        _state["stage"] = name
    return previous


def _line(subject: str, started: float) -> str:
    elapsed = time.monotonic() - started
    when = f"{elapsed / 60:.1f} min" if elapsed >= 60 else f"{elapsed:.0f} s"
    doing = _state["stage"]
    subject = "".join(c if c.isprintable() else "?" for c in subject)  # a file's name: no terminal control
    return f"mjharness: {subject}: {doing + ', ' if doing else ''}{when} so far"


@contextlib.contextmanager
def heartbeat(subject: str, *, every: float | None = None, quiet: bool = False) -> Iterator[None]:
    """While the block runs, a line on stderr every ``every`` seconds (default :data:`HEARTBEAT`) naming ``subject``
    and the current :func:`stage`; none where ``quiet``, or where a heartbeat already runs (then ``subject`` becomes
    its stage)."""
    with _lock:
        outer = _state["depth"] == 0
        _state["depth"] = int(_state["depth"]) + 1
        previous = _state["stage"]
        _state["stage"] = "" if outer else subject
    every = HEARTBEAT if every is None else every
    done = threading.Event()
    started = time.monotonic()

    def beat() -> None:
        while not done.wait(every):
            with _lock:
                text = _line(subject, started)
            print(text, file=sys.stderr, flush=True)

    thread = threading.Thread(target=beat, name="mjharness-heartbeat", daemon=True) if outer and not quiet else None
    if thread is not None:
        thread.start()
    try:
        yield
    finally:
        done.set()
        if thread is not None:
            thread.join()
        with _lock:
            _state["depth"] = int(_state["depth"]) - 1
            _state["stage"] = previous
