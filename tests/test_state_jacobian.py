"""The stiff solver's Jacobian ∂f/∂y of the tree reference (issue 43, point 2): every column exact to round-off, by
dual numbers over the complex arrays the tree's equations already differentiate with (analytic/dual.py,
analytic.solvers.state_jacobian), checked against two independent derivatives.

- sympy's exact derivative of a hand-derived system's q̈ (the double pendulum: the tree of its MJCF is the same
  Lagrangian, ``tests/test_tree.py``): both exact, so they agree to round-off. Tolerance 1e-13 of the Jacobian's
  largest entry: its entries are sums of a few dozen products of order-one numbers, each exact to a few ε
  (measured: 1e-15, so a margin of 100).
- central differences of order 6 at two steps h and h/2, on real robots (Panda with its clamps and one constraint
  row, Cassie's free joint and closed loops, the dm_control humanoid's free joint): c(h/2) is off by about
  |c(h) − c(h/2)|/63 from truncation plus round-off ~ ε |f| / h, so the exact column must lie within
  4 |c(h) − c(h/2)| + 1e4 ε |f|/h of it (entry by entry; measured: at most 0.17 of that bound, on Cassie). The
  former forward differences (√ε steps) are off by ~1e-8 relative and fail the same test by 90x (the humanoid) to
  2e7x (Panda): it tells exact from not.
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

import analytic.dual as dual_module
from analytic.dual import Dual, seeded, tangent
from analytic.dynamics import kkt_tangent, solve_kkt
from analytic.solvers import project, state_jacobian
from analytic.tree import TreeDynamics
from harness.reference.tree import charts, prepare, read_tree, start_state

MENAGERIE = Path(__file__).resolve().parent.parent.parent / "shared" / "models" / "menagerie"
STEP = 1e-30


def _rhs(dyn, stabilization=(20.0, 100.0)):
    n = dyn.n

    def rhs(_t, y):
        qdd, _ = dyn.accelerations(y[..., :n], y[..., n:], stabilization=stabilization)
        return np.concatenate([y[..., n:], qdd], axis=-1)
    return rhs


# ------------------------------------------------------------------ the dual numbers themselves
def test_a_dual_number_differentiates_a_complex_step_exactly():
    """g(x) = x² sin x: Im g(x + i h)/h = g′(x) (the complex step), and its ε part at x + ε is g″(x), exactly."""
    x = np.array([0.3, -1.2, 2.5])
    z = Dual(x + 1j * STEP, np.ones(3))
    first = (z * z * np.sin(z)).imag / STEP
    exact_first = 2 * x * np.sin(x) + x * x * np.cos(x)
    exact_second = 2 * np.sin(x) + 4 * x * np.cos(x) - x * x * np.sin(x)
    assert np.abs(first.value - exact_first).max() <= 4 * np.finfo(float).eps * np.abs(exact_first).max()
    assert np.abs(first.tangent - exact_second).max() <= 8 * np.finfo(float).eps * np.abs(exact_second).max()


def test_what_has_no_dual_rule_is_refused_not_dropped():
    """An operation without a rule raises, and a dual number never becomes a plain array (its tangent lost)."""
    z = seeded(np.array([0.5, 1.0]), np.eye(2))
    with pytest.raises(TypeError, match="no dual-number rule for exp"):
        np.exp(z)
    with pytest.raises(TypeError, match="no dual-number rule"):
        np.linalg.solve(np.eye(2), z)
    with pytest.raises(TypeError, match="tangent would be lost"):
        np.asarray(z, dtype=float)
    with pytest.raises(TypeError, match="not analytic"):
        np.abs(z + 1j)
    real = Dual(np.zeros(2), np.zeros(2))
    with pytest.raises(TypeError, match="imaginary part"):
        real[0] = z[0] + 1j
    with pytest.raises(TypeError, match="would read as zero"):
        tangent(np.zeros(2))


def test_a_clip_has_the_slope_of_its_branch():
    """Comparisons see the value: a clipped entry's tangent is 0, a free one's passes."""
    z = seeded(np.array([-2.0, 0.5, 3.0]), np.eye(3))
    clipped = np.where(z.real > 1.0, 1.0, np.where(z.real < -1.0, -1.0, z))
    assert np.array_equal(tangent(clipped), np.diag([0.0, 1.0, 0.0]))


def _redundant(s: float) -> tuple[np.ndarray, ...]:
    """KKT blocks along a parameter s: J of rank 1 whose range [1, s] turns with s (its second row s times the
    first), γ outside that range (the redundant rows disagree), M and F moving too."""
    return (np.array([[2.0, 0.3], [0.3, 1.0]]) * (1 + 0.1 * s), np.array([0.7, -0.2 + s]),
            np.array([[1.0, 0.5 * s], [s, 0.5 * s * s]]), np.array([1.0 + s, 0.3]))


def test_the_kkt_tangent_follows_redundant_rows_that_turn():
    """kkt_tangent against the central difference of solve_kkt along s (h = 1e-5: error ~h² ≈ 1e-10 of the
    derivative's size, against 1e-8): the term (J⁺)ᵀJ′ᵀr of the turning range, with r = Jq̈ − γ ≠ 0, is in it
    (without it the tangent is off by 0.19)."""
    s, h = 0.4, 1e-5
    mass, force, jac, gamma = _redundant(s)
    assert solve_kkt(mass, force, jac, gamma).rank == 1
    slopes = (np.array([[2.0, 0.3], [0.3, 1.0]]) * 0.1, np.array([0.0, 1.0]), np.array([[0.0, 0.5], [1.0, s]]),
              np.array([1.0, 0.0]))
    got = kkt_tangent(*(Dual(v, d) for v, d in zip(_redundant(s), slopes, strict=True))).qdd.tangent
    want = (solve_kkt(*_redundant(s + h)).qdd - solve_kkt(*_redundant(s - h)).qdd) / (2 * h)
    assert np.abs(got - want).max() <= 1e-8 * np.abs(want).max()


# ------------------------------------------------------------------ against sympy's exact derivative
def _against_sympy() -> float:
    """The worst difference between the tree's exact Jacobian of the double pendulum's MJCF and sympy's derivative
    of the hand-derived system's q̈ (∂q̈/∂q, ∂q̈/∂q̇ of M⁻¹F, symbolic), at four states, over its largest entry."""
    import sympy as sp  # lazy: sympy only for this comparison

    from harness import cases
    from harness.engine.models import compile_model
    from harness.families.sampled import sample_states
    from harness.reference import derivations
    from tests.test_tree import _at, _idealized

    case = cases.get("double_pendulum")
    model = _idealized(case, compile_model(case.mjcf, edit=prepare))
    ref = case.reference(model)
    binding = case.probe(ref.dynamics).binding
    derivation = derivations.derivation(case.system)
    system = derivation.system
    values = {p: ref.dynamics.params[p.name] for p in system.params}
    qdd = derivation.mass_matrix.subs(values).LUsolve(derivation.forcing.subs(values))
    state = [*system.q, *system.qd]
    jac = sp.lambdify(state, qdd.jacobian(state), modules="numpy")
    data = mujoco.MjData(model)
    worst = 0.0
    for q, qd in zip(*sample_states(ref, count=4), strict=True):
        binding.set_state(model, data, q, qd)  # the binding is the identity here: the tree's q are the joints'
        dyn, qt, qdt = _at(model, data.qpos.copy(), data.qvel.copy())
        y = np.concatenate([qt, qdt])
        rhs = _rhs(dyn, stabilization=(0.0, 0.0))
        got = state_jacobian(dyn, rhs, 0.0, y, rhs(0.0, y))[len(q):]
        want = np.asarray(jac(*q, *qd), dtype=float)
        worst = max(worst, float(np.abs(got - want).max() / np.abs(want).max()))
    return worst


def test_the_tree_jacobian_is_sympys_exact_derivative_of_the_double_pendulum():
    """To 1e-13 of the largest entry (module docstring)."""
    assert _against_sympy() <= 1e-13


# ------------------------------------------------------------------ against central differences, on real robots
def _menagerie(folder: str, scene: str) -> Path:
    path = MENAGERIE / folder / scene
    if not path.exists():
        pytest.skip(f"{MENAGERIE / folder} is absent")
    return path


def _robot(path: Path, *, seed: int = 1) -> tuple[TreeDynamics, np.ndarray]:
    """The tree of a robot at controls inside their ranges, and a state on its constraints: q away from qpos0,
    q̇ random."""
    spec = mujoco.MjSpec.from_file(str(path))
    prepare(spec)
    model = spec.compile()
    rng = np.random.default_rng(seed)
    lo, hi = (model.actuator_ctrlrange.T if model.nu else (np.zeros(0), np.zeros(0)))
    ctrl = np.where(model.actuator_ctrllimited, lo + (hi - lo) * rng.uniform(0.2, 0.8, model.nu),
                    rng.normal(size=model.nu))
    dyn = TreeDynamics.of(read_tree(model, chart=charts(model, mujoco.MjData(model).qpos), ctrl=ctrl))
    q, qd = project(dyn, rng.normal(scale=0.3, size=dyn.n), rng.normal(size=dyn.n), polish=True)
    return dyn, np.concatenate([q, qd])


def _central(rhs, y: np.ndarray, directions: np.ndarray, h: float) -> np.ndarray:
    """The sixth-order central difference of f along each direction (rows), columns as the Jacobian's."""
    weights = np.array([-1.0, 9.0, -45.0, 45.0, -9.0, 1.0]) / 60.0
    steps = np.array([-3.0, -2.0, -1.0, 1.0, 2.0, 3.0]) * h
    states = y + steps[None, :, None] * directions[:, None, :]
    values = rhs(0.0, states.reshape(-1, y.size)).reshape(len(directions), 6, y.size)
    return np.einsum("dkn,k->nd", values, weights) / h


def _disagreement(jac: np.ndarray, rhs, y: np.ndarray, directions: np.ndarray, h: float) -> float:
    """The worst |J d − c(h/2)| over its bound 4|c(h) − c(h/2)| + 1e4 ε |f|/h (module docstring): ≤ 1 where J is
    the derivative."""
    coarse, fine = _central(rhs, y, directions, h), _central(rhs, y, directions, h / 2)
    floor = 1e4 * np.finfo(float).eps * np.abs(rhs(0.0, y)).max() / (h / 2)
    return float(np.max(np.abs(jac @ directions.T - fine) / (4 * np.abs(coarse - fine) + floor)))


def _tangent_directions(dyn: TreeDynamics, y: np.ndarray) -> np.ndarray:
    """Unit directions of the state space that keep q on its constraints to first order (J v = 0; any q̇), rows:
    off them a loop's redundant rows turn independent within ~1e-7 (Cassie's achilles rods: the constraints' rank
    rises from 10 to 11, q̈ jumps), which no difference step can resolve."""
    n = dyn.n
    if not dyn.rows:
        return np.eye(2 * n)
    _, s, vt = np.linalg.svd(dyn.jacobian(y[:n]))
    null = vt[np.sum(s > 1e-9 * s[0]):]
    blocks = np.zeros((len(null) + n, 2 * n))
    blocks[:len(null), :n] = null
    blocks[len(null):, n:] = np.eye(n)
    return blocks


@pytest.mark.parametrize(("folder", "scene", "h"), [("franka_emika_panda", "scene.xml", 1e-3),
                                                    ("agility_cassie", "scene.xml", 1e-3),
                                                    ("robotiq_2f85", "scene.xml", 1e-3)])
def test_the_exact_jacobian_is_the_derivative_on_real_robots(folder, scene, h):
    """Panda (position servos with force ranges, the fingers' equality row), Cassie (free joint, four loops
    closed by connects with redundant rows) and the Robotiq 2F-85 (two loops closed by connects): the exact
    Jacobian along every direction that stays on the constraints agrees with the central differences within
    their own error; the former forward differences do not."""
    dyn, y = _robot(_menagerie(folder, scene))
    rhs = _rhs(dyn)
    f = rhs(0.0, y)
    directions = _tangent_directions(dyn, y)
    exact = state_jacobian(dyn, rhs, 0.0, y, f)
    assert _disagreement(exact, rhs, y, directions, h) <= 1.0
    assert _disagreement(state_jacobian(dyn, rhs, 0.0, y, f, differences=True), rhs, y, directions, h) > 10.0


def test_the_humanoids_free_joint_and_balls_are_exact():
    """dm_control's humanoid (27 dof under a free joint, damping, armature): every column, central differences."""
    suite = pytest.importorskip("dm_control").__file__
    dyn, y = _robot(Path(suite).parent / "suite" / "humanoid.xml")
    rhs = _rhs(dyn)
    exact = state_jacobian(dyn, rhs, 0.0, y, rhs(0.0, y))
    assert _disagreement(exact, rhs, y, np.eye(y.size), 1e-3) <= 1.0


# Every kind of constraint row at once, with the terms the robots above lack: a ball closing a loop by a connect, a
# weld between a free body and a hinged one, a joint equality with a quadratic polynomial, a slide's spring, and
# MuJoCo's polynomial damping (a v + b v|v| + c v³) on a hinge.
ROWS = """
<mujoco model="every constraint">
  <option gravity="0.3 -0.2 -9.81"/>
  <worldbody>
    <body name="a" pos="0 0 1">
      <joint name="a" type="hinge" axis="0 1 0" damping="0.3 0.2 0.05"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02" mass="1"/>
      <body name="b" pos="0.3 0 0">
        <joint name="b" type="ball" damping="0.02"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.3" size="0.02" mass="0.5"/>
      </body>
    </body>
    <body name="c" pos="0.3 0 0.7">
      <joint name="c" type="hinge" axis="0 1 0"/>
      <joint name="s" type="slide" axis="1 0 0" stiffness="20"/>
      <geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.02" mass="0.7"/>
    </body>
    <body name="f" pos="1 0 1">
      <freejoint name="f"/>
      <geom type="box" size="0.1 0.05 0.03" mass="0.8"/>
    </body>
    <body name="g" pos="1.4 0 1">
      <joint name="g" type="hinge" axis="0 0 1"/>
      <geom type="box" size="0.1 0.05 0.03" mass="0.3"/>
    </body>
  </worldbody>
  <equality>
    <connect body1="b" body2="c" anchor="0 0 -0.3"/>
    <weld body1="f" body2="g" relpose="-0.4 0 0 1 0 0 0"/>
    <joint joint1="s" joint2="c" polycoef="0.01 0.3 0.5 0 0"/>
  </equality>
</mujoco>"""


def _features() -> list:
    from tests.test_actuation import CLAMPED, SERVOS, TENDON_CLAMPS, TENDONS
    from tests.test_tree import EVERY_KIND

    return [pytest.param(SERVOS, id="servos"), pytest.param(CLAMPED, id="clamped joints"),
            pytest.param(TENDONS, id="tendon clamps", marks=pytest.mark.skipif(not TENDON_CLAMPS, reason="no tendon "
                                                                               "actuatorfrcrange in this MuJoCo")),
            pytest.param(EVERY_KIND, id="every joint kind"), pytest.param(_rows(), id="every constraint")]


def _rows() -> str:
    """:data:`ROWS`, its polynomial damping linear where this MuJoCo has none (3.3: a joint's damping is a float)."""
    joint = mujoco.MjSpec().worldbody.add_body().add_joint()
    return ROWS if np.ndim(joint.damping) else ROWS.replace('damping="0.3 0.2 0.05"', 'damping="0.3"')


@pytest.mark.parametrize("xml", _features())
def test_every_term_is_exact(xml):
    """Each term q̈ depends on, on small models: actuators with force ranges (clipped ones have slope 0) and gears,
    joints' and tendons' actuatorfrcrange, gravity compensation routed to the actuators (tests/test_actuation.py's
    models, at their keyframes); every joint kind with springs, damping, armature, gravcomp and an affine actuator
    (tests/test_tree.py's); connect, weld and joint-equality rows with their stabilization (``ROWS``): the exact
    Jacobian along every direction on the constraints within the central differences' own error."""
    spec = mujoco.MjSpec.from_string(xml)
    prepare(spec)
    model = spec.compile()
    data = mujoco.MjData(model)
    if model.nkey:
        mujoco.mj_resetDataKeyframe(model, data, 0)
    else:
        data.qvel[:] = np.random.default_rng(0).normal(size=model.nv)
    ctrl = data.ctrl.copy() if model.nkey else np.linspace(0.3, 0.8, model.nu)
    dyn = TreeDynamics.of(read_tree(model, chart=charts(model, data.qpos), ctrl=ctrl))
    q0, qd0 = start_state(model, data.qpos, data.qvel)
    q, qd = project(dyn, np.array([q0[c] for c in dyn.coordinates]) + 0.05,
                    np.array([qd0[c] for c in dyn.coordinates]), polish=True)
    y = np.concatenate([q, qd])
    rhs = _rhs(dyn)
    assert _disagreement(state_jacobian(dyn, rhs, 0.0, y, rhs(0.0, y)), rhs, y, _tangent_directions(dyn, y),
                         1e-3) <= 1.0


def _dropped(monkeypatch, block: int) -> None:
    """A planted wrong term: the tree's KKT block ``block`` (0 M, 2 J) taken as constant in q̈'s tangent."""
    original = TreeDynamics.kkt_terms

    def constant(self, q, qd, *, stabilization=(0.0, 0.0)):
        blocks = list(original(self, q, qd, stabilization=stabilization))
        if isinstance(blocks[block], Dual):
            blocks[block] = Dual(blocks[block].value, np.zeros_like(blocks[block].tangent))
        return tuple(blocks)

    monkeypatch.setattr(TreeDynamics, "kkt_terms", constant)


@pytest.mark.parametrize(("folder", "block"), [("franka_emika_panda", 0), ("robotiq_2f85", 2)])
def test_a_planted_wrong_term_fails(monkeypatch, folder, block):
    """The check is not blind: with M's q-derivative dropped (Panda) or the constraint Jacobian's (Robotiq's loops)
    the exact Jacobian no longer agrees with the central differences."""
    dyn, y = _robot(_menagerie(folder, "scene.xml"))
    rhs = _rhs(dyn)
    _dropped(monkeypatch, block)
    assert _disagreement(state_jacobian(dyn, rhs, 0.0, y, rhs(0.0, y)), rhs, y, _tangent_directions(dyn, y),
                         1e-3) > 10.0


def test_a_wrong_rule_fails_against_sympy(monkeypatch):
    """A wrong dual rule (cos′ = +sin) breaks the agreement with sympy's double-pendulum derivative."""
    monkeypatch.setitem(dual_module._UFUNCS, np.cos, dual_module._unary(np.cos, lambda v, _: np.sin(v)))
    assert _against_sympy() > 1e-3
