"""Is the model itself physical? Each body's inertial against its own geometry (docs/inertia.md).

geometry: the body's geoms in its frame, exact supports, hulls; bounds: the two bounds (the mass within the
geometry, no material denser than the densest element) and the centre of mass in the hull; audit: each body's
category, likely cause and effect on the dynamics; urdf: a URDF compiled with its own meshes; models: what
``check`` and ``run`` audit, with the config's acceptances.
"""

__all__: list[str] = []
