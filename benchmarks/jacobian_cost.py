"""What the stiff solver's Jacobian of the tree reference costs: exact (dual numbers, every column) against the
former forward differences (position columns by √ε steps, velocity columns by the five-point stencil), in one run.

    python benchmarks/jacobian_cost.py [--repeat 7] [--out benchmarks/results_jacobian.txt]

Per robot of ``../shared/models/menagerie`` (Cassie, Panda, KUKA iiwa 14, Allegro hand; Robotiq 2F-85 and the
dm_control humanoid where present): the tree at controls inside their ranges, a state on its constraints, the
first-order right-hand side as :func:`analytic.solvers.solve` builds it (Baumgarte ω = 10), and
:func:`analytic.solvers.state_jacobian` both ways, alternated, median CPU time of ``--repeat`` calls each (the
machine is shared: CPU time is the steadier). Reported: each in ms and in right-hand-side evaluations of one
state, their ratio exact/FD, and the largest difference between the two Jacobians relative to the exact one's
largest entry in the same row (floored at 1e-12 of its largest: a row of zeros reads the differences' noise): the
forward differences' own error.
"""

from __future__ import annotations

import argparse
import datetime
import importlib.util
import statistics
import time
from pathlib import Path

import mujoco
import numpy as np

from analytic.solvers import project, state_jacobian
from analytic.tree import TreeDynamics
from harness.reference.tree import charts, prepare, read_tree

ROOT = Path(__file__).resolve().parent.parent
MENAGERIE = ROOT.parent / "shared" / "models" / "menagerie"
ROBOTS = (("Cassie", "agility_cassie/scene.xml"), ("Panda", "franka_emika_panda/scene.xml"),
          ("iiwa 14", "kuka_iiwa_14/scene.xml"), ("Allegro", "wonik_allegro/scene_right.xml"),
          ("Robotiq 2F-85", "robotiq_2f85/scene.xml"))


def _paths() -> list[tuple[str, Path]]:
    out = [(name, MENAGERIE / rel) for name, rel in ROBOTS if (MENAGERIE / rel).exists()]
    spec = importlib.util.find_spec("dm_control")
    if spec is not None and spec.origin:
        out.append(("humanoid (dm_control)", Path(spec.origin).parent / "suite" / "humanoid.xml"))
    return out


def robot(path: Path, seed: int = 1) -> tuple[TreeDynamics, np.ndarray]:
    """The tree at controls inside their ranges (elsewhere normal), and a state on its constraints."""
    spec = mujoco.MjSpec.from_file(str(path))
    prepare(spec)
    model = spec.compile()
    rng = np.random.default_rng(seed)
    lo, hi = (model.actuator_ctrlrange.T if model.nu else (np.zeros(0), np.zeros(0)))
    ctrl = np.where(model.actuator_ctrllimited, lo + (hi - lo) * rng.uniform(0.2, 0.8, model.nu),
                    rng.normal(size=model.nu))
    dyn = TreeDynamics.of(read_tree(model, chart=charts(model, mujoco.MjData(model).qpos), ctrl=ctrl))
    q, qd = project(dyn, rng.normal(scale=0.3, size=dyn.n), rng.normal(size=dyn.n), polish=True)
    return dyn, np.concatenate([q, qd])


def first_order(dyn: TreeDynamics, omega: float = 10.0):
    n = dyn.n

    def rhs(_t, y):
        qdd, _ = dyn.accelerations(y[..., :n], y[..., n:], stabilization=(2.0 * omega, omega * omega))
        return np.concatenate([y[..., n:], qdd], axis=-1)
    return rhs


def _cpu(fn, repeat: int) -> list[float]:
    out = []
    for _ in range(repeat):
        start = time.process_time()
        fn()
        out.append(time.process_time() - start)
    return out


def measure(name: str, path: Path, repeat: int) -> str:
    dyn, y = robot(path)
    rhs = first_order(dyn)
    f = rhs(0.0, y)
    exact = state_jacobian(dyn, rhs, 0.0, y, f)
    fd = state_jacobian(dyn, rhs, 0.0, y, f, differences=True)
    times = {"exact": [], "fd": [], "rhs": []}
    for _ in range(repeat):  # alternated, so that a load change on the shared machine falls on both
        times["exact"] += _cpu(lambda: state_jacobian(dyn, rhs, 0.0, y, f), 1)
        times["fd"] += _cpu(lambda: state_jacobian(dyn, rhs, 0.0, y, f, differences=True), 1)
        times["rhs"] += _cpu(lambda: rhs(0.0, y), 5)
    med = {k: statistics.median(v) for k, v in times.items()}
    rows = np.maximum(np.abs(exact).max(axis=1, keepdims=True), 1e-12 * np.abs(exact).max())
    differ = float(np.max(np.abs(fd - exact) / rows))
    return (f"{name:22} {dyn.n:>3} {dyn.rows:>4} {med['exact'] * 1e3:9.1f} {med['fd'] * 1e3:8.1f} "
            f"{med['exact'] / med['rhs']:8.0f} {med['fd'] / med['rhs']:7.0f} {med['exact'] / med['fd']:9.2f} "
            f"{differ:10.1e}")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--repeat", type=int, default=7)
    p.add_argument("--out", type=Path)
    args = p.parse_args()
    lines = [f"the stiff solver's Jacobian of the tree reference, exact vs forward differences; MuJoCo "
             f"{mujoco.__version__}, {datetime.date.today()}, median CPU of {args.repeat} alternated calls",
             f"  command: python benchmarks/jacobian_cost.py --repeat {args.repeat}",
             f"  {'model':22} {'n':>3} {'rows':>4} {'exact ms':>9} {'FD ms':>8} {'exact/f':>8} {'FD/f':>7} "
             f"{'exact/FD':>9} {'|FD-ex|':>10}"]
    print("\n".join(lines), flush=True)
    for name, path in _paths():
        line = "  " + measure(name, path, args.repeat)
        print(line, flush=True)
        lines.append(line)
    lines.append("  exact/f, FD/f: the Jacobian's cost in evaluations of f at one state; |FD-ex|: the largest "
                 "difference over the exact row's largest entry (floored at 1e-12 of the largest)")
    if args.out:
        args.out.write_text("\n".join(lines) + "\n", encoding="utf-8")


if __name__ == "__main__":
    main()
