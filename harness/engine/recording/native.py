"""The native recorder: MuJoCo's own steps, recorded from C as they are made; built on first use.

Why: the constrained cases need ``efc_force``/``efc_pos`` at every state. They
lie in MuJoCo's arena, whose size changes from step to step, so
``mujoco.batch`` can neither record nor bind them, and reading them from
Python costs a forward per state (what a step of Euler costs). ``native_record.c`` steps with
``mj_step`` as ``mujoco.batch`` does (fields shifted by one; RK4: checked
forward, copy, then ``mj_RungeKutta``, as the loop recorder does) and records at
every sample the integration state, the fixed-size fields the rest needs
(:attr:`harness.engine.recording.assemble.Plan.native_fields`), the equalities'
``efc_*`` rows, the points' positions and velocities and the subtree angular
momenta the readings project (:attr:`harness.engine.readings.Reading.about`:
numpy's arithmetic, operation for operation) as it goes, so nothing is computed
twice and a short run's fixed cost stays small. Then the same assembly,
readings and check as the batch recorder's
(:func:`harness.engine.recording.verify.checked_run`).

How: the C file ships with the package; the first run compiles it with the
system's C compiler (``$CC``, else ``cc``, ``gcc`` or ``clang``) against the
headers and library that the installed ``mujoco`` wheel ships, into the user
cache (``$XDG_CACHE_HOME/mjharness/native``, a temporary folder when
``MJHARNESS_NO_CACHE=1``), keyed by a hash of the source, MuJoCo's version and
its struct headers, and renamed into place whole. A library is loaded only from
a folder of the user's that nobody else can enter (0700), only if nobody else
can write it and its SHA-256 is the one recorded when it was built; anything
else is rebuilt, never run (docs/security.md). It links the very library
Python's ``mujoco`` loaded (the loader shares one copy by its soname), so
callbacks and plugins are the same. Where anything of that is missing, or
``MJHARNESS_NATIVE=0``, :func:`library` is None, :func:`why_not` says why and
the batch recorder runs instead (the same numbers, more slowly).
"""

from __future__ import annotations

import contextlib
import ctypes
import functools
import hashlib
import os
import shutil
import stat
import subprocess
import tempfile
import threading
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from harness.core.cache import cache_dir, key
from harness.core.cache import write_atomic as cache_write_atomic
from harness.engine.integrators import integrator_name
from harness.engine.probe import Probe
from harness.engine.readings.momentum import subtree
from harness.engine.recording.assemble import Plan, Run, plan
from harness.engine.recording.equalities import equality_layout, fixed_rows, joint_equalities, signed
from harness.engine.recording.scratch import STATE, Record
from harness.engine.recording.verify import check_warnings, checked_run

__all__ = ["library", "record", "why_not"]

ABI = 7  # native_record.c's mjh_abi()
SOURCE = Path(__file__).with_name("native_record.c")
HASH_SUFFIX = ".sha256"  # beside the library: the hash of the file this install built
# the int fields of mjData's info header the recorder copies, in mjh_scalar's order
SCALARS: tuple[str, ...] = ("ne", "nf", "nl", "nefc", "ncon", "nisland")
# how mjh_record steps: RK4 (2) as the loop recorder does, every other integrator with mj_step (0)
INTEGRATOR_CODES: dict[str, int] = {"RK4": 2}

_why_not: list[str] = []


@dataclass(frozen=True)
class Point:
    """A point whose velocity the recorder computes: on ``body`` (whose root is ``root``), at ``site`` (−1: at
    the body's centre of mass), through the dofs ``chain`` (increasing) that move it."""

    body: int
    site: int
    root: int
    chain: tuple[int, ...]


def why_not() -> str | None:
    """Why :func:`library` is None in this process (None while it is not, or before it was asked)."""
    return _why_not[0] if _why_not else None


_LOADING = threading.Lock()


@functools.cache
def library() -> ctypes.CDLL | None:
    """The built recorder, loaded; None (and :func:`why_not` set) where it cannot be built or loaded. One thread
    at a time builds or loads it (runs are recorded side by side)."""
    with _LOADING:
        try:
            lib = _load()
        except _Unavailable as exc:
            _why_not[:] = [str(exc)]
            return None
        _why_not.clear()
        return lib


class _Unavailable(Exception):
    pass


def _mujoco_files() -> tuple[Path, Path]:
    """The wheel's include folder and its shared library."""
    package = Path(mujoco.__file__).parent
    include = package / "include"
    libraries = sorted(package.glob("libmujoco.so*")) + sorted(package.glob("libmujoco*.dylib"))
    if not (include / "mujoco" / "mujoco.h").is_file() or not libraries:
        raise _Unavailable(f"the mujoco package at {package} ships no C headers or no libmujoco")
    return include, libraries[0]


def _load() -> ctypes.CDLL:
    if os.environ.get("MJHARNESS_NATIVE", "").strip() == "0":
        raise _Unavailable("turned off (MJHARNESS_NATIVE=0)")
    include, shared = _mujoco_files()
    compiler = os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc") or shutil.which("clang")
    if not compiler:
        raise _Unavailable("no C compiler found ($CC, cc, gcc or clang)")
    headers = [include / "mujoco" / h for h in ("mujoco.h", "mjdata.h", "mjmodel.h")]
    digest = key(SOURCE.read_bytes(), mujoco.__version__, str(shared), compiler,
                 *(h.read_bytes() for h in headers), versions=False)
    root = cache_dir()
    folder = _private_folder(root / "native") if root is not None else None
    if folder is None:  # no cache, or its folder is not the user's alone: built afresh where only we write
        folder = Path(tempfile.mkdtemp(prefix="mjharness-native-"))
    target = folder / f"record-{digest[:32]}.so"
    if not _trusted(target):
        _build(compiler, include, shared, folder, target)
        if not _trusted(target):
            raise _Unavailable(f"its library {target} changed as it was built")
    try:
        lib = ctypes.CDLL(str(target))
    except OSError as exc:
        raise _Unavailable(f"its library {target} does not load: {exc}") from None
    if lib.mjh_abi() != ABI:
        raise _Unavailable(f"its library {target} is of another version (abi {lib.mjh_abi()}, expected {ABI})")
    lib.mjh_scalar.argtypes = [ctypes.c_void_p, ctypes.c_int]
    lib.mjh_scalar.restype = ctypes.c_void_p
    lib.mjh_record.argtypes = [
        ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int, ctypes.c_int, ctypes.c_void_p, ctypes.c_int,
        ctypes.c_int, ctypes.POINTER(ctypes.c_void_p), ctypes.POINTER(ctypes.c_long), ctypes.POINTER(ctypes.c_void_p),
        ctypes.c_int, ctypes.c_void_p, ctypes.c_void_p, ctypes.POINTER(ctypes.c_int),
        ctypes.c_int, ctypes.POINTER(ctypes.c_int), ctypes.POINTER(ctypes.c_int), ctypes.POINTER(ctypes.c_int),
        ctypes.POINTER(ctypes.c_int), ctypes.POINTER(ctypes.c_int), ctypes.c_void_p, ctypes.c_void_p,
        ctypes.c_int, ctypes.POINTER(ctypes.c_int), ctypes.POINTER(ctypes.c_int), ctypes.POINTER(ctypes.c_int),
        ctypes.c_void_p]
    lib.mjh_record.restype = ctypes.c_int
    return lib


def _owned_privately(st: os.stat_result) -> bool:
    """Whether ``st`` is of a file or folder of this user that nobody else may write."""
    return st.st_uid == os.geteuid() and not st.st_mode & (stat.S_IWGRP | stat.S_IWOTH)


def _private_folder(folder: Path) -> Path | None:
    """``folder``, created 0700 if missing (closed to 0700 if it is this user's), if it is a real folder (not a
    link) of this user that only they can enter; None if it is not (the library is then built in a fresh
    temporary folder: never loaded from a folder someone else could write)."""
    with contextlib.suppress(OSError):
        folder.mkdir(mode=0o700, parents=True, exist_ok=True)
    try:
        st = folder.lstat()
        if stat.S_ISDIR(st.st_mode) and st.st_uid == os.geteuid() and st.st_mode & 0o077:
            os.chmod(folder, 0o700)  # ours, made before this check: closed now (its files are each checked)
            st = folder.lstat()
    except OSError:
        return None
    private = stat.S_ISDIR(st.st_mode) and st.st_uid == os.geteuid() and not st.st_mode & 0o077
    return folder if private else None


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _trusted(target: Path) -> bool:
    """Whether ``target`` is the library this install built: a regular file of this user that nobody else may
    write, whose SHA-256 is the one recorded beside it when it was built (its folder is private:
    :func:`_private_folder`). A library that is not (missing, replaced, truncated, corrupt) is rebuilt,
    never loaded."""
    record = target.with_name(target.name + HASH_SUFFIX)
    try:
        st, rst = target.lstat(), record.lstat()
        if not (stat.S_ISREG(st.st_mode) and stat.S_ISREG(rst.st_mode) and _owned_privately(st)
                and _owned_privately(rst) and rst.st_size <= 128):
            return False
        return record.read_text(encoding="ascii").strip() == _sha256(target)
    except (OSError, ValueError):
        return False


def _build(compiler: str, include: Path, shared: Path, folder: Path, target: Path) -> None:
    """Compile into a temporary file beside ``target`` and rename it into place (concurrent builders
    never leave a half-written library)."""
    try:
        folder.mkdir(parents=True, exist_ok=True)
        fd, partial = tempfile.mkstemp(dir=folder, suffix=".so.partial")
        os.close(fd)
    except OSError as exc:
        raise _Unavailable(f"cannot write its library under {folder}: {exc.strerror}") from None
    # -ffp-contract=off: a point's velocity and a subtree's momentum are summed as numpy sums them, a product then
    # a sum, never fused
    command = [compiler, "-O2", "-std=c99", "-ffp-contract=off", "-shared", "-fPIC", f"-I{include}", str(SOURCE),
               "-o", partial, f"-L{shared.parent}", f"-l:{shared.name}", f"-Wl,-rpath,{shared.parent}"]
    try:
        done = subprocess.run(command, capture_output=True, text=True, timeout=120, check=False)
        if done.returncode != 0:
            first = next((ln for ln in done.stderr.splitlines() if ln.strip()), f"exit {done.returncode}")
            raise _Unavailable(f"{Path(compiler).name} could not build it: {first.strip()}")
        os.chmod(partial, 0o700)  # the compiler's mode follows the umask; nobody else may write it
        digest = _sha256(Path(partial))
        os.replace(partial, target)
        cache_write_atomic(target.with_name(target.name + HASH_SUFFIX), digest.encode())
    except (OSError, subprocess.TimeoutExpired) as exc:
        raise _Unavailable(f"{Path(compiler).name} could not build it: {exc}") from None
    finally:
        if os.path.exists(partial):
            os.unlink(partial)


def _address(array: np.ndarray) -> int:
    """Where ``array``'s data starts (``ndarray.ctypes.data``'s number, without making a ctypes object)."""
    return array.__array_interface__["data"][0]


@dataclass(frozen=True)
class Momentum:
    """A subtree's angular momentum the recorder computes: about ``site``, of ``bodies`` (the subtree, in the
    model's body order)."""

    site: int
    bodies: tuple[int, ...]


@dataclass(frozen=True)
class Copies:
    """mjh_record's field arguments (count, source addresses, row sizes, target addresses) for one MjData and
    one set of recording arrays of ``rows`` rows, checked once: neither moves while this holds them."""

    data: mujoco.MjData
    fields: Mapping[str, np.ndarray]
    rows: int
    arguments: tuple[int, ctypes.Array, ctypes.Array, ctypes.Array]


def copies(lib: ctypes.CDLL, data: mujoco.MjData, fields: Mapping[str, np.ndarray], n: int) -> Copies:
    """The arguments that copy each of ``fields`` (arrays of ``n`` rows, MjData's dtypes) from ``data`` into its
    row of every sample."""
    sources, sizes, targets = [], [], []
    for name, out in fields.items():
        if not (out.flags.c_contiguous and out.shape[0] == n):
            raise ValueError(f"field {name!r}: the recording array must be C-contiguous with {n} rows")
        if name in SCALARS:
            address = lib.mjh_scalar(data._address, SCALARS.index(name))
            size = 4
        else:
            view = np.asarray(getattr(data, name))
            if not view.flags.c_contiguous:
                raise ValueError(f"field {name!r} is not contiguous in MjData")
            address, size = _address(view), view.nbytes
        if out[0].nbytes != size:
            raise ValueError(f"field {name!r}: {out[0].nbytes} bytes a row to record, MjData has {size}")
        sources.append(address)
        sizes.append(size)
        targets.append(_address(out))
    return Copies(data=data, fields=fields, rows=n, arguments=(
        len(sources), (ctypes.c_void_p * len(sources))(*sources), (ctypes.c_long * len(sizes))(*sizes),
        (ctypes.c_void_p * len(targets))(*targets)))


def _ints(values: Sequence[int]) -> ctypes.Array:
    return (ctypes.c_int * max(len(values), 1))(*values)


@functools.lru_cache(maxsize=64)
def _point_arguments(points: tuple[Point, ...]) -> tuple:
    """mjh_record's point arguments: count, body, site, root, chain starts and the chains' dofs."""
    starts = np.cumsum([0, *(len(p.chain) for p in points)]).tolist()
    return (len(points), _ints([p.body for p in points]), _ints([p.site for p in points]),
            _ints([p.root for p in points]), _ints(starts), _ints([i for p in points for i in p.chain]))


@functools.lru_cache(maxsize=64)
def _momentum_arguments(momenta: tuple[Momentum, ...]) -> tuple:
    """mjh_record's momentum arguments: count, site, body starts and the subtrees' bodies."""
    starts = np.cumsum([0, *(len(m.bodies) for m in momenta)]).tolist()
    return (len(momenta), _ints([m.site for m in momenta]), _ints(starts),
            _ints([b for m in momenta for b in m.bodies]))


@functools.lru_cache(maxsize=16)
def _points(model: mujoco.MjModel, of: Plan) -> tuple[Point, ...]:
    """The points of a run's plan, as mjh_record takes them."""
    return tuple(Point(body=s.body, site=s.index if s.kind == "site" else -1, root=int(model.body_rootid[s.body]),
                       chain=chain) for s, chain in zip(of.sources, of.chains, strict=True))


@functools.lru_cache(maxsize=16)
def _momenta(model: mujoco.MjModel, of: Plan) -> tuple[Momentum, ...]:
    """The subtree momenta of a run's plan, as mjh_record takes them."""
    return tuple(Momentum(site=model.site(site).id, bodies=tuple(subtree(model, model.body(body).id)))
                 for body, site in of.momenta)


def mjh_record(lib: ctypes.CDLL, model: mujoco.MjModel, data: mujoco.MjData, *, steps: int, integrator: str,
               states: np.ndarray, fields: Copies, force: np.ndarray, pos: np.ndarray,
               points: Sequence[Point] = (), velocity: np.ndarray | None = None, position: np.ndarray | None = None,
               momenta: Sequence[Momentum] = (), momentum: np.ndarray | None = None) -> tuple[int, bool]:
    """``steps`` steps of ``data`` from its state (``states[0]``, which the caller wrote), recording states
    1..steps into ``states`` and, at every sample 0..steps, the fields ``fields`` copies (:func:`copies`
    of this ``data``, arrays of steps + 1 rows), the first ``force.shape[1]`` rows of efc_force/efc_pos and the
    world velocity of each of ``points`` into ``velocity`` ((len(points), steps + 1, 3)), with the arithmetic of
    :func:`harness.engine.recording.assemble.point_velocity`, its world position into ``position`` (the same
    shape), and the angular momentum of each of ``momenta`` into ``momentum`` ((len(momenta), 3, steps + 1)), with
    the arithmetic of the reading (:func:`harness.engine.readings.momentum.about_at`).

    Returns (the sample at whose checks MuJoCo raised a warning, or −1 when every sample is recorded;
    whether every sample had exactly that many equality rows)."""
    n = steps + 1
    if fields.data is not data or fields.rows != n:
        raise ValueError(f"fields: the copies must be of this MjData, into arrays of {n} rows")
    nrows = force.shape[1]
    velocity = np.empty((len(points), n, 3)) if velocity is None else velocity
    position = np.empty((len(points), n, 3)) if position is None else position
    for a in (states, force, pos):
        if not (a.flags.c_contiguous and a.dtype == np.float64 and a.shape[0] == n):
            raise ValueError("states, force and pos must be C-contiguous float64 arrays of steps + 1 rows")
    for a in (velocity, position):
        if not (a.flags.c_contiguous and a.dtype == np.float64 and a.shape == (len(points), n, 3)):
            raise ValueError(f"velocity and position must be C-contiguous float64 arrays of shape ({len(points)}, "
                             f"{n}, 3)")
    momentum = np.empty((0, 3, n)) if momentum is None else momentum
    if not (momentum.flags.c_contiguous and momentum.dtype == np.float64 and momentum.shape == (len(momenta), 3, n)):
        raise ValueError(f"momentum must be a C-contiguous float64 array of shape ({len(momenta)}, 3, {n})")
    ok = ctypes.c_int(1)
    k = lib.mjh_record(
        model._address, data._address, steps, INTEGRATOR_CODES.get(integrator, 0), _address(states), states.shape[1],
        *fields.arguments, nrows, _address(force), _address(pos), ctypes.byref(ok),
        *_point_arguments(tuple(points)), _address(velocity), _address(position), *_momentum_arguments(tuple(momenta)),
        _address(momentum))
    if k == -2:
        raise ValueError(f"states has {states.shape[1]} columns; this model's integration state has another size")
    return k, bool(ok.value)


def record(lib: ctypes.CDLL, model: mujoco.MjModel, probe: Probe, data: mujoco.MjData, steps: int,
           timings: dict[str, float]) -> Run | None:
    """The native recorder, from ``data``'s state: MuJoCo's steps made in C, recording the state, the
    fixed-size fields and the equalities' efc rows at every sample as it steps; None where the check
    against a fresh mj_forward sends the run back to the loop."""
    made = plan(model, probe)
    rec = Record.take(model, data, steps, made.native_fields)
    try:
        mujoco.mj_getState(model, data, rec.states[0], STATE)
        recoverable = joint_equalities(model, probe.constraints)
        read = [c for c in probe.constraints if c not in recoverable]
        layout = equality_layout(model) if read else None
        nrows = layout[1] if layout is not None else 0
        force, pos = np.empty((steps + 1, nrows)), np.empty((steps + 1, nrows))
        points, momenta = _points(model, made), _momenta(model, made)
        velocity = np.empty((len(points), steps + 1, 3))  # fresh arrays: the trajectory keeps their rows
        position = np.empty((len(points), steps + 1, 3))
        momentum = np.empty((len(momenta), 3, steps + 1))  # likewise: a reading may keep its rows
        fields = rec.kept.get("native")
        if fields is None or fields.data is not data:  # the arrays' addresses, kept with them
            fields = rec.kept["native"] = copies(lib, data, rec.fields, steps + 1)
        k, rows_ok = mjh_record(lib, model, data, steps=steps, integrator=integrator_name(model),
                                states=rec.states, fields=fields, force=force, pos=pos, points=points,
                                velocity=velocity, position=position, momenta=momenta, momentum=momentum)
        if k >= 0:
            check_warnings(data.warning.number, float(rec.states[k, 0]))
        fixed = fixed_rows(model, rec.states) if nrows and rows_ok else None
        lam, viol = {}, {}
        if fixed is not None:
            for c in read:
                lam[c], viol[c] = signed(probe.sign(c), force[:, fixed[c]], pos[:, fixed[c]])
        return checked_run(model, probe, data, rec, lam, viol, timings,
                           velocities=dict(zip(probe.points, velocity, strict=True)),
                           momenta=dict(zip(made.momenta, momentum, strict=True)),
                           positions=dict(zip(probe.points, position, strict=True)))
    finally:
        rec.give_back(model)
