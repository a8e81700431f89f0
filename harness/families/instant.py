"""The instantaneous family: MuJoCo's dynamics at sampled states against the analytic ones, no time integration.

At each sampled state (:mod:`harness.families.sampled`) the analytic M(q), F(q, q̇), q̈ and λ are compared with
MuJoCo's ``mj_fullM``, ``qfrc_passive − qfrc_bias``, ``qacc`` and the equality's ``efc_force``. A fault shows up
here before any trajectory is run, and the figure that fails says where it is (inertia, forces, or the
constraint). Figures ``instant.QUANTITY[.CONSTRAINT]``:

A constraint may be a block of rows (a ``connect`` equality has three): its
``force.NAME`` figure compares every row with its multiplier (the worst row
decides), and a block of several rows also gets ``generalized_force.NAME``,
its own Jᵀλ against D ᵀ J_mjᵀ efc_force over its rows — the force on the
coordinates, which does not depend on how the rows are scaled or ordered.

Those four go through the binding's constant dof matrix D (qvel = D q̇), or its
state-dependent velocity map B(q) (qvel = B(q) q̇, a ball or free joint's local
angular velocity; :func:`harness.engine.bindings.velocity_map`), with
qacc = B q̈ + Ḃ q̇ (Ḃ q̇ by complex step, exact to round-off): mass matrix
Bᵀ M_mj B vs M(q); forcing Bᵀ(qfrc_passive − qfrc_bias − M_mj Ḃ q̇) vs F (Kane's
generalized inertia and active forces: the velocity-dependent part of B moves
into the forcing); q̈ pulled back from qacc − Ḃ q̇
(:func:`harness.families.sampled.pull_back`); the generalized constraint force
Bᵀ qfrc_constraint vs Jᵀλ. A binding with neither gets only the observable
figures, which every case has: the kinetic energy ½ qvelᵀ M_mj qvel vs
½ q̇ᵀ M q̇ (inertia along the sampled velocities) and the world acceleration of
every named point, J_mj qacc + J̇_mj qvel vs (∂x/∂q) q̈ + q̇ᵀ(∂²x/∂q²)q̇ (inertia
and forces together); and ``instant.kinematics``, MuJoCo's point positions
against the analytic points (the geometry every other figure is read in).

Budget: the sampled states' (:mod:`harness.families.sampled`): the same states on the softer model, with the
floors doubled, with the constraints solved exactly; no integration error enters. Every figure is gated.
Where this family corrects an engine function to take its measurement, how far the engine's own answer is off
is a finding (:func:`engine_findings`).
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np

from analytic.dynamics import Dynamics
from harness.cases import Case
from harness.core.checks import Limit
from harness.core.deviation import Deviation
from harness.core.figures import FigureName
from harness.core.findings import Finding
from harness.engine.compat import JAC_DOT_DEFECT, jac_dot_missing
from harness.engine.points import point_source
from harness.engine.probe import Probe
from harness.families.bench import Bench, Measured
from harness.families.sampled import DEFAULT_SAMPLES, Sample, sample_states
from harness.reference.solutions import Reference

__all__ = ["NAME", "compare", "gated", "measure", "names", "not_unique", "owns", "theory_limit"]

NAME = "instant"
QUANTITIES = ("kinematics", "kinetic_energy", "point_acceleration", "mass_matrix", "forcing", "qacc",
              "generalized_force")
"""The figures every case may have (``instant.QUANTITY``); ``force`` and ``generalized_force`` also per constraint."""
OTHERS = ("sensor", "interaction", "peer")
"""Quantities of the instant layer that other families own (:mod:`.reactions`, :mod:`.peers`)."""


def owns(name: FigureName) -> bool:
    return name.layer == "instant" and name.quantity not in OTHERS


def names(case: Case, model: mujoco.MjModel) -> set[FigureName]:
    constraints = [*(model.equality(i).name for i in range(model.neq)), *case.mujoco_forces]
    return {FigureName.instant(q) for q in QUANTITIES} | \
        {FigureName.instant(q, c) for q in ("force", "generalized_force") for c in constraints}


def gated(name: FigureName, *, constrained: bool) -> bool:
    return True


def theory_limit(name: FigureName) -> Limit | None:
    return None


ROUNDOFF_QUANTITY = 1e-9
"""An analytic quantity whose largest value over the states is below this × its physical scale is zero up to
round-off (a body nothing pushes: its acceleration is 1e-17 m/s²); a figure relative to it would divide round-off by
round-off, so it is taken relative to the physical scale instead."""


def _scale(expected: np.ndarray, *, vector: bool = False, physical: float = 0.0) -> float:
    """What a relative figure divides by: the largest entry (vector norm) of the analytic quantity; its physical
    scale where the quantity is zero up to round-off (:data:`ROUNDOFF_QUANTITY`); 1 where it is 0 and no scale is
    given (the figure is then absolute)."""
    if not expected.size:
        return 1.0
    largest = float(np.max(np.linalg.norm(expected, axis=-1) if vector else np.abs(expected)))
    if physical > 0 and largest < ROUNDOFF_QUANTITY * physical:
        return physical
    return largest if largest > 0 else 1.0


def compare(sample: Sample) -> tuple[list[Deviation], dict[str, str], dict[str, str]]:
    """This family's figures at the sampled states: MuJoCo's side against the analytic values at (q, q̇)."""
    model, probe, ref, q, qd = sample.model, sample.probe, sample.reference, sample.q, sample.qd
    got, got_lam, got_block_gen = sample.got, sample.force, sample.block_gen
    dyn = sample.dynamics
    qdd, lam = sample.accelerations
    mass = dyn.mass_matrix(q)
    forcing = dyn.forcing(q, qd)
    gen = np.einsum("nmk,nm->nk", dyn.jacobian(q), lam)  # Jᵀλ over every row
    pts = dyn.points(q)
    acc = dyn.point_accelerations(q, qd, qdd)
    kinetic = 0.5 * np.einsum("ni,nij,nj->n", qd, mass, qd)
    mapped, coordinates = sample.mapped, sample.coordinates
    n = len(q)
    length = ref.scales.length

    def relative(name: FigureName, got_: list, expected: np.ndarray, description: str, *,
                 vector: bool = False, physical: float = 0.0) -> Deviation:
        return Deviation(name, np.reshape(got_, expected.shape) - expected, "vector" if vector else "scalar", "1",
                         description, scale=_scale(expected, vector=vector, physical=physical))

    sc = ref.scales  # the physical scales of each relative figure: g = L (E/p)², ω₀² = (E/p)²
    rate = (sc.energy / sc.momentum) ** 2 if sc.momentum > 0 else 0.0  # 0 (no floor) where no gravity sets a scale
    physical = {"kinetic_energy": sc.energy, "point_acceleration": sc.length * rate,
                "mass_matrix": sc.energy / rate if rate > 0 else 0.0,
                "forcing": min(sc.force, sc.energy), "qacc": min(rate, sc.length * rate),
                "generalized_force": min(sc.force, sc.energy)}

    sites = any(point_source(model, p).kind == "site" for p in dyn.point_names)
    where, what = ("point position (site or body com)", "site or body com") if sites else ("body position", "body com")
    out = [
        Deviation(FigureName.instant("kinematics"), np.array(got["pts"]) - pts, "scalar", "m",
                  f"max |MuJoCo {where} − analytic point| over {n} states", size=length),
        relative(FigureName.instant("kinetic_energy"), got["kinetic"], kinetic,
                 "max |½ qvelᵀ M_mj qvel − ½ q̇ᵀ M q̇| / max ½ q̇ᵀ M q̇", physical=physical["kinetic_energy"]),
        relative(FigureName.instant("point_acceleration"), got["acc"], acc,
                 f"max |J qacc + J̇ qvel − ẍ| / max |ẍ| over named points (world acceleration of the {what})",
                 vector=True, physical=physical["point_acceleration"]),
    ]
    d = "B" if mapped else "D"  # velocity_map wins where a binding gives both (bindings.velocity_map)
    if coordinates:
        out += [
            relative(FigureName.instant("mass_matrix"), got["mass"], mass,
                     f"max |{d}ᵀ M_mj {d} − M(q)| / max |M(q)|", physical=physical["mass_matrix"]),
            relative(FigureName.instant("forcing"), got["forcing"], forcing,
                     "max |Bᵀ(qfrc_passive + qfrc_actuator − qfrc_bias − M_mj Ḃq̇) − F| / max |F|" if mapped else
                     "max |Dᵀ(qfrc_passive + qfrc_actuator − qfrc_bias) − F| / max |F|", physical=physical["forcing"]),
            relative(FigureName.instant("qacc"), got["qacc"], qdd,
                     "max |B⁺(qacc − Ḃq̇) − q̈| / max |q̈| (B⁺: pull-back, kinetic-energy weighted where nv > n)"
                     if mapped else "max |qacc − q̈| / max |q̈|", physical=physical["qacc"]),
        ]
    if probe.constraints and coordinates:
        out.append(relative(FigureName.instant("generalized_force"), got["gen"], gen,
                            f"max |{d}ᵀ qfrc_constraint − Jᵀλ| / max |Jᵀλ|", physical=physical["generalized_force"]))
    jac = dyn.jacobian(q)
    force_scale = ref.scales.force
    unmeasured: dict[str, str] = {}
    for c, rows in dyn.blocks.items():
        if c not in got_lam:
            continue
        redundant = not_unique(dyn, sample.solved.unique, c)
        if redundant:  # any split of the force among dependent rows is right: only the total Jᵀλ is compared
            for name in (FigureName.instant("force", c), FigureName.instant("generalized_force", c)):
                unmeasured[str(name)] = redundant
            continue
        size = rows.stop - rows.start
        expected = lam[:, rows]
        out.append(Deviation(FigureName.instant("force", c), np.reshape(got_lam[c], expected.shape) - expected,
                             "scalar", "1",
                             f"max |efc_force − λ_{c}|{' over its ' + str(size) + ' rows' if size > 1 else ''} / "
                             f"force scale ({force_scale:.4g} N)", scale=force_scale,
                             size=max(float(np.max(np.abs(expected), initial=0.0)) / force_scale, 1.0)))
        if got_block_gen[c]:
            block_gen = np.einsum("nmk,nm->nk", jac[:, rows], lam[:, rows])
            out.append(relative(FigureName.instant("generalized_force", c), got_block_gen[c], block_gen,
                                f"max |{d}ᵀ J_mjᵀ efc_force − Jᵀλ| over the rows of {c!r} / max |Jᵀλ|"))
    return out, unmeasured, {}


def not_unique(dyn: Dynamics, unique: np.ndarray, constraint: str) -> str:
    """Why ``constraint``'s multipliers are not compared ('' where they are): some of its rows are redundant with
    other rows at some of the states (``unique``, (states, rows), from :meth:`Dynamics.constrained`), so their
    multipliers are not unique and any engine's split of the force among them is right; the generalized
    constraint force Jᵀλ of all rows together is unique and is compared (``generalized_force``)."""
    rows = dyn.blocks[constraint]
    unique = np.asarray(unique)[..., rows]
    if np.all(unique):
        return ""
    labels = [label for label, ok in zip(dyn.row_labels[rows], np.all(unique.reshape(-1, unique.shape[-1]), axis=0),
                                         strict=True) if not ok]
    return (f"not unique: row(s) {', '.join(labels)} of {constraint!r} are redundant with other constraint rows "
            f"(the constraint Jacobian loses rank there: a closed loop's dependent rows, or a singular configuration), "
            f"so any split of their force is right; the total generalized constraint force Jᵀλ is compared instead")


def engine_findings(model: mujoco.MjModel, probe: Probe, ref: Reference, *, count: int = DEFAULT_SAMPLES
                    ) -> list[Finding]:
    """Where this layer corrects an engine function to take its measurement, how far the engine's own
    answer is off, at the same states (:class:`~harness.core.findings.Finding`): ``mj_jacDot`` on a
    MuJoCo that misses a term (:func:`harness.engine.compat.jac_dot_missing`), as the error it alone
    would make in the named points' world acceleration."""
    dyn = ref.dynamics
    q, qd = sample_states(ref, count)
    qdd, _ = dyn.accelerations(q, qd)
    expected = np.linalg.norm(dyn.point_accelerations(q, qd, qdd), axis=-1)
    data = mujoco.MjData(model)
    worst = 0.0
    for i in range(len(q)):
        mujoco.mj_resetData(model, data)
        probe.binding.set_state(model, data, q[i], qd[i])
        mujoco.mj_forward(model, data)
        for p in dyn.point_names:
            source = point_source(model, p)
            missing = jac_dot_missing(model, data, source.position(data), source.body)
            if missing is None:
                return []
            worst = max(worst, float(np.linalg.norm(missing @ data.qvel)))
    scale = float(np.max(expected)) if expected.size and np.max(expected) > 0 else 1.0
    if worst <= 0:
        return []
    return [Finding("mj_jacDot", worst / scale, "1",
                    "max |J̇ qvel| that mj_jacDot leaves out / max |ẍ| of the named points at the sampled states "
                    "(the error it alone would make in their world acceleration; the harness adds the term)",
                    JAC_DOT_DEFECT)]


def measure(bench: Bench) -> Measured:
    measured = bench.measured_at_states(owns)  # first: the evaluation checks the model has what the probe reads
    found = tuple(bench.timed(NAME, lambda: engine_findings(bench.instant_model, bench.probe, bench.reference)))
    return dataclasses.replace(measured, findings=found)
