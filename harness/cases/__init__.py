"""The cases the harness checks, discovered from the shipped models: one case per ``mjcf/NAME.xml``.

A case pairs a MuJoCo model with the analytic system it models and the
motion it runs. Nothing lists them: for every model ``mjcf/NAME.xml``

- the system is ``analytic/systems/NAME.py``, unless the model's own module
  ``mjcf/NAME.py`` says otherwise (``WIRING = Wiring(system=...)``: a second
  model of an existing system, such as ``hoop_ramp_contact``);
- the motion (initial state, horizon, description, tags) is the system's
  ``MOTION``;
- what MuJoCo-side readings the case needs beyond the generic ones (a ball
  joint's binding, an angular momentum, contact forces, slip) is the
  ``WIRING`` of ``mjcf/NAME.py``, where that module exists.

So a new system is its analytic module and its model, and a new model of an
existing system is its model and, if it needs readings, its small module.
CLI, pytest and CI all select from :func:`all_cases`.

Users' systems are discovered the same way from their own directories
(``--systems DIR``, ``validate(systems=...)``) and from installed packages
(entry point group ``mjharness.systems``), each holding ``NAME.py`` (the system,
and its ``WIRING`` if it needs one), ``NAME.xml`` and ``NAME.limits.toml``
(:mod:`harness.cases.sources`).
"""

from __future__ import annotations

import dataclasses
import difflib
import functools
import importlib
import importlib.util
import math
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import mujoco

from analytic import systems
from analytic.dynamics import Dynamics
from analytic.systems import Motion
from harness.cases import sources
from harness.engine.bindings import JointBinding
from harness.engine.compat import version
from harness.engine.models import compile_model
from harness.engine.probe import Probe
from harness.engine.readings import Reading
from harness.engine.sensors import Load
from harness.reference.derivations import dynamics_of, params_of
from harness.reference.solutions import Reference, build_reference
from harness.reference.tree import TREE, TreeSystem

__all__ = ["TREE", "Case", "Series", "Wiring", "all_cases", "did_you_mean", "get", "names", "select", "unavailable"]

MODELS_PACKAGE = "mjcf"


@dataclass(frozen=True)
class Series:
    """A MuJoCo-only time series with no reference counterpart (a contact's slip
    velocity, its penetration), reported per integrator as its max |·| over the horizon."""

    read: Reading
    unit: str
    description: str


@dataclass(frozen=True)
class Wiring:
    """How a model is wired to its analytic system, declared as ``WIRING`` in ``mjcf/NAME.py``.

    Attributes:
        system: the analytic system the model is of (default: the model's name).
        motion: what the case runs (default: the system's ``MOTION``).
        description: one line for ``mjharness list`` and the report (default: the motion's).
        tags: added to the motion's.
        binding: factory from the analytic coordinate names to the object that
            sets MuJoCo's state (default: ``JointBinding``, one same-named
            hinge/slide per coordinate).
        invariants: extra invariants computed from MuJoCo's own state, by the
            name the reference uses (e.g. ``p_phi``); energy is always recorded.
        forces: constraint forces for constraints that are not MJCF equalities
            (contacts), by the analytic constraint name, in the analytic sign
            convention.
        series: MuJoCo-only series (:class:`Series`), e.g. the slip velocity of
            a contact, each reported as the figure ``INTEGRATOR.series.NAME``.
        settle: seconds after which force figures are taken. A soft contact
            builds its force from slip or penetration, so at t = 0 it has none
            of its own; 0 (compare from the start) for equalities.
        loads: the constraint forces MuJoCo applies to bodies from outside
            their joints (``cfrc_ext``: a spatial tendon's pull, a connect),
            each a :class:`~harness.engine.sensors.Load`, for the reactions
            its force and torque sensors are compared with
            (:mod:`harness.families.reactions`).
        equality_signs: −1 for an equality whose rows are −1 × its analytic
            constraint's (a tendon's length shrinks as the constraint grows):
            its efc_force is then −λ, and is read × −1.
        requires: (the oldest MuJoCo the model is that system in, why): on an
            older MuJoCo the case is not registered, and :func:`unavailable`
            says why (``mjharness list`` shows it).
    """

    system: str = ""
    motion: Motion | None = None
    description: str = ""
    tags: frozenset[str] = field(default_factory=frozenset)
    binding: Callable[[tuple[str, ...]], Any] | None = None
    invariants: Mapping[str, Reading] = field(default_factory=dict)
    forces: Mapping[str, Reading] = field(default_factory=dict)
    series: Mapping[str, Series] = field(default_factory=dict)
    settle: float = 0.0
    loads: tuple[Load, ...] = ()
    equality_signs: Mapping[str, float] = field(default_factory=dict)
    requires: tuple[tuple[int, int, int], str] | None = None


@dataclass(frozen=True)
class Case:
    """One validation case: a model, the system it models, the motion it runs and how it is wired.

    Attributes:
        name: case id (the model's file name; CLI name, test id, report section).
        system: analytic module under ``analytic.systems``.
        mjcf: path of the shipped model.
        motion: the initial state (in the analytic coordinates, by name; it must
            satisfy the constraints) and the horizon it runs for.
        wiring: the model's MuJoCo-side wiring (:class:`Wiring`).
        tree: where the reference is the model's own kinematic tree (a model the user brings, no
            hand-derived system): how it is read (:class:`~harness.reference.tree.TreeSystem`);
            ``system`` is then :data:`~harness.reference.tree.TREE`.
        origin: where a user's case was discovered (:mod:`harness.cases.sources`: a systems directory, an
            installed package); '' for a shipped case.

    The motion's and the wiring's parts are read through the properties below
    (``case.q0``, ``case.binding``, ``case.mujoco_forces``, …).
    """

    name: str
    system: str
    mjcf: Path
    motion: Motion
    wiring: Wiring = field(default_factory=Wiring)
    tree: TreeSystem | None = None
    origin: str = ""

    def __post_init__(self) -> None:
        if not 0 <= self.settle < self.horizon:
            raise ValueError(f"case {self.name!r}: settle must be in [0, horizon), got {self.settle}")

    @property
    def description(self) -> str:
        return self.wiring.description or self.motion.description

    @property
    def q0(self) -> Mapping[str, float]:
        return self.motion.q0

    @property
    def qd0(self) -> Mapping[str, float]:
        return self.motion.qd0

    @property
    def horizon(self) -> float:
        return self.motion.horizon

    @property
    def tags(self) -> frozenset[str]:
        return self.motion.tags | self.wiring.tags

    @property
    def binding(self) -> Callable[[tuple[str, ...]], Any] | None:
        return self.wiring.binding

    @property
    def mujoco_invariants(self) -> Mapping[str, Reading]:
        return self.wiring.invariants

    @property
    def mujoco_forces(self) -> Mapping[str, Reading]:
        return self.wiring.forces

    @property
    def mujoco_series(self) -> Mapping[str, Series]:
        return self.wiring.series

    @property
    def settle(self) -> float:
        return self.wiring.settle

    def with_motion(self, *, q0: Mapping[str, float] | None = None, qd0: Mapping[str, float] | None = None,
                    horizon: float | None = None) -> Case:
        """The case with its initial state or horizon changed: ``q0``/``qd0`` set the coordinates they
        name (the others keep the motion's values), ``horizon`` replaces the motion's. ValueError naming
        the coordinates accepted for an unknown one, or for a horizon that is not positive or leaves no
        time after ``settle``."""
        coordinates = tuple(self.q0)
        for label, given in (("q0", q0), ("qd0", qd0)):
            values = given or {}
            unknown = sorted(set(values) - set(coordinates))
            if unknown:
                raise ValueError(f"{label} names unknown coordinate(s) {', '.join(unknown)} of case {self.name!r}; "
                                 f"accepted: {', '.join(coordinates)}")
            bad = [k for k, v in values.items() if not math.isfinite(v)]
            if bad:
                raise ValueError(f"{label} must be finite numbers, got {', '.join(f'{k}={values[k]}' for k in bad)}")
        if horizon is not None and not (math.isfinite(horizon) and horizon > self.settle):
            raise ValueError(f"horizon must be a number of seconds above the case's settle time "
                             f"({self.settle:g} s), got {horizon}")
        motion = dataclasses.replace(self.motion, q0={**self.q0, **(q0 or {})}, qd0={**self.qd0, **(qd0 or {})},
                                     horizon=self.horizon if horizon is None else float(horizon))
        return dataclasses.replace(self, motion=motion)

    @property
    def prepare(self) -> Callable[[mujoco.MjSpec], None] | None:
        """The edit every compile of this case's model gets before any other (None: none): a tree case's
        model is given the energy flag and names for its unnamed elements, and what the tree reference does
        not model is switched off (:class:`~harness.reference.tree.TreeSystem`)."""
        return self.tree.edit if self.tree is not None else None

    def params_from_model(self, model: mujoco.MjModel) -> dict[str, float]:
        """The physical parameters the reference reads from ``model``."""
        if self.tree is not None:
            return self.tree.params_from_model(model)
        return params_of(self.system, model)

    def reference(self, model: mujoco.MjModel, *, t_end: float | None = None, **solve: Any) -> Reference:
        """The case's motion solved with the parameters of ``model`` (over at least ``t_end``)."""
        return build_reference(self.system, model, q0=self.q0, qd0=self.qd0, horizon=self.horizon,
                               t_end=t_end, tree=self.tree, **solve)

    def dynamics(self) -> Dynamics:
        """The system's numeric dynamics at the parameters of the shipped model (cached)."""
        if self.tree is not None:
            return self.tree.dynamics(compile_model(self.mjcf, edit=self.prepare))
        return dynamics_of(self.system, compile_model(self.mjcf))

    def probe(self, dyn: Dynamics) -> Probe:
        """What to read from MuJoCo for this case: equalities for every constraint not read through
        the case's own ``mujoco_forces``."""
        binding = (self.binding or JointBinding)(dyn.coordinates)
        equalities = tuple(c for c in dyn.constraint_names if c not in self.mujoco_forces)
        return Probe(binding=binding, points=dyn.point_names, constraints=equalities,
                     invariants=self.mujoco_invariants, forces=self.mujoco_forces,
                     series={k: s.read for k, s in self.mujoco_series.items()}, loads=self.wiring.loads,
                     signs=self.wiring.equality_signs)


def _wiring(source: sources.Source, model: str) -> Wiring:
    """The model's ``WIRING``: of ``mjcf/NAME.py`` for a shipped model, of the source's own ``NAME.py`` for a
    user's; the default where there is none."""
    if source.shipped:
        module_name = f"{MODELS_PACKAGE}.{model}"
        module = importlib.import_module(module_name) if importlib.util.find_spec(module_name) else None
    else:
        module = sources.module(source, model)
        module_name = str(source.systems / f"{model}.py")
    wiring = getattr(module, "WIRING", Wiring()) if module is not None else Wiring()
    if not isinstance(wiring, Wiring):
        raise ValueError(f"{module_name} must define WIRING = Wiring(...) (harness.cases.Wiring)")
    return wiring


def _case(source: sources.Source, path: Path) -> Case:
    name = path.stem
    wiring = _wiring(source, name)
    system = wiring.system or name
    if system not in systems.names():
        where = "analytic/systems/" if source.shipped else f"{source.systems}/"
        wired = f"mjcf/{name}.py" if source.shipped else f"{source.systems / name}.py"
        raise ValueError(f"model {path} has no analytic system: add {where}{system}.py, or name the system it "
                         f"models in {wired} (WIRING = Wiring(system=...))")
    if not source.shipped:
        missing = [a for a in systems.REQUIRED if not hasattr(sources.module(source, system), a)]
        if missing:
            raise ValueError(f"{source.systems / system}.py ({source.label}) lacks {', '.join(missing)}; accepted: "
                             f"a system module defining {', '.join(systems.REQUIRED)} (analytic/systems/__init__.py)")
    return Case(name=name, system=system, mjcf=path, motion=wiring.motion or systems.load(system).MOTION,
                wiring=wiring, origin="" if source.shipped else source.label)


@functools.cache
def _cases_of(found: tuple[sources.Source, ...]) -> tuple[Case, ...]:
    sources.check_collisions(found)
    every = [_case(s, path) for s in (sources.SHIPPED, *found) for path in s.model_files()]
    return tuple(sorted(every, key=lambda c: c.name))


def _every_case() -> tuple[Case, ...]:
    """The cases of every source in use: the shipped ones, the installed packages' and the directories given
    (:mod:`harness.cases.sources`)."""
    return _cases_of(sources.current())


def _too_new(case: Case) -> str:
    """Why ``case`` cannot run on this MuJoCo ('' where it can)."""
    need = case.wiring.requires
    if need is None or version() >= need[0]:
        return ""
    return (f"case {case.name!r} needs MuJoCo >= {'.'.join(map(str, need[0]))} ({need[1]}); "
            f"this is {mujoco.__version__}")


def unavailable() -> dict[str, str]:
    """The cases this MuJoCo is too old for, each with why (they are not in :func:`all_cases`)."""
    return {c.name: _too_new(c) for c in _every_case() if _too_new(c)}


def all_cases() -> tuple[Case, ...]:
    """Every case this MuJoCo can run, in the order of their names (:func:`unavailable`: the others)."""
    return tuple(c for c in _every_case() if not _too_new(c))


def names() -> tuple[str, ...]:
    return tuple(c.name for c in all_cases())


def did_you_mean(name: str, known: Iterable[str]) -> str:
    """``"did you mean 'pendulum'? "`` for the known name closest to a mistyped ``name``, '' where none is
    close (:func:`difflib.get_close_matches`)."""
    close = difflib.get_close_matches(name, list(known), n=1)
    return f"did you mean {close[0]!r}? " if close else ""


def get(name: str) -> Case:
    """The case called ``name``; ValueError suggesting the closest name and listing the known ones otherwise."""
    for case in all_cases():
        if case.name == name:
            return case
    if name in unavailable():
        raise ValueError(unavailable()[name])
    raise ValueError(f"unknown case {name!r}; {did_you_mean(name, [*names(), *unavailable()])}"
                     f"known cases: {', '.join(names())}")


def select(requested: Iterable[str] = (), *, tag: str | None = None) -> tuple[Case, ...]:
    """Cases by name (all when none are given), optionally only those with ``tag``."""
    requested = list(requested)
    chosen = tuple(get(n) for n in requested) if requested else all_cases()
    return tuple(c for c in chosen if tag is None or tag in c.tags)
