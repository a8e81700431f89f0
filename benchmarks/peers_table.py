"""The three-way comparison (harness/opinions/threeway.py) over every shipped model, the examples and every MJCF
of dm_control's suite and Gymnasium's assets that compiles alone: the table of docs/findings/peers.md, as
markdown rows (needs the pin and zoo extras).

    python benchmarks/peers_table.py
"""

from __future__ import annotations

import glob
import time
from pathlib import Path

import dm_control
import mujoco

from harness.opinions import threeway


def main() -> None:
    site = str(Path(dm_control.__file__).parent.parent) + "/"
    paths = [*sorted(glob.glob("mjcf/*.xml")), "examples/arm.xml", "examples/urdf/arm.xml",
             *sorted(glob.glob(site + "dm_control/suite/*.xml")),
             *sorted(glob.glob(site + "gymnasium/envs/mujoco/assets/*.xml"))]
    for path in paths:
        try:
            model = mujoco.MjModel.from_xml_path(path)
        except ValueError:  # an asset that is only an include of another model
            continue
        name = path.replace(site, "").replace("envs/mujoco/assets/", "").replace("suite/", "")
        start = time.perf_counter()
        result = threeway.three_way(model)
        seconds = time.perf_counter() - start
        if result.skipped:
            why = result.skipped.removeprefix("second opinions skipped: ")
            print(f"| {name} | {model.nv} | | | | | | skipped: {why} | |")
            continue
        cells = " | ".join(f"{a.mujoco:.2g} / {max(a.pairs.values()):.2g}" for a in result.agreements)
        off = ", ".join(f"{a.quantity}: {a.off}" for a in result.agreements if a.off) or "all agree"
        print(f"| {name} | {model.nv} | {result.conditioning:.2g} | {cells} | {off} | {seconds * 1000:.0f} |")


if __name__ == "__main__":
    main()
