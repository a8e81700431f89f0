"""Where a command's runs go: :class:`Executor` (this machine's process pool or a Ray cluster), and
:class:`TaskLost`, a run the cluster could not carry out (:mod:`harness.pipeline.cluster`)."""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["EXECUTORS", "LOCAL", "Executor", "TaskLost"]

EXECUTORS = ("local", "ray")
"""Where :func:`run_tasks` runs its calls: this machine's process pool, or tasks on a Ray cluster."""


@dataclass(frozen=True)
class Executor:
    """Where calls run: ``local`` (worker processes forked from this one) or ``ray`` (one Ray task a call,
    :mod:`harness.pipeline.cluster`) on the cluster at ``address``, else at ``RAY_ADDRESS``, else on a local
    cluster that the run starts and stops."""

    kind: str = "local"
    address: str | None = None

    def __post_init__(self) -> None:
        if self.kind not in EXECUTORS:
            raise ValueError(f"unknown executor {self.kind!r}; accepted: {', '.join(EXECUTORS)}")
        if self.address is not None and self.kind != "ray":
            raise ValueError("a Ray address needs --executor ray")


LOCAL = Executor()


class TaskLost(RuntimeError):
    """A call that failed for good on the cluster (its worker died on every retry, its node was lost), not
    by an error of its own: the message is one line naming the call and why."""
