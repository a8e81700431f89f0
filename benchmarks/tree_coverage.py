"""What the tree reference says it leaves out of a model, and what switching it off makes of the model (issue 46).

    python benchmarks/tree_coverage.py --out after.json            # every model found (below), one JSON
    python benchmarks/tree_coverage.py --compare before.json after.json   # exit 1 where any model differs

For each model — Menagerie's under ``../shared/models/menagerie`` (every entry file), dm_control's suite, Gymnasium's
MuJoCo assets, and this repository's ``mjcf/`` and ``examples/`` — it records ``uncovered(model)`` (keys, reasons and
their order) of the model as :func:`~harness.reference.tree.prepare` leaves it, and the isolated model (``prepare``
then ``isolate``, compiled): its disable flags, actuator gears, tendons' stiffness, damping, frictionloss, armature
and limits, the fluid options and the geoms' fluid parameters. It imports only ``prepare``, ``uncovered`` and
``isolate``, so it runs on the code before and after a change of how they are written (a checkout of the earlier
commit on ``PYTHONPATH``), and ``--compare`` says which models differ, if any.
"""

from __future__ import annotations

import argparse
import json
import sys
import warnings
from pathlib import Path

import mujoco
import numpy as np

ROOT = Path(__file__).resolve().parent.parent


def models() -> dict[str, Path]:
    """Every model file this comparison reads, by a name that is the same in every checkout, in a fixed order
    (a collection absent here is skipped, and said)."""
    roots: list[tuple[str, Path, str]] = [
        ("menagerie", ROOT.parent / "shared" / "models" / "menagerie", "*/*.xml")]
    try:
        import dm_control
        roots.append(("dm_control/suite", Path(dm_control.__file__).parent / "suite", "*.xml"))
    except ImportError:
        print("dm_control is not installed: its suite is skipped", file=sys.stderr)
    try:
        import gymnasium
        roots.append(("gymnasium", Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets", "*.xml"))
    except ImportError:
        print("gymnasium is not installed: its assets are skipped", file=sys.stderr)
    roots += [("mjcf", ROOT / "mjcf", "*.xml"), ("examples", ROOT / "examples", "**/*.xml")]
    found = {}
    for name, root, pattern in roots:
        if not root.is_dir():
            print(f"{root} is absent: skipped", file=sys.stderr)
        for path in sorted(root.glob(pattern)):
            found[f"{name}/{path.relative_to(root)}"] = path
    return found


def _arrays(model: mujoco.MjModel) -> dict[str, object]:
    def listed(name: str) -> object:
        value = getattr(model, name, None)
        return None if value is None else np.asarray(value, dtype=float).tolist()

    return {
        "disableflags": int(model.opt.disableflags),
        "density": float(model.opt.density), "viscosity": float(model.opt.viscosity),
        "wind": np.asarray(model.opt.wind, dtype=float).tolist(),
        "geom_fluid": listed("geom_fluid"), "actuator_gear": listed("actuator_gear"),
        "tendon_stiffness": listed("tendon_stiffness"), "tendon_damping": listed("tendon_damping"),
        "tendon_frictionloss": listed("tendon_frictionloss"), "tendon_armature": listed("tendon_armature"),
        "tendon_limited": listed("tendon_limited"),
    }


def record(path: Path) -> dict[str, object]:
    """``uncovered`` of ``path`` prepared, and the isolated model's arrays (an error's text where one is raised)."""
    from harness.reference.tree import isolate, prepare, uncovered
    out: dict[str, object] = {}
    try:
        spec = mujoco.MjSpec.from_file(str(path))
        prepare(spec)
        out["uncovered"] = list(uncovered(spec.compile()).items())
    except Exception as exc:  # a model this MuJoCo cannot compile: recorded as such, before and after
        return {"error": f"{type(exc).__name__}: {exc}".splitlines()[0]}
    spec = mujoco.MjSpec.from_file(str(path))
    prepare(spec)
    isolate(spec)
    out["isolated"] = _arrays(spec.compile())
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, help="write the record of every model to this JSON file")
    parser.add_argument("--compare", nargs=2, type=Path, metavar=("BEFORE", "AFTER"),
                        help="compare two records; exit 1 where any model differs")
    args = parser.parse_args(argv)
    if args.compare:
        before, after = (json.loads(p.read_text()) for p in args.compare)
        differ = sorted(k for k in before.keys() | after.keys() if before.get(k) != after.get(k))
        with_gaps = sum(1 for v in after.values() if v.get("uncovered"))
        errors = sum(1 for v in after.values() if "error" in v)
        print(f"{len(after)} models ({with_gaps} with uncovered features, {errors} that do not compile): "
              f"{len(differ)} differ")
        for k in differ:
            print(f"  differs: {k}")
        return 1 if differ else 0
    warnings.simplefilter("ignore")
    records = {}
    paths = models()
    for i, (key, path) in enumerate(paths.items(), 1):
        records[key] = record(path)
        gaps = records[key].get("uncovered")
        print(f"[{i}/{len(paths)}] {key}: "
              f"{records[key].get('error') or (', '.join(k for k, _ in gaps) if gaps else 'nothing uncovered')}",
              file=sys.stderr)
    text = json.dumps(records, indent=1, sort_keys=True)
    if args.out:
        args.out.write_text(text)
    else:
        print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
