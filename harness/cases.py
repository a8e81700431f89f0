"""The case registry: every system the harness checks, with its initial state and horizon.

CLI, pytest and CI all select from ``CASES``. A new system is one analytic
module, one MJCF model and one entry here.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field


@dataclass(frozen=True)
class Case:
    """One validation case.

    Attributes:
        name: case id (CLI name, test id, report section, config table).
        description: one line for ``mjharness list`` and the report.
        q0, qd0: initial state in the analytic coordinates, by name; it must
            satisfy the constraints (the reference refuses otherwise).
        horizon: simulated time in seconds.
        system: analytic module under ``analytic.systems`` (default: name).
        mjcf: model file under ``mjcf/`` without ``.xml`` (default: name).
        tags: selection tags (``fast``, ``ci``, ``constrained`` ...).
    """

    name: str
    description: str
    q0: Mapping[str, float]
    qd0: Mapping[str, float]
    horizon: float
    system: str = ""
    mjcf: str = ""
    tags: frozenset[str] = field(default_factory=frozenset)

    def __post_init__(self) -> None:
        object.__setattr__(self, "system", self.system or self.name)
        object.__setattr__(self, "mjcf", self.mjcf or self.name)
        if set(self.q0) != set(self.qd0):
            raise ValueError(f"case {self.name!r}: q0 and qd0 must name the same coordinates")
        if not self.horizon > 0:
            raise ValueError(f"case {self.name!r}: horizon must be positive, got {self.horizon}")


CASES: tuple[Case, ...] = (
    Case(
        name="pendulum",
        description="planar pendulum, length held by a constraint (multiplier = −rod tension)",
        q0={"theta": 1.0, "r": 1.0},
        qd0={"theta": 0.5, "r": 0.0},
        horizon=5.0,
        tags=frozenset({"fast", "ci", "constrained"}),
    ),
)


def names() -> tuple[str, ...]:
    return tuple(c.name for c in CASES)


def get(name: str) -> Case:
    """The case called ``name``; ValueError listing the known ones otherwise."""
    for case in CASES:
        if case.name == name:
            return case
    raise ValueError(f"unknown case {name!r}; known cases: {', '.join(names())}")


def select(requested: Iterable[str] = (), *, tag: str | None = None) -> tuple[Case, ...]:
    """Cases by name (all when none are given), optionally only those with ``tag``."""
    requested = list(requested)
    chosen = tuple(get(n) for n in requested) if requested else CASES
    return tuple(c for c in chosen if tag is None or tag in c.tags)
