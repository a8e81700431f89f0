"""A constraint of several rows read as one block: a ``connect`` equality (3 efc rows) against a 3-row
analytic constraint, per row and as the generalized force Jᵀλ, in the instant layer and the recorders.

The model (no case of the registry: everything is built here)::

        z ^
          |     hinge theta about −y at the origin; the link (mass m_l at l/2) points along
    pivot o     R_−y(θ)(0, 0, −l) = (l sin θ, 0, −l cos θ)
           \\
            \\ link
             ●  tip: the bob (mass m) on three world slides x, y, z from (0, 0, −l), held there by
                 <connect body1="bob" body2="link" anchor="0 0 0">

MuJoCo takes the second body's anchor from the model's own configuration (qpos0): there the bob sits
at the tip, so the connect holds the bob at the tip. Coordinates (theta, x, y, z), the bob at
(x, y, z − l); the constraint ``tip`` is anchor1 − anchor2 in world x, y, z, the rows MuJoCo's connect
makes in that order: (x − l sin θ, y, z − l + l cos θ) = 0. With M q̈ = F + Jᵀλ its three
multipliers are the world components of the force the link exerts on the bob (efc_force row by row).
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest
import sympy as sp

from analytic.dynamics import Dynamics
from analytic.lagrangian import Constraint, LagrangianSystem, coordinates
from analytic.solvers import solve
from analytic.systems import Scales
from harness.core.errors import ModelMismatch
from harness.engine.bindings import JointBinding
from harness.engine.constraints import equality_block, equality_force, equality_jacobian
from harness.engine.probe import Probe
from harness.engine.simulate import simulate
from harness.layers.instant import instantaneous_figures, sample_states
from harness.reference.solutions import Reference

M, M_LINK, L, G = 1.0, 0.5, 0.8, 9.81

XML = f"""
<mujoco>
  <option timestep="0.001" integrator="RK4" gravity="0 0 -{G}" solver="Newton" iterations="100" tolerance="1e-12">
    <flag energy="enable" contact="disable"/>
  </option>
  <worldbody>
    <body name="link">
      <joint name="theta" type="hinge" axis="0 -1 0"/>
      <inertial pos="0 0 -{L / 2}" mass="{M_LINK}" diaginertia="1e-10 1e-10 1e-10"/>
    </body>
    <body name="bob" pos="0 0 -{L}">
      <joint name="x" type="slide" axis="1 0 0"/>
      <joint name="y" type="slide" axis="0 1 0"/>
      <joint name="z" type="slide" axis="0 0 1"/>
      <inertial pos="0 0 0" mass="{M}" diaginertia="1e-10 1e-10 1e-10"/>
    </body>
  </worldbody>
  <equality>
    <connect name="tip" body1="bob" body2="link" anchor="0 0 0" solref="0.002 1" solimp="0.9999 0.9999 0.001 0.5 2"/>
  </equality>
</mujoco>
"""
THETA0, THETA_DOT0 = 0.5, 0.3
Q0 = np.array([THETA0, L * np.sin(THETA0), 0.0, L - L * np.cos(THETA0)])
QD0 = np.array([THETA_DOT0, L * np.cos(THETA0) * THETA_DOT0, 0.0, L * np.sin(THETA0) * THETA_DOT0])
PROBE = Probe(binding=JointBinding(("theta", "x", "y", "z")), points=("bob",), constraints=("tip",))
SOFTNESS = 1e-4  # 1 − d of the connect's solimp: MuJoCo's soft rows miss the ideal force by about that share


def _system(order=(0, 1, 2)) -> LagrangianSystem:
    """The analytic model; ``order`` permutes the constraint's rows (a wrong reading of the block)."""
    (th, x, y, z), (thd, xd, yd, zd) = coordinates("theta x y z")
    rows = [x - L * sp.sin(th), y, z - L + L * sp.cos(th)]
    link = sp.Matrix([L / 2 * sp.sin(th), 0, -L / 2 * sp.cos(th)])
    link_vel = link.diff(th) * thd
    return LagrangianSystem(
        name="connect_test", q=(th, x, y, z), qd=(thd, xd, yd, zd),
        kinetic=M * (xd**2 + yd**2 + zd**2) / 2 + M_LINK * link_vel.dot(link_vel) / 2,
        potential=M * G * (z - L) + M_LINK * G * link[2], params=(),
        constraints=(Constraint("tip", [rows[i] for i in order]),),
        points={"bob": (x, y, z - L)})


@pytest.fixture(scope="module")
def model() -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_string(XML)


def _reference(order=(0, 1, 2)) -> Reference:
    dyn = Dynamics.build(_system(order).derive(), {})
    sol = solve(dyn, q0=Q0, qd0=QD0, t_end=1.0)
    return Reference(system="connect_test", params={}, scales=Scales(length=L, force=M * G, energy=M * G * L),
                     solution=sol, initial=(tuple(Q0), tuple(QD0)))


def test_a_block_constraint_has_one_multiplier_per_row_under_one_name():
    dyn = _reference().dynamics
    assert dyn.constraint_names == ("tip",) and dyn.constraint_sizes == (3,) and dyn.rows == 3
    assert dyn.row_labels == ("tip[0]", "tip[1]", "tip[2]") and dyn.blocks == {"tip": slice(0, 3)}
    assert [s.name for s in _system().derive().multiplier_symbols] == ["lambda_tip_0", "lambda_tip_1",
                                                                       "lambda_tip_2"]
    lam = dyn.accelerations(Q0[None], QD0[None])[1]
    assert dyn.by_constraint(lam)["tip"].shape == (1, 3)


def test_the_connect_block_is_read_row_by_row(model):
    data = mujoco.MjData(model)
    PROBE.binding.set_state(model, data, Q0, QD0)
    mujoco.mj_forward(model, data)
    force, pos = equality_block(model, data, "tip")
    assert force.shape == pos.shape == (3,)
    np.testing.assert_allclose(pos, 0.0, atol=1e-12)  # the state is on the constraint
    jac = equality_jacobian(model, data, "tip")
    np.testing.assert_array_equal(jac.T @ force, data.qfrc_constraint)  # the block is every row
    with pytest.raises(ModelMismatch, match="3 efc rows; one is expected"):
        equality_force(model, data, "tip")
    # the rows against the analytic multipliers at the same state: MuJoCo's soft constraint misses by
    # (1 − d) of the force, d = 0.9999 (tests/test_atwood.py has the coupled formula)
    lam = _reference().dynamics.accelerations(Q0[None], QD0[None])[1][0]
    np.testing.assert_allclose(force, lam, rtol=0, atol=3e-4 * np.max(np.abs(lam)))


def test_the_instant_layer_compares_a_block_per_row_and_as_a_generalized_force(model):
    ref = _reference()
    figures = {f.name: f.value for f in instantaneous_figures(model, PROBE, ref)}
    # softness: each row misses by about (1 − d) of the largest force at the sampled states (which include
    # rescaled velocities), per unit force scale m g; ×3 for the coupling of the rows through A = J M⁻¹ Jᵀ
    lam = ref.dynamics.accelerations(*sample_states(ref))[1]
    assert figures["instant.force.tip"] < 3 * SOFTNESS * np.max(np.abs(lam)) / (M * G)
    assert figures["instant.generalized_force.tip"] < 3 * SOFTNESS  # relative to max |Jᵀλ|
    assert figures["instant.generalized_force"] == figures["instant.generalized_force.tip"]  # the only block
    # the same rows read in the wrong order: the per-row figure fails by the size of the forces
    swapped = {f.name: f.value for f in instantaneous_figures(model, PROBE, _reference(order=(2, 1, 0)))}
    assert swapped["instant.force.tip"] > 0.1


def test_both_recorders_record_the_block(model):
    loop = simulate(model, PROBE, q0=Q0, qd0=QD0, steps=200, method="loop")
    assert loop.multipliers["tip"].shape == (201, 3) and loop.violations["tip"].shape == (201, 3)
    if hasattr(mujoco, "batch"):
        batch = simulate(model, PROBE, q0=Q0, qd0=QD0, steps=200, method="batch")
        np.testing.assert_array_equal(batch.multipliers["tip"], loop.multipliers["tip"])
        np.testing.assert_array_equal(batch.violations["tip"], loop.violations["tip"])
    # every sample's block against the analytic multipliers along the reference: the softness share of
    # the force and its transient from the initial state (measured 2.2 (1 − d) max|λ|); ×5
    ref = _reference()
    q, qd = ref.solution.state(loop.t)
    lam = ref.dynamics.by_constraint(ref.dynamics.accelerations(q, qd)[1])["tip"]
    assert np.max(np.abs(loop.multipliers["tip"] - lam)) < 5 * SOFTNESS * np.max(np.abs(lam))


def test_an_inactive_block_is_a_mismatch_not_zeros(model):
    inactive = mujoco.MjModel.from_xml_string(XML.replace('<connect name="tip"', '<connect active="false" name="tip"'))
    data = mujoco.MjData(inactive)
    mujoco.mj_forward(inactive, data)
    with pytest.raises(ModelMismatch, match="0 efc rows; its type makes 3"):
        equality_block(inactive, data, "tip")
    assert dataclasses.replace(PROBE).constraints == ("tip",)


def test_a_sparse_jacobian_gives_the_same_block_rows(model):
    sparse = mujoco.MjModel.from_xml_string(XML.replace("<option ", '<option jacobian="sparse" '))
    assert mujoco.mj_isSparse(sparse) and not mujoco.mj_isSparse(model)
    rows = []
    for m in (model, sparse):
        data = mujoco.MjData(m)
        PROBE.binding.set_state(m, data, Q0, QD0)
        mujoco.mj_forward(m, data)
        rows.append(equality_jacobian(m, data, "tip"))
    assert rows[0].shape == (3, 4)
    np.testing.assert_allclose(rows[1], rows[0], rtol=0, atol=1e-15)
