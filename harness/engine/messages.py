"""MuJoCo's warning text, kept in this process instead of printed.

MuJoCo prints each warning on stderr followed by a blank line, and appends it
to ``MUJOCO_LOG.TXT`` in the working directory (simulation.rst, "Default
handler"), unless a warning handler is installed. The command installs one
(:func:`keep`), so that its stderr holds its own one-line error and nothing
else, and it leaves no log file behind. Nothing is lost: every warning about a
run is read from MuJoCo's counters (``mjData.warning``) and becomes that run's
"diverged" verdict, and a model MuJoCo would warn about while compiling (a
NaN, a mixed solref) is refused by :mod:`harness.engine.validity`, naming the
attribute. Library use (``harness.validate``) leaves MuJoCo's handler alone.
"""

from __future__ import annotations

import contextlib
from collections import deque
from collections.abc import Iterator

import mujoco

__all__ = ["keep", "kept_within"]

_kept: deque[str] = deque(maxlen=64)
_keeping: list[bool] = []  # whether keep() holds for the process (the CLI's), so a block leaves it on


def keep() -> None:
    """Keep MuJoCo's warnings in this process (the last 64, :func:`kept`) instead of printing and logging
    them (``mju_user_warning``; idempotent; forked workers inherit it)."""
    mujoco.set_mju_user_warning(_kept.append)
    _keeping[:] = [True]


@contextlib.contextmanager
def kept_within() -> Iterator[None]:
    """:func:`keep` for the duration of the block, then MuJoCo's own handler again (it prints and appends to
    ``MUJOCO_LOG.TXT`` in the working folder): a library call neither writes to the caller's stderr nor
    leaves a file behind, and leaves the caller's process as it found it."""
    if _keeping:
        yield
        return
    keep()
    try:
        yield
    finally:
        mujoco.set_mju_user_warning(None)
        _keeping.clear()


def kept() -> tuple[str, ...]:
    """The last warnings MuJoCo gave this process since :func:`keep`, oldest first."""
    return tuple(_kept)
