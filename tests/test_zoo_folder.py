"""A folder of robots in one command (issue 43 point 8): ``mjharness zoo --folder DIR`` judges every MJCF entry of a
folder laid out like MuJoCo Menagerie's (harness/zoo.py, ``folder_models``)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from harness import zoo
from harness.cli.commands import main

MENAGERIE = Path(__file__).resolve().parents[1] / ".." / "shared" / "models" / "menagerie"

ARM = ("<mujoco model='{name}'><worldbody><body name='link'><joint name='hinge' axis='0 1 0' damping='0.1'/>"
       "<geom type='capsule' fromto='0 0 0 0.3 0 0' size='0.03'/></body></worldbody></mujoco>")


def _robots(root: Path) -> Path:
    """Two robot folders as Menagerie lays them out: a scene including its robot, a second standalone file, an
    asset folder, a file that is not MJCF and one that is not XML."""
    arm = root / "acme_arm"
    (arm / "assets").mkdir(parents=True)
    (arm / "arm.xml").write_text(ARM.format(name="acme arm"))
    (arm / "scene.xml").write_text("<mujoco model='acme arm scene'><include file='arm.xml'/></mujoco>")
    (arm / "gripper.xml").write_text(ARM.format(name="acme gripper"))
    (arm / "assets" / "notes.xml").write_text("<notes>not a model</notes>")
    (arm / "broken.xml").write_text("<mujoco><worldbody>")
    other = root / "other_bot"
    other.mkdir()
    (other / "scene.xml").write_text(ARM.format(name="MuJoCo Model"))
    return root


def test_entries_are_the_mjcf_files_no_other_includes(tmp_path):
    models, passed = zoo.folder_models(_robots(tmp_path))
    assert [m.name for m in models] == ["acme_arm/gripper", "acme_arm/scene", "other_bot/scene"]
    assert [m.package for m in models] == ["acme_arm", "acme_arm", "other_bot"]
    assert len(passed) == 1 and passed[0].startswith("acme_arm/broken.xml: not XML")


def test_a_folder_that_is_none_or_holds_no_entry_is_one_line(tmp_path):
    with pytest.raises(ValueError, match="is not a folder"):
        zoo.folder_models(tmp_path / "missing")
    (tmp_path / "a.xml").write_text("<notes/>")
    with pytest.raises(ValueError, match="holds no MJCF entry"):
        zoo.folder_models(tmp_path)


def test_the_zoo_command_judges_a_folder_and_escapes_its_names(tmp_path, capsys):
    root = tmp_path / "robots"
    arm, odd = root / "acme_arm", root / "odd|bot<b>"
    arm.mkdir(parents=True)
    odd.mkdir()
    (arm / "arm.xml").write_text(ARM.format(name="acme arm"))
    (arm / "scene.xml").write_text("<mujoco model='acme arm scene'><include file='arm.xml'/></mujoco>")
    (odd / "scene\x1b[2J.xml").write_text(ARM.format(name="odd"))
    out = tmp_path / "report"
    code = main(["zoo", "--folder", str(root), "--out", str(out), "--integrators", "RK4", "--jobs", "1"])
    printed = capsys.readouterr().out
    assert code == 0, printed
    assert "\x1b" not in printed and "odd|bot<b>/scene?[2J: pass" in printed
    doc = json.loads((out / "zoo.json").read_text())
    assert {m["model"]: m["verdict"] for m in doc["models"]} == {"acme_arm/scene": "pass",
                                                                  "odd|bot<b>/scene\x1b[2J": "pass"}
    table = (out / "zoo.md").read_text()
    assert "odd\\|bot&lt;b&gt;/scene?[2J" in table and "<b>" not in table and "\x1b" not in table


def test_faults_are_not_sized_on_a_folder(tmp_path, capsys):
    assert main(["zoo", "--folder", str(_robots(tmp_path)), "--faults", "--out", str(tmp_path / "r")]) == 2
    assert "not with --folder" in capsys.readouterr().err


@pytest.mark.slow
def test_the_shared_menagerie_folder_in_one_command(tmp_path, capsys):
    """Every entry of ../shared/models/menagerie gets its row and none crashes (a robot still too slow for the
    60 s each is given ends unfinished, said so, exit 1)."""
    if not MENAGERIE.is_dir():
        pytest.skip(f"no robots folder at {MENAGERIE.resolve()}")
    code = main(["zoo", "--folder", str(MENAGERIE), "--out", str(tmp_path), "--timeout", "60"])
    doc = json.loads((tmp_path / "zoo.json").read_text())
    verdicts = {m["model"]: m["verdict"] for m in doc["models"]}
    assert set(verdicts) == {m.name for m in zoo.folder_models(MENAGERIE)[0]}
    assert "franka_emika_panda/scene" in verdicts and "crashed" not in verdicts.values(), verdicts
    assert code == (1 if "unfinished" in verdicts.values() else 0)


def test_a_folder_entry_carried_to_a_node_is_judged_from_its_copy_and_named_by_the_users_path(tmp_path):
    """On a cluster a folder's entry goes with its files (harness.pipeline.carry): the node judges the carried copy
    (here the user's folder is gone by then, as on a node that does not share it) and the row names the user's
    path, with the verdict the local run gives."""
    from harness.pipeline.carry import pack

    (model,) = [m for m in zoo.folder_models(_robots(tmp_path / "robots"))[0] if m.name == "acme_arm/scene"]
    local = zoo.judge_entry(model, ("RK4",))
    carried = pack(model.path)
    moved = tmp_path / "elsewhere"
    (tmp_path / "robots").rename(moved)
    on_node = zoo.judge_entry(model, ("RK4",), carried=carried)
    assert (on_node.verdict, on_node.path, on_node.failed) == (local.verdict, str(model.path), local.failed)
    assert local.verdict == zoo.PASS


@pytest.mark.slow
def test_a_folder_on_a_ray_cluster_gives_the_local_table(ray_address, tmp_path):
    """``zoo --folder DIR --executor ray``: one task per entry, each entry's files carried, the same verdicts
    and table as the local pool's (the clocks' seconds aside)."""
    root = _robots(tmp_path / "robots")
    docs = {}
    for name, extra in (("local", ()), ("ray", ("--executor", "ray", "--ray-address", ray_address))):
        out = tmp_path / name
        assert main(["zoo", "--folder", str(root), "--out", str(out), "--integrators", "RK4", *extra]) == 0
        docs[name] = {m["model"]: (m["verdict"], m["path"], m.get("failed")) for m in
                      json.loads((out / "zoo.json").read_text())["models"]}
    assert docs["ray"] == docs["local"] and set(docs["local"]) == {"acme_arm/gripper", "acme_arm/scene",
                                                                    "other_bot/scene"}
