"""The vocabulary every layer speaks, with no MuJoCo run and no sympy: figures and their names, checks,
trajectories, errors, and the on-disk cache with the costs measured beside it."""

__all__ = ["VERSION"]

VERSION = "0.1.0"
