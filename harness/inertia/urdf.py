"""A URDF compiled by MuJoCo with its own meshes, for the inertia audit: every ``<visual>`` and ``<collision>``
kept (MuJoCo's URDF default discards the visuals) and no fixed-joint child fused into its parent, so each link's
``<inertial>`` is held against that link's own geometry.

Mesh files are found as ROS finds them: ``package://NAME/rest`` in the ancestor folder named NAME (or an
ancestor's NAME sub-folder, or a folder of ``$ROS_PACKAGE_PATH``), ``file://`` and relative paths from the
URDF's folder. A mesh MuJoCo cannot read (Collada ``.dae``: MuJoCo reads STL, OBJ and MSH) or cannot find is left
out with its geoms, and its link's geometry is named partial (the audit then turns a bound that needs the
geometry into a warning: the missing part might hold the mass).
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import mujoco

from harness.core.errors import ModelError

__all__ = ["urdf_model"]

READABLE = (".stl", ".obj", ".msh")
_OPTIONS = '<mujoco><compiler discardvisual="false" fusestatic="false"/></mujoco>'


def resolve(filename: str, base: Path) -> Path | None:
    """The file a URDF's mesh ``filename`` names, looked up from the URDF's folder ``base`` (None: not found)."""
    if filename.startswith("file://"):
        filename = filename[len("file://"):]
    if not filename.startswith("package://"):
        path = (base / filename) if not os.path.isabs(filename) else Path(filename)
        return path if path.is_file() else None
    package, _, rest = filename[len("package://"):].partition("/")
    roots = [p for p in (base, *base.parents)]
    candidates = [r / rest for r in roots if r.name == package] + [r / package / rest for r in roots]
    candidates += [Path(p) / package / rest for p in os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep) if p]
    return next((c for c in candidates if c.is_file()), None)


def urdf_model(path: Path | str) -> tuple[mujoco.MjModel, dict[str, str]]:
    """MuJoCo's model of the URDF ``path`` with its geometry (see the module's docstring), and the links whose
    geometry is partial, each with why."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ModelError(f"cannot read URDF {str(path)!r}: {exc}; accepted: a URDF (XML) file") from None
    text = re.sub(r"<mujoco\b.*?</mujoco>", "", text, flags=re.S)  # ours replace the file's own options
    text, found = re.subn(r"(<robot\b[^>]*>)", r"\1" + _OPTIONS, text, count=1)
    if not found:
        raise ModelError(f"invalid URDF {str(path)!r}: no <robot> element; accepted: a URDF (XML) file")
    try:
        spec = mujoco.MjSpec.from_string(text)
    except Exception as exc:
        raise ModelError(f"invalid URDF {str(path)!r}: {' '.join(str(exc).split())}; accepted: a URDF that "
                         "MuJoCo's URDF import reads") from None
    partial: dict[str, str] = {}
    dropped = set()
    for mesh in list(spec.meshes):
        file = resolve(mesh.file, path.parent)
        if file is None or file.suffix.lower() not in READABLE:
            why = "not found" if file is None else f"{file.suffix} (MuJoCo reads {', '.join(READABLE)})"
            dropped.add(mesh.name)
            for geom in [g for g in spec.geoms if g.meshname == mesh.name]:
                partial.setdefault(geom.parent.name, f"mesh {Path(mesh.file).name} left out: {why}")
                _delete(spec, geom)
            _delete(spec, mesh)
        else:
            mesh.file = str(file)
    try:
        return spec.compile(), partial
    except Exception as exc:
        raise ModelError(f"invalid URDF {str(path)!r}: {' '.join(str(exc).split())}; accepted: a URDF that "
                         "MuJoCo's URDF import compiles") from None


def _delete(spec: mujoco.MjSpec, element) -> None:
    """Remove ``element`` from ``spec``: ``MjSpec.delete`` where this MuJoCo has it, the element's own ``delete``
    before (MuJoCo 3.3.0)."""
    if hasattr(spec, "delete"):
        spec.delete(element)
    else:
        element.delete()
