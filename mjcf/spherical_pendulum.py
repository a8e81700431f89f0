"""The spherical_pendulum case: two hinges; p_φ read from MuJoCo's own state."""

from __future__ import annotations

from harness.cases import Wiring
from harness.engine.readings.momentum import axial_angular_momentum

__all__ = ["WIRING"]

WIRING = Wiring(invariants={"p_phi": axial_angular_momentum(body="bob", site="pivot")})
