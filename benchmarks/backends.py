"""The accelerated backends: one batched call against a loop of single runs, and compile times.

Run from the repository root with a Python that has the backends installed
(``pip install '.[mjx,warp]'``)::

    python benchmarks/backends.py                      # Warp and MJX where installed
    python benchmarks/backends.py --backends warp --worlds 32 --steps 20

Three parts, each printed as a table; speed only as ratios taken in this one run
(a shared machine's absolute seconds vary), compile times separately:

1. Step ratio (goal ≥ 10×): ``--worlds`` runs of ``--steps`` steps of one case's
   model, as one batched call (Warp: ``nworld`` worlds stepped together; MJX:
   ``jax.vmap`` over the runs) against a loop of single-world steps on the same
   backend; the runs differ (initial angle), so nothing is shared but the model.
2. Recorded ratio: the same through the harness's backend interface,
   ``simulate_many`` of every run at once against one ``simulate_many`` per
   run: what a case's budget runs cost, recording and recomputed fields included.
3. Compile time: a fresh process's first batched step (and the recording's
   forward), with an empty kernel cache ("cold") and again with the cache the
   cold process left ("cached"), each in its own subprocess with its own
   ``XDG_CACHE_HOME``.
"""

from __future__ import annotations

import argparse
import copy
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

_COMPILE_SNIPPET = r"""
import sys, time
sys.path.insert(0, {root!r})
clock = time.perf_counter()
from harness import cases
from harness.engine import backends
from harness.engine.backends import Request
from harness.engine.models import compile_model
case = cases.get({case!r})
model = compile_model(case.mjcf)
ref = case.reference(model)
probe = case.probe(ref.dynamics)
backend = backends.get({backend!r})
setup = time.perf_counter() - clock
clock = time.perf_counter()
backend.simulate_many([Request(model, ref.q0(), ref.qd0(), 2)], probe)
print(f"RESULT {{setup:.3f}} {{time.perf_counter() - clock:.3f}}")
"""


def _load() -> float:
    return os.getloadavg()[0]


def _requests(case_name: str, worlds: int, steps: int):
    from harness import cases
    from harness.engine.backends import Request
    from harness.engine.models import compile_model

    case = cases.get(case_name)
    model = compile_model(case.mjcf)
    ref = case.reference(model)
    probe = case.probe(ref.dynamics)
    q0, qd0 = ref.q0(), ref.qd0()
    reqs = []
    for i in range(worlds):
        q = q0.copy()
        q[0] = q0[0] * (1.0 + 0.01 * i)  # distinct runs: the first coordinate spread by 1 % a run
        reqs.append(Request(model, q, qd0, steps))
    return model, probe, reqs


def warp_step_ratio(model, reqs, steps: int) -> tuple[float, float]:
    """(batched seconds, loop seconds): nworld worlds stepped together vs one world at a time."""
    import mujoco
    import mujoco_warp as mjw
    import warp as wp

    from harness.engine.backends import warp as W

    W.init()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    wm = mjw.put_model(model)
    d = mjw.put_data(model, data, nworld=len(reqs))
    mjw.step(wm, d)  # compiled (or loaded) before timing
    wp.synchronize()
    clock = time.perf_counter()
    for _ in range(steps):
        mjw.step(wm, d)
    wp.synchronize()
    batched = time.perf_counter() - clock
    clock = time.perf_counter()
    for _ in reqs:
        d1 = mjw.put_data(model, data, nworld=1)
        for _ in range(steps):
            mjw.step(wm, d1)
    wp.synchronize()
    loop = time.perf_counter() - clock
    return batched, loop


def mjx_step_ratio(model, reqs, steps: int) -> tuple[float, float]:
    """(batched seconds, loop seconds): jax.vmap over the runs vs one jitted single step per run."""
    import jax
    import jax.numpy as jnp
    import mujoco
    from mujoco import mjx

    model = copy.copy(model)  # MJX's put_model refuses the energy flag (the harness computes MJX's energy)
    model.opt.enableflags &= ~int(mujoco.mjtEnableBit.mjENBL_ENERGY)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    mx = mjx.put_model(model)
    dx = mjx.put_data(model, data)
    step = jax.jit(mjx.step)
    vstep = jax.jit(jax.vmap(mjx.step, in_axes=(None, 0)))
    batch = jax.tree_util.tree_map(lambda x: jnp.stack([x] * len(reqs)), dx)
    jax.block_until_ready(vstep(mx, batch))
    jax.block_until_ready(step(mx, dx))
    clock = time.perf_counter()
    for _ in range(steps):
        batch = vstep(mx, batch)
    jax.block_until_ready(batch)
    batched = time.perf_counter() - clock
    clock = time.perf_counter()
    for _ in reqs:
        one = dx
        for _ in range(steps):
            one = step(mx, one)
        jax.block_until_ready(one)
    loop = time.perf_counter() - clock
    return batched, loop


def recorded_ratio(backend_name: str, probe, reqs) -> tuple[float, float]:
    from harness.engine import backends

    backend = backends.get(backend_name)
    backend.simulate_many(reqs[:1], probe)  # both shapes compiled (or loaded) before timing: a jitted
    backend.simulate_many(reqs, probe)      # call compiles anew for each batch size
    clock = time.perf_counter()
    batched = backend.simulate_many(reqs, probe)
    batch_s = time.perf_counter() - clock
    clock = time.perf_counter()
    looped = [backend.simulate_many([r], probe)[0] for r in reqs]
    loop_s = time.perf_counter() - clock
    import numpy as np
    for a, b in zip(batched, looped, strict=True):  # batching must not change a number
        for p in a.positions:
            if not np.array_equal(a.positions[p], b.positions[p]):
                raise AssertionError(f"{backend_name}: batched and single runs differ at {p!r}")
    return batch_s, loop_s


def compile_times(backend_name: str, case: str) -> tuple[float, float]:
    """(cold, cached) seconds of a fresh process's first run, kernel cache empty then kept."""
    home = tempfile.mkdtemp(prefix=f"mjharness-bench-{backend_name}-")
    out = []
    for _ in range(2):
        env = dict(os.environ, XDG_CACHE_HOME=home)
        snippet = _COMPILE_SNIPPET.format(root=str(ROOT), case=case, backend=backend_name)
        proc = subprocess.run([sys.executable, "-c", snippet], env=env, capture_output=True, text=True,
                              check=True)
        line = next(x for x in proc.stdout.splitlines() if x.startswith("RESULT"))
        out.append(float(line.split()[2]))
    return out[0], out[1]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--backends", nargs="*", default=["warp", "mjx"])
    parser.add_argument("--case", default="pendulum")
    parser.add_argument("--worlds", type=int, default=32)
    parser.add_argument("--steps", type=int, default=20)
    parser.add_argument("--no-compile", action="store_true", help="skip the cold/cached compile timing")
    args = parser.parse_args(argv)
    os.environ.setdefault("XDG_CACHE_HOME", tempfile.mkdtemp(prefix="mjharness-bench-cache-"))
    import importlib.util

    import mujoco
    print(f"mjharness backends benchmark: MuJoCo {mujoco.__version__}, Python {platform.python_version()}, "
          f"{platform.machine()}, {os.cpu_count()} CPUs, load {_load():.2f}; no GPU (CPU backends only)")
    model, probe, reqs = _requests(args.case, args.worlds, args.steps)
    runners = {"warp": ("mujoco_warp", warp_step_ratio), "mjx": ("mujoco.mjx", mjx_step_ratio)}
    for name in args.backends:
        module, step_ratio = runners[name]
        try:
            present = importlib.util.find_spec(module) is not None
        except ModuleNotFoundError:
            present = False
        if not present:
            print(f"\n== {name}: not installed ({module}); skipped")
            continue
        print(f"\n== {name}: {args.case}, {args.worlds} runs of {args.steps} steps (load {_load():.2f})")
        batched, loop = step_ratio(model, reqs, args.steps)
        print(f"   1. step:     batched {batched:8.3f} s   loop of single runs {loop:8.3f} s   "
              f"ratio {loop / batched:6.1f}x  (goal >= 10x)")
        try:
            batched, loop = recorded_ratio(name, probe, reqs)
            print(f"   2. recorded: batched {batched:8.3f} s   loop of single runs {loop:8.3f} s   "
                  f"ratio {loop / batched:6.1f}x  (simulate_many, recording included; numbers identical)")
        except Exception as exc:  # the backend behind the interface may not exist yet on this branch
            print(f"   2. recorded: not measured ({type(exc).__name__}: {exc})")
        if not args.no_compile:
            cold, cached = compile_times(name, args.case)
            print(f"   3. compile:  cold {cold:7.1f} s   cached {cached:7.1f} s   "
                  f"(fresh process, first {args.case} run of 2 steps; load {_load():.2f})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
