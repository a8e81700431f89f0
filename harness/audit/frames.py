"""The seed documents' names and variables: the frames (a document's coordinates and multipliers, and how they
map to ours) that the claims of each document share, whichever module states them."""

from __future__ import annotations

import functools

import sympy as sp

from analytic.systems import symbols
from harness.audit import Frame, doc_frame

__all__ = ["GOLDSTEIN_1_3", "LECTURE15", "SIMULATIONS", "atwood_frame", "pendulum_frame", "pendulum_frame_flipped",
           "plane_frame", "ramp_frame", "spherical_frame", "spring_frame"]

LECTURE15 = "000_53d3a09bcd5afa0f.txt"  # Lecture 15: multiplier method, spherical pendulum, hoops, Atwood
GOLDSTEIN_1_3 = ("Goldstein, Poole & Safko, Classical Mechanics, 3rd ed. (2002), §1.3 'Constraints', p. 12–13: "
                 "holonomic if expressible as f(r₁, r₂, …, t) = 0 (eq. 1.37); 'constraints not expressible in "
                 "this fashion are called nonholonomic', e.g. the walls of a gas container, or a particle on a "
                 "sphere written as the inequality r² − a² ≥ 0")


@functools.cache
def spherical_frame() -> Frame:
    return doc_frame("spherical_pendulum", "theta phi", {"theta": "pi - theta", "phi": "phi"},
                     reading="θ_doc from the upward vertical: θ_ours = π − θ_doc")


@functools.cache
def atwood_frame() -> Frame:
    return doc_frame("atwood", "z1 z2 z3", {"z1": "z1", "z2": "z2", "theta": sp.Symbol("z3", real=True)
                                                                        / symbols("atwood").a},
                     lam={"string1": "lambda1", "string2": "lambda2"}, reading="z3 = a θ")


@functools.cache
def ramp_frame() -> Frame:
    return doc_frame("hoop_ramp", "x s phi")


@functools.cache
def plane_frame() -> Frame:
    return doc_frame("hoop_plane", "x y z theta phi")


SIMULATIONS = "001_c29a5107db08e1d9.txt"  # least action, constraints, spring, pendulum


@functools.cache
def spring_frame() -> Frame:
    return doc_frame("spring", "q", {"x": "q"})


@functools.cache
def pendulum_frame() -> Frame:
    return doc_frame("pendulum", "theta r", lam={"rod": "lambda"},
                     reading="θ from the downward vertical; λ of S = ∫(L + λf) dt, = our λ_rod = −tension")


@functools.cache
def pendulum_frame_flipped() -> Frame:
    return doc_frame("pendulum", "theta r", lam={"rod": "-lambda"},
                     reading="θ from the downward vertical; λ = −our λ_rod = +tension")
