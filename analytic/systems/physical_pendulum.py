r"""Physical (compound) pendulum: a rigid link with a full inertia tensor on one horizontal hinge.

The hinge runs through the origin (the pivot) along the horizontal diagonal
n = (1, −1, 0)/√2; the link swings in the vertical plane spanned by
e = (1, 1, 0)/√2 and z. θ is the link's rotation about n from the model's
authored pose (MuJoCo's qpos, qpos0 = 0), right-handed, so positive towards +e.
Seen along the hinge (n pointing at the reader)::

          z ^
            |
      pivot o-----> e = (1, 1, 0)/√2     (n = (1, −1, 0)/√2 out of the page)
            |\
            | \   c(θ) = R(θ) c₀: the centre of mass, d⊥ from the axis
            |θ ●
            |   \
            |    ✕ tip        ✕ side: a body point off the swing plane
           −z

    R(θ) = R_z(−π/4) R_x(θ) R_z(π/4)      (rotation by θ about n: e → cos θ e + sin θ ẑ)

The link is a :class:`analytic.rigid.RigidBody` whose body frame is the world
frame at θ = 0 (any body-fixed frame will do; the model's own body frame is not
turned either): its centre of mass is at c₀ = (cx, cy, cz) from the pivot at
θ = 0 and its inertia about the centre of mass, in those axes, is the full
symmetric tensor I_c (Ixx … Iyz, products included). Then (König; the
parallel-axis term is ½ m |ċ|²)

    T = ½ I_O θ̇²,   I_O = nᵀ I_c n + m d⊥² = ½(Ixx + Iyy) − Ixy + m ((cx + cy)²/2 + cz²),
    V = m g z_c = m g (u sin θ + cz cos θ),   u = e·c₀ = (cx + cy)/√2,   d⊥² = u² + cz²

so only the inertia about the hinge, in which the product Ixy enters, and the
distance d⊥ of the centre of mass from the axis enter the motion; its offset
(cx − cy)/√2 along the axis does not. The compiled model holds the tensor as
MuJoCo diagonalised it (``body_iquat``, ``body_inertia``); params_from_model
turns it back, and tests/test_physical_pendulum.py checks that against the
authored ``fullinertia``, independently.

Closed forms (with the shipped pose, u = 0 and cz = −d⊥: the centre of mass
hangs below the pivot at θ = 0, the stable equilibrium): small oscillations
have the period 2π √(I_O / (m g d⊥)); from rest at θ₀ the period is
4 √(I_O / (m g d⊥)) K(k²), k = sin(θ₀/2) (K the complete elliptic integral of
the first kind; ``scipy.special.ellipk`` takes m = k²).

The hinge is the system's, not a parameter (as the seed pendulums' axes are):
a model whose hinge is mounted otherwise is a fault its points show.

Named points: ``link`` is the centre of mass (MuJoCo: body ``link``'s xipos);
``tip`` and ``side`` are body-fixed points at (tx, ty, tz) and (sx, sy, sz)
from the centre of mass at θ = 0 (MuJoCo: the sites of those names), through
which the link's orientation is compared. No constraints; θ is minimal.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import mujoco
import numpy as np

from analytic.systems import Motion, Parameters, Scales

if TYPE_CHECKING:
    from analytic.lagrangian import LagrangianSystem

__all__ = ["MOTION", "PARAMETERS", "SIGNED_PARAMETERS", "build", "params_from_model", "scales"]

PARAMETERS = "m g cx cy cz Ixx Iyy Izz Ixy Ixz Iyz tx ty tz sx sy sz"
SIGNED_PARAMETERS = "cx cy cz Ixy Ixz Iyz tx ty tz sx sy sz"

MOTION = Motion(
    description="physical pendulum: a rigid link with a full inertia tensor (products, body frame offset "
                "and turned) on one hinge, released from 1.2 rad: large-amplitude period",
    q0={"theta": 1.2},
    qd0={"theta": 0.0},
    horizon=3.0,  # two periods (1.429 s each)
)

LINK = "link"
SITES = {"tip": ("tx", "ty", "tz"), "side": ("sx", "sy", "sz")}

def build(p: Parameters) -> LagrangianSystem:
    import sympy as sp  # lazy: sympy, only to derive

    from analytic.lagrangian import LagrangianSystem, coordinates  # lazy: loads sympy
    from analytic.rigid import RigidBody, axis_rotation  # lazy: loads sympy

    (theta,), (theta_d,) = coordinates("theta")
    turn = axis_rotation("z", sp.pi / 4)  # takes n = (1, −1, 0)/√2 to x̂
    rotation = turn.T * axis_rotation("x", theta) * turn  # by θ about n
    com = rotation * sp.Matrix([p.cx, p.cy, p.cz])
    inertia = sp.Matrix([[p.Ixx, p.Ixy, p.Ixz], [p.Ixy, p.Iyy, p.Iyz], [p.Ixz, p.Iyz, p.Izz]])
    link = RigidBody(mass=p.m, inertia=inertia, com=com, rotation=rotation)
    points = {LINK: tuple(com)} | {site: link.point([getattr(p, k) for k in keys]) for site, keys in SITES.items()}
    names = PARAMETERS.split()
    return LagrangianSystem(
        name="physical_pendulum",
        q=(theta,),
        qd=(theta_d,),
        kinetic=sp.simplify(link.kinetic((theta,), (theta_d,))),
        potential=p.m * p.g * com[2],
        params=tuple(getattr(p, k) for k in names),
        points=points,
        bodies={LINK: link},
    )


def params_from_model(model) -> dict[str, float]:
    """Every parameter from the compiled model at its authored pose (qpos0): m the link's mass; g
    from gravity; c₀ the centre of mass (``xipos``, from the pivot at the origin); I_c in world axes,
    ``ximat`` diag(``body_inertia``) ``ximat``ᵀ (MuJoCo's diagonalised tensor turned back); the
    sites' offsets from the centre of mass. ValueError for gravity off −z.

    The hinge itself is the system's, not a parameter: −y through the origin, as the seed pendulums'
    (a model whose hinge is mounted otherwise is a fault its points show, like their tilted axes)."""
    gravity = np.asarray(model.opt.gravity, dtype=float)
    if np.any(gravity[:2] != 0) or not gravity[2] < 0:
        raise ValueError(f"gravity must point along −z, got {gravity.tolist()}")
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    bid = model.body(LINK).id
    frame = data.ximat[bid].reshape(3, 3)
    inertia = frame @ np.diag(model.body_inertia[bid]) @ frame.T
    com = data.xipos[bid]  # from the pivot, the origin
    out = {"m": float(model.body_mass[bid]), "g": float(-gravity[2]),
           "cx": com[0], "cy": com[1], "cz": com[2],
           "Ixx": inertia[0, 0], "Iyy": inertia[1, 1], "Izz": inertia[2, 2],
           "Ixy": inertia[0, 1], "Ixz": inertia[0, 2], "Iyz": inertia[1, 2]}
    for site, keys in SITES.items():
        offset = data.site_xpos[model.site(site).id] - data.xipos[bid]
        out |= dict(zip(keys, offset, strict=True))
    return {k: float(v) for k, v in out.items()}


def hinge_inertia(params: dict[str, float]) -> float:
    """I_O = nᵀ I_c n + m d⊥² about the hinge: ½(Ixx + Iyy) − Ixy + m ((cx + cy)²/2 + cz²)."""
    return (0.5 * (params["Ixx"] + params["Iyy"]) - params["Ixy"]
            + params["m"] * (0.5 * (params["cx"] + params["cy"]) ** 2 + params["cz"] ** 2))


def scales(params: dict[str, float]) -> Scales:
    """Length: the tip's distance from the pivot (the largest the motion sweeps); force m g, energy
    m g L, momentum m √(g L) L."""
    tip = np.array([params["cx"] + params["tx"], params["cy"] + params["ty"], params["cz"] + params["tz"]])
    return Scales.gravity(mass=params["m"], g=params["g"], length=float(np.linalg.norm(tip)))
