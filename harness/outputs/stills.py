"""Still images of MJCF models for the report, rendered headless in a child process.

OpenGL initialisation can abort the whole process (a segfault in a driver, a
missing library), which no ``try`` can catch. So the parent never touches GL:
it starts ``python -m harness.outputs.stills``, hands it the models as JSON on stdin and
reads PNGs back on stdout. Backends are tried in order — the user's
``MUJOCO_GL`` if set (only that), else ``egl`` then ``osmesa`` — and when none
works the caller gets a one-line reason to show in the page instead of an
image. The model is posed at the case's initial state.

The scene is staged for a reader, without touching the physics: a pale sky
(a gradient skybox) and a checkered floor are added to the model through
``MjSpec`` before it is compiled, the headlight is brightened, and the joints
are drawn (a hinge as an arrow along its axis, a ball joint as a sphere), and
so are contacts with their forces — so two models of one system, such as the
two-hinge and the ball-joint spherical pendulum, or the hoop held on its ramp
by equalities and by a contact, show how they differ. The camera looks at a planar
system face on and at any other from an oblique angle.

Identical inputs give identical PNG bytes on one machine and backend (no
timestamps; pinned in tests/test_report.py).
"""

from __future__ import annotations

import base64
import io
import json
import os
import subprocess
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from harness import cases
from harness.core.lifetime import die_with_parent
from harness.engine.bindings import JointBinding

__all__ = ["Request", "Still", "stills"]

WIDTH, HEIGHT = 480, 360
BACKENDS = ("egl", "osmesa")
TIMEOUT_S = 120.0


@dataclass(frozen=True)
class Still:
    """A rendered model (``png`` bytes) or the reason there is none (``note``)."""

    png: bytes | None
    note: str
    backend: str = ""


@dataclass(frozen=True)
class Request:
    """One model to render: which case (for its binding and initial state) and which file; ``qpos``, where given,
    is the initial state itself (a model judged against its own tree is in no registry the child could ask)."""

    case: str
    mjcf: str
    coordinates: tuple[str, ...]
    qpos: tuple[float, ...] = ()


def stills(requests: Sequence[Request], *, timeout: float = TIMEOUT_S) -> dict[str, Still]:
    """A still per request's case; never raises for GL trouble (the reason goes in ``note``)."""
    if not requests:
        return {}
    payload = json.dumps([{"case": r.case, "mjcf": r.mjcf, "coordinates": list(r.coordinates), "qpos": list(r.qpos)}
                          for r in requests])
    user = os.environ.get("MUJOCO_GL")
    reasons = []
    for backend in ([user] if user else BACKENDS):
        env = dict(os.environ, MUJOCO_GL=backend)
        if backend in ("egl", "osmesa") and "PYOPENGL_PLATFORM" not in os.environ:
            env["PYOPENGL_PLATFORM"] = backend
        try:
            proc = subprocess.run([sys.executable, "-m", "harness.outputs.stills"], input=payload, env=env,
                                  capture_output=True, text=True, timeout=timeout, check=False)
        except (OSError, subprocess.TimeoutExpired) as exc:
            reasons.append(f"{backend}: {type(exc).__name__}")
            continue
        if proc.returncode == 0:
            try:
                return _parse(proc.stdout, backend)
            except (ValueError, KeyError, TypeError) as exc:
                reasons.append(f"{backend}: unreadable renderer output ({exc})")
                continue
        reasons.append(f"{backend}: {_last_line(proc.stderr) or f'exit {proc.returncode}'}")
    note = "model image unavailable: no headless OpenGL backend worked (" + "; ".join(reasons) + ")"
    return {r.case: Still(png=None, note=note) for r in requests}


def _parse(stdout: str, backend: str) -> dict[str, Still]:
    out = {}
    for case, item in json.loads(stdout).items():
        if item.get("png"):
            out[case] = Still(png=base64.b64decode(item["png"]), note="", backend=backend)
        else:
            out[case] = Still(png=None, note=f"model image unavailable: {item['error']}", backend=backend)
    return out


def _last_line(text: str) -> str:
    lines = [ln.strip() for ln in text.strip().splitlines() if ln.strip()]
    return lines[-1][:200] if lines else ""


# ------------------------------------------------------------------ child
def _pose(model, data, case_name: str, coordinates: Sequence[str]) -> None:
    """Put the model in the case's initial state (left at qpos0 if the case does not fit)."""
    case = cases.get(case_name)
    binding = (case.binding or JointBinding)(tuple(coordinates))
    binding.validate(model)
    binding.set_state(model, data, [case.q0[c] for c in coordinates], [0.0] * len(coordinates))


def planar(model, data) -> bool:
    """Whether every joint moves the model in the world's x-z plane: hinges about ±y, slides across y, no
    ball or free joint (then it is seen face on, else obliquely)."""
    for j in range(model.njnt):
        kind, along_y = int(model.jnt_type[j]), abs(float(data.xaxis[j][1]))
        if kind == int(mujoco.mjtJoint.mjJNT_HINGE) and along_y < 0.999:
            return False
        if kind == int(mujoco.mjtJoint.mjJNT_SLIDE) and along_y > 1e-3:
            return False
        if kind in (int(mujoco.mjtJoint.mjJNT_BALL), int(mujoco.mjtJoint.mjJNT_FREE)):
            return False
    return True


def _extent(model, data) -> tuple[np.ndarray, np.ndarray, float]:
    """The box holding the bodies, sites and geoms (not the floor), and its largest side (at least 0.3 m)."""
    planes = {int(mujoco.mjtGeom.mjGEOM_PLANE), int(mujoco.mjtGeom.mjGEOM_HFIELD)}
    solid = np.array([int(t) not in planes for t in model.geom_type], dtype=bool)
    centers, radii = data.geom_xpos[solid], model.geom_rbound[solid][:, None]
    pts = np.concatenate([np.zeros((1, 3)), data.xpos[1:], data.site_xpos.reshape(-1, 3),
                          (centers - radii).reshape(-1, 3), (centers + radii).reshape(-1, 3)])
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    return lo, hi, max(float(np.max(hi - lo)), 0.3)


def _camera(model, data):
    """A free camera framing the bodies, sites and geoms (not the floor): along +y for a planar model,
    else from the front right and above, so that depth shows."""
    lo, hi, span = _extent(model, data)
    cam = mujoco.MjvCamera()
    mujoco.mjv_defaultFreeCamera(model, cam)
    cam.lookat[:] = (lo + hi) / 2
    cam.distance = 1.7 * span  # the span fills ~3/4 of the default 45° field of view
    if planar(model, data):
        cam.azimuth, cam.elevation = 90.0, -12.0  # x to the right, z up, seen slightly from above
    else:
        cam.azimuth, cam.elevation = 125.0, -24.0
        cam.distance *= 1.1
    return cam


def _staged(path: str) -> mujoco.MjModel:
    """The model with a sky and a checkered floor added (visual assets only; see the module docstring)."""
    spec = mujoco.MjSpec.from_file(path)
    spec.add_texture(name="mjharness_sky", type=mujoco.mjtTexture.mjTEXTURE_SKYBOX,
                     builtin=mujoco.mjtBuiltin.mjBUILTIN_GRADIENT, rgb1=[0.96, 0.97, 0.99], rgb2=[0.62, 0.7, 0.8],
                     width=256, height=1536)
    spec.add_texture(name="mjharness_grid", type=mujoco.mjtTexture.mjTEXTURE_2D,
                     builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER, rgb1=[0.95, 0.95, 0.96], rgb2=[0.82, 0.84, 0.87],
                     width=256, height=256)
    floor = spec.add_material(name="mjharness_floor", texrepeat=[4, 4], texuniform=True)
    floor.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = "mjharness_grid"
    for geom in spec.geoms:
        if geom.type == mujoco.mjtGeom.mjGEOM_PLANE and not geom.material:
            geom.material = "mjharness_floor"
    return spec.compile()


def _render_one(item: Mapping[str, Any]) -> bytes:  # (a JSON entry)
    from PIL import Image  # lazy: Pillow, in the render child only

    model = _staged(str(item["mjcf"]))
    data = mujoco.MjData(model)
    if item.get("qpos"):
        data.qpos[:] = item["qpos"]
    else:
        _pose(model, data, str(item["case"]), list(item["coordinates"]))
    mujoco.mj_forward(model, data)
    model.vis.headlight.ambient[:] = 0.45
    model.vis.headlight.diffuse[:] = 0.55
    model.vis.headlight.specular[:] = 0.1
    span = _extent(model, data)[2]  # joints drawn at a size set by the model, not by its mean body size
    model.vis.scale.jointlength = 0.36 * span / float(model.stat.meansize)
    model.vis.scale.jointwidth = 0.02 * span / float(model.stat.meansize)
    model.vis.map.znear = 0.01
    cam = _camera(model, data)
    options = mujoco.MjvOption()
    for flag in (mujoco.mjtVisFlag.mjVIS_JOINT, mujoco.mjtVisFlag.mjVIS_CONTACTPOINT,
                 mujoco.mjtVisFlag.mjVIS_CONTACTFORCE):
        options.flags[flag] = True
    model.vis.map.force = 0.3 * span / max(float(np.sum(model.body_mass)) * 9.81, 1e-9)  # m·g drawn 0.3 × span
    width = min(WIDTH, int(model.vis.global_.offwidth))
    height = min(HEIGHT, int(model.vis.global_.offheight))
    with mujoco.Renderer(model, height, width) as renderer:
        renderer.update_scene(data, camera=cam, scene_option=options)
        pixels = renderer.render()
    buf = io.BytesIO()
    Image.fromarray(pixels).save(buf, format="PNG")
    return buf.getvalue()


def _probe_gl() -> None:
    """Create and free a GL context; any failure here is the backend's, not a model's."""
    ctx = mujoco.GLContext(1, 1)
    ctx.make_current()
    ctx.free()


def _child() -> int:
    die_with_parent(os.getppid())  # a renderer outlives no command that was killed
    items = json.loads(sys.stdin.read())
    try:
        _probe_gl()
    except Exception as exc:
        print(f"OpenGL unavailable: {type(exc).__name__}: {' '.join(str(exc).split())[:160]}", file=sys.stderr)
        return 3
    out: dict[str, dict[str, str]] = {}
    for item in items:
        try:
            out[item["case"]] = {"png": base64.b64encode(_render_one(item)).decode("ascii")}
        except Exception as exc:  # a model-specific problem: report it, render the rest
            out[item["case"]] = {"error": " ".join(str(exc).split())[:200]}
    sys.stdout.write(json.dumps(out))
    return 0


if __name__ == "__main__":
    sys.exit(_child())
