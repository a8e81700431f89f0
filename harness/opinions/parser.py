"""Pinocchio's own MJCF parser (``pinocchio.buildModelFromMJCF``) against MuJoCo's compiler: an advisory opinion.

Two readers of one MJCF should build the same robot; where they do not, one of them misreads the file. This loads
the MJCF with Pinocchio's parser, independently of MuJoCo's compiler, and compares the two models body by body
with :func:`harness.opinions.structure.compare` (joints matched by their order within each body: the parser names
a body's several joints one composite joint). It never gates: Pinocchio's parser has known gaps (docs/opinions.md
lists those found), so its disagreements are shown, never counted in the exit code.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import mujoco

from harness.opinions import structure
from harness.opinions.structure import PIN_EXTRA, Comparison, captured_stderr, compare

__all__ = ["ParserOpinion", "parser_opinion"]

TITLE = "Pinocchio's MJCF parser (advisory, never gates)"


@dataclass(frozen=True)
class ParserOpinion:
    """Pinocchio's parser's model of ``mjcf`` against MuJoCo's: the comparison, or ``skipped`` (one line: why
    there is none)."""

    mjcf: str
    comparison: Comparison | None = None
    skipped: str = ""

    def lines(self) -> list[str]:
        """The plain-text section the CLI prints: one line where skipped or in agreement."""
        if self.comparison is None:
            return [f"{TITLE}: {self.skipped}"]
        c = self.comparison
        if c.passed:
            return [f"{TITLE}: agrees with MuJoCo's compiler on {len(c.bodies)} moving bodies, {c.joints} joints, "
                    f"M(q) and gravity torques at {c.states} states"]
        out = [f"{TITLE}: disagrees with MuJoCo's compiler on {len(c.differences) + len(c.only_a) + len(c.only_b)} "
               f"point(s) (not counted in the exit code)"]
        out += [f"  body or joint only in Pinocchio's model: {name}" for name in c.only_a]
        out += [f"  body or joint only in MuJoCo's model: {name}" for name in c.only_b]
        out += ["  " + d.line("Pinocchio", "MuJoCo") for d in c.differences]
        if c.states == 0:
            out.append("  M(q) and gravity torques not compared: the two models' bodies do not match one to one")
        return out

    def as_dict(self) -> dict:
        if self.comparison is None:
            return {"mjcf": self.mjcf, "skipped": self.skipped}
        return {"mjcf": self.mjcf, **self.comparison.as_dict()}


def parser_opinion(mjcf: Path | str, model: mujoco.MjModel) -> ParserOpinion:
    """Pinocchio's parser's reading of ``mjcf`` against MuJoCo's compiled ``model`` of it; never raises for what
    Pinocchio cannot do (not installed, a file its parser refuses): that is the opinion's one line."""
    if not structure.pinocchio_available():  # looked up here: a test can say no
        return ParserOpinion(str(mjcf), skipped=f"skipped: Pinocchio is not installed ({PIN_EXTRA})")
    import pinocchio as pin  # lazy: Pinocchio is optional (the pin extra)

    try:
        with captured_stderr():
            pm = pin.buildModelFromMJCF(str(mjcf))
    except Exception as exc:  # any refusal of its parser is the finding, in one line
        reason = " ".join(str(exc).split()) or type(exc).__name__
        return ParserOpinion(str(mjcf), skipped=f"Pinocchio cannot load this file ({reason})")
    try:
        comparison = compare(pm, model, joint_names=False, absolute=True)
    except Exception as exc:  # a model the comparison cannot pair up: said, never gating
        return ParserOpinion(str(mjcf), skipped=f"Pinocchio's model cannot be compared with MuJoCo's "
                                                f"({type(exc).__name__}: {' '.join(str(exc).split())})")
    return ParserOpinion(str(mjcf), comparison)
