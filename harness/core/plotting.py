"""matplotlib, imported on first use: the plots of reports and studies, as PNG bytes.

``pyplot()`` selects the Agg backend (PNG bytes, no display) and the report's
style the first time it is called. Commands that draw nothing (``check``,
``baseline``, ``diff``) never import matplotlib, which costs about 0.16 s of
every such run's start. PNGs carry no Software or time metadata, so the same
plot gives byte-identical images.
"""

from __future__ import annotations

import base64
import functools
import io
from types import ModuleType

STYLE = {"figure.dpi": 90, "font.size": 9, "svg.hashsalt": "mjharness"}


@functools.cache
def pyplot() -> ModuleType:
    """``matplotlib.pyplot`` on the Agg backend, with :data:`STYLE`."""
    import matplotlib  # lazy: 0.16 s, only for commands that draw

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # lazy: as above

    plt.rcParams.update(STYLE)
    return plt


def png_bytes(fig, **savefig) -> bytes:
    """Render and close ``fig``; PNG bytes without the Software/time metadata. ``savefig`` options
    override the defaults (dpi 90, tight bounding box)."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", **({"dpi": 90, "metadata": {"Software": None}, "bbox_inches": "tight"}
                                      | savefig))
    pyplot().close(fig)
    return buf.getvalue()


def png_data_uri(png: bytes) -> str:
    """PNG bytes as a data URI, for a self-contained HTML page."""
    return "data:image/png;base64," + base64.b64encode(png).decode("ascii")
