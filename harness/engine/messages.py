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

from collections import deque

import mujoco

_kept: deque[str] = deque(maxlen=64)


def keep() -> None:
    """Keep MuJoCo's warnings in this process (the last 64, :func:`kept`) instead of printing and logging
    them (``mju_user_warning``; idempotent; forked workers inherit it)."""
    mujoco.set_mju_user_warning(_kept.append)


def kept() -> tuple[str, ...]:
    """The last warnings MuJoCo gave this process since :func:`keep`, oldest first."""
    return tuple(_kept)
