"""Property tests: random and mutated configs, baselines, report JSON and MJCF attributes fed to the CLI.

Whatever the input, the command ends with exit 0, 1, 2 or 3 (a requirement not met); on 2 its stderr is
exactly one line and names no traceback; and nothing is half-written: a --junit file is there and whole
on 0, 1 and 3, absent on 2. Inputs are mutations of real ones (the shipped pendulum's config, baseline,
``check --json`` and MJCF), so that most examples get past the first check and reach the later ones.

In-process examples reuse the session's pendulum run (``cached_runs``); a model run is a real run (about
a second each), so those examples are few here and more in the slow, subprocess variant, which also
sees what MuJoCo would print from C.
"""

from __future__ import annotations

import copy
import json
import math
import subprocess
import sys
import tempfile
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from harness.cli.commands import main
from harness.core.errors import ModelError
from harness.engine.models import compile_model
from harness.outputs.jsondoc import dumps, json_doc
from harness.pipeline.limits import load_limits
from harness.pipeline.verdict import judge
from tests.conftest import shipped_run

CASE = "pendulum"
ROOT = Path(__file__).resolve().parent.parent
MJCF = ROOT / "mjcf" / f"{CASE}.xml"
FIGURES = sorted({*load_limits().for_case(CASE), *load_limits().for_case("spring")})


def _settings(examples: int) -> settings:
    return settings(max_examples=examples, deadline=None, database=None, derandomize=True,
                    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])




def _judge(code: int, err: str, junit: Path | None = None) -> None:
    """The properties every command keeps, whatever it was given."""
    assert code in (0, 1, 2, 3), (code, err)
    assert "Traceback" not in err, err
    if code == 2:
        assert err.endswith("\n") and err.count("\n") == 1 and err.startswith("mjharness: error: "), err
    if junit is not None:
        if code == 2:
            assert not junit.exists()
        else:
            ET.parse(junit)  # whole


def _mutated(text: str) -> st.SearchStrategy[str]:
    """``text`` with one character inserted, deleted or replaced."""
    position = st.integers(0, len(text))
    letter = st.sampled_from("._-aRK4 \"'[]=\\é")
    return st.one_of(
        st.tuples(position, letter).map(lambda p: text[:p[0]] + p[1] + text[p[0]:]),
        position.map(lambda i: text[:i] + text[i + 1:]),
        st.tuples(position, letter).map(lambda p: text[:p[0]] + p[1] + text[p[0] + 1:]))


# ------------------------------------------------------------------ configs
def _toml_value(value: object) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return "nan" if math.isnan(value) else ("inf" if value > 0 else "-inf") if math.isinf(value) else repr(value)
    if isinstance(value, int):
        return str(value)
    if isinstance(value, list):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    return json.dumps(value)  # a TOML basic string


FIGURE_NAMES = st.one_of(st.sampled_from(FIGURES), st.sampled_from(FIGURES).flatmap(_mutated),
                         st.text(min_size=1, max_size=12))
LIMITS = st.one_of(st.floats(), st.floats(min_value=1e-9, max_value=10), st.integers(-3, 10**6), st.booleans(),
                   st.text(max_size=4), st.lists(st.integers(0, 3), max_size=2))
CASES = st.one_of(st.sampled_from([CASE, "spring", "atwood", "hoop_plane"]), st.sampled_from([CASE]).flatmap(_mutated))
TABLES = st.dictionaries(CASES, st.dictionaries(FIGURE_NAMES, LIMITS, max_size=3), max_size=3)


MEASURES = st.one_of(st.sampled_from(["position", "drift.energy", "force", "violation", "velocity"]),
                     st.sampled_from(["position"]).flatmap(_mutated), st.text(min_size=1, max_size=8))


@st.composite
def configs(draw) -> str:
    """A config file's text: thresholds by case (plain or pyproject style, or under a wrong key), with
    requirements and the acceptance of known defects or not, or a mutation of a valid one, or anything."""
    tables = draw(TABLES)
    prefix = draw(st.sampled_from(["", "tool.mjharness.", "tool.black."]))
    section = draw(st.sampled_from([f"{prefix}thresholds", "limits"]))
    text = "".join(f"[{section}.{json.dumps(case)}]\n" + "".join(f"{json.dumps(fig)} = {_toml_value(v)}\n"
                                                                  for fig, v in figs.items())
                   for case, figs in tables.items())
    required = draw(st.dictionaries(MEASURES, LIMITS, max_size=2))
    if required:
        text += f"[{prefix}require]\n" + "".join(f"{json.dumps(m)} = {_toml_value(v)}\n" for m, v in required.items())
    if draw(st.booleans()):
        text = f"{prefix and '[' + prefix[:-1] + ']'}\naccept_known_defects = {_toml_value(draw(LIMITS))}\n" + text
    return draw(st.one_of(st.just(text), _mutated(text) if text else st.just(text), st.text(max_size=60)))


@_settings(60)
@given(text=configs())
def test_any_config(text, cached_runs, capsys):
    with tempfile.TemporaryDirectory() as tmp:
        config, junit = Path(tmp) / "config.toml", Path(tmp) / "ci" / "junit.xml"
        config.write_text(text, encoding="utf-8", errors="surrogatepass")
        capsys.readouterr()
        code = main(["check", CASE, "--config", str(config), "--junit", str(junit)])
        _judge(code, capsys.readouterr().err, junit)


# --------------------------------------------------------- baselines, reports
JSON = st.recursive(st.none() | st.booleans() | st.floats() | st.integers() | st.text(max_size=6),
                    lambda inner: st.lists(inner, max_size=2) | st.dictionaries(st.text(max_size=6), inner, max_size=2),
                    max_leaves=4)


def _documents() -> dict[str, dict]:
    """A committed baseline and a ``check --json`` document of the case: what mutations start from."""
    result = shipped_run(CASE)
    checks = {CASE: judge(result, load_limits().for_case(CASE))}
    return {"baseline": json.loads((ROOT / "reports" / "baseline" / f"{CASE}.json").read_text()),
            "report": json.loads(dumps(json_doc([result], checks)))}


def _anchors(doc: dict) -> list[tuple]:
    """Where the readers look (a case, its figures, an entry, its value, a check, the schema, the versions):
    the places most mutations go, so that rare paths are reached too."""
    figure = next(iter(doc["cases"][CASE]["checks"]))
    return [(), ("schema",), ("versions",), ("versions", "mujoco"), ("cases",), ("cases", CASE),
            ("cases", CASE, "figures"), ("cases", CASE, "figures", figure), ("cases", CASE, "figures", figure, "value"),
            ("cases", CASE, "checks"), ("cases", CASE, "checks", figure), ("cases", CASE, "checks", figure, "passed"),
            ("cases", CASE, "checks", figure, "threshold")]


@st.composite
def mutated_documents(draw, original: dict) -> str:
    """``original`` with one to three entries replaced, removed or added, where the readers look or anywhere
    (a random walk), as JSON text (NaN and Infinity as Python writes them), or its text cut short."""
    doc = copy.deepcopy(original)
    for _ in range(draw(st.integers(1, 3))):
        parent, key, node = None, None, doc
        path = draw(st.one_of(st.sampled_from(_anchors(original)), st.lists(st.integers(0, 99), max_size=5)))
        for step in path:
            keys = sorted(node) if isinstance(node, dict) else list(range(len(node))) if isinstance(node, list) else []
            if isinstance(step, int):  # a random walk: the step-th key, whatever it is
                step = keys[step % len(keys)] if keys else None
            if step not in keys:
                break
            key = step
            parent, node = node, node[key]
        action, value = draw(st.sampled_from(["replace", "remove", "add"])), draw(JSON)
        if parent is None:
            doc = value if action == "replace" else doc
        elif action == "replace":
            parent[key] = value
        elif action == "remove":
            del parent[key]
        elif isinstance(node, dict):
            node[draw(st.text(max_size=6))] = value
    text = json.dumps(doc)
    return draw(st.one_of(st.just(text), st.integers(0, len(text)).map(lambda n: text[:n])))


@pytest.fixture(scope="module")
def documents():
    return _documents()


@_settings(80)
@given(data=st.data())
def test_any_baseline_or_report(data, documents, cached_runs, capsys):
    kind = data.draw(st.sampled_from(sorted(documents)))
    text = data.draw(mutated_documents(documents[kind]))
    command = data.draw(st.sampled_from(["compare", "diff-old", "diff-new"]))
    with tempfile.TemporaryDirectory() as tmp:
        bad, good = Path(tmp) / "bad.json", Path(tmp) / "good.json"
        bad.write_text(text)
        good.write_text(json.dumps(documents[kind]))
        args = {"compare": ["baseline", CASE, "--compare", str(bad)], "diff-old": ["diff", str(bad), str(good)],
                "diff-new": ["diff", str(good), str(bad)]}[command]
        capsys.readouterr()
        code = main(args)
        _judge(code, capsys.readouterr().err)
        assert sorted(p.name for p in Path(tmp).iterdir()) == ["bad.json", "good.json"]  # nothing written


# ----------------------------------------------------------------- models
NUMBERS = st.one_of(st.sampled_from(["nan", "inf", "-inf", "0", "-1", "1e308", "1e-300", "abc", ""]),
                    st.floats(min_value=-1e3, max_value=1e3).map(repr))
# (attribute as the model writes it, how many numbers it holds); the timestep keeps its runs short
ATTRIBUTES = [('gravity="0 0 -9.81"', 3), ('solref="0.002 1"', 2), ('solimp="0.9999 0.9999 0.001 0.5 2"', 5),
              ('mass="1"', 1), ('diaginertia="1e-10 1e-10 1e-10"', 3),
              ('damping="0" armature="0"/>\n      <joint name="r"', 1), ('iterations="100"', 1),
              ('tolerance="1e-12"', 1)]
TIMESTEPS = st.sampled_from(["nan", "inf", "0", "-0.001", "abc", "0.001", "0.002", "0.01", "1.0"])


@st.composite
def models(draw) -> str:
    """The case's MJCF with one attribute's numbers replaced by random ones, or its timestep."""
    text = MJCF.read_text()
    if draw(st.booleans()):
        return text.replace('timestep="0.001"', f'timestep="{draw(TIMESTEPS)}"')
    original, count = draw(st.sampled_from(ATTRIBUTES))
    name = original.split("=")[0]
    numbers = " ".join(draw(st.lists(NUMBERS, min_size=count, max_size=count)))
    return text.replace(original, f'{name}="{numbers}"' + original.split('"', 2)[2], 1)


@_settings(150)
@given(text=models())
def test_any_model_compiles_or_is_a_model_error(text):
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "model.xml"
        path.write_text(text)
        try:
            model = compile_model(path)
        except ModelError as exc:
            assert "\n" not in str(exc)
        else:
            assert model.opt.timestep > 0 and math.isfinite(model.opt.timestep)


@_settings(6)
@given(text=models())
def test_any_model_through_check(text, capsys):
    with tempfile.TemporaryDirectory() as tmp:
        path, junit = Path(tmp) / "model.xml", Path(tmp) / "junit.xml"
        path.write_text(text)
        capsys.readouterr()
        code = main(["check", "--case", CASE, "--mjcf", str(path), "--junit", str(junit)])
        _judge(code, capsys.readouterr().err, junit)


@pytest.mark.slow
@_settings(20)
@given(text=models())
def test_any_model_through_run_in_a_process(text):
    """As a user runs it: every byte MuJoCo might print from C is on this stderr, and on exit 2 the
    output directory holds nothing."""
    with tempfile.TemporaryDirectory() as tmp:
        path, out = Path(tmp) / "model.xml", Path(tmp) / "report"
        path.write_text(text)
        proc = subprocess.run([sys.executable, "-m", "harness.cli", "run", "--case", CASE, "--mjcf", str(path),
                               "--out", str(out), "--junit", str(out / "junit.xml")],
                              capture_output=True, text=True, timeout=300, cwd=tmp)
        _judge(proc.returncode, proc.stderr, out / "junit.xml")
        written = sorted(p.relative_to(out).as_posix() for p in out.rglob("*") if p.is_file()) if out.exists() else []
        assert written == ([] if proc.returncode == 2 else [".mjharness-manifest.json", f"cases/{CASE}.html",
                                                            "inertia.html", "junit.xml", "report.html",
                                                            "report.json", "summary.md"])
        if written:
            assert json.loads((out / "report.json").read_text())["cases"][CASE]
        assert sorted(p.name for p in Path(tmp).iterdir()) == ["model.xml", *(["report"] if written else [])]
