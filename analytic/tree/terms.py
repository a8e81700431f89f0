"""What a joint adds to the tree's Lagrangian beyond its kinematics: each a frozen record of its parameters that
states its own potential energy over the joint's coordinates, so that a new joint feature is a record here and the
line that reads it from a model (:data:`harness.reference.tree.FEATURES`), and the dynamics sum whatever the joints
carry without knowing any one of them.

A term's ``energy`` takes the joint's own coordinates (..., ndof), in :mod:`analytic.tree.model`'s convention
(hinge and slide: qpos; ball: the rotation vector θ from the joint's chart), and may be handed complex or
:class:`~analytic.dual.Dual` arrays: it is differentiated exactly, never by hand.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np

__all__ = ["Spring", "Term"]

Array = np.ndarray


@runtime_checkable
class Term(Protocol):
    """A joint's contribution to the potential V(q), and its parameters by a readable name (the report's rows)."""

    def energy(self, q: Array) -> Array:
        """V over the joint's coordinates q (..., ndof)."""
        ...

    def params(self, joint: str) -> dict[str, float]:
        """Every number the energy depends on, named ``{joint}.{parameter}``."""
        ...


@dataclass(frozen=True)
class Spring:
    """A hinge or slide's linear spring (MuJoCo's ``stiffness`` k about ``springref``, its ``qpos_spring``):
    V = ½ k (q − springref)²."""

    stiffness: float
    springref: float

    def energy(self, q: Array) -> Array:
        if not self.stiffness:  # no spring (or springs off): nothing at all, whatever q holds
            return np.zeros(())
        x = q[..., 0] - self.springref
        return 0.5 * self.stiffness * x * x

    def params(self, joint: str) -> dict[str, float]:
        return {f"{joint}.stiffness": float(self.stiffness), f"{joint}.springref": float(self.springref)}
