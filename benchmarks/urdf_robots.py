"""Real robots' URDFs against MuJoCo's own URDF import of them, and Pinocchio's MJCF parser over the zoo's and the
shipped models: the figures of docs/findings/urdf.md. Run from the repository's root (needs the ``robots`` extra):

    python benchmarks/urdf_robots.py

Each URDF is loaded by Pinocchio as shipped (``buildModelFromUrdf`` reads no meshes) and by MuJoCo from a copy with
every ``<visual>`` and ``<collision>`` element removed: MuJoCo's import would open their mesh files, which
the comparison does not need (the ``<inertial>`` tags are what it compares), and with the geoms gone MuJoCo's
``inertiafromgeom="auto"`` can take nothing from them. MuJoCo's URDF defaults are kept (``fusestatic`` and
``discardvisual`` true, ``balanceinertia`` false); MuJoCo adds no free joint, nor does Pinocchio here.
"""

from __future__ import annotations

import re
import sys
import tempfile
from pathlib import Path

import mujoco

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from harness import zoo  # noqa: E402
from harness.opinions.parser import parser_opinion  # noqa: E402
from harness.opinions.structure import compare  # noqa: E402
from harness.opinions.urdf import load_urdf  # noqa: E402


def robots() -> list[tuple[str, Path]]:
    """The URDFs compared: example-robot-data's and pybullet_data's, where installed."""
    out = []
    base = Path(mujoco.__file__).parents[1] / "cmeel.prefix" / "share" / "example-robot-data" / "robots"
    if base.is_dir():  # example-robot-data, installed as a cmeel package beside mujoco
        out += [(f"example-robot-data/{p.stem}", base / p) for p in (
            Path("ur_description/urdf/ur5_robot.urdf"), Path("panda_description/urdf/panda.urdf"),
            Path("solo_description/robots/solo12.urdf"), Path("a1_description/urdf/a1.urdf"),
            Path("anymal_b_simple_description/robots/anymal.urdf"), Path("talos_data/robots/talos_reduced.urdf"))]
    try:
        import pybullet_data

        base = Path(pybullet_data.getDataPath())
        out += [(f"pybullet_data/{p.parent.name}/{p.stem}", base / p) for p in (
            Path("kuka_iiwa/model.urdf"), Path("franka_panda/panda.urdf"))]
    except ImportError:
        pass
    return [(name, path) for name, path in out if path.is_file()]


def mujoco_import(urdf: Path) -> mujoco.MjModel:
    """MuJoCo's own import of ``urdf``, its visual and collision elements removed (see the module's docstring)."""
    text = re.sub(r"<(visual|collision)\b.*?</\1>", "", urdf.read_text(), flags=re.S)
    text = re.sub(r"<(visual|collision)\b[^>]*/>", "", text)
    with tempfile.NamedTemporaryFile("w", suffix=".urdf", delete=False) as fh:
        fh.write(text)
    try:
        return mujoco.MjModel.from_xml_path(fh.name)
    finally:
        Path(fh.name).unlink()


def urdf_rows() -> list[str]:
    lines = ["| robot | moving bodies | joints | differences over tolerance |", "|---|---|---|---|"]
    for name, path in robots():
        try:
            model = mujoco_import(path)
        except ValueError as exc:
            lines.append(f"| {name} | | | MuJoCo refuses the URDF: {' '.join(str(exc).split())} |")
            continue
        c = compare(load_urdf(path), model)
        listed = [f"only in URDF: {x}" for x in c.only_a] + [f"only in MuJoCo: {x}" for x in c.only_b]
        listed += [d.line("URDF", "MuJoCo") for d in c.differences]
        lines.append(f"| {name} | {len(c.bodies)} | {c.joints} | {'<br>'.join(listed) or 'none'} |")
    return lines


def parser_rows() -> list[str]:
    models, _ = zoo.discover()
    paths = [(m.name, m.path) for m in models] + [(f"mjcf/{p.stem}", p) for p in sorted((ROOT / "mjcf").glob("*.xml"))]
    lines = ["| model | Pinocchio's parser against MuJoCo's compiler |", "|---|---|"]
    for name, path in paths:
        try:
            model = mujoco.MjModel.from_xml_path(str(path))
        except ValueError as exc:
            lines.append(f"| {name} | MuJoCo refuses it: {' '.join(str(exc).split())[:120]} |")
            continue
        said = parser_opinion(path, model).lines()
        lines.append(f"| {name} | {'<br>'.join(s.strip() for s in said).replace('|', '/')} |")
    return lines


if __name__ == "__main__":
    print(f"MuJoCo {mujoco.__version__}\n")
    print("\n".join(urdf_rows()))
    print()
    print("\n".join(parser_rows()))
