"""The URDF opinion (a robot's URDF against MuJoCo's model of its MJCF) and Pinocchio's MJCF parser's (advisory):
the agreeing example pair passes, each planted conversion error is named by body or joint and quantity, bad input
is one line with exit 2, and the parser's disagreements never change the exit code."""

from __future__ import annotations

from pathlib import Path

import mujoco
import pytest

from harness.cli.commands import main
from harness.core.errors import ModelMismatch
from harness.engine.models import compile_model
from harness.opinions import structure
from harness.opinions.parser import parser_opinion
from harness.opinions.urdf import compare_urdf, model_opinions

ROOT = Path(__file__).resolve().parents[1]
URDF = ROOT / "examples" / "urdf" / "arm.urdf"
MJCF = ROOT / "examples" / "urdf" / "arm.xml"


def _planted(old: str, new: str) -> mujoco.MjModel:
    text = MJCF.read_text()
    assert text.count(old) == 1, old
    return mujoco.MjModel.from_xml_string(text.replace(old, new))


def _named(opinion) -> list[tuple[str, str, str]]:
    return [(d.kind, d.element, d.quantity.split(" (")[0]) for d in opinion.comparison.differences]


def test_the_agreeing_pair_passes():
    pytest.importorskip("pinocchio")
    opinion = compare_urdf(URDF, mujoco.MjModel.from_xml_path(str(MJCF)), mjcf=str(MJCF))
    assert opinion.passed and not opinion.comparison.differences
    assert [b for _, b in opinion.comparison.bodies] == ["upper", "fore", "hand"]
    assert opinion.comparison.joints == 3 and opinion.comparison.states == structure.STATES + 1


def test_a_fixed_joint_inertial_turned_by_the_joint_is_named_on_the_moving_body_it_is_welded_to():
    pytest.importorskip("pinocchio")
    # the tool's centre of mass turned by the fixed joint's 90° about y a second time: (0, 0, 0.05) → (0.05, 0, 0)
    model = _planted('<inertial pos="0 0 0.05" euler="0.3 0 0"', '<inertial pos="0.05 0 0" euler="0.3 0 0"')
    opinion = compare_urdf(URDF, model, mjcf="planted")
    named = _named(opinion)
    assert named[:2] == [("body", "hand", "centre of mass"), ("body", "hand", "inertia Iyy")]
    assert ("joint", "wrist", "gravity torque") in named
    com = opinion.comparison.differences[0]
    assert com.a == "(0.0318182, 0, 0.693636)" and com.b == "(0.00909091, 0, 0.670909)"
    assert com.torque is not None and com.torque > 0.1 and com.on == "shoulder"


def test_an_inertial_turned_in_place_changes_the_inertia_and_no_gravity_torque():
    pytest.importorskip("pinocchio")
    model = _planted('euler="0.3 0 0"', 'euler="0.3 1.5707963267948966 0"')
    opinion = compare_urdf(URDF, model, mjcf="planted")
    assert _named(opinion)[0] == ("body", "hand", "inertia Izz")
    assert not any(q == "gravity torque" for _, _, q in _named(opinion))
    assert opinion.comparison.differences[0].torque < 1e-12


def test_a_dropped_mass_is_named_with_the_torque_it_costs():
    pytest.importorskip("pinocchio")
    opinion = compare_urdf(URDF, _planted('mass="0.8"', 'mass="0.08"'), mjcf="planted")
    first = opinion.comparison.differences[0]
    assert (first.kind, first.element, first.quantity, first.a, first.b) == ("body", "fore", "mass", "0.8", "0.08")
    assert first.on == "shoulder" and first.torque == pytest.approx(2.22, abs=0.01)
    assert ("joint", "elbow", "gravity torque") in _named(opinion)


def test_a_flipped_axis_is_named_on_its_joint():
    pytest.importorskip("pinocchio")
    opinion = compare_urdf(URDF, _planted('name="elbow" axis="0 1 0"', 'name="elbow" axis="0 -1 0"'), mjcf="x")
    first = opinion.comparison.differences[0]
    assert (first.kind, first.element, first.quantity.split(" (")[0], first.a, first.b) == \
        ("joint", "elbow", "axis", "(0, 1, 0)", "(0, -1, 0)")
    assert not any(kind == "body" for kind, _, _ in _named(opinion))


def test_renamed_bodies_are_refused_naming_both_sides_until_mapped(tmp_path):
    pytest.importorskip("pinocchio")
    model = _planted('name="fore"', 'name="forearm"')
    with pytest.raises(ModelMismatch, match=r"URDF only: body fore; MJCF only: body forearm; .*--urdf-map"):
        compare_urdf(URDF, model, mjcf="renamed")
    mapping = tmp_path / "map.toml"
    mapping.write_text('[bodies]\nfore = "forearm"\n')
    assert compare_urdf(URDF, model, mjcf="renamed", mapping=mapping).passed


@pytest.mark.parametrize(("argv", "said"), [
    (["--urdf", "no_such.urdf"], "cannot read URDF 'no_such.urdf': no such file; accepted: a URDF (XML) file"),
    (["--urdf", str(MJCF)], "invalid URDF"),
    (["--urdf", str(URDF), "--urdf-map", "no_such.toml"], "cannot read --urdf-map 'no_such.toml': no such file"),
    (["--urdf-map", "map.toml"], "--urdf-map renames the names of a --urdf FILE; give --urdf too"),
])
def test_bad_input_is_one_line_and_exit_2(capsys, argv, said):
    pytest.importorskip("pinocchio")
    assert main(["check", "--mjcf", str(MJCF), *argv]) == 2
    out = capsys.readouterr()
    assert out.err.startswith("mjharness: error: ") and said in out.err and out.err.count("\n") == 1
    assert "Traceback" not in out.err + out.out


def test_a_difference_fails_the_check_and_is_listed(capsys, tmp_path):
    pytest.importorskip("pinocchio")
    planted = tmp_path / "arm.xml"
    planted.write_text(MJCF.read_text().replace('mass="0.8"', 'mass="0.08"'))
    assert main(["check", "--mjcf", str(planted), "--urdf", str(URDF), "--integrators", "RK4", "-q"]) == 1
    out = capsys.readouterr().out
    assert "  body fore: mass: URDF 0.8, MJCF 0.08 (off by 0.72 kg" in out
    last = out.rstrip().splitlines()[-2:]  # and the inertia audit's: fore's 0.006 kg·m² cannot fit 0.08 kg
    assert last[0].startswith("FAIL — the URDF disagrees with the MJCF: 5 difference(s)"), last
    assert last[1].startswith("FAIL — 1 body inertial(s) no mass distribution inside"), last


def test_without_pinocchio_the_parser_opinion_is_one_line_and_urdf_is_refused(monkeypatch):
    monkeypatch.setattr(structure, "pinocchio_available", lambda: False)
    opinion = parser_opinion(MJCF, mujoco.MjModel.from_xml_path(str(MJCF)))
    assert opinion.lines() == ["Pinocchio's MJCF parser (advisory, never gates): skipped: Pinocchio is not "
                               "installed (pip install 'mjharness[pin]')"]
    with pytest.raises(ValueError, match=r"--urdf needs Pinocchio, which is not installed; fix: pip install"):
        model_opinions(MJCF, urdf=URDF)


def test_the_parsers_disagreements_are_shown_and_never_gate():
    pytest.importorskip("pinocchio")
    welded = ROOT / "mjcf" / "welded_pendulum.xml"  # a second body under <worldbody>: Pinocchio's parser drops it
    opinions = model_opinions(welded, parser=True)
    assert opinions.parser.comparison.only_b == ("body link",)
    assert "  body or joint only in MuJoCo's model: body link" in opinions.lines()
    assert not opinions.failed and opinions.verdict() == ""
    agreeing = model_opinions(MJCF, parser=True)
    assert agreeing.parser.comparison.passed and agreeing.lines()[0].startswith(
        "Pinocchio's MJCF parser (advisory, never gates): agrees with MuJoCo's compiler on 3 moving bodies")


def test_a_file_pinocchios_parser_refuses_is_one_line():
    pytest.importorskip("pinocchio")
    path = ROOT / "mjcf" / "hoop_ramp.xml"
    opinion = parser_opinion(path, compile_model(path))
    assert opinion.comparison is None
    assert opinion.lines() == ["Pinocchio's MJCF parser (advisory, never gates): Pinocchio cannot load this file "
                               "(No such node (body))"]
