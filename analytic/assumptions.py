"""Checks that a compiled model is the system a module's physics assumes, where the system does not read a
parameter but assumes it (a thin hoop's inertia from its mass and radius): a model that breaks the assumption
is refused in one line naming it, instead of being judged against the physics of another body."""

from __future__ import annotations

import numpy as np

HOOP_RTOL = 1e-6
"""How far (relative to m a²) a body's inertia may be from a thin hoop's: a float32 backend's copies of the
model move it by a few ulps (1e-7); a hoop written as another body differs by tens of percent."""


def thin_hoop(model, body: str, axle: str, *, mass: float, radius: float, what: str) -> None:
    """ValueError unless ``body``'s inertia (in its body frame) is that of a thin hoop of ``mass`` and ``radius``
    turning about the hinge ``axle``: m a² about the axle, m a²/2 about every diameter, centre of mass on the
    axle. The system's equations take the inertia from m and a, so another inertia is another system."""
    import mujoco  # lazy: only with a model at hand

    b = model.body(body).id
    rotation = np.zeros(9)
    mujoco.mju_quat2Mat(rotation, np.asarray(model.body_iquat[b], dtype=float))
    rotation = rotation.reshape(3, 3)
    inertia = rotation @ np.diag(np.asarray(model.body_inertia[b], dtype=float)) @ rotation.T
    axis = np.asarray(model.jnt_axis[model.joint(axle).id], dtype=float)
    axis = axis / np.linalg.norm(axis)
    ma2 = mass * radius**2
    expected = 0.5 * ma2 * (np.eye(3) + np.outer(axis, axis))
    if np.max(np.abs(inertia - expected)) > HOOP_RTOL * ma2:
        moments = ", ".join(f"{x:.6g}" for x in np.asarray(model.body_inertia[b], dtype=float))
        raise ValueError(f"the {what} (body {body!r}) is a thin hoop, its mass on its rim: its inertia must be "
                         f"m a² = {ma2:.6g} kg m² about its axle ({axle!r}) and m a²/2 = {ma2 / 2:.6g} about its "
                         f"diameters (m = {mass:g} kg, a = {radius:g} m); the model's principal moments are "
                         f"{moments}")
