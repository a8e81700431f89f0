"""A robot's URDF (loaded by Pinocchio's ``buildModelFromUrdf``) against MuJoCo's compiled model of its MJCF.

Most MJCFs of robots are converted from a URDF, and the conversion is where they go wrong (an inertial turned by a
fixed joint's rpy, a mass dropped, an axis flipped). This compares the two files through
:func:`harness.opinions.structure.compare`: per moving body (mass, centre of mass, inertia), per joint (axis,
its position, limits), then M(q) and gravity torques at sampled states; every difference over tolerance fails
(exit 1). Bodies and joints are matched by name; ``--urdf-map FILE`` (TOML) renames them::

    [bodies]
    urdf_link = "mjcf_body"
    [joints]
    urdf_joint = "mjcf_joint"

A URDF has no free joint; where the MJCF's root body has one, the URDF is loaded with a free-flyer root joint.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass
from pathlib import Path

import mujoco

from harness.core import inputs
from harness.core.errors import BackendUnavailable, ConfigError, ModelError, ModelMismatch
from harness.engine.models import compile_model
from harness.opinions import structure
from harness.opinions.parser import ParserOpinion, parser_opinion
from harness.opinions.structure import PIN_EXTRA, Comparison, captured_stderr, compare

__all__ = ["compare_urdf", "load_urdf", "model_opinions"]

MAP_FORMAT = '[bodies] urdf_link = "mjcf_body" and [joints] urdf_joint = "mjcf_joint"'


@dataclass(frozen=True)
class UrdfOpinion:
    """The URDF ``urdf`` against MJCF ``mjcf``: the comparison, and whether it passed."""

    urdf: str
    mjcf: str
    comparison: Comparison

    @property
    def passed(self) -> bool:
        return self.comparison.passed

    def lines(self) -> list[str]:
        """The plain-text section the CLI prints."""
        c = self.comparison
        head = (f"URDF {self.urdf} against MJCF {self.mjcf} (MuJoCo's compiled model): {len(c.bodies)} moving "
                f"bodies, {c.joints} joints, M(q) and gravity torques at {c.states} states: ")
        if c.passed:
            return [head + "PASS — every quantity within its tolerance"]
        out = [head + f"FAIL — {len(c.differences)} difference(s) over tolerance"]
        out += ["  " + d.line("URDF", "MJCF") for d in c.differences]
        out += ["  " + n for n in c.notes]
        return out

    def as_dict(self) -> dict:
        return {"urdf": self.urdf, "mjcf": self.mjcf, **self.comparison.as_dict()}


def load_map(path: Path | str | None) -> tuple[dict[str, str], dict[str, str]]:
    """The renames of ``--urdf-map FILE``: (bodies, joints), each URDF name → MJCF name."""
    if path is None:
        return {}, {}
    path = Path(path)
    try:
        data = tomllib.loads(inputs.read_text(path, what="--urdf-map"))
    except FileNotFoundError:
        raise ConfigError(f"cannot read --urdf-map {str(path)!r}: no such file; accepted: TOML with "
                          f"{MAP_FORMAT}") from None
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise ConfigError(f"invalid --urdf-map {str(path)!r}: {' '.join(str(exc).split())}; accepted: TOML with "
                          f"{MAP_FORMAT}") from None
    unknown = sorted(set(data) - {"bodies", "joints"})
    tables = [data.get("bodies", {}), data.get("joints", {})]
    if unknown or not all(isinstance(t, dict) and all(isinstance(v, str) for v in t.values()) for t in tables):
        raise ConfigError(f"invalid --urdf-map {str(path)!r}: "
                          f"{'unknown table(s) ' + ', '.join(unknown) if unknown else 'a name that is not a string'}"
                          f"; accepted: {MAP_FORMAT}")
    return dict(tables[0]), dict(tables[1])


def load_urdf(path: Path | str, *, free: bool = False):
    """Pinocchio's model of the URDF ``path`` (with a free-flyer root joint where ``free``); a one-line error
    where Pinocchio is missing or the file is not a URDF it loads."""
    path = Path(path)
    if not structure.pinocchio_available():  # looked up here: a test can say no
        raise BackendUnavailable(f"--urdf needs Pinocchio, which is not installed; fix: {PIN_EXTRA}")
    if not path.is_file():
        what = "no such file" if not path.exists() else "not a regular file"
        raise ModelError(f"cannot read URDF {str(path)!r}: {what}; accepted: a URDF (XML) file")
    inputs.check(path, what="URDF", limit=inputs.MODEL_LIMIT)  # Pinocchio reads it whole
    import pinocchio as pin  # lazy: Pinocchio is optional (the pin extra)

    try:
        with captured_stderr() as said:
            return pin.buildModelFromUrdf(str(path), pin.JointModelFreeFlyer()) if free \
                else pin.buildModelFromUrdf(str(path))
    except Exception as exc:  # urdfdom's reason is what it printed; Pinocchio's own message is generic
        reason = next((line.split("Error:", 1)[1].strip() for line in said if "Error:" in line), str(exc))
        raise ModelError(f"invalid URDF {str(path)!r}: {' '.join(reason.split())}; accepted: a URDF that "
                         "Pinocchio's buildModelFromUrdf loads") from None


def _free_root(m: mujoco.MjModel) -> bool:
    return m.njnt > 0 and int(m.jnt_type[0]) == int(mujoco.mjtJoint.mjJNT_FREE) and m.body_parentid[
        m.jnt_bodyid[0]] == 0


def compare_urdf(urdf: Path | str, model: mujoco.MjModel, *, mjcf: str = "", mapping: Path | str | None = None,
                 ) -> UrdfOpinion:
    """The URDF ``urdf`` against MuJoCo's compiled ``model`` (of MJCF ``mjcf``), names renamed by ``mapping``
    (``--urdf-map``). Names that match on one side only raise :class:`ModelMismatch`, naming them."""
    bodies, joints = load_map(mapping)
    pm = load_urdf(urdf, free=_free_root(model))
    comparison = compare(pm, model, bodies=bodies, joints=joints)
    if comparison.only_a or comparison.only_b:
        raise ModelMismatch(
            f"URDF {str(urdf)!r} and MJCF {mjcf!r} do not match by name: URDF only: "
            f"{', '.join(comparison.only_a) or 'none'}; MJCF only: {', '.join(comparison.only_b) or 'none'}; "
            f"name the renamed ones in --urdf-map FILE (TOML: {MAP_FORMAT})")
    return UrdfOpinion(str(urdf), mjcf, comparison)


@dataclass(frozen=True)
class Opinions:
    """What ``check`` and ``run`` show of the second opinions on a model: the URDF comparison (gating) and
    Pinocchio's MJCF parser's (advisory), each None where not asked for."""

    urdf: UrdfOpinion | None = None
    parser: ParserOpinion | None = None

    @property
    def failed(self) -> bool:
        """Whether the exit code must say fail: the URDF disagrees with the MJCF (the parser never counts)."""
        return self.urdf is not None and not self.urdf.passed

    def lines(self, *, quiet: bool = False) -> list[str]:
        """The sections to print; ``quiet``: the URDF's differences only, where it fails."""
        out = [*(self.parser.lines() if self.parser and not quiet else ())]
        out += self.urdf.lines() if self.urdf and (self.failed or not quiet) else []
        return out

    def verdict(self) -> str:
        """The line under the checks' verdict where the URDF comparison fails ("" otherwise)."""
        if not self.failed:
            return ""
        assert self.urdf is not None  # failed: the URDF comparison failed
        return (f"FAIL — the URDF disagrees with the MJCF: {len(self.urdf.comparison.differences)} difference(s) "
                "over tolerance (listed above)")

    def as_dict(self) -> dict:
        return {k: v.as_dict() for k, v in (("urdf", self.urdf), ("pinocchio_parser", self.parser)) if v}


def model_opinions(mjcf: Path | str | None, *, urdf: Path | str | None = None,
                   mapping: Path | str | None = None, parser: bool = False) -> Opinions:
    """The opinions ``check``/``run`` show on MJCF ``mjcf``: its URDF's comparison where ``urdf`` is given
    (renames in ``mapping``), Pinocchio's parser's where ``parser``. Bad input raises one-line ValueErrors
    (the CLI's exit 2) before any case runs."""
    if mapping is not None and urdf is None:
        raise ValueError("--urdf-map renames the names of a --urdf FILE; give --urdf too")
    if mjcf is None or (urdf is None and not parser):
        if urdf is not None:
            raise ValueError("--urdf compares a URDF with one MJCF: give --mjcf FILE, or exactly one case")
        return Opinions()
    if urdf is not None:
        load_map(mapping)  # a bad map or URDF is named before the MJCF is compiled
        load_urdf(urdf)
    try:
        model = compile_model(mjcf)
    except ValueError:
        if urdf is not None:
            raise
        return Opinions()  # the check itself names what is wrong with the MJCF
    return Opinions(urdf=compare_urdf(urdf, model, mjcf=str(mjcf), mapping=mapping) if urdf is not None else None,
                    parser=parser_opinion(mjcf, model) if parser else None)
