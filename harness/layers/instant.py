"""Layer 2: instantaneous dynamics at sampled states, no time integration.

At each state the analytic M(q), F(q, q̇), q̈ and λ are compared with MuJoCo's
``mj_fullM``, ``qfrc_passive − qfrc_bias``, ``qacc`` and the equality's
``efc_force``. A fault shows up here before any trajectory is run, and the
figure that fails says where it is (inertia, forces, or the constraint).

A constraint may be a block of rows (a ``connect`` equality has three): its
``force.NAME`` figure compares every row with its multiplier (the worst row
decides), and a block of several rows also gets ``generalized_force.NAME``,
its own Jᵀλ against D ᵀ J_mjᵀ efc_force over its rows — the force on the
coordinates, which does not depend on how the rows are scaled or ordered.

Those four go through the binding's constant dof matrix D; a binding without
one (a ball joint) gets only the observable figures, which every case has:
the kinetic energy ½ qvelᵀ M_mj qvel vs ½ q̇ᵀ M q̇ (inertia along the sampled
velocities) and the world acceleration of every named point,
J_mj qacc + J̇_mj qvel vs (∂x/∂q) q̈ + q̇ᵀ(∂²x/∂q²)q̇ (inertia and forces together).

States are taken on the constraint manifold: along the reference, each also
with its velocity rescaled (which keeps J q̇ = 0 for homogeneous rows), so
both slow and fast states are covered.
"""

from __future__ import annotations

import mujoco
import numpy as np

from harness.core.figures import Figure, FigureName
from harness.engine.compat import full_mass_matrix, jac_dot
from harness.engine.constraints import equality_block, equality_jacobian
from harness.engine.probe import Probe
from harness.reference.solutions import Reference

DEFAULT_SAMPLES = 24


def sample_states(ref: Reference, count: int = DEFAULT_SAMPLES, seed: int = 0
                  ) -> tuple[np.ndarray, np.ndarray]:
    """``count`` states (q, q̇) on the manifold, deterministic for a seed."""
    if count < 2:
        raise ValueError(f"count must be >= 2, got {count}")
    half = count // 2
    t = np.linspace(0.0, ref.solution.t_end, half)
    q, qd = ref.solution.state(t)
    scale = np.random.default_rng(seed).uniform(-2.0, 2.0, size=(count - half, 1))
    idx = np.arange(count - half) % half
    return np.vstack([q, q[idx]]), np.vstack([qd, qd[idx] * scale])


def _relative(err: np.ndarray, ref: np.ndarray) -> float:
    denom = float(np.max(np.abs(ref))) if ref.size else 0.0
    return float(np.max(np.abs(err))) / denom if denom > 0 else float(np.max(np.abs(err), initial=0.0))


def _norms(vectors: np.ndarray) -> np.ndarray:
    return np.linalg.norm(vectors, axis=-1)


def point_acceleration(model: mujoco.MjModel, data: mujoco.MjData, body: str) -> np.ndarray:
    """World linear acceleration of a body's centre of mass after ``mj_forward``:
    J qacc + J̇ qvel, with J, J̇ from ``mj_jacBodyCom`` and ``mj_jacDot`` at ``xipos``."""
    bid = model.body(body).id
    jacp = np.zeros((3, model.nv))
    mujoco.mj_jacBodyCom(model, data, jacp, None, bid)
    jacp_dot = jac_dot(model, data, data.xipos[bid], bid)  # mj_jacDot, fixed on MuJoCo 3.3.0
    return jacp @ data.qacc + jacp_dot @ data.qvel


def instantaneous_figures(model: mujoco.MjModel, probe: Probe, ref: Reference,
                          *, count: int = DEFAULT_SAMPLES) -> list[Figure]:
    """Compare MuJoCo's instantaneous dynamics with the analytic ones at sampled states."""
    probe.validate(model)
    dyn = ref.dynamics
    q, qd = sample_states(ref, count)
    qdd, lam = dyn.accelerations(q, qd)
    mass = dyn.mass_matrix(q)
    forcing = dyn.forcing(q, qd)
    gen = np.einsum("nmk,nm->nk", dyn.jacobian(q), lam)  # Jᵀλ over every row
    pts = dyn.points(q)
    acc = dyn.point_accelerations(q, qd, qdd)
    kinetic = 0.5 * np.einsum("ni,nij,nj->n", qd, mass, qd)
    dof = probe.binding.dof_matrix(model)
    data = mujoco.MjData(model)
    got = {k: [] for k in ("mass", "forcing", "qacc", "gen", "pts", "acc", "kinetic")}
    got_lam = {c: [] for c in probe.constraints}
    got_block_gen = {c: [] for c in probe.constraints}
    for i in range(len(q)):
        mujoco.mj_resetData(model, data)
        probe.binding.set_state(model, data, q[i], qd[i])
        mujoco.mj_forward(model, data)
        full = full_mass_matrix(model, data)
        got["kinetic"].append(0.5 * data.qvel @ full @ data.qvel)
        got["pts"].append([data.xipos[model.body(p).id].copy() for p in dyn.point_names])
        got["acc"].append([point_acceleration(model, data, p) for p in dyn.point_names])
        if dof is not None:
            got["mass"].append(dof.T @ full @ dof)
            got["forcing"].append(dof.T @ (data.qfrc_passive - data.qfrc_bias))
            got["qacc"].append(np.linalg.lstsq(dof, data.qacc, rcond=None)[0])
            got["gen"].append(dof.T @ data.qfrc_constraint)
        for c in probe.constraints:
            force = equality_block(model, data, c)[0]
            got_lam[c].append(force)
            if dof is not None and force.size > 1:
                got_block_gen[c].append(dof.T @ (equality_jacobian(model, data, c).T @ force))
    n = len(q)
    figs = [
        Figure(FigureName.instant("kinematics"), float(np.max(np.abs(np.array(got["pts"]) - pts))), "m",
               f"max |MuJoCo body position − analytic point| over {n} states"),
        Figure(FigureName.instant("kinetic_energy"), _relative(np.array(got["kinetic"]) - kinetic, kinetic), "1",
               "max |½ qvelᵀ M_mj qvel − ½ q̇ᵀ M q̇| / max ½ q̇ᵀ M q̇"),
        Figure(FigureName.instant("point_acceleration"),
               _relative(_norms(np.reshape(got["acc"], acc.shape) - acc), _norms(acc)), "1",
               "max |J qacc + J̇ qvel − ẍ| / max |ẍ| over named points (world acceleration of the body com)"),
    ]
    if dof is not None:
        figs += [
            Figure(FigureName.instant("mass_matrix"), _relative(np.array(got["mass"]) - mass, mass), "1",
                   "max |Dᵀ M_mj D − M(q)| / max |M(q)|"),
            Figure(FigureName.instant("forcing"), _relative(np.array(got["forcing"]) - forcing, forcing), "1",
                   "max |Dᵀ(qfrc_passive − qfrc_bias) − F| / max |F|"),
            Figure(FigureName.instant("qacc"), _relative(np.array(got["qacc"]) - qdd, qdd), "1",
                   "max |qacc − q̈| / max |q̈|"),
        ]
    if probe.constraints and dof is not None:
        figs.append(Figure(FigureName.instant("generalized_force"), _relative(np.array(got["gen"]) - gen, gen), "1",
                           "max |Dᵀ qfrc_constraint − Jᵀλ| / max |Jᵀλ|"))
    jac = dyn.jacobian(q)
    for c, rows in dyn.blocks.items():
        if c not in got_lam:
            continue
        err = float(np.max(np.abs(np.array(got_lam[c]) - lam[:, rows]))) / ref.scales.force
        size = rows.stop - rows.start
        figs.append(Figure(FigureName.instant("force", c), err, "1",
                           f"max |efc_force − λ_{c}|{' over its ' + str(size) + ' rows' if size > 1 else ''} / force "
                           f"scale ({ref.scales.force:.4g} N)"))
        if got_block_gen[c]:
            block_gen = np.einsum("nmk,nm->nk", jac[:, rows], lam[:, rows])
            figs.append(Figure(FigureName.instant("generalized_force", c),
                               _relative(np.array(got_block_gen[c]) - block_gen, block_gen), "1",
                               f"max |Dᵀ J_mjᵀ efc_force − Jᵀλ| over the rows of {c!r} / max |Jᵀλ|"))
    return figs
