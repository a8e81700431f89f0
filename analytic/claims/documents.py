"""Every claim of the seed documents, in the order the audit reports them (one module per document)."""

from __future__ import annotations

from analytic.claims import Claim, lecture15, simulations


def all_claims() -> tuple[Claim, ...]:
    return (*simulations.claims(), *lecture15.claims())
