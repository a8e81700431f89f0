"""The ``mjharness`` command: :func:`harness.cli.main` in a process that skips what a command never uses.

- MuJoCo's import loads an OpenGL binding for rendering in this process (GLFW: 30 ms of every
  command's start). The CLI renders only in subprocesses (harness/render.py runs
  ``python -m harness.render`` with the backend it picks), so the command imports MuJoCo with
  ``MUJOCO_GL=disable`` and puts the variable back at once: those subprocesses, and anything
  else started from here, see the user's environment.
- Interpreter teardown, which frees every module's objects one by one (0.1 s with sympy loaded,
  and after a parallel ``check`` it comes when the workers are done): every file a command
  writes is closed and every worker pool shut down before ``main`` returns, so the command
  flushes its output and exits with main's code at once.

Library use (``from harness import ...``, tests) goes through neither.
"""

from __future__ import annotations

import os
import sys


def import_mujoco_without_gl() -> None:
    """Import MuJoCo (if not yet imported) with its in-process OpenGL context disabled."""
    if "mujoco" in sys.modules:
        return
    user = os.environ.get("MUJOCO_GL")
    os.environ["MUJOCO_GL"] = "disable"
    try:
        import mujoco  # noqa: F401
    finally:
        if user is None:
            del os.environ["MUJOCO_GL"]
        else:
            os.environ["MUJOCO_GL"] = user


def entry() -> None:
    import_mujoco_without_gl()
    from harness.cli import main

    code = main()
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)


if __name__ == "__main__":
    entry()
