"""matplotlib, imported on first use: the plots of reports and studies.

``pyplot()`` selects the Agg backend (PNG bytes, no display) and the report's
style the first time it is called. Commands that draw nothing (``check``,
``baseline``, ``diff``) never import matplotlib, which costs about 0.16 s of
every such run's start.
"""

from __future__ import annotations

import functools
from types import ModuleType

STYLE = {"figure.dpi": 90, "font.size": 9, "svg.hashsalt": "mjharness"}


@functools.cache
def pyplot() -> ModuleType:
    """``matplotlib.pyplot`` on the Agg backend, with :data:`STYLE`."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    plt.rcParams.update(STYLE)
    return plt
