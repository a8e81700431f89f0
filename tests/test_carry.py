"""A model's files carried to a cluster's node (harness/pipeline/carry.py): the copy unpacked in a folder of its
own compiles to the same model, whatever the model names (meshes in a meshdir outside its folder, includes);
one file fewer and it does not; a carried place cannot leave its folder."""

from __future__ import annotations

import dataclasses
import tempfile
from pathlib import Path

import mujoco
import numpy as np
import pytest

from harness.pipeline import carry

MENAGERIE = Path(__file__).resolve().parents[2] / "shared" / "models" / "menagerie"
CUBE = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"


@pytest.fixture
def unpack_in(tmp_path, monkeypatch) -> Path:
    """Carried models unpack under this test's folder (as on another node), never the machine's temporary one."""
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path / "node"))
    (tmp_path / "node").mkdir()
    return tmp_path / "node"


def _model(tmp_path: Path) -> Path:
    """A model naming a mesh in a meshdir beside its own folder and an included file with a second mesh."""
    (tmp_path / "meshes").mkdir()
    (tmp_path / "meshes" / "a.obj").write_text(CUBE)
    (tmp_path / "meshes" / "b.obj").write_text(CUBE.replace("v 1 0 0", "v 2 0 0"))
    (tmp_path / "robot").mkdir()
    (tmp_path / "robot" / "parts.xml").write_text(
        '<mujoco><asset><mesh name="b" file="b.obj"/></asset></mujoco>')
    (tmp_path / "robot" / "unrelated.bin").write_bytes(b"\0" * 1000)
    model = tmp_path / "robot" / "arm.xml"
    model.write_text('<mujoco><compiler meshdir="../meshes"/><include file="parts.xml"/>'
                     '<asset><mesh name="a" file="a.obj"/></asset><worldbody><body><joint type="hinge"/>'
                     '<geom type="mesh" mesh="a"/><geom type="mesh" mesh="b" pos="0 0 1"/></body></worldbody>'
                     '</mujoco>')
    return model


def _same(a: mujoco.MjModel, b: mujoco.MjModel) -> bool:
    return (a.nmesh == b.nmesh and np.array_equal(a.mesh_vert, b.mesh_vert)
            and np.array_equal(a.body_mass, b.body_mass) and np.array_equal(a.body_inertia, b.body_inertia))


def test_a_model_naming_files_outside_its_folder_compiles_the_same_from_its_carried_copy(tmp_path, unpack_in):
    model = _model(tmp_path)
    carried = carry.pack(model)
    assert sorted(place for place, _ in carried.files) == ["meshes/a.obj", "meshes/b.obj", "robot/arm.xml",
                                                          "robot/parts.xml"]  # not the unrelated file
    here = carried.here()
    assert here.is_relative_to(unpack_in) and here.name == "arm.xml"
    assert _same(mujoco.MjModel.from_xml_path(str(here)), mujoco.MjModel.from_xml_path(str(model)))
    assert carried.here() == here  # unpacked once: a later task of the model reuses it
    assert carried.path == str(model)


def test_a_copy_missing_one_named_file_does_not_compile(tmp_path, unpack_in):
    """The comparison above can fail: without the included file's mesh the copy is no model."""
    carried = carry.pack(_model(tmp_path))
    fewer = dataclasses.replace(carried, files=tuple(f for f in carried.files if f[0] != "meshes/b.obj"),
                                digest="0" * 64)
    with pytest.raises(ValueError, match=r"b\.obj"):
        mujoco.MjModel.from_xml_path(str(fewer.here()))


@pytest.mark.parametrize("place", ["../outside.xml", "/etc/passwd", ""])
def test_a_carried_place_cannot_leave_its_folder(place, unpack_in):
    bad = carry.Carried("m.xml", "m.xml", ((place, b"x"),), "1" * 64)
    with pytest.raises(ValueError, match="not inside the model's folder"):
        bad.here()


def test_a_model_too_large_to_carry_is_one_line(tmp_path, monkeypatch):
    monkeypatch.setattr(carry, "LIMIT", 100)
    with pytest.raises(ValueError) as caught:
        carry.pack(_model(tmp_path))
    assert "more than the 0 MiB a model may carry" in str(caught.value) and "\n" not in str(caught.value)
    with pytest.raises(ValueError, match="no model file"):
        carry.pack(tmp_path / "none.xml")


@pytest.mark.parametrize("entry", [pytest.param("franka_emika_panda/panda.xml", marks=pytest.mark.slow),  # 4 s
                                   "kuka_iiwa_14/iiwa14.xml", "robotiq_2f85/2f85.xml",
                                   "agility_cassie/cassie.xml", "wonik_allegro/scene_right.xml"])
def test_a_menagerie_robot_compiles_the_same_from_its_carried_copy(entry, unpack_in):
    if not MENAGERIE.is_dir():
        pytest.skip(f"no robots here: {MENAGERIE} is absent")
    carried = carry.pack(MENAGERIE / entry)
    # the folder's README, LICENSE and picture of the robot (beside the model) are named by no model: not carried
    assert all(place.endswith(".xml") or place.startswith("assets/") for place, _ in carried.files)
    copy, original = (mujoco.MjModel.from_xml_path(str(p)) for p in (carried.here(), MENAGERIE / entry))
    assert _same(copy, original)
