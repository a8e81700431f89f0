"""Checks that a compiled model is the system a module's physics assumes, where the system does not read a
parameter but assumes it (a thin hoop's inertia from its mass and radius): a model that breaks the assumption
is refused in one line naming it, instead of being judged against the physics of another body."""

from __future__ import annotations

import numpy as np

__all__ = ["thin_hoop"]

HOOP_RTOL = 1e-6
"""How far (relative to m a²) a body's principal moments may be from a thin hoop's: a float32 backend's copies
of the model move them by a few ulps (1e-7); a hoop written as another body differs by tens of percent."""


def thin_hoop(model, body: str, *, mass: float, radius: float, what: str) -> None:
    """ValueError unless ``body``'s principal moments of inertia are a thin hoop's of ``mass`` and ``radius``:
    m a² (about its axis) and m a²/2 twice (about its diameters). The system's equations take the inertia
    from m and a, so another inertia is another system. How the hoop is turned against its hinge is not
    checked here: a hinge out of true is a fault the run shows (the catalog's axis tilt), not another body."""
    moments = np.sort(np.asarray(model.body_inertia[model.body(body).id], dtype=float))
    ma2 = mass * radius**2
    if np.max(np.abs(moments - np.array([ma2 / 2, ma2 / 2, ma2]))) > HOOP_RTOL * ma2:
        raise ValueError(f"the {what} (body {body!r}) is a thin hoop, its mass on its rim: its principal moments "
                         f"of inertia must be m a² = {ma2:.6g} kg m² about its axis and m a²/2 = {ma2 / 2:.6g} "
                         f"about its diameters (m = {mass:g} kg, a = {radius:g} m); the model's are "
                         f"{', '.join(f'{x:.6g}' for x in moments)}")
