"""MuJoCo-side angular momentum, from MuJoCo's own state (never via analytic coordinates).

The conserved momentum of a cyclic azimuth (``p_phi`` of the spherical
pendulum) is the component along the symmetry axis of the angular momentum
about a fixed point. Here it is assembled from ``mj_subtreeVel``:

    L_o = subtree_angmom + M (subtree_com − o) × subtree_linvel

(angular momentum about the subtree's centre of mass, plus that of its total
mass M moving with the centre of mass), so it includes the bodies' own spin and
is the quantity MuJoCo's dynamics conserves when gravity is along the axis.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import mujoco
import numpy as np

# same shape as harness.cases.Reading, which cannot be imported here (cases imports this module)
Reading = Callable[[mujoco.MjModel, mujoco.MjData], float]


def axial_angular_momentum(*, body: str, site: str, axis: Sequence[float] = (0.0, 0.0, 1.0)) -> Reading:
    """A reading of axis · L about ``site`` of the subtree rooted at ``body``.

    ``axis`` is a world direction (normalised here); the reading expects
    ``mj_forward`` to have run and calls ``mj_subtreeVel`` itself.
    """
    unit = np.asarray(axis, dtype=float)
    if unit.shape != (3,) or not np.linalg.norm(unit) > 0:
        raise ValueError(f"axis must be a non-zero 3-vector, got {axis!r}")
    unit = unit / np.linalg.norm(unit)

    def read(model: mujoco.MjModel, data: mujoco.MjData) -> float:
        bid = model.body(body).id
        origin = data.site_xpos[model.site(site).id]
        mujoco.mj_subtreeVel(model, data)
        about_com = data.subtree_angmom[bid]
        transport = model.body_subtreemass[bid] * np.cross(data.subtree_com[bid] - origin,
                                                             data.subtree_linvel[bid])
        return float(unit @ (about_com + transport))

    read.__doc__ = f"axis {unit.tolist()} · angular momentum of subtree {body!r} about site {site!r}"
    return read
