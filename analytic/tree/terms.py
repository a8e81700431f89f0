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
from typing import Protocol

import numpy as np

__all__ = ["Spring", "Term"]

Array = np.ndarray


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
    """A hinge or slide's spring about ``springref`` (MuJoCo's ``qpos_spring``): the force −f(x), x = q − springref,
    f(x) = k x + p₀ x² + p₁ x³ + … with k ``stiffness`` and ``poly`` the higher coefficients (MuJoCo
    ≥ 3.7's ``jnt_stiffnesspoly``; none before). V = ∫₀ˣ f = ½ k x² + Σᵢ pᵢ x^(i+3) / (i + 3)."""

    stiffness: float
    springref: float
    poly: tuple[float, ...] = ()

    def energy(self, q: Array) -> Array:
        if not self.stiffness and not any(self.poly):  # no spring (or springs off): nothing at all, whatever q holds
            return np.zeros(())
        x = q[..., 0] - self.springref
        v = 0.5 * self.stiffness * x * x
        if any(self.poly):  # Horner: x² Σᵢ pᵢ x^(i+1) / (i + 3)
            tail: Array | float = 0.0
            for i in reversed(range(len(self.poly))):
                tail = (tail + self.poly[i] / (i + 3)) * x
            v = v + x * x * tail
        return v

    def params(self, joint: str) -> dict[str, float]:
        """``stiffness`` and ``springref``; the polynomial's coefficients (``stiffnesspoly.i``) only where any is
        nonzero, so that a linear spring's rows stay those of every joint (:meth:`analytic.tree.Tree.params`)."""
        out = {f"{joint}.stiffness": float(self.stiffness), f"{joint}.springref": float(self.springref)}
        if any(self.poly):
            out |= {f"{joint}.stiffnesspoly.{i}": float(p) for i, p in enumerate(self.poly)}
        return out
