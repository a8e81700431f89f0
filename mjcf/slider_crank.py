"""The slider_crank case: the system's own model, with the wrist pin's pull declared for the reaction sensors.

The ``connect`` ``wrist_pin`` (site1 ``rod_end`` on the rod, site2 ``piston_pin`` on
the piston) acts outside the joints: MuJoCo counts it in ``cfrc_ext``. Its
three rows are the world components of rod_end − piston_pin, so with
M q̈ = F + Jᵀλ the multipliers λ are the world force on the rod at its end and
−λ the force on the piston at its pin (:class:`harness.engine.sensors.Load`);
the sensors of the bearing, the crank pin and the guide are compared with
Newton–Euler of their subtrees less these loads (:mod:`harness.families.reactions`).
"""

from __future__ import annotations

from harness.cases import Wiring
from harness.engine.compat import CONNECT_WELD_LOOPS
from harness.engine.sensors import Load

__all__ = ["WIRING"]

WIRING = Wiring(
    loads=(Load("wrist_pin", body="rod", site="rod_end", sign=1.0),
           Load("wrist_pin", body="piston", site="piston_pin", sign=-1.0)),
    requires=CONNECT_WELD_LOOPS,
)
