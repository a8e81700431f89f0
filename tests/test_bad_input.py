"""Hostile input: each is refused before any work with one line naming what is wrong and what is accepted
(exit 2), or judged as what it is; never a traceback, a number standing for a diverged run, or MuJoCo's
own warnings on stderr.

Subprocess tests pin what only a real process shows: the exit status, every byte on stderr (MuJoCo
prints its warnings from C, past pytest's capture) and what is left in the working directory.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from harness.cli.commands import main
from harness.core.errors import ModelError
from harness.engine.models import compile_model

CASE = "pendulum"
MJCF = Path(__file__).resolve().parent.parent / "mjcf" / f"{CASE}.xml"


def _variant(tmp_path: Path, old: str, new: str, name: str = "variant.xml") -> Path:
    text = MJCF.read_text()
    assert old in text
    path = tmp_path / name
    path.write_text(text.replace(old, new))
    return path


def _cli(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "harness.cli", *args], capture_output=True, text=True,
                          timeout=300, cwd=cwd)


def _one_line(err: str, needle: str) -> None:
    assert err.endswith("\n") and err.count("\n") == 1, repr(err)  # exactly one line, nothing before it
    assert needle in err and "Traceback" not in err, err


# ------------------------------------------------------------------ models
BAD_ATTRIBUTES = [
    ('timestep="0.001"', 'timestep="nan"', "option timestep = nan is not finite; accepted: a timestep > 0 s"),
    ('timestep="0.001"', 'timestep="0"', "option timestep = 0 s; accepted: a timestep > 0 s"),
    ('timestep="0.001"', 'timestep="-0.001"', "option timestep = -0.001 s; accepted: a timestep > 0 s"),
    ('gravity="0 0 -9.81"', 'gravity="0 0 nan"', "option gravity = [0 0 nan] is not finite"),
    ('solref="0.002 1"', 'solref="nan 1"', "equality 'rod' solref = [nan 1] is not finite"),
    ('solref="0.002 1"', 'solref="0.002 -1"', "equality 'rod' solref = [0.002 -1] mixes solref's two formats"),
    ('mass="1" diaginertia', 'mass="nan" diaginertia', "'bob'"),
    ('damping="0" armature="0"/>\n      <joint name="r"', 'damping="inf" armature="0"/>\n      <joint name="r"',
     "joint 'theta' damping = inf is not finite"),
]


@pytest.mark.parametrize("old, new, needle", BAD_ATTRIBUTES, ids=[b[1].split("=")[0] + ":" + b[1].split('"')[1]
                                                                  for b in BAD_ATTRIBUTES])
def test_a_model_with_a_senseless_number_is_refused_naming_it(tmp_path, old, new, needle):
    path = _variant(tmp_path, old, new)
    with pytest.raises(ModelError, match="invalid MJCF") as info:
        compile_model(path)
    assert needle in str(info.value)


def test_a_refused_model_prints_one_line_and_leaves_no_log(tmp_path):
    """MuJoCo warns about the NaN while parsing (and, at every constraint row, about the solref it
    replaces), on stderr from C and into MUJOCO_LOG.TXT in the working directory: none of it shows."""
    path = _variant(tmp_path, 'solref="0.002 1"', 'solref="nan 1"')
    proc = _cli("check", "--case", CASE, "--mjcf", str(path), cwd=tmp_path)
    assert proc.returncode == 2 and proc.stdout == ""
    _one_line(proc.stderr, "equality 'rod' solref = [nan 1] is not finite; accepted: finite numbers")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["variant.xml"]


@pytest.mark.parametrize("target, needle", [
    (lambda tmp: tmp, "it is a directory"),
    (lambda tmp: Path("/dev/zero"), "it is a character device, not a file"),
    (lambda tmp: tmp / "missing.xml", "no such file"),
])
def test_mjcf_that_is_not_a_file_says_what_it_is(tmp_path, capsys, target, needle):
    assert main(["check", "--case", CASE, "--mjcf", str(target(tmp_path))]) == 2
    err = capsys.readouterr().err
    _one_line(err, needle)
    assert "accepted: an MJCF (XML) file" in err
