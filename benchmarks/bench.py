"""Where mjharness spends its time, and the speed targets as measured figures.

Run from the repository root::

    python benchmarks/bench.py                  # everything (minutes)
    python benchmarks/bench.py --no-run         # skip the full report with studies
    python benchmarks/bench.py --cases pendulum atwood --repeat 3

Four parts, each printed as a table:

1. Recorder vs MuJoCo (target 1): per case, the time to record every
   integrator's trajectory (state, constraint forces, energy, readings) against
   a bare ``mujoco.rollout`` of the same models and steps, as a ratio measured
   in this one run (best of ``--repeat``, the two taken in turn so that a burst
   of other load on a shared machine falls on both). Where the recorder reports its own
   split, "core" is the recording without evaluating the case's readings
   (``Case.mujoco_forces/series/invariants``: per sample in Python before the
   speed work, over the whole run from recorded fields since). Wall time: an
   RK4 run recomputes its fields on a second thread while it steps.
2. Per-case split (target 5): derivation (sympy, then the numeric functions
   lambdified at the model's parameters; or both loaded from the on-disk
   cache), reference solve, instantaneous layer, MuJoCo runs, comparison, the
   fast convergence study, and the case's report (HTML/JSON/Markdown with its
   plots), so that the next bottleneck is visible. The on-disk derivation cache
   (if this version has one) points at a directory that is empty when the
   benchmark starts.
3. The full report's split (target 4b): the cases, the studies, seed audit
   and plots, and the rest of the report, as ``mjharness run`` does them (both
   first steps on the process pool), then each study call's own seconds
   summed by kind.
4. Command lines (targets 3 and 4): ``mjharness check`` from a cold start
   (fresh process, empty derivation cache) and warm, on 1 and 2 workers, and
   the full report with studies (``mjharness run --out DIR``) from a cold start.

Timings on a shared machine vary; the load average is printed beside each
command-line figure, and ratios of part 1 are taken within one run.
"""

from __future__ import annotations

import argparse
import os
import platform
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

# every timing below starts with an empty derivation cache, unless told otherwise
_CACHE_HOME = tempfile.mkdtemp(prefix="mjharness-bench-cache-")
os.environ["XDG_CACHE_HOME"] = _CACHE_HOME

import mujoco  # noqa: E402
import numpy as np  # noqa: E402
from mujoco import rollout  # noqa: E402

from harness import cases  # noqa: E402
from harness.engine import recording  # noqa: E402
from harness.engine.integrators import available_integrators  # noqa: E402
from harness.engine.models import compile_model  # noqa: E402
from harness.engine.probe import Probe  # noqa: E402
from harness.outputs import drawings  # noqa: E402
from harness.outputs.report import write_report  # noqa: E402
from harness.pipeline import matrix as runner  # noqa: E402
from harness.pipeline.limits import load_limits  # noqa: E402
from harness.pipeline.pool import cpus, run_tasks  # noqa: E402
from harness.pipeline.run import run_case  # noqa: E402
from harness.pipeline.verdict import judge  # noqa: E402
from harness.reference import derivations  # noqa: E402
from harness.reference import solutions as refmod  # noqa: E402


def _best(fn: Callable[[], object], repeat: int) -> float:
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return min(times)


def _load() -> str:
    return f"load {os.getloadavg()[0]:.2f}"


def _recorder() -> str:
    return recording.recorder()


# ------------------------------------------------------------------ part 1
def _bare_rollout(model: mujoco.MjModel, probe: Probe, q0, qd0, steps: int) -> Callable[[], object]:
    data = mujoco.MjData(model)
    probe.binding.set_state(model, data, q0, qd0)
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state = np.zeros((1, mujoco.mj_stateSize(model, spec)))
    mujoco.mj_getState(model, data, state[0], spec)
    return lambda: rollout.rollout(model, data, state, nstep=steps)


def recorder_vs_rollout(selected, repeat: int) -> None:
    split = True  # the recorder reports its Python readings' share
    print(f"\n== 1. Recorder vs bare mujoco.rollout (target: ratio <= 1.2), best of {repeat}")
    print(f"   recorder: {_recorder()}")
    print(f"   {'case':24s} {'steps':>6s} {'rollout ms':>11s} {'record ms':>10s} {'ratio':>6s}"
          + (f" {'core ms':>8s} {'core ratio':>10s} {'readings ms':>12s}" if split else ""))
    totals = np.zeros(4)
    worst_core, any_loop = 0.0, False
    for case in selected:
        ref = case.reference(compile_model(case.mjcf))
        probe = case.probe(ref.dynamics)
        q0, qd0 = ref.q0(), ref.qd0()
        bare = rec = core = readings = 0.0
        steps, looped = 0, False
        for name in available_integrators():
            model = compile_model(case.mjcf, integrator=name)
            steps = round(case.horizon / model.opt.timestep)
            rollout_once = _bare_rollout(model, probe, q0, qd0, steps)
            fastest, best, best_split = np.inf, np.inf, {}
            for _ in range(repeat):  # in turn with the recording: a burst of other load falls on both
                fastest = min(fastest, _best(rollout_once, 1))
                timings: dict[str, float] = {}
                kwargs = {"timings": timings} if split else {}
                start = time.perf_counter()
                recording.record(model, probe, q0=q0, qd0=qd0, steps=steps, **kwargs)
                elapsed = time.perf_counter() - start
                if elapsed < best:
                    best, best_split = elapsed, timings
            bare += fastest
            rec += best
            looped |= "loop" in best_split  # the loop reads everything per sample: no separate share
            readings += best_split.get("readings", 0.0)
            core += best - best_split.get("readings", 0.0)
        totals += (bare, rec, core, readings)
        any_loop |= looped
        line = f"   {case.name:24s} {steps:6d} {bare * 1e3:11.2f} {rec * 1e3:10.2f} {rec / bare:6.2f}"
        if split and not looped:
            worst_core = max(worst_core, core / bare)
            line += f" {core * 1e3:8.2f} {core / bare:10.2f} {readings * 1e3:12.2f}"
        elif split:
            line += f" {'-':>8s} {'-':>10s} {'(in loop)':>12s}"
        print(line)
    bare, rec, core, readings = totals
    line = f"   {'all cases':24s} {'':6s} {bare * 1e3:11.2f} {rec * 1e3:10.2f} {rec / bare:6.2f}"
    separable = split and not any_loop
    if separable:
        line += f" {core * 1e3:8.2f} {core / bare:10.2f} {readings * 1e3:12.2f}"
    print(line)
    print(f"   TARGET 1: record / rollout = {rec / bare:.2f} over all cases"
          + (f"; without Python readings {core / bare:.2f} (worst case {worst_core:.2f})" if separable else ""))


# ------------------------------------------------------------------ part 2
def _clear_process_caches() -> None:
    for fn in (derivations.derivation, derivations._dynamics, derivations.minimal_derivation,
               derivations._minimal_dynamics):
        fn.cache_clear()
    refmod.clear_caches()


def _derive(system: str) -> None:
    deriv = derivations.derivation(system)
    for name in derivations.SYMBOLIC:
        getattr(deriv, name)
    derivations.minimal_derivation(system)


def per_case_split(selected) -> None:
    config = load_limits()
    cols = ("derivation", "reference", "instant", "mujoco", "compare", "converge", "report")
    print("\n== 5. Per-case time split, seconds (process caches cleared per case; the on-disk derivation cache "
          "starts empty, so a system's second case loads what its first one stored)")
    print(f"   {'case':24s}" + "".join(f" {c:>10s}" for c in cols) + f" {'total':>8s}")
    sums = dict.fromkeys(cols, 0.0)
    # part 1 solved references (and so derived every system): a cache of this part's own, empty
    os.environ["XDG_CACHE_HOME"] = tempfile.mkdtemp(prefix="mjharness-bench-split-")
    for case in selected:
        _clear_process_caches()
        start = time.perf_counter()
        _derive(case.system)
        derivation = time.perf_counter() - start
        result = run_case(case)
        t = dict(result.timings)
        row = {"derivation": derivation + t.get("derivation", 0.0)}
        for c in cols[1:-1]:
            row[c] = t.get(c, 0.0)
        checks = {case.name: judge(result, config.for_case(case.name))}
        with tempfile.TemporaryDirectory() as out:
            start = time.perf_counter()
            write_report(out, [result], checks, config_source=config.source)
            row["report"] = time.perf_counter() - start
        for c in cols:
            sums[c] += row[c]
        print(f"   {case.name:24s}" + "".join(f" {row[c]:10.3f}" for c in cols) + f" {sum(row.values()):8.3f}")
    print(f"   {'all cases':24s}" + "".join(f" {sums[c]:10.3f}" for c in cols) + f" {sum(sums.values()):8.3f}")
    print(f"   largest share: {max(sums, key=sums.get)} ({max(sums.values()) / sum(sums.values()):.0%})")


# ------------------------------------------------------------------ part 3
def _cli(args: list[str], cache: str) -> tuple[float, int, str]:
    env = dict(os.environ, XDG_CACHE_HOME=cache)
    start = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "harness.cli.entry", *args], cwd=ROOT, env=env,
                          capture_output=True, text=True, check=False)
    elapsed = time.perf_counter() - start
    tail = (proc.stdout.strip().splitlines() or [""])[-1]
    if proc.returncode not in (0, 1):
        tail = proc.stderr.strip().splitlines()[-1] if proc.stderr.strip() else tail
    return elapsed, proc.returncode, tail


def command_lines(run_report: bool, repeat: int) -> None:
    helptext = subprocess.run([sys.executable, "-m", "harness.cli.entry", "check", "--help"], cwd=ROOT,
                              capture_output=True, text=True, check=False).stdout
    jobs = "--jobs" in helptext
    print(f"\n== 3, 4. Command lines (best of {repeat}), cold start = fresh process and empty derivation cache; "
          f"{os.cpu_count()} CPUs")
    times = {}
    configs = [("1 worker", ["--jobs", "1"]), ("2 workers", ["--jobs", "2"])] if jobs else [("serial", [])]
    warm = tempfile.mkdtemp(prefix="mjharness-bench-warm-")
    _cli(["check"], warm)  # fills the warm cache: every warm run below finds its derivations stored
    for warmth in ("cold", "warm"):
        runs: dict[str, list] = {label: [] for label, _ in configs}
        for _ in range(repeat):  # interleaved, so that a busy moment of the machine hits both alike
            for label, extra in configs:
                cache = warm if warmth == "warm" else tempfile.mkdtemp(prefix="mjharness-bench-cold-")
                runs[label].append((_load(), *_cli(["check", *extra], cache)))
        for label, extra in configs:
            load, elapsed, code, tail = min(runs[label], key=lambda r: r[1])
            times[f"{label}, {warmth}"] = elapsed
            print(f"   mjharness check {' '.join(extra):10s} {elapsed:7.2f} s  exit {code}  ({warmth} cache, {load})"
                  f"  {tail if warmth == 'cold' else ''}".rstrip())
        if not jobs:
            break
    if jobs:
        print(f"   TARGET 3: check speedup 2 vs 1 workers = {times['1 worker, cold'] / times['2 workers, cold']:.2f}x "
              f"cold, {times['1 worker, warm'] / times['2 workers, warm']:.2f}x warm cache (target >= 1.7x)")
    else:
        print("   TARGET 3: n/a (this version has no --jobs option: one process, serial)")
    cold = min(v for k, v in times.items() if "warm" not in k)
    print(f"   TARGET 4a: check, all default cases, cold start = {cold:.1f} s (target <= 20 s)")
    if run_report:
        with tempfile.TemporaryDirectory() as out:
            load = _load()
            elapsed, code, tail = _cli(["run", "--out", out], tempfile.mkdtemp(prefix="mjharness-bench-cold-"))
        print(f"   mjharness run --out DIR     {elapsed:7.2f} s  exit {code}  ({load})  {tail}")
        print(f"   TARGET 4b: full report with studies, cold start = {elapsed:.1f} s (target <= 120 s)")


def _timed_study(kind: str, name: str):
    """drawings.study, with its duration (module-level: the pool's forked workers run it)."""
    start = time.perf_counter()
    result = drawings.study(kind, name)
    return result, time.perf_counter() - start


def report_split(selected) -> None:
    """What ``mjharness run --out DIR`` spends its time on, step by step as cmd_run does it, in this
    process (derivations already cached by the parts above), and each study call's own duration."""
    _clear_process_caches()
    steps: dict[str, float] = {}
    clock = time.perf_counter()
    results, checks, config = runner.run_all(selected, None)
    steps["cases (run_case, default --jobs)"] = time.perf_counter() - clock
    clock = time.perf_counter()
    pages, appendix, plots = drawings.draw_report(selected, results, jobs=None, studies=True)
    steps["studies, seed audit, plots (default --jobs)"] = time.perf_counter() - clock
    clock = time.perf_counter()
    with tempfile.TemporaryDirectory() as out:
        write_report(out, results, checks, config_source=config.source, pages=pages, appendix=appendix,
                     plots=plots)
    steps["report (HTML, JSON, Markdown, plots, stills)"] = time.perf_counter() - clock
    total = sum(steps.values())
    print(f"\n== 4b. Where the full report's time goes (in this process, {_load()}), seconds")
    for name, seconds in steps.items():
        print(f"   {name:46s} {seconds:7.2f}  {seconds / total:4.0%}")
    print(f"   {'total':46s} {total:7.2f}")
    calls = drawings.study_calls(selected)
    timed = run_tasks([(_timed_study, call) for call in calls], cpus())
    kinds: dict[str, float] = {}
    for (kind, _), (_, seconds) in zip(calls, timed, strict=True):
        kinds[kind] = kinds.get(kind, 0.0) + seconds
    print(f"   study calls ({len(calls)}), their own seconds summed by kind (on {cpus()} workers): "
          + ", ".join(f"{k} {v:.2f}" for k, v in kinds.items()))


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--cases", nargs="*", default=None, help="cases (default: all)")
    p.add_argument("--repeat", type=int, default=3, help="repeats of each timing in part 1 (best taken)")
    p.add_argument("--no-cli", dest="cli", action="store_false", help="skip part 3 (command lines)")
    p.add_argument("--no-run", dest="run", action="store_false",
                   help="skip the full report (its split, and the command in part 3)")
    p.add_argument("--cli-repeat", type=int, default=5, help="runs of each check command in part 3 (best taken)")
    args = p.parse_args(argv)
    selected = cases.select(args.cases or [])
    print(f"mjharness benchmark: MuJoCo {mujoco.__version__}, Python {platform.python_version()}, "
          f"{platform.machine()}, {os.cpu_count()} CPUs, {_load()}")
    recorder_vs_rollout(selected, args.repeat)
    per_case_split(selected)
    if args.run:
        report_split(selected)
    if args.cli:
        command_lines(args.run, args.cli_repeat)
    return 0


if __name__ == "__main__":
    sys.exit(main())
