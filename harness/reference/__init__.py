"""The analytic side as the harness uses it: derivations and numeric dynamics, cached on disk, and
references solved once per process (:mod:`.derivations`, :mod:`.solutions`)."""

__all__: list[str] = []
