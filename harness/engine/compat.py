"""Differences between MuJoCo versions (3.3 is the oldest supported), in one place."""

from __future__ import annotations

import os
import re
import warnings
from collections.abc import Mapping
from dataclasses import dataclass

import mujoco
import numpy as np

from harness.core.figures import FigureName
from harness.engine.integrators import DOCUMENTED_INTEGRATORS, available_integrators
from harness.engine.readings import Reading

__all__ = ["CONNECT_WELD_LOOPS", "JAC_DOT_DEFECT", "SOLVER_ITERATIONS", "after_compile", "applicable_defect",
           "fallbacks", "full_mass_matrix", "jac_dot", "jac_dot_missing", "joint_types", "known_defect",
           "missing_flags", "set_damping", "set_stiffness", "solver_iterations", "spec_from_file",
           "unavailable_reason", "version"]


def full_mass_matrix(model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
    """Dense joint-space inertia matrix after ``mj_forward``.

    MuJoCo 3.10.0 changed ``mj_fullM(m, dst, qM)`` to ``mj_fullM(m, d, dst)`` (changelog 3.10.0, item 14)
    and later removed ``mjData.qM``; 3.10.0 itself has both ``qM`` and the new signature (found by
    ``mjharness versions``), so the release decides, not the field.
    """
    dense = np.zeros((model.nv, model.nv))
    if _version() >= (3, 10, 0):
        mujoco.mj_fullM(model, data, dense)
    else:
        mujoco.mj_fullM(model, dense, data.qM)
    return dense


def solver_iterations(data: mujoco.MjData) -> int:
    """Constraint-solver iterations of the last ``mj_forward``: the most any island took.

    ``mjData.solver_niter`` is per island (mjNISLAND entries; renamed from
    ``solver_iter`` before 3.3). With islands off (the 3.3 default) ``nisland``
    is 0 and the single solve is entry 0.
    """
    count = max(1, min(int(getattr(data, "nisland", 0)), len(data.solver_niter)))
    return int(np.max(data.solver_niter[:count]))


def _iterations(model: mujoco.MjModel, rec: Mapping[str, np.ndarray]) -> np.ndarray:
    niter = rec["solver_niter"]
    count = np.clip(rec["nisland"].reshape(len(niter)), 1, niter.shape[1])
    return np.where(np.arange(niter.shape[1]) < count[:, None], niter, 0).max(axis=1).astype(float)


# solver_iterations over a recorded run (a series the solver study records with every integrator)
SOLVER_ITERATIONS = Reading(fields=("solver_niter", "nisland"), evaluate=_iterations,
                            description="constraint-solver iterations of the sample's mj_forward: the most "
                                        "any island took")


def constraint_diagonal(data: mujoco.MjData) -> np.ndarray:
    """The diagonal of A = J M⁻¹ Jᵀ per constraint row that the regulariser R is scaled by.

    ``mjData.efc_diagA`` since it can be exact (diagexact); ``efc_diagApprox`` in
    MuJoCo 3.3, where it is always the approximation.
    """
    diag = data.efc_diagA if hasattr(data, "efc_diagA") else data.efc_diagApprox
    return np.asarray(diag)[: data.nefc]


def unavailable_reason(figure: str) -> str:
    """Why a figure named after an integrator cannot be measured with this MuJoCo ('' if it can).

    A limit for ``discrete.position`` or ``converge.discrete.order_shortfall``
    is then shown as not applicable (n/a, with this reason), never dropped silently.
    """
    integrator = FigureName(figure).integrator
    absent = set(DOCUMENTED_INTEGRATORS) - set(available_integrators())
    return f"integrator {integrator} is not in MuJoCo {mujoco.__version__}" if integrator in absent else ""


# <option><flag> attributes newer than MuJoCo 3.3 that shipped models set, by the enum that
# marks their presence. ``diagexact`` (exact diagonal of A = J M⁻¹ Jᵀ for the regulariser R)
# arrived after 3.3.
_NEWER_FLAGS: dict[str, str] = {"diagexact": "mjENBL_DIAGEXACT"}
_FALLBACKS: dict[str, tuple[str, ...]] = {}
_EMULATE_DIAGEXACT: set[str] = set()


def missing_flags() -> tuple[str, ...]:
    """The newer <flag> attributes this MuJoCo does not know."""
    return tuple(a for a, enum in _NEWER_FLAGS.items() if not hasattr(mujoco.mjtEnableBit, enum))


def spec_from_file(path: str) -> mujoco.MjSpec:
    """``MjSpec.from_file``, with a fallback for <flag> attributes this MuJoCo lacks.

    The attribute is removed from the text before parsing (the parser would
    reject it) and the fallback is recorded for :func:`fallbacks` and warned
    about, so a report shows it. ``diagexact`` is then emulated where it can be
    after compiling (:func:`after_compile`).
    """
    absent = missing_flags()
    if not absent:
        return mujoco.MjSpec.from_file(path)
    with open(path, encoding="utf-8") as fh:
        text = fh.read()
    notes = []
    for attr in absent:
        pattern = re.compile(rf'(<flag\b[^>]*?)\s+{attr}\s*=\s*"[^"]*"')
        if pattern.search(text):
            text = pattern.sub(r"\1", text)
            notes.append(f"<flag {attr}> is not in MuJoCo {mujoco.__version__}: removed")
    if not notes:
        return mujoco.MjSpec.from_file(path)
    if path not in _FALLBACKS:
        warnings.warn(f"{path}: " + "; ".join(notes), stacklevel=2)
    _FALLBACKS[path] = tuple(notes)
    if "diagexact" in absent and any("diagexact" in n for n in notes):
        _EMULATE_DIAGEXACT.add(path)
    spec = mujoco.MjSpec.from_string(text)
    spec.modelfiledir = os.path.dirname(os.path.abspath(path))
    return spec


def fallbacks(path: str) -> tuple[str, ...]:
    """The fallbacks :func:`spec_from_file` applied to ``path`` (empty on a MuJoCo with every feature)."""
    return _FALLBACKS.get(str(path), ())


def _version() -> tuple[int, ...]:
    return tuple(int(p) for p in re.findall(r"\d+", mujoco.__version__)[:3])


def version() -> tuple[int, ...]:
    """This MuJoCo's version as numbers, e.g. (4, 0, 0)."""
    return _version()


def jac_dot(model: mujoco.MjModel, data: mujoco.MjData, point: np.ndarray, body: int) -> np.ndarray:
    """Translational J̇ (3 × nv) of a point moving with ``body``, after ``mj_forward``: ``mj_jacDot``,
    corrected where this MuJoCo's is wrong (:func:`jac_dot_missing`)."""
    jacp_dot = np.zeros((3, model.nv))
    mujoco.mj_jacDot(model, data, jacp_dot, None, point, body)
    missing = jac_dot_missing(model, data, point, body)
    return jacp_dot if missing is None else jacp_dot + missing


JAC_DOT_DEFECT = ("mj_jacDot of MuJoCo < 3.3.1 misses the motion of the point itself (changelog 3.3.1: "
                  "\"mj_jacDot was missing a term that accounts for the motion of the point\"): each column "
                  "lacks ω_j × ṗ")


def jac_dot_missing(model: mujoco.MjModel, data: mujoco.MjData, point: np.ndarray, body: int) -> np.ndarray | None:
    """What this MuJoCo's ``mj_jacDot`` leaves out of J̇ (3 × nv), or None where it is right.

    MuJoCo 3.3.0's ``mj_jacDot`` missed the motion of the point itself (fixed in
    3.3.1, :data:`JAC_DOT_DEFECT`): each column lacks ω_j × ṗ, with ω_j the
    rotational Jacobian column and ṗ = J qvel (pinned against finite differences
    in tests/test_compat.py). The harness adds it to take its own measurement
    and reports the engine's disagreement as a finding
    (:func:`harness.families.instant.engine_findings`).
    """
    if _version() >= (3, 3, 1):
        return None
    jacp = np.zeros((3, model.nv))
    jacr = np.zeros((3, model.nv))
    mujoco.mj_jac(model, data, jacp, jacr, point, body)
    pdot = jacp @ data.qvel
    return np.cross(jacr.T, pdot).T  # column j: ω_j × ṗ


def after_compile(model: mujoco.MjModel, path: str) -> None:
    """Apply the fallbacks :func:`spec_from_file` recorded for ``path`` to its compiled model.

    ``diagexact`` emulation. The regulariser R_ii = (1 − d)/d · Â_ii uses MuJoCo's
    diagonal approximation Â, which for a two-joint equality q1 = poly(q2) adds
    the joints' inverse weights without the polycoef gain c: Â = w1 + w2, where
    the exact diagonal at qpos0 is A_ii = J M⁻¹ Jᵀ with J = e1 − c e2. Setting
    w2 = A_ii − w1 makes the two agree (tests/test_atwood.py: the shipped
    diagonal is the exact one on every MuJoCo; docs/findings/versions.md). It is exact
    when the equality is linear (poly = c0 + c q2), M is constant and every
    equality on dof2 asks for the same w2; otherwise nothing is changed and the
    note says so. Contacts (body inverse weights) are not emulated.
    """
    if path not in _EMULATE_DIAGEXACT:
        return
    notes = [n for n in _FALLBACKS.get(path, ()) if not n.startswith("diagexact emulat")]
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    wanted: dict[int, list[float]] = {}
    for i in range(model.neq):
        if int(model.eq_type[i]) != int(mujoco.mjtEq.mjEQ_JOINT) or model.eq_obj2id[i] < 0:
            continue
        dof1 = int(model.jnt_dofadr[model.eq_obj1id[i]])
        dof2 = int(model.jnt_dofadr[model.eq_obj2id[i]])
        row = np.zeros(model.nv)
        row[dof1], row[dof2] = 1.0, -float(model.eq_data[i][1])
        minv_row = np.zeros(model.nv)
        mujoco.mj_solveM(model, data, minv_row.reshape(1, -1), row.reshape(1, -1))
        wanted.setdefault(dof2, []).append(float(row @ minv_row) - float(model.dof_invweight0[dof1]))
    for dof, values in wanted.items():
        name = model.joint(int(model.dof_jntid[dof])).name
        if min(values) <= 0 or max(values) - min(values) > 1e-9 * max(values):
            notes.append(f"diagexact emulation impossible for joint {name}: its equalities need "
                         f"inverse weights {values}")
            continue
        old = float(model.dof_invweight0[dof])
        model.dof_invweight0[dof] = float(np.mean(values))
        notes.append(f"diagexact emulated: dof_invweight0 of joint {name} {old:.6g} -> {np.mean(values):.6g}, "
                     "so the default diagonal equals the exact one at qpos0")
    _FALLBACKS[path] = tuple(notes)


def _set_linear(joint, attr: str, value: float) -> None:
    current = getattr(joint, attr)
    if np.ndim(current) == 0:
        setattr(joint, attr, float(value))
    else:
        setattr(joint, attr, [float(value), *[float(x) for x in np.asarray(current)[1:]]])


def set_damping(joint, value: float) -> None:
    """Set a joint's (linear) damping through MjSpec.

    ``MjsJoint.damping`` is a float in MuJoCo 3.3 and an array later: the
    polynomial coefficients (a, b, c) of f = −(a v + b v|v| + c v³), the same
    for every dof of the joint. ``a`` is set; the other entries are kept.
    """
    _set_linear(joint, "damping", value)


def set_stiffness(joint, value: float) -> None:
    """Set a joint's (linear) stiffness through MjSpec.

    ``MjsJoint.stiffness`` is a float in MuJoCo 3.3 and an array later: the
    polynomial coefficients (a, b, c) of f = −(a x + b x² + c x³). ``a`` is set;
    the other entries are kept.
    """
    _set_linear(joint, "stiffness", value)


# Defects of older MuJoCo versions that the harness measures, documented upstream. A check that
# fails on such a version, on such a model, and shows the defect's signature (harness.pipeline.verdict:
# the integrator's observed order is the defect's, and the budget at that order explains the figure)
# is a failure shown as the known defect, with the reason; the same check on a fixed version is an
# ordinary gate.
CONNECT_WELD_LOOPS: tuple[tuple[int, int, int], str] = (
    (3, 7, 0), "the Coriolis term J̇v in the connect/weld bias, added in MuJoCo 3.7.0 (changelog 3.7.0, item 5): "
               "without it the site-defined loop drifts — measured on 3.3.0, 3.3.7 and 3.6.0: slider_crank "
               "RK4.violation.wrist_pin 1.3e-5 m (3190x its budget), welded_pendulum RK4.violation.glue 7.1e-6 m "
               "(87x on 3.6.0); 3.7.0 holds both")
"""The oldest MuJoCo that holds a closed loop of connect/weld equalities, with its measured reason: the
``Wiring(requires=...)`` of every case whose motion depends on one."""


@dataclass(frozen=True)
class KnownDefect:
    """A documented defect: the version that fixed it, the integrator and joint types it affects, the
    convergence order it degrades that integrator to (its signature), and the reason, with its source."""

    fixed_in: tuple[int, int, int]
    integrator: str
    joint_types: tuple[int, ...]
    order: float
    reason: str


KNOWN_DEFECTS: tuple[KnownDefect, ...] = (
    KnownDefect((4, 0, 0), "RK4", (int(mujoco.mjtJoint.mjJNT_BALL), int(mujoco.mjtJoint.mjJNT_FREE)), 2.0,
                "MuJoCo < 4.0.0: RK4 combined its stages' angular velocities without the Runge-Kutta-Munthe-Kaas "
                "correction, so ball/free-joint orientations converge at 2nd order (changelog 4.0.0, item 5)"),
)


def joint_types(model: mujoco.MjModel) -> frozenset[int]:
    """The joint types a model has (what :func:`applicable_defect` matches defects against)."""
    return frozenset(int(t) for t in model.jnt_type)


def applicable_defect(joints: frozenset[int], integrator: str) -> KnownDefect | None:
    """The documented defect of this MuJoCo that affects ``integrator`` on a model with the joint types
    ``joints`` (:func:`joint_types`), or None. Whether a failing figure shows it is the verdict's
    question (its signature)."""
    for defect in KNOWN_DEFECTS:
        if _version() < defect.fixed_in and defect.integrator == integrator and joints & set(defect.joint_types):
            return defect
    return None


def known_defect(joints: frozenset[int], figure: str) -> str:
    """The reason of the documented defect of this MuJoCo that may explain ``figure`` failing on a model
    with the joint types ``joints``, or '' (the defect applies; its signature is not checked here)."""
    defect = applicable_defect(joints, FigureName(figure).integrator)
    return defect.reason if defect else ""
