"""The ``mjharness`` command: :func:`harness.cli.commands.main` in a process that skips what a command never uses.

- MuJoCo's import loads an OpenGL binding for rendering in this process (GLFW: a cost at every
  command's start, docs/findings/speed.md). The CLI renders only in subprocesses (harness/render.py runs
  ``python -m harness.outputs.stills`` with the backend it picks), so the command imports MuJoCo with
  ``MUJOCO_GL=disable`` and puts the variable back at once: those subprocesses, and anything
  else started from here, see the user's environment.
- Interpreter teardown, which frees every module's objects one by one (slow with sympy loaded,
  and after a parallel ``check`` it comes when the workers are done): every file a command
  writes is closed and every worker pool shut down before ``main`` returns, so the command
  flushes its output (Python's and C's: MuJoCo prints its warnings with printf) and exits with
  main's code at once.

Library use (``from harness import ...``, tests) goes through neither.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import sys


def import_mujoco_without_gl() -> None:
    """Import MuJoCo (if not yet imported) with its in-process OpenGL context disabled."""
    if "mujoco" in sys.modules:
        return
    user = os.environ.get("MUJOCO_GL")
    os.environ["MUJOCO_GL"] = "disable"
    try:
        import mujoco  # noqa: F401  # lazy: the point of this function is the environment it imports in
    finally:
        if user is None:
            del os.environ["MUJOCO_GL"]
        else:
            os.environ["MUJOCO_GL"] = user


def exit_now(code: int) -> None:
    """Exit with ``code`` after flushing Python's and C's output buffers, without teardown. MuJoCo
    writes its warnings with C's printf, which a pipe (a CI log) buffers apart from Python."""
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(OSError, ValueError):  # a reader gone since: nothing left to tell it
            stream.flush()
    ctypes.CDLL(None).fflush(None)  # every C stdio stream
    os._exit(code)


def entry() -> None:
    """``mjharness``: MuJoCo without GL, :func:`harness.cli.commands.main`, then :func:`exit_now` with its code."""
    import_mujoco_without_gl()
    from harness.cli.commands import main  # lazy: after MuJoCo, which it imports, is imported without GL

    exit_now(main())


if __name__ == "__main__":
    entry()
