"""The hoop_plane case: a hoop rolling on a frictional contact, its heading turning.

All three constraints are held by the contact: the multipliers are read as
the contact force on the rim along the slides ``x``, ``y`` and ``z``
(:func:`~harness.engine.readings.contact.slide_force`); p_θ from MuJoCo's own
state; slip and penetration recorded as series. The lateral friction needs a
slip velocity to build (MuJoCo's friction rows see J q̈ but not J̇ q̇); it
settles within a few ms at solref 2 ms, so force figures start at 0.02 s.

The same three multipliers are the contact's load on the hoop for its reaction
sensors (:class:`harness.engine.sensors.Load`): MuJoCo counts the contact in
``cfrc_ext``, outside the joints, so the sensors at the centre read Newton–Euler
of the hoop less the contact force, each multiplier along its slide's world axis
at the contact point (:mod:`harness.families.reactions`).
"""

from __future__ import annotations

from harness.cases import Series, Wiring
from harness.engine.readings.contact import analytic_residual, slide_force
from harness.engine.readings.momentum import axial_angular_momentum
from harness.engine.sensors import Load

__all__ = ["WIRING"]

WIRING = Wiring(
    forces={"roll_x": slide_force(geom="rim", joint="x"),
            "roll_y": slide_force(geom="rim", joint="y"),
            "normal": slide_force(geom="rim", joint="z")},
    invariants={"p_theta": axial_angular_momentum(body="hoop", site="centre")},
    series={
        "slip": Series(analytic_residual(system="hoop_plane", constraints=("roll_x", "roll_y"), level="velocity"),
                       "m/s", "|(ẋ − a φ̇ cos θ, ẏ − a φ̇ sin θ)|, the slip speed at MuJoCo's state"),
        "penetration": Series(analytic_residual(system="hoop_plane", constraints=("normal",), level="position"),
                              "m", "|z − a|, the contact's penetration"),
    },
    settle=0.02,
    loads=tuple(Load(row, body="hoop", slide=slide, contact="rim")
                for row, slide in (("roll_x", "x"), ("roll_y", "y"), ("normal", "z"))),
)
