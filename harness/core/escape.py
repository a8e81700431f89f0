"""Text from outside (file names, model element names, command-line values) escaped for where it lands.

A file name may hold any character but ``/`` and NUL, and a model's names any at all: markup (``<svg
onload=...>``), quotes that close an attribute, a ``|`` or newline that splits a Markdown table row, a control
character that makes XML not well-formed, or an ESC that drives the user's terminal. Every output writes such
text through one of these, chosen by where it lands (docs/security.md):

- :func:`html_text` and :func:`html_attr`: HTML element content and quoted attribute values;
- :func:`markdown_cell`: a cell of a Markdown table, or a line of Markdown (no markup, no table break);
- :func:`xml_text`: XML text and attribute values (JUnit);
- :func:`terminal`: a line for the terminal (no escape sequences, no line breaks).

Control and format characters (category Cc and Cf, which include ESC, BEL, NUL and the bidirectional
overrides) are written visibly as ``\\xNN``/``\\uNNNN`` everywhere: a reader sees the name that was given,
never what its characters would do.
"""

from __future__ import annotations

import html
import unicodedata

__all__ = ["html_attr", "html_text", "markdown_cell", "terminal", "visible", "xml_text"]


def visible(text: object) -> str:
    """``text`` with every control or format character written as its escape (``\\x1b``, ``\\u202e``)."""
    s = str(text)
    if s.isprintable():
        return s
    return "".join(c if c == " " or unicodedata.category(c) not in ("Cc", "Cf", "Cs", "Zl", "Zp")
                   else (f"\\x{ord(c):02x}" if ord(c) < 0x100 else f"\\u{ord(c):04x}") for c in s)


def html_text(text: object) -> str:
    """``text`` as HTML element content (markup characters and quotes as entities)."""
    return html.escape(visible(text), quote=True)


def html_attr(text: object) -> str:
    """``text`` as an HTML attribute value, quoted with ``'`` or ``"`` (both escaped)."""
    return html.escape(visible(text), quote=True)


# what changes a cell's structure or makes a link (emphasis characters only restyle: left as they are)
_MARKDOWN_SPECIAL = "\\`|[]"


def markdown_cell(text: object) -> str:
    """``text`` as a Markdown table cell or inline text: one line, no table break, no link, no HTML (GitHub
    renders HTML in Markdown): ``&`` and ``<`` (which opens every tag) as entities, the other specials
    backslash-escaped."""
    s = visible(text).replace("&", "&amp;").replace("<", "&lt;")
    return "".join(f"\\{c}" if c in _MARKDOWN_SPECIAL else c for c in s)


def xml_text(text: object) -> str:
    """``text`` with the characters XML 1.0 cannot hold (controls) written visibly; the XML writer escapes
    markup."""
    return visible(text)


def terminal(text: object) -> str:
    """``text`` as one line for the terminal: no escape sequences, bells or line breaks take effect."""
    return visible(text)
