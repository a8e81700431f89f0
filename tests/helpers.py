"""What the per-system tests share below a run: an analytic state put into a model, random states drawn
block by block, and what their tables of faults and legitimate settings are made of: gate names and MjSpec
edits (each edit names what it changes, so a table reads as the physics it adds). Running a case and judging
it, the tables' two directions included: tests/conftest.py."""

from __future__ import annotations

from collections.abc import Sequence

import mujoco
import numpy as np
import pytest

from harness.engine import compat
from harness.engine.constraints import equality_block, equality_jacobian

# MuJoCo's default constraint softness (solref, solimp), far softer than the shipped models'
DEFAULT_SOFTNESS = ([0.02, 1.0], [0.9, 0.95, 0.001, 0.5, 2.0])


# a polynomial spring (stiffness="a b c", jnt_stiffnesspoly) is MuJoCo 3.7's: the oldest supported MuJoCo (3.3.0)
# reads one stiffness and refuses three
needs_polynomial_springs = pytest.mark.skipif(not hasattr(mujoco.MjModel, "jnt_stiffnesspoly"),
                                              reason=f"MuJoCo {mujoco.__version__} has no polynomial springs")
# MuJoCo 3.3's one flag for every passive force, later springs' own
SPRINGS_OFF = int(getattr(mujoco.mjtDisableBit, "mjDSBL_SPRING", getattr(mujoco.mjtDisableBit, "mjDSBL_PASSIVE", 0)))


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


def integrate_pos_gap(model: mujoco.MjModel, binding, q, qd, h: float) -> tuple[float, mujoco.MjData, mujoco.MjData]:
    """How far mj_integratePos(qpos, qvel, h) from the state (q, q̇) lands from the state ``binding`` writes at
    q + h q̇ (max |Δqpos|: O(h²) where qvel is q̇ as MuJoCo reads it), with the data at (q, q̇) and at q + h q̇."""
    data = forward_at(model, binding, q, qd)
    ahead = data.qpos.copy()
    mujoco.mj_integratePos(model, ahead, data.qvel, h)
    later = forward_at(model, binding, q + h * qd, qd)
    return float(np.max(np.abs(ahead - later.qpos))), data, later


def equality_rows(model: mujoco.MjModel, forward, dynamics, equality: str, states, *,
                  jacobian_atol: float) -> list[np.ndarray]:
    """At each q of ``states`` (``forward(model, q)``: MjData after mj_forward there) MuJoCo's efc_pos of
    ``equality`` is the analytic constraint ``dynamics.position_residual(q)`` row by row (to 1e-14) and its
    efc_J rows are ``dynamics.jacobian(q)`` (to ``jacobian_atol``): so its efc_force is the multiplier, same
    sign and scale. Each state's efc_pos, for the caller's check that every row is seen."""
    seen = []
    for q in states:
        data = forward(model, q)
        pos = equality_block(model, data, equality)[1]
        np.testing.assert_allclose(pos, dynamics.position_residual(q), rtol=0, atol=1e-14)
        np.testing.assert_allclose(equality_jacobian(model, data, equality), dynamics.jacobian(q), rtol=0,
                                   atol=jacobian_atol)
        seen.append(pos)
    return seen


# --- gates ---------------------------------------------------------------------------------------------

INTEGRATORS = ("Euler", "implicit", "implicitfast", "RK4", "discrete")


def each_integrator(*figures: str) -> set[str]:
    """``figures`` of every integrator (``position`` -> ``Euler.position``, ..., ``discrete.position``)."""
    return {f"{i}.{f}" for i in INTEGRATORS for f in figures}


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
