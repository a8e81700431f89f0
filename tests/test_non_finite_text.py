"""A number written non-finite anywhere in the MJCF is refused in one line naming the element (issue 45,
point 5). The spec reads a geom's ``mass="nan"`` as "unset", so MuJoCo gave the geom its density's mass and
the run PASSed; the compiled model's own values are checked by tests/test_bad_input.py."""

from __future__ import annotations

import pytest

from harness.cli.commands import main
from harness.core.errors import ModelError
from harness.engine.models import compile_model, mjcf_path


def _edited(tmp_path, old: str, new: str):
    text = mjcf_path("pendulum").read_text()
    assert old in text
    path = tmp_path / "edited.xml"
    path.write_text(text.replace(old, new, 1))
    return path


ROD = '<geom name="rod" type="capsule" fromto="0 0 0 0 0 1" size="0.01" mass="0"'


@pytest.mark.parametrize(("new", "named"), [
    (ROD.replace('mass="0"', 'mass="nan"'), "geom 'rod' mass = 'nan'"),
    (ROD.replace('mass="0"', 'mass="NaN"'), "geom 'rod' mass = 'NaN'"),
    (ROD.replace('mass="0"', 'density="inf"'), "geom 'rod' density = 'inf'"),
    (ROD.replace('mass="0"', 'mass="-Infinity"'), "geom 'rod' mass = '-Infinity'"),
])
def test_a_number_written_non_finite_is_refused_naming_the_element(tmp_path, new, named):
    with pytest.raises(ModelError, match="is not finite") as exc:
        compile_model(_edited(tmp_path, ROD, new))
    assert named in str(exc.value)


def test_a_name_that_reads_as_a_number_is_a_name(tmp_path):
    model = compile_model(_edited(tmp_path, '<geom name="rod"', '<geom name="nan"'))
    assert model.geom("nan").id >= 0


def test_the_command_refuses_it_in_one_line(tmp_path, capsys):
    assert main(["check", "--mjcf", str(_edited(tmp_path, ROD, ROD.replace('mass="0"', 'mass="nan"')))]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "geom 'rod' mass = 'nan' is not finite" in err


def test_a_non_finite_number_in_an_included_file_is_refused_too(tmp_path):
    """A robot's scene includes the robot: a ``mass="nan"`` there is as silent as in the scene (MuJoCo gives the
    geom its density's mass), so the included files are read too, and the element is named."""
    robot = tmp_path / "robot.xml"
    robot.write_text("<mujoco><worldbody><body name='link'><joint name='j' axis='0 1 0'/>"
                     "<geom name='arm' type='capsule' fromto='0 0 0 0.3 0 0' size='0.03' mass='nan'/></body>"
                     "</worldbody></mujoco>")
    scene = tmp_path / "scene.xml"
    scene.write_text("<mujoco model='scene'><include file='robot.xml'/></mujoco>")
    with pytest.raises(ModelError, match="geom 'arm' mass = 'nan' is not finite"):
        compile_model(scene)
    robot.write_text(robot.read_text().replace("mass='nan'", "mass='1'"))
    assert compile_model(scene).nbody == 2
