"""A cart-pole for mjharness: the package directory holds the system (cartpole.py), its MJCF and its limits.

mjharness finds this directory through the entry point group ``mjharness.systems`` (pyproject.toml), or
with ``--systems`` pointing at it; it imports ``cartpole.py`` itself, so nothing is imported here.
"""
