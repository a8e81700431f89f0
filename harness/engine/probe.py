"""What the harness reads from a MuJoCo run of a case: points (sites or bodies), equality constraints, readings."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import mujoco

from harness.core.errors import ModelMismatch
from harness.engine.bindings import Binding
from harness.engine.points import point_source
from harness.engine.readings import Reading
from harness.engine.sensors import Load

__all__ = ["Probe"]


@dataclass(frozen=True)
class Probe:
    """What to read from MuJoCo: points, constraints (equalities) and the dof map."""

    binding: Binding
    points: Sequence[str]
    constraints: Sequence[str]
    invariants: Mapping[str, Reading] = field(default_factory=dict)
    forces: Mapping[str, Reading] = field(default_factory=dict)
    series: Mapping[str, Reading] = field(default_factory=dict)
    loads: Sequence[Load] = ()
    signs: Mapping[str, float] = field(default_factory=dict)
    """An equality whose rows are −1 × its analytic constraint's (a tendon that shortens as the
    constraint's coordinate grows) by name: its efc_force and efc_pos are read × the sign."""

    def sign(self, constraint: str) -> float:
        return float(self.signs.get(constraint, 1.0))

    def validate(self, model: mujoco.MjModel) -> None:
        self.binding.validate(model)
        for name in self.points:
            point_source(model, name)  # a site of that name, else a body (ModelMismatch naming both)
        for name in self.constraints:
            if mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_EQUALITY, name) < 0:
                known = [model.equality(i).name for i in range(model.neq)]
                raise ModelMismatch(f"model has no equality {name!r} (equalities: {known})")
        if not model.opt.enableflags & mujoco.mjtEnableBit.mjENBL_ENERGY:
            raise ModelMismatch("model must enable the energy flag (<flag energy=\"enable\"/>)")

    def readings(self) -> dict[str, Reading]:
        """Every reading, by a key unique across the three groups."""
        return ({f"invariants.{k}": r for k, r in self.invariants.items()}
                | {f"forces.{k}": r for k, r in self.forces.items()}
                | {f"series.{k}": r for k, r in self.series.items()})
