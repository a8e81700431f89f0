"""Welded pendulum (case ``welded_pendulum``): a link with six joints of its own held to a hinged hub by a
``weld``. The weld's six rows are MuJoCo's (position, then torquescale × the relative quaternion's axis
part: efc_pos and efc_J at arbitrary states), the multipliers against the link's Newton–Euler equations,
MuJoCo's weld force row by row, a fault of the weld and the settings that pass.

Closed forms (by hand). On the motion the link turns with the hub, a compound pendulum about the axle:

    θ̈ = −m g (a + d) sin θ / (I_h + I2 + m (a + d)²)

(the centre of mass c = (a + d)(sin θ, 0, −cos θ) + (0, e, 0) is a + d from the axle whatever e). The
weld's force on the link at its top S and its moment there (Newton–Euler about the centre of mass, ω =
−θ̇ ŷ along a principal axis, so dL/dt = −I2 θ̈ ŷ):

    F = m (c̈ − g),      τ = −I2 θ̈ ŷ − (S − c) × F

and the multipliers are λ_F = F and λ_τ = (2/s) R_hubᵀ τ (the system's docstring). MuJoCo counts this
wrench in ``cfrc_ext`` (on the link at its top, the opposite on the hub at the socket), which the reaction
sensors rest on: pinned here by hand, and the wiring's loads shown to matter (a flipped sign, a wrong
torquescale fails the sensor figures).
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest

from harness import cases
from harness.core.options import RunOptions
from harness.engine import sensors
from harness.engine.constraints import equality_block
from harness.engine.models import compile_model, mjcf_path
from harness.pipeline import run as pipeline
from tests.conftest import assert_passes, assert_trips, failing, shipped_run
from tests.helpers import default_equality_softness, equality_rows, forward_at

if "welded_pendulum" in cases.unavailable():  # an older MuJoCo: the case is listed as n/a with the measured reason
    pytest.skip(cases.unavailable()["welded_pendulum"], allow_module_level=True)
CASE = cases.get("welded_pendulum")


@pytest.fixture(scope="module")
def model() -> mujoco.MjModel:
    return compile_model(mjcf_path("welded_pendulum"))


@pytest.fixture(scope="module")
def ref(model):
    return CASE.reference(model)


@pytest.fixture(scope="module")
def params(model) -> dict[str, float]:
    from analytic.systems import welded_pendulum

    return welded_pendulum.params_from_model(model)


def _forward(model, q, qd=None) -> mujoco.MjData:
    return forward_at(model, CASE.probe(CASE.dynamics()).binding, q, np.zeros(7) if qd is None else qd)


def _rot(axis: str, angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return {"x": np.array([[1, 0, 0], [0, c, -s], [0, s, c]]), "y": np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]]),
            "z": np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])}[axis]


# --- conventions ----------------------------------------------------------------------------------------

def test_mjcf_constants_read_back(params) -> None:
    assert params == {"I_h": 0.01, "m_h": 0.5, "a": 0.2, "m": 1.5, "I1": 0.08, "I2": 0.085, "I3": 0.01, "d": 0.4,
                      "e": 0.05, "s": 0.5, "g": 9.81}


def test_the_links_joints_compose_as_the_docstring_says(model) -> None:
    """Slides world-aligned, then pitch (−y), roll (x), yaw (z) about the axes as turned before: R_link =
    R_−y(pitch) R_x(roll) R_z(yaw), its top at (x, y, z); the hub's θ about −y."""
    rng = np.random.default_rng(3)
    for _ in range(5):
        q = rng.uniform(-1.5, 1.5, size=7)
        data = _forward(model, q)
        theta, x, y, z, pitch, roll, yaw = q
        expected = _rot("y", -pitch) @ _rot("x", roll) @ _rot("z", yaw)
        np.testing.assert_allclose(data.xmat[model.body("link").id].reshape(3, 3), expected, atol=1e-15)
        np.testing.assert_allclose(data.site_xpos[model.site("top").id], [x, y, z], atol=1e-15)
        np.testing.assert_allclose(data.xmat[model.body("hub").id].reshape(3, 3), _rot("y", -theta), atol=1e-15)


def test_the_weld_rows_are_mujocos_rows(model, ref) -> None:
    """At arbitrary states (off the weld too) MuJoCo's efc_pos of ``glue`` is the analytic f(q) row by row —
    top − socket, then torquescale × vec(q̄_hub ⊗ q_link) — and its efc_J rows are ∂f/∂q: the weld's rows are
    holonomic constraints whose multipliers are its efc_force, same sign and scale."""
    rng = np.random.default_rng(11)
    states = [rng.uniform(-1.0, 1.0, size=7) for _ in range(10)]
    for pos in equality_rows(model, _forward, ref.dynamics, "glue", states, jacobian_atol=1e-13):
        assert np.min(np.abs(pos)) > 1e-4  # off the weld: every row is seen


# --- the reference against Newton–Euler ---------------------------------------------------------------------

def test_the_weld_force_and_moment_are_newton_euler_of_the_link(ref, params) -> None:
    p = params
    t = np.linspace(0.0, CASE.horizon, 201)
    q, qd = ref.solution.state(t)
    qdd, lam = ref.dynamics.accelerations(q, qd)
    theta, td = q[:, 0], qd[:, 0]
    arm = p["a"] + p["d"]
    tdd = -p["m"] * p["g"] * arm * np.sin(theta) / (p["I_h"] + p["I2"] + p["m"] * arm**2)
    np.testing.assert_allclose(qdd[:, 0], tdd, rtol=0, atol=1e-9)
    # on the motion: the link turns with the hub, its top at the socket
    np.testing.assert_allclose(q[:, 4], theta, atol=1e-9)
    np.testing.assert_allclose(q[:, 5:], 0.0, atol=1e-9)
    radial = np.column_stack([np.sin(theta), 0 * theta, -np.cos(theta)])
    tangent = np.column_stack([np.cos(theta), 0 * theta, np.sin(theta)])
    acc = arm * (tdd[:, None] * tangent - (td**2)[:, None] * radial)
    force = p["m"] * (acc - np.array([0.0, 0.0, -p["g"]]))
    socket, com = p["a"] * radial, arm * radial + np.array([0.0, p["e"], 0.0])
    moment = -p["I2"] * tdd[:, None] * np.array([0.0, 1.0, 0.0]) - np.cross(socket - com, force)
    hub = np.array([_rot("y", -th) for th in theta])
    expected = np.column_stack([force, (2 / p["s"]) * np.einsum("nji,nj->ni", hub, moment)])
    np.testing.assert_allclose(lam, expected, rtol=0, atol=1e-8)
    np.testing.assert_allclose(ref.solution.multipliers(t), lam, rtol=0, atol=1e-7)
    carried = np.max(np.abs(lam), axis=0)
    assert carried[1] < 1e-9 and np.all(np.delete(carried, 1) > 0.05)  # 5 of the 6 rows carry load


# --- MuJoCo ----------------------------------------------------------------------------------------------

def test_mujoco_weld_force_is_lambda_row_by_row(params) -> None:
    """RK4 at the shipped settings: the weld's six efc_force rows within 1e-3 of m g of λ, the weld held
    to 1e-7 m (the budget's parts of RK4.force.glue and RK4.violation.glue are the finer statement)."""
    result = shipped_run("welded_pendulum")
    sim, ref = result.simulations["RK4"], result.reference
    weight = params["m"] * params["g"]
    assert np.max(np.abs(sim.multipliers["glue"] - ref.multipliers["glue"])) < 1e-3 * weight
    assert np.max(np.abs(sim.violations["glue"])) < 1e-7


def _about(wrench: np.ndarray, centre: np.ndarray, point: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A c-frame wrench (torque about ``centre``, force) as (force, moment about ``point``)."""
    return wrench[3:], wrench[:3] + np.cross(centre - point, wrench[3:])


def test_mujoco_counts_the_weld_wrench_in_cfrc_ext_as_the_load_says(model, params) -> None:
    """By hand, on the weld (θ, the link on the hub, any velocities): MuJoCo's cfrc_ext of the link is λ_F at
    its top and the moment (s/2) R_−y(θ) λ_τ (typed here, s = 0.5 read back above), the hub's the opposite at
    the socket. Off the weld (arbitrary states, r = q̄_socket ⊗ q_top ≠ 1) the moment is what the dynamics
    uses — solved from the link's qfrc_constraint = J_topᵀ F + J_ωᵀ τ on its six joints — and what
    weld_moment_map gives: the sign and frame of the weld loads of mjcf/welded_pendulum.py."""
    rng = np.random.default_rng(5)
    link, hub = model.body("link").id, model.body("hub").id
    top, socket = model.site("top").id, model.site("socket").id
    a, s = params["a"], params["s"]
    for k in range(6):
        if k < 3:  # on the weld
            theta = rng.uniform(-1.5, 1.5)
            q = np.array([theta, a * np.sin(theta), 0.0, -a * np.cos(theta), theta, 0.0, 0.0])
        else:
            q = rng.uniform(-1.0, 1.0, size=7)
        data = _forward(model, q, rng.uniform(-2.0, 2.0, size=7))
        mujoco.mj_rnePostConstraint(model, data)
        lam = equality_block(model, data, "glue")[0]
        force, moment = _about(data.cfrc_ext[link], data.subtree_com[link], data.site_xpos[top])
        np.testing.assert_allclose(force, lam[:3], rtol=1e-12, atol=1e-12)
        if k < 3:
            np.testing.assert_allclose(moment, s / 2 * _rot("y", -theta) @ lam[3:], rtol=1e-9, atol=1e-9)
        jacp, jacr = np.zeros((3, model.nv)), np.zeros((3, model.nv))
        mujoco.mj_jacSite(model, data, jacp, jacr, top)
        dofs = slice(1, 7)  # the link's x, y, z, pitch, roll, yaw
        solved = np.linalg.solve(np.vstack([jacp, jacr])[:, dofs].T, data.qfrc_constraint[dofs])
        scale = max(1.0, float(np.max(np.abs(lam))))
        np.testing.assert_allclose(solved, np.concatenate([lam[:3], moment]), rtol=0, atol=1e-10 * scale)
        np.testing.assert_allclose(sensors.weld_moment_map(model, data, "glue") @ lam[3:], moment, rtol=0,
                                   atol=1e-10 * scale)
        hub_force, hub_moment = _about(data.cfrc_ext[hub], data.subtree_com[hub], data.site_xpos[socket])
        np.testing.assert_allclose(np.concatenate([hub_force, hub_moment]), -np.concatenate([lam[:3], moment]),
                                   rtol=0, atol=1e-10 * scale)


def _wired(*loads: sensors.Load):
    return dataclasses.replace(CASE, wiring=dataclasses.replace(CASE.wiring, loads=loads))


LINK = sensors.Load("glue", body="link", site="top", sign=1.0)
HUB = sensors.Load("glue", body="hub", site="socket", sign=-1.0)
TORQUES = {"instant.sensor.socket_torque", "instant.sensor.top_torque", "instant.interaction.hub",
           "instant.interaction.link"}


@pytest.mark.parametrize(("label", "loads", "moment_map", "expected"), [
    ("the link's load with sign -1", (dataclasses.replace(LINK, sign=-1.0), HUB), None,
     {"instant.sensor.top_force", "instant.sensor.top_torque", "instant.interaction.link"}),
    ("the hub's load with sign +1", (LINK, dataclasses.replace(HUB, sign=1.0)), None,
     {"instant.sensor.socket_force", "instant.sensor.socket_torque", "instant.interaction.hub"}),
    ("torquescale 1 (MuJoCo's default) for the weld's 0.5", (LINK, HUB), lambda m: 2.0 * m, TORQUES),
    ("λ_τ as the world moment (MuJoCo < 3.14's cfrc_ext)", (LINK, HUB), lambda m: np.eye(3), TORQUES),
    ("no moment (the weld read as a connect)", (LINK, HUB), lambda m: 0.0 * m, TORQUES),
])
def test_a_wrong_weld_load_fails_the_sensor_figures(monkeypatch, label, loads, moment_map, expected) -> None:
    """The weld's loads are what the hub and link sensors rest on: each wrong sign or moment fails the
    figures they enter (and the shipped wiring passes them: test_a_legitimate_setting_passes_every_gate)."""
    if moment_map is not None:
        shipped = sensors.weld_moment_map
        monkeypatch.setattr(sensors, "weld_moment_map", lambda *a: moment_map(shipped(*a)))
    got = failing(pipeline.run_case(_wired(*loads), RunOptions(integrators=["RK4"])))
    assert expected <= got, (label, sorted(got))
    assert not {f for f in got if not f.startswith("instant.")}, (label, sorted(got))


# --- faults and legitimate settings ------------------------------------------------------------------------

def _socket_turned(spec: mujoco.MjSpec) -> None:
    """The socket's frame turned 1 mrad about x: MuJoCo welds the link at another orientation than the hub's."""
    site = spec.site("socket")
    half = 0.5e-3
    site.quat = [np.cos(half), np.sin(half), 0.0, 0.0]


@pytest.mark.parametrize(("label", "edit", "expected"), [
    ("socket turned 1 mrad", _socket_turned, {"RK4.force.glue", "RK4.position", "RK4.violation.glue"}),
])
def test_a_fault_of_the_weld_trips_its_gates(label, edit, expected) -> None:
    assert_trips(CASE, {"integrators": ["RK4"], "edit": edit}, expected, label)


@pytest.mark.parametrize(("label", "kwargs"), [
    ("MuJoCo's default softness", {"edit": default_equality_softness}),
    ("timestep 4 ms", {"timestep": 0.004}),
])
def test_a_legitimate_setting_passes_every_gate(label, kwargs) -> None:
    assert_passes(CASE, {"integrators": ["RK4", "implicitfast"], **kwargs}, label)
