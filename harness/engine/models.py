"""Finding and compiling MJCF models.

Paths resolve from the installed ``mjcf`` package, never the working
directory, so editable and regular installs behave the same. Settings are
changed through ``mujoco.MjSpec``, never by editing XML text.
"""

from __future__ import annotations

from collections.abc import Callable
from importlib import resources
from pathlib import Path

import mujoco

from harness.core.errors import ModelError
from harness.engine.compat import after_compile, spec_from_file
from harness.engine.integrators import integrator_enum


def mjcf_path(name: str) -> Path:
    """Path of the shipped model ``mjcf/NAME.xml``."""
    path = Path(str(resources.files("mjcf") / f"{name}.xml"))
    if not path.is_file():
        raise ModelError(f"no shipped model {name!r} (looked for {path})")
    return path


def load_spec(path: Path | str) -> mujoco.MjSpec:
    path = Path(path)
    if not path.is_file():
        raise ModelError(f"cannot read MJCF {str(path)!r}: no such file")
    try:
        return spec_from_file(str(path))  # MjSpec.from_file, with fallbacks for an older MuJoCo
    except Exception as exc:  # MuJoCo raises ValueError with the parser's message
        raise ModelError(f"invalid MJCF {str(path)!r}: {_one_line(exc)}") from None


def compile_model(
    path: Path | str,
    *,
    integrator: str | None = None,
    timestep: float | None = None,
    edit: Callable[[mujoco.MjSpec], None] | None = None,
) -> mujoco.MjModel:
    """Compile ``path`` with a spec edit and optional integrator/timestep overrides (applied after the
    edit, so that they hold whatever the edit sets)."""
    spec = load_spec(path)
    if edit is not None:
        edit(spec)
    if integrator is not None:
        spec.option.integrator = integrator_enum(integrator)
    if timestep is not None:
        if not timestep > 0:
            raise ValueError(f"timestep must be positive, got {timestep}")
        spec.option.timestep = timestep
    try:
        model = spec.compile()
    except Exception as exc:
        raise ModelError(f"invalid MJCF {str(path)!r}: {_one_line(exc)}") from None
    after_compile(model, str(path))  # fallbacks for an older MuJoCo (harness.compat)
    return model


def _one_line(exc: Exception) -> str:
    return " ".join(str(exc).split())
