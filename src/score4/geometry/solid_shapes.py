"""Shapes from live Geant4 solids (worker side: the GDML reader subprocess, a program using
:mod:`score4.api`).

:func:`shape_from_g4_solid` reads a solid through geant4_pybind's getters (duck-typed); only a
:class:`LiveSolidShape`, the fallback for solids no dataclass describes, imports geant4_pybind to
ask the live solid. What it gives per solid type:

=====================================  ==============================================
G4Box, G4Trd, G4Trap, G4Tubs, G4Cons,  the dataclass of the same name
G4Sphere, G4Orb
G4Polycone, G4GenericPolycone          :class:`G4GenericPolycone` of Geant4's contour
                                       (``GetCorner``); the binding gives only the first
                                       z plane of ``GetOriginalParameters``
G4Polyhedra                            :class:`G4GenericPolyhedra` of the contour
G4TessellatedSolid, G4ExtrudedSolid    :class:`MeshShape` of its facets (exact), one face
                                       per plane (:meth:`MeshShape.by_planes`)
G4UnionSolid, G4SubtractionSolid,      :class:`BooleanShape` of its constituents,
G4IntersectionSolid, G4MultiUnion,     :class:`PlacedShape` for a displaced solid
G4DisplacedSolid
anything else                          :class:`LiveSolidShape` (needs the live solid)
=====================================  ==============================================
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from score4.errors import ConfigError
from score4.shapes.base import INSIDE, Shape, ShapeSample, as_points
from score4.shapes.boolean import BooleanShape
from score4.shapes.csg import G4Box, G4Cons, G4Orb, G4Sphere, G4Trap, G4Trd, G4Tubs
from score4.shapes.from_data import SHAPE_TYPES
from score4.shapes.mesh_shape import MeshShape
from score4.shapes.placed import PlacedShape
from score4.shapes.revolved import G4GenericPolycone, G4GenericPolyhedra
from score4.shapes.transform import Transform


def _rotation(r: Any) -> np.ndarray:
    return np.array([[r.xx, r.xy, r.xz], [r.yx, r.yy, r.yz], [r.zx, r.zy, r.zz]], float)


def _vector(v: Any) -> np.ndarray:
    return np.array([v.x, v.y, v.z], float)


def _corners(solid: Any) -> tuple[tuple[float, ...], tuple[float, ...]]:
    n = solid.GetNumRZCorner()
    corners = [solid.GetCorner(i) for i in range(n)]
    return tuple(c.r for c in corners), tuple(c.z for c in corners)


def _phi(solid: Any) -> tuple[float, float]:
    start, end = solid.GetStartPhi(), solid.GetEndPhi()
    return start, end - start


def _facets(solid: Any) -> np.ndarray:
    tris = []
    for i in range(solid.GetNumberOfFacets()):
        f = solid.GetFacet(i)
        v = [_vector(f.GetVertex(k)) for k in range(f.GetNumberOfVertices())]
        tris += [[v[0], v[k], v[k + 1]] for k in range(1, len(v) - 1)]
    return np.array(tris)


def _transform3d(t: Any) -> Transform:
    """A HepGeom::Transform3D (G4MultiUnion::GetTransformation) as a Transform."""
    return Transform(_rotation(t.getRotation()), _vector(t.getTranslation()))


def _read(solid: Any) -> Shape:
    kind = solid.GetEntityType()
    if kind == "G4Box":
        return G4Box(solid.GetXHalfLength(), solid.GetYHalfLength(), solid.GetZHalfLength())
    if kind == "G4Trd":
        return G4Trd(
            solid.GetXHalfLength1(),
            solid.GetXHalfLength2(),
            solid.GetYHalfLength1(),
            solid.GetYHalfLength2(),
            solid.GetZHalfLength(),
        )
    if kind == "G4Trap":
        axis = _vector(solid.GetSymAxis())
        return G4Trap(
            solid.GetZHalfLength(),
            math.atan2(math.hypot(axis[0], axis[1]), axis[2]),
            math.atan2(axis[1], axis[0]),
            solid.GetYHalfLength1(),
            solid.GetXHalfLength1(),
            solid.GetXHalfLength2(),
            math.atan(solid.GetTanAlpha1()),
            solid.GetYHalfLength2(),
            solid.GetXHalfLength3(),
            solid.GetXHalfLength4(),
            math.atan(solid.GetTanAlpha2()),
        )
    if kind == "G4Tubs":
        return G4Tubs(
            solid.GetInnerRadius(),
            solid.GetOuterRadius(),
            solid.GetZHalfLength(),
            solid.GetStartPhiAngle(),
            solid.GetDeltaPhiAngle(),
        )
    if kind == "G4Cons":
        return G4Cons(
            solid.GetInnerRadiusMinusZ(),
            solid.GetOuterRadiusMinusZ(),
            solid.GetInnerRadiusPlusZ(),
            solid.GetOuterRadiusPlusZ(),
            solid.GetZHalfLength(),
            solid.GetStartPhiAngle(),
            solid.GetDeltaPhiAngle(),
        )
    if kind == "G4Sphere":
        return G4Sphere(
            solid.GetInnerRadius(),
            solid.GetOuterRadius(),
            solid.GetStartPhiAngle(),
            solid.GetDeltaPhiAngle(),
            solid.GetStartThetaAngle(),
            solid.GetDeltaThetaAngle(),
        )
    if kind == "G4Orb":
        return G4Orb(solid.GetRadius())
    if kind in ("G4Polycone", "G4GenericPolycone"):
        r, z = _corners(solid)
        return G4GenericPolycone(*_phi(solid), r, z)
    if kind == "G4Polyhedra":
        r, z = _corners(solid)
        return G4GenericPolyhedra(*_phi(solid), solid.GetNumSide(), r, z)
    if kind in ("G4TessellatedSolid", "G4ExtrudedSolid"):
        return MeshShape.by_planes(_facets(solid), extruded=kind == "G4ExtrudedSolid")
    if kind == "G4DisplacedSolid":
        return PlacedShape(
            _read(solid.GetConstituentMovedSolid()),
            Transform(_rotation(solid.GetObjectRotation()), _vector(solid.GetObjectTranslation())),
        )
    if kind in ("G4UnionSolid", "G4SubtractionSolid", "G4IntersectionSolid"):
        op = {
            "G4UnionSolid": "union",
            "G4SubtractionSolid": "subtraction",
            "G4IntersectionSolid": "intersection",
        }[kind]
        first, second = solid.GetConstituentSolid(0), solid.GetConstituentSolid(1)
        a = _read(first)
        if second.GetEntityType() == "G4DisplacedSolid":
            transform = Transform(
                _rotation(second.GetObjectRotation()), _vector(second.GetObjectTranslation())
            )
            b = _read(second.GetConstituentMovedSolid())
        else:
            transform, b = Transform(), _read(second)
        return BooleanShape(op, a, b, transform)  # type: ignore[arg-type]  # op is a literal
    if kind == "G4MultiUnion":
        parts: list[Shape] = [
            PlacedShape(_read(solid.GetSolid(i)), _transform3d(solid.GetTransformation(i)))
            for i in range(solid.GetNumberOfSolids())
        ]
        shape = parts[0]
        for p in parts[1:]:
            shape = BooleanShape("union", shape, p)
        return shape
    raise _Unsupported(kind)


class _Unsupported(Exception):
    pass


def shape_from_g4_solid(solid: Any, *, live_fallback: bool = True) -> Shape:
    """The shape of a live Geant4 solid (see the module docstring for what each type gives).

    Solids that no dataclass describes (G4Torus, G4Ellipsoid, G4CutTubs, twisted solids, a
    boolean containing one, ...) become a :class:`LiveSolidShape` when ``live_fallback``, else
    ConfigError names the type and the supported ones.
    """
    try:
        return _read(solid)
    except _Unsupported as err:
        if live_fallback:
            return LiveSolidShape(solid)
        supported = ", ".join(
            [
                *SHAPE_TYPES,
                "G4TessellatedSolid",
                "G4ExtrudedSolid",
                "booleans",
                "G4MultiUnion",
                "G4DisplacedSolid",
            ]
        )
        raise ConfigError(
            f"solid {solid.GetName()!r}: type {err} has no numpy shape; supported: {supported}"
        ) from None


# --------------------------------------------------------------------------------------------
# Any solid, through the live Geant4 object
# --------------------------------------------------------------------------------------------

_K_INFINITY = 9.0e99


@dataclass(frozen=True, eq=False)
class LiveSolidShape(Shape):
    """Any Geant4 solid, sampled on its true surface through the live solid (Geant4 process only).

    Surface points come from random lines: lines uniform in space and direction (isotropic
    directions, uniform over the disc of the bounding sphere seen from that direction) cross
    a surface at points that are uniform per true area, and a line crosses it on average
    ``A / (2 pi R^2)`` times (Cauchy-Crofton), which gives the area. Each crossing comes from
    ``DistanceToIn`` / ``DistanceToOut`` along the line; the normal from ``SurfaceNormal``.
    The area is drawn in rounds of ``n_area_lines`` lines until its standard error is at most
    ``area_precision`` of it (0.1 %, issue 24) or ``max_area_lines`` lines are drawn
    (:attr:`area_error` states what it reached; a torus of radii 5 and 20 mm needs about
    3.6 10^6 lines, each a few Geant4 calls from Python). One face, ``surface``. ``to_dict`` is
    not available (the shape is the live object).
    """

    solid: Any
    n_area_lines: int = 100_000
    seed: int = 20263
    area_precision: float = 1e-3
    max_area_lines: int = 4_000_000
    kind = "LiveSolidShape"
    _pool: dict = field(default_factory=dict, repr=False)

    def _g4(self) -> Any:
        import geant4_pybind

        return geant4_pybind

    @property
    def _sphere(self) -> tuple[np.ndarray, float]:
        g4 = self._g4()
        lo, hi = g4.G4ThreeVector(), g4.G4ThreeVector()
        self.solid.BoundingLimits(lo, hi)
        a, b = _vector(lo), _vector(hi)
        return 0.5 * (a + b), 0.5 * float(np.linalg.norm(b - a)) * 1.001 + 1e-6

    def crossings(
        self, rng: np.random.Generator, n_lines: int, counts: list[int] | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """All crossings of ``n_lines`` random lines with the surface: points and normals
        (``counts``, if given, receives the number of crossings of each line)."""
        g4 = self._g4()
        centre, radius = self._sphere
        u = rng.normal(size=(n_lines, 3))
        u /= np.linalg.norm(u, axis=1, keepdims=True)
        helper = np.where(np.abs(u[:, :1]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]])
        e1 = np.cross(u, helper)
        e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
        e2 = np.cross(u, e1)
        rho = radius * np.sqrt(rng.random(n_lines))
        ang = rng.random(n_lines) * 2 * math.pi
        start = centre + (rho * np.cos(ang))[:, None] * e1 + (rho * np.sin(ang))[:, None] * e2
        start -= radius * u
        points: list[tuple[float, float, float]] = []
        normals: list[tuple[float, float, float]] = []
        solid, V3 = self.solid, g4.G4ThreeVector
        for s, d in zip(start, u, strict=True):
            p, v = V3(*s), V3(*d)
            inside, before = False, len(points)
            for _ in range(10_000):
                t = solid.DistanceToOut(p, v) if inside else solid.DistanceToIn(p, v)
                if t >= _K_INFINITY or (inside and t <= 0):
                    break
                p = p + v * t
                points.append((p.x, p.y, p.z))
                nv = solid.SurfaceNormal(p)
                normals.append((nv.x, nv.y, nv.z))
                inside = not inside
            if counts is not None:
                counts.append(len(points) - before)
        return np.array(points).reshape(-1, 3), np.array(normals).reshape(-1, 3)

    @property
    def _area_estimate(self) -> tuple[float, float]:
        if "area" not in self._pool:
            rng = np.random.default_rng(self.seed)
            counts: list[int] = []
            _, radius = self._sphere
            scale = 2 * math.pi * radius**2
            while True:  # rounds of n_area_lines until the error is small enough
                self.crossings(rng, self.n_area_lines, counts)
                c = np.array(counts, float)
                area, err = scale * c.mean(), scale * c.std(ddof=1) / math.sqrt(len(c))
                done = err <= self.area_precision * area
                if done or len(counts) + self.n_area_lines > self.max_area_lines:
                    break
            self._pool["area"] = (area, err)
        return self._pool["area"]

    def _build(self):
        return ("surface",), {}, []

    @property
    def face_areas(self) -> dict[str, float]:
        return {"surface": self._area_estimate[0]}

    @property
    def area_error(self) -> float:
        return self._area_estimate[1]

    def face_sampler(self, faces: Any = "all") -> LiveFaceSampler:  # type: ignore[override]
        self.resolve_faces(faces)
        return LiveFaceSampler(self)

    def signed_distance(self, points: ArrayLike) -> np.ndarray:
        codes = self.inside(points)
        return np.where(codes == INSIDE, -1.0, np.where(codes == 0, 1.0, 0.0))

    def inside(self, points: ArrayLike) -> np.ndarray:
        g4 = self._g4()
        p = as_points(points)
        code = {g4.EInside.kOutside: 0, g4.EInside.kSurface: 1, g4.EInside.kInside: 2}
        return np.array([code[self.solid.Inside(g4.G4ThreeVector(*q))] for q in p], np.int8)

    @property
    def volume(self) -> float:
        """Geant4's ``GetCubicVolume`` (exact for CSG solids, an estimate for others)."""
        return float(self.solid.GetCubicVolume())

    def bounding_box(self) -> tuple[np.ndarray, np.ndarray]:
        g4 = self._g4()
        lo, hi = g4.G4ThreeVector(), g4.G4ThreeVector()
        self.solid.BoundingLimits(lo, hi)
        return _vector(lo), _vector(hi)

    def to_dict(self) -> dict[str, Any]:
        raise ConfigError(
            f"shape: a {self.solid.GetEntityType()} is described by the live Geant4 solid only"
        )


class LiveFaceSampler:
    """Surface points of a :class:`LiveSolidShape` (all crossings of random lines, shuffled)."""

    def __init__(self, shape: LiveSolidShape) -> None:
        self.shape = shape
        self.area = shape.area
        self.area_error = shape.area_error  # the random lines' standard error
        self.faces = ("surface",)
        self.planar = False

    def sample(self, rng: np.random.Generator, n: int) -> ShapeSample:
        pts, nrm = np.empty((0, 3)), np.empty((0, 3))
        _, radius = self.shape._sphere
        per_line = self.area / (2 * math.pi * radius**2)
        while len(pts) < n:
            lines = int((n - len(pts)) / max(per_line, 1e-6) * 1.1) + 8
            p, q = self.shape.crossings(rng, lines)
            pts, nrm = np.concatenate([pts, p]), np.concatenate([nrm, q])
        order = rng.permutation(len(pts))[:n]
        return ShapeSample(pts[order], nrm[order], np.zeros(n, np.int64))
