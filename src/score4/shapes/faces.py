"""One face of a shape as geometry: its area, a parametrisation, its normal and distance.

Rough layers, sources and dead layers attach to a face through this interface, whatever the
solid. A :class:`Face` gives

- ``area``: exact, mm^2;
- ``planar``: True for a flat face;
- ``point(u, v)`` and ``normal(u, v)``: the face's surface and its outward unit normal at
  parameters (u, v), in the shape's frame;
- ``locate(points) -> (u, v, h)``: the inverse: parameters of the nearest point of the face's
  surface and the signed distance ``h`` from it along the outward normal (> 0 outside the
  solid); exact for planes and for surfaces of revolution (cylinders, cones, annuli);
- ``distance(points)``: ``h`` alone (the height above the face's surface);
- ``extent``: the parameter ranges ``((u0, u1), (v0, v1))`` the face lies in;
- ``frame``: a :class:`~score4.shapes.Transform` from face-local coordinates (x, y in the
  tangent plane, z along the outward normal, origin at the face's reference point) to the
  shape's frame.

:class:`PlaneFace`: (u, v) are face-local x, y (mm); ``rectangle`` tells that the face fills its
extent (the faces of a G4Box). :class:`RevolvedFace`: a piece of a cylinder or cone swept around
z, (u, v) = (azimuth phi in rad, arc length s along the generator from its midpoint in mm); the
area element is ``r(s) du dv``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from .transform import Transform

Extent = tuple[tuple[float, float], tuple[float, float]]


class Face:
    """A named face of a shape (see the module docstring)."""

    name: str
    area: float
    frame: Transform
    extent: Extent

    @property
    def planar(self) -> bool:
        raise NotImplementedError

    def point(self, u: ArrayLike, v: ArrayLike) -> np.ndarray:
        raise NotImplementedError

    def normal(self, u: ArrayLike, v: ArrayLike) -> np.ndarray:
        raise NotImplementedError

    def locate(self, points: ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        raise NotImplementedError

    def distance(self, points: ArrayLike) -> np.ndarray:
        """Signed distance from the face's surface along its outward normal, mm."""
        return self.locate(points)[2]


@dataclass(frozen=True, eq=False)
class PlaneFace(Face):
    """A flat face: ``frame`` maps (u, v, h) to the shape's frame; ``rectangle``: the face is
    the whole of its extent (else a part of it, e.g. the disk in its bounding square)."""

    name: str
    area: float
    frame: Transform
    extent: Extent
    rectangle: bool = False

    @property
    def planar(self) -> bool:
        return True

    @property
    def size(self) -> tuple[float, float]:
        """Lengths of the extent along u and v, mm."""
        (u0, u1), (v0, v1) = self.extent
        return (u1 - u0, v1 - v0)

    def point(self, u: ArrayLike, v: ArrayLike) -> np.ndarray:
        u, v = np.broadcast_arrays(np.asarray(u, float), np.asarray(v, float))
        return self.frame.apply(np.stack([u, v, np.zeros(u.shape)], axis=-1))

    def normal(self, u: ArrayLike, v: ArrayLike) -> np.ndarray:
        shape = np.broadcast(np.asarray(u), np.asarray(v)).shape
        return np.broadcast_to(self.frame.rotation[:, 2], (*shape, 3)).copy()

    def locate(self, points: ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        q = self.frame.inverse_apply(np.asarray(points, float).reshape(-1, 3))
        return q[:, 0], q[:, 1], q[:, 2]


@dataclass(frozen=True, eq=False)
class RevolvedFace(Face):
    """The segment (r1, z1) -> (r2, z2) of the (r, z) half-plane swept over phi in
    [phi0, phi0 + dphi] (not perpendicular to z: a cylinder or cone piece), ``(nr, nz)`` its
    outward normal in the (r, z) plane."""

    name: str
    rz1: tuple[float, float]
    rz2: tuple[float, float]
    phi0: float
    dphi: float
    nrz: tuple[float, float]

    @property
    def planar(self) -> bool:
        return False

    @property
    def length(self) -> float:
        """Length of the generator, mm."""
        return float(np.hypot(self.rz2[0] - self.rz1[0], self.rz2[1] - self.rz1[1]))

    @property
    def area(self) -> float:  # type: ignore[override]
        return self.dphi * self.length * 0.5 * (self.rz1[0] + self.rz2[0])

    @property
    def extent(self) -> Extent:  # type: ignore[override]
        half = 0.5 * self.length
        return ((self.phi0, self.phi0 + self.dphi), (-half, half))

    @property
    def _mid(self) -> np.ndarray:
        return 0.5 * (np.asarray(self.rz1, float) + np.asarray(self.rz2, float))

    @property
    def _tangent(self) -> np.ndarray:
        d = np.asarray(self.rz2, float) - np.asarray(self.rz1, float)
        return d / max(float(np.hypot(*d)), 1e-300)

    def radius(self, v: ArrayLike) -> np.ndarray:
        """Distance from the axis of the surface at generator arc length ``v``."""
        return self._mid[0] + np.asarray(v, float) * self._tangent[0]

    @property
    def frame(self) -> Transform:  # type: ignore[override]
        """Local frame at the face's middle (phi at the middle of its range, the generator's
        midpoint): x along increasing phi, y along the generator, z the outward normal."""
        phi = self.phi0 + 0.5 * self.dphi
        c, s = np.cos(phi), np.sin(phi)
        radial, azimuthal = np.array([c, s, 0.0]), np.array([-s, c, 0.0])
        tr, tz = self._tangent
        y = tr * radial + np.array([0.0, 0.0, tz])
        nr, nz = self.nrz
        z = nr * radial + np.array([0.0, 0.0, nz])
        x = np.cross(y, z)
        if x @ azimuthal < 0:  # keep (x, y, z) right-handed with z outward
            y = -y
            x = np.cross(y, z)
        r, zz = self._mid
        return Transform(np.column_stack([x, y, z]), r * radial + np.array([0.0, 0.0, zz]))

    def point(self, u: ArrayLike, v: ArrayLike) -> np.ndarray:
        u, v = np.broadcast_arrays(np.asarray(u, float), np.asarray(v, float))
        (rm, zm), (tr, tz) = self._mid, self._tangent
        r, z = rm + v * tr, zm + v * tz
        return np.stack([r * np.cos(u), r * np.sin(u), z], axis=-1)

    def normal(self, u: ArrayLike, v: ArrayLike) -> np.ndarray:
        u, v = np.broadcast_arrays(np.asarray(u, float), np.asarray(v, float))
        nr, nz = self.nrz
        return np.stack([nr * np.cos(u), nr * np.sin(u), np.full(u.shape, nz)], axis=-1)

    def locate(self, points: ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        p = np.asarray(points, float).reshape(-1, 3)
        rho = np.hypot(p[:, 0], p[:, 1])
        phi = np.mod(np.arctan2(p[:, 1], p[:, 0]) - self.phi0, 2 * np.pi) + self.phi0
        (rm, zm), (tr, tz) = self._mid, self._tangent
        dr, dz = rho - rm, p[:, 2] - zm
        nr, nz = self.nrz
        return phi, dr * tr + dz * tz, dr * nr + dz * nz


@dataclass(frozen=True, eq=False)
class AnnulusFace(PlaneFace):
    """A flat ring rmin <= r <= rmax perpendicular to z (the end face of a tube, cone or
    polycone), over phi in [phi0, phi0 + dphi]: local x along the shape's x, the local origin on
    the axis, the extent the square of side 2 rmax."""

    rmin: float = 0.0
    rmax: float = 0.0
    phi0: float = 0.0
    dphi: float = 2 * np.pi

    @classmethod
    def make(
        cls, name: str, radii: list[float], z: float, nz: float, phi0: float, dphi: float
    ) -> AnnulusFace:
        rmin, rmax = (float(r) for r in radii)
        n = np.array([0.0, 0.0, 1.0 if nz > 0 else -1.0])
        u = np.array([1.0, 0.0, 0.0])
        rotation = np.column_stack([u, np.cross(n, u), n])
        area = 0.5 * dphi * (rmax**2 - rmin**2)
        extent = ((-rmax, rmax), (-rmax, rmax))
        frame = Transform(rotation, np.array([0.0, 0.0, z]))
        return cls(name, area, frame, extent, False, rmin, rmax, float(phi0), float(dphi))

    @property
    def full_circle(self) -> bool:
        return self.dphi >= 2 * np.pi - 1e-9

    def covers(self, centres: np.ndarray, size: tuple[float, float]) -> np.ndarray:
        """True for the (u, v) rectangles of ``size`` around ``centres`` (..., 2) that lie
        wholly in the ring (a full circle)."""
        px, py = size
        x, y = np.abs(centres[..., 0]), np.abs(centres[..., 1])
        far = np.hypot(x + px / 2, y + py / 2)
        near = np.hypot(np.maximum(x - px / 2, 0.0), np.maximum(y - py / 2, 0.0))
        return np.asarray((far <= self.rmax * (1 + 1e-12)) & (near >= self.rmin * (1 - 1e-12)))


@dataclass(frozen=True, eq=False)
class SphereFace(Face):
    """A zone of the sphere of ``radius`` about the origin between polar angles theta1 < theta2,
    over phi in [phi0, phi0 + dphi]; ``sign`` +1 for an outer (convex) face, -1 for an inner one.
    (u, v) = (azimuth phi, arc length along the meridian from the zone's middle), v running so
    that (increasing phi, increasing v, outward normal) is right-handed: towards smaller theta
    on an outer face, larger theta on an inner one. The area element is ``R sin(theta) du dv``.
    The same interface as :class:`RevolvedFace` where rough layers need it (``radius(v)``,
    ``length``, ``band_area``)."""

    name: str
    sphere_radius: float
    theta: tuple[float, float]
    phi0: float
    dphi: float
    sign: int = 1

    @property
    def planar(self) -> bool:
        return False

    @property
    def length(self) -> float:
        """Length of the meridian arc, mm."""
        return self.sphere_radius * (self.theta[1] - self.theta[0])

    @property
    def area(self) -> float:  # type: ignore[override]
        c1, c2 = np.cos(self.theta[0]), np.cos(self.theta[1])
        return float(self.sphere_radius**2 * self.dphi * (c1 - c2))

    @property
    def extent(self) -> Extent:  # type: ignore[override]
        half = 0.5 * self.length
        return ((self.phi0, self.phi0 + self.dphi), (-half, half))

    def polar(self, v: ArrayLike) -> np.ndarray:
        """Polar angle at meridian arc length ``v``."""
        mid = 0.5 * (self.theta[0] + self.theta[1])
        return mid - self.sign * np.asarray(v, float) / self.sphere_radius

    def radius(self, v: ArrayLike) -> np.ndarray:
        """Distance from the z axis of the sphere at arc length ``v``."""
        return self.sphere_radius * np.sin(self.polar(v))

    def band_area(self, v0: float, v1: float, dphi: float) -> float:
        """Exact area of the band between arc lengths v0 and v1 over ``dphi``."""
        c0, c1 = np.cos(self.polar(v0)), np.cos(self.polar(v1))
        return float(self.sphere_radius**2 * dphi * abs(c0 - c1))

    @property
    def frame(self) -> Transform:  # type: ignore[override]
        """Local frame at the zone's middle: x along increasing phi, y along increasing v,
        z the outward normal."""
        phi = self.phi0 + 0.5 * self.dphi
        n = self.normal(phi, 0.0)
        x = np.array([-np.sin(phi), np.cos(phi), 0.0])
        return Transform(np.column_stack([x, np.cross(n, x), n]), self.point(phi, 0.0))

    def point(self, u: ArrayLike, v: ArrayLike) -> np.ndarray:
        u, v = np.broadcast_arrays(np.asarray(u, float), np.asarray(v, float))
        t = self.polar(v)
        st = np.sin(t)
        unit = np.stack([st * np.cos(u), st * np.sin(u), np.cos(t)], axis=-1)
        return self.sphere_radius * unit

    def normal(self, u: ArrayLike, v: ArrayLike) -> np.ndarray:
        return self.sign * self.point(u, v) / self.sphere_radius

    def locate(self, points: ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        p = np.asarray(points, float).reshape(-1, 3)
        r = np.linalg.norm(p, axis=1)
        phi = np.mod(np.arctan2(p[:, 1], p[:, 0]) - self.phi0, 2 * np.pi) + self.phi0
        t = np.arccos(np.clip(p[:, 2] / np.maximum(r, 1e-300), -1.0, 1.0))
        mid = 0.5 * (self.theta[0] + self.theta[1])
        v = -self.sign * (t - mid) * self.sphere_radius
        return phi, v, self.sign * (r - self.sphere_radius)
