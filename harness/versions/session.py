"""``mjharness versions`` end to end: the releases' environments, their runs, the comparison or bisection."""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence

from harness.pipeline.executor import LOCAL, Executor
from harness.versions import changes as changes_mod
from harness.versions.bisect import Target, bisect
from harness.versions.changes_report import Comparison
from harness.versions.envs import Builder, EnvSpec
from harness.versions.releases import Release
from harness.versions.runs import NOISE_RUNS, CheckCommand, ReleaseRun, run_release, run_releases

__all__ = ["bisect_releases", "compare_releases"]


def _snapshot(run: ReleaseRun) -> changes_mod.Snapshot:
    assert run.doc is not None
    return changes_mod.snapshot(run.release, run.doc, [run.noise[p] for p in sorted(run.noise)])


def compare_releases(builder: Builder, releases: Sequence[Release], digest: str, command: CheckCommand, *,
                     extras: Sequence[str] = (), pinned: Sequence[str] = (), parallel: int = 1,
                     noise: Sequence[float] = NOISE_RUNS, refused: Mapping[Release, str] | None = None,
                     added: Mapping[Release, Sequence[str]] | None = None,
                     on_done: Callable[[ReleaseRun], None] | None = None,
                     executor: Executor = LOCAL) -> Comparison:
    """Every release run (``parallel`` at a time, or one Ray task each on a Ray ``executor``) and compared
    with the one before it; a release in ``refused`` is not built, its reason its run's error; ``added`` are
    packages of one release's environment besides ``extras`` (a backend's)."""
    start = time.perf_counter()
    specs = [_spec(r, extras, pinned, refused, added) for r in releases]
    runs = run_releases(builder, specs, digest, command, parallel=parallel, noise=noise, on_done=on_done,
                        executor=executor)
    snaps = [_snapshot(r) for r in runs if r.ok]
    found = changes_mod.changes(snaps)
    return Comparison(tuple(runs), tuple(snaps), tuple(found), check_args=command.args,
                      extras=_listed(extras, added), seconds=time.perf_counter() - start, perturbations=tuple(noise))


def bisect_releases(builder: Builder, releases: Sequence[Release], digest: str, command: CheckCommand,
                    target: Target, *, extras: Sequence[str] = (), pinned: Sequence[str] = (),
                    noise: Sequence[float] = NOISE_RUNS, refused: Mapping[Release, str] | None = None,
                    added: Mapping[Release, Sequence[str]] | None = None,
                    on_done: Callable[[ReleaseRun], None] | None = None) -> Comparison:
    """The first release at which ``target`` changed, running only the releases the bisection visits
    (one at a time: each depends on the last), with the comparison of those it ran; a release in
    ``refused`` is not built, its reason its run's error."""
    start = time.perf_counter()
    builder.wheel(digest)
    runs: dict[Release, ReleaseRun] = {}

    def run(release: Release) -> changes_mod.Snapshot | str:
        got = run_release(builder, _spec(release, extras, pinned, refused, added), digest, command, noise=noise)
        runs[release] = got
        if on_done is not None:
            on_done(got)
        return _snapshot(got) if got.ok else got.error

    outcome = bisect(target, releases, run)
    ordered = [runs[r] for r in sorted(runs)]
    snaps = [_snapshot(r) for r in ordered if r.ok]
    found = changes_mod.changes(snaps)
    if target.key is not None:
        found = [c for c in found if (c.case, c.figure) == target.key]
    else:
        found = [c for c in found if c.kind == "flip"]
    return Comparison(tuple(ordered), tuple(snaps), tuple(found), check_args=command.args,
                      extras=_listed(extras, added), seconds=time.perf_counter() - start, bisection=outcome,
                      perturbations=tuple(noise))


def _spec(release: Release, extras: Sequence[str], pinned: Sequence[str], refused: Mapping[Release, str] | None,
          added: Mapping[Release, Sequence[str]] | None) -> EnvSpec:
    return EnvSpec(release, (*extras, *(added or {}).get(release, ())), tuple(pinned),
                   (refused or {}).get(release, ""))


def _listed(extras: Sequence[str], added: Mapping[Release, Sequence[str]] | None) -> tuple[str, ...]:
    """Every extra package of the run, once: ``extras`` and each release's ``added``."""
    return tuple(dict.fromkeys([*extras, *(p for got in (added or {}).values() for p in got)]))
