"""A Check: one figure beside its limit, and the verdict it gets.

A gated figure is judged one of two ways (its limit's basis, :mod:`harness.pipeline.limits`):

- by its error **budget** (:class:`~harness.core.budget.Budget`): what the
  model's own settings explain is removed, and the unexplained residual must
  lie within the limit the estimates' accuracy sets. ``threshold`` is that
  limit, and ``value`` the figure as measured;
- by a fixed limit from **theory** (or a user's config): ``value`` ≤ ``threshold``.

A :class:`Limit` says which, with its basis; the families declare their figures' theory limits
(:mod:`harness.families`), the shipped limits files which figures are gated (:mod:`harness.pipeline.limits`).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Literal

from harness.core.budget import Budget
from harness.core.figures import FigureName

__all__ = ["BASES", "Check", "Limit", "closest", "gate", "ratio"]

Basis = Literal["budget", "theory", "user"]
BASES = ("budget", "theory")


@dataclass(frozen=True)
class Limit:
    """One figure's limit and its basis (see the module docstring): ``value`` for a theory or user
    limit (on the figure), none for a budget (computed per run)."""

    basis: Basis
    value: float | None = None
    reason: str = ""

    def __post_init__(self) -> None:
        if self.basis not in (*BASES, "user"):
            raise ValueError(f"a limit's basis must be {', '.join(BASES)} or user, got {self.basis!r}")
        if self.basis == "budget":
            if self.value is not None:
                raise ValueError("a budget limit has no value: the budget computes it for each run")
            return
        if isinstance(self.value, bool) or not isinstance(self.value, int | float) or not math.isfinite(self.value) \
                or self.value <= 0:
            raise ValueError(f"a {self.basis} limit must be a positive number, got {self.value!r}")
        if self.basis == "theory" and not self.reason:
            raise ValueError("a theory limit must say what bound it is (reason)")

    def describe(self) -> str:
        """One line: the basis and its reason."""
        if self.basis == "budget":
            return "budget: the unexplained residual within the estimates' accuracy (harness/core/budget.py)"
        return f"{self.basis}: {self.reason}" if self.reason else self.basis


@dataclass(frozen=True)
class Check:
    """A figure beside its limit.

    Attributes:
        value: the figure as measured.
        threshold: the limit: on the budget's unexplained residual where ``budget`` is set, else on
            ``value``.
        note: non-empty for a check this MuJoCo cannot measure (an integrator it lacks): n/a, with the
            note; not a failure.
        known: non-empty for a failure that shows the signature of a documented defect of this MuJoCo
            (harness.engine.compat.KNOWN_DEFECTS): still a failure, shown with the reason; a run passes
            the gate despite it only where the user accepts known defects (:func:`gate`).
        budget: the figure's error budget, where it is judged by one.
        diverged: non-empty where the run the figure comes from could not be measured ("diverged:
            mjWARN_BADQACC at t = 0.25 s"): a failure with that reason and no number.
    """

    case: str
    name: FigureName
    value: float
    threshold: float
    unit: str
    note: str = ""
    known: str = ""
    budget: Budget | None = None
    diverged: str = ""

    def __post_init__(self) -> None:
        object.__setattr__(self, "name", FigureName(self.name))

    @property
    def judged(self) -> float:
        """What the limit applies to: the unexplained residual of the budget, or the figure itself."""
        return self.budget.unexplained if self.budget is not None else self.value

    @property
    def passed(self) -> bool:
        if self.note:
            return True
        return not self.known and not self.diverged and math.isfinite(self.judged) and self.judged <= self.threshold

    @property
    def reason(self) -> str:
        """What a verdict says beside its status: why it is n/a, the known defect, or why the run could
        not be measured ('' if none)."""
        return self.note or self.known or self.diverged

    @property
    def status(self) -> str:
        """``pass``, ``FAIL``, ``FAIL (known defect)`` or ``n/a`` (not measurable here)."""
        if self.note:
            return "n/a"
        if self.known:
            return "FAIL (known defect)"
        return "pass" if self.passed else "FAIL"

    @property
    def ratio(self) -> float:
        """judged / threshold: below 1 passes (nan where not measured)."""
        if self.note or not self.threshold > 0:
            return math.nan
        return self.judged / self.threshold


def gate(checks: Iterable[Check], *, accept_known_defects: bool = False) -> bool:
    """Whether a run passes: every check passes, or (with ``accept_known_defects``) every failure is a
    documented defect of this MuJoCo whose signature the figure shows."""
    return all(c.passed or (accept_known_defects and c.known) for c in checks)


def ratio(check: Check) -> float:
    """Share of its limit a check uses (the unexplained residual's, for a budget): ≤ 1 passes (a
    non-finite figure fails: inf); nan for a check this MuJoCo cannot measure (n/a)."""
    if check.note:
        return float("nan")
    judged = check.judged
    if not math.isfinite(judged) or not check.threshold > 0:
        return float("inf")
    return judged / check.threshold


def closest(checks: Sequence[Check]) -> Check | None:
    """The measurable check using the largest share of its limit."""
    return max((c for c in checks if not c.note), key=ratio, default=None)
