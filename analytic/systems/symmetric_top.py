r"""Heavy symmetric top (Lagrange top): a rigid body with I₁ = I₂ ≠ I₃ on a fixed pivot, under gravity.

The pivot is the world origin. The body's own z axis (the unit vector e₃) is
its symmetry axis; the centre of mass sits on it at distance l from the pivot,
ABOVE the pivot when θ < π/2 (a top standing on its point, the classic case).
The body is turned by the Euler angles (z-x-z, ``analytic.rigid.euler_zxz``)::

    R(φ, θ, ψ) = R_z(φ) R_x(θ) R_z(ψ)          (body → world)

    side view (the plane of e₃ and world z):        seen from above:

          z ^      e₃  (symmetry axis)                   y ^
            |     /                                        |
            |θ   ● centre of mass, at l e₃                 |    line of nodes
            |   /                                          |   /  n = R_z(φ) x̂
            |  /                                           |  /
            | /                                            | / φ
     pivot  o --------> horizontal                  pivot  o ---------> x
     (world origin; the top spins about e₃ by ψ)

    e₃ = R ẑ = (sin θ sin φ,  −sin θ cos φ,  cos θ)
    centre of mass  c = l e₃

The axis leans away from the vertical perpendicular to the line of nodes, towards
the azimuth φ − 90° (at φ = 0 the tip leans towards −y); the precession rate φ̇ is
the rate at which the tip's horizontal projection turns about world z.

Coordinates q = (phi, theta, psi):

    phi    precession: about world +z, from +x towards +y (turns the line of nodes n = R_z(φ) x̂);
    theta  nutation: the tilt of e₃ from world +z, about n (θ = 0: upright; θ < π/2: centre of mass
           above the pivot);
    psi    spin: about the body's own e₃.

The Euler angles are singular at sin θ = 0 (φ and ψ turn about the same
axis); the case's motion keeps θ within [0.96, 1.20] rad.

Inertia: I₁ = I₂ (``I1``) and I₃ (``I3``) are the principal moments about the
CENTRE OF MASS, the MJCF's ``diaginertia="I1 I1 I3"`` at ``pos="0 0 l"``. The
kinetic energy is built by ``analytic.rigid.RigidBody`` from the inertia tensor
and the body's angular velocity ω_b ([ω_b]× = Rᵀ Ṙ), nothing specific to a top:

    T = ½ m |ċ|² + ½ ω_bᵀ diag(I₁, I₁, I₃) ω_b
      = ½ I₁' (θ̇² + φ̇² sin²θ) + ½ I₃ (ψ̇ + φ̇ cos θ)²,   I₁' = I₁ + m l² (about the pivot)
    V = m g l cos θ                                      (zero at the pivot's height)

φ and ψ are absent from L, so (signs: counter-clockwise seen from +z, resp. from the tip of e₃)

    p_psi = I₃ ω₃,  ω₃ = ψ̇ + φ̇ cos θ          the angular momentum about the pivot along e₃
    p_phi = I₁' sin²θ φ̇ + I₃ ω₃ cos θ           the angular momentum about the pivot along world z

and the energy are conserved. MuJoCo holds the orientation as a ball joint's
quaternion; its side of p_φ and p_ψ is read from its own state (the angular
momentum of the body about the pivot, on world z and on the body's z;
``mjcf/symmetric_top.py``), never through Euler angles.

Nutation (Goldstein §5.7): with u = cos θ, I₁' the moment about the pivot and

    α = (2E − I₃ ω₃²)/I₁',   β = 2 m g l / I₁',   a = p_ψ / I₁',   b = p_φ / I₁'

energy, p_φ and p_ψ give u̇² = f(u) = (1 − u²)(α − β u) − (b − a u)²: θ turns back
where f has its two roots in [−1, 1], and φ̇ = (b − a u)/(1 − u²). For a steady
precession at θ = θ₀ (θ̇ = 0 for ever) the θ equation leaves the quadratic

    I₁' cos θ₀ φ̇² − I₃ ω₃ φ̇ + m g l = 0

with a slow and a fast root (:func:`steady_precession_rates`). Both are closed
forms typed by hand, checked against the sympy-derived reference and against
MuJoCo's symmetry axis in tests/test_symmetric_top.py.

Observables (world positions compared with MuJoCo): ``top`` the centre of
mass (the body's ``xipos``); ``tip`` the end of the axle, 2.5 l along e₃ from the
pivot; ``rim`` a point of the disc's rim (radius 2.5 l), 2.5 l along the body's x
from the centre of mass — it turns with ψ, so it is where MuJoCo's spin is observed.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from analytic.systems import Motion, Parameters, Scales

if TYPE_CHECKING:
    from analytic.lagrangian import LagrangianSystem

__all__ = ["MOTION", "PARAMETERS", "build", "params_from_model", "scales"]

PARAMETERS = "m g l I1 I3"

MOTION = Motion(
    description="heavy symmetric top on a ball joint: spinning, precessing and nutating (θ between its two "
                "turning points), p_phi and p_psi conserved",
    # θ nutates between its turning points 0.960 and 1.196 rad (the cubic's roots), 6 times in 1.5 s
    q0={"phi": 0.0, "theta": 1.0, "psi": 0.0},
    qd0={"phi": 2.0, "theta": 2.0, "psi": 20.0},
    horizon=1.5,
)

BODY = "top"
TIP = "tip"
RIM = "rim"

# Body-frame offsets from the PIVOT of the two observed body points, in units of l (the MJCF's sites
# must be there; params_from_model checks it).
SIZE = 2.5
"""The top's size in units of l: its axle's length and its disc's radius, how far its observed points
(``tip``, ``rim``) are from the pivot."""
SITE_OFFSETS = {TIP: (0.0, 0.0, SIZE), RIM: (SIZE, 0.0, 1.0)}


def build(p: Parameters) -> LagrangianSystem:
    import sympy as sp  # lazy: sympy, only to derive

    from analytic.lagrangian import LagrangianSystem, coordinates  # lazy: loads sympy
    from analytic.rigid import RigidBody, euler_zxz  # lazy: loads sympy

    m, g, l, i1, i3 = p.m, p.g, p.l, p.I1, p.I3
    q, qd = coordinates("phi theta psi")
    phi, theta, psi = q
    rotation = euler_zxz(phi, theta, psi)
    top = RigidBody(mass=m, inertia=sp.diag(i1, i1, i3), com=rotation * sp.Matrix([0, 0, l]), rotation=rotation)
    # simplified so that φ and ψ are structurally absent from T (Derivation.cyclic tests ∂L/∂q == 0)
    kinetic = sp.simplify(sp.expand(sp.trigsimp(top.kinetic(q, qd))))
    points = {BODY: tuple(top.com)}
    for name, (x, y, z) in SITE_OFFSETS.items():
        points[name] = top.point((x * l, y * l, z * l - l))
    return LagrangianSystem(
        name="symmetric_top",
        q=q,
        qd=qd,
        kinetic=kinetic,
        potential=m * g * top.com[2],
        params=(m, g, l, i1, i3),
        points=points,
        bodies={BODY: top},
    )


def params_from_model(model) -> dict[str, float]:
    """m from body ``top``'s mass; l from the height of its centre of mass along its axle (body z) above
    the pivot (its ball joint's anchor); I₁, I₃ from its inertia tensor about the centre of mass in the
    body frame: I₃ its moment about the axle, I₁ the mean of its moments about body x and y (the
    symmetric top nearest the model's inertia); g from gravity.

    What the reference cannot read is physics this top does not have, judged as a fault, not refused: a
    centre of mass beside the axle (a lopsided top: instant.kinematics, forcing), moments about x and y
    that differ or products of inertia (an asymmetric top: instant.mass_matrix). Refused with ValueError
    naming it, as another system or frame: the body's frame not at the world origin or turned (the ball
    joint's quaternion is then not R(φ, θ, ψ)); a joint other than one ball joint at the origin; the
    centre of mass at or below the pivot along the axle; the sites ``tip`` and ``rim`` elsewhere than
    :data:`SITE_OFFSETS` × l (the observed points); gravity not along −z.
    """
    bid = model.body(BODY).id
    com = np.asarray(model.body_ipos[bid], dtype=float)
    scale = max(float(np.linalg.norm(com)), 1e-300)
    unturned = np.all(np.abs(model.body_quat[bid] - [1, 0, 0, 0]) <= 1e-12)
    if np.any(np.abs(model.body_pos[bid]) > 1e-12 * scale) or not unturned:
        raise ValueError(f"body {BODY!r} must sit at the world origin unturned (pos 0 0 0, quat 1 0 0 0), got pos "
                         f"{model.body_pos[bid].tolist()} quat {model.body_quat[bid].tolist()}")
    first, count = int(model.body_jntadr[bid]), int(model.body_jntnum[bid])
    if count != 1 or int(model.jnt_type[first]) != 1:  # mjJNT_BALL
        raise ValueError(f"body {BODY!r} must have exactly one joint, a ball joint at the pivot")
    if np.any(np.abs(model.jnt_pos[first]) > 1e-12 * scale):
        raise ValueError(f"the ball joint of body {BODY!r} must be at the pivot (pos 0 0 0), got "
                         f"{model.jnt_pos[first].tolist()}")
    if not com[2] > 0:
        raise ValueError(f"the centre of mass of {BODY!r} must be above the pivot along its axle (inertial pos "
                         f"0 0 l, l > 0), got {com.tolist()}")
    axes = _quat_matrix(model.body_iquat[bid])  # columns: the principal axes in the body frame
    tensor = axes @ np.diag(np.asarray(model.body_inertia[bid], dtype=float)) @ axes.T  # about the com, body frame
    l = float(com[2])
    for name, offset in SITE_OFFSETS.items():
        sid = model.site(name).id
        where = np.asarray(model.site_pos[sid]) - l * np.asarray(offset)
        if int(model.site_bodyid[sid]) != bid or np.any(np.abs(where) > 1e-12 * l):
            raise ValueError(f"site {name!r} must be on body {BODY!r} at pos {(l * np.asarray(offset)).tolist()} "
                             f"(= {offset} × l), got {model.site_pos[sid].tolist()}")
    gravity = np.asarray(model.opt.gravity, dtype=float)
    if np.any(gravity[:2] != 0) or not gravity[2] < 0:
        raise ValueError(f"gravity must point along −z, got {gravity.tolist()}")
    return {"m": float(model.body_mass[bid]), "g": float(-gravity[2]), "l": l,
            "I1": float((tensor[0, 0] + tensor[1, 1]) / 2), "I3": float(tensor[2, 2])}


def _quat_matrix(quat) -> np.ndarray:
    """The rotation matrix of a unit quaternion (w, x, y, z), MuJoCo's order."""
    w, x, y, z = (float(v) for v in quat)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def scales(params: dict[str, float]) -> Scales:
    """Length: the top's size, 2.5 l (:data:`SIZE`: where its observed points move); force m g, energy
    m g l (the potential's swing is 2 m g l), angular momentum m l √(g l)."""
    m, g, l = params["m"], params["g"], params["l"]
    return Scales(length=SIZE * l, force=m * g, energy=m * g * l, momentum=m * l * (g * l) ** 0.5)


# ---------------------------------------------------------------- closed forms (independent checks)
def nutation_cubic(params: dict[str, float], *, energy: float, p_phi: float, p_psi: float) -> np.ndarray:
    """The coefficients (highest power first) of f(u) = (1 − u²)(α − β u) − (b − a u)², u = cos θ,
    whose roots in [−1, 1] are the turning points of the nutation (Goldstein §5.7). Typed by hand from
    the conserved quantities, an independent check of the derived equations."""
    i1p = params["I1"] + params["m"] * params["l"] ** 2
    alpha = (2 * energy - p_psi**2 / params["I3"]) / i1p
    beta = 2 * params["m"] * params["g"] * params["l"] / i1p
    a, b = p_psi / i1p, p_phi / i1p
    # (1 − u²)(α − β u) = β u³ − α u² − β u + α;  (b − a u)² = a² u² − 2 a b u + b²
    return np.array([beta, -alpha - a**2, -beta + 2 * a * b, alpha - b**2])


def turning_points(params: dict[str, float], *, energy: float, p_phi: float, p_psi: float) -> tuple[float, float]:
    """(θ_min, θ_max): the nutation's limits, from the two roots of :func:`nutation_cubic` in [−1, 1]."""
    roots = np.roots(nutation_cubic(params, energy=energy, p_phi=p_phi, p_psi=p_psi))
    real = np.sort(roots[np.abs(roots.imag) < 1e-9].real)
    inside = real[(real >= -1.0) & (real <= 1.0)]
    if len(inside) != 2:
        raise ValueError(f"expected two roots of the nutation cubic in [−1, 1], got {real.tolist()}")
    return float(np.arccos(inside[1])), float(np.arccos(inside[0]))


def steady_precession_rates(params: dict[str, float], *, theta: float, omega3: float) -> tuple[float, float]:
    """(slow, fast) φ̇ of a steady precession at θ with spin ω₃ = ψ̇ + φ̇ cos θ: the roots of
    I₁' cos θ φ̇² − I₃ ω₃ φ̇ + m g l = 0 (θ̈ = 0 at θ̇ = 0); ValueError where the spin is too slow."""
    i1p = params["I1"] + params["m"] * params["l"] ** 2
    a, b, c = i1p * np.cos(theta), -params["I3"] * omega3, params["m"] * params["g"] * params["l"]
    disc = b * b - 4 * a * c
    if disc < 0:
        raise ValueError(f"no steady precession at θ = {theta}: the spin ω₃ = {omega3} is too slow")
    roots = sorted(((-b - np.sqrt(disc)) / (2 * a), (-b + np.sqrt(disc)) / (2 * a)), key=abs)
    return float(roots[0]), float(roots[1])
