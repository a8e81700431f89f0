"""The two necessary conditions a body's inertial must meet to be a mass distribution inside its own geometry, and
the causes that explain a violation (docs/inertia.md has the derivations).

With I the inertia about the centre of mass c and Σ = ½ tr(I)·1 − I the second moment ∫ (x − c)(x − c)ᵀ dm:

- upper bound: for every unit n, nᵀΣn ≤ m · w(n)², w(n) = max over the geometry's hull of |n·(x − c)|, which the
  hull's support function h gives exactly: w(n) = max(h(n) − n·c, h(−n) + n·c). Its ratio is the largest
  nᵀΣn / (m w(n)²) over :data:`DIRECTIONS` directions and Σ's principal axes: a lower estimate of the true
  maximum, so a ratio over 1 is always a real violation (never a sampling artefact);
- lower bound: no material is denser than osmium/iridium (:data:`DENSEST`), and of all distributions of mass m at
  density at most ρ the ball about c has the least tr Σ: tr Σ ≥ (3/5) m R², R = (3m / 4πρ)^(1/3);
- the centre of mass lies in the hull: n·c ≤ h(n) for every direction (checked over the same directions).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from harness.inertia.geometry import Geom, fibonacci_directions, supports

DENSEST = 22_600.0  # kg/m³: osmium 22,590, iridium 22,560, the densest elements at room conditions
DIRECTIONS = 1000  # Fibonacci directions over the sphere (a hemisphere would do: w(n) = w(−n))
_DIRS = fibonacci_directions(DIRECTIONS)


def second_moment(inertia: np.ndarray) -> np.ndarray:
    """Σ = ½ tr(I)·1 − I: the second moment of the mass about the centre of mass, from the inertia about it."""
    return 0.5 * np.trace(inertia) * np.eye(3) - inertia


def inertia_of(sigma: np.ndarray) -> np.ndarray:
    """The inertia I = tr(Σ)·1 − Σ whose second moment is Σ."""
    return np.trace(sigma) * np.eye(3) - sigma


def densest_ball(mass: float) -> float:
    """The least tr Σ any mass distribution of ``mass`` kg at density at most :data:`DENSEST` can have: the ball's
    (3/5) m R²."""
    radius = (3 * mass / (4 * math.pi * DENSEST)) ** (1 / 3)
    return 0.6 * mass * radius ** 2


@dataclass(frozen=True)
class Extent:
    """A body's hull as the bounds need it: the support h(n) at each direction and at its opposite."""

    directions: np.ndarray
    plus: np.ndarray
    minus: np.ndarray

    def width(self, c: np.ndarray) -> np.ndarray:
        """w(n) = the largest |n·(x − c)| over the hull, for each direction."""
        nc = self.directions @ c
        return np.maximum(self.plus - nc, self.minus + nc)

    def outside(self, c: np.ndarray) -> float:
        """How far ``c`` lies outside the hull (m, the largest n·c − h(n); ≤ 0 inside)."""
        nc = self.directions @ c
        return float(max((nc - self.plus).max(), (-nc - self.minus).max()))


def extent(geoms: list[Geom], extra: np.ndarray | None = None) -> Extent:
    """The hull of ``geoms`` at the standard directions plus ``extra`` ones (rows)."""
    n = _DIRS if extra is None else np.vstack([_DIRS, extra])
    return Extent(n, *supports(geoms, n))


@dataclass(frozen=True)
class Shape:
    """A body's geoms with their hull's supports at the standard directions, computed once: what every bound
    reads (empty: a body without geometry)."""

    geoms: tuple[Geom, ...]
    ext: Extent | None

    @classmethod
    def of(cls, geoms: list[Geom]) -> Shape:
        return cls(tuple(geoms), extent(list(geoms)) if geoms else None)

    def with_axes(self, axes: np.ndarray) -> Extent:
        """The supports at the standard directions and at ``axes`` (rows) too."""
        plus, minus = supports(list(self.geoms), axes)
        return Extent(np.vstack([self.ext.directions, axes]), np.concatenate([self.ext.plus, plus]),
                      np.concatenate([self.ext.minus, minus]))


def upper_ratio(mass: float, c: np.ndarray, sigma: np.ndarray, shape: Shape) -> tuple[float, np.ndarray]:
    """The largest nᵀΣn / (m w(n)²) over the directions and Σ's principal axes, and the direction that gives it."""
    ext = shape.with_axes(np.linalg.eigh(sigma)[1].T)
    w = ext.width(c)
    moments = np.einsum("ij,jk,ik->i", ext.directions, sigma, ext.directions)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(w > 0, moments / (mass * w ** 2), np.where(moments > 0, np.inf, 0.0))
    k = int(np.argmax(ratio))
    return float(ratio[k]), ext.directions[k]


def lower_ratio(mass: float, sigma: np.ndarray) -> float:
    """(3/5) m R² / tr Σ: over 1 where the inertia is smaller than the densest ball's."""
    trace = float(np.trace(sigma))
    return densest_ball(mass) / trace if trace > 0 else math.inf


def com_outside(c: np.ndarray, shape: Shape) -> float:
    """How far the centre of mass ``c`` lies outside the geoms' hull (m; ≤ 0 inside)."""
    return shape.ext.outside(c)


def realizable(mass: float, c: np.ndarray, sigma: np.ndarray, shape: Shape) -> bool:
    """Whether (m, c, Σ) passes every bound on ``shape``: a valid inertia, both bounds and c in the hull."""
    eig = np.linalg.eigvalsh(sigma)
    if mass <= 0 or eig.min() < -1e-12 * max(eig.max(), 1e-300):
        return False
    if lower_ratio(mass, sigma) > 1:
        return False
    if shape.ext is None:
        return True
    return upper_ratio(mass, c, sigma, shape)[0] <= 1 and com_outside(c, shape) <= 0
