"""A body's own geometry in its body frame, from MuJoCo's compiled model: support functions, containment and a
tessellated hull, written here rather than taken from MuJoCo's inertia-from-geometry (which is itself a thing the
audit checks against).

"The body's own geometry" is every geom of the body (visual and collision alike, whatever its ``contype`` or
group; sites are not geometry): a visual mesh is the shape the author drew, and a body's mass must lie within it.
Geoms of other bodies (a welded child included) are theirs.

Each geom is described exactly by its support function h(n) = max over the geom of n·x (body frame):

- sphere radius r at p: n·p + r
- capsule radius r, half-length l along its axis a: n·p + l|n·a| + r
- cylinder radius r, half-height l along a: n·p + l|n·a| + r·sqrt(1 − (n·a)²)
- box half-sizes s along its axes Rₖ: n·p + Σ sₖ|n·Rₖ|
- ellipsoid semi-axes s: n·p + |diag(s) Rᵀn|
- mesh (and sdf): the largest n·v over its convex hull's vertices (MuJoCo's ``mesh_vert`` placed by the geom's pose)

The union's hull has the largest of the geoms' supports. Planes and height fields are left out (a plane is
unbounded; a height field is terrain): a body drawn only by them has no geometry here.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
from scipy.spatial import ConvexHull, QhullError

__all__ = ["Geom", "Solid", "body_geoms", "fibonacci_directions", "solid", "supports"]

_G = mujoco.mjtGeom
SKIPPED = (int(_G.mjGEOM_PLANE), int(_G.mjGEOM_HFIELD))


def fibonacci_directions(count: int) -> np.ndarray:
    """``count`` unit vectors spread evenly over the sphere (a Fibonacci lattice), one per row."""
    k = np.arange(count) + 0.5
    z = 1 - 2 * k / count
    phi = k * np.pi * (3 - np.sqrt(5))
    r = np.sqrt(1 - z * z)
    return np.column_stack([r * np.cos(phi), r * np.sin(phi), z])


@dataclass(frozen=True)
class Geom:
    """One geom in its body's frame: MuJoCo type, position, rotation (columns: the geom's axes), size, and for a
    mesh its convex hull's vertices (body frame)."""

    name: str
    kind: int
    pos: np.ndarray
    rot: np.ndarray
    size: np.ndarray
    vertices: np.ndarray | None = None

    def support(self, n: np.ndarray) -> np.ndarray:
        """h(n) for each row of ``n``: the largest n·x over the geom (exact for every type)."""
        if self.vertices is not None:
            return (n @ self.vertices.T).max(axis=1)
        local = n @ self.rot  # the directions in the geom's axes
        r, s = self.size[0], self.size
        base = n @ self.pos
        if self.kind == _G.mjGEOM_SPHERE:
            return base + r
        if self.kind == _G.mjGEOM_CAPSULE:
            return base + s[1] * np.abs(local[:, 2]) + r
        if self.kind == _G.mjGEOM_CYLINDER:
            return base + s[1] * np.abs(local[:, 2]) + r * np.sqrt(np.clip(1 - local[:, 2] ** 2, 0, None))
        if self.kind == _G.mjGEOM_BOX:
            return base + np.abs(local) @ s
        if self.kind == _G.mjGEOM_ELLIPSOID:
            return base + np.linalg.norm(local * s, axis=1)
        raise ValueError(f"no support function for geom type {self.kind}")

    def contains(self, x: np.ndarray) -> bool:
        """Whether the body-frame point ``x`` lies in the geom (its convex hull, for a mesh), exactly."""
        if self.vertices is not None:
            return _in_hull(self.vertices, x)
        y = self.rot.T @ (x - self.pos)
        r, s = self.size[0], self.size
        tol = 1e-12 * max(1.0, float(np.abs(s).max()))
        if self.kind == _G.mjGEOM_SPHERE:
            return float(np.linalg.norm(y)) <= r + tol
        if self.kind == _G.mjGEOM_CAPSULE:
            return float(np.linalg.norm([y[0], y[1], max(abs(y[2]) - s[1], 0.0)])) <= r + tol
        if self.kind == _G.mjGEOM_CYLINDER:
            return abs(y[2]) <= s[1] + tol and float(np.hypot(y[0], y[1])) <= r + tol
        if self.kind == _G.mjGEOM_BOX:
            return bool(np.all(np.abs(y) <= s + tol))
        return float(np.sum((y / s) ** 2)) <= 1 + 1e-12  # ellipsoid

    def cloud(self) -> np.ndarray:
        """Points on the geom's surface (a mesh's hull vertices; a primitive tessellated): what the drawn and
        uniformly filled hull is built from. Not used by the bounds, which take the exact supports."""
        if self.vertices is not None:
            return self.vertices
        unit = _UNIT_SPHERE
        r, s = self.size[0], self.size
        if self.kind == _G.mjGEOM_SPHERE:
            local = r * unit
        elif self.kind == _G.mjGEOM_CAPSULE:
            axis = np.array([0.0, 0.0, s[1]])
            local = np.vstack([r * unit + axis, r * unit - axis])
        elif self.kind == _G.mjGEOM_CYLINDER:
            ring = np.column_stack([np.cos(_RING), np.sin(_RING), np.zeros_like(_RING)]) * r
            axis = np.array([0.0, 0.0, s[1]])
            local = np.vstack([ring + axis, ring - axis])
        elif self.kind == _G.mjGEOM_BOX:
            local = np.array([[a, b, c] for a in (-1, 1) for b in (-1, 1) for c in (-1, 1)], float) * s
        else:
            local = unit * s
        return local @ self.rot.T + self.pos


_UNIT_SPHERE = fibonacci_directions(96)
_RING = np.linspace(0, 2 * np.pi, 48, endpoint=False)


def _in_hull(vertices: np.ndarray, x: np.ndarray) -> bool:
    try:
        hull = ConvexHull(vertices)
    except QhullError:  # a flat mesh: nothing lies strictly inside it
        return False
    scale = float(np.abs(vertices).max()) or 1.0
    return bool(np.all(hull.equations[:, :3] @ x + hull.equations[:, 3] <= 1e-9 * scale))


def hull_vertices(points: np.ndarray) -> np.ndarray:
    """The vertices of the convex hull of ``points`` (all of them where they span no volume)."""
    if len(points) < 5:
        return points
    try:
        return points[ConvexHull(points).vertices]
    except QhullError:
        return points


def body_geoms(model: mujoco.MjModel, body: int, *, meshes: dict[int, np.ndarray] | None = None) -> list[Geom]:
    """The geoms of ``body`` in its frame (planes and height fields left out); ``meshes`` caches each mesh's hull
    vertices (mesh frame) by mesh id across bodies."""
    meshes = {} if meshes is None else meshes
    out = []
    start, count = int(model.body_geomadr[body]), int(model.body_geomnum[body])
    for g in range(start, start + count) if start >= 0 else ():
        kind = int(model.geom_type[g])
        if kind in SKIPPED:
            continue
        flat = np.zeros(9)
        mujoco.mju_quat2Mat(flat, model.geom_quat[g])
        rot = flat.reshape(3, 3)
        pos = model.geom_pos[g].copy()
        vertices = None
        if kind in (_G.mjGEOM_MESH, _G.mjGEOM_SDF):
            mesh = int(model.geom_dataid[g])
            if mesh < 0:
                continue
            if mesh not in meshes:
                a, n = int(model.mesh_vertadr[mesh]), int(model.mesh_vertnum[mesh])
                meshes[mesh] = hull_vertices(np.array(model.mesh_vert[a:a + n], dtype=float))
            vertices = meshes[mesh] @ rot.T + pos
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g) or f"geom {g}"
        out.append(Geom(name, kind, pos, rot, model.geom_size[g].copy(), vertices))
    return out


def support(geoms: list[Geom], n: np.ndarray) -> np.ndarray:
    """The support function of the union's hull at each row of ``n``."""
    return np.max([g.support(n) for g in geoms], axis=0)


def supports(geoms: list[Geom], n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The union's support at each row of ``n`` and at its opposite, a mesh's vertices read once for both."""
    plus, minus = [], []
    for g in geoms:
        if g.vertices is not None:
            dots = n @ g.vertices.T
            plus.append(dots.max(axis=1))
            minus.append(-dots.min(axis=1))
        else:
            plus.append(g.support(n))
            minus.append(g.support(-n))
    return np.max(plus, axis=0), np.max(minus, axis=0)


@dataclass(frozen=True)
class Solid:
    """The tessellated hull of a body's geoms filled uniformly: volume, centroid and inertia about the centroid
    per unit density (body frame), and the hull's vertices (for drawing)."""

    volume: float
    centroid: np.ndarray
    inertia: np.ndarray
    vertices: np.ndarray


def solid(geoms: list[Geom]) -> Solid | None:
    """The uniformly filled hull of ``geoms``' tessellations (None where it spans no volume): the shape a body's
    geometry implies, for the plausibility warnings and the drawings (the bounds use the exact supports)."""
    points = np.vstack([g.cloud() for g in geoms])
    try:
        hull = ConvexHull(points)
    except QhullError:
        return None
    if hull.volume <= 0:
        return None
    inside = points[hull.vertices].mean(axis=0)
    tri = points[hull.simplices] - inside  # tetrahedra (inside, a, b, c)
    vol = np.abs(np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2]))) / 6
    total = float(vol.sum())
    centroid = inside + (vol[:, None] * tri.sum(axis=1) / 4).sum(axis=0) / total
    # second moments of each tetrahedron about ``inside``: V/20 (Σ vᵢvᵢᵀ + s sᵀ), s the vertex sum (origin a vertex)
    s = tri.sum(axis=1)
    second = (vol[:, None, None] / 20 * (np.einsum("tki,tkj->tij", tri, tri) + np.einsum("ti,tj->tij", s, s))
              ).sum(axis=0)
    d = centroid - inside
    second -= total * np.outer(d, d)  # about the centroid
    inertia = np.trace(second) * np.eye(3) - second
    return Solid(total, centroid, inertia, points[hull.vertices])
