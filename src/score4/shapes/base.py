"""What every shape has: named faces, exact areas, inside/surface/outside, sampling.

A shape lives in its own frame (Geant4's local frame of the solid; mm, rad). Its surface is cut
into *faces* with names; each face is made of exactly sampled *patches* (plane triangles,
pieces of cones/cylinders/annuli swept around z, sphere zones, sphere sectors). Sampling picks a
patch by its exact area, then a point uniformly per area on it, with its outward normal.

``inside`` follows Geant4's ``EInside`` values and tolerance: 0 (kOutside), 1 (kSurface: within
half of kCarTolerance = 1e-9 mm of the surface), 2 (kInside).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields
from functools import cached_property
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike

from ..errors import ConfigError
from ._plane import TOLERANCE
from .faces import AnnulusFace, Face, PlaneFace, RevolvedFace, SphereFace
from .transform import Transform

OUTSIDE, SURFACE, INSIDE = 0, 1, 2


@dataclass
class ShapeSample:
    """Points on a shape's surface.

    Attributes
    ----------
    position
        (n, 3) points, mm.
    normal
        (n, 3) unit outward normals there.
    face
        (n,) index into the shape's :attr:`Shape.faces`.
    """

    position: np.ndarray
    normal: np.ndarray
    face: np.ndarray


# --------------------------------------------------------------------------------------------
# Patches: surface pieces with an exact area and an exact area-uniform sampler
# --------------------------------------------------------------------------------------------


class Patch:
    """A surface piece of one face. ``area`` is exact; ``sample`` is uniform per area."""

    face: int
    area: float

    def sample(self, rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
        raise NotImplementedError

    def parallel_factor(self, position: np.ndarray, d: np.ndarray) -> np.ndarray:
        """Area of the inner parallel surface at depth ``d`` per area of the surface, at a
        point: ``(1 - d k1)(1 - d k2)``, principal curvatures k > 0 where the material is convex."""
        return np.ones(len(position))

    def max_parallel_factor(self, d: np.ndarray) -> np.ndarray:
        """An upper bound of :meth:`parallel_factor` over the patch at depths ``d``."""
        return np.ones(len(d))

    @property
    def planar(self) -> bool:
        return False


class PlaneTriangles(Patch):
    """Flat triangles (k, 3, 3) with their outward normals (k, 3)."""

    def __init__(self, face: int, triangles: np.ndarray, normals: np.ndarray) -> None:
        self.face = face
        self.triangles = np.asarray(triangles, float).reshape(-1, 3, 3)
        cross = np.cross(
            self.triangles[:, 1] - self.triangles[:, 0], self.triangles[:, 2] - self.triangles[:, 0]
        )
        self.areas = 0.5 * np.linalg.norm(cross, axis=1)
        self.area = float(self.areas.sum())
        self.normals = np.broadcast_to(np.asarray(normals, float), (len(self.triangles), 3))
        self._cum = np.cumsum(self.areas)

    @property
    def planar(self) -> bool:
        return True

    def sample(self, rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
        k = np.minimum(
            np.searchsorted(self._cum, rng.random(n) * self.area, side="right"), len(self.areas) - 1
        )
        st = rng.random((2, n))
        flip = st.sum(axis=0) > 1
        st[:, flip] = 1 - st[:, flip]
        t = self.triangles[k]
        pos = t[:, 0] + st[0, :, None] * (t[:, 1] - t[:, 0]) + st[1, :, None] * (t[:, 2] - t[:, 0])
        return pos, self.normals[k].copy()


class Revolved(Patch):
    """The segment (r1, z1) -> (r2, z2) of the (r, z) half-plane swept over phi in
    [phi0, phi0 + dphi]: a piece of a cone, cylinder or annulus. ``(nr, nz)`` is its outward
    normal in the (r, z) plane."""

    def __init__(
        self,
        face: int,
        rz1: Sequence[float],
        rz2: Sequence[float],
        phi0: float,
        dphi: float,
        nrz: Sequence[float],
    ) -> None:
        self.face = face
        self.r1, self.z1 = (float(v) for v in rz1)
        self.r2, self.z2 = (float(v) for v in rz2)
        self.phi0, self.dphi = float(phi0), float(dphi)
        self.nr, self.nz = (float(v) for v in nrz)
        length = float(np.hypot(self.r2 - self.r1, self.z2 - self.z1))
        self.area = self.dphi * length * 0.5 * (self.r1 + self.r2)

    def sample(self, rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
        u, v = rng.random((2, n))
        r1, r2 = self.r1, self.r2
        if abs(r2 - r1) <= 1e-12 * max(r1, r2, 1.0):
            t, r = u, np.full(n, 0.5 * (r1 + r2))
        else:  # density along the segment proportional to r: invert r^2 linearly
            r = np.sqrt(r1 * r1 + u * (r2 * r2 - r1 * r1))
            t = np.clip((r - r1) / (r2 - r1), 0.0, 1.0)
        z = self.z1 + t * (self.z2 - self.z1)
        phi = self.phi0 + v * self.dphi
        c, s = np.cos(phi), np.sin(phi)
        pos = np.column_stack([r * c, r * s, z])
        normal = np.column_stack([self.nr * c, self.nr * s, np.full(n, self.nz)])
        return pos, normal

    def as_face(self, name: str) -> Face:
        """This patch as a :class:`~score4.shapes.faces.Face`: an annulus (perpendicular to
        z) or a cylinder/cone piece."""
        if abs(self.nr) <= 1e-12:
            return AnnulusFace.make(
                name, sorted((self.r1, self.r2)), self.z1, self.nz, self.phi0, self.dphi
            )
        return RevolvedFace(
            name,
            (self.r1, self.z1),
            (self.r2, self.z2),
            self.phi0,
            self.dphi,
            (self.nr, self.nz),
        )

    def parallel_factor(self, position: np.ndarray, d: np.ndarray) -> np.ndarray:
        rho = np.hypot(position[:, 0], position[:, 1])
        with np.errstate(divide="ignore", invalid="ignore"):
            k = np.where(rho > 0, self.nr / rho, 0.0)
        return np.maximum(1 - d * k, 0.0)

    def max_parallel_factor(self, d: np.ndarray) -> np.ndarray:
        rmin = min(self.r1, self.r2)
        if self.nr >= 0:
            return np.ones(len(d))  # convex or flat: the parallel surface is smaller
        return 1 - d * self.nr / max(rmin, 1e-300)


class SphereZone(Patch):
    """The sphere of radius ``radius`` between polar angles theta1 < theta2 and azimuths
    [phi0, phi0 + dphi]; ``sign`` +1 for an outer (convex) face, -1 for an inner one."""

    def __init__(
        self,
        face: int,
        radius: float,
        theta: tuple[float, float],
        phi0: float,
        dphi: float,
        sign: int,
    ) -> None:
        self.face, self.radius, self.sign = face, float(radius), int(sign)
        self.c1, self.c2 = np.cos(theta[0]), np.cos(theta[1])
        self.phi0, self.dphi = float(phi0), float(dphi)
        self.area = self.radius**2 * self.dphi * (self.c1 - self.c2)

    def sample(self, rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
        u, v = rng.random((2, n))
        cos = self.c2 + u * (self.c1 - self.c2)
        sin = np.sqrt(np.maximum(1 - cos * cos, 0.0))
        phi = self.phi0 + v * self.dphi
        unit = np.column_stack([sin * np.cos(phi), sin * np.sin(phi), cos])
        return self.radius * unit, self.sign * unit

    def parallel_factor(self, position: np.ndarray, d: np.ndarray) -> np.ndarray:
        return np.maximum(1 - d * self.sign / self.radius, 0.0) ** 2

    def max_parallel_factor(self, d: np.ndarray) -> np.ndarray:
        return np.maximum(1 - d * self.sign / self.radius, 0.0) ** 2


class SphereSector(Patch):
    """The flat region {rho in [rmin, rmax], theta in [theta1, theta2]} of the half-plane at
    azimuth ``phi`` (a phi cut of a G4Sphere), with a fixed outward normal."""

    def __init__(
        self,
        face: int,
        radii: tuple[float, float],
        theta: tuple[float, float],
        phi: float,
        normal: np.ndarray,
    ) -> None:
        self.face = face
        self.rmin, self.rmax = radii
        self.t1, self.t2 = theta
        self.phi = phi
        self.normal = np.asarray(normal, float)
        self.area = 0.5 * (self.t2 - self.t1) * (self.rmax**2 - self.rmin**2)

    @property
    def planar(self) -> bool:
        return True

    def sample(self, rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
        u, v = rng.random((2, n))
        rho = np.sqrt(self.rmin**2 + u * (self.rmax**2 - self.rmin**2))
        theta = self.t1 + v * (self.t2 - self.t1)
        s = np.sin(theta)
        pos = np.column_stack(
            [rho * s * np.cos(self.phi), rho * s * np.sin(self.phi), rho * np.cos(theta)]
        )
        return pos, np.tile(self.normal, (n, 1))


# --------------------------------------------------------------------------------------------
# Shapes
# --------------------------------------------------------------------------------------------


def _plane_face(name: str, patches: Sequence[PlaneTriangles]) -> PlaneFace:
    """A face of flat triangles with one normal: a frame at the centroid of its corners, x along
    its first edge; the extent the bounding rectangle of its corners."""
    tris = np.concatenate([p.triangles for p in patches])
    normals = np.concatenate([p.normals for p in patches])
    n = normals[0]
    if not np.allclose(normals, n, atol=1e-9):
        raise ConfigError(f"face: face {name!r} is not flat (its facets have several normals)")
    edges = tris[:, 1] - tris[:, 0]
    edges = edges - (edges @ n)[:, None] * n
    lengths = np.linalg.norm(edges, axis=1)
    # the first edge of some length (a polyhedra's end face with no hole starts with triangles
    # shrunk to the axis)
    x = edges[int(np.argmax(lengths > 1e-12 * max(float(lengths.max()), 1e-300)))]
    x /= max(float(np.linalg.norm(x)), 1e-300)
    rotation = np.column_stack([x, np.cross(n, x), n])
    centre = tris.reshape(-1, 3).mean(axis=0)
    q = (tris.reshape(-1, 3) - centre) @ rotation
    area = float(sum(p.area for p in patches))
    lo, hi = q.min(axis=0), q.max(axis=0)
    extent = ((float(lo[0]), float(hi[0])), (float(lo[1]), float(hi[1])))
    return PlaneFace(name, area, Transform(rotation, centre), extent)


def as_points(points: ArrayLike) -> np.ndarray:
    p = np.asarray(points, dtype=float)
    if p.ndim == 1:
        p = p.reshape(1, 3)
    if p.ndim != 2 or p.shape[1] != 3:
        raise ConfigError(f"points: need an (n, 3) array, got shape {p.shape}")
    return p


def classify(signed: np.ndarray, tol: float = TOLERANCE) -> np.ndarray:
    """EInside codes from a signed distance (negative inside) and Geant4's tolerance."""
    half = 0.5 * tol
    return np.where(signed > half, OUTSIDE, np.where(signed < -half, INSIDE, SURFACE)).astype(
        np.int8
    )


class Shape:
    """Base class of all shapes: named faces, exact areas and volume, inside, sampling.

    Subclasses define :meth:`_build` (face names, groups, patches), :meth:`signed_distance`,
    :attr:`volume`, :meth:`bounding_box` and :meth:`sample_volume`.
    """

    kind: ClassVar[str] = "shape"

    # -- definition by subclasses -------------------------------------------------------------

    def _build(self) -> tuple[tuple[str, ...], dict[str, tuple[str, ...]], list[Patch]]:
        raise NotImplementedError

    def signed_distance(self, points: ArrayLike) -> np.ndarray:
        """Geant4-style safety with a sign: < 0 inside, > 0 outside, ~0 on the surface.

        For points inside it is the distance to the nearest face (exact for the convex solids;
        a lower bound elsewhere); outside it is a lower bound of the distance.
        """
        raise NotImplementedError

    @property
    def volume(self) -> float:
        """Exact volume, mm^3."""
        raise NotImplementedError

    def bounding_box(self) -> tuple[np.ndarray, np.ndarray]:
        """(lo, hi) corners of an axis-aligned box holding the shape, mm."""
        raise NotImplementedError

    def sample_volume(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """``n`` points uniform in the volume, (n, 3)."""
        return self._volume_by_rejection(rng, n)

    # -- common machinery ------------------------------------------------------------------------

    @cached_property
    def _structure(self) -> tuple[tuple[str, ...], dict[str, tuple[str, ...]], list[Patch]]:
        return self._build()

    @property
    def faces(self) -> tuple[str, ...]:
        """Face names, in a fixed order (a sample's ``face`` indexes this)."""
        return self._structure[0]

    @property
    def groups(self) -> dict[str, tuple[str, ...]]:
        """Names that stand for several faces (``all`` is always there)."""
        return {**self._structure[1], "all": self.faces}

    @property
    def patches(self) -> list[Patch]:
        return self._structure[2]

    @cached_property
    def face_areas(self) -> Mapping[str, float]:
        """Exact area of every face, mm^2."""
        total = np.zeros(len(self.faces))
        for p in self.patches:
            total[p.face] += p.area
        return {name: float(a) for name, a in zip(self.faces, total, strict=True)}

    @property
    def area(self) -> float:
        """Exact total surface area, mm^2."""
        return float(sum(self.face_areas.values()))

    def face_area(self, faces: str | Sequence[str] = "all") -> float:
        """Total area of the selected faces (names or group names), mm^2."""
        return float(sum(self.face_areas[f] for f in self.resolve_faces(faces)))

    def resolve_faces(self, faces: str | Sequence[str] = "all") -> tuple[str, ...]:
        """Face names of a selection: a face name, a group name (``all``, ``outer``, ...) or a
        list of them; ConfigError names the valid choices."""
        items = [faces] if isinstance(faces, str) else list(faces)
        out: list[str] = []
        groups = self.groups
        for item in items:
            if item in groups:
                out += [f for f in groups[item] if f not in out]
            elif item in self.faces:
                if item not in out:
                    out.append(item)
            else:
                named = [g for g in groups if g not in self.faces]
                choices = ", ".join(self.faces) + (f"; groups: {', '.join(named)}" if named else "")
                raise ConfigError(f"face: {self.kind} has no face {item!r}; its faces: {choices}")
        if not out:
            raise ConfigError("face: the selection names no face")
        return tuple(out)

    def face(self, name: str) -> Face:
        """The geometry of one face (:mod:`score4.shapes.faces`): a flat face (a plane's
        triangles, an annulus) or a piece of a cylinder or cone around z; ConfigError for a
        face of another kind or a name the shape does not have."""
        self.resolve_faces(name)  # a name it does not have: the error lists its faces
        if name not in self.faces:
            raise ConfigError(f"face: {name!r} names several faces of a {self.kind}; give one")
        k = self.faces.index(name)
        patches = [p for p in self.patches if p.face == k]
        if len(patches) == 1 and isinstance(patches[0], Revolved):
            return patches[0].as_face(name)
        if len(patches) == 1 and isinstance(patches[0], SphereZone):
            z = patches[0]
            theta = (float(np.arccos(z.c1)), float(np.arccos(z.c2)))
            return SphereFace(name, z.radius, theta, z.phi0, z.dphi, z.sign)
        if patches and all(isinstance(p, PlaneTriangles) for p in patches):
            return _plane_face(name, [p for p in patches if isinstance(p, PlaneTriangles)])
        raise ConfigError(
            f"face: face {name!r} of a {self.kind} is neither flat nor a surface of revolution"
        )

    def thickness_along(self, direction: np.ndarray) -> float:
        """Width of the bounding box along a unit ``direction`` (the solid's thickness behind
        a face perpendicular to an axis: exact for boxes and the end faces of tubes)."""
        lo, hi = self.bounding_box()
        return float(np.abs(np.asarray(direction, float)) @ (hi - lo))

    @property
    def box_like(self) -> bool:
        """True when the solid is its own bounding box (a G4Box)."""
        return False

    def trimmed(self, cuts: dict[str, float]) -> tuple[Shape, np.ndarray] | None:
        """The solid made thinner by ``cuts[face]`` (mm) behind each named flat face, and the
        shift of its origin in this frame (so the other faces stay); None when the shape cannot
        be cut that way."""
        return None

    def moved(self, cuts: dict[str, float]) -> tuple[Shape, np.ndarray] | None:
        """The solid with each named flat face moved inward by ``cuts[face]`` mm (outward for a
        depth below 0: a subtracted solid grows for an ``into`` layer on its face), and the
        shift of its origin in this frame; None when the shape cannot be moved that way. Where
        :meth:`trimmed` cuts the solid this is the same; a G4Trd and a G4Polyhedra move here
        only (as a constituent of a boolean: alone, ``into`` clips them by planes)."""
        return self.trimmed(cuts)

    def face_sampler(self, faces: str | Sequence[str] = "all") -> FaceSampler:
        """A reusable sampler on the selected faces (see :class:`FaceSampler`)."""
        return FaceSampler(self, self.resolve_faces(faces))

    def sample_surface(
        self, rng: np.random.Generator, n: int, faces: str | Sequence[str] = "all"
    ) -> ShapeSample:
        """``n`` points uniform per area on the selected faces, with outward normals."""
        return self.face_sampler(faces).sample(rng, n)

    def inside(self, points: ArrayLike) -> np.ndarray:
        """EInside codes (0 outside, 1 surface, 2 inside) of points (n, 3), Geant4's tolerance."""
        return classify(self.signed_distance(as_points(points)))

    def _volume_by_rejection(self, rng: np.random.Generator, n: int) -> np.ndarray:
        lo, hi = self.bounding_box()
        out = np.empty((0, 3))
        efficiency = max(self.volume / float(np.prod(hi - lo)), 1e-6)
        while len(out) < n:
            m = int((n - len(out)) / efficiency * 1.1) + 16
            p = lo + rng.random((m, 3)) * (hi - lo)
            out = np.concatenate([out, p[self.inside(p) == INSIDE]])
        return out[:n]

    # -- serialisation -----------------------------------------------------------------------

    def to_dict(self) -> dict[str, Any]:
        """Plain data (``type`` + Geant4 parameters in mm and rad)."""
        out: dict[str, Any] = {"type": self.kind}
        for f in fields(self):  # type: ignore[arg-type]  # subclasses are dataclasses
            value = getattr(self, f.name)
            out[f.name] = (
                value.tolist()
                if isinstance(value, np.ndarray)
                else (list(value) if isinstance(value, tuple) else value)
            )
        return out


class FaceSampler:
    """Area-uniform points on a selection of a shape's faces, built once and drawn many times.

    Attributes
    ----------
    shape, faces
        The shape and the selected face names.
    area
        Exact area of the selection, mm^2.
    """

    def __init__(self, shape: Shape, faces: tuple[str, ...]) -> None:
        self.shape, self.faces = shape, faces
        wanted = {shape.faces.index(f) for f in faces}
        self.patches = [p for p in shape.patches if p.face in wanted and p.area > 0]
        self.area = float(sum(p.area for p in self.patches))
        if not self.area > 0:
            raise ConfigError(
                f"face: the selected faces ({', '.join(faces)}) of this {shape.kind} have no area"
            )
        self._cum = np.cumsum([p.area for p in self.patches])

    @property
    def planar(self) -> bool:
        """True when every selected patch is flat."""
        return all(p.planar for p in self.patches)

    def sample_patches(self, rng: np.random.Generator, n: int) -> np.ndarray:
        return np.minimum(
            np.searchsorted(self._cum, rng.random(n) * self.area, side="right"),
            len(self.patches) - 1,
        )

    def sample(self, rng: np.random.Generator, n: int) -> ShapeSample:
        """``n`` points uniform per area on the selection."""
        return self.sample_with_patch(rng, n)[0]

    def sample_with_patch(self, rng: np.random.Generator, n: int) -> tuple[ShapeSample, np.ndarray]:
        """Like :meth:`sample`, also returning the index of each point's patch."""
        which = self.sample_patches(rng, n)
        pos, normal = np.empty((n, 3)), np.empty((n, 3))
        face = np.empty(n, dtype=np.int64)
        for k in np.unique(which):
            rows = np.flatnonzero(which == k)
            patch = self.patches[k]
            pos[rows], normal[rows] = patch.sample(rng, len(rows))
            face[rows] = patch.face
        return ShapeSample(pos, normal, face), which

    def sample_parallel(self, rng: np.random.Generator, d: np.ndarray) -> ShapeSample:
        """One surface point per depth ``d[i]``, uniform per area of the inner parallel surface
        at that depth: a point drawn per area is kept with probability
        ``(1 - d k1)(1 - d k2) / max`` (principal curvatures k, > 0 where the material is
        convex), the max taken over all selected patches so their relative weights stay right.
        Flat patches have the factor 1."""
        n = len(d)
        out = ShapeSample(np.empty((n, 3)), np.empty((n, 3)), np.empty(n, dtype=np.int64))
        bound = np.max([p.max_parallel_factor(d) for p in self.patches], axis=0)
        pending = np.arange(n)
        for _ in range(10_000):
            if len(pending) == 0:
                return out
            s, which = self.sample_with_patch(rng, len(pending))
            factor = np.empty(len(pending))
            for k in np.unique(which):
                rows = np.flatnonzero(which == k)
                factor[rows] = self.patches[k].parallel_factor(s.position[rows], d[pending[rows]])
            ok = rng.random(len(pending)) * bound[pending] < factor
            done = pending[ok]
            out.position[done], out.normal[done], out.face[done] = (
                s.position[ok],
                s.normal[ok],
                s.face[ok],
            )
            pending = pending[~ok]
        raise ConfigError(
            "depth: the drawn depths exceed the radius of curvature of the selected faces"
        )
