"""Backends: the engines a case's runs go to, behind one small interface.

The rest of the harness never knows which one ran. A backend takes compiled
``MjModel`` s (made by :mod:`harness.engine.models`, variants and all) and a
:class:`~harness.engine.probe.Probe`, steps them, and hands back one
:class:`~harness.core.trajectory.Trajectory` per run, in the schema every layer
reads: positions and velocities of the named points, the equalities'
multipliers and violations, energy, generalized constraint force, readings.

``c``        MuJoCo's C engine, the recorders of :mod:`harness.engine.recording`
             (float64; the default, unchanged bit for bit).
``mjx``      MJX's JAX implementation (``mujoco-mjx``), float32, what a policy
             trained on MJX runs with by default.
``mjx-f64``  the same in float64 (``jax_enable_x64``).
``warp``     MuJoCo Warp on CPU (float32), in :mod:`.warp` where installed.

Which backend runs is chosen for a whole case (``RunOptions.backend``): the case's
bench holds it (:attr:`harness.families.bench.Bench.engine`) and passes it to
every family and every budget run, which call :func:`simulate` (one run) or
:meth:`Backend.simulate_many` (the batched call: a backend that can batch,
``jax.vmap`` or Warp worlds, runs the requests as one call) on it. Nothing reads
a backend from ambient state.

``forward_many`` is the instantaneous layer's call: the backend's forward
dynamics at given states (no time integration), one row per state, as one
batched call (one ``jax.vmap``, one Warp world per state; on C, ``mj_forward``
per state). What it hands back is a :class:`Forward` of float64 copies of the
backend's own arrays; a field the backend does not compute is None, never the
C engine's.
"""

from __future__ import annotations

import importlib
import importlib.util
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import mujoco
import numpy as np

from harness.core.errors import BackendUnavailable
from harness.core.trajectory import Trajectory
from harness.engine.probe import Probe

__all__ = ["BACKENDS", "PRECISION", "Backend", "Forward", "Request", "check_installed", "computes_reactions", "expand",
           "get", "simulate"]

BACKENDS: tuple[str, ...] = ("c", "mjx", "mjx-f64", "warp")
"""Every backend's name, as ``--backend`` and ``validate(backend=...)`` accept them (and ``all``)."""

_MODULES = {"c": "c", "mjx": "mjx", "mjx-f64": "mjx", "warp": "warp"}
PRECISION = {"c": "float64", "mjx": "float32", "mjx-f64": "float64", "warp": "float32"}
"""The arithmetic each backend steps in (known without importing it)."""
_REQUIRES = {"mjx": ("jax", "mujoco.mjx"), "mjx-f64": ("jax", "mujoco.mjx"), "warp": ("warp", "mujoco_warp")}
EXTRAS = {"mjx": "mjx", "mjx-f64": "mjx", "warp": "warp"}
"""The pip extra that installs each optional backend: ``pip install 'mjharness[EXTRA]'``."""


@dataclass(frozen=True)
class Request:
    """One run: a compiled model (its own integrator, timestep and settings), the initial analytic state
    and how many steps to take."""

    model: mujoco.MjModel
    q0: np.ndarray
    qd0: np.ndarray
    steps: int


@dataclass(frozen=True)
class Forward:
    """A backend's forward dynamics at N states, float64 copies of its arrays, one row per state.

    Attributes:
        qacc: (N, nv) the acceleration of the forward pass (constraints included).
        qfrc_bias: (N, nv) Coriolis, centrifugal and gravity forces, C(q, q̇).
        qfrc_passive: (N, nv) springs, dampers and other passive forces.
        qfrc_constraint: (N, nv) the constraint force in generalized coordinates, Jᵀ efc_force.
        mass: (N, nv, nv) the dense joint-space inertia matrix M(q).
        equality: the ``efc_force`` rows of each equality the probe names (``Probe.constraints``), (N, k) in
            the C engine's row order for that equality (connect: 3, weld: 6, joint and tendon: 1), unsigned.
        sensordata: (N, nsensordata), where the backend computes the sensors at these states; else None.
        cfrc_int, cfrc_ext: (N, nbody, 6) MuJoCo's c-frame interaction and external wrenches (torque, force),
            where the backend computes them; else None.
        qfrc_actuator: (N, nv) the actuators' generalized force, where the model has actuators; else None (zero).
    """

    qacc: np.ndarray
    qfrc_bias: np.ndarray
    qfrc_passive: np.ndarray
    qfrc_constraint: np.ndarray
    mass: np.ndarray
    equality: dict[str, np.ndarray]
    sensordata: np.ndarray | None = None
    cfrc_int: np.ndarray | None = None
    cfrc_ext: np.ndarray | None = None
    qfrc_actuator: np.ndarray | None = None

    def actuator(self, k: int) -> np.ndarray | float:
        """The actuators' generalized force at state ``k`` (0 where the model has none)."""
        return 0.0 if self.qfrc_actuator is None else self.qfrc_actuator[k]


def computes_reactions(model: mujoco.MjModel) -> bool:
    """Whether a forward pass of ``model`` computes ``cfrc_int``/``cfrc_ext`` (MuJoCo's ``mj_rnePostConstraint``):
    where an accelerometer, force or torque sensor needs them and sensors are not disabled (engine_sensor.c,
    and MJX's and Warp's ``sensor_acc``, which call it for the same sensor types)."""
    if model.opt.disableflags & int(mujoco.mjtDisableBit.mjDSBL_SENSOR):
        return False
    kinds = {int(mujoco.mjtSensor.mjSENS_ACCELEROMETER), int(mujoco.mjtSensor.mjSENS_FORCE),
             int(mujoco.mjtSensor.mjSENS_TORQUE)}
    return any(int(t) in kinds for t in model.sensor_type)


@runtime_checkable
class Backend(Protocol):
    """An engine that runs compiled MuJoCo models and records Trajectories.

    Attributes:
        name: as in :data:`BACKENDS`.
        precision: ``float64`` or ``float32``: the arithmetic its state is stepped in.
        epsilon: that arithmetic's machine epsilon: the error budget's round-off part scales with it
            (:mod:`harness.families.runs`).
    """

    name: str
    precision: str
    epsilon: float

    def unsupported(self, model: mujoco.MjModel) -> str:
        """Why this backend cannot run ``model`` (one line: the backend, the feature, the fix), or ""."""

    def adaptations(self, model: mujoco.MjModel) -> tuple[str, ...]:
        """What this backend's copy of ``model`` changes (a flag it lacks) and what stands in, one line each."""

    def supports(self, model: mujoco.MjModel) -> None:
        """Raise :class:`BackendUnavailable` with :meth:`unsupported`'s reason, if any."""

    def simulate_many(self, requests: Sequence[Request], probe: Probe) -> list[Trajectory]:
        """Every request's run, ``steps + 1`` samples each (t = 0 .. steps·h), as one batched call where
        the backend allows. Raises SimulationDiverged as the C recorders do."""

    def forward_many(self, model: mujoco.MjModel, probe: Probe, qpos: np.ndarray, qvel: np.ndarray) -> Forward:
        """The backend's forward dynamics of ``model`` at every state (rows of ``qpos``, ``qvel``: MuJoCo's
        coordinates), as one batched call where the backend allows, from a zero warm start."""


def names() -> tuple[str, ...]:
    return BACKENDS


def expand(spec: str) -> tuple[str, ...]:
    """The backends a ``--backend`` value names: one name, ``all`` (every backend) or a comma list."""
    chosen = BACKENDS if spec == "all" else tuple(s.strip() for s in spec.split(","))
    for name in chosen:
        if name not in BACKENDS:
            raise ValueError(f"unknown backend {name!r}; accepted: {', '.join(BACKENDS)}, all")
    return tuple(dict.fromkeys(chosen))


_loaded: dict[str, Backend] = {}


def check_installed(name: str) -> None:
    """:class:`BackendUnavailable` (one line: backend, what is missing, the fix) where backend ``name``'s
    packages are not installed, found without importing them: a parent process that forks workers must not
    import JAX or Warp first (neither survives a fork), and MJX's precision is fixed by its first import."""
    if name not in BACKENDS:
        raise ValueError(f"unknown backend {name!r}; accepted: {', '.join(BACKENDS)}, all")
    for module in _REQUIRES.get(name, ()):
        try:
            found = importlib.util.find_spec(module) is not None
        except ModuleNotFoundError:  # its parent package is missing
            found = False
        if not found:
            raise BackendUnavailable(f"backend {name!r} is not installed ({module} is missing); "
                                     f"fix: pip install 'mjharness[{EXTRAS[name]}]', or use --backend c")


def get(name: str) -> Backend:
    """The backend called ``name``; ValueError for an unknown name, :class:`BackendUnavailable` (one
    line: backend, what is missing, the fix) where it is not installed."""
    if name not in BACKENDS:
        raise ValueError(f"unknown backend {name!r}; accepted: {', '.join(BACKENDS)}, all")
    if name not in _loaded:
        try:  # lazy: an optional backend imports jax or warp, which the default install lacks
            module = importlib.import_module(f"harness.engine.backends.{_MODULES[name]}")
        except ImportError as exc:
            raise BackendUnavailable(
                f"backend {name!r} is not installed ({exc.name or exc} is missing); "
                f"fix: pip install 'mjharness[{EXTRAS[name]}]', or use --backend c") from None
        _loaded[name] = module.backend(name)
    return _loaded[name]


def simulate(engine: Backend, model: mujoco.MjModel, probe: Probe, *, q0: Sequence[float] | np.ndarray,
             qd0: Sequence[float] | np.ndarray, steps: int) -> Trajectory:
    """One run on ``engine`` (:func:`harness.engine.recording.record`'s contract)."""
    return engine.simulate_many([Request(model, np.asarray(q0, float), np.asarray(qd0, float), steps)], probe)[0]
