"""The smallest energy injection a model's work–energy balance detects: energy that no force in MuJoCo's accounts
explains.

The balance (harness/families/balance.py) judges a model as it is, contacts, limits and all: its energy may change
only by the work of the forces MuJoCo reports. How small an unaccounted gain it sees depends on the model (its
timestep, its impacts, how well h, h/2, h/4 resolve them), so it is measured per model:

- the engine's model gets one extra force on the hinge or slide that carries the most mass, pushing along its
  velocity, f = c q̇ with c = s × M_jj √(g/L) (the damping fault's scale, harness/studies/engine_faults.py, with
  the sign that feeds energy in: a negative damper of s times the model's natural rate);
- MuJoCo applies it through an actuator, whose work the accounts then leave out (:func:`unaccounted`): to the
  balance it is energy from nothing, as a force missing from MuJoCo's reports or an integrator's defect would be;
- :func:`smallest_injection` bisects s over the decades :data:`SIZES_SEARCHED`: caught
  where a balance check fails that passes without it, on the integrators given; the size is reported with the
  energy injected over the horizon at that s, against the model's energy scale and its peak kinetic energy.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from harness.cases.own import from_mjcf
from harness.core.errors import SimulationDiverged
from harness.engine import backends
from harness.engine.integrators import EXPECTED_ORDER
from harness.engine.models import compile_model
from harness.engine.probe import Probe
from harness.engine.readings import Reading
from harness.engine.recording import steps_in
from harness.engine.variants import compose
from harness.families.balance import POWER, POWER_FIELDS, balance_figures, cumulative_work
from harness.reference.tree import TreeEdit, prepare
from harness.studies.engine_faults import SIZES, bisect_decades, damping_scale

__all__ = ["INJECTED", "SIZES_SEARCHED", "Injection", "injector", "smallest_injection", "unaccounted"]

INJECTOR = "mjharness_injection"
"""The name of the actuator that injects the energy (added last: the model's own actuators keep their indices)."""
INTEGRATORS = ("RK4", "Euler")
SIZES_SEARCHED = (10.0, 1.0, *SIZES)
"""The decades of s searched, largest first: from 10 (a negative damper ten times the model's natural rate, which on a
joint that barely moves may still feed in little) down to the engine faults' 1e-13."""
"""RK4 resolves the smallest balances; Euler's is judged where RK4's impacts leave its balance not judged."""

Edit = Callable[[mujoco.MjSpec], None]


def main_dof_joint(model: mujoco.MjModel) -> str | None:
    """The hinge or slide whose body carries the most mass (its subtree), first in the model on a tie."""
    kinds = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))
    joints = [j for j in range(model.njnt) if int(model.jnt_type[j]) in kinds]
    if not joints:
        return None
    return model.joint(max(joints, key=lambda j: (float(model.body_subtreemass[int(model.jnt_bodyid[j])]), -j))).name


def injector(joint: str, rate: float) -> Edit:
    """An actuator on ``joint`` whose force is ``rate`` × the joint's velocity (N·m·s/rad or N·s/m), whatever the
    control: a negative damper, feeding energy in at ``rate`` q̇²."""
    def edit(spec: mujoco.MjSpec) -> None:
        actuator = spec.add_actuator(name=INJECTOR, target=joint, trntype=mujoco.mjtTrn.mjTRN_JOINT)
        actuator.gaintype = mujoco.mjtGain.mjGAIN_FIXED  # a unit gain: the runs keep ctrl at 0 (MuJoCo 4.0 compiles
        gain = np.zeros(len(actuator.gainprm))           # a zero gain's bias to zero as well)
        gain[0] = 1.0
        actuator.gainprm = gain
        actuator.biastype = mujoco.mjtBias.mjBIAS_AFFINE
        bias = np.zeros(len(actuator.biasprm))
        bias[2] = rate
        actuator.biasprm = bias
        actuator.ctrllimited = mujoco.mjtLimited.mjLIMITED_FALSE
        actuator.forcelimited = mujoco.mjtLimited.mjLIMITED_FALSE
    edit.__qualname__ = f"injector({joint!r}, {rate:g})"
    return edit


def _injected_power(model: mujoco.MjModel, recorded: Mapping[str, np.ndarray]) -> np.ndarray:
    k = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, INJECTOR)
    if k < 0:
        return np.zeros(len(recorded["qvel"]))
    return recorded["actuator_force"][:, k] * recorded["actuator_velocity"][:, k]


INJECTED = Reading(fields=("actuator_force", "actuator_velocity"), evaluate=_injected_power,
                   description="the injector's power (W)")


def _unaccounted_power(model: mujoco.MjModel, recorded: Mapping[str, np.ndarray]) -> np.ndarray:
    return POWER.evaluate(model, recorded) - _injected_power(model, recorded)


def unaccounted() -> Reading:
    """The balance's power without the injector's: the energy it feeds in is then accounted to no force."""
    return Reading(fields=(*POWER_FIELDS, *INJECTED.fields), evaluate=_unaccounted_power,
                   description="the power of every force but the injector's (W)")


def _kinetic(model: mujoco.MjModel, recorded: Mapping[str, np.ndarray]) -> np.ndarray:
    return recorded["energy"][:, 1]


KINETIC = Reading(fields=("energy",), evaluate=_kinetic, description="MuJoCo's kinetic energy (J)")


@dataclass(frozen=True)
class Injection:
    """The smallest injection caught on one model: s (nan: not caught at the largest; None: no hinge or slide to
    inject on, ``note`` says why), its rate, the balance check that caught it there, and the energy it fed in over
    the horizon against the model's energy scale and its peak kinetic energy."""

    model: str
    joint: str | None
    size: float | None
    rate: float = math.nan
    deciding: str = ""
    energy: float = math.nan
    of_scale: float = math.nan
    of_kinetic: float = math.nan
    note: str = ""
    runs: int = 0
    seconds: float = 0.0
    crashed: str = ""
    unfinished: str = ""


def smallest_injection(path: Path | str, *, name: str | None = None, horizon: float | None = None,
                       integrators: Sequence[str] = INTEGRATORS) -> Injection:
    """The smallest injection the balance of the model at ``path`` catches, judged as ``check --mjcf`` judges the
    model as it is (its start, its horizon, its control)."""
    path = Path(path)
    name = name or path.stem
    clock = time.perf_counter()
    case = from_mjcf(path, horizon=horizon)
    joint = main_dof_joint(compile_model(path, edit=prepare))
    if joint is None:
        return Injection(name, None, None, note="no hinge or slide")
    ref = case.reference(compile_model(path, edit=case.prepare))
    assert case.tree is not None  # from_mjcf: a model judged against its own tree
    as_is = TreeEdit(isolating=False, ctrl=case.tree.ctrl)
    binding = case.probe(ref.dynamics).binding
    scale = damping_scale(compile_model(path, edit=prepare), joint)
    not_examined = [k for k, _ in case.tree.uncovered]

    def failing(rate: float) -> dict[str, float]:
        edit = compose(as_is, injector(joint, rate))
        _, budgets, diverged, _ = balance_figures(
            path, edit, binding, integrators=integrators, q0=ref.q0(), qd0=ref.qd0(), horizon=case.horizon,
            energy_scale=ref.scales.energy, orders=EXPECTED_ORDER, not_examined=not_examined, power=unaccounted(),
            engine=backends.get("c"))
        return {k: (b.unexplained / b.limit if b.limit > 0 else math.inf) for k, b in budgets.items()
                if not b.passed} | dict.fromkeys(diverged, math.inf)

    already = failing(0.0)

    def detects(s: float) -> str:
        new = {k: r for k, r in failing(s * scale).items() if k not in already}
        return max(new, key=new.__getitem__) if new else ""

    size, deciding, runs = bisect_decades(detects, SIZES_SEARCHED)
    note = f"fails without an injection: {', '.join(sorted(already))}" if already else ""
    if math.isnan(size):  # not caught even at the largest: say how much energy that fed in
        try:
            energy, peak = _injected(path, compose(as_is, injector(joint, SIZES_SEARCHED[0] * scale)), binding,
                                     q0=ref.q0(), qd0=ref.qd0(), horizon=case.horizon)
            missed = (f"at s = {SIZES_SEARCHED[0]:g} it fed in {energy / peak if peak > 0 else math.inf:.1e} of the "
                      f"peak kinetic energy, {energy / ref.scales.energy:.1e} of m g L")
        except SimulationDiverged as exc:  # the model's own integrator could not carry that much
            missed = f"at s = {SIZES_SEARCHED[0]:g} its run at the model's own integrator {exc.reason}"
        return Injection(name, joint, size, note="; ".join(n for n in (missed, note) if n), runs=runs + 1,
                         seconds=time.perf_counter() - clock)
    rate = size * scale
    try:
        energy, peak = _injected(path, compose(as_is, injector(joint, rate)), binding, q0=ref.q0(), qd0=ref.qd0(),
                                 horizon=case.horizon)
    except SimulationDiverged as exc:  # caught because it blew the run up: no energy to tell
        note = "; ".join(n for n in (f"its run at the model's own integrator {exc.reason}", note) if n)
        energy, peak = math.nan, math.nan
    return Injection(name, joint, size, rate, deciding, energy, energy / ref.scales.energy,
                     energy / peak if peak > 0 else math.nan, note, runs + 1, time.perf_counter() - clock)


def _injected(path: Path, edit: Edit, binding, *, q0: np.ndarray, qd0: np.ndarray, horizon: float
              ) -> tuple[float, float]:
    """The energy the injector fed in over the horizon (J) and the run's peak kinetic energy (J), at the model's
    own integrator and timestep."""
    model = compile_model(path, edit=edit)
    h = float(model.opt.timestep)
    probe = Probe(binding=binding, points=(), constraints=(), series={"injected": INJECTED, "kinetic": KINETIC})
    run = backends.simulate(backends.get("c"), model, probe, q0=q0, qd0=qd0, steps=steps_in(horizon, h))
    return float(cumulative_work(run.series["injected"], h)[-1]), float(np.max(run.series["kinetic"]))

