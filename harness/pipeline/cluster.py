"""Calls as tasks on a Ray cluster: :func:`harness.pipeline.pool.run_tasks` with ``Executor("ray")``.

- **Where.** The cluster at the executor's address, else at ``RAY_ADDRESS``, else a local one that this
  process starts at its first call (every CPU of the machine, one a task) and stops when it ends
  (:func:`shutdown`), never one that happens to run on this machine already (Ray's own ``ray.init()``
  would join the last cluster ``ray start`` started here). One connection serves every call of a command.
- **Authentication.** A cluster started with ``ray start --head`` where a token exists
  (``~/.ray/auth_token``, ``RAY_AUTH_TOKEN``, ``RAY_AUTH_TOKEN_PATH``) requires it (Ray 2.52 and later): a
  driver given that cluster's address uses the token when ``RAY_AUTH_MODE`` is unset, as Ray's own
  ``ray.init()`` does for a cluster it finds by itself (docs/sweeps.md, "Ray's authentication").
  ``RAY_AUTH_MODE`` set (``token``, ``disabled``) is Ray's, and obeyed.
- **Output.** Ray's own messages (a worker died, a task retried) go to stderr, never to stdout: stdout
  carries only what the command prints (``check --json``: the document alone).
- **What travels.** A :class:`~harness.pipeline.carry.Carried` model among a call's arguments is put in
  the cluster's object store once, however many calls name it; the task unpacks it on its node. To a
  cluster of its own address the harness's packages (``analytic``, ``harness``,
  ``mjcf``) go as the job's ``runtime_env`` ``py_modules``, so every node runs the code of this process
  (its nodes need the harness's dependencies: ``pip install 'mjharness[ray]'``). A local cluster's
  workers are started from this process's environment and import what it imports.
- **A task.** Each call is one task of one CPU, named ``mjharness:LABEL`` (its worker's process title
  is ``ray::mjharness:LABEL``), running MuJoCo on one thread as the local pool's workers do; a call
  computes the same numbers wherever it runs, so its result is the local pool's, bit for bit.
- **Faults.** A worker that dies mid-task (killed, out of memory, its node lost) is rerun by Ray, up
  to :data:`RETRIES` times; a call is deterministic, so a rerun gives the same result. A call whose
  reruns are spent, or that the cluster cannot run, fails for good: ``failed(i, reason)`` takes its
  place, else :class:`~harness.pipeline.pool.TaskLost` is raised with one line naming it. A call's own
  error is no fault of the cluster: it is not rerun, and is raised once every earlier call has
  finished, as the local pool raises it.
- **Ctrl-C.** Every unfinished task is cancelled with force (its worker process killed) before the
  interrupt goes on, so nothing of the run keeps a cluster's CPUs busy.
"""

from __future__ import annotations

import atexit
import logging
import os
import socket
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import ray
import ray.exceptions

from harness.pipeline.carry import Carried
from harness.pipeline.executor import Executor, TaskLost

__all__: list[str] = []

RETRIES = 3
"""Ray's reruns of a task whose worker died: a killed worker, a node lost mid-run."""

PACKAGES = ("analytic", "harness", "mjcf")
"""The harness's own packages, sent to a cluster of its own address with every task."""


def address(executor: Executor) -> str | None:
    """The cluster ``executor`` names: its address, else ``RAY_ADDRESS``, else None (a local one)."""
    return executor.address or os.environ.get("RAY_ADDRESS") or None


def _runtime_env() -> dict:
    root = Path(__file__).resolve().parents[2]
    return {"py_modules": [str(root / name) for name in PACKAGES], "excludes": ["__pycache__", "*.pyc"],
            "env_vars": {"MUJOCO_GL": "disable"}}


def _reachable(where: str) -> None:
    """ValueError (one line) where ``where`` is no HOST:PORT that answers: Ray itself would retry for minutes."""
    if where == "auto" or "://" in where:  # Ray's own forms (the local node's cluster, Ray Client): Ray checks them
        return
    host, _, port = where.rpartition(":")
    accepted = ("accepted: the address `ray start --head` printed (HOST:PORT), or none (no --ray-address, no "
                "RAY_ADDRESS) for a local cluster")
    if not host or not port.isdigit():
        raise ValueError(f"Ray address {where!r} is not HOST:PORT; {accepted}")
    try:
        socket.create_connection((host, int(port)), timeout=5).close()
    except OSError as exc:
        raise ValueError(f"no Ray cluster answers at {where} ({exc.strerror or exc}); {accepted}") from None


def _token_auth() -> None:
    """Token authentication for a cluster of a given address where a token exists and ``RAY_AUTH_MODE`` is
    unset: ``ray start --head`` turns it on there, and Ray's driver does so only for a cluster it finds by
    itself, never for an address it is given (it would then be refused: "InvalidAuthToken")."""
    from ray._private.authentication import authentication_token_setup as setup  # lazy: Ray's own rule, reused

    said = logging.getLogger(setup.__name__)
    level = said.level
    said.setLevel(logging.ERROR)  # its warning that the token is used: docs/sweeps.md says so once and for all
    try:
        setup.maybe_enable_token_auth_if_token_available(warn_if_disabled=False)
    finally:
        said.setLevel(level)


def _ray_output_to_stderr() -> None:
    """Ray's driver prints the cluster's error messages ("(raylet) A worker died …") to stdout, log_to_driver
    or not: sent to stderr instead, so that stdout is the command's own."""
    worker = ray._private.worker
    if getattr(worker.print_to_stdstream, "_to_stderr", False):
        return
    original = worker.print_to_stdstream

    def to_stderr(data, ignore_prefix: bool) -> None:
        original({**data, "is_err": True}, ignore_prefix)

    # a mark on the function, found by name (a function's attributes are not in its type)
    to_stderr._to_stderr = True  # type: ignore[attr-defined]
    worker.print_to_stdstream = to_stderr


def connect(executor: Executor) -> None:
    """Connect to the cluster ``executor`` names, or start a local one of this process's own, unless
    connected already."""
    if ray.is_initialized():
        return
    where = address(executor)
    if where is not None:
        _reachable(where)
    _ray_output_to_stderr()
    try:
        if where is None:  # "local": a cluster of its own, never the last one `ray start` started here
            ray.init(address="local", include_dashboard=False, log_to_driver=False, logging_level=logging.ERROR,
                     runtime_env={"env_vars": {"MUJOCO_GL": "disable"}})
        else:
            _token_auth()
            ray.init(address=where, log_to_driver=False, logging_level=logging.ERROR, runtime_env=_runtime_env())
    except ray.exceptions.AuthenticationError as exc:
        raise ValueError(f"the Ray cluster at {where!r} refused this run's authentication: "
                         f"{' '.join(str(exc).split())[:160]}; fix: put the cluster's token in ~/.ray/auth_token "
                         "(`ray get-auth-token` prints it on the head node) or RAY_AUTH_TOKEN, or start the "
                         "cluster with RAY_AUTH_MODE=disabled on a trusted network") from None
    except (ConnectionError, RuntimeError, ValueError) as exc:
        untokened = where is not None and os.environ.get("RAY_AUTH_MODE", "").lower() != "token"
        raise ValueError(f"cannot connect to the Ray cluster at {where!r}: {' '.join(str(exc).split())[:200]}; "
                         "accepted: an address that `ray start --head` printed (host:port), or none for a "
                         "local cluster" + ("; a cluster with token authentication (Ray's default where "
                                            "~/.ray/auth_token exists on its head node) needs its token here too: "
                                            "in ~/.ray/auth_token or RAY_AUTH_TOKEN" if untokened else "")) from None
    atexit.register(shutdown)


def shutdown() -> None:
    """Disconnect from the cluster (a local one that this process started stops with it)."""
    if ray.is_initialized():
        ray.shutdown()


def _call(fn: Callable[..., Any], *args: Any) -> Any:
    from harness.engine import recording  # lazy: imported in the worker, where the task runs

    recording.set_threads(1)  # one task per CPU: the tasks, not MuJoCo's threads, share the cores
    return fn(*args)


_task = ray.remote(num_cpus=1, max_retries=RETRIES, retry_exceptions=False)(_call)


def _reason(exc: BaseException) -> str:
    """One line for a task lost for good."""
    kinds = {ray.exceptions.WorkerCrashedError: f"its worker died on every try ({RETRIES + 1})",
             ray.exceptions.NodeDiedError: "its node was lost",
             ray.exceptions.OutOfMemoryError: "its worker ran out of memory",
             ray.exceptions.TaskCancelledError: "it was cancelled",
             ray.exceptions.RuntimeEnvSetupError: "its runtime environment could not be set up"}
    for kind, text in kinds.items():
        if isinstance(exc, kind):
            return text
    return f"{type(exc).__name__}: {' '.join(str(exc).split())[:160]}"


def run_tasks(calls: Sequence[tuple[Callable[..., Any], tuple]], executor: Executor, *,
              on_done: Callable[[int, Any], None] | None = None, failed: Callable[[int, str], Any] | None = None,
              labels: Sequence[str] | None = None) -> list:
    """``fn(*args)`` for every call, each a task on the cluster; results in the order of ``calls``
    (see the module's docstring for faults and Ctrl-C)."""
    if not calls:
        return []
    connect(executor)
    names = list(labels) if labels is not None else [f"{fn.__name__} {i}" for i, (fn, _) in enumerate(calls)]
    stored: dict[str, ray.ObjectRef] = {}  # a carried model in the object store once (a top-level argument
    # that is a reference reaches the task as its value)

    def put(arg: Any) -> Any:
        if isinstance(arg, Carried):
            if arg.digest not in stored:
                stored[arg.digest] = ray.put(arg)
            return stored[arg.digest]
        return arg

    refs = [_task.options(name=f"mjharness:{names[i]}").remote(fn, *map(put, args))
            for i, (fn, args) in enumerate(calls)]
    index = {ref: i for i, ref in enumerate(refs)}
    results: dict[int, Any] = {}
    errors: dict[int, BaseException] = {}
    pending = list(refs)
    next_in_order = 0
    try:
        while pending:
            # with a timeout: a wait without one holds Ctrl-C until some task ends (minutes, for a long one)
            ready, pending = ray.wait(pending, num_returns=1, timeout=0.25)
            if not ready:
                continue
            i = index[ready[0]]
            try:
                results[i] = ray.get(ready[0])
            except ray.exceptions.RayTaskError as exc:  # the call's own error: raised in call order
                errors[i] = exc.cause if isinstance(exc.cause, BaseException) else exc
            except ray.exceptions.RayError as exc:  # lost for good
                reason = _reason(exc)
                if failed is None:
                    errors[i] = TaskLost(f"{names[i]}: its Ray task failed for good: {reason}")
                else:
                    results[i] = failed(i, reason)
            if i in results and on_done is not None:
                on_done(i, results[i])
            while next_in_order in results or next_in_order in errors:
                if next_in_order in errors:
                    raise errors[next_in_order]
                next_in_order += 1
    except BaseException:  # an error raised, or Ctrl-C: nothing of this run goes on on the cluster
        for ref in pending:
            ray.cancel(ref, force=True)
        raise
    return [results[i] for i in range(len(calls))]
