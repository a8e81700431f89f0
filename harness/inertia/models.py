"""The inertia audit of the models a ``check`` or ``run`` judges: each case's MJCF (once per file) and a
``--urdf`` FILE's own inertials against its own meshes (:mod:`harness.inertia.urdf`), with the bodies a user's
config accepts (``[accept_inertia]``: body = "reason", :mod:`harness.pipeline.limits`)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from harness.core.errors import ModelError
from harness.engine.models import compile_model
from harness.inertia.audit import ModelAudit, audit_model
from harness.inertia.urdf import urdf_model

__all__ = ["Inertials", "audit_files"]


@dataclass(frozen=True)
class Inertials:
    """The audits of the models judged, the models that could not be audited (name, why), and the accepted
    bodies that had no finding (a stale acceptance is named, not silently kept)."""

    audits: tuple[ModelAudit, ...] = ()
    skipped: tuple[tuple[str, str], ...] = ()
    unused: tuple[str, ...] = ()

    @property
    def failed(self) -> bool:
        return any(a.failed for a in self.audits)

    own: bool = False

    def lines(self, *, quiet: bool = False) -> list[str]:
        """Each model's section (:meth:`ModelAudit.lines`), the models not audited and the unused acceptances: a
        shipped case's model only where it has something to say (a finding, warning or inert violation); a model
        of your own (``own``: --mjcf) and a URDF always, with its one-line summary."""
        out = [line for a in self.audits if quiet or self.own or a.model.startswith("URDF ") or any(
            b.kind in ("finding", "warning", "inert") for b in a.bodies) for line in a.lines(quiet=quiet)]
        if not quiet:
            out += [f"Inertials of {name} not audited: {why}" for name, why in self.skipped]
            out += [f"config accepts the inertia of body {b!r}, which has no finding in the models checked"
                    for b in self.unused]
        return out

    def verdict(self) -> str:
        """The line under the checks' verdict where a finding fails ("" otherwise)."""
        if not self.failed:
            return ""
        count = sum(b.failing for a in self.audits for b in a.bodies)
        return (f"FAIL — {count} body inertial(s) no mass distribution inside the body's own geometry can have "
                "(listed above; accept one in the config's [accept_inertia] with a reason)")

    def as_dict(self) -> dict:
        return {"models": [a.as_dict() for a in self.audits],
                "not_audited": [{"model": n, "why": w} for n, w in self.skipped]}


def audit_files(mjcf: Sequence[tuple[str, Path | str]], *, urdf: Path | str | None = None,
                accept: Mapping[str, str] | None = None, own: bool = False) -> Inertials:
    """The audits of the MJCF files ``mjcf`` ((name, path), each path once; ``own``: models the user brought)
    and of the URDF ``urdf``; a file that does not compile is left to the check that names it (its name and why
    listed as not audited)."""
    audits, skipped, seen = [], [], set()
    for name, path in mjcf:
        key = str(Path(path).resolve())
        if key in seen:
            continue
        seen.add(key)
        try:
            model = compile_model(path)
        except ValueError as exc:
            skipped.append((name, str(exc)))
            continue
        audits.append(audit_model(model, name=name, accept=accept))
    if urdf is not None:
        try:
            model, partial = urdf_model(urdf)
        except ModelError as exc:
            skipped.append((f"URDF {urdf}", str(exc)))
        else:
            audits.append(audit_model(model, name=f"URDF {urdf}", accept=accept, partial=partial))
    found = {b.body for a in audits for b in a.bodies if b.kind == "finding"}
    unused = tuple(b for b in (accept or {}) if b not in found)
    return Inertials(tuple(audits), tuple(skipped), unused, own)
