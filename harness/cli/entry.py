"""The ``mjharness`` command: :func:`harness.cli.commands.main` in a process that skips what a command never uses.

- MuJoCo's import loads an OpenGL binding for rendering in this process (GLFW: a cost at every
  command's start, docs/findings/speed.md). The CLI renders only in subprocesses (harness/render.py runs
  ``python -m harness.outputs.stills`` with the backend it picks), so the command imports MuJoCo with
  ``MUJOCO_GL=disable`` and puts the variable back at once: those subprocesses, and anything
  else started from here, see the user's environment.
- numpy's OpenBLAS starts a thread per core for every matrix product, and a command already spreads its work
  over the cores (MuJoCo's runs on threads, cases on worker processes): the tree reference's solve kept a second
  core busy for nothing (dm_control's dog: the same wall time on one BLAS thread, half the CPU time, which the
  reference's CPU bound counts; docs/findings/speed.md). The command imports numpy with
  ``OPENBLAS_NUM_THREADS=1`` unless the user set it, and puts the variable back at once, as for MuJoCo's GL.
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

__all__ = ["entry"]

SETTINGS = {"MUJOCO_GL": "disable", "OPENBLAS_NUM_THREADS": "1"}
"""The environment MuJoCo and numpy are imported in (see the module docstring): MUJOCO_GL always, the BLAS
threads where the user has not set them."""


def import_mujoco_without_gl() -> None:
    """Import MuJoCo (if not yet imported), and numpy with it, in :data:`SETTINGS`; the user's environment put
    back after."""
    if "mujoco" in sys.modules:
        return
    user = {name: os.environ.get(name) for name in SETTINGS}
    os.environ["MUJOCO_GL"] = SETTINGS["MUJOCO_GL"]
    if "numpy" not in sys.modules:
        os.environ.setdefault("OPENBLAS_NUM_THREADS", SETTINGS["OPENBLAS_NUM_THREADS"])
    try:
        import mujoco  # noqa: F401  # lazy: the point of this function is the environment it imports in
    finally:
        for name, value in user.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value


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
