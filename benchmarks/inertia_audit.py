"""The inertia audit (harness/inertia) on every robot of ../shared/models/menagerie, the zoo, the example-robot-data
(and pybullet_data) URDFs benchmarks/urdf_robots.py compares, and the planted errors of tests/test_inertia.py: the
figures of docs/findings/inertia.md. Run from the repository's root:

    python benchmarks/inertia_audit.py

Per model: the bodies with mass, each finding (body, upper-bound ratio, lower-bound ratio, centre of mass outside
in mm, likely cause, the largest change of M(q) relative to an entry's own scale and of a gravity torque), the
warnings, and the audit's time (compile excluded; one process, so the first model also pays numpy's warm-up).
"""

from __future__ import annotations

import importlib.util
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from harness import zoo  # noqa: E402
from harness.engine.models import compile_model  # noqa: E402
from harness.inertia.audit import ModelAudit, audit_model  # noqa: E402
from harness.inertia.urdf import urdf_model  # noqa: E402

MENAGERIE = ROOT.parent / "shared" / "models" / "menagerie"


def _urdf_robots() -> list[tuple[str, Path]]:
    spec = importlib.util.spec_from_file_location("urdf_robots", ROOT / "benchmarks" / "urdf_robots.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.robots()


def _finding(b) -> str:
    parts = [f"**{b.body}**"]
    if b.upper is not None and b.upper > 1:
        parts.append(f"upper {b.upper:.3g}×")
    if b.lower > 1 and b.kind != "point mass":
        parts.append(f"lower {b.lower:.3g}×")
    if b.outside is not None and b.outside > 0:
        parts.append(f"c {b.outside * 1e3:.3g} mm outside")
    if b.causes:
        parts.append("cause: " + "; ".join(c.split(" (")[0] for c in b.causes))
    if b.effect:
        parts.append(f"M(q) {100 * b.effect.relative:.3g} %, gravity torque {b.effect.torque:.3g}")
    return ", ".join(parts)


def row(name: str, audit: ModelAudit) -> str:
    worst = max((b.upper for b in audit.bodies if b.upper is not None), default=None)
    said = [_finding(b) for b in audit.findings]
    said += [f"warning: {_finding(b)}" for b in audit.bodies if b.kind in ("warning", "inert")]
    return (f"| {name} | {len(audit.bodies)} | {len(audit.findings)} | "
            f"{'—' if worst is None else f'{worst:.3g}'} | {'<br>'.join(said) or 'none'} | "
            f"{audit.seconds * 1e3:.0f} |")


def rows() -> list[str]:
    lines = ["| model | bodies with mass | findings | largest upper ratio | findings and warnings | ms |",
             "|---|---|---|---|---|---|"]
    if MENAGERIE.is_dir():
        for path in sorted(MENAGERIE.glob("*/*.xml")):
            if path.stem.startswith("scene"):
                continue
            name = f"menagerie/{path.parent.name}/{path.stem}"
            lines.append(row(name, audit_model(compile_model(path), name=name)))
    for m in zoo.discover()[0]:
        lines.append(row(m.name, audit_model(compile_model(m.path), name=m.name)))
    for name, path in _urdf_robots():
        try:
            model, partial = urdf_model(path)
        except ValueError as exc:
            lines.append(f"| {name} (URDF) | | | | not audited: {' '.join(str(exc).split())[:160]} | |")
            continue
        lines.append(row(f"{name} (URDF, {len(partial)} link(s) with a mesh left out)",
                         audit_model(model, name=name, partial=partial)))
    return lines


def planted() -> list[str]:
    spec = importlib.util.spec_from_file_location("test_inertia", ROOT / "tests" / "test_inertia.py")
    t = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(t)
    import numpy as np

    c = t.COM
    origin = np.diag(t.BOX) + t.MASS * (c @ c * np.eye(3) - np.outer(c, c))
    models = {
        "inertia about the link origin": t._link(inertia=f"diaginertia='{t._fmt(np.diag(origin))}'"),
        "principal axes swapped": t._link(inertia=f"diaginertia='{t._fmt(t.BOX[[2, 1, 0]])}'"),
        "mass in grams": t._link(mass=t.MASS * 1000),
        "inertia in kg·mm²": t._link(inertia=f"diaginertia='{t._fmt(t.BOX * 1e6)}'"),
        "placeholder 0.001 kg·m² for 60 kg": t._link(mass=60, inertia="diaginertia='0.001 0.001 0.001'"),
        "centre of mass moved 0.2 m sideways": t._link(pos=c + np.array([0.2, 0, 0])),
    }
    lines = ["| planted error (2 kg box link on a hinge) | category | finding and diagnosis |", "|---|---|---|"]
    for what, model in models.items():
        (b,) = audit_model(model, name=what).bodies
        lines.append(f"| {what} | {b.kind} | {_finding(b)} |")
    return lines


if __name__ == "__main__":
    start = time.perf_counter()
    print("\n".join(rows()))
    print()
    print("\n".join(planted()))
    print(f"\n({time.perf_counter() - start:.0f} s)")
