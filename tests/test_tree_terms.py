"""A joint feature is a term (analytic/tree/terms.py) and its entry's reader in FEATURES: a toy term added so,
from this file alone, is put on the joints, lists its parameters and acts as the force −∂V/∂q its energy states,
against a force typed here by hand; the shipped spring's rows stay those of every joint, and its polynomial (MuJoCo
≥ 3.7's stiffness="a b c") is read whole, its energy the integral of the force MuJoCo documents."""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
import pytest

import harness.reference.tree as tree_reference
from analytic.dual import Dual
from analytic.tree import Spring, TreeDynamics
from harness.reference.tree import FEATURES, Feature, read_tree
from tests.helpers import SPRINGS_OFF, needs_polynomial_springs

XML = """<mujoco>
  <compiler angle="radian"/>
  <worldbody>
    <body name="arm">
      <joint name="hinge" type="hinge" axis="0 1 0" stiffness="3" springref="0.2"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.04"/>
      <body name="tip" pos="0.3 0 0">
        <joint name="ball" type="ball"/>
        <geom size="0.03" pos="0.1 0 0" mass="0.2"/>
      </body>
    </body>
  </worldbody>
</mujoco>"""


@dataclass(frozen=True)
class Quartic:
    """V = ¼ c q⁴ on a hinge."""

    c: float

    def energy(self, q: np.ndarray) -> np.ndarray:
        return 0.25 * self.c * q[..., 0] ** 4

    def params(self, joint: str) -> dict[str, float]:
        return {f"{joint}.quartic": self.c}


def _quartic(model: mujoco.MjModel, j: int) -> tuple[Quartic, ...]:
    return (Quartic(7.0),) if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE else ()


@pytest.fixture
def model() -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_string(XML)


def test_a_feature_entry_puts_its_term_on_the_joints_and_it_acts_as_its_energy_states(model, monkeypatch):
    bare = read_tree(model)
    monkeypatch.setattr(tree_reference, "FEATURES", (*FEATURES, Feature("quartic", terms=_quartic)))
    toy = read_tree(model)
    assert toy.joints[0].terms == (*bare.joints[0].terms, Quartic(7.0))
    assert toy.joints[1].terms == bare.joints[1].terms == ()
    assert toy.params()["hinge.quartic"] == 7.0
    rng = np.random.default_rng(3)
    q, qd = rng.normal(size=4), rng.normal(size=4)
    added = TreeDynamics.of(toy).forcing(q, qd) - TreeDynamics.of(bare).forcing(q, qd)
    expected = np.zeros(4)
    expected[0] = -7.0 * q[0] ** 3  # −∂(¼ c q⁴)/∂q, typed by hand
    assert np.allclose(added, expected, rtol=1e-12, atol=1e-12)


def test_the_spring_is_read_as_a_term_and_every_joint_keeps_a_springs_rows(model):
    tree = read_tree(model)
    assert tree.joints[0].terms == (Spring(stiffness=3.0, springref=0.2),)
    params = tree.params()
    assert (params["hinge.stiffness"], params["hinge.springref"]) == (3.0, 0.2)
    assert (params["ball.stiffness"], params["ball.springref"]) == (0.0, 0.0)  # a ball's spring is not read
    names = [k for k in params if k.startswith("hinge.")]
    assert names.index("hinge.ref") < names.index("hinge.stiffness") < names.index("hinge.springref") \
        < names.index("hinge.armature")


def test_springs_off_leave_the_spring_at_nothing(model):
    model.opt.disableflags |= SPRINGS_OFF
    spring = read_tree(model).joints[0].terms[0]
    assert spring == Spring(stiffness=0.0, springref=0.2)
    assert spring.energy(np.array([[np.inf]])) == 0.0  # exactly nothing, whatever q holds


@needs_polynomial_springs
def test_a_polynomial_spring_is_read_whole_and_its_energy_is_the_integral_of_its_force(model):
    """stiffness="3 -1 2" is the force −f(x), f(x) = 3x − x² + 2x³ (MuJoCo's doc/computation "Polynomial forces"):
    read into the hinge's one spring, its coefficients listed as rows only where they are nonzero, the exact
    derivative of its energy (dual numbers, as the stiff solver's Jacobian takes it) f typed here by hand, over
    displacements where the cubic dominates; springs off leave nothing of it."""
    poly = mujoco.MjModel.from_xml_string(XML.replace('stiffness="3"', 'stiffness="3 -1 2"'))
    spring = read_tree(poly).joints[0].terms[0]
    assert spring == Spring(stiffness=3.0, springref=0.2, poly=(-1.0, 2.0))
    params = read_tree(poly).params()
    assert (params["hinge.stiffnesspoly.0"], params["hinge.stiffnesspoly.1"]) == (-1.0, 2.0)
    assert not any(".stiffnesspoly" in k for k in read_tree(model).params())  # a linear spring's rows are unchanged
    x = np.linspace(-4.0, 4.0, 17)
    dv = spring.energy(Dual((0.2 + x)[:, None], np.ones((x.size, 1)))).tangent
    assert np.allclose(dv, 3 * x - x ** 2 + 2 * x ** 3, rtol=1e-14, atol=1e-14)
    poly.opt.disableflags |= SPRINGS_OFF
    assert read_tree(poly).joints[0].terms[0] == Spring(stiffness=0.0, springref=0.2)
