"""Where a named analytic point is read in a MuJoCo model: a site, or a body's centre of mass.

An analytic point whose name is a site of the model is that site: its world
position ``site_xpos`` and its velocity and acceleration as a point fixed in the
site's body (``mj_jac``/``mj_jacDot`` at ``site_xpos`` on ``site_bodyid``). A
body-fixed point away from the centre of mass is how a rigid body's orientation
is observed (the tip of a link, the rim of a top), compared through world
positions that never wrap. Any other name is a body, read at its centre of mass
``xipos`` (``mj_jac`` at ``xipos``, which is what ``mj_jacBodyCom`` does): a
point mass, as every system had before rigid bodies. A site wins where a body and
a site share a name (MuJoCo keeps their names apart), so a system names a site on
purpose.

Both recorders and the instantaneous layer read points only through here, so a
point means the same thing everywhere.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from harness.core.errors import ModelMismatch

__all__ = ["PointSource", "point_jacobian", "point_source"]


@dataclass(frozen=True)
class PointSource:
    """A named point in a compiled model: ``kind`` ``"site"`` (index into the sites) or ``"body"``
    (index into the bodies, its centre of mass); ``body`` is the body it moves with."""

    name: str
    kind: str
    index: int
    body: int

    @property
    def field(self) -> str:
        """The mjData field holding its world position (one row per ``index``)."""
        return "site_xpos" if self.kind == "site" else "xipos"

    def position(self, data: mujoco.MjData) -> np.ndarray:
        """Its world position after ``mj_forward`` (the array itself: copy before keeping it)."""
        return getattr(data, self.field)[self.index]


def point_source(model: mujoco.MjModel, name: str) -> PointSource:
    """The site ``name`` if the model has one, else the body ``name`` (its centre of mass);
    ModelMismatch naming both kinds where it has neither."""
    sid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, name)
    if sid >= 0:
        return PointSource(name=name, kind="site", index=sid, body=int(model.site_bodyid[sid]))
    bid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name)
    if bid >= 0:
        return PointSource(name=name, kind="body", index=bid, body=bid)
    raise ModelMismatch(f"model has no site or body {name!r} for point {name!r} "
                        "(a point is a site of that name, else a body's centre of mass)")


def point_jacobian(model: mujoco.MjModel, data: mujoco.MjData, source: PointSource) -> np.ndarray:
    """Translational Jacobian (3 × nv) of the point after ``mj_forward``: ``mj_jac`` at its position
    on its body (for a body, the same call ``mj_jacBodyCom`` makes; for a site, ``mj_jacSite``'s)."""
    jacp = np.zeros((3, model.nv))
    mujoco.mj_jac(model, data, jacp, None, source.position(data), source.body)
    return jacp
