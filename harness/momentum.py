"""MuJoCo-side angular momentum, from MuJoCo's own state (never via analytic coordinates).

The conserved momentum of a cyclic azimuth (``p_phi`` of the spherical
pendulum) is the component along the symmetry axis of the angular momentum
about a fixed point o of the subtree rooted at a body:

    L_o = Σ_b  R_b I_b R_bᵀ ω_b + m_b (x_b − o) × v_b

over the subtree's bodies b, with I_b the principal inertia (``body_inertia``)
in the inertia frame R_b (``ximat``), x_b the centre of mass (``xipos``), and
ω_b, v_b its angular and linear velocity from the com-based velocity
``cvel`` = (ω, velocity of the point at ``subtree_com`` of b's root):
v_b = cvel_lin + ω × (x_b − subtree_com[root]). It includes the bodies' own
spin, so it is the quantity MuJoCo's dynamics conserves when gravity is along
the axis; it is what ``mj_subtreeVel`` assembles (subtree_angmom plus the
transport term), computed from fields ``mj_forward`` leaves, over a whole
run at once (pinned against ``mj_subtreeVel`` in tests/test_spherical_pendulum.py).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import mujoco
import numpy as np

from harness.readings import Reading


def subtree(model: mujoco.MjModel, body: int) -> list[int]:
    """``body`` and every body below it."""
    inside = [body]
    for b in range(body + 1, model.nbody):  # parents precede children in MuJoCo's body order
        if int(model.body_parentid[b]) in inside:
            inside.append(b)
    return inside


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise a × b of (N, 3) arrays (np.cross's own overhead dominates on small arrays)."""
    return np.stack([a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1],
                     a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2],
                     a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]], axis=1)


def axial_angular_momentum(*, body: str, site: str, axis: Sequence[float] = (0.0, 0.0, 1.0)) -> Reading:
    """A reading of axis · L about ``site`` of the subtree rooted at ``body`` (kg m²/s).

    ``axis`` is a world direction (normalised here).
    """
    unit = np.asarray(axis, dtype=float)
    if unit.shape != (3,) or not np.linalg.norm(unit) > 0:
        raise ValueError(f"axis must be a non-zero 3-vector, got {axis!r}")
    unit = unit / np.linalg.norm(unit)

    def evaluate(model: mujoco.MjModel, rec: Mapping[str, np.ndarray]) -> np.ndarray:
        origin = rec["site_xpos"][:, model.site(site).id]
        total = np.zeros((len(origin), 3))
        for b in subtree(model, model.body(body).id):
            omega = rec["cvel"][:, b, :3]
            centre = rec["xipos"][:, b]
            rot = rec["ximat"][:, b].reshape(-1, 3, 3)
            velocity = rec["cvel"][:, b, 3:] + _cross(omega, centre - rec["subtree_com"][:, model.body_rootid[b]])
            local = np.einsum("nji,nj->ni", rot, omega) * model.body_inertia[b]  # I_b R_bᵀ ω
            total += np.einsum("nij,nj->ni", rot, local) + model.body_mass[b] * _cross(centre - origin, velocity)
        return total @ unit

    return Reading(fields=("site_xpos", "cvel", "xipos", "ximat", "subtree_com"), evaluate=evaluate,
                   description=f"axis {unit.tolist()} · angular momentum of subtree {body!r} about site "
                               f"{site!r} (kg m²/s)")
