"""The invariants family: what the motion conserves, as each integrator's run keeps it.

Figures ``INTEGRATOR.drift.NAME`` (MuJoCo's own energy, or a momentum MuJoCo's state gives, against its value at
t = 0: max |NAME(t) − NAME(0)| over its scale) and ``INTEGRATOR.NAME`` (against the reference's value), for the
energy and the case's MuJoCo-side invariants (a cyclic coordinate's momentum, ``p_phi``: read from MuJoCo's own
state, :mod:`harness.engine.readings.momentum`). Where the reference shows the quantity is not conserved by this
motion (damping, actuators), the drift is MuJoCo's change against the reference's change.

Budget: the runs' (:mod:`harness.families.runs`), as the trajectory family's: the invariants are compared over the
same runs and variants. Gated by default: every drift and every momentum against the reference (the energy
against the reference is not: its drift is).
"""

from __future__ import annotations

import mujoco

from harness.cases import Case
from harness.core.checks import Limit
from harness.core.deviation import Deviation
from harness.core.figures import FigureName
from harness.core.trajectory import Trajectory
from harness.engine.integrators import EXPECTED_ORDER
from harness.families import trajectory
from harness.families.bench import Bench, Measured
from harness.families.runs import Target, largest

__all__ = ["NAME", "compare", "gated", "measure", "names", "owns", "theory_limit"]

NAME = "invariants"

NOT_CONSERVED = 1e4
"""A reference invariant that changes by more than this × the reference's tolerance (× its scale) over the horizon
is not conserved by the motion (damping, actuators, gravity compensation): the change is physics, not the
reference's error (a conserved one drifts ≤ 7e-12 = 7 rtol on the shipped cases at rtol 1e-12, measured: ×1000 less).
Every force that is not conservative is then accounted for by the reference's own change: a fixed 1e-6 let MuJoCo's
car lose its wheels' damping (5e-7 of the energy scale) as unexplained drift. An invariant the motion conserves and
the reference misclassifies costs at most the reference's own drift, ~rtol: nothing a limit sees."""


def owns(name: FigureName) -> bool:
    return name.layer == "trajectory" and name.quantity not in (*trajectory.QUANTITIES, "balance")


def names(case: Case, model: mujoco.MjModel) -> set[FigureName]:
    invariants = ["energy", *case.mujoco_invariants]
    found: set[FigureName] = set()
    for integrator in EXPECTED_ORDER:
        found |= {FigureName.trajectory(integrator, i) for i in invariants}
        found |= {FigureName.trajectory(integrator, "drift", i) for i in invariants}
    return found


def gated(name: FigureName, *, constrained: bool) -> bool:
    return name.quantity == "drift" or name.quantity.startswith("p_")


def theory_limit(name: FigureName) -> Limit | None:
    return None


def compare(target: Target, sim: Trajectory, prefix: str) -> list[Deviation]:
    """This family's figures of one run (its integrator ``prefix``): each invariant's drift, and the invariant
    against the reference's."""
    ref, scales = target.reference, target.scales
    out = []
    for name, values in sim.invariants.items():
        scale = scales.energy if name == "energy" else scales.momentum
        size = max(largest(ref.invariants.get(name, values)) / scale, 1.0)
        drift, what = values - values[0], f"max |{name}(t) − {name}(0)| of MuJoCo's own {name}, / {scale:.4g}"
        if name in ref.invariants and \
                largest(ref.invariants[name] - ref.invariants[name][0]) > NOT_CONSERVED * target.rtol * scale:
            # not an invariant of this motion (damping, actuators): MuJoCo's change against the reference's change
            drift = drift - (ref.invariants[name] - ref.invariants[name][0])
            what = f"max |Δ{name}_mj(t) − Δ{name}_ref(t)| ({name} is not conserved here), / {scale:.4g}"
        out.append(Deviation(FigureName.trajectory(prefix, "drift", name), drift, "scalar", "1", what, scale=scale,
                             size=size))
        if name in ref.invariants:
            out.append(Deviation(FigureName.trajectory(prefix, name), values - ref.invariants[name], "scalar", "1",
                                 f"max |{name}_mj − {name}_ref| / {scale:.4g}", scale=scale, size=size))
    return out


def measure(bench: Bench) -> Measured:
    return bench.measured_over_runs(owns)
