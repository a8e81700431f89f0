"""The welded_pendulum case's wiring: the weld's wrench declared for the reaction sensors, and only the oldest
MuJoCo that holds its weld (see ``requires``).

The weld ``glue`` (site1 ``top`` on the link, site2 ``socket`` on the hub) acts outside the joints: MuJoCo
counts it in ``cfrc_ext``. Its six rows are top − socket (world) and s·vec(q̄_socket ⊗ q_top), so with
M q̈ = F + Jᵀλ the first three multipliers are the world force on the link at its top and the last three the
moment (s/2) R_socket λ_τ on it; the hub feels the opposite at the socket
(:class:`harness.engine.sensors.Load`, :func:`harness.engine.sensors.weld_moment_map`).
"""

from __future__ import annotations

from harness.cases import Wiring
from harness.engine.compat import CONNECT_WELD_LOOPS
from harness.engine.sensors import Load

__all__ = ["WIRING"]

WIRING = Wiring(
    loads=(Load("glue", body="link", site="top", sign=1.0),
           Load("glue", body="hub", site="socket", sign=-1.0)),
    requires=CONNECT_WELD_LOOPS,
)
