"""MjSpec edits that break a contact model, shared by the hoop tests."""

from __future__ import annotations

import mujoco
import numpy as np

# MuJoCo's default contact softness (solref, solimp), far softer than the shipped pairs
DEFAULT_SOFTNESS = ([0.02, 1.0], [0.9, 0.95, 0.001, 0.5, 2.0])


def friction(mu: float):
    """Every contact pair's sliding friction set to ``mu`` (torsional and rolling off)."""
    def edit(spec: mujoco.MjSpec) -> None:
        for pair in spec.pairs:
            pair.friction = [mu, mu, 0.0, 0.0, 0.0]
    return edit


def mujoco_default_softness(spec: mujoco.MjSpec) -> None:
    for pair in spec.pairs:
        pair.solref, pair.solimp = list(DEFAULT_SOFTNESS[0]), list(DEFAULT_SOFTNESS[1])


def rim_radius(factor: float):
    """The contact geom ``rim`` scaled by ``factor`` (the analytic radius stays the shipped one)."""
    def edit(spec: mujoco.MjSpec) -> None:
        spec.geom("rim").size = np.asarray(spec.geom("rim").size) * factor
    return edit
