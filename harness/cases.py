"""The case registry: every system the harness checks, with its initial state and horizon.

CLI, pytest and CI all select from ``CASES``. A new system is one analytic
module, one MJCF model and one entry here.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

# A MuJoCo-side reading: (model, data) after mj_forward -> one number.
Reading = Callable[[Any, Any], float]


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
        binding: factory from the analytic coordinate names to the object that
            sets MuJoCo's state (default: ``JointBinding``, one same-named
            hinge/slide per coordinate).
        mujoco_invariants: extra invariants computed from MuJoCo's own state,
            by the name the reference uses (e.g. ``p_phi``); energy is always
            recorded.
        mujoco_forces: constraint forces for constraints that are not MJCF
            equalities (contacts), by the analytic constraint name, in the
            analytic sign convention.
    """

    name: str
    description: str
    q0: Mapping[str, float]
    qd0: Mapping[str, float]
    horizon: float
    system: str = ""
    mjcf: str = ""
    tags: frozenset[str] = field(default_factory=frozenset)
    binding: Callable[[tuple[str, ...]], Any] | None = None
    mujoco_invariants: Mapping[str, Reading] = field(default_factory=dict)
    mujoco_forces: Mapping[str, Reading] = field(default_factory=dict)

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
