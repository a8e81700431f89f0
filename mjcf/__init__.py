"""The MuJoCo side of each case: one model per case, ``NAME.xml``, shipped as package data.

Beside a model, ``NAME.py`` (where it exists) declares ``WIRING``: which
analytic system the model is of, when that is not the system of the same
name, and the MuJoCo-side readings the case needs beyond the generic ones
(harness/cases/__init__.py says how cases are discovered).
"""

__all__: list[str] = []
