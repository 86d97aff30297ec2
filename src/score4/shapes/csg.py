"""Geant4's CSG solids as parameter dataclasses: G4Box, G4Trd, G4Trap, G4Tubs, G4Cons, G4Orb,
G4Sphere.

Parameters are Geant4's own (half-lengths, mm; angles in rad), in the order of the Geant4
constructors. Phi ranges are normalised as Geant4 does (a range of 2 pi or more is the full
circle with start 0; a start below 0 or above 2 pi is brought into [0, 2 pi)).

Face names
----------
G4Box, G4Trd, G4Trap
    ``+x``, ``-x``, ``+y``, ``-y``, ``+z``, ``-z`` (the face whose outward normal points most
    along that axis; a G4Trd's ``-z`` face is the ``dx1 x dy1`` one, a G4Trap's the ``-dz``
    one).
G4Tubs, G4Cons
    ``-z``, ``+z`` (end caps: disks, annuli or their sectors), ``outer``, ``inner`` (only with
    an inner radius), ``phi_start``, ``phi_end`` (only for a phi segment). A face of zero area
    (a G4Cons closing to a point) is left out.
G4Orb
    ``outer``.
G4Sphere
    ``outer``, ``inner`` (rmin > 0), ``phi_start``, ``phi_end`` (phi segment), ``theta_start``
    (cone at the start polar angle, when > 0), ``theta_end`` (when the end angle is < pi).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from ..errors import ConfigError
from .base import Patch, PlaneTriangles, Shape, SphereSector, SphereZone, as_points
from .faces import Face, PlaneFace
from .revolved import TWO_PI, RevolvedShape, _wedge_distance, normalise_phi
from .transform import Transform


def _positive(what: str, **values: float) -> None:
    for name, v in values.items():
        if not (math.isfinite(v) and v > 0):
            raise ConfigError(f"{what}: {name} must be > 0, got {v!r}")


# --------------------------------------------------------------------------------------------
# Flat-faced convex solids
# --------------------------------------------------------------------------------------------

# the six faces of a hexahedron with corners indexed by bits (x: 1, y: 2, z: 4), as quads
# wound counter-clockwise seen from outside
_QUADS = {
    "+x": (1, 3, 7, 5),
    "-x": (0, 4, 6, 2),
    "+y": (2, 6, 7, 3),
    "-y": (0, 1, 5, 4),
    "+z": (4, 5, 7, 6),
    "-z": (0, 2, 3, 1),
}


#: Face -> (u, v) axes of its frame as (axis index, sign); n = u x v is the outward normal.
BOX_FACE_AXES = {
    "+z": ((0, 1), (1, 1)),
    "-z": ((0, 1), (1, -1)),
    "+x": ((1, 1), (2, 1)),
    "-x": ((1, -1), (2, 1)),
    "+y": ((2, 1), (0, 1)),
    "-y": ((0, 1), (2, 1)),
}


class _Hexahedron(Shape):
    """A convex solid with six quadrilateral faces (G4Box, G4Trd)."""

    def corners(self) -> np.ndarray:
        raise NotImplementedError

    def _build(self):
        c = self.corners()
        patches: list[Patch] = []
        names = tuple(_QUADS)
        for k, quad in enumerate(_QUADS.values()):
            q = c[list(quad)]
            tris = np.array([[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
            n = np.cross(q[2] - q[0], q[3] - q[1])
            n /= max(float(np.linalg.norm(n)), 1e-300)  # a face shrunk to a line has none
            patches.append(PlaneTriangles(k, tris, n))
        return names, {}, patches

    def _planes(self) -> tuple[np.ndarray, np.ndarray]:
        """Unit outward normals (6, 3) and offsets (6,) of the face planes: n . x <= h inside."""
        c = self.corners()
        normals, offsets = [], []
        for quad in _QUADS.values():
            q = c[list(quad)]
            n = np.cross(q[2] - q[0], q[3] - q[1])
            n /= np.linalg.norm(n)
            normals.append(n)
            offsets.append(float(n @ q.mean(axis=0)))
        return np.array(normals), np.array(offsets)

    def signed_distance(self, points: ArrayLike) -> np.ndarray:
        p = as_points(points)
        n, h = self._planes()
        return (p @ n.T - h).max(axis=1)

    def bounding_box(self) -> tuple[np.ndarray, np.ndarray]:
        c = self.corners()
        return c.min(axis=0), c.max(axis=0)

    def moved_corners(self, cuts: dict[str, float]) -> np.ndarray | None:
        """The eight corners (indexed as :meth:`corners`) once each named face's plane moves
        inward by ``cuts[face]`` mm (< 0: outward), every corner where its three planes meet;
        None for a name that is not one of the six faces. ConfigError when a moved face turns
        over (the cut is wider than the solid there)."""
        if set(cuts) - set(_QUADS):
            return None
        n, h = self._planes()
        names = list(_QUADS)
        h = h - np.array([cuts.get(f, 0.0) for f in names])
        out = np.empty((8, 3))
        for k in range(8):
            rows = [
                names.index(("+" if k & bit else "-") + a)
                for bit, a in ((1, "x"), (2, "y"), (4, "z"))
            ]
            out[k] = np.linalg.solve(n[rows], h[rows])
        c = self.corners()
        scale = max(float(np.abs(c).max()), 1.0)
        for face, quad in _QUADS.items():  # each face keeps its orientation and some area
            q, old = out[list(quad)], c[list(quad)]
            m = np.cross(q[2] - q[0], q[3] - q[1])
            m0 = np.cross(old[2] - old[0], old[3] - old[1])
            if not m @ m0 > 1e-18 * scale**4:
                moved = ", ".join(f"{k} by {v * 1e3:.4g} um" for k, v in cuts.items())
                raise ConfigError(
                    f"{self.kind}: moving face {moved} turns its face {face} over (the solid is "
                    "narrower there than the cut); the cut must be thinner than the solid"
                )
        return out

    @property
    def volume(self) -> float:  # divergence theorem over the (exact) triangles
        return float(
            sum(
                np.einsum(
                    "ij,ij->", p.triangles[:, 0], np.cross(p.triangles[:, 1], p.triangles[:, 2])
                )
                for p in self.patches
                if isinstance(p, PlaneTriangles)
            )
            / 6.0
        )


@dataclass(frozen=True)
class G4Box(_Hexahedron):
    """``G4Box(name, pX, pY, pZ)``: half-lengths along x, y, z (mm)."""

    dx: float
    dy: float
    dz: float
    kind = "G4Box"

    def __post_init__(self) -> None:
        _positive("G4Box", dx=self.dx, dy=self.dy, dz=self.dz)

    def corners(self) -> np.ndarray:
        bits = np.arange(8)
        return np.column_stack(
            [
                np.where(bits & 1, self.dx, -self.dx),
                np.where(bits & 2, self.dy, -self.dy),
                np.where(bits & 4, self.dz, -self.dz),
            ]
        ).astype(float)

    def signed_distance(self, points: ArrayLike) -> np.ndarray:
        p = as_points(points)
        return (np.abs(p) - np.array([self.dx, self.dy, self.dz])).max(axis=1)

    @property
    def half(self) -> np.ndarray:
        return np.array([self.dx, self.dy, self.dz], float)

    @property
    def box_like(self) -> bool:
        return True

    def face(self, name: str) -> Face:
        """A face of the box with the axes of :data:`BOX_FACE_AXES`, centred on the face."""
        if name not in BOX_FACE_AXES:
            self.resolve_faces(name)  # the error lists the faces
            return super().face(name)
        (a, sa), (b, sb) = BOX_FACE_AXES[name]
        u, v = np.zeros(3), np.zeros(3)
        u[a], v[b] = sa, sb
        n = np.cross(u, v)
        axis = int(np.flatnonzero(n)[0])
        half = self.half
        centre = np.zeros(3)
        centre[axis] = n[axis] * half[axis]
        lu, lv = float(2 * half[a]), float(2 * half[b])
        return PlaneFace(
            name,
            lu * lv,
            Transform(np.column_stack([u, v, n]), centre),
            ((-lu / 2, lu / 2), (-lv / 2, lv / 2)),
            rectangle=True,
        )

    def trimmed(self, cuts: dict[str, float]) -> tuple[Shape, np.ndarray] | None:
        lo, hi = -self.half, self.half.copy()
        for name, depth in cuts.items():
            axis = "xyz".index(name[1])
            if name[0] == "+":
                hi[axis] -= depth
            else:
                lo[axis] += depth
        return G4Box(*((hi - lo) / 2)), (hi + lo) / 2

    @property
    def volume(self) -> float:
        return 8.0 * self.dx * self.dy * self.dz

    def sample_volume(self, rng: np.random.Generator, n: int) -> np.ndarray:
        half = np.array([self.dx, self.dy, self.dz])
        return (2 * rng.random((n, 3)) - 1) * half


@dataclass(frozen=True)
class G4Trd(_Hexahedron):
    """``G4Trd(name, dx1, dx2, dy1, dy2, dz)``: half-lengths at -dz (1) and +dz (2), mm."""

    dx1: float
    dx2: float
    dy1: float
    dy2: float
    dz: float
    kind = "G4Trd"

    def __post_init__(self) -> None:
        _positive("G4Trd", dz=self.dz)
        for name in ("dx1", "dx2", "dy1", "dy2"):
            if not getattr(self, name) >= 0:
                raise ConfigError(f"G4Trd: {name} must be >= 0, got {getattr(self, name)!r}")
        if max(self.dx1, self.dx2) <= 0 or max(self.dy1, self.dy2) <= 0:
            raise ConfigError("G4Trd: dx1/dx2 and dy1/dy2 may not both be 0")

    def corners(self) -> np.ndarray:
        bits = np.arange(8)
        top = (bits & 4) > 0
        dx = np.where(top, self.dx2, self.dx1)
        dy = np.where(top, self.dy2, self.dy1)
        return np.column_stack(
            [
                np.where(bits & 1, dx, -dx),
                np.where(bits & 2, dy, -dy),
                np.where(top, self.dz, -self.dz),
            ]
        ).astype(float)

    def _build(self):
        names, groups, patches = super()._build()
        # a face shrunk to a line (dx2 = 0, ...) has no area and no normal: leave it out
        return names, groups, [p for p in patches if p.area > 0]

    def _planes(self) -> tuple[np.ndarray, np.ndarray]:
        dz = self.dz
        nx = np.array([2 * dz, 0.0, self.dx1 - self.dx2])
        ny = np.array([0.0, 2 * dz, self.dy1 - self.dy2])
        nx, ny = nx / np.linalg.norm(nx), ny / np.linalg.norm(ny)
        hx = nx[0] * 0.5 * (self.dx1 + self.dx2)
        hy = ny[1] * 0.5 * (self.dy1 + self.dy2)
        normals = np.array([nx, nx * [-1, 1, 1], ny, ny * [1, -1, 1], [0, 0, 1.0], [0, 0, -1.0]])
        return normals, np.array([hx, hx, hy, hy, dz, dz])

    def moved(self, cuts: dict[str, float]) -> tuple[Shape, np.ndarray] | None:
        """The G4Trd with its faces moved inward by ``cuts`` (< 0: outward): an end face along
        z (the half widths there follow the sides' planes), a side along its normal (its planes'
        x or y at every z move by the depth over the normal's x or y component; the half widths
        at both ends change by half that, the centre moves by the other half); the shift of the
        centre. ConfigError when a half width would fall below 0."""
        if set(cuts) - set(_QUADS):
            return None
        dz = self.dz
        lo, hi = -dz + cuts.get("-z", 0.0), dz - cuts.get("+z", 0.0)
        if not hi > lo:
            raise ConfigError(
                f"G4Trd: moving its end faces leaves no solid ({2 * dz:.4g} mm long); the cut "
                "must be thinner than the solid"
            )
        out, centre = [], [0.0, 0.0, (lo + hi) / 2]
        for axis, (w1, w2) in enumerate(((self.dx1, self.dx2), (self.dy1, self.dy2))):
            name = "xy"[axis]
            plane = np.zeros(3)
            plane[axis], plane[2] = 2 * dz, w1 - w2  # the + side's outward normal, not unit
            along = float(np.linalg.norm(plane) / plane[axis])  # shift per depth along the axis
            sp, sm = cuts.get(f"+{name}", 0.0) * along, cuts.get(f"-{name}", 0.0) * along

            def width(z: float, w1: float = w1, w2: float = w2) -> float:
                return w1 + (w2 - w1) * (z + dz) / (2 * dz)

            ends = [width(lo) - (sp + sm) / 2, width(hi) - (sp + sm) / 2]
            if min(ends) < -1e-12 * max(w1, w2, dz) or max(ends) <= 0:
                moved = ", ".join(f"{k} by {v * 1e3:.4g} um" for k, v in cuts.items())
                raise ConfigError(
                    f"G4Trd: moving face {moved} leaves a half width of {min(ends):.4g} mm in "
                    f"{name}; the cut must be thinner than the solid"
                )
            out.append([max(e, 0.0) for e in ends])
            centre[axis] = (sm - sp) / 2
        (dx1, dx2), (dy1, dy2) = out
        return G4Trd(dx1, dx2, dy1, dy2, (hi - lo) / 2), np.array(centre)

    @property
    def volume(self) -> float:
        a1, a2 = 4 * self.dx1 * self.dy1, 4 * self.dx2 * self.dy2
        am = 4 * 0.5 * (self.dx1 + self.dx2) * 0.5 * (self.dy1 + self.dy2)
        return 2 * self.dz * (a1 + 4 * am + a2) / 6.0  # Simpson: exact for a quadratic section


@dataclass(frozen=True)
class G4Trap(_Hexahedron):
    """``G4Trap(name, pDz, pTheta, pPhi, pDy1, pDx1, pDx2, pAlp1, pDy2, pDx3, pDx4, pAlp2)``:
    half-length in z, polar and azimuthal angle of the line joining the centres of the -z and +z
    faces, and at each end (1: -z, 2: +z) the half-length in y, the half-lengths in x at -y and
    +y, and the tilt angle of the x sides (mm, rad). Faces as a G4Box's (the ``-z`` face is the
    ``-dz`` one)."""

    dz: float
    theta: float
    phi: float
    dy1: float
    dx1: float
    dx2: float
    alpha1: float
    dy2: float
    dx3: float
    dx4: float
    alpha2: float
    kind = "G4Trap"

    def __post_init__(self) -> None:
        _positive("G4Trap", dz=self.dz, dy1=self.dy1, dy2=self.dy2)
        for name in ("dx1", "dx2", "dx3", "dx4"):
            if not getattr(self, name) > 0:
                raise ConfigError(f"G4Trap: {name} must be > 0, got {getattr(self, name)!r}")
        c = self.corners()
        for quad in _QUADS.values():  # Geant4 refuses a trap whose side faces are not planes
            q = c[list(quad)]
            n = np.cross(q[2] - q[0], q[3] - q[1])
            n /= np.linalg.norm(n)
            off = float(np.abs((q - q[0]) @ n).max())
            if off > 1e-9 * max(float(np.abs(c).max()), 1.0):
                raise ConfigError(f"G4Trap: a side face is not planar (off by {off:.3g} mm)")

    @classmethod
    def from_corners(cls, c: np.ndarray) -> tuple[G4Trap, np.ndarray]:
        """The G4Trap with the eight corners ``c`` (indexed as :meth:`corners`; the -z face's
        four at one z, the +z face's at another, each face's -y and +y edges along x), and the
        shift of its origin (the corners are the trap's moved by it)."""
        c = np.asarray(c, float)
        z1, z2 = float(c[:4, 2].mean()), float(c[4:, 2].mean())
        dz, mid_z = (z2 - z1) / 2, (z1 + z2) / 2
        c = c.tolist()  # plain floats
        ends = []
        for q in (c[:4], c[4:]):
            dy = (q[2][1] - q[0][1]) / 2
            xm, xp = (q[0][0] + q[1][0]) / 2, (q[2][0] + q[3][0]) / 2
            centre = np.array([(xm + xp) / 2, (q[0][1] + q[2][1]) / 2])
            dxm, dxp = (q[1][0] - q[0][0]) / 2, (q[3][0] - q[2][0]) / 2
            ends.append((centre, dy, dxm, dxp, math.atan((xp - xm) / (2 * dy))))
        (c1, dy1, dx1, dx2, al1), (c2, dy2, dx3, dx4, al2) = ends
        shift = np.array([*((c1 + c2) / 2), mid_z])
        tx, ty = ((c2 - c1) / (2 * dz)).tolist()
        theta, phi = math.atan(math.hypot(tx, ty)), math.atan2(ty, tx)
        return cls(dz, theta, phi, dy1, dx1, dx2, al1, dy2, dx3, dx4, al2), shift

    def moved(self, cuts: dict[str, float]) -> tuple[Shape, np.ndarray] | None:
        """The G4Trap with each named face's plane moved inward by ``cuts`` (< 0: outward; the
        other planes stay): its corners where their planes meet (:meth:`moved_corners`), a
        G4Trap again (its end faces stay along z, its y faces hold the x direction), and the
        shift of its origin."""
        c = self.moved_corners(cuts)
        return None if c is None else G4Trap.from_corners(c)

    def corners(self) -> np.ndarray:
        """The eight corners, indexed by bits (x: 1, y: 2, z: 4) as G4Trap numbers them."""
        tx = math.tan(self.theta) * math.cos(self.phi)
        ty = math.tan(self.theta) * math.sin(self.phi)
        ta1, ta2 = math.tan(self.alpha1), math.tan(self.alpha2)
        out = []
        for z, dy, dxm, dxp, ta in (
            (-self.dz, self.dy1, self.dx1, self.dx2, ta1),
            (self.dz, self.dy2, self.dx3, self.dx4, ta2),
        ):
            for y, dx in ((-dy, dxm), (dy, dxp)):
                out += [[z * tx + y * ta + sx * dx, z * ty + y, z] for sx in (-1, 1)]
        return np.array(out, float)


# --------------------------------------------------------------------------------------------
# Tubes and cones
# --------------------------------------------------------------------------------------------


def _cone_contour(
    rmin1: float, rmax1: float, rmin2: float, rmax2: float, dz: float
) -> tuple[np.ndarray, list[str]]:
    """Counter-clockwise (r, z) contour and edge names of a G4Cons section."""
    poly = np.array([[rmin1, -dz], [rmax1, -dz], [rmax2, dz], [rmin2, dz]], float)
    names = ["-z", "outer", "+z", "inner"]
    keep = [i for i in range(4) if np.hypot(*(poly[(i + 1) % 4] - poly[i])) > 0]
    return poly[keep] if len(keep) < 4 else poly, [names[i] for i in keep]


@dataclass(frozen=True)
class G4Tubs(RevolvedShape):
    """``G4Tubs(name, pRMin, pRMax, pDz, pSPhi, pDPhi)``: radii, half-length in z, phi range."""

    rmin: float
    rmax: float
    dz: float
    sphi: float = 0.0
    dphi: float = TWO_PI
    kind = "G4Tubs"

    def __post_init__(self) -> None:
        _positive("G4Tubs", rmax=self.rmax, dz=self.dz)
        if not 0 <= self.rmin < self.rmax:
            raise ConfigError(f"G4Tubs: need 0 <= rmin < rmax, got {self.rmin!r}, {self.rmax!r}")
        s, d = normalise_phi(self.sphi, self.dphi, "G4Tubs")
        object.__setattr__(self, "sphi", s)
        object.__setattr__(self, "dphi", d)

    def contour(self) -> tuple[np.ndarray, list[str]]:
        return _cone_contour(self.rmin, self.rmax, self.rmin, self.rmax, self.dz)

    def trimmed(self, cuts: dict[str, float]) -> tuple[Shape, np.ndarray] | None:
        """Shorter along z for cuts behind the end faces ``+z``/``-z``, thinner for cuts behind
        the walls ``outer`` (rmax less the cut) and ``inner`` (rmin more); None for others."""
        if set(cuts) - {"+z", "-z", "outer", "inner"} or ("inner" in cuts and self.rmin == 0):
            return None
        lo_z, hi_z = -self.dz, self.dz
        rmin, rmax = self.rmin + cuts.get("inner", 0.0), self.rmax - cuts.get("outer", 0.0)
        if rmin >= rmax:
            walls = " and ".join(
                f"{cuts[w] * 1e3:.4g} um behind face {w}" for w in ("outer", "inner") if w in cuts
            )
            raise ConfigError(
                f"G4Tubs: a cut of {walls} leaves no wall: the tube is "
                f"{(self.rmax - self.rmin) * 1e3:.4g} um thick (rmax - rmin); the cut must be "
                "thinner"
            )
        for name, depth in cuts.items():
            if name == "+z":
                hi_z -= depth
            elif name == "-z":
                lo_z += depth
        shorter = G4Tubs(rmin, rmax, (hi_z - lo_z) / 2, self.sphi, self.dphi)
        return shorter, np.array([0.0, 0.0, (hi_z + lo_z) / 2])


@dataclass(frozen=True)
class G4Cons(RevolvedShape):
    """``G4Cons(name, pRmin1, pRmax1, pRmin2, pRmax2, pDz, pSPhi, pDPhi)``: radii at -dz (1)
    and +dz (2), half-length, phi range."""

    rmin1: float
    rmax1: float
    rmin2: float
    rmax2: float
    dz: float
    sphi: float = 0.0
    dphi: float = TWO_PI
    kind = "G4Cons"

    def __post_init__(self) -> None:
        _positive("G4Cons", dz=self.dz)
        if not (0 <= self.rmin1 <= self.rmax1 and 0 <= self.rmin2 <= self.rmax2):
            raise ConfigError("G4Cons: need 0 <= rmin <= rmax at both ends")
        if max(self.rmax1, self.rmax2) <= 0:
            raise ConfigError("G4Cons: rmax1 and rmax2 may not both be 0")
        s, d = normalise_phi(self.sphi, self.dphi, "G4Cons")
        object.__setattr__(self, "sphi", s)
        object.__setattr__(self, "dphi", d)

    def contour(self) -> tuple[np.ndarray, list[str]]:
        return _cone_contour(self.rmin1, self.rmax1, self.rmin2, self.rmax2, self.dz)

    def trimmed(self, cuts: dict[str, float]) -> tuple[Shape, np.ndarray] | None:
        """The G4Cons with the faces ``cuts`` names moved inward by their depths: a wall's
        radii at both ends moved so that the wall moves by the depth along its normal, an end
        face moved along z (:meth:`cut_contour`; a cone closing to a point gets shorter); the
        shift of its centre along z. None for a phi cut."""
        cut = self.cut_contour(cuts)
        if cut is None:
            return None
        poly = cut[0]
        z0, z1 = float(poly[:, 1].min()), float(poly[:, 1].max())
        tol = 1e-12 * max(float(np.abs(poly).max()), 1.0)
        low, high = poly[np.abs(poly[:, 1] - z0) <= tol, 0], poly[np.abs(poly[:, 1] - z1) <= tol, 0]
        shape = G4Cons(
            float(low.min()),
            float(low.max()),
            float(high.min()),
            float(high.max()),
            (z1 - z0) / 2,
            self.sphi,
            self.dphi,
        )
        return shape, np.array([0.0, 0.0, (z0 + z1) / 2])


# --------------------------------------------------------------------------------------------
# Spheres
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class G4Sphere(Shape):
    """``G4Sphere(name, pRmin, pRmax, pSPhi, pDPhi, pSTheta, pDTheta)``."""

    rmin: float
    rmax: float
    sphi: float = 0.0
    dphi: float = TWO_PI
    stheta: float = 0.0
    dtheta: float = math.pi
    kind = "G4Sphere"

    def __post_init__(self) -> None:
        _positive("G4Sphere", rmax=self.rmax)
        if not 0 <= self.rmin < self.rmax:
            raise ConfigError(f"G4Sphere: need 0 <= rmin < rmax, got {self.rmin!r}, {self.rmax!r}")
        s, d = normalise_phi(self.sphi, self.dphi, "G4Sphere")
        object.__setattr__(self, "sphi", s)
        object.__setattr__(self, "dphi", d)
        if not (0 <= self.stheta < math.pi and self.dtheta > 0):
            raise ConfigError("G4Sphere: need 0 <= stheta < pi and dtheta > 0")
        if self.stheta + self.dtheta >= math.pi:
            object.__setattr__(self, "dtheta", math.pi - self.stheta)

    @property
    def _theta(self) -> tuple[float, float]:
        return self.stheta, self.stheta + self.dtheta

    @property
    def _full_phi(self) -> bool:
        return self.dphi >= TWO_PI

    def trimmed(self, cuts: dict[str, float]) -> tuple[Shape, np.ndarray] | None:
        """Thinner by cuts behind its faces ``outer`` and ``inner`` (None for others)."""
        if set(cuts) - {"outer", "inner"}:
            return None
        rmin = self.rmin + cuts.get("inner", 0.0)
        rmax = self.rmax - cuts.get("outer", 0.0)
        return G4Sphere(rmin, rmax, self.sphi, self.dphi, self.stheta, self.dtheta), np.zeros(3)

    def _build(self):
        t1, t2 = self._theta
        names: list[str] = []
        patches: list[Patch] = []

        def add(name: str, patch_of) -> None:
            names.append(name)
            patches.append(patch_of(len(names) - 1))

        add("outer", lambda k: SphereZone(k, self.rmax, (t1, t2), self.sphi, self.dphi, +1))
        if self.rmin > 0:
            add("inner", lambda k: SphereZone(k, self.rmin, (t1, t2), self.sphi, self.dphi, -1))
        if not self._full_phi:
            for name, phi, sign in (
                ("phi_start", self.sphi, 1),
                ("phi_end", self.sphi + self.dphi, -1),
            ):
                normal = sign * np.array([math.sin(phi), -math.cos(phi), 0.0])
                add(
                    name,
                    lambda k, phi=phi, normal=normal: SphereSector(
                        k, (self.rmin, self.rmax), (t1, t2), phi, normal
                    ),
                )
        from .base import Revolved

        if t1 > 0:
            s, c = math.sin(t1), math.cos(t1)
            add(
                "theta_start",
                lambda k: Revolved(
                    k,
                    (self.rmin * s, self.rmin * c),
                    (self.rmax * s, self.rmax * c),
                    self.sphi,
                    self.dphi,
                    (-c, s),
                ),
            )
        if t2 < math.pi:
            s, c = math.sin(t2), math.cos(t2)
            add(
                "theta_end",
                lambda k: Revolved(
                    k,
                    (self.rmin * s, self.rmin * c),
                    (self.rmax * s, self.rmax * c),
                    self.sphi,
                    self.dphi,
                    (c, -s),
                ),
            )
        return tuple(names), {}, patches

    def signed_distance(self, points: ArrayLike) -> np.ndarray:
        p = as_points(points)
        r = np.linalg.norm(p, axis=1)
        s = r - self.rmax
        if self.rmin > 0:
            s = np.maximum(s, self.rmin - r)
        t1, t2 = self._theta
        if t1 > 0 or t2 < math.pi:
            theta = np.arccos(np.clip(p[:, 2] / np.maximum(r, 1e-300), -1, 1))
            angle = np.maximum(t1 - theta, theta - t2)  # > 0 outside the polar range
            a = np.abs(angle)
            dist = np.where(a < 0.5 * math.pi, r * np.sin(np.minimum(a, 0.5 * math.pi)), r)
            s = np.maximum(s, np.where(angle > 0, dist, -dist))
        if not self._full_phi:
            s = np.maximum(s, _wedge_distance(p, self.sphi, self.dphi))
        return s

    @property
    def volume(self) -> float:
        t1, t2 = self._theta
        return self.dphi * (math.cos(t1) - math.cos(t2)) * (self.rmax**3 - self.rmin**3) / 3.0

    def bounding_box(self) -> tuple[np.ndarray, np.ndarray]:
        # the box of a few thousand surface points plus the exact extremes, widened a little
        rng = np.random.default_rng(0)
        pts = self.sample_surface(rng, 4000).position
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        r = self.rmax
        for axis_point in (
            np.array([[r, 0, 0]]),
            np.array([[-r, 0, 0]]),
            np.array([[0, r, 0]]),
            np.array([[0, -r, 0]]),
            np.array([[0, 0, r]]),
            np.array([[0, 0, -r]]),
        ):
            if self.inside(axis_point)[0] > 0:
                lo, hi = np.minimum(lo, axis_point[0]), np.maximum(hi, axis_point[0])
        pad = 0.01 * r
        return np.maximum(lo - pad, -r), np.minimum(hi + pad, r)

    def sample_volume(self, rng: np.random.Generator, n: int) -> np.ndarray:
        u, v, w = rng.random((3, n))
        r = np.cbrt(self.rmin**3 + u * (self.rmax**3 - self.rmin**3))
        t1, t2 = self._theta
        cos = math.cos(t2) + v * (math.cos(t1) - math.cos(t2))
        sin = np.sqrt(np.maximum(1 - cos * cos, 0.0))
        phi = self.sphi + w * self.dphi
        return r[:, None] * np.column_stack([sin * np.cos(phi), sin * np.sin(phi), cos])


@dataclass(frozen=True)
class G4Orb(Shape):
    """``G4Orb(name, pRmax)``: a full sphere of radius ``r`` (mm)."""

    r: float
    kind = "G4Orb"

    def __post_init__(self) -> None:
        _positive("G4Orb", r=self.r)

    def _build(self):
        return ("outer",), {}, [SphereZone(0, self.r, (0.0, math.pi), 0.0, TWO_PI, +1)]

    def signed_distance(self, points: ArrayLike) -> np.ndarray:
        return np.linalg.norm(as_points(points), axis=1) - self.r

    def trimmed(self, cuts: dict[str, float]) -> tuple[Shape, np.ndarray] | None:
        """Smaller by a cut behind its face ``outer`` (None for others)."""
        if set(cuts) - {"outer"}:
            return None
        return G4Orb(self.r - cuts.get("outer", 0.0)), np.zeros(3)

    @property
    def volume(self) -> float:
        return 4.0 / 3.0 * math.pi * self.r**3

    def bounding_box(self) -> tuple[np.ndarray, np.ndarray]:
        return np.full(3, -self.r), np.full(3, self.r)

    def sample_volume(self, rng: np.random.Generator, n: int) -> np.ndarray:
        return G4Sphere(0.0, self.r).sample_volume(rng, n)
