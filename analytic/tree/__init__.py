"""The tree reference: the Lagrangian of any kinematic tree, built from plain data and differentiated exactly.

A hand-written Lagrangian per system (:mod:`analytic.systems`) does not reach
robots: symbolic derivation grows several-fold with every degree of freedom
(docs/design.md, "Any model"). Here the
Lagrangian of a whole tree — bodies, joints, inertias, springs, damping,
gravity, equality constraints, actuators at a fixed control — is evaluated
numerically from its description (:mod:`analytic.tree.model`) with our own
forward kinematics (:mod:`analytic.tree.kinematics`), and Lagrange's equations
are obtained by complex-step differentiation (:mod:`analytic.tree.dynamics`),
exact to round-off. The result is a :class:`~analytic.dynamics.Dynamics`, so
the solvers and every layer of the harness take it as they take a derived one.
"""

from analytic.tree.dynamics import TreeDynamics
from analytic.tree.model import Actuator, Body, Equality, ForceLimit, Joint, Point, TendonLimit, Tree
from analytic.tree.terms import Spring, Term

__all__ = ["Actuator", "Body", "Equality", "ForceLimit", "Joint", "Point", "Spring", "TendonLimit", "Term", "Tree",
           "TreeDynamics"]
