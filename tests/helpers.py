"""What the per-system tests share below a run: an analytic state put into a model, random states drawn
block by block, and the MjSpec edits their fault and setting tables are made of (each edit names what
it changes, so a table reads as the physics it adds). Running a case and judging it: tests/conftest.py."""

from __future__ import annotations

from collections.abc import Sequence

import mujoco
import numpy as np

from harness.engine import compat

# MuJoCo's default constraint softness (solref, solimp), far softer than the shipped models'
DEFAULT_SOFTNESS = ([0.02, 1.0], [0.9, 0.95, 0.001, 0.5, 2.0])


# --- states ---------------------------------------------------------------------------------------------

def forward_at(model: mujoco.MjModel, binding, q, qd) -> mujoco.MjData:
    """MjData after mj_forward at the analytic state (q, q̇), written by ``binding``."""
    data = mujoco.MjData(model)
    binding.set_state(model, data, q, qd)
    mujoco.mj_forward(model, data)
    return data


def random_states(count: int, seed: int, blocks: Sequence[tuple[float, float, int]],
                  rates: tuple[float, float], offset=0.0) -> tuple[np.ndarray, np.ndarray]:
    """``count`` states (q, q̇), each of shape (count, n): q's columns uniform in ``blocks`` ((low, high,
    columns) each, drawn block after block), then q̇ uniform in ``rates`` in every column, plus ``offset``."""
    rng = np.random.default_rng(seed)
    q = np.column_stack([rng.uniform(low, high, (count, columns)) for low, high, columns in blocks])
    return q, rng.uniform(*rates, (count, q.shape[1])) + offset


# --- MjSpec edits ---------------------------------------------------------------------------------------

def damping(joint: str, value: float):
    """Linear damping ``value`` on every dof of ``joint`` (f = −c q̇; MuJoCo 3.3 has no other kind)."""
    def edit(spec: mujoco.MjSpec) -> None:
        compat.set_damping(spec.joint(joint), value)
    return edit


def stiffness(joint: str, value: float):
    """A linear spring of stiffness ``value`` on ``joint``, towards its qpos0."""
    def edit(spec: mujoco.MjSpec) -> None:
        compat.set_stiffness(spec.joint(joint), value)
    return edit


def armature(joint: str, value: float):
    """Armature (rotor inertia) ``value`` on every dof of ``joint``."""
    def edit(spec: mujoco.MjSpec) -> None:
        spec.joint(joint).armature = value
    return edit


def gravcomp(body: str, value: float):
    """Gravity compensation: the fraction ``value`` of ``body``'s weight lifted."""
    def edit(spec: mujoco.MjSpec) -> None:
        spec.body(body).gravcomp = value
    return edit


def gravity(vector: Sequence[float]):
    """The model's gravity set to ``vector``."""
    def edit(spec: mujoco.MjSpec) -> None:
        spec.option.gravity = vector
    return edit


def equality_offset(name: str, value: float):
    """The constant term of equality ``name``'s polynomial moved by ``value``: the constraint holds its
    coordinates ``value`` away from where the reference starts them."""
    def edit(spec: mujoco.MjSpec) -> None:
        eq = next(e for e in spec.equalities if e.name == name)
        eq.data = [eq.data[0] + value, *list(eq.data[1:])]
    return edit


def default_equality_softness(spec: mujoco.MjSpec) -> None:
    """Every equality at MuJoCo's default softness."""
    for eq in spec.equalities:
        eq.solref, eq.solimp = list(DEFAULT_SOFTNESS[0]), list(DEFAULT_SOFTNESS[1])


def default_pair_softness(spec: mujoco.MjSpec) -> None:
    """Every contact pair at MuJoCo's default softness."""
    for pair in spec.pairs:
        pair.solref, pair.solimp = list(DEFAULT_SOFTNESS[0]), list(DEFAULT_SOFTNESS[1])


def friction(mu: float):
    """Every contact pair's sliding friction set to ``mu`` (torsional and rolling off)."""
    def edit(spec: mujoco.MjSpec) -> None:
        for pair in spec.pairs:
            pair.friction = [mu, mu, 0.0, 0.0, 0.0]
    return edit


def rim_radius(factor: float):
    """The contact geom ``rim`` scaled by ``factor`` (the analytic radius stays the shipped one)."""
    def edit(spec: mujoco.MjSpec) -> None:
        spec.geom("rim").size = np.asarray(spec.geom("rim").size) * factor
    return edit
