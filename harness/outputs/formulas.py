"""Formulas on a page: LaTeX typeset as an image by matplotlib's mathtext (as the equations panel is), or
on one line of Unicode (:func:`harness.audit.notation.latex_text`) where it is prose with mathematics in
it or mathtext cannot typeset it — never raw LaTeX. Self-contained (PNG data URIs) and byte-identical for
identical inputs."""

from __future__ import annotations

import base64
import html
import re

from harness.audit.notation import latex_text
from harness.core.plotting import formula_png

__all__ = ["formula_html", "is_display", "quote_html", "text_html"]

FONTSIZE = 12.0
_SCRIPT = re.compile(r"([_^])\{([^{}]*)\}")
_COMMANDS = re.compile(r"\\(?:text|mathrm|operatorname)\{[^{}]*\}|\\[A-Za-z]+")
_PROSE = re.compile(r"[A-Za-z]{3,}[,.;:]?\s+[A-Za-z]{3,}")


def text_html(text: str) -> str:
    """``text`` escaped, with the script groups Unicode has no characters for (``Q_{k,Δ}``,
    ``∫_{t₁}^{t₂}``) set as sub- and superscripts."""
    return _SCRIPT.sub(lambda m: f"<{'sub' if m[1] == '_' else 'sup'}>{m[2]}</{'sub' if m[1] == '_' else 'sup'}>",
                       html.escape(text))


def is_display(source: str) -> bool:
    """A formula to typeset whole: no ``$``-delimited mathematics inside prose, and no two words in a row
    outside its ``\\text{...}``."""
    return "$" not in source and not _PROSE.search(_COMMANDS.sub(" ", source))


def formula_html(latex: str) -> str:
    """The formula as a typeset image (its LaTeX the alt text), or as Unicode where mathtext cannot set it."""
    png = formula_png(latex.replace(r"\frac{", r"\dfrac{"), fontsize=FONTSIZE)  # display-size fractions
    if png is None:
        return f"<span class='formula'>{text_html(latex_text(latex))}</span>"
    uri = "data:image/png;base64," + base64.b64encode(png).decode("ascii")
    return f"<img class='formula' src='{uri}' alt='{html.escape(latex, quote=True)}'>"


def quote_html(source: str) -> str:
    """A document's text as printed: a display typeset, prose (with its mathematics) in Unicode."""
    return formula_html(source) if is_display(source) else f"<span class='prose'>{text_html(latex_text(source))}</span>"
