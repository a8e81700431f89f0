"""The speed paths give the slow paths' answers: derivation cache, reused references, parallel cases.

- Derivations cached on disk load as the derivation itself; a corrupt,
  truncated or foreign entry, one altered since it was written (a constant
  changed), another system's entry in a system's slot and an unwritable cache
  directory fall back to deriving, silently and correctly; editing a system's
  source changes the key.
- Numeric dynamics cached on disk (lambdify's source at the model's
  parameters) give the freshly lambdified values, per parameter values; a
  check that finds them cached never imports sympy.
- A case's reference is solved once per process and reused for every shorter
  horizon, whatever asked first.
- ``--jobs N`` gives the serial run's figures, in registry order, and a case's
  error is still the one-line exit-2 message.
"""

from __future__ import annotations

import io
import json
import os
import pickle
import subprocess
import sys

import numpy as np
import pytest
import sympy as sp

from analytic import systems
from harness import cases
from harness.cli import commands as cli
from harness.core import cache, costs
from harness.core.errors import ModelMismatch
from harness.engine.models import compile_model, mjcf_path
from harness.outputs import drawings
from harness.pipeline import matrix as runner
from harness.reference import derivations
from harness.reference import solutions as refmod
from tests.conftest import PROGRESS_LINE, without_progress

SYSTEM = "pendulum"


@pytest.fixture
def cache_home(tmp_path, monkeypatch):
    """An empty cache directory, and no derivation cached in this process; the package's prebuilt dynamics
    unused (tests/test_prebuilt.py), so that a run finds nothing stored."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    monkeypatch.setenv("MJHARNESS_NO_PREBUILT", "1")
    monkeypatch.delenv("MJHARNESS_NO_CACHE", raising=False)
    _clear()
    yield tmp_path / "xdg" / "mjharness"
    _clear()


def _clear() -> None:
    for fn in (derivations.derivation, derivations.minimal_derivation, derivations._dynamics,
               derivations._minimal_dynamics):
        fn.cache_clear()


def _entry(root, kind: str = "derivation"):
    entries = sorted((root / kind).glob(f"{SYSTEM}-*.entry"))
    assert len(entries) == 1, entries
    return entries[0]


def _stored(entry, kind: str = "derivation"):
    """The value the entry file ``entry`` holds, read through the cache (None where it is unusable)."""
    header = cache.read_header(entry)
    return None if header is None else cache.load(kind, SYSTEM, header["key"], object)


def _same(a, b) -> bool:
    return all(sp.srepr(getattr(a, name)) == sp.srepr(getattr(b, name)) for name in derivations.SYMBOLIC)


def _python(*args: str, timeout: float = 60, **env: str | None) -> subprocess.CompletedProcess:
    """A fresh interpreter on ``args``, its environment this one's with ``env`` applied (None unsets)."""
    environ = dict(os.environ)
    for name, value in env.items():
        if value is None:
            environ.pop(name, None)
        else:
            environ[name] = value
    return subprocess.run([sys.executable, *args], capture_output=True, text=True, timeout=timeout, env=environ)


def _check_imports(cases_: str, *modules: str, cache_dir=None, **env: str | None) -> str:
    """The last line ``check CASES --jobs 1`` prints in a fresh process (``env`` applied to its
    environment): which of ``modules`` it imported, then main's exit code."""
    code = (f"import sys; from harness.cli import commands as cli; "
            f"code = cli.main(['check', {cases_}, '--jobs', '1']); "
            f"print(sorted({{m.split('.')[0] for m in sys.modules}} & {set(modules)!r}), code)")
    if cache_dir is not None:
        env = {"XDG_CACHE_HOME": str(cache_dir), "MJHARNESS_NO_CACHE": None} | env
    proc = _python("-c", code, timeout=300, **env)
    return proc.stdout.strip().splitlines()[-1] if proc.stdout.strip() else proc.stderr


def test_a_cached_derivation_is_the_derivation(cache_home):
    fresh = derivations.derivation(SYSTEM)
    entry = _entry(cache_home)
    derivations.derivation.cache_clear()
    loaded = derivations.derivation(SYSTEM)
    assert loaded is not fresh and _same(loaded, fresh)
    assert all(name in vars(loaded) for name in derivations.SYMBOLIC)  # nothing left to derive
    assert _entry(cache_home) == entry
    assert derivations.minimal_derivation(SYSTEM) is not None and _entry(cache_home, "minimal")


@pytest.mark.parametrize("damage", [b"", b"not a pickle", pickle.dumps({"a": "dict"}), "truncate"])
def test_a_damaged_entry_is_recomputed_silently(cache_home, damage):
    good = derivations.derivation(SYSTEM)
    entry = _entry(cache_home)
    entry.write_bytes(entry.read_bytes()[:100] if damage == "truncate" else damage)
    derivations.derivation.cache_clear()
    again = derivations.derivation(SYSTEM)
    assert _same(again, good)
    assert set(_stored(entry)) == set(derivations.SYMBOLIC)  # rewritten: the symbolic results, as data


def _pendulum_params() -> dict[str, float]:
    return systems.load(SYSTEM).params_from_model(compile_model(mjcf_path(SYSTEM)))


def _forcing(dyn, params) -> np.ndarray:
    q, qd = np.array([[0.3, params["l"]]]), np.array([[0.7, 0.0]])
    return dyn.forcing(q, qd)


def test_a_stored_constant_altered_since_it_was_written_is_recomputed(cache_home):
    """The numeric code is lambdify's source with the parameter values in it: an entry whose g was
    changed still reads and runs, and would give a wrong reference on every run. Its checksum
    no longer matches, so it is made anew and stored over."""
    params = _pendulum_params()
    good = _forcing(derivations.dynamics(SYSTEM, params), params)
    entry = _entry(cache_home, "dynamics")
    data = entry.read_bytes()
    g = repr(params["g"]).encode()
    assert g == b"9.81" and data.count(g) >= 1
    entry.write_bytes(data.replace(g, b"9.18"))  # same length: the data stays valid
    assert json.loads(entry.read_bytes().partition(b"\n")[2])  # still reads as data
    _clear()
    assert np.array_equal(_forcing(derivations.dynamics(SYSTEM, params), params), good)
    assert entry.read_bytes() == data  # stored over with the right value


def test_another_systems_entry_in_a_systems_slot_is_recomputed(cache_home):
    """An entry copied into another system's slot holds that other system; its header says so, and the
    slot's own system is made anew instead of being served the wrong one (or a confusing error)."""
    params = _pendulum_params()
    spring = systems.load("spring").params_from_model(compile_model(mjcf_path("spring")))
    derivations.dynamics(SYSTEM, params)
    own = derivations.dynamics("spring", spring)
    (slot,) = (cache_home / "dynamics").glob("spring-*.entry")
    slot.write_bytes(_entry(cache_home, "dynamics").read_bytes())
    _clear()
    again = derivations.dynamics("spring", spring)
    assert again.coordinates == own.coordinates != derivations.dynamics(SYSTEM, params).coordinates
    assert cache.read_header(slot)["name"] == "spring"


def test_an_unwritable_cache_still_derives(cache_home):
    cache_home.parent.mkdir(parents=True)
    cache_home.write_text("a file where the directory should be")
    assert _same(derivations.derivation(SYSTEM), derivations._derived(systems.build(SYSTEM)))
    assert cache.store("derivation", SYSTEM, "0" * 64, 1) is False


def test_the_cache_can_be_turned_off(cache_home, monkeypatch):
    monkeypatch.setenv("MJHARNESS_NO_CACHE", "1")
    derivations.derivation(SYSTEM)
    assert not cache_home.exists()


def test_cached_dynamics_are_the_lambdified_dynamics_per_parameter_values(cache_home):
    """The stored source, loaded with numpy alone, evaluates as sympy's own lambdify of the
    derivation at these values (its default printer and namespace); other parameter values are
    another entry, never the first one's."""
    params = systems.load(SYSTEM).params_from_model(compile_model(mjcf_path(SYSTEM)))
    assert derivations.dynamics(SYSTEM, params) and derivations.minimal_dynamics(SYSTEM, params) is not None
    assert _entry(cache_home, "dynamics") and _entry(cache_home, "minimal-dynamics")
    _clear()
    loaded = derivations.dynamics(SYSTEM, params)
    deriv = derivations.derivation(SYSTEM)
    values = {p: params[p.name] for p in deriv.system.params}
    rng = np.random.default_rng(0)
    q, qd = rng.normal(size=(50, 2)) + np.array([0.0, params["l"]]), rng.normal(size=(50, 2))
    for name, exprs, args in (("mass_matrix", deriv.mass_matrix, (q,)), ("forcing", deriv.forcing, (q, qd)),
                              ("jacobian", deriv.jacobian, (q,)), ("gamma", deriv.gamma, (q, qd)),
                              ("energy", sp.Matrix([deriv.energy]), (q, qd)), ("momenta", deriv.momenta, (q, qd))):
        direct = sp.lambdify([*deriv.system.q, *deriv.system.qd], sp.Matrix(exprs).subs(values), modules="numpy")
        for i in range(0, 50, 7):
            expected = np.asarray(direct(*q[i], *qd[i]), dtype=float)
            got = getattr(loaded, name)(*(a[i] for a in args))
            assert np.allclose(got.reshape(expected.shape), expected, rtol=1e-14, atol=1e-14), name
    heavier = derivations.dynamics(SYSTEM, dict(params, m=2 * params["m"]))
    assert len(list((cache_home / "dynamics").glob(f"{SYSTEM}-*.entry"))) == 2
    assert np.allclose(heavier.mass_matrix(q), 2 * loaded.mass_matrix(q), rtol=1e-15, atol=0)


def test_stored_numeric_code_that_does_not_run_is_made_anew(cache_home):
    """An entry that reads but whose code fails (a numpy without a function it names, a damaged
    edit) is replaced, not served to every later run."""
    from analytic.dynamics import Compiled

    params = systems.load(SYSTEM).params_from_model(compile_model(mjcf_path(SYSTEM)))
    good = derivations.dynamics(SYSTEM, params)
    entry = _entry(cache_home, "dynamics")
    compiled = _stored(entry, "dynamics")
    broken = [(n, src.replace("numpy.sin", "numpy.no_such_function"), r, c) for n, src, r, c in compiled.functions]
    assert broken != list(compiled.functions)
    assert cache.store("dynamics", SYSTEM, cache.read_header(entry)["key"],  # a valid entry: its code fails
                       Compiled(**{**vars(compiled), "functions": tuple(broken)}))
    _clear()
    again = derivations.dynamics(SYSTEM, params)
    q = np.array([[0.3, params["l"]]])
    assert np.array_equal(again.mass_matrix(q), good.mass_matrix(q))
    assert "no_such_function" not in entry.read_text(errors="ignore")  # stored over


def test_a_check_with_its_derivations_cached_never_imports_sympy(tmp_path):
    """sympy costs 0.15 s to import and 0.08 s to tear down in every process; with the numeric
    dynamics cached, check needs numpy and MuJoCo only (the first run derives and stores them), and scipy's
    convex hulls for the inertia audit (harness.inertia)."""
    first = _check_imports("'pendulum', 'hoop_ramp_contact'", "sympy", cache_dir=tmp_path,
                           MJHARNESS_NO_PREBUILT="1")  # not the package's: derived here
    again = _check_imports("'pendulum', 'hoop_ramp_contact'", "sympy", cache_dir=tmp_path,
                           MJHARNESS_NO_PREBUILT="1")
    assert first == "['sympy'] 0"  # derived: the probe can fail
    assert again == "[] 0"


def test_the_key_follows_the_sources(tmp_path):
    one, two = tmp_path / "system.py", tmp_path / "lagrangian.py"
    one.write_text("L = T - V\n")
    two.write_text("def derive(): ...\n")
    before = cache.source_key([one, two])
    assert cache.source_key([one, two]) == before
    one.write_text("L = T - V + 1\n")
    assert cache.source_key([one, two]) != before
    assert derivations._sources(SYSTEM)[0].name == f"{SYSTEM}.py"
    assert [p.relative_to(p.parents[1]).as_posix() for p in derivations._sources(SYSTEM)[1:]] == \
        ["systems/__init__.py", "analytic/lagrangian.py"]


def test_a_reference_is_solved_once_and_serves_shorter_horizons():
    case = cases.get("atwood")
    model = compile_model(case.mjcf)
    refmod.clear_caches()
    short_first = case.reference(model, t_end=0.25).solution
    full = case.reference(model).solution
    assert short_first is full and full.t_end == case.horizon
    longer = case.reference(model, t_end=2 * case.horizon).solution
    assert longer is not full and longer.t_end == 2 * case.horizon
    # order does not matter: a fresh process's solve of the same key is the same numbers
    refmod.clear_caches()
    again = case.reference(model).solution
    t = np.linspace(0, case.horizon, 97)
    assert np.array_equal(again.state(t)[0], full.state(t)[0])


def test_solutions_handed_between_processes_are_reused(monkeypatch):
    case = cases.get("spring")
    model = compile_model(case.mjcf)
    refmod.clear_caches()
    solved = case.reference(model).solution
    seeds = pickle.loads(pickle.dumps(refmod.export_solutions()))
    assert refmod.export_solutions() == {}  # exported once
    refmod.clear_caches()
    refmod.import_solutions(seeds)

    def no_solve(*args, **kwargs):
        raise AssertionError("an imported solution was solved again")

    monkeypatch.setattr(refmod, "solve", no_solve)
    reused = case.reference(model).solution
    t = np.linspace(0, case.horizon, 51)
    assert reused is not solved and reused.nfev == solved.nfev
    assert np.array_equal(reused.state(t)[1], solved.state(t)[1])


def test_a_stored_solution_is_the_solve_bit_for_bit(cache_home, monkeypatch):
    """A reference solved in an earlier process loads from the disk cache as the very bits a fresh solve makes
    (and with the cache off the solve is made again)."""
    case = cases.get("atwood")
    model = compile_model(case.mjcf)
    refmod.clear_caches()
    fresh = case.reference(model).solution
    assert len(list((cache_home / "solution").glob("atwood-*.entry"))) == 1
    refmod.clear_caches()

    def no_solve(*args, **kwargs):
        raise AssertionError("a stored solution was solved again")

    with monkeypatch.context() as m:
        m.setattr(refmod, "solve", no_solve)
        loaded = case.reference(model).solution
    t = np.linspace(0, case.horizon, 101)
    assert loaded is not fresh and (loaded.nfev, loaded.method) == (fresh.nfev, fresh.method)
    assert all(np.array_equal(a, b) for a, b in zip(loaded.state(t), fresh.state(t), strict=True))
    refmod.clear_caches()
    monkeypatch.setenv("MJHARNESS_NO_CACHE", "1")
    with monkeypatch.context() as m, pytest.raises(AssertionError, match="solved again"):
        m.setattr(refmod, "solve", no_solve)
        case.reference(model)


def test_a_stored_solution_serves_only_its_own_key(cache_home, monkeypatch):
    """Another step bound (which may send a stiff motion to Radau IIA, or refuse it), an entry damaged since it
    was written, or other code: the solve is made again. The code key covers the solvers, the dynamics, every
    system and the tree reader."""
    case = cases.get("spring")
    model = compile_model(case.mjcf)
    refmod.clear_caches()
    case.reference(model)
    refmod.clear_caches()
    monkeypatch.setenv("MJHARNESS_MAX_REFERENCE_STEPS", "50")  # the spring's solve takes more
    with pytest.raises(Exception, match="MJHARNESS_MAX_REFERENCE_STEPS"):
        case.reference(model)
    monkeypatch.delenv("MJHARNESS_MAX_REFERENCE_STEPS")
    refmod.clear_caches()
    (entry,) = (cache_home / "solution").glob("spring-*.entry")
    entry.write_bytes(entry.read_bytes()[:-1] + b"\x00")
    solved = []
    real = refmod.solve
    monkeypatch.setattr(refmod, "solve", lambda *a, **k: solved.append(1) or real(*a, **k))
    case.reference(model)
    assert solved == [1]
    names = {p.relative_to(p.parents[1]).as_posix() for p in refmod.code_files()}
    assert {"analytic/solvers.py", "analytic/dop853.py", "analytic/radau.py", "analytic/dynamics.py",
            "systems/spring.py", "tree/dynamics.py", "reference/tree.py", "reference/derivations.py"} <= names


def _check_json(*args: str, cache_dir) -> dict:
    proc = _python("-m", "harness.cli", "check", "--json", *args, timeout=300, XDG_CACHE_HOME=str(cache_dir))
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout)


def test_parallel_check_is_the_serial_check(tmp_path):
    names = ["spring", "atwood", "hoop_ramp"]
    serial = _check_json(*names, "--jobs", "1", cache_dir=tmp_path / "serial")  # each from a cold cache
    parallel = _check_json(*names, "--jobs", "2", cache_dir=tmp_path / "parallel")
    assert list(parallel["cases"]) == list(serial["cases"])
    for name in names:
        assert parallel["cases"][name]["figures"] == serial["cases"][name]["figures"]


def test_a_failing_case_in_a_pool_is_the_one_line_exit_2(monkeypatch, capsys):
    real = runner.run_case

    def run(case, options=None):  # the forked workers inherit this
        if case.name == "atwood":
            raise ModelMismatch("model has no equality 'string1'")
        return real(case, options)

    monkeypatch.setattr(runner, "run_case", run)
    assert cli.main(["check", "spring", "atwood", "--jobs", "2"]) == 2
    err = without_progress(capsys.readouterr().err)  # spring's line, if it finished first
    assert err.strip() == "mjharness: error: model has no equality 'string1'"


def test_the_progress_bar_counts_cases_done_in_workers(monkeypatch, cached_runs):
    # cached_runs here and in the two tests of lines below: the runs are the session's (what a pool's workers
    # compute is test_parallel_check_is_the_serial_check's and test_figures_only_workers_send_no_trajectories...)
    class Terminal(io.StringIO):
        def isatty(self) -> bool:
            return True

    bars = []
    real = runner.progress
    monkeypatch.setattr(runner, "progress", lambda *a, **k: bars.append(real(*a, **k)) or bars[-1])
    monkeypatch.setattr(sys, "stderr", Terminal())
    results, checks, _ = runner.run_all(cases.select(["spring", "atwood"]), None, jobs=2)
    assert [r.case.name for r in results] == ["spring", "atwood"] and list(checks) == ["spring", "atwood"]
    (bar,) = bars
    assert bar.n == bar.total == 2  # (a closed bar reads as disabled)
    assert "mjharness" in sys.stderr.getvalue() and "case" in sys.stderr.getvalue()


@pytest.mark.parametrize("jobs", [1, 2])
def test_a_log_gets_a_line_per_finished_case(jobs, capsys, monkeypatch, cached_runs):
    """Where stderr is not a terminal (a CI log), run and check print one line per case as it finishes, with
    its checks, its failures and its seconds; a tightened figure shows as one failure."""
    monkeypatch.setattr(sys.stderr, "isatty", lambda: False)
    results, checks, _ = runner.run_all(cases.select(["spring", "atwood"]), None, jobs=jobs, figures_only=True,
                                        lines=True)
    lines = capsys.readouterr().err.splitlines()
    assert sorted(lines) == sorted(
        f"case {r.case.name + ':':7s} {len(checks[r.case.name]):3d} checks, "
        f"{sum(not c.passed for c in checks[r.case.name]):2d} fail, {runner.worst_text(checks[r.case.name])} "
        f"({sum(r.timings.values()):.1f} s)" for r in results)
    assert all(len(checks[name]) > 0 for name in checks)
    runner.run_all(cases.select(["spring"]), None, jobs=jobs, figures_only=True)  # a library call: no lines
    assert capsys.readouterr().err == ""


@pytest.mark.parametrize("jobs", [1, 2])
def test_case_lines_stream_to_their_stream_in_the_order_the_cases_finish(jobs, capsys, monkeypatch, cached_runs):
    """check's lines (``out``): each case's line written and flushed as it finishes, terminal or not, in the
    order the cases finish (not the registry's), and no progress bar or log line besides them."""
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True)  # a terminal would get a bar without ``out``
    monkeypatch.setattr(runner, "PROGRESS_INTERVAL", 0.0)
    finished: list[str] = []
    real = runner.judge

    def judge(result, limits):  # called as each case comes in, just before its line
        finished.append(result.case.name)
        return real(result, limits)

    class Log(io.StringIO):
        flushes = 0

        def flush(self) -> None:
            self.flushes += 1

    monkeypatch.setattr(runner, "judge", judge)
    log = Log()
    _, checks, _ = runner.run_all(cases.select(["spring", "atwood", "pendulum"]), None, jobs=jobs,
                                  figures_only=True, out=log)
    lines = log.getvalue().splitlines()
    assert [ln.split()[1].rstrip(":") for ln in lines] == finished and sorted(finished) == sorted(checks)
    assert all(PROGRESS_LINE.fullmatch(ln) for ln in lines) and log.flushes >= len(lines)
    assert len({ln.index(" checks") for ln in lines}) == 1  # the names padded to the longest: aligned
    assert capsys.readouterr().err == ""  # no bar, no periodic line


@pytest.mark.parametrize("value", ["0", "-1", "two"])
def test_jobs_must_be_a_positive_integer(value, capsys):
    with pytest.raises(SystemExit) as info:
        cli.main(["check", "spring", "--jobs", value])
    assert info.value.code == 2
    assert "must be a positive integer" in capsys.readouterr().err


def test_figures_only_workers_send_no_trajectories_and_the_same_figures():
    """check and baseline read figures and settings only: their workers send no trajectories back
    (megabytes a case), and the figures are those of a run that kept them."""
    selected = cases.select(["spring", "atwood"])
    light, _, _ = runner.run_all(selected, None, jobs=2, figures_only=True)
    full, _, _ = runner.run_all(selected, None, jobs=2)
    assert all(r.reference is None and r.simulations == {} for r in light)
    assert all(r.reference is not None and r.simulations for r in full)
    assert [r.figures for r in light] == [r.figures for r in full]


def test_check_draws_nothing_and_never_imports_matplotlib():
    """matplotlib is imported on first plot (harness.plotting): a check, which draws nothing, does not
    pay for it."""
    assert _check_imports("'spring'", "matplotlib") == "[] 0"


def test_the_pool_starts_the_costliest_systems_first(monkeypatch):
    """Groups are a system's cases (derivation and reference made once), ordered by their cases'
    measured costs plus the system's measured derivation where it is not cached, so the cheapest
    fill the end; a case or derivation never measured counts costs.UNKNOWN."""
    selected = cases.all_cases()
    measured = {c.name: 0.1 + 0.05 * k for k, c in enumerate(selected)}
    derive = {s: 3.0 - 0.4 * k for k, s in enumerate(dict.fromkeys(c.system for c in selected))}  # against the cases
    monkeypatch.setattr(costs, "case_costs", lambda: measured)
    monkeypatch.setattr(derivations, "derivation_cost", derive.get)
    for derived in (lambda system: True, lambda system: False, lambda system: system != "hoop_ramp"):
        groups = runner.groups(selected, derived=derived)
        assert sorted(i for g in groups for i in g) == list(range(len(selected)))
        assert all(len({selected[i].system for i in g}) == 1 for g in groups)
        totals = [sum(measured[selected[i].name] for i in g)
                  + (0 if derived(selected[g[0]].system) else derive[selected[g[0]].system]) for g in groups]
        assert totals == sorted(totals, reverse=True)
    warm = [selected[g[0]].system for g in runner.groups(selected, derived=lambda system: True)]
    cold = [selected[g[0]].system for g in runner.groups(selected, derived=lambda system: False)]
    assert warm != cold  # the derivations change which systems cost most
    monkeypatch.setattr(costs, "case_costs", dict)  # nothing measured yet: every group costs UNKNOWN a case
    monkeypatch.setattr(derivations, "derivation_cost", lambda system: None)
    sizes = [len(g) for g in runner.groups(selected, derived=lambda system: True)]
    assert sizes == sorted(sizes, reverse=True)


def test_costs_are_measured_and_recorded_by_a_run(cache_home):
    """No hand-typed cost table: a run records each case's warm cost, and the cache the seconds of
    each derivation it computed; the next run's scheduler reads them."""
    assert costs.case_costs() == {} and derivations.derivation_cost("spring") is None
    runner.run_all(cases.select(["spring", "atwood"]), None, jobs=1, figures_only=True)
    recorded = costs.case_costs()
    assert set(recorded) == {"spring", "atwood"} and all(v > 0 for v in recorded.values())
    assert derivations.derivation_cost("spring") > 0 and derivations.derivation_cost("atwood") > 0


def test_preloading_sympy_for_forked_derivers_tolerates_a_module_sympy_lacks(monkeypatch):
    from analytic import lagrangian

    monkeypatch.setattr(lagrangian, "_LAZY", ("sympy.physics.units", "sympy.no_such_module"))
    lagrangian.preload()
    assert "sympy.physics.units" in sys.modules


def test_the_scheduler_sees_whether_a_derivation_is_stored(cache_home):
    assert not derivations.derivation_stored(SYSTEM)
    derivations.derivation(SYSTEM)
    assert derivations.derivation_stored(SYSTEM)


def test_the_command_flushes_what_c_printed_before_it_exits():
    """MuJoCo prints its warnings with C's printf: on a pipe they wait in C's buffer, which
    interpreter teardown would flush and os._exit does not."""
    code = ("import ctypes; from harness.cli import entry as command; ctypes.CDLL(None).printf(b'from C\\n'); "
            "command.exit_now(3)")
    proc = _python("-c", code, PYTHONUNBUFFERED=None)  # a pipe is then block-buffered, as in a CI log
    assert proc.returncode == 3 and proc.stdout == "from C\n", (proc.stdout, proc.stderr)


def test_the_command_exits_with_mains_code_and_flushed_output(tmp_path):
    """``mjharness`` (harness.cli.entry:entry) skips interpreter teardown: its output must still be
    whole and its exit code main's, for a listing (short: it sits in the buffer until flushed), a
    usage error and a bad argument."""
    env = {"XDG_CACHE_HOME": str(tmp_path), "PYTHONUNBUFFERED": None}  # a pipe is then block-buffered
    ok = _python("-m", "harness.cli.entry", "list", **env)
    assert ok.returncode == 0 and all(name in ok.stdout for name in cases.names()), (ok.stdout, ok.stderr)
    bad = _python("-m", "harness.cli.entry", "check", "no_such_case", **env)
    assert bad.returncode == cli.EXIT_USAGE and bad.stderr.startswith("mjharness: error:"), bad.stderr
    usage = _python("-m", "harness.cli.entry", "check", "--jobs", "0", **env)
    assert usage.returncode == 2 and "jobs" in usage.stderr


@pytest.mark.parametrize("user", [None, "egl"])
def test_the_command_loads_no_gl_binding_and_leaves_mujoco_gl_as_it_was(user):
    """The command's own process never renders (stills come from subprocesses that pick a backend
    from MUJOCO_GL), so it imports MuJoCo without GLFW; the variable is the user's again after."""
    code = ("import os, sys; from harness.cli import entry as command; command.import_mujoco_without_gl(); "
            "import mujoco; print('glfw' in sys.modules, os.environ.get('MUJOCO_GL'))")
    proc = _python("-c", code, MUJOCO_GL=user)
    assert proc.stdout.split() == ["False", str(user)], proc.stderr


BLAS_THREADS = (
    "import ctypes, glob, os, sys; from harness.cli import entry as command; command.import_mujoco_without_gl(); "
    "import numpy; libs = glob.glob(os.path.join(os.path.dirname(numpy.__file__), os.pardir, '*.libs', '*openblas*'));"
    "names = ('scipy_openblas_get_num_threads64_', 'openblas_get_num_threads64_', 'openblas_get_num_threads');"
    "found = [getattr(ctypes.CDLL(lib), n) for lib in libs for n in names if hasattr(ctypes.CDLL(lib), n)];"
    "print(found[0]() if found else 'none', os.environ.get('OPENBLAS_NUM_THREADS'))")


@pytest.mark.parametrize("user", [None, "2"])
def test_the_command_runs_numpy_on_one_blas_thread_unless_the_user_says_otherwise(user):
    """A command spreads its work over the cores itself, so numpy's OpenBLAS gets one thread (a user's
    OPENBLAS_NUM_THREADS stands); the variable is the user's again after."""
    proc = _python("-c", BLAS_THREADS, OPENBLAS_NUM_THREADS=user)
    threads, after = proc.stdout.split()
    if threads == "none":
        pytest.skip("this numpy's BLAS is not OpenBLAS (nothing to count its threads by)")
    assert (int(threads), after) == (1 if user is None else 2, str(user)), proc.stderr


def _square_or_fail(x: int) -> int:
    if x in (3, 5):
        raise ValueError(f"call {x} failed")
    return x * x


def test_a_pool_keeps_what_it_inherits_out_of_the_garbage_collector_while_it_lives():
    """gc.freeze before the fork (the workers' collections then leave inherited objects, and their
    memory pages, alone) and unfreeze after, whether the body ends or raises."""
    import gc

    from harness.pipeline.pool import fork_pool

    before = gc.get_freeze_count()
    with fork_pool(1) as pool:
        assert gc.get_freeze_count() > before
        assert pool.submit(abs, -2).result() == 2
    assert gc.get_freeze_count() == before
    with pytest.raises(KeyError), fork_pool(1):
        raise KeyError("in the body")
    assert gc.get_freeze_count() == before


@pytest.mark.parametrize("workers", [1, 2])
def test_pool_results_come_in_call_order_and_the_first_error_wins(workers):
    from harness.pipeline.pool import run_tasks

    done = []
    assert run_tasks([(_square_or_fail, (x,)) for x in (4, 2, 0, 1)], workers,
                     on_done=lambda i, r: done.append(i)) == [16, 4, 0, 1]
    assert sorted(done) == [0, 1, 2, 3]
    with pytest.raises(ValueError, match="call 3 failed"):  # the earlier of the two failing calls
        run_tasks([(_square_or_fail, (x,)) for x in (1, 3, 5, 2)], workers)


@pytest.mark.slow
def test_studies_and_plots_on_the_pool_are_the_serial_ones():
    """The report's layer 4, seed audit and plots on two workers: the same sections, JSON and
    images as one process."""
    selected = cases.select(["spring", "atwood", "hoop_ramp_contact"])
    results, _, _ = runner.run_all(selected, None, jobs=1)
    serial = drawings.draw_report(selected, results, jobs=1, studies=True)
    parallel = drawings.draw_report(selected, results, jobs=2, studies=True)
    assert parallel[1] == serial[1] and parallel[2] == serial[2]
    assert list(parallel[2]) == [c.name for c in selected] and all(parallel[2].values())
    assert [_without_timings(p) for p in parallel[0]] == [_without_timings(p) for p in serial[0]]


def _without_timings(page) -> tuple:
    """A report page (harness.outputs.page.Page) with every duration in its sections made alike."""
    import re

    return page.name, page.title, page.about, tuple(re.sub(r"\d+(\.\d+)? s\b", "T s", s) for s in page.sections)
