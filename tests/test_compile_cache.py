"""A variant of a model asked for again is not compiled again (:func:`harness.engine.models.compile_model` keeps it
from its second request on), and a model compiled for one variant is never handed out for another."""

from __future__ import annotations

import functools
import os

import mujoco
import pytest

from harness.engine import compat, models
from harness.engine.models import compile_model, edit_identity
from harness.engine.variants import ConvergedSolver, compose
from harness.reference.tree import TreeEdit

XML = """<mujoco>
  <option timestep="0.01"/>
  <worldbody>
    <body name="b" pos="0 0 1">
      <joint name="j" type="hinge" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0 0 -1" size="0.05" mass="{mass}"/>
    </body>
  </worldbody>
</mujoco>
"""


def _heavier(spec: mujoco.MjSpec, factor: float = 2.0) -> None:
    for geom in spec.geoms:
        geom.mass = factor * float(geom.mass)


def _counts() -> tuple[int, int]:
    return models.COMPILES["compiled"], models.COMPILES["reused"]


KEEPS = pytest.mark.skipif(bool(compat.missing_flags()), reason=f"MuJoCo {mujoco.__version__} needs per-parse "
                           "fallbacks (harness.engine.compat): compile_model keeps nothing there")


@pytest.fixture
def path(tmp_path):
    p = tmp_path / "pendulum.xml"
    p.write_text(XML.format(mass=1.0))
    return p


@KEEPS
def test_an_equal_variant_is_compiled_no_more_than_twice_and_handed_out_as_a_copy(path):
    def variant():
        return compile_model(path, integrator="RK4", timestep=0.005, edit=compose(TreeEdit(), ConvergedSolver(100)))

    first = variant()
    compiled = _counts()[0]
    second = variant()  # asked for again: compiled, and kept
    assert _counts()[0] == compiled + 1
    before = _counts()
    again = variant()
    assert _counts() == (before[0], before[1] + 1)  # reused, not compiled
    assert again is not first and again is not second  # a copy: a caller changing it changes no one else's
    again.opt.timestep = 0.5
    again.body_mass[1] = 7.0
    third = variant()
    assert third.opt.timestep == 0.005 and third.body_mass[1] == first.body_mass[1] == 1.0
    assert _counts()[1] == before[1] + 2


@pytest.mark.parametrize("change", ["timestep", "integrator", "edit", "edit argument", "none vs edit"])
def test_a_different_variant_is_never_reused(path, change):
    base = {"integrator": "Euler", "timestep": 0.005, "edit": functools.partial(_heavier, factor=2.0)}
    other = dict(base)
    if change == "timestep":
        other["timestep"] = 0.0025
    elif change == "integrator":
        other["integrator"] = "RK4"
    elif change == "edit":
        other["edit"] = ConvergedSolver(100)
    elif change == "edit argument":
        other["edit"] = functools.partial(_heavier, factor=3.0)
    else:
        other["edit"] = None
    compile_model(path, **base)
    a = compile_model(path, **base)  # kept: an equal variant would now be reused
    compiled = _counts()[0]
    b = compile_model(path, **other)
    assert _counts()[0] == compiled + 1
    assert compile_model(path, **base).body_mass[1] == a.body_mass[1]
    assert (a.opt.timestep, a.opt.integrator, a.body_mass[1], a.opt.solver) != \
        (b.opt.timestep, b.opt.integrator, b.body_mass[1], b.opt.solver)


def test_a_file_changed_on_disk_is_compiled_again(path):
    assert compile_model(path).body_mass[1] == compile_model(path).body_mass[1] == 1.0  # kept
    path.write_text(XML.format(mass=3.0))
    assert compile_model(path).body_mass[1] == 3.0


def test_an_included_file_changed_on_disk_is_compiled_again(tmp_path):
    (tmp_path / "body.xml").write_text(XML.format(mass=1.0).replace("<mujoco>", "<mujoco>", 1))
    scene = tmp_path / "scene.xml"
    scene.write_text('<mujoco><include file="body.xml"/></mujoco>')
    assert compile_model(scene).body_mass[1] == compile_model(scene).body_mass[1] == 1.0  # kept
    stat = (tmp_path / "body.xml").stat()
    (tmp_path / "body.xml").write_text(XML.format(mass=4.0))  # same size: the identity must still change
    os.utime(tmp_path / "body.xml", ns=(stat.st_atime_ns, stat.st_mtime_ns + 1_000_000))
    assert compile_model(scene).body_mass[1] == 4.0


def test_an_edit_without_a_stable_identity_is_compiled_every_time(path):
    factor = [2.0]

    def closure(spec: mujoco.MjSpec) -> None:  # reads state that may change between calls
        _heavier(spec, factor[0])

    assert edit_identity(closure) is None and edit_identity(lambda spec: None) is None
    assert edit_identity(compose(TreeEdit(), closure)) is None
    assert compile_model(path, edit=closure).body_mass[1] == compile_model(path, edit=closure).body_mass[1] == 2.0
    factor[0] = 5.0
    compiled = _counts()[0]
    assert compile_model(path, edit=closure).body_mass[1] == 5.0
    assert _counts()[0] == compiled + 1


def test_equal_compositions_have_one_identity():
    assert edit_identity(compose(TreeEdit(), None, ConvergedSolver(100))) == \
        edit_identity(compose(compose(TreeEdit()), ConvergedSolver(100)))
    assert compose(None, TreeEdit()) == TreeEdit()  # one edit is itself: the same model as compiling with it
    assert edit_identity(ConvergedSolver(100)) != edit_identity(ConvergedSolver(200))
    assert edit_identity(TreeEdit(ctrl=(1.0,))) != edit_identity(TreeEdit(ctrl=(True,)))


@KEEPS
def test_the_cache_is_bounded(path, monkeypatch):
    monkeypatch.setattr(models, "COMPILED_MAX", 3)
    for k in range(6):
        compile_model(path, timestep=0.001 * (k + 1))
        compile_model(path, timestep=0.001 * (k + 1))
    assert len(models._COMPILED) == 3
    size = int(compile_model(path).nbuffer)
    monkeypatch.setattr(models, "COMPILED_BYTES", 2 * size)
    for k in range(3):
        compile_model(path, timestep=0.01 * (k + 1))
        compile_model(path, timestep=0.01 * (k + 1))
    assert sum(int(m.nbuffer) for _, m in models._COMPILED.values()) <= 2 * size


def test_a_variant_asked_for_once_is_not_kept(path):
    compile_model(path, timestep=0.0123)
    assert not any(key[3] == (float, 0.0123) for key in models._COMPILED)
