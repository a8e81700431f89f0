"""Analytic side of mjharness: Lagrangian derivations (sympy) and our own solvers."""
