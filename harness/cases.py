"""The case registry: every system the harness checks, with its initial state and horizon.

CLI, pytest and CI all select from ``CASES``. A new system is one analytic
module, one MJCF model and one entry here.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

from harness.ball_binding import BallBinding
from harness.contact import analytic_residual, slide_force
from harness.momentum import axial_angular_momentum
from harness.readings import Reading

__all__ = ["CASES", "Case", "Reading", "Series", "get", "names", "select"]


@dataclass(frozen=True)
class Series:
    """A MuJoCo-only time series with no reference counterpart (a contact's slip
    velocity, its penetration), reported per integrator as its max |·| over the horizon."""

    read: Reading
    unit: str
    description: str


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
        mujoco_series: MuJoCo-only series (``Series``), e.g. the slip velocity
            of a contact, each reported as the figure ``INTEGRATOR.series.NAME``.
        settle: seconds after which force figures are taken. A soft contact
            builds its force from slip or penetration, so at t = 0 it has none
            of its own; 0 (compare from the start) for equalities.
        cost: seconds a ``mjharness check`` of this case alone takes once its
            system's derivation is cached (measured with benchmarks/bench.py,
            part 5, on the 2-core CI machine); a cold run adds the system's
            :data:`DERIVATION_COST`, once per system. Only orders a process
            pool's work, costliest first so that the cheapest fill the end;
            results never depend on it.
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
    mujoco_series: Mapping[str, Series] = field(default_factory=dict)
    settle: float = 0.0
    cost: float = 0.5

    def __post_init__(self) -> None:
        object.__setattr__(self, "system", self.system or self.name)
        object.__setattr__(self, "mjcf", self.mjcf or self.name)
        if set(self.q0) != set(self.qd0):
            raise ValueError(f"case {self.name!r}: q0 and qd0 must name the same coordinates")
        if not self.horizon > 0:
            raise ValueError(f"case {self.name!r}: horizon must be positive, got {self.horizon}")
        if not self.cost > 0:
            raise ValueError(f"case {self.name!r}: cost must be positive, got {self.cost}")
        if not 0 <= self.settle < self.horizon:
            raise ValueError(f"case {self.name!r}: settle must be in [0, horizon), got {self.settle}")


# Seconds a cold derivation of each system adds to its first case (sympy: derive, simplify, lambdify at
# the model's parameters; measured like Case.cost, without sympy's own import). Only orders a pool's work.
DERIVATION_COST: Mapping[str, float] = {
    "pendulum": 0.57, "hoop_ramp": 0.46, "spherical_pendulum": 0.42, "hoop_plane": 0.22, "atwood": 0.16,
    "spring": 0.04,
}

CASES: tuple[Case, ...] = (
    Case(
        name="pendulum",
        description="planar pendulum, length held by a constraint (multiplier = −rod tension)",
        q0={"theta": 1.0, "r": 1.0},
        qd0={"theta": 0.5, "r": 0.0},
        horizon=5.0,
        tags=frozenset({"fast", "ci", "constrained"}),
        cost=0.45,
    ),
    Case(
        name="spherical_pendulum",
        description="spherical pendulum on two hinges (azimuth, polar); precessing orbit, p_phi conserved",
        q0={"theta": 1.0, "phi": 0.0},
        qd0={"theta": 0.0, "phi": 2.0},  # conical orbit at θ = 1 needs φ̇ = √(g/(l cos θ)) = 4.26 rad/s
        horizon=5.0,
        tags=frozenset({"fast", "ci"}),
        cost=0.25,
        mujoco_invariants={"p_phi": axial_angular_momentum(body="bob", site="pivot")},
    ),
    Case(
        name="spherical_pendulum_ball",
        description="spherical pendulum on one ball joint (quaternion state); same orbit as spherical_pendulum",
        system="spherical_pendulum",
        mjcf="spherical_pendulum_ball",
        q0={"theta": 1.0, "phi": 0.0},
        qd0={"theta": 0.0, "phi": 2.0},
        horizon=5.0,
        tags=frozenset({"fast", "ci"}),
        cost=0.11,
        binding=BallBinding,
        mujoco_invariants={"p_phi": axial_angular_momentum(body="bob", site="pivot")},
    ),
    Case(
        name="spring",
        description="mass on a horizontal spring: x = c1 sin ωt + c2 cos ωt, about 5 periods",
        q0={"x": 0.2},
        qd0={"x": 1.0},
        horizon=5.0,
        tags=frozenset({"fast", "ci"}),
        cost=0.17,
    ),
    Case(
        name="atwood",
        description="Atwood's machine, massive pulley; two string equalities (multipliers = tensions)",
        q0={"z1": 0.0, "z2": 0.0, "theta": 0.0},
        qd0={"z1": 0.0, "z2": 0.0, "theta": 0.0},  # from rest: consistent for any radius a
        horizon=1.5,
        tags=frozenset({"fast", "ci", "constrained"}),
        cost=0.14,
    ),
    Case(
        name="hoop_ramp",
        description="hoop rolling down a 30° incline, rolling and contact as joint equalities "
                    "(multipliers = friction, normal force)",
        q0={"x": 0.0, "s": 0.25, "phi": 0.0},
        qd0={"x": 0.5, "s": 0.0, "phi": 2.0},  # rolling: ẋ = a φ̇ with a = 0.25 m
        horizon=2.0,
        tags=frozenset({"fast", "ci", "constrained"}),
        cost=0.15,
    ),
    Case(
        name="hoop_ramp_contact",
        description="the hoop_ramp system on a real frictional contact (mj_contactForce), slip recorded",
        system="hoop_ramp",
        q0={"x": 0.0, "s": 0.25, "phi": 0.0},
        qd0={"x": 0.5, "s": 0.0, "phi": 2.0},
        horizon=2.0,
        tags=frozenset({"fast", "ci", "constrained", "contact"}),
        cost=0.13,
        mujoco_forces={"roll": slide_force(geom="rim", joint="x"),
                       "normal": slide_force(geom="rim", joint="s")},
        mujoco_series={
            "slip": Series(analytic_residual(system="hoop_ramp", constraints=("roll",), level="velocity"),
                           "m/s", "|ẋ − a φ̇|, the slip velocity at MuJoCo's state"),
            "creep": Series(analytic_residual(system="hoop_ramp", constraints=("roll",), level="position"),
                            "m", "|x − a φ|, the accumulated slip"),
            "penetration": Series(analytic_residual(system="hoop_ramp", constraints=("normal",),
                                                    level="position"),
                                  "m", "|s − a|, the contact's penetration"),
        },
    ),
    Case(
        name="hoop_plane",
        description="vertical hoop rolling on a plane, heading turning: circular path, Pfaffian rolling "
                    "rows on a frictional contact",
        q0={"x": 0.0, "y": 0.0, "z": 0.5, "theta": 0.0, "phi": 0.0},
        # v = a φ̇ = 1 m/s, θ̇ = 1 rad/s: a circle of radius 1 m about (0, 1)
        qd0={"x": 1.0, "y": 0.0, "z": 0.0, "theta": 1.0, "phi": 2.0},
        horizon=2.0,
        tags=frozenset({"fast", "ci", "constrained", "contact"}),
        cost=0.48,
        mujoco_forces={"roll_x": slide_force(geom="rim", joint="x"),
                       "roll_y": slide_force(geom="rim", joint="y"),
                       "normal": slide_force(geom="rim", joint="z")},
        mujoco_invariants={"p_theta": axial_angular_momentum(body="hoop", site="centre")},
        mujoco_series={
            "slip": Series(analytic_residual(system="hoop_plane", constraints=("roll_x", "roll_y"),
                                             level="velocity"),
                           "m/s", "|(ẋ − a φ̇ cos θ, ẏ − a φ̇ sin θ)|, the slip speed at MuJoCo's state"),
            "penetration": Series(analytic_residual(system="hoop_plane", constraints=("normal",),
                                                    level="position"),
                                  "m", "|z − a|, the contact's penetration"),
        },
        # the lateral friction needs a slip velocity to build (MuJoCo's friction rows
        # see J q̈ but not J̇ q̇); it settles within a few ms at solref 2 ms
        settle=0.02,
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
