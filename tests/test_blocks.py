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
from harness.engine.backends import get
from harness.engine.bindings import JointBinding
from harness.engine.compat import full_mass_matrix
from harness.engine.compat import version as mujoco_version
from harness.engine.constraints import equality_block, equality_force, equality_jacobian, equality_rows
from harness.engine.probe import Probe
from harness.engine.recording import native, record
from harness.families import COMPARISONS
from harness.families.sampled import at_states, sample_states
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


def _predicted(model: mujoco.MjModel, data: mujoco.MjData, lam: np.ndarray, gamma: np.ndarray) -> np.ndarray:
    """The force MuJoCo's soft rows give at a consistent state for the ideal multipliers λ.

    MuJoCo solves (A + R) f = a_ref − a_u for an equality's rows (A = J M⁻¹ Jᵀ, R its regulariser
    efc_R, a_u = J M⁻¹ F the unconstrained acceleration, a_ref efc_aref); on a motion J q̈ = γ, so
    a_u = γ − A λ and f = (A + R)⁻¹ (A λ + a_ref − γ). Since MuJoCo 3.7 a connect's a_ref holds the
    centripetal term −J̇ q̇ = γ at a consistent state and f = λ − (A + R)⁻¹ R λ, the softness alone;
    before 3.7 it held none (a_ref = 0), and f lacks the centripetal part of the force."""
    jac = equality_jacobian(model, data, "tip")
    a = jac @ np.linalg.solve(full_mass_matrix(model, data), jac.T)
    rows = equality_rows(model, data, "tip")
    return np.linalg.solve(a + np.diag(data.efc_R[rows]), a @ lam + data.efc_aref[rows] - gamma)


def _ideal(q: np.ndarray, qd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """λ and γ (J q̈ = γ) of the analytic model at (q, q̇)."""
    dyn = _reference().dynamics
    return dyn.accelerations(q[None], qd[None])[1][0], dyn.gamma(q[None], qd[None])[0]


def _forward(model: mujoco.MjModel, q: np.ndarray, qd: np.ndarray) -> mujoco.MjData:
    data = mujoco.MjData(model)
    PROBE.binding.set_state(model, data, q, qd)
    mujoco.mj_forward(model, data)
    return data


def test_the_connect_block_is_read_row_by_row(model):
    data = _forward(model, Q0, QD0)
    force, pos = equality_block(model, data, "tip")
    assert force.shape == pos.shape == (3,)
    np.testing.assert_allclose(pos, 0.0, atol=1e-12)  # the state is on the constraint
    jac = equality_jacobian(model, data, "tip")
    np.testing.assert_array_equal(jac.T @ force, data.qfrc_constraint)  # the block is every row
    with pytest.raises(ModelMismatch, match="3 efc rows; one is expected"):
        equality_force(model, data, "tip")
    # row by row, what MuJoCo's soft rows make of the analytic multipliers at this consistent state, to
    # the solver's tolerance (1e-12): the rows are read in MuJoCo's order, with the analytic sign
    lam, gamma = _ideal(Q0, QD0)
    np.testing.assert_allclose(force, _predicted(model, data, lam, gamma), rtol=0, atol=1e-9 * np.max(np.abs(lam)))
    assert np.max(np.abs(force - lam)) > 0  # the softness the comparison above accounts for is there
    aref = data.efc_aref[equality_rows(model, data, "tip")]
    if mujoco_version() >= (3, 7, 0):  # changelog 3.7.0: the J̇v term joined the connect's solver bias
        np.testing.assert_allclose(aref, gamma, rtol=1e-6)
    else:
        np.testing.assert_allclose(aref, 0.0, atol=1e-9)


def test_the_instant_layer_compares_a_block_per_row_and_as_a_generalized_force(model):
    ref = _reference()
    figures = {d.name: d.magnitude() for d in at_states(model, PROBE, ref, get("c"), COMPARISONS.at_states).deviations}
    # the figure is what MuJoCo's rows make of λ at the sampled states and nothing more: the largest
    # |λ − f| (per unit force scale m g), within 1 % (the states on the manifold are consistent to 1e-10).
    # From MuJoCo 3.7 that is the softness alone (about 1e-4); before, the missing centripetal term too
    q, qd = sample_states(ref)
    expected = max(np.max(np.abs(_ideal(q[i], qd[i])[0] - _predicted(model, _forward(model, q[i], qd[i]),
                                                                      *_ideal(q[i], qd[i]))))
                   for i in range(len(q))) / (M * G)
    assert figures["instant.force.tip"] == pytest.approx(expected, rel=1e-2)
    if mujoco_version() >= (3, 7, 0):
        assert figures["instant.force.tip"] < 1e-3
    assert figures["instant.generalized_force.tip"] == figures["instant.generalized_force"]  # the only block
    # the same rows read in the wrong order: the per-row figure fails by the size of the forces
    swapped = {d.name: d.magnitude() for d in at_states(model, PROBE, _reference(order=(2, 1, 0)), get("c"),
                                                          COMPARISONS.at_states).deviations}
    assert swapped["instant.force.tip"] > 0.1


def test_both_recorders_record_the_block(model):
    loop = record(model, PROBE, q0=Q0, qd0=QD0, steps=200, method="loop")
    assert loop.multipliers["tip"].shape == (201, 3) and loop.violations["tip"].shape == (201, 3)
    in_c = [m for m, here in (("native", native.library() is not None), ("batch", hasattr(mujoco, "batch"))) if here]
    for method in in_c:
        got = record(model, PROBE, q0=Q0, qd0=QD0, steps=200, method=method)
        np.testing.assert_array_equal(got.multipliers["tip"], loop.multipliers["tip"])
        np.testing.assert_array_equal(got.violations["tip"], loop.violations["tip"])
    # the first sample is the consistent initial state: its block is what the soft rows make of λ there
    lam, gamma = _ideal(Q0, QD0)
    expected = _predicted(model, _forward(model, Q0, QD0), lam, gamma)
    np.testing.assert_allclose(loop.multipliers["tip"][0], expected, rtol=0, atol=1e-9 * np.max(np.abs(lam)))


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
