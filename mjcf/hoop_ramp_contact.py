"""The hoop_ramp_contact case: the hoop_ramp system on a real frictional contact.

The two constraints of the system are not MJCF equalities here: the contact
holds them, so their multipliers are read as the contact force on the rim
along the slides ``x`` and ``s`` (:func:`~harness.engine.readings.contact.slide_force`),
and the contact's slip, creep and penetration are recorded as series.

The same multipliers are the contact's load on the hoop for its reaction sensors
(:class:`harness.engine.sensors.Load`): MuJoCo counts the contact in ``cfrc_ext``,
outside the joints, so the sensors at the hub read Newton–Euler of the hoop less
the contact force, each multiplier along its slide's world axis at the contact
point (:mod:`harness.families.reactions`) — nothing, in this plane, where
``hoop_ramp``'s joint equalities put the whole reaction on the joints.
"""

from __future__ import annotations

from harness.cases import Series, Wiring
from harness.engine.readings.contact import analytic_residual, slide_force
from harness.engine.sensors import Load

__all__ = ["WIRING"]

WIRING = Wiring(
    system="hoop_ramp",
    description="the hoop_ramp system on a real frictional contact (mj_contactForce), slip recorded",
    tags=frozenset({"contact"}),
    forces={"roll": slide_force(geom="rim", joint="x"),
            "normal": slide_force(geom="rim", joint="s")},
    series={
        "slip": Series(analytic_residual(system="hoop_ramp", constraints=("roll",), level="velocity"),
                       "m/s", "|ẋ − a φ̇|, the slip velocity at MuJoCo's state"),
        "creep": Series(analytic_residual(system="hoop_ramp", constraints=("roll",), level="position"),
                        "m", "|x − a φ|, the accumulated slip"),
        "penetration": Series(analytic_residual(system="hoop_ramp", constraints=("normal",), level="position"),
                              "m", "|s − a|, the contact's penetration"),
    },
    loads=(Load("roll", body="hoop", slide="x", contact="rim"),
           Load("normal", body="hoop", slide="s", contact="rim")),
)
