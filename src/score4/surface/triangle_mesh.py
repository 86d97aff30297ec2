"""Triangle meshes of rough surfaces: the exact top surface and the closed body around it.

One :class:`TriangleMesh` is shared by metrology, vertex sampling and the Geant4 solid, so the
three cannot disagree. Conventions:

* lengths in mm; faces are wound counter-clockwise seen from outside the material, so the
  right-hand normal points *out of the material* (+z side for a top surface);
* ``top`` marks the faces of the rough (contaminated) surface; walls and bottom of a closed
  body are not ``top``;
* everything is vectorised: meshes of 10^6 spikes (4·10^6 faces) are built in seconds.

Checks (:func:`is_watertight`, :func:`signed_volume`, :func:`degenerate_faces`) and writers
(:func:`write_stl`, :func:`write_ply`, both atomic) are plain functions of a mesh.
"""

from __future__ import annotations

import numbers
import os
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from score4.common.units import length_text

from ..errors import ConfigError
from ..files import atomic_output
from .heightmap import HeightMap

#: Default relative tolerance of :func:`degenerate_faces`: a face is degenerate when its area is
#: below this fraction of the square of its longest edge (for a triangle, area/longest² is half
#: the sine of an angle times an edge ratio, so 1e-9 only flags true slivers and zero areas).
DEGENERATE_REL_TOL = 1e-9


def _readonly(a: np.ndarray) -> np.ndarray:
    a.setflags(write=False)
    return a


def _optional_ids(ids: np.ndarray | None, n_faces: int, name: str) -> np.ndarray | None:
    if ids is None:
        return None
    ids = np.array(ids, dtype=np.int64)
    if ids.shape != (n_faces,):
        raise ConfigError(
            f"{name}: need one id per face, shape ({n_faces},), got shape {ids.shape}"
        )
    return _readonly(ids)


@dataclass(frozen=True, eq=False)
class TriangleMesh:
    """A triangle mesh with per-face flags; arrays are copied and made read-only.

    Parameters
    ----------
    vertices
        (n, 3) float vertex coordinates in mm.
    faces
        (m, 3) int vertex indices, counter-clockwise seen from outside the material.
    top
        (m,) bool: True for faces of the rough top surface. Default: all True.
    patch
        Optional (m,) int id of the patch (tile) each face belongs to.
    facet
        Optional (m,) int id of the source element of each face within its patch (spike index
        ``j * nx + i`` for spike grids, cell index ``j * (nx - 1) + i`` for height maps);
        -1 where there is none (walls, bottom).
    """

    vertices: np.ndarray
    faces: np.ndarray
    top: np.ndarray | None = None
    patch: np.ndarray | None = None
    facet: np.ndarray | None = None

    def __post_init__(self) -> None:
        v = np.array(self.vertices, dtype=float)
        f = np.array(self.faces, dtype=np.int64)
        if v.ndim != 2 or v.shape[1] != 3:
            raise ConfigError(f"vertices: need shape (n, 3), got {v.shape}")
        if f.ndim != 2 or f.shape[1] != 3:
            raise ConfigError(f"faces: need shape (m, 3), got {f.shape}")
        if not np.isfinite(v).all():
            raise ConfigError("vertices: every coordinate must be finite (found NaN or inf)")
        if f.size and (f.min() < 0 or f.max() >= len(v)):
            raise ConfigError(
                f"faces: indices must lie in [0, {len(v) - 1}], got [{f.min()}, {f.max()}]"
            )
        top = np.ones(len(f), dtype=bool) if self.top is None else np.array(self.top, dtype=bool)
        if top.shape != (len(f),):
            raise ConfigError(
                f"top: need one flag per face, shape ({len(f)},), got shape {top.shape}"
            )
        object.__setattr__(self, "vertices", _readonly(v))
        object.__setattr__(self, "faces", _readonly(f))
        object.__setattr__(self, "top", _readonly(top))
        object.__setattr__(self, "patch", _optional_ids(self.patch, len(f), "patch"))
        object.__setattr__(self, "facet", _optional_ids(self.facet, len(f), "facet"))

    @property
    def n_vertices(self) -> int:
        return len(self.vertices)

    @property
    def n_faces(self) -> int:
        return len(self.faces)

    @cached_property
    def _area_vectors(self) -> np.ndarray:
        # Half the cross product: direction = right-hand normal, length = area.
        v, f = self.vertices, self.faces
        origin = v[f[:, 0]]
        e1, e2 = v[f[:, 1]] - origin, v[f[:, 2]] - origin
        out = origin  # reuse the buffer: explicit components avoid np.cross's temporaries
        out[:, 0] = e1[:, 1] * e2[:, 2] - e1[:, 2] * e2[:, 1]
        out[:, 1] = e1[:, 2] * e2[:, 0] - e1[:, 0] * e2[:, 2]
        out[:, 2] = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
        out *= 0.5
        return _readonly(out)

    @cached_property
    def areas(self) -> np.ndarray:
        """(m,) true face areas in mm²."""
        return _readonly(np.linalg.norm(self._area_vectors, axis=1))

    @cached_property
    def normals(self) -> np.ndarray:
        """(m, 3) unit normals pointing out of the material; zero rows for zero-area faces."""
        a = self.areas[:, None]
        out = np.divide(self._area_vectors, a, out=np.zeros_like(self._area_vectors), where=a > 0)
        return _readonly(out)

    @cached_property
    def projected_areas(self) -> np.ndarray:
        """(m,) signed areas projected on the xy plane, mm²: > 0 when the normal points up."""
        return _readonly(np.ascontiguousarray(self._area_vectors[:, 2]))

    @property
    def total_area(self) -> float:
        """Sum of all face areas in mm²."""
        return float(self.areas.sum())

    @property
    def top_area(self) -> float:
        """True area of the top surface in mm² (the area that carries contamination)."""
        return float(self.areas[self.top].sum())

    @property
    def bounds(self) -> np.ndarray:
        """(2, 3) array: minimum and maximum corner of the bounding box, mm."""
        return np.stack([self.vertices.min(axis=0), self.vertices.max(axis=0)])


# --- construction -------------------------------------------------------------------------


def from_heightmap(hm: HeightMap) -> TriangleMesh:
    """Triangulate a height map: one vertex per sample, two triangles per grid cell.

    Every cell from (i, j) to (i+1, j+1) is split along the diagonal from (i, j) to (i+1, j+1). All
    faces are ``top``; ``facet`` is the cell index ``j * (nx - 1) + i``.

    Raises
    ------
    ConfigError
        If the map has missing (NaN) points: fill or crop them first.
    """
    z = hm.heights
    if np.isnan(z).any():
        raise ConfigError(
            f"heights: {int(np.isnan(z).sum())} missing (NaN) points; a mesh needs every point "
            "(fill or crop the missing points first)"
        )
    ny, nx = z.shape
    xx, yy = np.meshgrid(hm.x, hm.y)
    vertices = np.column_stack([xx.ravel(), yy.ravel(), z.ravel()])
    idx = np.arange(nx * ny).reshape(ny, nx)
    a, b = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel()  # (i, j), (i+1, j)
    c, d = idx[1:, 1:].ravel(), idx[1:, :-1].ravel()  # (i+1, j+1), (i, j+1)
    # Counter-clockwise seen from +z, so normals point up (out of the material below).
    faces = np.stack([np.column_stack([a, b, c]), np.column_stack([a, c, d])], axis=1).reshape(
        -1, 3
    )
    cell = np.repeat(np.arange(len(a)), 2)
    return TriangleMesh(vertices, faces, facet=cell)


def _undirected_edges(faces: np.ndarray, n_vertices: int) -> tuple[np.ndarray, np.ndarray]:
    """Directed half-edges (3m, 2) of the faces and their undirected int64 keys (3m,)."""
    he = faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    key = np.minimum(he[:, 0], he[:, 1]) * np.int64(n_vertices) + np.maximum(he[:, 0], he[:, 1])
    return he, key


def boundary_half_edges(mesh: TriangleMesh) -> np.ndarray:
    """(k, 2) directed half-edges of the faces that no other face shares."""
    he, key = _undirected_edges(mesh.faces, mesh.n_vertices)
    order = np.argsort(key)
    k = key[order]
    if (k[2:] == k[:-2]).any():
        raise ConfigError("top_mesh: some edges are shared by more than two faces (not a surface)")
    differs = k[1:] != k[:-1]
    single = np.concatenate([[True], differs]) & np.concatenate([differs, [True]])
    return he[order[single]]


def _check_star_shaped(edges_xy: np.ndarray, centre: np.ndarray) -> None:
    """The bottom fan is valid only if the boundary winds once anticlockwise round ``centre``."""
    a, b = edges_xy[:, 0] - centre, edges_xy[:, 1] - centre
    cross = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    dot = (a * b).sum(axis=1)
    scale = np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1)
    turns = np.arctan2(cross, dot).sum() / (2 * np.pi)
    if (cross <= DEGENERATE_REL_TOL * scale).any() or abs(turns - 1.0) > 1e-6:
        raise ConfigError(
            "top_mesh: its boundary must be one counter-clockwise loop around the centre of its "
            "bounding box (e.g. a rectangle); holes, several pieces or concave outlines are not "
            "supported"
        )


def closed_body(top_mesh: TriangleMesh, thickness: float) -> TriangleMesh:
    """Close a rough top surface into a watertight body.

    The body is bounded by the top mesh, vertical walls under each boundary edge of the top
    mesh, and a flat bottom at ``z = -thickness`` (the base plane of the surface is z = 0, so
    ``thickness`` is the depth of material under the base plane). The walls reuse the top
    boundary vertices exactly (no T-junctions); the bottom is a fan from a centre vertex over
    the bottom copies of the boundary vertices, so no bottom face is a zero-area sliver even
    when many boundary vertices are collinear.

    Parameters
    ----------
    top_mesh
        A height-field surface (no overhangs) whose outline is one loop, star-shaped around the
        centre of its bounding box (any rectangle is).
    thickness
        Depth of the bottom plane below z = 0, in mm; every top vertex must lie above it.

    Returns
    -------
    TriangleMesh
        Top faces first (same order, ``top`` True, ids kept), then walls, then bottom (``top``
        False, ids -1).
    """
    is_number = not isinstance(thickness, bool) and isinstance(thickness, numbers.Real)
    if not (is_number and np.isfinite(thickness) and thickness > 0):
        raise ConfigError(f"thickness: must be a positive length, got {thickness!r}")
    zmin = float(top_mesh.vertices[:, 2].min())
    if zmin <= -thickness:
        raise ConfigError(
            f"thickness: the bottom plane z = -{length_text(thickness)} must lie below the lowest "
            "top vertex "
            f"(z = {length_text(zmin)}); use thickness > {length_text(-zmin)}"
        )
    boundary = boundary_half_edges(top_mesh)
    if len(boundary) < 3:
        raise ConfigError("top_mesh: has no boundary (already closed?)")
    v = top_mesh.vertices
    lo, hi = v[:, :2].min(axis=0), v[:, :2].max(axis=0)
    centre = 0.5 * (lo + hi)
    _check_star_shaped(v[boundary][:, :, :2], centre)

    ring, local = np.unique(boundary, return_inverse=True)
    local = local.reshape(-1, 2)
    n_top = top_mesh.n_vertices
    bottom = np.column_stack([v[ring, :2], np.full(len(ring), -float(thickness))])
    vertices = np.vstack([v, bottom, [[centre[0], centre[1], -float(thickness)]]])
    a, b = boundary[:, 0], boundary[:, 1]
    a_low, b_low = n_top + local[:, 0], n_top + local[:, 1]
    c_low = np.full(len(a), n_top + len(ring))
    # Reverse of each boundary half-edge, so wall and top share the edge with opposite orientation.
    walls = np.concatenate([np.column_stack([b, a, a_low]), np.column_stack([b, a_low, b_low])])
    floor = np.column_stack([b_low, a_low, c_low])
    faces = np.vstack([top_mesh.faces, walls, floor])
    n_extra = len(walls) + len(floor)
    return TriangleMesh(
        vertices,
        faces,
        top=np.concatenate([top_mesh.top, np.zeros(n_extra, bool)]),
        patch=_extend_ids(top_mesh.patch, n_extra),
        facet=_extend_ids(top_mesh.facet, n_extra),
    )


def _extend_ids(ids: np.ndarray | None, n_extra: int) -> np.ndarray | None:
    return None if ids is None else np.concatenate([ids, np.full(n_extra, -1, dtype=np.int64)])


# --- checks -------------------------------------------------------------------------------


def is_watertight(mesh: TriangleMesh) -> bool:
    """True if every edge is shared by exactly two faces that traverse it in opposite directions.

    This is the condition for a closed, consistently oriented (orientable) surface; it does not
    test for self-intersections.
    """
    he, key = _undirected_edges(mesh.faces, mesh.n_vertices)
    directed = np.sort(he[:, 0] * np.int64(mesh.n_vertices) + he[:, 1])
    if (directed[1:] == directed[:-1]).any():
        return False  # an edge traversed twice in the same direction: flipped or duplicated face
    # Sorted undirected keys must come in pairs: equal within a pair, different across pairs.
    key = np.sort(key)
    if len(key) % 2:
        return False
    return bool((key[0::2] == key[1::2]).all() and (key[2::2] != key[1:-1:2]).all())


def signed_volume(mesh: TriangleMesh) -> float:
    """Volume enclosed by a closed mesh, mm³: positive when normals point outwards.

    Sum of the signed tetrahedra (origin, face); vertices are shifted to their centroid first
    to avoid cancellation far from the origin.
    """
    p = mesh.vertices[mesh.faces] - mesh.vertices.mean(axis=0)
    return float(np.einsum("ij,ij->i", p[:, 0], np.cross(p[:, 1], p[:, 2])).sum() / 6.0)


def degenerate_faces(mesh: TriangleMesh, rel_tol: float = DEGENERATE_REL_TOL) -> np.ndarray:
    """Indices of faces whose area is at most ``rel_tol`` times their longest edge squared.

    Catches zero-area faces, repeated vertices and needle/sliver triangles (which Geant4's
    ``G4TriangularFacet`` rejects with a warning) independently of the mesh's length scale.
    """
    p = mesh.vertices[mesh.faces]
    edges = p[:, [1, 2, 0]] - p
    longest2 = (edges**2).sum(axis=2).max(axis=1)
    return np.flatnonzero(mesh.areas <= rel_tol * longest2)


# --- export -------------------------------------------------------------------------------


#: Geant4's kCarTolerance (mm), for :func:`intersect_tolerance`.
KCAR_TOLERANCE = 1e-9


def intersect_tolerance(tri: np.ndarray) -> np.ndarray:
    """For each triangle ``tri`` (n, 3, 3), in the vertex order Geant4 gets: the largest distance
    (mm) beyond one of its edges at which ``G4TriangularFacet::Intersect`` (Geant4 11) still
    counts a ray's crossing as a hit, so that ``G4TessellatedSolid::Inside`` can class a point
    that far outside the solid as inside. Its tests of the barycentric coordinates carry
    ``kCarTolerance`` times sums of products of the edge vectors (``a = |E1|^2``, ``b = E1.E2``,
    ``c = |E2|^2`` and the point's ``d``, ``e``, largest at the edge's far corner); over the
    facet's doubled area and the edge's length these are distances: about ``2 kCar / w`` beyond
    an edge at the corner opposite the longest edge (``w`` the smaller altitude there), but
    ``4 kCar L / w^2`` beyond a short edge ``w`` opposite ``P0`` in a facet of length ``L``
    (kCarTolerance is 1e-9 in mm units; Geant4's tolerances are not scaled as lengths)."""
    p0, p1, p2 = tri[:, 0], tri[:, 1], tri[:, 2]
    e1, e2 = p1 - p0, p2 - p0
    a, c = np.einsum("nc,nc->n", e1, e1), np.einsum("nc,nc->n", e2, e2)
    b = np.abs(np.einsum("nc,nc->n", e1, e2))
    two_area = np.linalg.norm(np.cross(e1, e2), axis=1)
    beyond_e2 = 2 * (b + c) / (two_area * np.sqrt(c))  # the edge P0 P2 (s < 0)
    beyond_e1 = 2 * (a + b) / (two_area * np.sqrt(a))  # the edge P0 P1 (t < 0)
    beyond_e3 = (a + c + 2 * b) / (two_area * np.linalg.norm(p2 - p1, axis=1))  # s + t > 1
    return KCAR_TOLERANCE * np.maximum(np.maximum(beyond_e1, beyond_e2), beyond_e3)


def longest_edge_last(v: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """``faces`` with each triangle's corners turned (cyclically, so its normal is kept) until
    the first corner faces the longest edge: Geant4's ``P0`` then lies opposite it, and
    ``G4TriangularFacet::Intersect`` accepts crossings at most about ``2 kCarTolerance / w``
    beyond any edge (:func:`intersect_tolerance`), not ``4 kCarTolerance L / w^2``."""
    tri = v[faces]
    length = np.stack(
        [np.linalg.norm(tri[:, (k + 2) % 3] - tri[:, (k + 1) % 3], axis=1) for k in range(3)],
        axis=1,
    )
    first = length.argmax(axis=1)
    turn = (first[:, None] + np.arange(3)[None, :]) % 3
    return np.take_along_axis(faces, turn, axis=1)


def _atomic_write(path: str | os.PathLike, chunks: list[bytes]) -> None:
    """Write bytes to a temporary file beside ``path``, then rename it over ``path``."""
    with atomic_output(path) as tmp, open(tmp, "wb") as fh:
        fh.writelines(chunks)


_STL_RECORD = np.dtype([("normal", "<f4", (3,)), ("vertices", "<f4", (3, 3)), ("attribute", "<u2")])


def write_stl(mesh: TriangleMesh, path: str | os.PathLike, binary: bool = True) -> None:
    """Write the mesh as STL (lengths in mm, single precision in binary STL), atomically.

    Binary STL stores float32 coordinates: about 7 significant digits, i.e. ~0.1 nm on a 1 mm
    part; use :func:`write_ply` (float64) when that matters.
    """
    tri = mesh.vertices[mesh.faces]
    if binary:
        rec = np.zeros(mesh.n_faces, dtype=_STL_RECORD)
        rec["normal"] = mesh.normals
        rec["vertices"] = tri
        header = b"score4 binary STL, units mm".ljust(80, b" ")
        _atomic_write(path, [header, np.uint32(mesh.n_faces).tobytes(), rec.tobytes()])
        return
    rows = np.concatenate([mesh.normals[:, None, :], tri], axis=1).reshape(-1, 12)
    fmt = (
        "facet normal %.9e %.9e %.9e\n outer loop\n"
        "  vertex %.17e %.17e %.17e\n  vertex %.17e %.17e %.17e\n  vertex %.17e %.17e %.17e\n"
        " endloop\nendfacet\n"
    )
    # ASCII STL is meant for small meshes (inspection, tests); binary is the default.
    body = "".join(fmt % tuple(r) for r in rows)
    _atomic_write(path, [b"solid score4\n", body.encode("ascii"), b"endsolid score4\n"])


def write_ply(mesh: TriangleMesh, path: str | os.PathLike) -> None:
    """Write the mesh as binary little-endian PLY, atomically.

    Vertices are float64 (mm); each face carries its vertex list and a ``top`` flag (uchar).
    """
    if mesh.n_vertices > np.iinfo(np.int32).max:
        raise ConfigError(f"mesh: {mesh.n_vertices} vertices exceed the PLY int32 vertex index")
    header = (
        "ply\nformat binary_little_endian 1.0\ncomment score4 mesh, units mm\nelement vertex "
        f"{mesh.n_vertices}\nproperty double x\nproperty double y\nproperty double z\nelement face "
        f"{mesh.n_faces}\nproperty list uchar int vertex_indices\nproperty uchar top\nend_header\n"
    )
    rec = np.zeros(mesh.n_faces, dtype=[("n", "u1"), ("v", "<i4", (3,)), ("top", "u1")])
    rec["n"] = 3
    rec["v"] = mesh.faces
    rec["top"] = mesh.top
    verts = np.ascontiguousarray(mesh.vertices, dtype="<f8")
    _atomic_write(path, [header.encode("ascii"), verts.tobytes(), rec.tobytes()])
