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

__all__ = ["DENSEST", "Shape", "com_outside", "densest_ball", "inertia_of", "lower_ratio", "realizable",
           "second_moment", "upper_ratio"]

DENSEST = 22_600.0  # kg/m³: osmium 22,590, iridium 22,560, the densest elements at room conditions
DIRECTIONS = 500  # Fibonacci directions over the sphere (a hemisphere would do: w(n) = w(−n)), and the body axes
_DIRS = np.vstack([np.eye(3), fibonacci_directions(DIRECTIONS)])


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
        assert self.ext is not None  # asked only of a shape with geoms
        return Extent(np.vstack([self.ext.directions, axes]), np.concatenate([self.ext.plus, plus]),
                      np.concatenate([self.ext.minus, minus]))


def _ratios(mass: float, c: np.ndarray, sigma: np.ndarray, ext: Extent) -> np.ndarray:
    w = ext.width(c)
    moments = np.einsum("ij,jk,ik->i", ext.directions, sigma, ext.directions)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(w > 0, moments / (mass * w ** 2), np.where(moments > 0, np.inf, 0.0))


def upper_ratio(mass: float, c: np.ndarray, sigma: np.ndarray, shape: Shape, *,
                refine: bool = True) -> tuple[float, np.ndarray]:
    """The largest nᵀΣn / (m w(n)²) over the directions and Σ's principal axes, refined (``refine``) by a pattern
    search about the best of them (8 neighbours at a step halved down to 1e-4 rad), and the direction that gives
    it."""
    ratio = _ratios(mass, c, sigma, ext := shape.with_axes(np.linalg.eigh(sigma)[1].T))
    k = int(np.argmax(ratio))
    best, n = float(ratio[k]), ext.directions[k]
    if not refine or not math.isfinite(best) or best <= 0:
        return best, n
    step, turns = 0.05, np.linspace(0, 2 * np.pi, 8, endpoint=False)
    while step > 1e-4:
        t1 = np.cross(n, [1.0, 0, 0] if abs(n[0]) < 0.9 else [0, 1.0, 0])
        t1 /= np.linalg.norm(t1)
        t2 = np.cross(n, t1)
        trial = n + step * (np.outer(np.cos(turns), t1) + np.outer(np.sin(turns), t2))
        trial /= np.linalg.norm(trial, axis=1, keepdims=True)
        local = _ratios(mass, c, sigma, Extent(trial, *supports(list(shape.geoms), trial)))
        j = int(np.argmax(local))
        if local[j] > best:
            best, n = float(local[j]), trial[j]
        else:
            step /= 2
    return best, n


def lower_ratio(mass: float, sigma: np.ndarray) -> float:
    """(3/5) m R² / tr Σ: over 1 where the inertia is smaller than the densest ball's."""
    trace = float(np.trace(sigma))
    return densest_ball(mass) / trace if trace > 0 else math.inf


def com_outside(c: np.ndarray, shape: Shape) -> float:
    """How far the centre of mass ``c`` lies outside the geoms' hull (m; ≤ 0 inside)."""
    assert shape.ext is not None  # asked only of a shape with geoms
    return shape.ext.outside(c)


def realizable(mass: float, c: np.ndarray, sigma: np.ndarray, shape: Shape) -> bool:
    """Whether (m, c, Σ) passes every bound on ``shape``: a valid inertia, both bounds and c in the hull (the
    upper bound over the standard directions, unrefined: what a diagnosis needs)."""
    eig = np.linalg.eigvalsh(sigma)
    if mass <= 0 or eig.min() < -1e-12 * max(eig.max(), 1e-300):
        return False
    if lower_ratio(mass, sigma) > 1:
        return False
    if shape.ext is None:
        return True
    return upper_ratio(mass, c, sigma, shape, refine=False)[0] <= 1 and com_outside(c, shape) <= 0
