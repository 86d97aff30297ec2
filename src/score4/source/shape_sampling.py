"""Sources on any volume: area-uniform points on faces of a placed shape (rough faces on their
meshes), and uniform points in a volume without its daughters.

These plug into :class:`~score4.source.depth.VertexSampler` like a
:class:`~score4.source.sampling.SurfaceSampler`: a volume of any solid type is given by a
:mod:`score4.shapes` shape and its global transform (world = R local + t), so box targets and
GDML volumes use the same code.

Depth below a curved face
-------------------------
``normal``: the vertex is ``p - d n(p)`` with ``p`` uniform per true area and ``n`` the exact
outward normal at ``p`` (for a cylinder: radial, so the vertex lies at distance exactly ``d``
below the true surface, whatever the facetting of a mesh would have been).

``distance``: the vertex's distance to the solid's surface equals ``d`` and, given ``d``, it is
uniform per area on the inner parallel surface at depth ``d`` of the selected faces. That surface
has ``(1 - d k1)(1 - d k2)`` times the area of the face (k the principal curvatures, > 0 where the
material is convex: ``1 - d / R`` on a cylinder of radius R, ``(1 - d / R)^2`` on a sphere,
``1 + d / R`` in a bore), so surface points are drawn with that weight, and a vertex closer than
``d`` to another part of the solid's surface (near an edge) is redrawn. The solid's distance is
the shape's :meth:`~score4.shapes.Shape.signed_distance`: exact for boxes, trapezoids, tubes,
cones, spheres and (away from phi cuts) for the contour solids; a lower bound near phi cuts, where
a few vertices may be redrawn that need not be. At concave edges (a step of a polycone) the
parallel surface also has cylindrical pieces around the edge that are not proposed: vertices
within ``d`` of such an edge are missing (a share of about ``d L / A`` for an edge of length L).
On flat faces ``normal`` and ``distance`` differ only near edges.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ..errors import ConfigError
from ..shapes import OUTSIDE, FaceSampler, Shape, Transform
from .sampling import SurfaceSample, SurfaceSampler, TiledSurfaceSampler

__all__ = ["BulkSampler", "CombinedSurfaceSampler", "ShapeSurfaceSampler"]


class ShapeSurfaceSampler:
    """Points uniform per **true** area on faces of a shape placed in the world.

    Parameters
    ----------
    shape
        The volume's shape in its own frame (:mod:`score4.shapes`).
    faces
        A face name, a group name (``all``, ``outer``, ...) or a list of them.
    transform
        Local -> world transform of the volume (Geant4's global object transform).
    rough
        Rough faces: face name -> sampler on the rough mesh **in world coordinates** (a
        :class:`TiledSurfaceSampler` as :meth:`score4.world.scene.RoughLayer.sampler` gives). A
        rough face is sampled on its mesh with its true (rough) area as weight against the flat
        faces.

    Attributes
    ----------
    area
        True sampled area, mm^2 (flat faces exact, rough faces their mesh area).
    projected_area
        Area of the selected faces of the shape itself (a rough face counted flat), mm^2.
    face_names
        The shape's faces; the ``face`` of a sample indexes this.
    """

    def __init__(
        self,
        shape: Shape,
        faces: str | Sequence[str] = "all",
        transform: Transform | None = None,
        rough: Mapping[str, SurfaceSampler | TiledSurfaceSampler] | None = None,
    ) -> None:
        self.shape = shape
        self.transform = transform or Transform()
        rough = dict(rough or {})
        self.selected = shape.resolve_faces(faces)
        unknown = sorted(set(rough) - set(shape.faces))
        if unknown:
            raise ConfigError(f"rough: {shape.kind} has no face {unknown[0]!r}")
        self.face_names = shape.faces
        flat = tuple(f for f in self.selected if f not in rough and shape.face_areas[f] > 0)
        self.flat: Any = shape.face_sampler(flat) if flat else None
        self.rough = [(shape.faces.index(f), rough[f]) for f in self.selected if f in rough]
        weights = ([self.flat.area] if self.flat is not None else []) + [
            s.area for _, s in self.rough
        ]
        if not weights or not sum(weights) > 0:
            raise ConfigError(f"face: the selected faces ({', '.join(self.selected)}) have no area")
        self._cum = np.cumsum(weights)
        self.area = float(self._cum[-1])
        # the standard error of an estimated area (boolean and live solids), 0 when exact
        errors = [getattr(self.flat, "area_error", 0.0)]  # (a boolean's rough face: its rest)
        errors += [getattr(r, "area_error", 0.0) for _, r in self.rough]
        self.area_error = float(np.sqrt(sum(float(e) ** 2 for e in errors)))
        self.projected_area = float(shape.face_area(self.selected))
        self.has_patches = bool(self.rough)

    # -- surface points ------------------------------------------------------------------------

    def _components(self, rng: np.random.Generator, n: int) -> np.ndarray:
        return np.minimum(
            np.searchsorted(self._cum, rng.random(n) * self.area, side="right"), len(self._cum) - 1
        )

    def sample(self, rng: np.random.Generator, n: int) -> SurfaceSample:
        """``n`` points uniform per true area with outward normals, their face, and (on rough
        faces) facet, cell and variant (-1 on flat faces)."""
        comp = self._components(rng, n)
        out = SurfaceSample(
            np.empty((n, 3)),
            np.empty((n, 3)),
            np.full(n, -1, np.int64),
            np.full(n, -1, np.int64),
            np.full(n, -1, np.int64),
        )
        out.face = np.empty(n, np.int64)
        offset = 0 if self.flat is None else 1
        if self.flat is not None:
            rows = np.flatnonzero(comp == 0)
            s = self.flat.sample(rng, len(rows))
            out.position[rows] = self.transform.apply(s.position)
            out.normal[rows] = self.transform.apply_vectors(s.normal)
            out.face[rows] = s.face
        for k, (face, sampler) in enumerate(self.rough):
            rows = np.flatnonzero(comp == k + offset)
            if len(rows) == 0:
                continue
            s = sampler.sample(rng, len(rows))
            out.position[rows], out.normal[rows], out.face[rows] = s.position, s.normal, face
            out.facet[rows] = s.facet
            if s.patch is not None and s.variant is not None:
                out.patch[rows], out.variant[rows] = s.patch, s.variant  # type: ignore[index]
        return out

    # -- vertices (the VertexSampler hook) ----------------------------------------------------

    def check_definition(self, definition: str) -> None:
        """Refuse ``distance`` where it is not defined here (see the module docstring)."""
        if definition != "distance":
            return
        if self.rough:
            raise ConfigError(
                "definition: 'distance' on several faces with a rough one is not supported; use "
                "'normal', or put the source on the rough face alone"
            )
        if not isinstance(self.flat, FaceSampler):
            raise ConfigError(
                f"definition: 'distance' needs exact faces; a {self.shape.kind} has none (use "
                "'normal')"
            )

    def draw_vertices(self, rng: np.random.Generator, d: np.ndarray, definition: str) -> tuple:
        """One vertex proposal per depth: (x, normal, facet, patch, variant, accepted, face)."""
        n = len(d)
        if definition == "normal":
            s = self.sample(rng, n)
            x = s.position - d[:, None] * s.normal
            return x, s.normal, s.facet, s.patch, s.variant, np.ones(n, bool), s.face
        s2 = self.flat.sample_parallel(rng, d)
        local = s2.position - d[:, None] * s2.normal
        # the vertex must not be closer than d to another part of the surface
        ok = -self.shape.signed_distance(local) >= d * (1 - 1e-9) - 1e-12
        minus = np.full(n, -1, np.int64)
        return (
            self.transform.apply(local),
            self.transform.apply_vectors(s2.normal),
            minus,
            minus.copy(),
            minus.copy(),
            ok,
            s2.face,
        )


class CombinedSurfaceSampler:
    """Several surface samplers as one, each chosen by its (true) area: e.g. a face that is
    partly rough (the rough cells' :class:`TiledSurfaceSampler`) and partly flat (a
    :class:`SurfaceSampler` on the rest), to pass as one entry of ``rough=`` of
    :class:`ShapeSurfaceSampler`. Samples carry the part's facet, patch and variant (-1 where a
    part has none)."""

    def __init__(self, parts: Sequence[Any]) -> None:
        if not parts:
            raise ConfigError("CombinedSurfaceSampler: give at least one part")
        self.parts = list(parts)
        self._cum = np.cumsum([p.area for p in self.parts])
        self.area = float(self._cum[-1])
        #: the standard error of an estimated area among the parts (a boolean's face), else 0
        self.area_error = float(
            np.sqrt(sum(float(getattr(p, "area_error", 0.0)) ** 2 for p in self.parts))
        )

    def sample(self, rng: np.random.Generator, n: int) -> SurfaceSample:
        which = np.minimum(
            np.searchsorted(self._cum, rng.random(n) * self.area, side="right"),
            len(self.parts) - 1,
        )
        out = SurfaceSample(
            np.empty((n, 3)),
            np.empty((n, 3)),
            np.full(n, -1, np.int64),
            np.full(n, -1, np.int64),
            np.full(n, -1, np.int64),
        )
        for k, part in enumerate(self.parts):
            rows = np.flatnonzero(which == k)
            if len(rows) == 0:
                continue
            s = part.sample(rng, len(rows))
            out.position[rows], out.normal[rows], out.facet[rows] = s.position, s.normal, s.facet
            if s.patch is not None and s.variant is not None:
                out.patch[rows], out.variant[rows] = s.patch, s.variant  # type: ignore[index]
        return out


class BulkSampler:
    """Points uniform in a placed shape, outside its daughters (and anything else excluded).

    Parameters
    ----------
    shape, transform
        The volume's shape and its local -> world transform.
    exclude
        Shapes **in world coordinates** (e.g. :class:`~score4.shapes.PlacedShape` of each
        daughter with its global transform) whose points do not belong to the volume's material.
    name
        The volume's name, for messages.

    Attributes
    ----------
    volume
        Volume of the volume's own material: the shape's volume minus the excluded volumes
        (daughters lie inside their mother in Geant4), mm^3.
    """

    def __init__(
        self,
        shape: Shape,
        transform: Transform | None = None,
        exclude: Sequence[Shape] = (),
        name: str = "volume",
        max_rounds: int = 1000,
    ) -> None:
        self.shape, self.transform, self.exclude = shape, transform or Transform(), list(exclude)
        self.name, self.max_rounds = name, max_rounds
        self.volume = float(shape.volume - sum(e.volume for e in self.exclude))
        if not self.volume > 1e-9 * shape.volume:
            raise ConfigError(
                f"source.volume: {name!r} has no material of its own left: its daughters fill its "
                f"{shape.volume:.6g} mm3"
            )

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """(n, 3) world points uniform in the volume's own material."""
        out = np.empty((n, 3))
        pending = np.arange(n)
        for _ in range(self.max_rounds):
            if len(pending) == 0:
                return out
            p = self.transform.apply(self.shape.sample_volume(rng, len(pending)))
            ok = np.ones(len(p), dtype=bool)
            for e in self.exclude:
                ok &= e.inside(p) == OUTSIDE
            out[pending[ok]] = p[ok]
            pending = pending[~ok]
        if len(pending) == 0:
            return out
        raise ConfigError(
            f"source.volume: {self.name!r}: {len(pending)} of {n} points fell in its daughters "
            f"{self.max_rounds} times in a row; the volume has (almost) no material of its own"
        )
