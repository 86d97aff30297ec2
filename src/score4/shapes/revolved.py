"""Solids swept around the z axis from an (r, z) contour: G4Polycone, G4GenericPolycone,
G4Polyhedra, G4GenericPolyhedra (and the machinery G4Tubs and G4Cons share).

Face names of the contour solids
--------------------------------
The contour is taken as Geant4 stores it (repeated corners and corners on a straight line
removed), counter-clockwise in the (r, z) half-plane (r to the right, z up), starting at its
lowest corner (smallest r among the lowest). Edge ``i`` (corner i to corner i + 1) swept around
z is the face ``seg_<i>``; edges on the z axis are not surfaces and have no face. Groups:
``outer`` (edges whose outward normal points away from the axis), ``inner`` (towards it),
``top`` / ``bottom`` (flat rings facing +z / -z), and ``phi_start`` / ``phi_end`` (the flat cuts
of a phi segment). A solid built from z planes and the same solid read back from Geant4 (which
keeps only the contour) have the same faces under the same names.

G4Polyhedra: the radii of the z-plane form are Geant4's: distances from the axis to the flat
sides (apothems); the generic (r, z) form takes corner radii, as ``G4Polyhedra::GetCorner``
returns them. Each contour edge is ``nsides`` flat quadrilaterals under one name.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from ..errors import ConfigError
from . import _plane
from .base import Patch, PlaneTriangles, Revolved, Shape, as_points

TWO_PI = 2 * math.pi
ANGLE_TOLERANCE = 1e-9  # Geant4's kAngTolerance, rad


def normalise_phi(sphi: float, dphi: float, what: str) -> tuple[float, float]:
    """Geant4's rule for phi ranges (G4Tubs::CheckPhiAngles and friends)."""
    if not dphi > 0:
        raise ConfigError(f"{what}: the phi range must be > 0, got {dphi:g} rad")
    if dphi >= TWO_PI - 0.5 * ANGLE_TOLERANCE:
        return 0.0, TWO_PI
    sphi = TWO_PI - math.fmod(abs(sphi), TWO_PI) if sphi < 0 else math.fmod(sphi, TWO_PI)
    if sphi + dphi > TWO_PI:
        sphi -= TWO_PI
    return sphi, float(dphi)


def _wedge_distance(points: np.ndarray, sphi: float, dphi: float) -> np.ndarray:
    """Signed distance (negative inside) to the wedge sphi <= phi <= sphi + dphi."""
    rho = np.hypot(points[:, 0], points[:, 1])
    delta = np.mod(np.arctan2(points[:, 1], points[:, 0]) - sphi, TWO_PI)
    inside = delta <= dphi
    angle = np.where(
        inside, np.minimum(delta, dphi - delta), np.minimum(delta - dphi, TWO_PI - delta)
    )
    dist = np.where(angle < 0.5 * math.pi, rho * np.sin(np.minimum(angle, 0.5 * math.pi)), rho)
    return np.where(inside, -dist, dist)


def _edges(poly: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Start and end corners of the edges and their unit outward normals (counter-clockwise)."""
    a, b = poly, np.roll(poly, -1, axis=0)
    d = b - a
    length = np.hypot(d[:, 0], d[:, 1])
    normal = np.column_stack([d[:, 1], -d[:, 0]]) / np.maximum(length, 1e-300)[:, None]
    return a, b, normal


def _contour_names(poly: np.ndarray) -> tuple[list[str], dict[str, tuple[str, ...]]]:
    """``seg_<i>`` for every edge off the axis, and the outer/inner/top/bottom groups."""
    a, b, normal = _edges(poly)
    names: list[str] = []
    groups: dict[str, list[str]] = {"outer": [], "inner": [], "top": [], "bottom": []}
    for i in range(len(poly)):
        if a[i, 0] == 0 and b[i, 0] == 0:
            names.append("")  # on the axis: no surface
            continue
        name = f"seg_{i}"
        names.append(name)
        nr, nz = normal[i]
        if abs(nr) <= 1e-12:
            groups["top" if nz > 0 else "bottom"].append(name)
        else:
            groups["outer" if nr > 0 else "inner"].append(name)
    return names, {k: tuple(v) for k, v in groups.items() if v}


def _sample_rz(rng: np.random.Generator, poly: np.ndarray, n: int) -> np.ndarray:
    """(n, 2) points in the polygon with density proportional to r (exact, by rejection)."""
    tris = _plane.triangulate(poly)
    area = 0.5 * np.abs(
        (tris[:, 1, 0] - tris[:, 0, 0]) * (tris[:, 2, 1] - tris[:, 0, 1])
        - (tris[:, 2, 0] - tris[:, 0, 0]) * (tris[:, 1, 1] - tris[:, 0, 1])
    )
    rmax = tris[:, :, 0].max(axis=1)
    weight = area * rmax  # proposal: uniform in the triangle, accepted with r / rmax
    cum = np.cumsum(weight)
    out = np.empty((0, 2))
    while len(out) < n:
        m = 2 * (n - len(out)) + 16
        k = np.minimum(np.searchsorted(cum, rng.random(m) * cum[-1], side="right"), len(tris) - 1)
        st = rng.random((2, m))
        flip = st.sum(axis=0) > 1
        st[:, flip] = 1 - st[:, flip]
        t = tris[k]
        p = t[:, 0] + st[0, :, None] * (t[:, 1] - t[:, 0]) + st[1, :, None] * (t[:, 2] - t[:, 0])
        keep = rng.random(m) * rmax[k] < p[:, 0]
        out = np.concatenate([out, p[keep]])
    return out[:n]


def offset_contour(
    poly: np.ndarray, names: list[str], cuts: dict[str, float], what: str
) -> tuple[np.ndarray, list[int]]:
    """The contour with each named edge moved inward (against its outward normal) by
    ``cuts[name]`` mm: every corner is where the lines of its two edges (moved or not) meet, so
    a neighbour of a moved edge keeps its line and gets shorter or longer. Where two edges in
    one line (a face divided by cuts) move by different depths, a step joins them. Returns the
    new corners and, for each old edge, the index of its new edge. ConfigError (after
    ``what``) when an edge would vanish or turn round, a radius would fall below 0 or the
    contour would cross itself."""
    a, b, normal = _edges(poly)
    n = len(poly)
    depth = np.array([cuts.get(name, 0.0) if name else 0.0 for name in names])
    scale = max(float(np.abs(poly).max()), 1.0)
    corners: list[np.ndarray] = []
    first: list[int] = []  # index of the first new corner of each old corner
    for k in range(n):
        i, j = (k - 1) % n, k  # edge i ends at corner k, edge j starts there
        first.append(len(corners))
        if depth[i] == 0 and depth[j] == 0:
            corners.append(poly[k].copy())
            continue
        di, dj = b[i] - a[i], b[j] - a[j]
        den = di[0] * dj[1] - di[1] * dj[0]
        if abs(den) <= 1e-12 * float(np.hypot(*di) * np.hypot(*dj)):  # one line
            pi, pj = poly[k] - depth[i] * normal[i], poly[k] - depth[j] * normal[j]
            corners += [pi] if depth[i] == depth[j] else [pi, pj]
            continue
        # the moved lines: normal . p = normal . a - depth
        m = np.array([normal[i], normal[j]])
        h = np.array([normal[i] @ a[i] - depth[i], normal[j] @ a[j] - depth[j]])
        corners.append(np.linalg.solve(m, h))
    out = np.array(corners)
    # old edge k runs from the last new corner of corner k to the first of corner k + 1
    last = [(first[k + 1] - 1) if k + 1 < n else len(corners) - 1 for k in range(n)]
    for k in range(n):
        s, e = out[last[k]], out[first[(k + 1) % n]]
        d_old, d_new = b[k] - a[k], e - s
        if names[k] and (d_new @ d_old <= 1e-9 * scale * float(np.hypot(*d_old))):
            moved = [names[m] for m in ((k - 1) % n, (k + 1) % n, k) if depth[m] != 0]
            raise ConfigError(
                f"{what}: a cut of {max(np.abs(depth)) * 1e3:.4g} um "
                f"{'behind' if depth.max() > 0 else 'in front of'} face {moved[0]} leaves no "
                f"face {names[k]} ({float(np.hypot(*d_old)):.4g} mm long); a face next to an "
                "into face must be longer than the cut moves its end"
            )
    if (out[:, 0] < -1e-9 * scale).any():
        raise ConfigError(
            f"{what}: the cut moves a corner of the (r, z) contour to r = "
            f"{float(out[:, 0].min()):.4g} mm, past the axis; the cut must be thinner than the "
            "solid"
        )
    out[:, 0] = np.maximum(out[:, 0], 0.0)
    if _plane._self_crossing(out):
        raise ConfigError(
            f"{what}: the cut makes the (r, z) contour cross itself; the cut must be thinner "
            "than the solid is wide there"
        )
    return out, last


class RevolvedShape(Shape):
    """A solid of revolution: an (r, z) contour swept over ``[sphi, sphi + dphi]``.

    Subclasses give :meth:`contour` (counter-clockwise corners and one name per edge) and the
    fields ``sphi``, ``dphi``.
    """

    sphi: float
    dphi: float

    def contour(self) -> tuple[np.ndarray, list[str]]:
        raise NotImplementedError

    @property
    def full_phi(self) -> bool:
        return self.dphi >= TWO_PI

    def _groups(self, names: list[str]) -> dict[str, tuple[str, ...]]:
        return {}

    def cut_contour(self, cuts: dict[str, float]) -> tuple[np.ndarray, list[int]] | None:
        """The (r, z) contour with the faces ``cuts`` names moved inward by their depths
        (:func:`offset_contour`) and the new edge of each old one; None when a cut names no
        face swept from the contour (a phi cut)."""
        poly, names = self.contour()
        a, b, _ = _edges(poly)
        names = ["" if (a[i, 0] == 0 and b[i, 0] == 0) else n for i, n in enumerate(names)]
        if set(cuts) - {n for n in names if n}:
            return None
        return offset_contour(poly, names, cuts, self.kind)

    def cut_face(self, name: str, cuts: dict[str, float]) -> Revolved:
        """Face ``name`` of the solid cut by ``cuts`` (see :meth:`cut_contour`), as a patch
        (``.as_face(name)``)."""
        poly, names = self.contour()
        cut = self.cut_contour(cuts)
        assert cut is not None
        new, edge_of = cut
        k = names.index(name)
        e = edge_of[k]
        normal = _edges(poly)[2][k]
        return Revolved(0, new[e], new[(e + 1) % len(new)], self.sphi, self.dphi, normal)

    def footed(
        self, cuts: dict[str, float], feet: dict[str, float]
    ) -> tuple[Shape, np.ndarray] | None:
        """The solid cut by ``cuts`` (:meth:`cut_contour`; may be empty) with each flat end face
        named in ``feet`` (an edge of the contour along r) extruded by its depth (mm, > 0) along
        its outward normal: straight along the axis from its rim, whatever the slope of the
        walls that meet it (a part of a union grown down into the cut of the face it stands
        on); a G4GenericPolycone, and no shift. None for a phi cut or a face of ``feet`` that
        is not a flat end face."""
        poly, names = self.contour()
        cut = self.cut_contour(cuts)
        if cut is None or set(feet) - set(names):
            return None
        new, edge_of = cut
        a, b, normal = _edges(poly)
        steps: dict[int, np.ndarray] = {}
        for face, depth in feet.items():
            k = names.index(face)
            if a[k, 1] != b[k, 1] or a[k, 0] == b[k, 0] or not depth > 0:
                return None
            steps[edge_of[k]] = normal[k] * depth
        m = len(new)
        out: list[np.ndarray] = []
        for i in range(m):
            out.append(new[i])
            if i in steps:  # the foot's rim, then the foot moved out
                out += [new[i] + steps[i], new[(i + 1) % m] + steps[i]]
        pts = np.array(out)
        tol = 1e-12 * max(float(np.abs(pts).max()), 1.0)
        r = pts[:, 0]
        straight = (np.abs(np.roll(r, 1) - r) <= tol) & (np.abs(np.roll(r, -1) - r) <= tol)
        pts = pts[~straight]  # a rim corner on a wall along the axis (or on the axis)
        if _plane._self_crossing(pts):
            raise ConfigError(
                f"{self.kind}: its foot extruded by {max(feet.values()) * 1e3:.4g} um makes the "
                "(r, z) contour cross itself"
            )
        return G4GenericPolycone(
            self.sphi, self.dphi, _as_tuple(pts[:, 0]), _as_tuple(pts[:, 1])
        ), (np.zeros(3))

    def _build(self):
        poly, names = self.contour()
        a, b, normal = _edges(poly)
        faces: list[str] = []
        patches: list[Patch] = []
        for i, name in enumerate(names):
            if not name or (a[i, 0] == 0 and b[i, 0] == 0):
                continue
            faces.append(name)
            patches.append(Revolved(len(faces) - 1, a[i], b[i], self.sphi, self.dphi, normal[i]))
        groups = self._groups(names)
        if not self.full_phi:
            tris = _plane.triangulate(poly)
            for name, phi, sign in (
                ("phi_start", self.sphi, 1.0),
                ("phi_end", self.sphi + self.dphi, -1.0),
            ):
                faces.append(name)
                c, s = math.cos(phi), math.sin(phi)
                t3 = np.stack([tris[..., 0] * c, tris[..., 0] * s, tris[..., 1]], axis=-1)
                patches.append(PlaneTriangles(len(faces) - 1, t3, sign * np.array([s, -c, 0.0])))
        return tuple(faces), groups, patches

    def _surface_edges(self, poly: np.ndarray) -> np.ndarray:
        a, b, _ = _edges(poly)
        return ~((a[:, 0] == 0) & (b[:, 0] == 0))

    def signed_distance(self, points: ArrayLike) -> np.ndarray:
        p = as_points(points)
        poly, _ = self.contour()
        rz = np.column_stack([np.hypot(p[:, 0], p[:, 1]), p[:, 2]])
        s = _plane.signed_distance(rz, poly, self._surface_edges(poly))
        if not self.full_phi:
            s = np.maximum(s, _wedge_distance(p, self.sphi, self.dphi))
        return s

    @property
    def volume(self) -> float:
        return self.dphi * _plane.first_moment_r(self.contour()[0])

    def bounding_box(self) -> tuple[np.ndarray, np.ndarray]:
        poly, _ = self.contour()
        rmin, rmax = poly[:, 0].min(), poly[:, 0].max()
        zlo, zhi = poly[:, 1].min(), poly[:, 1].max()
        if self.full_phi:
            return np.array([-rmax, -rmax, zlo]), np.array([rmax, rmax, zhi])
        angles = [self.sphi, self.sphi + self.dphi]
        angles += [
            k * 0.5 * math.pi
            for k in range(-4, 9)
            if 0 < (k * 0.5 * math.pi - self.sphi) < self.dphi
        ]
        xy = np.array([[r * math.cos(t), r * math.sin(t)] for t in angles for r in (rmin, rmax)])
        return np.array([*xy.min(axis=0), zlo]), np.array([*xy.max(axis=0), zhi])

    def sample_volume(self, rng: np.random.Generator, n: int) -> np.ndarray:
        rz = _sample_rz(rng, self.contour()[0], n)
        phi = self.sphi + rng.random(n) * self.dphi
        return np.column_stack([rz[:, 0] * np.cos(phi), rz[:, 0] * np.sin(phi), rz[:, 1]])


class _ContourShape(RevolvedShape):
    """Revolved solids whose faces are named after the canonical contour (``seg_<i>``).

    ``cuts`` (G4GenericPolycone) divide faces at points of the contour: edge ``i`` cut at k
    points gives the faces ``seg_<i>a``, ``seg_<i>b``, ... (from corner i on) and the group
    ``seg_<i>`` of them. ``labels`` name a group per face (``pplus``, ``passive``, ...).
    """

    def canonical(self) -> np.ndarray:
        raise NotImplementedError

    def _cut_points(self) -> np.ndarray:
        return np.asarray(getattr(self, "cuts", ()), float).reshape(-1, 2)

    def _split(self) -> tuple[np.ndarray, list[str], dict[str, tuple[str, ...]]]:
        """The contour with the cut points inserted, a name per edge, and the sub-faces of each
        divided face."""
        poly = self.canonical()
        names = _contour_names(poly)[0]
        cuts = self._cut_points()
        if not len(cuts):
            return poly, names, {}
        corners: list[np.ndarray] = []
        out: list[str] = []
        parts: dict[str, tuple[str, ...]] = {}
        used = np.zeros(len(cuts), dtype=bool)
        a, b, _ = _edges(poly)
        for i, name in enumerate(names):
            d = b[i] - a[i]
            length2 = float(d @ d)
            t = ((cuts - a[i]) @ d) / length2
            off = np.abs((cuts[:, 0] - a[i, 0]) * d[1] - (cuts[:, 1] - a[i, 1]) * d[0])
            on = (off <= 1e-9 * math.sqrt(length2)) & (t > 1e-9) & (t < 1 - 1e-9) & bool(name)
            used |= on
            ts = np.unique(np.round(t[on], 12))
            corners.append(a[i][None, :])
            if not len(ts):
                out.append(name)
                continue
            corners.append(a[i] + ts[:, None] * d)
            sub = tuple(f"{name}{chr(ord('a') + k)}" for k in range(len(ts) + 1))
            out += list(sub)
            parts[name] = sub
        if not used.all():
            r, z = cuts[int(np.flatnonzero(~used)[0])]
            raise ConfigError(
                f"{self.kind}: the face cut at (r, z) = ({r:g}, {z:g}) mm is not inside a face "
                "of the contour"
            )
        return np.concatenate(corners), out, parts

    def contour(self) -> tuple[np.ndarray, list[str]]:
        poly, names, _ = self._split()
        return poly, names

    def _groups(self, names: list[str]) -> dict[str, tuple[str, ...]]:
        _, faces, parts = self._split()
        groups = {
            g: tuple(f for base in members for f in parts.get(base, (base,)))
            for g, members in _contour_names(self.canonical())[1].items()
        }
        groups.update(parts)
        labels = tuple(getattr(self, "labels", ()))
        if labels:
            named = [f for f in faces if f]
            if len(labels) != len(named):
                raise ConfigError(
                    f"{self.kind}: {len(labels)} face labels for {len(named)} faces "
                    f"({', '.join(named)})"
                )
            for label, face in zip(labels, named, strict=True):
                if label:
                    groups[label] = (*groups.get(label, ()), face)
        return groups


def _as_tuple(values: ArrayLike) -> tuple[float, ...]:
    return tuple(float(v) for v in np.asarray(values, float).ravel())


def _planes_contour(
    z: tuple[float, ...], rmin: tuple[float, ...], rmax: tuple[float, ...], what: str
) -> np.ndarray:
    if not (len(z) == len(rmin) == len(rmax) >= 2):
        raise ConfigError(
            f"{what}: need z, rmin, rmax of one length >= 2, got {len(z)}, {len(rmin)}, {len(rmax)}"
        )
    if any(lo > hi for lo, hi in zip(rmin, rmax, strict=True)):
        raise ConfigError(f"{what}: rmin must be <= rmax at every z plane")
    r = [*rmin, *reversed(rmax)]
    zz = [*z, *reversed(z)]
    return _plane.canonical_contour(np.array(r), np.array(zz), what)


def _set_phi(obj: Any, what: str) -> None:
    s, d = normalise_phi(obj.sphi, obj.dphi, what)
    object.__setattr__(obj, "sphi", s)
    object.__setattr__(obj, "dphi", d)


@dataclass(frozen=True)
class G4Polycone(_ContourShape):
    """``G4Polycone(name, phiStart, phiTotal, numZPlanes, zPlane, rInner, rOuter)``."""

    sphi: float
    dphi: float
    z: tuple[float, ...]
    rmin: tuple[float, ...]
    rmax: tuple[float, ...]
    kind = "G4Polycone"

    def __post_init__(self) -> None:
        for name in ("z", "rmin", "rmax"):
            object.__setattr__(self, name, _as_tuple(getattr(self, name)))
        _set_phi(self, "G4Polycone")
        self.canonical()  # validates

    def canonical(self) -> np.ndarray:
        return _planes_contour(self.z, self.rmin, self.rmax, "G4Polycone")

    def trimmed(self, cuts: dict[str, float]) -> tuple[Shape, np.ndarray] | None:
        """A G4GenericPolycone of the contour with the faces ``cuts`` names moved inward
        (:meth:`cut_contour`); None for a phi cut."""
        return _cut_polycone(self, cuts)


@dataclass(frozen=True)
class G4GenericPolycone(_ContourShape):
    """``G4GenericPolycone(name, phiStart, phiTotal, numRZ, r, z)``: corners of the contour."""

    sphi: float
    dphi: float
    r: tuple[float, ...]
    z: tuple[float, ...]
    # (r, z) points, flattened, where a face of the contour is divided (see _ContourShape)
    cuts: tuple[float, ...] = ()
    labels: tuple[str, ...] = ()  # a group name per face (after the cuts), "" for none
    kind = "G4GenericPolycone"

    def __post_init__(self) -> None:
        object.__setattr__(self, "r", _as_tuple(self.r))
        object.__setattr__(self, "z", _as_tuple(self.z))
        object.__setattr__(self, "cuts", _as_tuple(self.cuts))
        object.__setattr__(self, "labels", tuple(str(x) for x in self.labels))
        if len(self.cuts) % 2:
            raise ConfigError("G4GenericPolycone: cuts are (r, z) pairs")
        if len(self.r) != len(self.z):
            raise ConfigError(
                f"G4GenericPolycone: {len(self.r)} r values but {len(self.z)} z values"
            )
        _set_phi(self, "G4GenericPolycone")
        self.canonical()

    def canonical(self) -> np.ndarray:
        return _plane.canonical_contour(np.array(self.r), np.array(self.z), "G4GenericPolycone")

    def trimmed(self, cuts: dict[str, float]) -> tuple[Shape, np.ndarray] | None:
        """A G4GenericPolycone of the contour with the faces ``cuts`` names moved inward
        (:meth:`cut_contour`); None for a phi cut."""
        return _cut_polycone(self, cuts)


class _PolyhedraBase(_ContourShape):
    """Polyhedra: the contour is in apothems (axis-to-side distances)."""

    nsides: int

    @property
    def _half_angle(self) -> float:
        return 0.5 * self.dphi / self.nsides

    def _build(self):
        poly, names = self.contour()
        a, b, normal = _edges(poly)
        alpha = 2 * self._half_angle
        tan = math.tan(self._half_angle)
        k = np.arange(self.nsides)
        centre = self.sphi + (k + 0.5) * alpha
        c = np.column_stack([np.cos(centre), np.sin(centre), np.zeros(self.nsides)])
        t = np.column_stack([-np.sin(centre), np.cos(centre), np.zeros(self.nsides)])
        ez = np.array([0.0, 0.0, 1.0])
        faces: list[str] = []
        patches: list[Patch] = []
        for i, name in enumerate(names):
            if not name:
                continue
            faces.append(name)
            (a1, z1), (a2, z2) = a[i], b[i]
            p1m, p1p = a1 * c - a1 * tan * t + z1 * ez, a1 * c + a1 * tan * t + z1 * ez
            p2m, p2p = a2 * c - a2 * tan * t + z2 * ez, a2 * c + a2 * tan * t + z2 * ez
            tris = np.concatenate([np.stack([p1m, p1p, p2p], 1), np.stack([p1m, p2p, p2m], 1)])
            nrm = normal[i, 0] * c + normal[i, 1] * ez
            patches.append(PlaneTriangles(len(faces) - 1, tris, np.concatenate([nrm, nrm])))
        groups = self._groups(names)
        if not self.full_phi:
            corner = poly * [1.0 / math.cos(self._half_angle), 1.0]
            tris2 = _plane.triangulate(corner)
            for name, phi, sign in (
                ("phi_start", self.sphi, 1.0),
                ("phi_end", self.sphi + self.dphi, -1.0),
            ):
                faces.append(name)
                cc, ss = math.cos(phi), math.sin(phi)
                t3 = np.stack([tris2[..., 0] * cc, tris2[..., 0] * ss, tris2[..., 1]], axis=-1)
                patches.append(PlaneTriangles(len(faces) - 1, t3, sign * np.array([ss, -cc, 0.0])))
        return tuple(faces), groups, patches

    def moved(self, cuts: dict[str, float]) -> tuple[Shape, np.ndarray] | None:
        """A G4GenericPolyhedra of the apothem contour with the faces ``cuts`` names moved
        inward (< 0: outward; :meth:`cut_contour`: moving an edge of the apothem contour moves
        each of the face's planes along its normal by the same depth); None for a phi cut."""
        cut = self.cut_contour(cuts)
        if cut is None:
            return None
        poly = cut[0]
        corner = poly[:, 0] / math.cos(self._half_angle)
        r, z = _as_tuple(corner), _as_tuple(poly[:, 1])
        return G4GenericPolyhedra(self.sphi, self.dphi, self.nsides, r, z), np.zeros(3)

    def _side_coordinates(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Apothem coordinate (projection on the centre direction of the point's side) and the
        side index of points."""
        alpha = 2 * self._half_angle
        delta = np.mod(np.arctan2(p[:, 1], p[:, 0]) - self.sphi, TWO_PI)
        k = np.clip(np.floor(delta / alpha), 0, self.nsides - 1)
        if not self.full_phi:  # outside the wedge: the nearer end side
            k = np.where(
                delta > self.dphi,
                np.where(delta - self.dphi < TWO_PI - delta, self.nsides - 1, 0),
                k,
            )
        centre = self.sphi + (k + 0.5) * alpha
        return p[:, 0] * np.cos(centre) + p[:, 1] * np.sin(centre), k

    def signed_distance(self, points: ArrayLike) -> np.ndarray:
        p = as_points(points)
        poly, _ = self.contour()
        apothem, _k = self._side_coordinates(p)
        rz = np.column_stack([apothem, p[:, 2]])
        s = _plane.signed_distance(rz, poly, self._surface_edges(poly))
        if not self.full_phi:
            s = np.maximum(s, _wedge_distance(p, self.sphi, self.dphi))
        return s

    @property
    def volume(self) -> float:
        return (
            2 * self.nsides * math.tan(self._half_angle) * _plane.first_moment_r(self.contour()[0])
        )

    def bounding_box(self) -> tuple[np.ndarray, np.ndarray]:
        corners = np.concatenate(
            [p.triangles.reshape(-1, 3) for p in self.patches if isinstance(p, PlaneTriangles)]
        )
        return corners.min(axis=0), corners.max(axis=0)

    def sample_volume(self, rng: np.random.Generator, n: int) -> np.ndarray:
        rz = _sample_rz(rng, self.contour()[0], n)  # density proportional to the side width
        k = rng.integers(0, self.nsides, n)
        centre = self.sphi + (k + 0.5) * 2 * self._half_angle
        s = (2 * rng.random(n) - 1) * rz[:, 0] * math.tan(self._half_angle)
        x = rz[:, 0] * np.cos(centre) - s * np.sin(centre)
        y = rz[:, 0] * np.sin(centre) + s * np.cos(centre)
        return np.column_stack([x, y, rz[:, 1]])


def _check_sides(obj: Any, what: str) -> None:
    if int(obj.nsides) != obj.nsides or obj.nsides < 1:
        raise ConfigError(f"{what}: nsides must be a whole number >= 1, got {obj.nsides!r}")
    object.__setattr__(obj, "nsides", int(obj.nsides))


@dataclass(frozen=True)
class G4Polyhedra(_PolyhedraBase):
    """``G4Polyhedra(name, phiStart, phiTotal, numSide, numZPlanes, zPlane, rInner, rOuter)``:
    radii are distances from the axis to the sides (Geant4's and GDML's convention)."""

    sphi: float
    dphi: float
    nsides: int
    z: tuple[float, ...]
    rmin: tuple[float, ...]
    rmax: tuple[float, ...]
    kind = "G4Polyhedra"

    def __post_init__(self) -> None:
        for name in ("z", "rmin", "rmax"):
            object.__setattr__(self, name, _as_tuple(getattr(self, name)))
        _check_sides(self, "G4Polyhedra")
        _set_phi(self, "G4Polyhedra")
        self.canonical()

    def canonical(self) -> np.ndarray:
        return _planes_contour(self.z, self.rmin, self.rmax, "G4Polyhedra")


@dataclass(frozen=True)
class G4GenericPolyhedra(_PolyhedraBase):
    """``G4Polyhedra(name, phiStart, phiTotal, numSide, numRZ, r, z)``: contour corners with
    corner radii (as ``GetCorner`` returns them)."""

    sphi: float
    dphi: float
    nsides: int
    r: tuple[float, ...]
    z: tuple[float, ...]
    kind = "G4GenericPolyhedra"

    def __post_init__(self) -> None:
        object.__setattr__(self, "r", _as_tuple(self.r))
        object.__setattr__(self, "z", _as_tuple(self.z))
        if len(self.r) != len(self.z):
            raise ConfigError(f"G4Polyhedra: {len(self.r)} r values but {len(self.z)} z values")
        _check_sides(self, "G4Polyhedra")
        _set_phi(self, "G4Polyhedra")
        self.canonical()

    def canonical(self) -> np.ndarray:
        apothem = np.array(self.r) * math.cos(0.5 * self.dphi / self.nsides)
        return _plane.canonical_contour(apothem, np.array(self.z), "G4Polyhedra")


def _cut_polycone(
    shape: G4Polycone | G4GenericPolycone, cuts: dict[str, float]
) -> tuple[Shape, np.ndarray] | None:
    cut = shape.cut_contour(cuts)
    if cut is None:
        return None
    poly = cut[0]
    r, z = _as_tuple(poly[:, 0]), _as_tuple(poly[:, 1])
    return G4GenericPolycone(shape.sphi, shape.dphi, r, z), np.zeros(3)
