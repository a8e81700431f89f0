"""Layer 4 for contacts: slip and force error vs friction cone, impratio, noslip and softness.

One reference per case, then one MuJoCo run per setting (the model's own
integrator and timestep), each compared with the same figures run_case uses.
The settings swept are the options that decide how MuJoCo's soft contact
approximates rolling without slipping:

- ``cone``: pyramidal or elliptic friction cone;
- ``impratio``: ratio of frictional to normal impedance (elliptic cones);
- ``noslip_iterations``: the NoSlip post-processing pass (hard friction rows);
- softness: the case's own contact ``solref``/``solimp`` ("shipped") or
  MuJoCo's defaults ("mujoco_default": solref 0.02 1, solimp 0.9 0.95 0.001
  0.5 2), to show which of the three matter where.

The figures per row: the largest slip speed (J q̇ + b of the rolling rows at
MuJoCo's state) over the horizon and over its second half (the steady, slow
slippage), the penetration, the error of every contact multiplier (after the
settle time run_case uses, / m g), the position error and MuJoCo's energy drift.
"""

from __future__ import annotations

import base64
import html
import itertools
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

from harness import cases
from harness.core.errors import SimulationDiverged
from harness.core.plotting import FULL_WIDTH, png_bytes, pyplot
from harness.engine.backends import simulate
from harness.engine.integrators import integrator_name
from harness.engine.models import compile_model
from harness.engine.recording import steps_in
from harness.layers.trajectory import trajectory_figures
from harness.pipeline.run import settle_time
from harness.reference import solutions as refmod

CONES = ("pyramidal", "elliptic")
IMPRATIOS = (1.0, 10.0, 100.0)
NOSLIP_ITERATIONS = (0, 3)
SOFTNESS: Mapping[str, tuple[tuple[float, ...], tuple[float, ...]] | None] = {
    "shipped": None,
    "mujoco_default": ((0.02, 1.0), (0.9, 0.95, 0.001, 0.5, 2.0)),
}


# a row's figures, nan where its run diverged (the row's "diverged" says why)
DIVERGED_NAN = ("slip_max", "slip_late", "penetration", "force_error", "position", "drift.energy")


@dataclass(frozen=True)
class StudyResult:
    """Rows of the study (one dict per setting) and the settings the MJCF ships."""

    case: str
    integrator: str
    timestep: float
    shipped: Mapping[str, object]
    rows: tuple[Mapping[str, object], ...]

    def shipped_row(self) -> Mapping[str, object]:
        """The row with the MJCF's own cone, impratio, noslip and softness."""
        for row in self.rows:
            if row["softness"] == "shipped" and all(row[k] == v for k, v in self.shipped.items()):
                return row
        raise ValueError(f"the study did not include the shipped settings {dict(self.shipped)}")

    def plot_png(self) -> bytes:
        """Steady slip, worst force error and position error per setting, as PNG bytes: one horizontal bar
        a setting in three panels side by side, labelled in the table's order (the shipped row in bold)."""
        plt = pyplot()
        from matplotlib.patches import Patch  # lazy: matplotlib loads only to draw

        shipped = self.shipped_row()
        labels = [f"{r['cone']}, impratio {r['impratio']:g}, noslip {r['noslip_iterations']}, {r['softness']}"
                  for r in self.rows]
        colours = ["tab:blue" if r["cone"] == "elliptic" else "tab:orange" for r in self.rows]
        panels = [("slip_late", "steady slip [m/s]\n(max over the 2nd half)"),
                  ("force_error", "worst contact force\nerror / m g"),
                  ("position", "position error [m]")]
        fig, axes = plt.subplots(1, len(panels), figsize=(FULL_WIDTH, 1.4 + 0.19 * len(self.rows)), sharey=True,
                                 layout="constrained")
        y = np.arange(len(self.rows))
        for ax, (key, title) in zip(axes, panels, strict=True):
            values = np.array([float(r[key]) for r in self.rows])
            finite = np.isfinite(values)  # a setting whose run diverged has no number: named, not drawn
            values = np.maximum(values[finite], 1e-16)
            ax.barh(y[finite], values, color=[c for c, f in zip(colours, finite, strict=True) if f], height=0.7)
            ax.set_xscale("log")  # whole decades, labelled at the decades only (minor labels would collide)
            if values.size:
                ax.set_xlim(10 ** np.floor(np.log10(values.min())), 10 ** np.ceil(np.log10(values.max())))
            for row in y[~finite]:
                ax.annotate("diverged", (0.02, row), xycoords=("axes fraction", "data"), va="center", fontsize=8)
            ax.tick_params(axis="x", which="minor", labelbottom=False)
            ax.set_title(title)
            ax.grid(True, axis="x", alpha=0.3)
        axes[0].set_yticks(y, labels)
        axes[0].invert_yaxis()  # the table's order, top to bottom
        for tick, row in zip(axes[0].get_yticklabels(), self.rows, strict=True):
            tick.set_fontweight("bold" if row is shipped else "normal")
        fig.legend(handles=[Patch(color="tab:orange", label="pyramidal cone"),
                            Patch(color="tab:blue", label="elliptic cone")], loc="outside lower center", ncol=2,
                   frameon=False)
        fig.suptitle(f"{self.case}: contact settings ({self.integrator}, h = {self.timestep:g} s; "
                     "the shipped settings in bold)")
        return png_bytes(fig)


def _options(model: mujoco.MjModel) -> dict[str, object]:
    return {"cone": mujoco.mjtCone(int(model.opt.cone)).name.removeprefix("mjCONE_").lower(),
            "impratio": float(model.opt.impratio),
            "noslip_iterations": int(model.opt.noslip_iterations)}


def _edit(cone: str, impratio: float, noslip: int, softness: tuple | None):
    def edit(spec: mujoco.MjSpec) -> None:
        spec.option.cone = getattr(mujoco.mjtCone, f"mjCONE_{cone.upper()}")
        spec.option.impratio = impratio
        spec.option.noslip_iterations = noslip
        if softness is not None:
            for pair in spec.pairs:
                pair.solref, pair.solimp = list(softness[0]), list(softness[1])

    return edit


def _validate(values: Sequence, allowed: Sequence | None, label: str) -> None:
    if not values:
        raise ValueError(f"{label} must not be empty")
    if allowed is not None and set(values) - set(allowed):
        raise ValueError(f"{label} must be among {list(allowed)}, got {list(values)}")


def contact_study(
    case_name: str,
    *,
    cones: Sequence[str] = CONES,
    impratios: Sequence[float] = IMPRATIOS,
    noslip_iterations: Sequence[int] = NOSLIP_ITERATIONS,
    softness: Sequence[str] = tuple(SOFTNESS),
) -> StudyResult:
    """Run ``case_name`` (a case with a contact <pair> and a ``slip`` series) at every
    combination of the settings; one row per combination."""
    case = cases.get(case_name)
    _validate(cones, CONES, "cones")
    _validate(softness, tuple(SOFTNESS), "softness")
    _validate(impratios, None, "impratios")
    _validate(noslip_iterations, None, "noslip_iterations")
    if any(not r >= 1 for r in impratios) or any(n < 0 for n in noslip_iterations):
        raise ValueError(f"impratios must be >= 1 and noslip_iterations >= 0, got {impratios}, "
                         f"{noslip_iterations}")
    path = case.mjcf
    shipped_model = compile_model(path)
    if shipped_model.npair == 0 or "slip" not in case.mujoco_series:
        raise ValueError(f"case {case_name!r} has no contact pair and slip series; contact cases: "
                         f"{[c.name for c in cases.all_cases() if 'slip' in c.mujoco_series]}")
    ref = case.reference(shipped_model)
    probe = case.probe(ref.dynamics)
    steps = steps_in(case.horizon, shipped_model.opt.timestep)
    rows = []
    for soft, cone, imp, ns in itertools.product(softness, cones, impratios, noslip_iterations):
        model = compile_model(path, edit=_edit(cone, float(imp), int(ns), SOFTNESS[soft]))
        setting = {"softness": soft, "cone": cone, "impratio": float(imp), "noslip_iterations": int(ns),
                   "solref": [float(x) for x in model.pair_solref[0]]}
        try:
            sim = simulate(model, probe, q0=ref.q0(), qd0=ref.qd0(), steps=steps)
        except SimulationDiverged as exc:  # a finding of the sweep, never a number
            rows.append({**setting, **dict.fromkeys(DIVERGED_NAN + tuple(f"force.{c}" for c in case.mujoco_forces),
                                                    float("nan")), "diverged": exc.reason})
            continue
        ref_traj = refmod.trajectory(ref, sim.t)
        figs = {f.name.removeprefix("sim."): f.value
                for f in trajectory_figures(ref_traj, sim, ref.scales, prefix="sim",
                                            settle=settle_time(case, model, case.horizon)[0],
                                            series=case.mujoco_series)}
        forces = {f"force.{c}": figs[f"force.{c}"] for c in case.mujoco_forces}
        slip = sim.series["slip"]
        rows.append({
            **setting,
            "slip_max": float(np.max(np.abs(slip))),
            "slip_late": float(np.max(np.abs(slip[len(slip) // 2:]))),
            "penetration": figs.get("series.penetration", float("nan")),
            **forces,
            "force_error": max(forces.values()),
            "position": figs["position"],
            "drift.energy": figs["drift.energy"],
        })
    return StudyResult(case=case_name, integrator=integrator_name(shipped_model),
                       timestep=float(shipped_model.opt.timestep), shipped=_options(shipped_model),
                       rows=tuple(rows))


def _settings_text(settings: Mapping[str, object]) -> str:
    """``cone = elliptic, impratio = 10, noslip_iterations = 0``: the settings as a reader writes them."""
    return ", ".join(f"{k} = {v:g}" if isinstance(v, float) else f"{k} = {v}" for k, v in settings.items())


def html_section(results: Sequence[StudyResult]) -> str:
    """The contact-settings studies as a report section: a table per case (shipped row marked) and its plot."""
    parts = []
    for r in results:
        keys = ("cone", "impratio", "noslip_iterations", "softness", "slip_late", "force_error", "position",
                *(("diverged",) if any("diverged" in row for row in r.rows) else ()))
        shipped = r.shipped_row()
        head = "".join(f"<th>{k}</th>" for k in keys)
        rows = "".join(
            "<tr" + (" class='shipped'" if row is shipped else "") + ">"
            + "".join(f"<td>{row[k]:.3g}</td>" if isinstance(row.get(k), float)
                      else f"<td>{html.escape(str(row.get(k, '')))}</td>" for k in keys) + "</tr>" for row in r.rows)
        img = base64.b64encode(r.plot_png()).decode("ascii")
        parts.append(f"<section id='contact-{html.escape(r.case)}'>"
                     f"<h3>{html.escape(r.case)}: cone, impratio, noslip ({html.escape(r.integrator)}, "
                     f"h = {r.timestep:g} s)</h3><p>Shipped settings: {html.escape(_settings_text(r.shipped))} "
                     f"(bold row). slip_late: steady slip velocity (m/s), max over the second half; "
                     f"force_error: worst contact force error / m g; position: max position error (m).</p>"
                     f"<table><tr>{head}</tr>{rows}</table><img src='data:image/png;base64,{img}' "
                     f"alt='contact settings of {html.escape(r.case)}'></section>")
    return (f"<section id='contact-study'><h2>Contact settings study</h2>{''.join(parts)}</section>"
            if parts else "")
