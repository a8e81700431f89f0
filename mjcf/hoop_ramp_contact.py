"""The hoop_ramp_contact case: the hoop_ramp system on a real frictional contact.

The two constraints of the system are not MJCF equalities here: the contact
holds them, so their multipliers are read as the contact force on the rim
along the slides ``x`` and ``s`` (:func:`~harness.engine.readings.contact.slide_force`),
and the contact's slip, creep and penetration are recorded as series.
"""

from __future__ import annotations

from harness.cases import Series, Wiring
from harness.engine.readings.contact import analytic_residual, slide_force

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
)
