"""The zoo: models nobody here wrote, installed from PyPI, each judged against its own kinematic tree.

The zoo is found, not listed: every MJCF file that the installed packages of
:data:`SOURCES` ship (dm_control's suite, Gymnasium's MuJoCo assets). A package
that is not installed gives no models and one line saying what it would give and
the pip command that installs it, never an error.

Each model runs case-free, exactly as ``mjharness check --mjcf FILE`` runs it
(:func:`harness.pipeline.entry.own_case`, then :func:`harness.validate`, which runs
:func:`harness.pipeline.entry.evaluate`: every layer and budget, every integrator unless told otherwise),
and ends in one of four verdicts:

- ``pass``: every check within its budget's limit (``check`` exits 0);
- ``fail``: a finding, named by the check that decides it (the failed check furthest over
  its limit, or a run that could not be measured): figure, measured, unexplained, limit
  and the budget's parts (``check`` exits 1). A finding is about the model or MuJoCo,
  not an error of the harness;
- ``refused``: a model the tree reference cannot read (no degrees of freedom, flex,
  plugins, ...) or whose reference cannot be integrated, in one line (``check`` exits 2);
- ``crashed``: anything else raised: a bug of the harness, with the exception's last line;
- ``unfinished``: stopped at the zoo's time limit (``--timeout``) before a verdict.

Each model's wall time is measured from reading the file to the verdict.
"""

from __future__ import annotations

import contextlib
import dataclasses
import html
import importlib.util
import math
import signal
import time
import traceback
import xml.etree.ElementTree as ET
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, cast

import mujoco
import numpy as np

from analytic.dop853 import IntegrationError
from analytic.solvers import TooManySteps
from harness.api import validate
from harness.core import VERSION
from harness.core.checks import Check
from harness.engine.models import compile_model
from harness.outputs.studies.engine_faults import cell as fault_cell
from harness.outputs.studies.injection import cell as injection_cell
from harness.pipeline.carry import Carried, pack
from harness.pipeline.entry import own_case
from harness.pipeline.executor import LOCAL, Executor
from harness.pipeline.pool import run_tasks
from harness.reference.tree import prepare, uncovered
from harness.studies.engine_faults import CLAIMED, FAULTS, SIZES, UNITS, Caught, smallest_caught
from harness.studies.injection import SIZES_SEARCHED, Injection, smallest_injection
from harness.versions.sweep import Model as SweepModel

__all__ = ["Injection", "ZooResult", "discover", "folder_models", "run", "select", "sweep_models", "zoo_json",
           "zoo_markdown"]

PASS, FAIL, REFUSED, CRASHED, UNFINISHED = "pass", "fail", "refused", "crashed", "unfinished"
EXIT = {PASS: 0, FAIL: 1, REFUSED: 2, CRASHED: 2, UNFINISHED: None}
"""What ``mjharness check --mjcf FILE`` exits with for each verdict (a crash: 2, the harness's error; unfinished:
stopped at the zoo's time limit, no exit)."""


class TimeLimit(BaseException):
    """Raised in a zoo task that runs past its time limit (a BaseException: no ``except Exception`` on the way
    swallows it)."""


@contextlib.contextmanager
def time_limit(seconds: float | None) -> Iterator[None]:
    """:class:`TimeLimit` raised in this (main) thread after ``seconds`` (None: no limit), by SIGALRM."""
    if not seconds:
        yield
        return

    def expire(_signum, _frame):
        raise TimeLimit(f"stopped at the time limit of {seconds:g} s")

    previous = signal.signal(signal.SIGALRM, expire)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


@dataclass(frozen=True)
class Source:
    """A PyPI package that ships MuJoCo models: where in it they lie, and the models it gave when this
    was written (listed only to say what a missing package would give)."""

    package: str
    folder: str
    pip: str
    expected: tuple[str, ...]


SOURCES: tuple[Source, ...] = (
    Source("dm_control", "suite", "pip install dm_control",
           ("acrobot", "ball_in_cup", "cartpole", "cheetah", "dog", "finger", "fish", "hopper", "humanoid",
            "humanoid_CMU", "lqr", "manipulator", "pendulum", "point_mass", "quadruped", "reacher", "stacker",
            "swimmer", "walker")),
    Source("gymnasium", "envs/mujoco/assets", "pip install gymnasium",
           ("ant", "half_cheetah", "hopper", "humanoid", "humanoidstandup", "inverted_double_pendulum",
            "inverted_pendulum", "point", "pusher", "pusher_v5", "reacher", "swimmer", "walker2d", "walker2d_v5")),
)


@dataclass(frozen=True)
class ZooModel:
    """One model of the zoo: ``name`` is ``package/stem`` (``dm_control/acrobot``)."""

    name: str
    package: str
    path: Path

    @property
    def stem(self) -> str:
        return self.path.stem


@dataclass(frozen=True)
class Skipped:
    """A source whose package is not installed: the models it would give, and how to install it."""

    package: str
    pip: str
    models: tuple[str, ...]

    def line(self) -> str:
        return (f"{self.package}: not installed, {len(self.models)} models skipped "
                f"({', '.join(self.models)}); install with: {self.pip}")


def _package_dir(package: str) -> Path | None:
    """Where ``package`` is installed (None where it is not), found without importing it."""
    try:
        spec = importlib.util.find_spec(package)
    except (ImportError, ValueError):
        return None
    if spec is None or not spec.submodule_search_locations:
        return None
    return Path(next(iter(spec.submodule_search_locations)))


def discover(sources: Sequence[Source] = SOURCES) -> tuple[tuple[ZooModel, ...], tuple[Skipped, ...]]:
    """Every model file the installed sources ship, sorted by name, and the sources not installed."""
    models: list[ZooModel] = []
    skipped: list[Skipped] = []
    for source in sources:
        root = _package_dir(source.package)
        if root is None or not (root / source.folder).is_dir():
            skipped.append(Skipped(source.package, source.pip,
                                   tuple(f"{source.package}/{m}" for m in source.expected)))
            continue
        models += [ZooModel(f"{source.package}/{p.stem}", source.package, p)
                   for p in sorted((root / source.folder).glob("*.xml"))]
    return tuple(models), tuple(skipped)


FOLDER_FILES = 10_000
"""The most ``.xml`` files :func:`folder_models` reads in a folder (Menagerie holds about 300): a folder past it is
refused in one line rather than read for minutes."""
FOLDER_FILE_BYTES = 16_000_000
"""The largest ``.xml`` file :func:`folder_models` reads to find its includes (Menagerie's largest is under 1 MB);
a larger one is not an entry, and said so."""


def printable(text: str) -> str:
    """``text`` with every character a terminal would act on (a control character, an escape) as ``?``: a file's
    name as it lands in a line."""
    return "".join(c if c.isprintable() else "?" for c in text)


def _included(path: Path, root: ET.Element) -> set[Path]:
    """The files ``path``'s ``<include file=...>`` elements name, resolved as MuJoCo resolves them (relative to the
    including file's folder)."""
    return {(path.parent / inc.get("file", "")).resolve() for inc in root.iter("include") if inc.get("file")}


def folder_models(folder: Path | str) -> tuple[tuple[ZooModel, ...], tuple[str, ...]]:
    """Every MJCF entry of a folder laid out like MuJoCo Menagerie's (a folder per robot, each with its entry files
    such as ``scene.xml`` and the robot's own ``<robot>.xml``, its meshes in a subfolder), and the files passed over
    with why. An entry is every ``.xml`` file under ``folder`` whose root element is ``<mujoco>`` and that no other
    such file ``<include>``s: ``scene.xml`` (which includes ``panda.xml``) is an entry and ``panda.xml`` is not;
    ``hand.xml``, included by none, is one. Whether it compiles is for its verdict to say (refused, in one line).
    Each is named by its path under ``folder`` without ``.xml`` (``franka_emika_panda/scene``), its package the
    robot's folder. ValueError (one line) for a folder that is none, holds no entry, or more than
    :data:`FOLDER_FILES` files."""
    folder = Path(folder)
    if not folder.is_dir():
        raise ValueError(f"--folder {printable(str(folder))!r} is not a folder; accepted: a folder of robot "
                         "folders, each with its MJCF files (MuJoCo Menagerie's layout)")
    files: list[Path] = []
    for path in sorted(folder.rglob("*.xml")):
        if len(files) == FOLDER_FILES:
            raise ValueError(f"--folder {printable(str(folder))!r} holds more than {FOLDER_FILES} .xml files; "
                             "accepted: a folder of robots (point it at fewer)")
        if path.is_file():
            files.append(path)
    roots: dict[Path, ET.Element] = {}
    passed: list[str] = []
    for path in files:
        where = printable(path.relative_to(folder).as_posix())
        if path.stat().st_size > FOLDER_FILE_BYTES:
            passed.append(f"{where}: larger than {FOLDER_FILE_BYTES / 1e6:g} MB, not read")
            continue
        try:
            root = ET.parse(path).getroot()
        except (ET.ParseError, OSError, ValueError) as exc:
            passed.append(f"{where}: not XML ({printable(' '.join(str(exc).split()))})")
            continue
        if root.tag == "mujoco":
            roots[path.resolve()] = root
    included = set().union(*(_included(p, r) for p, r in roots.items())) if roots else set()
    entries = [p for p in files if p.resolve() in roots and p.resolve() not in included]
    if not entries:
        raise ValueError(f"--folder {printable(str(folder))!r} holds no MJCF entry (an .xml file whose root is "
                         "<mujoco>, included by no other)")
    models = []
    for path in entries:
        relative = path.relative_to(folder)
        name = relative.with_suffix("").as_posix()
        package = relative.parts[0] if len(relative.parts) > 1 else folder.resolve().name
        models.append(ZooModel(name, package, path))
    return tuple(models), tuple(passed)


def select(names: Sequence[str], models: Sequence[ZooModel], skipped: Sequence[Skipped] = ()) -> tuple[ZooModel, ...]:
    """The models named (``package/stem``, or a stem alone: every package's model of that stem); all where
    none is named. ValueError listing the known names for a name that matches none."""
    if not names:
        return tuple(models)
    chosen: dict[str, ZooModel] = {}
    for name in names:
        found = [m for m in models if name in (m.name, m.stem)]
        if not found:
            missing = [s for s in skipped if name in s.models or any(m.endswith(f"/{name}") for m in s.models)]
            if missing:
                raise ValueError(f"zoo model {name!r} needs {missing[0].package}: {missing[0].pip}")
            raise ValueError(f"unknown zoo model {name!r}; known: {', '.join(m.name for m in models)}")
        chosen |= {m.name: m for m in found}
    return tuple(chosen.values())


def sweep_models(names: Sequence[str]) -> tuple[SweepModel, ...]:
    """The models of ``mjharness sweep``, each once in the order given: an MJCF file (a path ending in ``.xml``
    or an existing file), a zoo model (``package/stem`` or a stem: every package's model of that stem), or a
    case (``case:NAME``). ValueError (one line) saying what is accepted for a name that is none of them."""
    from harness import cases  # lazy: only the sweep's planning reads the cases

    if not names:
        raise ValueError("name at least one model: a zoo model (dm_control/acrobot, or a stem), an MJCF file, "
                         "or a shipped case (case:pendulum)")
    models, skipped = discover()
    out: dict[str, SweepModel] = {}
    for name in names:
        if name.startswith("case:"):
            cases.select([name.removeprefix("case:")])  # an unknown case: one line naming the known ones
            out.setdefault(name, SweepModel(name, "case"))
        elif name.endswith(".xml") or Path(name).is_file():
            if not Path(name).is_file():
                raise ValueError(f"MJCF file {name!r} does not exist")
            out.setdefault(name, SweepModel(name, "file", str(Path(name).resolve())))
        else:
            try:
                found = select([name], models, skipped)
            except ValueError as exc:
                raise ValueError(f"{exc}; a model is a zoo name, an MJCF file (.xml) or a case (case:NAME)") from None
            for m in found:
                root = _package_dir(m.package)
                within = m.path.relative_to(root).as_posix() if root is not None else ""
                out.setdefault(m.name, SweepModel(m.name, "zoo", str(m.path), m.package, within))
    return tuple(out.values())


# ---- what a model has ---------------------------------------------------------------------------------------
_JOINT_KINDS = {int(mujoco.mjtJoint.mjJNT_HINGE): "hinge", int(mujoco.mjtJoint.mjJNT_SLIDE): "slide",
                int(mujoco.mjtJoint.mjJNT_BALL): "ball", int(mujoco.mjtJoint.mjJNT_FREE): "free"}


def joint_kinds(model: mujoco.MjModel) -> dict[str, int]:
    """How many joints of each kind (hinge, slide, ball, free)."""
    kinds = [_JOINT_KINDS[int(k)] for k in model.jnt_type]
    return {k: kinds.count(k) for k in ("free", "ball", "hinge", "slide") if k in kinds}


def features(model: mujoco.MjModel, not_examined: Mapping[str, str]) -> tuple[str, ...]:
    """What the model has that shapes its dynamics, each named once: the forces the tree reference models
    (damping, springs, armature, gravcomp, actuators, equalities, fixed tendons) and those it does not."""
    out = []
    if "contacts" in not_examined:
        out.append("contacts")
    if np.any(model.jnt_limited):
        out.append("limits")
    if model.nu:
        out.append(_count(model.nu, "actuator"))
    if model.neq:
        kinds = sorted({mujoco.mjtEq(int(t)).name.removeprefix("mjEQ_").lower() for t in model.eq_type})
        out.append(f"{_count(model.neq, 'equality').replace('ys', 'ies')} ({', '.join(kinds)})")
    if model.ntendon:
        out.append(_count(model.ntendon, "tendon"))
    for name, present in (("damping", np.any(model.dof_damping)), ("springs", np.any(model.jnt_stiffness)),
                          ("armature", np.any(model.dof_armature)), ("frictionloss", np.any(model.dof_frictionloss)),
                          ("gravcomp", np.any(model.body_gravcomp)), ("fluid", "fluid forces" in not_examined)):
        if present:
            out.append(name)
    return tuple(out)


def not_examined_summary(not_examined: Mapping[str, str]) -> tuple[str, ...]:
    """The forces not examined, grouped: ``actuator a``, ``actuator b`` read ``2 actuators (why)``."""
    grouped: dict[str, list[str]] = {}
    for key, why in not_examined.items():
        kind = key.split(" ", 1)[0] if key.startswith(("actuator ", "tendon ")) or key.endswith(" spring") else key
        grouped.setdefault(kind, []).append(why)
    labels = {"actuator": "actuator", "tendon": "tendon", "joint": "joint spring"}
    return tuple(f"{_count(len(whys), labels[kind])} ({'; '.join(dict.fromkeys(whys))})" if kind in labels else kind
                 for kind, whys in grouped.items())


def _count(n: int, noun: str) -> str:
    return f"{n} {noun}{'' if n == 1 else 's'}"


# ---- one model judged ---------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Deciding:
    """The check that decides a model's verdict, with its budget's parts."""

    name: str
    unit: str
    measured: float
    limit: float
    unexplained: float | None = None
    explained: Mapping[str, float] = field(default_factory=dict)
    diverged: str = ""

    @classmethod
    def of(cls, c: Check) -> Deciding:
        if c.budget is None:
            return cls(str(c.name), c.unit, float(c.value), float(c.threshold), diverged=c.diverged)
        b = c.budget
        return cls(str(c.name), c.unit, float(c.value), float(b.limit), float(b.unexplained),
                   {k: float(v) for k, v in b.explained.items() if v}, c.diverged)

    def text(self) -> str:
        """``RK4.position: measured 1.2e-03 m = integration 1e-5 + unexplained 1.2e-03 > limit 5e-7``."""
        if self.diverged:
            return f"{self.name}: {self.diverged}"
        unit = "" if self.unit in ("", "1") else f" {self.unit}"
        if self.unexplained is None:
            return f"{self.name}: {self.measured:.3g}{unit} vs limit {self.limit:.3g}"
        parts = ", ".join(f"{k} {v:.2g}" for k, v in self.explained.items())
        return (f"{self.name}: measured {self.measured:.3g}{unit} = {parts or 'nothing explained'} + "
                f"unexplained {self.unexplained:.2g}; limit {self.limit:.2g}")


def deciding_check(checks: Sequence[Check]) -> Check | None:
    """The check that decides: among the failures the one that could not be measured, else the one furthest
    over its limit; with none failed, the one closest to its limit."""
    judged = [c for c in checks if not c.note]
    failed = [c for c in judged if not c.passed]
    def ratio(c: Check) -> float:
        return c.ratio if math.isfinite(c.ratio) else math.inf
    if failed:
        return max(failed, key=lambda c: (bool(c.diverged), ratio(c)))
    return max(judged, key=lambda c: c.ratio if math.isfinite(c.ratio) else -1.0, default=None)


@dataclass(frozen=True)
class ZooResult:
    """One zoo model's verdict (see the module's docstring), what it has, and what it cost.

    Attributes:
        failed: every failed check's name (empty unless ``verdict`` is fail).
        reason: why it was refused, or the crash's exception in one line.
        horizon: the horizon chosen from the motion, and why.
        seconds: wall time from reading the file to the verdict.
        own: the integrator the model names, which the verdict leads with.
        stability: by integrator (the model's own first), the statement of each run beyond its stability limit.
    """

    model: str
    package: str
    path: str
    verdict: str
    seconds: float
    nv: int = 0
    joints: Mapping[str, int] = field(default_factory=dict)
    features: tuple[str, ...] = ()
    not_examined: Mapping[str, str] = field(default_factory=dict)
    integrators: tuple[str, ...] = ()
    checks: int = 0
    deciding: Deciding | None = None
    failed: tuple[str, ...] = ()
    reason: str = ""
    horizon: str = ""
    own: str = ""
    stability: Mapping[str, str] = field(default_factory=dict)

    @property
    def exit(self) -> int | None:
        return EXIT[self.verdict]

    @property
    def limits(self) -> tuple[str, ...]:
        """The statement of each integrator run beyond its stability limit, the model's own first (its figures
        are n/a: the method's limit, not MuJoCo's defect; harness/families/stability.py)."""
        return tuple(self.stability.values())

    def line(self) -> str:
        """One line for the terminal as the model finishes."""
        head = f"{self.model}: {self.verdict}"
        if self.verdict == PASS:
            tail = f"{self.checks} checks" + (f", closest {self.deciding.name}" if self.deciding else "")
        elif self.verdict == FAIL and self.deciding is not None:
            tail = f"{len(self.failed)} of {self.checks} checks failed; deciding {self.deciding.text()}"
        else:
            tail = self.reason
        limits = "".join(f"; {text}" for text in self.limits)
        return printable(f"{head} (nv {self.nv}, {self.seconds:.1f} s): {tail}{limits}")

    def as_dict(self) -> dict[str, object]:
        out = asdict(self)
        out["exit"] = self.exit
        return out


def _described(path: Path) -> tuple[mujoco.MjModel | None, str]:
    try:
        return compile_model(path, edit=prepare), ""
    except ValueError as exc:
        return None, " ".join(str(exc).split())


def one_line(exc: BaseException, width: int = 300) -> str:
    """The exception's type and message on one line, at most ``width`` characters."""
    text = " ".join("".join(traceback.format_exception_only(exc)).split())
    return text if len(text) <= width else text[:width - 1] + "…"


def judge(model: ZooModel, *, integrators: Sequence[str] | None = None, timeout: float | None = None) -> ZooResult:
    """``model`` judged as ``mjharness check --mjcf FILE`` judges it; never raises (a crash is a verdict, and so
    is running past ``timeout`` seconds: unfinished)."""
    clock = time.perf_counter()
    base: dict[str, Any] = {"model": model.name, "package": model.package, "path": str(model.path)}
    compiled, why = _described(model.path)
    if compiled is None:
        return ZooResult(**base, verdict=REFUSED, seconds=time.perf_counter() - clock, reason=why)
    gaps = uncovered(compiled)
    have: dict[str, Any] = {"nv": int(compiled.nv), "joints": joint_kinds(compiled),
                            "features": features(compiled, gaps), "not_examined": gaps}
    try:
        with time_limit(timeout):
            case = own_case(model.path)
            v = validate(case, integrators=integrators)
    except TimeLimit as exc:
        return ZooResult(**base, **have, verdict=UNFINISHED, seconds=time.perf_counter() - clock, reason=str(exc))
    except (np.linalg.LinAlgError, IntegrationError) as exc:  # our own solvers failed (check exits 4), no refusal;
        if not isinstance(exc, TooManySteps):  # LinAlgError is a ValueError: before it
            return ZooResult(**base, **have, verdict=CRASHED, seconds=time.perf_counter() - clock,
                             reason=f"a numerical solve of the harness failed: {one_line(exc)}")
        reason = f"the reference cannot be computed for this model: {' '.join(str(exc).split())}"
        return ZooResult(**base, **have, verdict=REFUSED, seconds=time.perf_counter() - clock, reason=reason)
    except ValueError as exc:  # ModelError and every input check: what check exits 2 with
        reason = " ".join(str(exc).split())
        return ZooResult(**base, **have, verdict=REFUSED, seconds=time.perf_counter() - clock, reason=reason)
    except Exception as exc:
        return ZooResult(**base, **have, verdict=CRASHED, seconds=time.perf_counter() - clock,
                         reason=f"{one_line(exc)} (a bug of the harness)")
    settings = v.settings
    assert settings is not None  # validate() always records the settings it ran with
    tree: Mapping[str, Any] = settings.tree or {}
    deciding = deciding_check(v.checks)
    # the stability family's entry: each integrator's statement (harness/families/stability.py)
    stability = cast("Mapping[str, Mapping[str, Any]]", settings.families.get("stability", {}))
    beyond = {name: s["statement"] for name, s in stability.items() if s["beyond"]}
    return ZooResult(**base, **have | {"not_examined": dict(tree.get("not examined", gaps))},
                     verdict=PASS if v.passed else FAIL, seconds=time.perf_counter() - clock,
                     integrators=tuple(settings.integrators), checks=len(v.checks),
                     deciding=Deciding.of(deciding) if deciding is not None else None,
                     failed=tuple(str(c.name) for c in v.failures), horizon=str(tree.get("horizon", "")),
                     own=settings.integrator, stability=beyond)


def judge_named(name: str, integrators: tuple[str, ...] | None, timeout: float | None = None) -> ZooResult:
    """:func:`judge` by name (what a worker process is sent)."""
    models, _ = discover()
    return judge(select([name], models)[0], integrators=integrators, timeout=timeout)


def judge_entry(model: ZooModel, integrators: tuple[str, ...] | None, timeout: float | None = None,
                carried: Carried | None = None) -> ZooResult:
    """:func:`judge` of a model found by :func:`folder_models` (what a worker process is sent: the model itself,
    which no discovery finds again). ``carried``: on a cluster's node, the model's files carried there
    (:mod:`harness.pipeline.carry`), judged from that copy and named by the user's path."""
    if carried is None:
        return judge(model, integrators=integrators, timeout=timeout)
    result = judge(dataclasses.replace(model, path=carried.here()), integrators=integrators, timeout=timeout)
    return dataclasses.replace(result, path=str(model.path))


# ---- the whole zoo ------------------------------------------------------------------------------------------
MIN_MODELS = 3
"""Each engine-side fault must be caught, at the size issue 29 names, on at least this many zoo models (or on
every model it applies to, where fewer ran)."""


@dataclass(frozen=True)
class ZooRun:
    """The zoo's verdicts, the sources not installed, and (with faults) each fault's smallest size caught."""

    results: tuple[ZooResult, ...]
    skipped: tuple[Skipped, ...] = ()
    faults: tuple = ()  # harness.studies.engine_faults.Caught, by model then fault
    fault_models_left_out: tuple[str, ...] = ()
    injections: tuple[Injection, ...] = ()  # by model: the smallest energy injection its balance catches
    command: str = ""
    seconds: float = 0.0

    @property
    def crashed(self) -> tuple[str, ...]:
        """Every model (and fault study) that crashed: bugs of the harness."""
        return tuple(dict.fromkeys([*(r.model for r in self.results if r.verdict == CRASHED),
                                    *(c.model for c in (*self.faults, *self.injections) if c.crashed)]))

    def caught_on(self, fault: str) -> tuple[str, ...]:
        """The models on which ``fault`` is caught at its claimed size or smaller."""
        return tuple(c.model for c in self.faults if c.fault == fault and c.caught_at_claim)

    @property
    def unfinished(self) -> tuple[str, ...]:
        """Every model (and fault study) stopped at the time limit."""
        return tuple(dict.fromkeys([*(r.model for r in self.results if r.verdict == UNFINISHED),
                                    *(c.model for c in (*self.faults, *self.injections) if c.unfinished)]))

    def faults_short(self) -> dict[str, str]:
        """Each fault caught on fewer models than :data:`MIN_MODELS` (or than it applies to), and on how many."""

        out = {}
        for fault in FAULTS:
            applies = [c for c in self.faults if c.fault == fault and c.size is not None and not c.crashed]
            if not applies:
                continue
            need = min(MIN_MODELS, len(applies))
            caught = self.caught_on(fault)
            if len(caught) < need:
                out[fault] = f"caught on {len(caught)} of {len(applies)} models (at least {need} needed)"
        return out

    @property
    def exit_code(self) -> int:
        """0: every model ran to a verdict (a finding is about the model or MuJoCo, in the report) and every fault
        is caught where asked; 1: a fault caught on too few models, or a model stopped at the time limit before
        its verdict; 2: a crash (a bug of the harness)."""
        if self.crashed:
            return 2
        return 1 if self.faults_short() or self.unfinished else 0


def run(models: Sequence[ZooModel], *, jobs: int = 1, integrators: Sequence[str] | None = None,
        faults: bool = False, fault_max_nv: int | None = None, injection: bool = False,
        skipped: Sequence[Skipped] = (), on_done=None, command: str = "", timeout: float | None = None,
        executor: Executor = LOCAL, found: bool = True) -> ZooRun:
    """Judge every model (and, with ``faults``, size each engine-side fault, with ``injection`` the smallest energy
    injection its balance catches, on those of at most ``fault_max_nv`` dofs) on ``jobs`` worker processes,
    costliest first; ``on_done(result)`` as each ends. ``timeout``: each model's verdict, and each model's fault
    or injection study, stops after so many seconds (unfinished). ``executor``: where the calls run (a Ray
    cluster: one task a call; a task lost for good is its model's row, crashed, saying so). ``found``: the models
    are the installed zoo's (:func:`discover`); False: a folder's (:func:`folder_models`), judged alone (no faults,
    no injection: those studies find their models by name)."""
    if not found and (faults or injection):
        raise ValueError("--faults and --injection size faults on the installed zoo's models; not with --folder")

    clock = time.perf_counter()
    nv = {m.name: _nv(m.path) for m in models}
    order = sorted(models, key=lambda m: -nv[m.name])  # the costliest first: the pool ends together
    chosen = tuple(integrators) if integrators is not None else None
    # a folder's models on a cluster: each with its files (meshes, includes), which the nodes need not share
    carried = {m.name: pack(m.path) for m in order} if not found and executor.kind == "ray" else {}
    calls: list[tuple[Callable[..., Any], tuple[Any, ...]]] = [
        (judge_named, (m.name, chosen, timeout)) if found else
        (judge_entry, (m, chosen, timeout, carried.get(m.name))) for m in order]
    left_out: list[str] = []
    sized = [m for m in order if fault_max_nv is None or nv[m.name] <= fault_max_nv]
    if faults or injection:
        left_out = [f"{m.name} (nv {nv[m.name]})" for m in order if m not in sized]
    if faults:
        calls += [(smallest_caught_named, (m.name, FAULTS, timeout)) for m in sized]
    if injection:
        calls += [(smallest_injection_named, (m.name, timeout)) for m in sized]
    def lost(i: int, reason: str):  # a task the cluster could not run: its rows, never missing
        fn, (name, *_) = calls[i]
        name = name.name if isinstance(name, ZooModel) else name
        why = f"its Ray task failed for good: {reason}"
        if fn is judge_entry:
            chosen = next(m for m in models if m.name == name)
            return ZooResult(name, chosen.package, str(chosen.path), CRASHED, 0.0, nv=nv[name], reason=why)
        if fn is judge_named:
            chosen = select([name], models)[0]
            return ZooResult(name, chosen.package, str(chosen.path), CRASHED, 0.0, nv=nv[name], reason=why)
        if fn is smallest_caught_named:
            return [Caught(name, f, None, None, crashed=why) for f in FAULTS]
        return Injection(name, None, None, crashed=why)

    labels = [f"zoo {fn.__name__.removesuffix('_named')} {printable(getattr(args[0], 'name', args[0]))} "
              f"(MuJoCo {mujoco.__version__}, backend c)" for fn, args in calls]
    rows = run_tasks(calls, jobs, on_done=(lambda _i, r: on_done(r)) if on_done else None, executor=executor,
                     failed=lost, labels=labels)
    verdicts = {r.model: r for r in rows if isinstance(r, ZooResult)}
    sized_rows = [c for r in rows if isinstance(r, list) for c in r]
    by_name = [m.name for m in models]
    return ZooRun(results=tuple(verdicts[n] for n in by_name),
                  skipped=tuple(skipped),
                  faults=tuple(sorted(sized_rows, key=lambda c: by_name.index(c.model))),
                  fault_models_left_out=tuple(left_out),
                  injections=tuple(sorted((r for r in rows if isinstance(r, Injection)),
                                          key=lambda c: by_name.index(c.model))),
                  command=command, seconds=time.perf_counter() - clock)


def _nv(path: Path) -> int:
    try:
        return int(compile_model(path).nv)  # as a run compiles it: a robot's image textures are not decoded
    except ValueError:
        return 0


# ---- the report ---------------------------------------------------------------------------------------------
def _cell(text: str) -> str:
    """``text`` as one Markdown table cell: no row or column break, no HTML (a file's name may hold either)."""
    return html.escape(printable(text), quote=False).replace("|", "\\|")


def _verdict_cell(r: ZooResult) -> str:
    if r.verdict == FAIL:
        return f"**fail** ({len(r.failed)} of {r.checks})"
    if r.verdict == PASS:
        return f"pass ({r.checks} checks)"
    return f"**{r.verdict}**: {r.reason}"


def zoo_markdown(z: ZooRun) -> str:
    """zoo.md: the command, the verdict table, the findings named, the fault table."""

    counts = {v: sum(r.verdict == v for r in z.results) for v in (PASS, FAIL, REFUSED, CRASHED, UNFINISHED)}
    lines = [
        "# The zoo: models nobody here wrote, judged against their own kinematic trees", "",
        f"Written by `{z.command or 'mjharness zoo'}` (mjharness {VERSION}, MuJoCo {mujoco.__version__}) "
        f"in {z.seconds:.0f} s wall. Each model runs as `mjharness check --mjcf FILE` runs it: reference from the "
        "model's own tree, start at qpos0 with every joint set moving, horizon chosen from the motion, the forces "
        "the tree does not model switched off and listed under *not examined*. `exit` is what `check` exits "
        "with: 0 pass, 1 a finding (named by the deciding check: the failure furthest over its limit), 2 refused "
        "(one line) or crashed (a bug of the harness). Seconds: wall time per model, on a shared 2-core machine "
        "with other work running.", "",
        f"{len(z.results)} models: {counts[PASS]} pass, {counts[FAIL]} fail with a named finding, "
        f"{counts[REFUSED]} refused, {counts[CRASHED]} crashed"
        + (f", {counts[UNFINISHED]} unfinished (stopped at the time limit)" if counts[UNFINISHED] else "") + ".", ""]
    lines += [f"- skipped: {s.line()}" for s in z.skipped]
    if z.skipped:
        lines.append("")
    lines += ["| model | nv | joints | features | not examined | verdict | exit | deciding figure | seconds |",
              "|---|---:|---|---|---|---|---:|---|---:|"]
    for r in z.results:
        joints = ", ".join(f"{n} {k}" for k, n in r.joints.items())
        deciding = r.deciding.text() if r.deciding is not None and r.verdict in (PASS, FAIL) else ""
        if r.verdict == PASS and r.deciding is not None:
            deciding = f"closest: {deciding}"
        if r.own in r.stability:  # the verdict leads with the model's own integrator
            deciding = f"{r.stability[r.own]}; {deciding}" if deciding else r.stability[r.own]
        lines.append("| " + " | ".join(_cell(x) for x in (
            r.model, str(r.nv), joints, ", ".join(r.features) or "-",
            ", ".join(not_examined_summary(r.not_examined)) or "-", _verdict_cell(r),
            "-" if r.exit is None else str(r.exit), deciding,
            f"{r.seconds:.1f}")) + " |")
    failed = [r for r in z.results if r.verdict == FAIL]
    if failed:
        lines += ["", "## Findings", ""]
        for r in failed:
            lines.append(f"- **{_cell(r.model)}**: {r.deciding.text() if r.deciding else ''}; failed: "
                         f"{', '.join(r.failed)}")
    limited = [r for r in z.results if r.limits]
    if limited:
        lines += ["", "## Beyond a stability limit: the method's, not MuJoCo's defect", "",
                  "An explicit integrator run at a step where h·λ lies outside its stability region, λ the "
                  "eigenvalues of the reference's own linearization at the run's states (harness/families/"
                  "stability.py): its figures are n/a with the statement, neither pass nor fail; the model's own "
                  "integrator first.", ""]
        lines += [f"- **{r.model}** (its own integrator: {r.own}): " + "; ".join(r.limits) for r in limited]
    if z.faults or z.fault_models_left_out:
        lines += ["", "## Faults made on the engine's side alone", "",
                  "The reference is built from the unmodified file; only the engine's model is changed "
                  "(harness/studies/engine_faults.py): **inertia**: the heaviest moving body's mass and inertia × "
                  "(1 + s); **damping**: extra damping s × M_jj √(g/L) on the hinge carrying the most mass; "
                  "**axis**: that hinge's axis tilted by s rad. Each cell: the smallest size caught in a bisection "
                  f"over the decades {SIZES[0]:g} … {SIZES[-1]:g} (RK4 only), and the check that caught it there "
                  "(a check failing that does not fail unfaulted). Sizes named in issue 29: "
                  + ", ".join(f"{f} {CLAIMED[f]:g} ({UNITS[f]})" for f in FAULTS) + ".", ""]
        models = list(dict.fromkeys(c.model for c in z.faults))
        lines += ["| model | where | " + " | ".join(FAULTS) + " | seconds |", "|---|---|" + "---|" * len(FAULTS)
                  + "---:|"]
        for model in models:
            row = {c.fault: c for c in z.faults if c.model == model}
            where = ", ".join(dict.fromkeys(c.target for c in row.values() if c.target))
            cells = [fault_cell(row[f]) if f in row else "" for f in FAULTS]
            if all(row[f].size is None and not row[f].crashed and not row[f].unfinished for f in row):
                cells = ["refused"] * len(FAULTS)
            lines.append("| " + " | ".join(_cell(x) for x in (model, where or "-", *cells,
                                                              f"{sum(c.seconds for c in row.values()):.0f}")) + " |")
        lines.append("")
        for fault in FAULTS:
            caught = z.caught_on(fault)
            lines.append(f"- {fault}: caught at {CLAIMED[fault]:g} or smaller on {len(caught)} models")
        for fault, why in z.faults_short().items():
            lines.append(f"- **{fault} short**: {why}")
        if z.fault_models_left_out:
            lines.append(f"- not sized (over --fault-max-nv): {', '.join(z.fault_models_left_out)}")
    if z.injections:
        lines += ["", "## Energy from nothing: the smallest injection each model's balance catches", "",
                  "The engine's model gets a force that feeds energy in, f = c q̇ on the hinge or slide carrying the "
                  "most mass with c = s × M_jj √(g/L), and the balance's accounts leave its work out "
                  "(harness/studies/injection.py): to the work–energy balance it is energy from nothing. Each cell: "
                  f"the smallest s caught in a bisection over the decades {SIZES_SEARCHED[0]:g} … "
                  f"{SIZES_SEARCHED[-1]:g} (RK4 and Euler), "
                  "the energy it fed in over the horizon against the peak kinetic energy and against m g L, and the "
                  "check that caught it.", "", "| model | joint | smallest injection caught | seconds |",
                  "|---|---|---|---:|"]
        for c in z.injections:
            lines.append("| " + " | ".join(_cell(x) for x in (c.model, c.joint or "-", injection_cell(c),
                                                              f"{c.seconds:.0f}")) + " |")
    if z.crashed:
        lines += ["", f"**Crashed (bugs of the harness)**: {', '.join(z.crashed)}"]
    if z.unfinished:
        lines += ["", f"**Unfinished (stopped at the time limit)**: {', '.join(z.unfinished)}"]
    return "\n".join(lines) + "\n"


def zoo_json(z: ZooRun) -> dict[str, object]:
    """zoo.json: every model's result, the skipped sources, the faults, the exit code."""
    return {"command": z.command, "seconds": z.seconds, "mujoco": mujoco.__version__, "exit": z.exit_code,
            "models": [r.as_dict() for r in z.results],
            "skipped": [asdict(s) for s in z.skipped],
            "faults": [asdict(c) | {"caught_at_claim": c.caught_at_claim} for c in z.faults],
            "faults_not_sized": list(z.fault_models_left_out), "faults_short": z.faults_short(),
            "injections": [asdict(c) for c in z.injections]}


def smallest_caught_named(model: str, faults: tuple[str, ...] = FAULTS, timeout: float | None = None
                          ) -> list[Caught]:
    """:func:`smallest_caught` on the zoo model called ``model`` (what a worker process is sent), stopped after
    ``timeout`` seconds (the faults not sized by then: unfinished); an exception is returned as a crash of
    each fault not sized (a bug of the harness, with its last line), never raised."""
    models, _ = discover()
    chosen = select([model], models)[0]
    clock = time.perf_counter()
    done: list[Caught] = []
    rest = lambda: [f for f in faults if f not in {c.fault for c in done}]  # noqa: E731
    try:
        with time_limit(timeout):
            done.extend(smallest_caught(chosen.path, faults, name=chosen.name))
    except TimeLimit as exc:
        done += [Caught(chosen.name, f, None, None, unfinished=str(exc), seconds=time.perf_counter() - clock)
                 for f in rest()]
    except ValueError as exc:  # a model the tree reference refuses: no faults to judge
        done += [Caught(chosen.name, f, None, None, note=" ".join(str(exc).split())) for f in rest()]
    except Exception as exc:
        done += [Caught(chosen.name, f, None, None, crashed=one_line(exc), seconds=time.perf_counter() - clock)
                 for f in rest()]
    return done


def smallest_injection_named(model: str, timeout: float | None = None) -> Injection:
    """:func:`~harness.studies.injection.smallest_injection` on the zoo model called ``model`` (what a worker
    process is sent), stopped after ``timeout`` seconds (unfinished); an exception is returned as a crash (a bug
    of the harness, with its last line) or, where the tree reference refuses the model, as n/a, never raised."""
    models, _ = discover()
    chosen = select([model], models)[0]
    clock = time.perf_counter()
    try:
        with time_limit(timeout):
            return smallest_injection(chosen.path, name=chosen.name)
    except TimeLimit as exc:
        return Injection(chosen.name, None, None, unfinished=str(exc), seconds=time.perf_counter() - clock)
    except ValueError as exc:  # a model the tree reference refuses: nothing to inject into
        return Injection(chosen.name, None, None, note=" ".join(str(exc).split()))
    except Exception as exc:
        return Injection(chosen.name, None, None, crashed=one_line(exc), seconds=time.perf_counter() - clock)
