"""Legitimate settings pass and faults fail — on every case, through the command line a user runs.

Each change of :mod:`harness.studies.faults` that applies to a case is written
as an MJCF variant of the shipped model (``MjSpec.to_xml``) and judged by
``mjharness check CASE --mjcf VARIANT.xml [--timestep H]``, as a user would:
a setting must exit 0, a fault 1 — at the shipped settings with the fault's
small size, and at 2 × the timestep with MuJoCo's default softness with its
coarse size. Slow (a few hundred runs): ``pytest -m slow``, but for the fast suite's share (:data:`FAST`).
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import pytest

from harness import cases
from harness.cli.commands import main
from harness.engine.compat import spec_from_file
from harness.engine.compat import version as mujoco_version
from harness.engine.models import compile_model
from harness.engine.variants import compose
from harness.studies.faults import COARSE, FAULTS, SETTINGS, Change

# The fast suite's share: both directions through the command line on the systems whose own test modules have no
# parametrized legitimate change and fault (tests/conftest.py keeps one of each of those per module)
FAST = {("pendulum", "masses×2"), ("pendulum", "damping"), ("double_pendulum", "masses×2"),
        ("double_pendulum", "damping")}


def _matrix(changes, *, fast: bool = True) -> list:
    """(case name, change) for every case and change, as ``NAME-CHANGE``; slow but for :data:`FAST` (on MuJoCo 4:
    3.3 writes a spec only once compiled, and then refuses double_pendulum's point masses, so it never ran this)."""
    fast = fast and mujoco_version() >= (4, 0, 0)
    return [pytest.param(name, change, id=f"{name}-{change.name}",
                         marks=() if fast and (name, change.name) in FAST else pytest.mark.slow)
            for name in cases.names() for change in changes]


def _variant(tmp_path: Path, case: cases.Case, edits) -> Path:
    spec = spec_from_file(str(case.mjcf))
    compose(*edits)(spec)
    path = tmp_path / f"{case.name}-variant.xml"
    path.write_text(spec.to_xml())
    return path


def _check(tmp_path: Path, capsys, case: cases.Case, change: Change, *, coarse: bool = False) -> tuple[int, str]:
    why = change.reason_not(case)
    if why:
        pytest.skip(f"{change.name} does not apply to {case.name}: {why}")
    size = change.sizes[1 if coarse else 0]
    edits = [change.edit(case, size)]
    factor = change.timestep
    if coarse:
        edits.append(COARSE.edit(case))
        factor *= COARSE.timestep
    args = ["check", case.name, "--mjcf", str(_variant(tmp_path, case, edits))]
    if factor != 1.0:
        args += ["--timestep", repr(float(compile_model(case.mjcf).opt.timestep) * factor)]
    code = main(args)
    out = capsys.readouterr()
    return code, out.out + out.err


@pytest.mark.parametrize(("name", "change"), _matrix(SETTINGS))
def test_a_legitimate_setting_passes(tmp_path, capsys, name, change):
    code, text = _check(tmp_path, capsys, cases.get(name), change)
    assert code == 0, text[-3000:]


@pytest.mark.parametrize(("name", "change"), _matrix(FAULTS))
def test_a_fault_fails_at_the_shipped_settings(tmp_path, capsys, name, change):
    code, text = _check(tmp_path, capsys, cases.get(name), change)
    assert code == 1, text[-3000:]


@pytest.mark.parametrize(("name", "change"), _matrix(FAULTS, fast=False))
def test_a_fault_fails_at_twice_the_timestep_with_default_softness(tmp_path, capsys, name, change):
    code, text = _check(tmp_path, capsys, cases.get(name), change, coarse=True)
    assert code == 1, text[-3000:]


@pytest.mark.slow  # as the rest of the matrix (it writes specs, which MuJoCo 3.3 does only once compiled)
def test_the_variants_are_what_the_catalog_says(tmp_path):
    """A variant written to MJCF compiles to the model the edit makes (to_xml loses nothing the
    harness reads)."""
    case = cases.get("pendulum")
    damping = next(c for c in FAULTS if c.name == "damping")
    path = _variant(tmp_path, case, [damping.edit(case, 1e-3)])
    written = compile_model(path)
    direct = compile_model(case.mjcf, edit=damping.edit(case, 1e-3))
    assert written.dof_damping.tolist() == direct.dof_damping.tolist() == [1e-3, 1e-3]
    assert isinstance(written, mujoco.MjModel)
