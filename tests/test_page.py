"""The parts that make report.html readable, each on its own: the table of contents read from the page,
numbers that do not break, formulas typeset or in Unicode (never raw LaTeX), equations broken to fit,
plots whose coinciding curves are named together, and model stills with a sky, a floor and a camera that
shows how two models of one system differ. (The whole page in a browser: tests/test_browser.py.)"""

from __future__ import annotations

import io
import re

import mujoco
import numpy as np
import pytest

from harness import cases
from harness.audit.notation import latex_text
from harness.core.plotting import coinciding, formula_png
from harness.outputs import page, stills
from harness.outputs.equations import MAX_WIDTH_PX, equations, width_px
from harness.outputs.formulas import formula_html, is_display, quote_html, text_html
from harness.reference.derivations import derivation

# ------------------------------------------------------------- contents
BODY = ("<section id='summary'><h2>Summary</h2></section>"
        "<section id='pendulum'><h2>pendulum <span class='badge'>PASS 3/3</span></h2><div>"
        "<section><h3>no id: not listed</h3><section id='inner'><h4>inside one without an id</h4></section>"
        "</section></div></section>"
        "<section id='studies'><h2>Studies</h2><section id='converge-pendulum'><h3>Convergence: pendulum</h3>"
        "</section></section>")


def test_the_contents_list_every_section_with_an_id_nested_as_on_the_page():
    tree = page.outline(BODY)
    assert [(e.anchor, e.title) for e in tree] == [("summary", "Summary"), ("pendulum", "pendulum PASS 3/3"),
                                                   ("studies", "Studies")]
    assert [e.anchor for e in tree[1].children] == ["inner"]
    assert [(e.anchor, e.title) for e in tree[2].children] == [("converge-pendulum", "Convergence: pendulum")]
    nav = page.table_of_contents(BODY)
    assert re.findall(r"href='#([^']+)'", nav) == ["summary", "pendulum", "inner", "studies", "converge-pendulum",
                                                   page.CONTENTS_ID]  # the last: the way back
    assert f"id='{page.CONTENTS_ID}'" in nav


def test_numbers_in_text_are_kept_whole_and_tags_styles_and_attributes_are_left_alone():
    html = ("<style>.x{margin:1e-3px}</style><td title='4.99e-04'>4.99e-04 and −1.2e+03</td>"
            "<img alt='2e-5' src='data:image/png;base64,AAAe-1'>1e-12")
    out = page.unbroken_numbers(html)
    assert out == ("<style>.x{margin:1e-3px}</style><td title='4.99e-04'><span class='nb'>4.99e-04</span> and "
                   "<span class='nb'>−1.2e+03</span></td><img alt='2e-5' src='data:image/png;base64,AAAe-1'>"
                   "<span class='nb'>1e-12</span>")


# ------------------------------------------------------------- formulas
@pytest.mark.parametrize("source, text", [
    (r"\frac{d}{dt}\frac{\partial L}{\partial \dot q_i} - \frac{\partial L}{\partial q_i} = 0",
     "d/dt ∂L/∂q̇_i - ∂L/∂q_i = 0"),
    (r"\lambda_2 = \frac{m_p + 2m_1}{-m_p + m_1 + m_2} m_2 g", "λ₂ = (m_p + 2m₁)/(-m_p + m₁ + m₂) m₂ g"),
    (r"ml^2\ddot{\phi}\sin^2\theta = 0", "ml²φ̈ sin²θ = 0"),
    (r"\text{No } Q_{k,\triangle} \text{: no forces}", "No Q_{k,Δ} : no forces"),
    (r"a path from the point $(q_1, \dot{q_1})$", "a path from the point (q₁, q̇₁)"),
    ("we only have 1 independent coordinate", "we only have 1 independent coordinate"),
])
def test_the_documents_latex_reads_as_one_line_of_unicode(source, text):
    assert latex_text(source) == text


def test_script_groups_unicode_lacks_are_set_as_sub_and_superscripts():
    assert text_html("∫_{t₁}^{t₂} Q_{k,Δ} <x>") == "∫<sub>t₁</sub><sup>t₂</sup> Q<sub>k,Δ</sub> &lt;x&gt;"


def test_a_display_is_typeset_prose_is_unicode_and_neither_shows_latex():
    display = r"\ddot{z}_1 = -\frac{m_1 - m_2}{m_p + m_1 + m_2}g"
    assert is_display(display) and not is_display("The principle of least action: \\delta S = 0")
    shown = quote_html(display)
    assert shown.startswith("<img class='formula' src='data:image/png;base64,")
    prose = quote_html("The boundary term is $0$ because $\\delta q$ vanishes")
    assert prose == "<span class='prose'>The boundary term is 0 because δq vanishes</span>"
    unparsable = formula_html(r"\bigg\rvert_{t_1} x")  # mathtext cannot set it: Unicode, never the LaTeX
    assert "\\" not in unparsable and "<sub>t₁</sub>" in unparsable


# ------------------------------------------------------------ equations
def test_wide_equations_are_broken_between_terms_to_fit_beside_the_model():
    eqs = {e.label: e for e in equations(derivation("double_pendulum"))}
    kinetic = eqs["kinetic energy"]
    assert width_px(kinetic.latex) > MAX_WIDTH_PX and len(kinetic.shown) > 1
    for e in eqs.values():
        assert all(width_px(line) <= MAX_WIDTH_PX for line in e.shown), (e.label, e.shown)
        assert formula_png(e.shown) is not None
    assert kinetic.shown[0].startswith("T = ") and all(line.startswith(r"\qquad ") for line in kinetic.shown[1:])
    assert eqs["equation for theta1"].shown[-1].endswith(" = 0")
    assert all(len(e.shown) == 1 for e in equations(derivation("pendulum")))  # what fits stays on one line


# ---------------------------------------------------------------- plots
def test_coinciding_curves_are_drawn_once_and_named_together():
    a = np.array([1e-3, 2e-3, 4e-3])
    groups = coinciding({"Euler": a, "implicit": a * (1 + 1e-4), "implicitfast": a.copy(), "RK4": a * 1e-6,
                         "discrete": a.copy()})
    assert groups == [(["Euler", "implicit", "implicitfast", "discrete"],
                       "Euler ≈ implicit ≈ implicitfast ≈ discrete (within 1 %)"), (["RK4"], "RK4")]
    assert coinciding({"Euler": a, "discrete": a.copy()}) == [(["Euler", "discrete"],
                                                                "Euler = discrete (identical)")]


# --------------------------------------------------------------- stills
def _posed(name: str):
    case = cases.get(name)
    model = stills._staged(str(case.mjcf))
    data = mujoco.MjData(model)
    stills._pose(model, data, name, [q.name for q in derivation(case.system).system.q])
    mujoco.mj_forward(model, data)
    return model, data


def test_a_still_has_a_sky_and_a_floor_but_the_physics_is_untouched():
    model, _ = _posed("pendulum")
    shipped = mujoco.MjModel.from_xml_path(str(cases.get("pendulum").mjcf))
    assert int(mujoco.mjtTexture.mjTEXTURE_SKYBOX) in model.tex_type.tolist() and model.nmat == shipped.nmat + 1
    assert (model.nbody, model.njnt, model.neq, model.opt.timestep) == (
        shipped.nbody, shipped.njnt, shipped.neq, shipped.opt.timestep)
    assert np.array_equal(model.body_mass, shipped.body_mass)


def test_a_planar_model_is_seen_face_on_and_a_spatial_one_obliquely():
    assert stills.planar(*_posed("pendulum")) and stills.planar(*_posed("double_pendulum"))
    assert not stills.planar(*_posed("spherical_pendulum"))
    assert not stills.planar(*_posed("spherical_pendulum_ball"))


def test_the_rendered_still_has_no_black_sky_and_shows_the_two_pendulum_models_apart():
    got = stills.stills([stills.Request(n, str(cases.get(n).mjcf), tuple(
        q.name for q in derivation(cases.get(n).system).system.q)) for n in
        ("spherical_pendulum", "spherical_pendulum_ball")])
    if any(s.png is None for s in got.values()):
        pytest.skip(f"no OpenGL here: {next(s.note for s in got.values() if s.png is None)}")
    from PIL import Image  # lazy: Pillow comes with matplotlib

    pixels = {n: np.asarray(Image.open(io.BytesIO(s.png)).convert("RGB"), dtype=float) for n, s in got.items()}
    for n, px in pixels.items():
        top = px[: px.shape[0] // 3]
        assert top.mean() > 150, f"{n}: the upper third is dark ({top.mean():.0f} of 255)"
    difference = np.abs(pixels["spherical_pendulum"] - pixels["spherical_pendulum_ball"]).max(axis=2)
    assert (difference > 60).mean() > 0.002  # the hinge arrows vs the ball: not the same picture
