"""A stand-in for uv and for the environments it builds, for tests/test_versions.py: no network, no MuJoCo.

As uv (``python fake_uv.py ARGS``, through the shell script the tests write):

- ``build --wheel --quiet --out-dir DIR SRC``: writes an empty ``DIR/mjharness-0.1.0-py3-none-any.whl``;
- ``venv --quiet --python PY FOLDER``: makes ``FOLDER/bin/python``, a script running this file as the
  environment's interpreter;
- ``pip install --quiet --python FOLDER/bin/python [--reinstall-package mjharness] WHEEL REQ...``:
  records the requirements in ``FOLDER/requirements.txt`` (fails, exit 1, where ``FAKE_UV_FAIL`` names
  the ``mujoco==`` release being installed).

Every call is appended to ``FAKE_UV_LOG`` as one JSON line.

As an environment's interpreter (``FOLDER/bin/python -P -m harness check --json --jobs N ARGS``): prints a
run document (schema 2) of the release in ``requirements.txt``, from the world file ``FAKE_WORLD``:
``{"values": {"CASE/FIGURE": {"RELEASE": value}}, "status": {"CASE/FIGURE": {"RELEASE": status}},
"noise": {"CASE/FIGURE": size}, "exit": {"RELEASE": code}}``. A figure absent for a release is absent from
the document; ``--perturb=S`` moves each value by ``noise × S / 1e-15``. The call is logged to
``FAKE_CHECK_LOG`` with its working directory.
"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path


def _log(var: str, entry: object) -> None:
    with open(os.environ[var], "a") as fh:
        fh.write(json.dumps(entry) + "\n")


def uv(args: list[str]) -> int:
    _log("FAKE_UV_LOG", args)
    if args[0] == "build":
        out = Path(args[args.index("--out-dir") + 1])
        out.mkdir(parents=True, exist_ok=True)
        (out / "mjharness-0.1.0-py3-none-any.whl").write_bytes(b"")
        return 0
    if args[0] == "venv":
        folder = Path(args[-1])
        (folder / "bin").mkdir(parents=True)
        script = folder / "bin" / "python"
        script.write_text(f"#!/bin/sh\nexec {sys.executable} {Path(__file__).resolve()} env \"$0\" \"$@\"\n")
        script.chmod(0o755)
        return 0
    if args[:2] == ["pip", "install"]:
        python = Path(args[args.index("--python") + 1])
        wheel = next(i for i, a in enumerate(args) if a.endswith(".whl"))
        reqs = args[wheel + 1:]
        mujoco = next((r for r in reqs if r.startswith("mujoco==")), None)
        if mujoco is not None and os.environ.get("FAKE_UV_FAIL") == mujoco.split("==")[1]:
            print(f"error: no wheel for {mujoco} on this platform", file=sys.stderr)
            return 1
        if "--no-deps" not in args:
            (python.parent.parent / "requirements.txt").write_text("\n".join(reqs) + "\n")
        return 0
    print(f"fake uv: unknown command {args}", file=sys.stderr)
    return 2


def environment(python: str, args: list[str]) -> int:
    folder = Path(python).parent.parent
    installed = (folder / "requirements.txt").read_text().split()
    release = next(r.split("==")[1] for r in installed if r.startswith("mujoco=="))
    _log("FAKE_CHECK_LOG", {"release": release, "argv": args, "cwd": os.getcwd()})
    world = json.loads(Path(os.environ["FAKE_WORLD"]).read_text())
    code = world.get("exit", {}).get(release, 0)
    if release in world.get("crash", ()):  # a traceback, as a harness that cannot drive this MuJoCo gives
        print("Traceback (most recent call last):\nTypeError: mj_fullM(): incompatible function arguments",
              file=sys.stderr)
        return 1
    if code == 2:
        print("mjharness: error: unknown case 'nope'", file=sys.stderr)
        return 2
    perturb = next((float(a.split("=", 1)[1]) for a in args if a.startswith("--perturb=")), 0.0)
    cases: dict = {}
    for key, by_release in world["values"].items():
        if release not in by_release:
            continue
        case, figure = key.split("/")
        value = by_release[release] + world.get("noise", {}).get(key, 0.0) * perturb / 1e-15
        entry = cases.setdefault(case, {"passed": True, "figures": {}, "checks": {}, "settings": {}})
        entry["figures"][figure] = {"value": value, "unit": "m", "description": ""}
        status = world.get("status", {}).get(key, {}).get(release)
        if status is not None:
            entry["checks"][figure] = {"value": value, "threshold": 1.0, "unit": "m", "status": status,
                                       "passed": status in ("pass", "n/a"), "basis": "limit"}
    doc = {"schema": 2, "versions": {"mujoco": release}, "passed": True, "cases": cases}
    print(json.dumps(doc))
    return code


if __name__ == "__main__":
    if sys.argv[1] == "env":
        sys.exit(environment(sys.argv[2], sys.argv[3:]))
    sys.exit(uv(sys.argv[1:]))
