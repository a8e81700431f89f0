"""Faults made on the engine's side alone: does the verdict still fail on a model nobody here wrote?

The reference is read from the unmodified file (``from_mjcf(path, reference=path)``);
the fault is an edit of the engine's model only (``validate(case, edit=fault)``), so
everything the harness measures against the tree is a fault of the engine's model:

- ``inertia``: the heaviest moving body's mass and inertia × (1 + s). Every body's
  compiled inertial is first written back into the model as an explicit one (and
  ``inertiafromgeom``/``settotalmass`` turned off), so that geoms' densities, explicit
  masses or a total-mass rescale cannot spread the change to other bodies: at s = 0 the
  compiled model is the original's (pinned by a test).
- ``damping``: extra viscous damping on the hinge that carries the most mass (the largest
  subtree), of s × M_jj √(g/L) (M_jj that joint's diagonal of the mass matrix at qpos0, L
  the tree's size): a damping that alone would decay the joint's motion at s times the
  model's natural rate.
- ``axis``: that hinge's axis tilted by s rad (turned about the coordinate axis least aligned
  with it, made perpendicular).

:func:`smallest_caught` finds the smallest size each fault fails the verdict at: a bisection
over the decades :data:`SIZES` (detection taken as monotonic in the size). "Caught" means a check
fails that does not fail without the fault, judged on the same integrators (default
:data:`INTEGRATORS`: RK4, the most accurate, where the faults stand out most cheaply).
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from harness.cases.own import from_mjcf
from harness.core.options import RunOptions
from harness.engine.models import compile_model
from harness.pipeline.limits import case_limits, load_limits
from harness.pipeline.run import run_case
from harness.pipeline.verdict import judge
from harness.reference.tree import prepare, read_tree, tree_scales

__all__ = ["CLAIMED", "FAULTS", "SIZES", "UNITS", "Caught", "bisect_decades", "damping_scale", "smallest_caught"]

FAULTS = ("inertia", "damping", "axis")
CLAIMED = {"inertia": 1e-2, "damping": 1e-2, "axis": 1e-3}
"""The sizes issue 29 names for each fault (× 1.01, an extra damping, 1e-3 rad): caught there or smaller."""
UNITS = {"inertia": "relative", "damping": "× M_jj √(g/L)", "axis": "rad"}
SIZES = tuple(10.0 ** -k for k in range(1, 14))
"""The decades searched, largest first: 1e-1 … 1e-13, down to round-off (a bisection: 5 runs a fault)."""
INTEGRATORS = ("RK4",)

Edit = Callable[[mujoco.MjSpec], None]


def heaviest_body(model: mujoco.MjModel) -> str:
    """The heaviest body that moves (has a joint on its path to the world)."""
    moving = [b for b in range(1, model.nbody) if _moves(model, b)]
    return model.body(max(moving, key=lambda b: float(model.body_mass[b]))).name


def _moves(model: mujoco.MjModel, b: int) -> bool:
    while b:
        if int(model.body_dofnum[b]):
            return True
        b = int(model.body_parentid[b])
    return False


def main_hinge(model: mujoco.MjModel) -> str | None:
    """The hinge whose body carries the most mass (its subtree), first in the model on a tie; None without one."""
    hinges = [j for j in range(model.njnt) if int(model.jnt_type[j]) == int(mujoco.mjtJoint.mjJNT_HINGE)]
    if not hinges:
        return None
    return model.joint(max(hinges, key=lambda j: (float(model.body_subtreemass[int(model.jnt_bodyid[j])]), -j))).name


def bake_inertials(spec: mujoco.MjSpec) -> None:
    """Every body's compiled mass and inertia written back as an explicit inertial, computed from nothing
    else (``inertiafromgeom`` false, no ``settotalmass``): one body's inertial then changes that body alone."""
    with warnings.catch_warnings():  # settotalmass's deprecation: the model's own, compiled as it is
        warnings.simplefilter("ignore")
        model = spec.compile()
    for body in spec.bodies[1:]:
        bid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, body.name)
        if bid < 0 or not model.body_mass[bid] > 0:
            continue  # fused into its parent, or massless: nothing of its own to keep
        body.mass = float(model.body_mass[bid])
        body.inertia = [float(x) for x in model.body_inertia[bid]]
        body.fullinertia = [math.nan, 0, 0, 0, 0, 0]
        body.ipos = [float(x) for x in model.body_ipos[bid]]
        body.iquat = [float(x) for x in model.body_iquat[bid]]
        body.explicitinertial = True
    spec.compiler.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_FALSE
    spec.compiler.settotalmass = -1.0


def inertia_fault(body: str, s: float) -> Edit:
    """``body``'s mass and inertia × (1 + s), every other body as compiled."""
    def edit(spec: mujoco.MjSpec) -> None:
        bake_inertials(spec)
        target = spec.body(body)
        target.mass = target.mass * (1.0 + s)
        target.inertia = [x * (1.0 + s) for x in target.inertia]
    edit.__qualname__ = f"inertia_fault({body!r}, {s:g})"
    return edit


def damping_scale(model: mujoco.MjModel, joint: str) -> float:
    """M_jj √(g/L) of ``joint`` at qpos0 (N·m·s/rad): the damping that decays its motion at the model's
    natural rate √(g/L), L the tree's size."""
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    dof = int(model.jnt_dofadr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, joint)])
    unit, column = np.zeros(model.nv), np.zeros(model.nv)
    unit[dof] = 1.0
    mujoco.mj_mulM(model, data, column, unit)
    length = tree_scales(read_tree(model)).length
    return float(column[dof]) * math.sqrt(9.81 / length)


def damping_fault(joint: str, extra: float) -> Edit:
    """``extra`` N·m·s/rad of viscous damping added to ``joint``."""
    def edit(spec: mujoco.MjSpec) -> None:
        target = spec.joint(joint)
        damping = np.array(target.damping, dtype=float)
        damping[0] += extra
        target.damping = damping
    edit.__qualname__ = f"damping_fault({joint!r}, {extra:g})"
    return edit


def tilted(axis: Sequence[float], angle: float) -> np.ndarray:
    """``axis`` (normalised) turned by ``angle`` rad towards the coordinate axis least aligned with it."""
    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    e = np.eye(3)[int(np.argmin(np.abs(a)))]
    u = np.cross(a, e)
    u /= np.linalg.norm(u)  # ⊥ a: the turn's own axis
    return a * math.cos(angle) + np.cross(u, a) * math.sin(angle)


def axis_fault(joint: str, angle: float) -> Edit:
    """``joint``'s axis tilted by ``angle`` rad."""
    def edit(spec: mujoco.MjSpec) -> None:
        target = spec.joint(joint)
        target.axis = tilted(target.axis, angle)
    edit.__qualname__ = f"axis_fault({joint!r}, {angle:g})"
    return edit


@dataclass(frozen=True)
class Target:
    """Where a model's faults are made: the heaviest moving body, the hinge carrying the most mass and its
    damping scale (None where the model has no hinge)."""

    body: str
    hinge: str | None
    damping_scale: float

    @classmethod
    def of(cls, path: Path | str) -> Target:
        model = compile_model(Path(path), edit=prepare)
        hinge = main_hinge(model)
        return cls(heaviest_body(model), hinge, damping_scale(model, hinge) if hinge else math.nan)

    def where(self, fault: str) -> str | None:
        return self.body if fault == "inertia" else self.hinge

    def edit(self, fault: str, s: float) -> Edit:
        if fault == "inertia":
            return inertia_fault(self.body, s)
        if self.hinge is None:
            raise ValueError(f"fault {fault!r} needs a hinge; the model has none")
        if fault == "damping":
            return damping_fault(self.hinge, s * self.damping_scale)
        if fault == "axis":
            return axis_fault(self.hinge, s)
        raise ValueError(f"unknown fault {fault!r}; known: {', '.join(FAULTS)}")


@dataclass(frozen=True)
class Caught:
    """One fault's smallest size caught on one model (nan: not caught at the largest size; None: not
    applicable, ``note`` says why), the check that caught it there, and the runs it took."""

    model: str
    fault: str
    target: str | None
    size: float | None
    deciding: str = ""
    note: str = ""
    runs: int = 0
    seconds: float = 0.0
    crashed: str = ""
    unfinished: str = ""

    @property
    def caught_at_claim(self) -> bool:
        """Caught at the size issue 29 names, or smaller."""
        return self.size is not None and math.isfinite(self.size) and self.size <= CLAIMED[self.fault] * (1 + 1e-9)


def _failed(case, integrators: Sequence[str], edit: Edit | None) -> dict[str, float]:
    """Each failed check's name and how far over its limit (inf: a run that could not be measured), as ``check``
    judges the run."""
    result = run_case(case, RunOptions(integrators=tuple(integrators), edit=edit))
    checks = judge(result, case_limits(load_limits(), case, result.judged_names))
    return {str(c.name): c.ratio if math.isfinite(c.ratio) and not c.diverged else math.inf
            for c in checks if not c.passed and not c.note}


def bisect_decades(detects: Callable[[float], str], sizes: Sequence[float] = SIZES) -> tuple[float, str, int]:
    """The smallest of ``sizes`` (largest first) at which ``detects`` names a check ('' where it does not):
    (size, check, runs); (nan, '', runs) where even the largest is not detected."""
    runs = 1
    deciding = detects(sizes[0])
    if not deciding:
        return math.nan, "", runs
    lo, hi, found = 0, len(sizes), deciding  # sizes[lo] is detected, sizes[hi] (past the end: none) is not
    while hi - lo > 1:
        mid = (lo + hi) // 2
        runs += 1
        deciding = detects(sizes[mid])
        if deciding:
            lo, found = mid, deciding
        else:
            hi = mid
    return sizes[lo], found, runs


def smallest_caught(path: Path | str, faults: Sequence[str] = FAULTS, *, name: str | None = None,
                    integrators: Sequence[str] = INTEGRATORS) -> Iterator[Caught]:
    """For each of ``faults`` in turn, the smallest size caught on the model at ``path`` (engine side only)."""
    path = Path(path)
    name = name or path.stem
    case = from_mjcf(path, reference=path)
    target = Target.of(path)
    already = _failed(case, integrators, None)
    for fault in faults:
        clock = time.perf_counter()
        where = target.where(fault)
        if where is None:
            yield Caught(name, fault, None, None, note="no hinge")
            continue

        def detects(s: float, fault: str = fault) -> str:
            new = {k: r for k, r in _failed(case, integrators, target.edit(fault, s)).items() if k not in already}
            return max(new, key=new.__getitem__) if new else ""  # the check furthest over its limit

        size, deciding, runs = bisect_decades(detects)
        note = f"fails unfaulted: {', '.join(sorted(already))}" if already and math.isnan(size) else ""
        yield Caught(name, fault, where, size, deciding, note, runs, time.perf_counter() - clock)
