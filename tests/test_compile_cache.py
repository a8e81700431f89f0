"""A variant of a model asked for again is not compiled again (:func:`harness.engine.models.compile_model` keeps it
from its first request on), and a model compiled for one variant is never handed out for another."""

from __future__ import annotations

import functools
import os

import mujoco
import pytest

from harness.engine import compat, models
from harness.engine.models import compile_model, edit_identity
from harness.engine.variants import ConvergedSolver, compose
from harness.reference import tree
from harness.reference.tree import TreeEdit

_isolate = tree.isolate

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
def test_an_equal_variant_is_compiled_once_and_handed_out_as_a_copy(path):
    def variant():
        return compile_model(path, integrator="RK4", timestep=0.005, edit=compose(TreeEdit(), ConvergedSolver(100)))

    first = variant()
    before = _counts()
    again = variant()
    assert _counts() == (before[0], before[1] + 1)  # reused, not compiled
    assert again is not first  # a copy: a caller changing it changes no one else's
    again.opt.timestep = 0.5
    again.body_mass[1] = 7.0
    third = variant()
    assert third.opt.timestep == 0.005 and third.body_mass[1] == first.body_mass[1] == 1.0
    assert _counts() == (before[0], before[1] + 2)


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
    assert len({id(entry) for entry in models._COMPILED.values()}) == 3  # models (each under its keys)
    size = int(compile_model(path).nbuffer)
    monkeypatch.setattr(models, "COMPILED_BYTES", 2 * size)
    for k in range(3):
        compile_model(path, timestep=0.01 * (k + 1))
        compile_model(path, timestep=0.01 * (k + 1))
    assert sum(int(m.nbuffer) for _, m in {id(e): e for e in models._COMPILED.values()}.values()) <= 2 * size


@KEEPS
def test_a_variant_asked_for_once_is_kept(path):
    compile_model(path, timestep=0.0123)
    assert any(key[3] == (float, 0.0123) for key in models._COMPILED)


@KEEPS
def test_a_variant_naming_the_integrator_and_timestep_it_compiled_with_is_the_same_model(path):
    own = compile_model(path, edit=ConvergedSolver(100))
    compiled = _counts()[0]
    named = compile_model(path, integrator="Euler", timestep=float(own.opt.timestep), edit=ConvergedSolver(100))
    assert _counts()[0] == compiled and named.opt.timestep == own.opt.timestep == 0.01
    assert compile_model(path, integrator="Euler", edit=ConvergedSolver(100)).opt.timestep == 0.01
    assert compile_model(path, timestep=0.01, edit=ConvergedSolver(100)).opt.integrator == own.opt.integrator
    assert _counts()[0] == compiled
    other = compile_model(path, integrator="RK4", timestep=float(own.opt.timestep), edit=ConvergedSolver(100))
    assert _counts()[0] == compiled + 1 and other.opt.integrator != own.opt.integrator


@KEEPS
def test_a_tree_case_is_prepared_once_whatever_variants_follow(path, monkeypatch):
    """isolate compiles the model to find what to switch off: once per model, not once per variant."""
    isolated = []
    monkeypatch.setattr(tree, "isolate", lambda spec: (isolated.append(1), _isolate(spec)))
    lead = TreeEdit(isolating=True)
    models_ = [compile_model(path, timestep=h, edit=compose(lead, edit))
               for h in (0.01, 0.005) for edit in (None, ConvergedSolver(100), functools.partial(_heavier, factor=3.0))]
    assert len(isolated) == 1
    # each variant as if compiled from the file with the whole edit applied to a fresh parse
    for k, (h, edit) in enumerate((h, e) for h in (0.01, 0.005)
                                  for e in (None, ConvergedSolver(100), functools.partial(_heavier, factor=3.0))):
        spec = mujoco.MjSpec.from_file(str(path))
        compose(lead, edit)(spec)
        spec.option.timestep = h
        fresh = spec.compile()
        assert models_[k].opt.timestep == h and models_[k].body_mass[1] == fresh.body_mass[1]
        assert models_[k].opt.disableflags == fresh.opt.disableflags and models_[k].opt.solver == fresh.opt.solver
    isolated.clear()
    assert compile_model(path, edit=TreeEdit(isolating=False)) is not None and not isolated  # not isolating


@KEEPS
def test_a_file_changed_on_disk_is_prepared_again(path, monkeypatch):
    isolated = []
    monkeypatch.setattr(tree, "isolate", lambda spec: (isolated.append(1), _isolate(spec)))
    assert compile_model(path, edit=TreeEdit(isolating=True)).body_mass[1] == 1.0
    path.write_text(XML.format(mass=3.0))
    assert compile_model(path, edit=compose(TreeEdit(isolating=True), ConvergedSolver(100))).body_mass[1] == 3.0
    assert len(isolated) == 2


@KEEPS
def test_one_check_of_a_model_compiles_each_variant_once(tmp_path, monkeypatch):
    """A check of a model of one's own asks for its variants many times (the bench, the budget's runs, the
    ladders, the balance, a tightened reference's second measurement): each variant (file, integrator, timestep,
    edit) is compiled once, and the tree case's preparation (isolate: a joint limit to switch off) runs once for
    the compiles and once for the authored text its settings compare (:func:`harness.engine.models.authored`)."""
    from harness.core.options import RunOptions
    from harness.pipeline.entry import evaluate

    path = tmp_path / "limited.xml"
    path.write_text(XML.format(mass=1.0).replace('axis="0 1 0"', 'axis="0 1 0" limited="true" range="-3 3"'))
    compiled: list[tuple | None] = []
    real = models._compiled

    def counted(p, *, integrator, timestep, edit):
        compiled.append(models._variant_key(p, integrator, timestep, edit))
        return real(p, integrator=integrator, timestep=timestep, edit=edit)

    isolated = []
    monkeypatch.setattr(models, "_compiled", counted)
    monkeypatch.setattr(tree, "isolate", lambda spec: (isolated.append(1), _isolate(spec)))
    done = evaluate(str(path), options=RunOptions(integrators=("RK4",)), bar=False, record_costs=False)
    assert done.results[0].case.tree.uncovered  # the limit is switched off: isolate has work
    keyed = [k for k in compiled if k is not None]
    assert len(keyed) > 3 and not [k for k in set(keyed) if keyed.count(k) > 1]
    assert len(isolated) == 2
