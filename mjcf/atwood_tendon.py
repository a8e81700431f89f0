"""The atwood_tendon case: the atwood system with its string as two spatial tendons over the pulley.

Each string is a spatial tendon from a hook on its mass, wrapped over the
pulley's cylinder, to an anchor on the rim, its length held by a tendon
equality of the same name as the analytic constraint (``string1``,
``string2``). A tendon shortens as its mass rises, so its row is −1 × the
constraint's (J = ∂L/∂q = (−1, 0, a) for string1 against (1, 0, −a)) and its
``efc_force`` is −λ = −tension: read × −1 (``equality_signs``).

MuJoCo ≥ 4.0 applies a spatial tendon's pull at its path points, outside the
joints (``cfrc_ext``), so the strings are declared as loads for the reaction
sensors (:mod:`harness.families.reactions`): string k pulls its mass up with λ_k ẑ
at its hook and the pulley down with λ_k at its rim (on the vertical line
through ``rim_left``/``rim_right``). The strings' lengths are recorded as the
series ``stretch`` (max over both of |L − L₀|, the length at qpos0 the
equalities hold).

The motion is the system's, over 0.8 s: the wraps stay inside (0, 180°) there
(mjcf/atwood_tendon.xml).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from analytic.systems import atwood
from harness.cases import Series, Wiring
from harness.engine.readings import Reading
from harness.engine.sensors import Load

__all__ = ["WIRING"]

STRINGS = ("string1", "string2")


def _stretch(model, recorded) -> np.ndarray:
    ids = [model.tendon(s).id for s in STRINGS]
    return np.max(np.abs(recorded["ten_length"][:, ids] - model.tendon_length0[ids]), axis=1)


WIRING = Wiring(
    system="atwood",
    motion=dataclasses.replace(atwood.MOTION, horizon=0.8,
                               description="Atwood's machine, massive pulley; the string as two spatial tendons "
                                           "wrapped over the pulley, tendon equalities (forces = −tensions)"),
    equality_signs={s: -1.0 for s in STRINGS},
    # on 3.3.0 the wraps take other sides (string2's ∂L/∂θ = +a at qpos0, string1 unwraps past θ = −1.5);
    # mj_rnePostConstraint counts spatial tendons in cfrc_ext from 3.14.0 (changelog 3.14.0, bug fix 9). With
    # this requirement lifted, the releases before 4.0.0 fail most of the case's checks
    # (docs/findings/bases.md): 4.0.0 is the first release that runs it.
    requires=((4, 0, 0), "its tendons' wrap over the pulley (3.3.0 to 3.17.0 wrap it differently: 52 of 58 "
                         "checks fail on 3.17.0, measured)"),
    loads=(Load("string1", body="mass1", site="hook1", direction=(0.0, 0.0, 1.0)),
           Load("string1", body="pulley", site="rim_left", direction=(0.0, 0.0, -1.0)),
           Load("string2", body="mass2", site="hook2", direction=(0.0, 0.0, 1.0)),
           Load("string2", body="pulley", site="rim_right", direction=(0.0, 0.0, -1.0))),
    series={"stretch": Series(Reading(("ten_length",), _stretch, "max |L − L₀| of the strings (m)"), "m",
                              "max over both strings of |L − L₀|, the tendon length off the length its equality "
                              "holds")},
)
