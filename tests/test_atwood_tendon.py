"""Atwood's machine with a real string (mjcf/atwood_tendon.xml): two spatial tendons wrapped over the
pulley, held by tendon equalities; the tendons' rows against the system's constraints, their forces
against the tensions, the axle's reaction, the strings' length; the faults that trip every gate.

Closed forms (by hand, as in tests/test_atwood.py), M = m1 + m2 + m_p:

    T1 = m1 g (2 m2 + m_p) / M,   T2 = m2 g (2 m1 + m_p) / M,   axle: F = (m_p g + T1 + T2) ẑ
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from harness import cases
from harness.engine import compat
from harness.engine.bindings import JointBinding
from harness.engine.constraints import equality_force
from harness.engine.models import compile_model, mjcf_path
from tests.conftest import assert_faults_cover, assert_passes, assert_trips, failing, shipped_run
from tests.helpers import damping, default_equality_softness, each_integrator, equality_offset, forward_at
from tests.test_atwood import closed_forms

if "atwood_tendon" in cases.unavailable():  # an older MuJoCo: the case is listed as n/a, not run
    pytest.skip(cases.unavailable()["atwood_tendon"], allow_module_level=True)
CASE = cases.get("atwood_tendon")
STRINGS = ("string1", "string2")
# the equalities' softness: solimp d = 0.9999, so a force at a consistent state is off the rigid one by
# a relative O(1 − d) = 1e-4 (docs/design.md, "The parts and their variants"); ×10 margin
SOFT = 1e-3


@pytest.fixture(scope="module")
def model() -> mujoco.MjModel:
    return compile_model(mjcf_path("atwood_tendon"))


def _params(model):
    m1, m2, m_p = (float(model.body(b).mass[0]) for b in ("mass1", "mass2", "pulley"))
    return m1, m2, m_p, float(-model.opt.gravity[2]), float(model.geom("pulley").size[0])


def _at(model, theta, *, qd=0.0):
    """MjData after mj_forward at the consistent state z1 = aθ, z2 = −aθ, with velocity θ̇ = qd."""
    a = _params(model)[4]
    return forward_at(model, JointBinding(("z1", "z2", "theta")), np.array([a * theta, -a * theta, theta]),
                      np.array([a * qd, -a * qd, qd]))


def test_params_read_a_from_the_wrapped_cylinder(model) -> None:
    assert CASE.dynamics().params["a"] == _params(model)[4] == 0.1


@pytest.mark.parametrize("theta", [0.0, -0.7, -1.5, -2.5])
def test_tendon_rows_are_minus_the_constraints(model, theta) -> None:
    """∂L/∂q of each tendon is −1 × its constraint's J (string1: (1, 0, −a), string2: (0, 1, a)), over the
    angles the motion reaches (θ from 0 to −2.4 rad), and each length is the one at qpos0."""
    a = _params(model)[4]
    data = _at(model, theta)
    dense = np.zeros((model.ntendon, model.nv))
    mujoco.mju_sparse2dense(dense, data.ten_J, model.ten_J_rownnz, model.ten_J_rowadr, model.ten_J_colind)
    dof = {j: model.joint(j).dofadr[0] for j in ("z1", "z2", "theta")}
    rows = {"string1": {"z1": 1.0, "z2": 0.0, "theta": -a}, "string2": {"z1": 0.0, "z2": 1.0, "theta": a}}
    for s, row in rows.items():
        got = dense[model.tendon(s).id]
        np.testing.assert_allclose([got[dof[j]] for j in row], [-v for v in row.values()], atol=1e-12)
    np.testing.assert_allclose(data.ten_length, model.tendon_length0, atol=1e-12)


def test_the_wrap_is_linear_only_inside_its_range(model) -> None:
    """Past θ = 0 string2's anchor passes its tangent point and the wrap leaves the cylinder: the
    length is no longer z2 + aθ. The motion stays at θ ≤ 0 (m1 sinks): this pins why the horizon is 0.8 s."""
    data = _at(model, 0.5)
    assert abs(data.ten_length[model.tendon("string2").id] - model.tendon_length0[model.tendon("string2").id]) > 1e-5


def test_tendon_forces_are_minus_the_tensions(model) -> None:
    m1, m2, m_p, g, _ = _params(model)
    _, t1, t2 = closed_forms(m1, m2, m_p, g)
    data = _at(model, 0.0)
    forces = np.array([equality_force(model, data, s)[0] for s in STRINGS])
    np.testing.assert_allclose(-forces, [t1, t2], rtol=SOFT)


def _sensor(model, data, name):
    s = model.sensor(name)
    site = model.site(int(s.objid[0]))
    return data.site_xmat[site.id].reshape(3, 3) @ data.sensordata[s.adr[0]:s.adr[0] + 3]


@pytest.mark.parametrize("theta,speed", [(0.0, 0.0), (-1.2, -3.0)])
def test_axle_carries_both_tensions_and_the_weight(model, theta, speed) -> None:
    m1, m2, m_p, g, _ = _params(model)
    _, t1, t2 = closed_forms(m1, m2, m_p, g)
    data = _at(model, theta, qd=speed)
    np.testing.assert_allclose(_sensor(model, data, "axle_force"), [0, 0, m_p * g + t1 + t2], rtol=SOFT,
                               atol=SOFT * m_p * g)
    assert np.linalg.norm(_sensor(model, data, "axle_torque")) < 1e-12  # the hinge carries no moment
    # the slide under a string carries nothing: the string holds the mass
    assert np.linalg.norm(_sensor(model, data, "slide1_force")) < 1e-9 * m1 * g
    np.testing.assert_allclose(_sensor(model, data, "world_accel"), [0, 0, g], rtol=1e-15)  # at rest: +g up


def test_joint_equality_strings_leave_the_axle_its_weight_alone() -> None:
    """The disagreement with the physics where the string is a joint equality (mjcf/atwood.xml): MuJoCo's
    coupling is a joint-space force, attributed to the joints, so a force sensor on the pulley reads m_p g,
    not m_p g + T1 + T2."""
    spec = compat.spec_from_file(str(mjcf_path("atwood")))
    spec.body("pulley").add_site(name="axle")
    spec.add_sensor(name="axle_force", type=mujoco.mjtSensor.mjSENS_FORCE, objtype=mujoco.mjtObj.mjOBJ_SITE,
                    objname="axle")
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    m_p, g = float(model.body("pulley").mass[0]), float(-model.opt.gravity[2])
    np.testing.assert_allclose(_sensor(model, data, "axle_force"), [0, 0, m_p * g], rtol=1e-12)


def test_gravity_compensation_on_the_pulley_is_invisible_to_its_sensor(model) -> None:
    """A physical upward force m_p g on the pulley (gravcomp 1) takes its weight off the axle, but MuJoCo
    attributes gravity compensation to the joints (mj_rnePostConstraint), and on a hinge through the
    pulley's centre of mass its projection is zero: the axle sensor still reads m_p g + T1 + T2. A
    disagreement with the physics no gate can see (the motion is unchanged too)."""
    spec = compat.spec_from_file(str(mjcf_path("atwood_tendon")))
    spec.body("pulley").gravcomp = 1.0
    compensated = spec.compile()
    data, base = _at(compensated, 0.0), _at(model, 0.0)
    np.testing.assert_allclose(_sensor(compensated, data, "axle_force"), _sensor(model, base, "axle_force"),
                               rtol=1e-12)


def test_shipped_case_passes_every_gate() -> None:
    assert failing(shipped_run("atwood_tendon")) == set()


def _armature(spec: mujoco.MjSpec) -> None:
    """10 % more inertia on the pulley's axle, as joint armature: the pulley stays a thin hoop of its mass (an inertia
    changed alone is another pulley, which the system refuses: tests/test_bad_input.py; as tests/test_atwood.py)."""
    spec.joint("theta").armature = 0.1 * spec.body("pulley").inertia[1]


def _move_mass1(spec: mujoco.MjSpec) -> None:
    spec.body("mass1").pos = [-0.101, 0.0, 0.0]


def _no_gravity(spec: mujoco.MjSpec) -> None:
    spec.option.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_GRAVITY)


# Faults -> the gates they must trip. Damping on the pulley: the hinge transmits its moment, which the
# ideal axle does not (axle_torque), and drains energy. Extra pulley inertia (axle armature) changes the accelerations
# and the tensions the axle carries. mass1 1 mm off the tangent tilts string1: the slide must hold it
# sideways (slide1_force, cfrc_int of mass1) and kinematics. No gravity in MuJoCo while the reference has it: the static
# accelerometer reads 0 instead of +g. A string held 1 cm longer than it starts: its violation and stretch.
FAULTS = {
    "pulley damping 1e-3 N m s": (dict(edit=damping("theta", 1e-3)), {"instant.forcing", "instant.sensor.axle_torque"}
                                  | each_integrator("position", "drift.energy")),
    "pulley armature +10%": (dict(edit=_armature), {"instant.mass_matrix", "instant.kinetic_energy", "instant.qacc",
                                                  "instant.point_acceleration", "instant.force.string1",
                                                  "instant.force.string2", "instant.generalized_force",
                                                  "instant.sensor.axle_force", "instant.interaction.pulley",
                                                  "instant.sensor.mass1_accel", "instant.sensor.mass2_accel"}
                            | each_integrator("force.string1", "force.string2")),
    "mass1 1 mm off x = -a": (dict(edit=_move_mass1), {"instant.kinematics", "instant.sensor.slide1_force",
                                                       "instant.interaction.mass1"}),
    "gravity disabled": (dict(edit=_no_gravity), {"instant.sensor.world_accel"}),
    "string1 held 1 cm long": (dict(edit=equality_offset("string1", 0.01)),
                               each_integrator("violation.string1", "series.stretch")),
    "string2 held 1 cm long": (dict(edit=equality_offset("string2", 0.01)), each_integrator("violation.string2")),
}

# Legitimate changes: softer strings and a coarser timestep; their errors are the budget's parts.
SETTINGS = {
    "soft strings": dict(edit=default_equality_softness),
    "timestep x4": dict(timestep=0.004),
}


@pytest.mark.slow
@pytest.mark.parametrize("fault", list(FAULTS))
def test_a_fault_trips_its_gates(fault: str) -> None:
    assert_trips(CASE, *FAULTS[fault], fault)


@pytest.mark.slow
@pytest.mark.parametrize("setting", list(SETTINGS))
def test_a_legitimate_change_passes_every_gate(setting: str) -> None:
    assert_passes(CASE, SETTINGS[setting], setting)


def test_every_gate_has_a_fault() -> None:
    assert_faults_cover("atwood_tendon", FAULTS)
