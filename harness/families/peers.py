"""The second opinions' family: MuJoCo, the tree reference and Pinocchio at sampled states, MuJoCo's distance from
its nearer peer (:mod:`harness.opinions.threeway`).

Figures ``instant.peer.QUANTITY`` (M, the bias forces, qacc, inverse dynamics), on MuJoCo's C engine alone and
where Pinocchio is installed (the comparison says what it skipped otherwise). Limit: from theory,
:data:`~harness.opinions.threeway.LIMIT` ε cond(M), the round-off of a backward-stable evaluation, whatever the
case (its basis: harness/opinions/threeway.py, docs/findings/peers.md). The comparison itself, with the side
each disagreement is attributed to, goes into the run's settings (``peers``).
"""

from __future__ import annotations

import mujoco

from harness.cases import Case
from harness.core.checks import Limit
from harness.core.figures import FigureName
from harness.families.bench import Bench, Measured
from harness.opinions import threeway

__all__ = ["NAME", "gated", "measure", "names", "owns", "theory_limit"]

NAME = "peers"


def owns(name: FigureName) -> bool:
    return name.layer == "instant" and name.quantity == "peer"


def names(case: Case, model: mujoco.MjModel) -> set[FigureName]:
    return {FigureName.instant("peer", q) for q in threeway.QUANTITIES}  # where Pinocchio is installed


def gated(name: FigureName, *, constrained: bool) -> bool:
    return True


def theory_limit(name: FigureName) -> Limit | None:
    return Limit("theory", threeway.LIMIT, f"{threeway.LIMIT:g} ε cond(M): a backward-stable evaluation's "
                                           "round-off (harness/opinions/threeway.py; docs/findings/peers.md)")


def measure(bench: Bench) -> Measured:
    if bench.engine.name != "c":  # a second opinion on MuJoCo's C engine alone
        return Measured()
    peers = bench.timed(NAME, lambda: threeway.three_way(bench.instant_model))
    return Measured(figures=tuple(peers.figures()), settings={"peers": peers.as_dict()})
