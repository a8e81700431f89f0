"""Every claim of the seed documents, in the order the audit reports them (each document's claims live in its own
modules: simulations for 001, lecture15 and lecture15_method for 000)."""

from __future__ import annotations

from harness.audit import Claim, lecture15, simulations

__all__ = ["all_claims"]


def all_claims() -> tuple[Claim, ...]:
    return (*simulations.claims(), *lecture15.claims())
