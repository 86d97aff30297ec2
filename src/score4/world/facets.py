"""Rough layers on flat faces of any outline (numpy, no Geant4): the faces of a G4Trd or
G4Trap, a G4Polyhedra phi cut, each side of a G4Polyhedra face, each plane of a tessellated or
extruded mesh; any face of a shape made of flat triangles.

Such a face is grouped by plane (:func:`plane_groups`); each plane is a polygon (possibly with
holes or in several pieces), the union of its triangles, and gets a layer of its own. The patch
grid covers the polygon's bounding rectangle in the face's frame (x along the face's first
edge, as :func:`score4.shapes.base._plane_face` sets it), whole cells centred on the rectangle;
a cell holds a patch when its rectangle lies wholly in the polygon (:func:`cells_inside`), the
other cells stay flat (``rough_shares`` reports the rough share). The layer's envelope is the
polygon extruded along the normal by the layer's thickness (:func:`prism_mesh`: the face's own
triangles at both ends and a wall on each boundary edge), so layers on neighbouring faces of a
convex solid never meet, whatever the angle between the faces; at a concave edge they would,
and the clearance check refuses them.
"""

from __future__ import annotations

import numpy as np

from score4.errors import ConfigError
from score4.shapes import Shape
from score4.shapes.base import PlaneTriangles, _plane_face
from score4.shapes.faces import PlaneFace
from score4.shapes.mesh_shape import plane_index
from score4.surface.triangle_mesh import TriangleMesh


def face_triangles(shape: Shape, name: str) -> np.ndarray:
    """The flat triangles (k, 3, 3) of face ``name`` of ``shape``, in the shape's frame."""
    k = shape.faces.index(name)
    parts = [p.triangles for p in shape.patches if p.face == k and isinstance(p, PlaneTriangles)]
    return np.concatenate(parts) if parts else np.zeros((0, 3, 3))


def boundary_edges(tri2d: np.ndarray) -> np.ndarray:
    """Edges (m, 2, 2) of a set of 2D triangles that belong to one triangle only (the outline of
    their union, holes included), each in its triangle's winding."""
    k = len(tri2d)
    edges = np.stack([tri2d, np.roll(tri2d, -1, axis=1)], axis=2).reshape(3 * k, 2, 2)
    scale = max(float(np.abs(tri2d).max()), 1.0) if k else 1.0
    key = np.round(edges / (1e-9 * scale)).astype(np.int64).reshape(3 * k, 4)
    fwd = [tuple(r) for r in key]
    back = {tuple(np.concatenate([r[2:], r[:2]])) for r in key}
    fwd_count: dict[tuple, int] = {}
    for r in fwd:
        fwd_count[r] = fwd_count.get(r, 0) + 1
    keep = [i for i, r in enumerate(fwd) if r not in back and fwd_count[r] == 1]
    return edges[keep]


def point_in_triangles(points: np.ndarray, tri2d: np.ndarray, tol: float) -> np.ndarray:
    """True for 2D points in (or within ``tol`` of) at least one of the triangles."""
    out = np.zeros(len(points), dtype=bool)
    for t in tri2d:
        a, b, c = t
        area = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
        if abs(area) <= 0:
            continue
        sign = 1.0 if area > 0 else -1.0
        inside = np.ones(len(points), dtype=bool)
        for u, v in ((a, b), (b, c), (c, a)):
            d = v - u
            cross = d[0] * (points[:, 1] - u[1]) - d[1] * (points[:, 0] - u[0])
            inside &= sign * cross >= -tol * float(np.hypot(*d))
        out |= inside
    return out


def cells_inside(
    tri2d: np.ndarray, centres: np.ndarray, size: tuple[float, float], tol: float
) -> np.ndarray:
    """True for the cells (rectangles of ``size`` around ``centres``, (..., 2)) that lie wholly
    in the union of the triangles: their four corners in it and no corner of its outline
    strictly inside the rectangle (an outline edge through the rectangle with no corner in it
    would leave a corner of the rectangle outside)."""
    px, py = size
    c = centres.reshape(-1, 2)
    inside = np.ones(len(c), dtype=bool)
    for sx in (-0.5, 0.5):
        for sy in (-0.5, 0.5):
            inside &= point_in_triangles(c + np.array([sx * px, sy * py]), tri2d, tol)
    edges = boundary_edges(tri2d)
    if len(edges):
        corners = np.unique(edges[:, 0], axis=0)
        rows = np.flatnonzero(inside)
        for v in corners:
            d = np.abs(v - c[rows])
            strictly = (d[:, 0] < px / 2 - tol) & (d[:, 1] < py / 2 - tol)
            inside[rows[strictly]] = False
    return inside.reshape(centres.shape[:-1])


def prism_mesh(tri2d: np.ndarray, thickness: float) -> TriangleMesh:
    """The closed prism of the 2D triangles (wound counter-clockwise) between z = -t/2 and
    z = t/2: the triangles at both ends and two triangles per boundary edge."""
    half = thickness / 2
    top = np.concatenate([tri2d, np.full((*tri2d.shape[:2], 1), half)], axis=2)
    bottom = np.concatenate([tri2d[:, ::-1], np.full((*tri2d.shape[:2], 1), -half)], axis=2)
    edges = boundary_edges(tri2d)
    a0 = np.column_stack([edges[:, 0], np.full(len(edges), -half)])
    b0 = np.column_stack([edges[:, 1], np.full(len(edges), -half)])
    up = np.array([0.0, 0.0, thickness])
    a1, b1 = a0 + up, b0 + up
    walls = np.concatenate([np.stack([a0, b0, b1], 1), np.stack([a0, b1, a1], 1)])
    tris = np.concatenate([top, bottom, walls])
    vertices, faces = np.unique(tris.reshape(-1, 3), axis=0, return_inverse=True)
    return TriangleMesh(vertices, faces.reshape(-1, 3))


def polygon_area(tri2d: np.ndarray) -> float:
    e1, e2 = tri2d[:, 1] - tri2d[:, 0], tri2d[:, 2] - tri2d[:, 0]
    return float(0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]).sum())


def ccw(tri2d: np.ndarray) -> np.ndarray:
    """The triangles wound counter-clockwise."""
    e1, e2 = tri2d[:, 1] - tri2d[:, 0], tri2d[:, 2] - tri2d[:, 0]
    cw = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0] < 0
    out = tri2d.copy()
    out[cw] = out[cw][:, ::-1]
    return out


def check_one_plane(tri_local: np.ndarray, where: str, face: str, target: str) -> None:
    """ConfigError when the face's triangles are not in one plane (face-local z = 0)."""
    if len(tri_local) == 0:
        raise ConfigError(f"{where}: face {face} of {target!r} has no flat facets")
    off = float(np.abs(tri_local[..., 2]).max())
    if off > 1e-9 * max(float(np.abs(tri_local).max()), 1.0):
        raise ConfigError(
            f"{where}: face {face} of {target!r} is not one plane (its facets leave the plane "
            f"of the first by {off:.3g} mm); rough faces are flat facet groups"
        )


def plane_groups(triangles: np.ndarray) -> list[np.ndarray]:
    """The triangles (k, 3, 3) grouped by their plane (normal and offset), in order of first
    appearance, degenerate ones left out (:func:`score4.shapes.mesh_shape.plane_index`)."""
    plane = plane_index(triangles)
    return [triangles[plane == g] for g in range(int(plane.max(initial=-1)) + 1)]


def plane_face(name: str, triangles: np.ndarray) -> PlaneFace:
    """The flat face of coplanar triangles (the frame of :func:`score4.shapes.base._plane_face`)."""
    n = np.cross(triangles[0, 1] - triangles[0, 0], triangles[0, 2] - triangles[0, 0])
    n = n / np.linalg.norm(n)
    return _plane_face(name, [PlaneTriangles(0, triangles, n)])


def solid_triangles(shape: Shape) -> np.ndarray | None:
    """The closed surface (k, 3, 3) of a solid made of flat facets only (a G4Trd, G4Trap,
    G4Polyhedra, tessellated or extruded solid), in its own frame; None for any other."""
    if not shape.patches or not all(isinstance(p, PlaneTriangles) for p in shape.patches):
        return None
    return np.concatenate([p.triangles for p in shape.patches if isinstance(p, PlaneTriangles)])


def is_convex(triangles: np.ndarray) -> bool:
    """True when every corner lies on the inner side of every facet's plane (to 1e-9 of the
    solid's size): a convex solid."""
    n = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    norm = np.linalg.norm(n, axis=1)
    keep = norm > 0
    n = n[keep] / norm[keep, None]
    offset = np.einsum("ij,ij->i", n, triangles[keep, 0])
    corners = np.unique(triangles.reshape(-1, 3), axis=0)
    tol = 1e-9 * max(float(np.abs(triangles).max()), 1.0)
    return bool((corners @ n.T - offset[None, :] <= tol).all())


def clip_convex(triangles: np.ndarray, normal: np.ndarray, offset: float) -> np.ndarray:
    """The closed surface of a convex solid (its triangles, wound outward) cut by the plane
    ``normal . x = offset``: the part with ``normal . x <= offset``, the cut closed by a cap
    (the convex polygon of the cut, fanned from its centre, facing ``normal``)."""
    n = np.asarray(normal, float) / np.linalg.norm(normal)
    scale = max(float(np.abs(triangles).max()), 1.0)
    tol = 1e-12 * scale
    out: list[np.ndarray] = []
    on_plane: list[np.ndarray] = []
    for tri in triangles:
        s = tri @ n - offset
        poly = []
        for k in range(3):  # Sutherland-Hodgman against one plane
            a, b, sa, sb = tri[k], tri[(k + 1) % 3], s[k], s[(k + 1) % 3]
            if sa <= tol:
                poly.append(a)
            if (sa < -tol and sb > tol) or (sa > tol and sb < -tol):
                poly.append(a + (b - a) * (sa / (sa - sb)))
        on_plane += [p for p in poly if abs(float(p @ n) - offset) <= tol]
        out += [np.array([poly[0], poly[k], poly[k + 1]]) for k in range(1, len(poly) - 1)]
    out += list(_cap(np.array(on_plane).reshape(-1, 3), n, tol))
    tris = np.array(out).reshape(-1, 3, 3)
    area = np.linalg.norm(np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]), axis=1)
    return tris[area > 1e-12 * scale * scale]


def _cap(points: np.ndarray, n: np.ndarray, tol: float) -> np.ndarray:
    """Triangles (k, 3, 3) fanning the convex polygon of ``points`` (in one plane of normal
    ``n``) from its centre, wound counter-clockwise about ``n``."""
    if len(points) < 3:
        return np.zeros((0, 3, 3))
    pts = np.unique(np.round(points / tol) * tol, axis=0)
    if len(pts) < 3:
        return np.zeros((0, 3, 3))
    centre = pts.mean(axis=0)
    u = pts[0] - centre
    u -= (u @ n) * n
    u /= np.linalg.norm(u)
    d = pts - centre
    ring = pts[np.argsort(np.arctan2(d @ np.cross(n, u), d @ u))]
    return np.array([[centre, ring[k], ring[(k + 1) % len(ring)]] for k in range(len(ring))])


def section(triangles: np.ndarray, normal: np.ndarray, offset: float) -> np.ndarray:
    """The cut of a convex solid (its triangles) by the plane ``normal . x = offset``: the cap
    of :func:`clip_convex`, triangles (k, 3, 3) facing ``normal`` (none when the plane misses)."""
    n = np.asarray(normal, float) / np.linalg.norm(normal)
    tris = clip_convex(triangles, n, offset)
    tol = 1e-9 * max(float(np.abs(triangles).max()), 1.0)
    flat = np.abs(tris @ n - offset).max(axis=1) <= tol
    return tris[flat]


def clip_to_convex(tri2d: np.ndarray, convex: np.ndarray) -> np.ndarray:
    """The 2D triangles ``tri2d`` (k, 3, 2) cut to the convex polygon that the triangles
    ``convex`` cover (wound counter-clockwise): each clipped by the half-plane left of every
    outline edge, the pieces fanned into triangles."""
    edges = boundary_edges(ccw(convex))
    out = []
    for tri in tri2d:
        poly = list(tri)
        for a, b in edges:
            d = b - a
            s = [d[0] * (q[1] - a[1]) - d[1] * (q[0] - a[0]) for q in poly]
            cut = []
            for k in range(len(poly)):
                p0, p1, s0, s1 = poly[k], poly[(k + 1) % len(poly)], s[k], s[(k + 1) % len(poly)]
                if s0 >= 0:
                    cut.append(p0)
                if (s0 < 0 < s1) or (s1 < 0 < s0):
                    cut.append(p0 + (p1 - p0) * (s0 / (s0 - s1)))
            poly = cut
            if len(poly) < 3:
                break
        out += [[poly[0], poly[k], poly[k + 1]] for k in range(1, len(poly) - 1)]
    return np.array(out, float).reshape(-1, 3, 2)


def mesh_of(triangles: np.ndarray) -> TriangleMesh:
    """A :class:`TriangleMesh` of triangles (k, 3, 3), corners merged."""
    vertices, faces = np.unique(triangles.reshape(-1, 3), axis=0, return_inverse=True)
    return TriangleMesh(vertices, faces.reshape(-1, 3))
