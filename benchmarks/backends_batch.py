"""The batched call against a loop of single steps on the same accelerated backend, and compile times apart.

Run from the repository root, in an environment with the backend installed::

    python benchmarks/backends_batch.py --backend mjx --case pendulum --batch 8 --steps 1000

For a study's B runs (here the case's model at B timesteps h, h·(1 + 1/B), …: what a budget or a
convergence ladder sends), two ways to get the same B trajectories on the backend:

- loop: one jitted single step (``mjx.step``), called from Python per step and per run, reading the state
  back each step as a recorder must (B × N calls);
- batched: the harness's own call (:meth:`Backend.simulate_many`): the B runs as one ``jax.vmap`` of a
  ``jax.lax.scan`` of 250-step chunks, recording every field the layers read.

Each is timed warm (after a first call that compiles; best of ``--repeat``), and the first calls' compile
times are printed apart. The ratio loop / batched is the figure (goal ≥ 10); both are measured in this one
process on this machine, which is shared: the load average is printed beside them.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import jax
import numpy as np

from harness import cases
from harness.engine import backends
from harness.engine.backends.mjx import host_model
from harness.engine.models import compile_model


def _requests(case_name: str, batch: int, steps: int) -> tuple[list[backends.Request], object]:
    case = cases.get(case_name)
    base = compile_model(case.mjcf)
    ref = case.reference(base)
    h0 = float(base.opt.timestep)
    models = [compile_model(case.mjcf, timestep=h0 * (1 + k / batch)) for k in range(batch)]
    return [backends.Request(m, ref.q0(), ref.qd0(), steps) for m in models], case.probe(ref.dynamics)


def _loop(backend, requests, probe) -> float:
    """B × N single jitted steps from Python, the state read back every step."""
    step = jax.jit(backend.mjx.step)
    start = time.perf_counter()
    for r in requests:
        put = backend.mjx.put_model(host_model(r.model))
        d = backend._initial_data(r, put, probe)
        for _ in range(r.steps):
            d = step(put, d)
            jax.device_get((d.qpos, d.qvel))
    return time.perf_counter() - start


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--backend", default="mjx", choices=["mjx", "mjx-f64"])
    p.add_argument("--case", default="pendulum")
    p.add_argument("--batch", type=int, default=8)
    p.add_argument("--steps", type=int, default=1000)
    p.add_argument("--repeat", type=int, default=2)
    args = p.parse_args()
    backend = backends.get(args.backend)
    requests, probe = _requests(args.case, args.batch, args.steps)

    start = time.perf_counter()
    backend.simulate_many(requests, probe)
    batched_first = time.perf_counter() - start
    batched = min(_timed(lambda: backend.simulate_many(requests, probe)) for _ in range(args.repeat))

    one = requests[:1]
    start = time.perf_counter()
    _loop(backend, [backends.Request(one[0].model, one[0].q0, one[0].qd0, 1)], probe)
    loop_first = time.perf_counter() - start
    per_run = min(_loop(backend, one, probe) for _ in range(args.repeat))
    loop = per_run * len(requests)  # the loop's cost is B times one run's: each run is its own calls

    load = os.getloadavg()[0]
    steps = sum(r.steps for r in requests)
    print(f"backend {args.backend} ({backend.precision}, CPU), case {args.case}, {len(requests)} runs × "
          f"{args.steps} steps, load average {load:.1f}")
    print(f"  compile (first call, batched):       {batched_first - batched:8.2f} s")
    print(f"  compile (first call, single step):   {loop_first:8.2f} s")
    print(f"  batched call, warm:                  {batched:8.3f} s  ({steps / batched:,.0f} steps/s, "
          f"{args.steps / batched:,.0f} steps/s per world)")
    print(f"  loop of single steps, warm:          {loop:8.3f} s  ({steps / loop:,.0f} steps/s; one run "
          f"{per_run:.3f} s × {len(requests)})")
    print(f"  ratio loop / batched:                {loop / batched:8.1f}×")
    return 0


def _timed(fn) -> float:
    start = time.perf_counter()
    fn()
    return time.perf_counter() - start


if __name__ == "__main__":
    np.set_printoptions(precision=3)
    sys.exit(main())
