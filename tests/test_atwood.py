"""Atwood's machine with a massive pulley: hand-derived closed forms against the sympy
derivation, our reference and MuJoCo's efc_force; the softness theory behind the
instantaneous figures; the faults that trip every gate and the legitimate changes that pass.

Closed forms (derived by hand, independently of the sympy path), with M = m1 + m2 + m_p:

    z̈1 = −z̈2 = a θ̈ = −(m1 − m2) g / M
    T1 = λ_string1 = m1 g (2 m2 + m_p) / M,   T2 = λ_string2 = m2 g (2 m1 + m_p) / M

(from m1 z̈1 = −m1 g + T1, m2 z̈2 = −m2 g + T2, m_p a² θ̈ = a (T2 − T1)).
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest
import sympy as sp

from analytic import systems
from analytic.systems import atwood
from harness import cases
from harness.core.options import RunOptions
from harness.engine import compat, models
from harness.engine.bindings import JointBinding
from harness.engine.constraints import equality_force
from harness.engine.models import compile_model, mjcf_path
from harness.pipeline import run as pipeline
from tests.conftest import assert_faults_cover, assert_passes, assert_trips, failing, judged, shipped_run
from tests.helpers import damping, default_equality_softness, each_integrator, equality_offset

P = systems.symbols("atwood")  # the parameters as sympy symbols

CASE = cases.get("atwood")
STRINGS = ("string1", "string2")
# <flag diagexact> is newer than MuJoCo 3.3; there harness.compat removes it and emulates the exact
# diagonal after compiling, so "diagexact off" means that emulation left out (_approximate_diagonal).
HAS_DIAGEXACT = hasattr(mujoco.mjtEnableBit, "mjENBL_DIAGEXACT")


def closed_forms(m1, m2, m_p, g):
    """(z̈1, T1, T2), typed by hand; works on sympy symbols and floats alike."""
    total = m1 + m2 + m_p
    return -(m1 - m2) * g / total, m1 * g * (2 * m2 + m_p) / total, m2 * g * (2 * m1 + m_p) / total


@pytest.fixture(scope="module")
def model() -> mujoco.MjModel:
    return compile_model(mjcf_path("atwood"))


@pytest.fixture(scope="module")
def shipped() -> pipeline.CaseResult:
    return shipped_run("atwood")


@dataclasses.dataclass(frozen=True)
class Physical:
    """The machine's constants, read directly from the compiled model (not via params_from_model)."""

    m1: float
    m2: float
    m_p: float
    inertia: float
    a: float
    g: float

    @classmethod
    def read(cls, model: mujoco.MjModel) -> Physical:
        return cls(m1=float(model.body("mass1").mass[0]), m2=float(model.body("mass2").mass[0]),
                   m_p=float(model.body("pulley").mass[0]), inertia=float(model.body("pulley").inertia[1]),
                   a=float(model.equality("string1").data[1]), g=float(-model.opt.gravity[2]))

    def tensions(self) -> np.ndarray:
        return np.array(closed_forms(self.m1, self.m2, self.m_p, self.g)[1:])

    def softness_error(self, diag: np.ndarray, d: float) -> np.ndarray:
        """Δf = −(A + R)⁻¹ R f*: MuJoCo's equality forces minus the ideal tensions at a
        consistent state (zero violation and velocity, so a_ref = 0), with
        A = J M⁻¹ Jᵀ and R = (1 − d)/d · diag (MuJoCo's regulariser)."""
        jac = np.array([[1.0, 0.0, -self.a], [0.0, 1.0, self.a]])
        delassus = jac @ np.diag([1 / self.m1, 1 / self.m2, 1 / self.inertia]) @ jac.T
        reg = np.diag((1 - d) / d * diag)
        return -np.linalg.solve(delassus + reg, reg @ self.tensions())

    def exact_diagonal(self) -> np.ndarray:
        return np.array([1 / self.m1 + self.a**2 / self.inertia, 1 / self.m2 + self.a**2 / self.inertia])


# --- layer 1: derivation ---------------------------------------------------------------

def test_constraint_rows_are_the_mjcf_equalities() -> None:
    der = systems.build("atwood").derive()
    a = P.a
    assert der.jacobian == sp.Matrix([[1, 0, -a], [0, 1, a]])
    assert [c.name for c in der.system.constraints] == list(STRINGS)


def test_sympy_derivation_gives_the_closed_forms() -> None:
    der = systems.build("atwood").derive()
    qdd = [sp.Symbol(f"{c.name}_ddot", real=True) for c in der.system.q]
    lam = list(der.multiplier_symbols)
    constraint_acc = der.jacobian * sp.Matrix(qdd) - der.gamma
    sol = sp.solve([*der.equations, *constraint_acc], [*qdd, *lam], dict=True)
    assert len(sol) == 1
    sol = sol[0]
    z1dd, t1, t2 = closed_forms(P.m1, P.m2, P.m_p, P.g)
    assert sp.simplify(sol[qdd[0]] - z1dd) == 0
    assert sp.simplify(sol[qdd[1]] + z1dd) == 0
    assert sp.simplify(sol[qdd[2]] - z1dd / P.a) == 0
    assert sp.simplify(sol[lam[0]] - t1) == 0
    assert sp.simplify(sol[lam[1]] - t2) == 0


def test_seed_claims() -> None:
    """The seed's z̈1 and λ1 hold; its λ2 is printed with −m_p in the denominator, a typo:
    only the +m_p form equals the derivation (and makes λ2 the tension by symmetry 1 ↔ 2)."""
    m1, m2, m_p, g = P.m1, P.m2, P.m_p, P.g
    z1dd, t1, t2 = closed_forms(m1, m2, m_p, g)
    assert sp.simplify(z1dd - (-(m1 - m2) / (m_p + m1 + m2) * g)) == 0
    assert sp.simplify(t1 - (m_p + 2 * m2) / (m_p + m1 + m2) * m1 * g) == 0
    assert sp.simplify(t2 - (m_p + 2 * m1) / (-m_p + m1 + m2) * m2 * g) != 0
    assert sp.simplify(t2 - (m_p + 2 * m1) / (m_p + m1 + m2) * m2 * g) == 0


def test_minimal_system_is_the_effective_mass_equation() -> None:
    der = systems.build("atwood", minimal=True).derive()
    z_dd = sp.Symbol("z1_ddot", real=True)
    m1, m2, m_p, g = P.m1, P.m2, P.m_p, P.g
    assert sp.simplify(der.equations[0] - ((m1 + m2 + m_p) * z_dd + (m1 - m2) * g)) == 0


def test_params_come_from_the_model(model) -> None:
    p = Physical.read(model)
    params = atwood.params_from_model(model)
    assert (params["m1"], params["m2"], params["m_p"], params["a"], params["g"]) == \
        (p.m1, p.m2, p.m_p, p.a, p.g)
    assert params["h"] == float(model.body("pulley").pos[2])
    assert p.inertia == pytest.approx(p.m_p * p.a**2, rel=1e-12)  # mass on the rim


def test_positive_theta_raises_the_left_rim(model) -> None:
    """The docstring's sense of θ: hinge about +y, so the rim point above mass1 (x = −a)
    rises by a sin θ, as z1 = aθ says to first order."""
    a = float(model.equality("string1").data[1])
    data = mujoco.MjData(model)
    data.qpos[model.joint("theta").qposadr[0]] = 0.1
    mujoco.mj_kinematics(model, data)
    pulley = model.body("pulley").id
    rim = data.xpos[pulley] + data.xmat[pulley].reshape(3, 3) @ [-a, 0.0, 0.0]
    assert rim[2] - data.xpos[pulley][2] == pytest.approx(a * np.sin(0.1), rel=1e-12)


# --- reference and MuJoCo against the closed forms -------------------------------------

def test_reference_matches_closed_forms(model) -> None:
    p = Physical.read(model)
    z1dd, t1, t2 = closed_forms(p.m1, p.m2, p.m_p, p.g)
    ref = CASE.reference(model)
    t = np.linspace(0.0, CASE.horizon, 301)
    q, qd = ref.solution.state(t)
    qdd, lam = ref.dynamics.accelerations(q, qd)
    assert np.max(np.abs(q[:, 0] - z1dd * t**2 / 2)) < 1e-10
    assert np.max(np.abs(qdd - [z1dd, -z1dd, z1dd / p.a])) < 1e-10 * abs(z1dd / p.a)
    assert np.max(np.abs(lam - [t1, t2])) < 1e-10 * t1
    assert t1 > t2 > 0  # both strings taut; the heavier side pulls harder


def _forward_at_consistent_states(model: mujoco.MjModel, count: int = 12):
    """(efc_force per string, qacc in analytic order, data) after mj_forward at states exactly
    on both strings (z1 = aθ, z2 = −aθ and the same for velocities, in floating point too)."""
    a = float(model.equality("string1").data[1])
    binding = JointBinding(("z1", "z2", "theta"))
    dof = binding.dof_matrix(model)
    data = mujoco.MjData(model)
    forces, qacc = [], []
    for theta, omega in zip(np.linspace(-10.0, 2.0, count), np.linspace(-12.0, 3.0, count), strict=True):
        mujoco.mj_resetData(model, data)
        binding.set_state(model, data, [a * theta, -a * theta, theta], [a * omega, -a * omega, omega])
        mujoco.mj_forward(model, data)
        forces.append([equality_force(model, data, s)[0] for s in STRINGS])
        qacc.append(dof.T @ data.qacc)
    return np.array(forces), np.array(qacc), data


def test_mujoco_tensions_match_closed_forms_within_softness(model) -> None:
    """At the shipped settings efc_force = T + Δf with Δf = −(A+R)⁻¹R T, R = (1−d)/d diag A
    (diagexact): it is within |Δf| (×1.5) of the ideal tension, and Δf predicts the
    difference to 1e-6."""
    p = Physical.read(model)
    d = float(model.eq_solimp[model.equality("string1").id][0])
    assert d == float(model.eq_solimp[model.equality("string2").id][0])
    delta = p.softness_error(p.exact_diagonal(), d)
    forces, qacc, _ = _forward_at_consistent_states(model)
    assert np.all(np.abs(forces - p.tensions()) <= 1.5 * np.abs(delta))
    assert np.max(np.abs(forces - p.tensions() - delta)) < 1e-6 * np.abs(delta).max()
    # the accelerations follow: M q̈ = F + Jᵀ(T + Δf)
    z1dd = closed_forms(p.m1, p.m2, p.m_p, p.g)[0]
    dq = np.array([delta[0] / p.m1, delta[1] / p.m2, p.a * (delta[1] - delta[0]) / p.inertia])
    assert np.max(np.abs(qacc - [z1dd, -z1dd, z1dd / p.a] - dq)) < 1e-10


def test_instant_figures_are_the_softness_theory(model, shipped) -> None:
    p = Physical.read(model)
    delta = p.softness_error(p.exact_diagonal(), 0.9999)
    weight = (p.m1 + p.m2) * p.g
    for j, s in enumerate(STRINGS):
        assert shipped.figure(f"instant.force.{s}").value == pytest.approx(abs(delta[j]) / weight, rel=1e-3)
    z1dd = closed_forms(p.m1, p.m2, p.m_p, p.g)[0]
    dq = np.array([delta[0] / p.m1, delta[1] / p.m2, p.a * (delta[1] - delta[0]) / p.inertia])
    assert shipped.figure("instant.qacc").value == pytest.approx(np.abs(dq).max() / abs(z1dd / p.a), rel=1e-3)


def test_default_diagonal_ignores_the_polycoef_gain(model, monkeypatch) -> None:
    """Why the MJCF enables diagexact: MuJoCo's default diagonal for a joint equality adds the
    two joints' inverse weights without the gain a², so R is ~75× the softness solimp asks
    for, and the tensions are off by percents (measured 2.7 %). On a MuJoCo without the flag
    (3.3) the same default diagonal is what harness.compat's emulation corrects."""
    _default_diagonal_on_any_version(monkeypatch)
    approx = compile_model(mjcf_path("atwood"), edit=_approximate_diagonal)
    p = Physical.read(approx)
    forces, _, data = _forward_at_consistent_states(approx, count=3)
    rows = [int(np.flatnonzero((data.efc_type == mujoco.mjtConstraint.mjCNSTR_EQUALITY)
                               & (data.efc_id == approx.equality(s).id))[0]) for s in STRINGS]
    naive = np.array([1 / p.m1 + 1 / p.inertia, 1 / p.m2 + 1 / p.inertia])
    assert compat.constraint_diagonal(data)[rows] == pytest.approx(naive, rel=1e-9)
    delta = p.softness_error(naive, 0.9999)
    assert np.max(np.abs(forces - p.tensions() - delta)) < 1e-6 * np.abs(delta).max()
    assert np.max(np.abs(forces - p.tensions()) / p.tensions()) > 0.02


def test_shipped_diagonal_is_the_exact_one(model) -> None:
    """With diagexact (or, on a MuJoCo without it, harness.compat's emulation) the diagonal R is
    scaled by is A_ii = J M⁻¹ Jᵀ exactly: 1/m_i + a²/I."""
    _, _, data = _forward_at_consistent_states(model, count=1)
    rows = [int(np.flatnonzero((data.efc_type == mujoco.mjtConstraint.mjCNSTR_EQUALITY)
                               & (data.efc_id == model.equality(s).id))[0]) for s in STRINGS]
    assert compat.constraint_diagonal(data)[rows] == pytest.approx(Physical.read(model).exact_diagonal(), rel=1e-9)


# --- gates ---------------------------------------------------------------------------

def test_shipped_case_passes_every_gate(shipped) -> None:
    assert failing(shipped) == set()


def _equality(spec: mujoco.MjSpec, name: str):
    return next(e for e in spec.equalities if e.name == name)


def _polycoef(name: str, value: float):
    def edit(spec: mujoco.MjSpec) -> None:
        eq = _equality(spec, name)
        eq.data = [eq.data[0], value, *list(eq.data[2:])]
    return edit


def _armature(spec: mujoco.MjSpec) -> None:
    """10 % more inertia on the pulley's axle, as joint armature: the pulley stays a thin hoop of its mass (an
    inertia changed alone is another pulley, which the system refuses: tests/test_bad_input.py)."""
    spec.joint("theta").armature = 0.1 * spec.body("pulley").inertia[1]


def _move_mass1(spec: mujoco.MjSpec) -> None:
    spec.body("mass1").pos = [-0.101, 0.0, 0.0]


def _approximate_diagonal(spec: mujoco.MjSpec) -> None:
    """diagexact off: MuJoCo's default diagonal. A MuJoCo without the flag (3.3) has read the
    file without it, so there is nothing to clear; see _default_diagonal_on_any_version."""
    if HAS_DIAGEXACT:
        spec.option.enableflags &= ~int(mujoco.mjtEnableBit.mjENBL_DIAGEXACT)


def _default_diagonal_on_any_version(monkeypatch: pytest.MonkeyPatch) -> None:
    """With _approximate_diagonal, for the rest of the test: on a MuJoCo without diagexact,
    compile without the harness's emulation of it (harness.compat.after_compile), so the
    model has MuJoCo's own default diagonal there too. Nothing to do where the flag exists."""
    if not HAS_DIAGEXACT:
        monkeypatch.setattr(models, "after_compile", lambda model, path: None)  # where compile_model calls it


_INSTANT_FORCES = {"instant.force.string1", "instant.force.string2", "instant.qacc",
                   "instant.point_acceleration", "instant.generalized_force"}

# Faults: physics the machine of the seed does not have -> the gates they must trip. A string wound on
# another radius than the other (polycoef a +2% on one string) is a different constraint: forces and
# motion; damping on the pulley drains energy (forcing, drift); extra inertia on the pulley's axle
# (armature) beyond the hoop of mass m_p and radius a changes the mass matrix and the kinetic energy, and the
# strings' tensions, whose difference turns the pulley (T2 − T1 = I θ̈ / a); mass1 moved 1 mm off the rim
# (x = −a) hangs its string off the tangent: kinematics; an offset in a string's polycoef holds its mass 1 cm
# away from where the reference starts it, so MuJoCo pulls the machine onto its own constraint: violation.
# The wrong radius is required to trip RK4's string forces, not the first-order integrators': where the
# exact diagonal cannot be had (MuJoCo 3.3 emulates diagexact only when both strings ask the same inverse
# weight of the pulley, which a wrong radius breaks), MuJoCo's approximate diagonal makes the strings ~70×
# softer, and the fault's force error (5e-3 relative) then lies within a quarter of Euler's softness part.
_WRONG_RADIUS = _INSTANT_FORCES | each_integrator("position") | {"RK4.force.string1", "RK4.force.string2"}
FAULTS = {
    "string2 polycoef a +2%": (dict(edit=_polycoef("string2", -0.102)), _WRONG_RADIUS),
    "string1 polycoef a +2%": (dict(edit=_polycoef("string1", 0.102)), _WRONG_RADIUS),
    "pulley damping 1e-3 N m s": (dict(edit=damping("theta", 1e-3)),
                                  {"instant.forcing"} | each_integrator("position", "drift.energy")),
    "pulley armature +10%": (dict(edit=_armature), {"instant.mass_matrix", "instant.kinetic_energy"}
                             | each_integrator("force.string1", "force.string2")),
    "mass1 1 mm off x = -a": (dict(edit=_move_mass1), {"instant.kinematics"}),
    "string1 offset 1 cm": (dict(edit=equality_offset("string1", 0.01)), each_integrator("violation.string1")),
    "string2 offset 1 cm": (dict(edit=equality_offset("string2", 0.01)), each_integrator("violation.string2")),
}

# Legitimate changes: softer strings, a coarser timestep and MuJoCo's default (approximate) constraint
# diagonal change how the same machine is simulated; their errors are the budget's softness and
# integration parts. Every gate passes.
SETTINGS = {
    "soft strings": dict(edit=default_equality_softness),
    "timestep x4": dict(timestep=0.004),
    "diagexact off": dict(edit=_approximate_diagonal),
}


@pytest.mark.parametrize("fault", list(FAULTS))
def test_a_fault_trips_its_gates(fault: str) -> None:
    assert_trips(CASE, *FAULTS[fault], fault)


@pytest.mark.parametrize("setting", list(SETTINGS))
def test_a_legitimate_change_passes_every_gate(setting: str, monkeypatch) -> None:
    if SETTINGS[setting].get("edit") is _approximate_diagonal:
        _default_diagonal_on_any_version(monkeypatch)
    assert_passes(CASE, SETTINGS[setting], setting)


def test_every_gate_has_a_fault() -> None:
    assert_faults_cover("atwood", FAULTS)


def test_an_initial_state_off_the_strings_is_moved_onto_them() -> None:
    """mass1 started 5e-10 m off string1 (inside solve()'s 1e-9 consistency check): the reference projects
    the state onto the constraints of the model under test, says so, and its own gates pass."""
    off = dataclasses.replace(CASE, motion=dataclasses.replace(CASE.motion, q0={**CASE.q0, "z1": 5e-10}))
    result = pipeline.run_case(off, RunOptions(integrators=["RK4"]))
    assert any(p.startswith("q0 ") for p in result.settings.projected), result.settings
    assert {"reference.residual", "reference.ode_vs_dae"} <= set(judged(result)) - failing(result)
