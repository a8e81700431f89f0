"""Analytic side of mjharness: Lagrangian derivations (sympy) and our own solvers."""

__all__: list[str] = []
