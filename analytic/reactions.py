"""Reaction forces and moments at any attachment, from a solution: Newton–Euler of the subtree.

Cut a mechanism at an attachment (a joint, a weld, a pivot): the bodies on the
far side — the *subtree* — move as the forces on them dictate, so the wrench
the attachment transmits follows from their motion alone (no system-specific
formula)::

          parent                          F, τ_P : the wrench exerted BY the parent
            │  attachment at P                     ON the subtree, through the attachment
        ────┼────  cut
          subtree: bodies i, masses m_i, centres c_i, angular momenta L_i about c_i
                   external loads f_k at p_k (a string, a contact: forces that do
                   not pass through the attachment)

    F   = Σ_i m_i (c̈_i − g)                                 − Σ_k f_k
    τ_P = Σ_i [ (c_i − P) × m_i (c̈_i − g) + dL_i/dt ]       − Σ_k [(p_k − P) × f_k + μ_k]

with g the gravity vector (0, 0, −g) and μ_k a load's free moment (a couple,
the same about every point: a weld's orientation rows exert one besides its
force). For a point bob alone, F = m(a − g):
the pull of the rod. A body at rest feels F = −m g (its weight carried up).

**Sign convention** (pinned by ``tests/test_reactions.py``): F and τ are exerted
*by the parent on the subtree*, in world coordinates, τ about the point P. This
is MuJoCo's: its ``force`` and ``torque`` sensors read "the interaction force
between the body where the site is and its parent body, pointing from the child
towards the parent" (XMLreference, ``sensor/force``), which is ``cfrc_int`` of
the site's body (``mj_rnePostConstraint``) — for a hanging bob at rest, +m g
upward; they give it in the site's frame, the harness rotates it to the world.

The **proper acceleration** a − g of a point is what an ideal accelerometer
reads (MuJoCo's ``accelerometer``: "linear acceleration of the site, including
gravity"): +g upward for a point at rest, 0 in free fall.

The quantities per body (c, c̈, dL/dt, m) come from the system's ``bodies``
(:class:`analytic.rigid.RigidBody`), lambdified in :class:`analytic.dynamics.Dynamics`;
which bodies make a subtree, where P is and which loads act are the caller's
(the harness takes them from the MuJoCo model's tree and the case's wiring).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from analytic.dynamics import Array, Dynamics

__all__ = ["Load", "proper_acceleration", "subtree_wrench"]


@dataclass(frozen=True)
class Load:
    """An external force on the subtree, at the world point ``at``, and a free ``moment`` besides (a
    couple, e.g. a weld's; None: none): all world, (..., 3)."""

    force: Array
    at: Array
    moment: Array | None = None


def proper_acceleration(acceleration: Array, gravity: Array) -> Array:
    """a − g: what an accelerometer at a point of world acceleration ``acceleration`` reads (world frame)."""
    return np.asarray(acceleration, dtype=float) - np.asarray(gravity, dtype=float)


def subtree_wrench(dynamics: Dynamics, bodies: Sequence[str], q: Array, qd: Array, qdd: Array, *,
                   gravity: Array, about: Array, loads: Sequence[Load] = ()) -> tuple[Array, Array]:
    """(F, τ): the force and the moment about ``about`` (world, (..., 3)) that the parent exerts on the
    subtree made of ``bodies`` (names in ``dynamics.body_names``) at the state (q, q̇) with accelerations
    q̈ (the solution's own), less the external ``loads``; see the module docstring for the convention.
    Shapes (..., 3) each."""
    unknown = sorted(set(bodies) - set(dynamics.body_names))
    if unknown:
        raise ValueError(f"bodies {unknown} are not bodies of the system; its bodies: {list(dynamics.body_names)}")
    idx = [dynamics.body_names.index(b) for b in bodies]
    mass = dynamics.body_masses()[idx]
    com = dynamics.body_coms(q)[..., idx, :]
    inertial = mass[:, None] * proper_acceleration(dynamics.body_accelerations(q, qd, qdd)[..., idx, :], gravity)
    spin = dynamics.body_momentum_rates(q, qd, qdd)[..., idx, :]
    about = np.asarray(about, dtype=float)[..., None, :]
    force = inertial.sum(axis=-2)
    torque = (np.cross(com - about, inertial) + spin).sum(axis=-2)
    for load in loads:
        f = np.asarray(load.force, dtype=float)
        force = force - f
        torque = torque - np.cross(np.asarray(load.at, dtype=float) - about[..., 0, :], f)
        if load.moment is not None:
            torque = torque - np.asarray(load.moment, dtype=float)
    return force, torque
