"""Rough layers on curved faces: patches bent onto a surface of revolution (numpy, no Geant4).

A face swept around z (the side wall of a G4Tubs, a G4Cons face, a segment of a G4Polycone or
G4GenericPolycone: :class:`~score4.shapes.faces.RevolvedFace`) is tiled in *rings*: rows of
patches along the generator (pitch ``py``, centred on the face), each row a ring of
``floor(r dphi / px)`` patches around the axis (angular pitch ``px / r`` at the row's radius
``r``, centred on the face's phi range). A patch is the closed body of its surface variant
(rough top, walls, a slab of ``base_thickness`` below the base plane) *bent* onto the surface:
a patch-local point ``(x, y, z)`` goes to azimuth ``x / r``, generator position ``v + y`` and
height ``z + base_thickness + lift`` along the surface's outward normal. The vertices are mapped
exactly; the facets stay flat between them. The slab's floor is triangulated as a strip between
its two long edges, so each floor facet spans only the distance between neighbouring boundary
vertices; a chord of the circle lies inside it by its sagitta, so the whole patch is lifted by
the largest floor sagitta (``lift``) on a convex face (a concave face, a bore, needs none): the
floor then never enters the volume, and its gap to the true surface is at most ``lift`` (the
measured ``gap`` of the layer). The walls between patches of a ring lie in planes through the
axis, shared exactly by neighbours.

Rotational symmetry: all patches of a ring (and all rings of a cylinder) of one variant are
the same solid, rotated about z; Geant4 gets one solid and logical volume per variant and ring
radius, placed once per cell.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from score4.errors import ConfigError
from score4.shapes.faces import RevolvedFace, SphereFace
from score4.surface.rough import Surface
from score4.surface.triangle_mesh import TriangleMesh, longest_edge_last

#: The base of a bent layer must follow the true surface this closely: the larger of this share
#: of the roughness height and GAP_FLOOR (mm).
GAP_SHARE = 0.01
GAP_FLOOR = 1e-4

#: On a sphere, a ring holds patches only where a patch's width at the ring's edge nearer the
#: pole differs from its width at the ring's centre by at most this share (the bent patch is
#: squeezed towards the pole); rings nearer the poles stay flat (``rough_shares``).
MAX_SQUEEZE = 0.05


def gap_limit(max_height: float) -> float:
    """Largest allowed gap (mm) between a bent layer's base and the true surface."""
    return max(GAP_SHARE * max_height, GAP_FLOOR)


def _floor_strip(xy: np.ndarray, ring: np.ndarray, px: float, py: float) -> np.ndarray:
    """Triangles (k, 3) of vertex indices (from ``ring``) covering the rectangle
    [-px/2, px/2] x [-py/2, py/2] whose boundary vertices are ``xy[ring]``: fans at the two
    short sides, a strip between the two long sides."""
    p = xy[ring]
    tol = 1e-9 * max(px, py)
    low, high = np.abs(p[:, 1] + py / 2) <= tol, np.abs(p[:, 1] - py / 2) <= tol
    left, right = np.abs(p[:, 0] + px / 2) <= tol, np.abs(p[:, 0] - px / 2) <= tol
    a = ring[low][np.argsort(p[low, 0], kind="stable")]  # bottom edge, x rising
    b = ring[high][np.argsort(p[high, 0], kind="stable")]  # top edge, x rising
    side_l = ring[left & ~low & ~high][np.argsort(p[left & ~low & ~high, 1], kind="stable")]
    side_r = ring[right & ~low & ~high][np.argsort(p[right & ~low & ~high, 1], kind="stable")]
    tris: list[tuple[int, int, int]] = []
    chain = [a[0], *side_l, b[0]]
    tris += [(chain[k], chain[k + 1], a[1]) for k in range(len(chain) - 1)]
    chain = [a[-1], *side_r, b[-1]]
    tris += [(chain[k], chain[k + 1], b[-2]) for k in range(len(chain) - 1)]
    lo, hi = list(a[1:]), list(b[:-1])
    i = j = 0
    while i < len(lo) - 1 or j < len(hi) - 1:
        if j == len(hi) - 1 or (i < len(lo) - 1 and xy[lo[i + 1], 0] <= xy[hi[j + 1], 0]):
            tris.append((lo[i], lo[i + 1], hi[j]))
            i += 1
        else:
            tris.append((lo[i], hi[j + 1], hi[j]))
            j += 1
    out = np.array(tris, dtype=np.int64)
    # the floor faces down (-z): flip the triangles wound the other way
    e1, e2 = xy[out[:, 1]] - xy[out[:, 0]], xy[out[:, 2]] - xy[out[:, 0]]
    up = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0] > 0
    out[up] = out[up][:, ::-1]
    return out


def flat_body(
    surface: Surface, base_thickness: float, grid_floor: bool = False
) -> tuple[np.ndarray, np.ndarray, int]:
    """A variant's closed patch body with its floor as a strip (see :func:`_floor_strip`):
    vertices (patch-local, centred), faces, and the number of top faces (first).

    ``grid_floor``: the floor is the top's own triangulation moved down to the floor (its
    facets as small as the top's in both directions: a surface curved along both, a sphere,
    bends a strip's long facets away from it by ``py^2 / 8R``); for a spike grid, two
    triangles per spike cell between the cell's corners, so each cell's floor bent onto a
    sphere is the planar floor of the bent G4Trap below that spike
    (:func:`score4.geometry.curved.place_bent_frustums`)."""
    body = surface.body(base_thickness)
    top = np.asarray(body.top, bool)
    faces = body.faces
    v = body.vertices
    floor_level = np.abs(v[:, 2] + base_thickness) <= 1e-12
    is_floor = floor_level[faces].all(axis=1)
    ring = np.unique(faces[is_floor & ~top].ravel())
    ring = ring[np.isin(ring, faces[~is_floor & ~top].ravel())]  # not the fan's centre
    if grid_floor and surface.spikes is not None:
        g = surface.spikes
        cx = np.arange(g.nx + 1) * g.width_x - 0.5 * g.size_x
        cy = np.arange(g.ny + 1) * g.width_y - 0.5 * g.size_y
        gx, gy = np.meshgrid(cx, cy)
        corners = np.column_stack([gx.ravel(), gy.ravel(), np.full(gx.size, -base_thickness)])
        scale = max(surface.size_x, surface.size_y)
        key = {tuple(np.round(v[i, :2] / scale * 1e9).astype(np.int64)): int(i) for i in ring}
        index = np.empty(len(corners), np.int64)
        extra_c: list[np.ndarray] = []
        for n, c in enumerate(corners):
            k = tuple(np.round(c[:2] / scale * 1e9).astype(np.int64))
            if k in key:
                index[n] = key[k]
            else:
                index[n] = len(v) + len(extra_c)
                extra_c.append(c)
        v = np.vstack([v, np.array(extra_c, float).reshape(-1, 3)])
        c = index.reshape(g.ny + 1, g.nx + 1)
        a, b, d, e = c[:-1, :-1].ravel(), c[:-1, 1:].ravel(), c[1:, 1:].ravel(), c[1:, :-1].ravel()
        # facing down (-z): (a, d, b) and (a, e, d) with a, b, d, e counter-clockwise from above
        floor = np.vstack([np.column_stack([a, d, b]), np.column_stack([a, e, d])])
    elif grid_floor:
        top_faces = faces[top]
        used = np.unique(top_faces)
        scale = max(surface.size_x, surface.size_y)
        key = {tuple(np.round(v[i, :2] / scale * 1e9).astype(np.int64)): int(i) for i in ring}
        index = np.empty(len(v), np.int64)
        extra: list[list[float]] = []
        for i in used:
            k = tuple(np.round(v[i, :2] / scale * 1e9).astype(np.int64))
            if k in key:
                index[i] = key[k]
            else:
                index[i] = len(v) + len(extra)
                extra.append([v[i, 0], v[i, 1], -base_thickness])
        v = np.vstack([v, np.array(extra, float).reshape(-1, 3)])
        floor = index[top_faces][:, ::-1]  # facing down
    else:
        floor = _floor_strip(v[:, :2], ring, surface.size_x, surface.size_y)
    keep = faces[~is_floor]
    n_top = int(top[~is_floor].sum())
    return v, np.vstack([keep, floor]), n_top


def _floor_grid(
    v: np.ndarray, ring: np.ndarray, px: float, py: float, base: float
) -> tuple[np.ndarray, np.ndarray] | None:
    """The floor of :func:`_floor_strip` cut into the rectangles of a grid through its boundary
    vertices (two triangles each): columns at the x of the bottom and top edges' vertices, rows
    at the y of the two short sides' vertices (a spike grid's cells, squares of the spike
    width). Returns (new interior vertices, triangles facing down), or None when the bottom
    and top edges (or the two sides) do not hold vertices at the same positions. Bent onto a
    surface swept around z, every point of a column (one azimuth) lies on the straight line
    its two end vertices bend to, and each column's two lines on one plane (through the
    cone's apex, or parallel), so the grid is the strip's surface cut in smaller facets."""
    p = v[ring, :2]
    tol = 1e-9 * max(px, py)
    low, high = np.abs(p[:, 1] + py / 2) <= tol, np.abs(p[:, 1] - py / 2) <= tol
    left, right = np.abs(p[:, 0] + px / 2) <= tol, np.abs(p[:, 0] - px / 2) <= tol
    xs_lo, xs_hi = np.sort(p[low, 0]), np.sort(p[high, 0])
    ys_l, ys_r = np.sort(p[left, 1]), np.sort(p[right, 1])
    if (
        len(xs_lo) != len(xs_hi)
        or len(ys_l) != len(ys_r)
        or np.abs(xs_lo - xs_hi).max() > tol
        or np.abs(ys_l - ys_r).max() > tol
    ):
        return None
    xs, ys = xs_lo, ys_l
    scale = max(px, py)

    def key(x: float, y: float) -> tuple[int, int]:
        return (round(x / scale * 1e9), round(y / scale * 1e9))

    known = {key(*v[i, :2]): int(i) for i in ring}
    index = np.empty((len(ys), len(xs)), np.int64)
    extra: list[tuple[float, float, float]] = []
    for k, y in enumerate(ys):
        for i, x in enumerate(xs):
            at = known.get(key(x, y))
            if at is None:
                if k in (0, len(ys) - 1) or i in (0, len(xs) - 1):
                    return None  # a boundary point that is no boundary vertex
                at = len(v) + len(extra)
                extra.append((float(x), float(y), -base))
            index[k, i] = at
    a, b = index[:-1, :-1].ravel(), index[:-1, 1:].ravel()
    d, e = index[1:, 1:].ravel(), index[1:, :-1].ravel()
    # facing down (-z): (a, d, b) and (a, e, d) with a, b, d, e counter-clockwise from above
    floor = np.vstack([np.column_stack([a, d, b]), np.column_stack([a, e, d])])
    return np.array(extra, float).reshape(-1, 3), floor


def solid_body(
    flat: tuple[np.ndarray, np.ndarray, int],
    surface: Surface,
    base_thickness: float,
    cut_floor: bool = True,
) -> tuple[np.ndarray, np.ndarray, int]:
    """The body Geant4 gets for a variant's ``flat`` body (:func:`flat_body` with the strip
    floor): the same surface with the floor cut into the rectangles of :func:`_floor_grid`
    (where its boundary is such a grid; not with ``cut_floor`` False: a sphere's floor is a
    grid already, :func:`flat_body`) and every facet but the top's turned by
    :func:`longest_edge_last`. The strip's long facets (a patch's length by a spike's width)
    and the fans' slivers at its short sides let ``G4TessellatedSolid::Inside`` class points
    up to ~1 um outside the body as inside
    (:func:`~score4.surface.triangle_mesh.intersect_tolerance`); the top keeps its triangles
    and their order (sources drawn on it are the same)."""
    v, faces, n_top = flat
    n_floor = _n_floor(v, faces, base_thickness)
    keep = faces[: len(faces) - n_floor]
    ring = np.unique(faces[len(faces) - n_floor :].ravel())
    ring = ring[np.isin(ring, keep[n_top:].ravel())]  # the floor's boundary (the walls' feet)
    grid = (
        _floor_grid(v, ring, surface.size_x, surface.size_y, base_thickness) if cut_floor else None
    )
    if grid is not None:
        extra, floor = grid
        v = np.vstack([v, extra])
        faces = np.vstack([keep, floor])
    rest = longest_edge_last(v, faces[n_top:])
    return v, np.vstack([faces[:n_top], rest]), n_top


@dataclass
class RingLayout:
    """Rows (rings) of patches on a surface of revolution (see the module docstring).

    ``v``: generator position of each row's centre (mm, from the face's middle); ``radius``:
    the surface's distance from the axis there; ``count``: patches in the ring; ``step``:
    angular pitch (rad); ``phi_mid``: the middle of the face's phi range.
    """

    face: RevolvedFace | SphereFace
    patch_size: tuple[float, float]
    v: np.ndarray
    radius: np.ndarray
    count: np.ndarray
    step: np.ndarray
    phi_mid: float

    row_gap: float = 0.0
    #: rings narrower than this hold no patch (:meth:`make`), mm
    least: float = 0.0

    @classmethod
    def make(
        cls,
        face: RevolvedFace | SphereFace,
        patch_size: tuple[float, float],
        reserve: float = 0.0,
        row_gap: float = 0.0,
        least: float = 0.0,
    ) -> RingLayout:
        """Rings on ``face``; on a cone, the rows keep ``reserve`` (at least the layer's
        thickness) clear of the z planes of the face's ends, so the patches stay between
        them, and ``row_gap`` (mm) apart: neighbouring rings bend their facets with different
        radii, so their walls (chords of the circle) do not coincide exactly. ``least``: rings
        whose smallest radius is below it hold no patch (a cone narrowing to a point: near its
        tip a bent patch cannot follow the surface; ``make_curved_layer`` in
        :mod:`score4.world.scene` finds that radius)."""
        px, py = patch_size
        if isinstance(face, SphereFace):
            # its ends are cones through the centre (or poles): the end rows' outer walls are
            # chords of those cones' circles, inside them only by the chords' sagitta, which
            # row_gap exceeds
            usable = face.length - 2 * row_gap
        else:
            tz = abs(float(face._tangent[1]))
            usable = face.length - 2 * reserve * abs(face.nrz[1]) / max(tz, 1e-300)
        pitch = py + row_gap
        rows = max(int(np.floor((usable + row_gap) / pitch * (1 + 1e-9))), 0)
        v = (np.arange(rows) - (rows - 1) / 2) * pitch
        radius = face.radius(v)
        # a ring holds its patches at the smallest radius the row reaches
        inner = np.minimum(face.radius(v - py / 2), face.radius(v + py / 2))
        count = np.floor(np.maximum(inner, 0.0) * face.dphi / px * (1 + 1e-9)).astype(np.int64)
        if isinstance(face, SphereFace):
            squeezed = inner < (1 - MAX_SQUEEZE) * radius
            count[squeezed] = 0
        count[inner < least] = 0
        step = px / np.maximum(radius, 1e-300)
        mid = face.phi0 + 0.5 * face.dphi
        return cls(face, patch_size, v, radius, count, step, mid, row_gap, least)

    @property
    def n_cells(self) -> int:
        return int(self.count.sum())

    @property
    def min_radius(self) -> float:
        """The smallest ring radius among the rings that hold patches (all rings if none)."""
        held = self.radius[self.count > 0]
        return float((held if len(held) else self.radius).min())

    def cell_phi(self, j: int) -> np.ndarray:
        """Azimuths of the cell centres of ring ``j``."""
        n = int(self.count[j])
        return self.phi_mid + (np.arange(n) - (n - 1) / 2) * self.step[j]

    def ring_z(self, j: int) -> float:
        """z of the surface at the centre of ring ``j`` (the placement's shift along z)."""
        return float(self.face.point(0.0, self.v[j])[2])

    def bend(self, local: np.ndarray, j: int, height_offset: float) -> np.ndarray:
        """Patch-local points (x, y, z) of a cell of ring ``j`` centred at phi = 0, bent onto the
        surface, relative to the ring's centre z (see the module docstring)."""
        x, y, z = local[:, 0], local[:, 1], local[:, 2]
        phi = x / self.radius[j]
        face = self.face
        v = self.v[j] + y
        p = face.point(phi, v) + (z + height_offset)[:, None] * face.normal(phi, v)
        p[:, 2] -= self.ring_z(j)
        return p

    def bend_rows(self, local: np.ndarray, j: np.ndarray, height_offset: float) -> np.ndarray:
        """:meth:`bend` with a ring ``j[n]`` for each point ``local[n]``."""
        x, y, z = local[:, 0], local[:, 1], local[:, 2]
        face = self.face
        phi = x / self.radius[j]
        v = self.v[j] + y
        p = face.point(phi, v) + (z + height_offset)[:, None] * face.normal(phi, v)
        p[:, 2] -= face.point(np.zeros(len(j)), self.v[j])[:, 2]
        return p

    def locate(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Cell (ring j, index i; -1 off the patches) and patch-local (x, y, h) of points in the
        target's frame (h: height above the true surface)."""
        u, v, h = self.face.locate(points)
        py = self.patch_size[1]
        rows = len(self.v)
        pitch = py + self.row_gap
        j = np.floor((v - self.v[0]) / pitch + 0.5).astype(np.int64) if rows else np.zeros(0, int)
        ok = (j >= 0) & (j < rows)
        jj = np.where(ok, j, 0)
        ok &= np.abs(v - self.v[jj]) <= py / 2
        step, count = self.step[jj], self.count[jj]
        first = self.phi_mid - (count - 1) / 2 * step
        dphi = np.mod(u - first + step / 2, 2 * np.pi)
        i = np.floor(dphi / step).astype(np.int64)
        ok &= (i >= 0) & (i < count)
        x = (dphi - (i + 0.5) * step) * self.radius[jj]
        y = v - self.v[jj]
        return np.where(ok, j, -1), np.where(ok, i, -1), np.column_stack([x, y, h])


def cone_cell(
    lay: RingLayout, j: int, t: float
) -> tuple[tuple[float, ...], tuple[float, ...], float]:
    """The cell of a patch on ring ``j`` of a cone, exactly: the wedge of the patch's azimuths
    between the face and the face moved out by the layer thickness ``t`` (a G4Cons segment ``a``)
    and between the two cones of surface normals through the patch's ends along the generator,
    moved apart by the rows' gap (a G4Cons ``b``), both over the z range of the cell and centred
    on its middle ``zc`` (ring frame). Returns ``(a, b, zc)`` with ``a`` = (rmin1, rmax1,
    rmin2, rmax2, dz, sphi, dphi) and ``b`` = (rmin1, rmax1, rmin2, rmax2, dz)."""
    face = lay.face
    assert isinstance(face, RevolvedFace)
    py = lay.patch_size[1]
    e = 0.5 * lay.row_gap
    v = lay.v[j] + np.array([-py / 2 - e, py / 2 + e])
    corners: dict[tuple[int, int], tuple[float, float]] = {}
    for ia, vv in enumerate(v):
        for ib, h in enumerate((0.0, t)):
            p = face.point(0.0, vv) + h * face.normal(0.0, vv)
            corners[ia, ib] = (float(p[0]), float(p[2]) - lay.ring_z(j))
    zs = [c[1] for c in corners.values()]
    z0, z1 = min(zs), max(zs)

    def at(p: tuple[float, float], q: tuple[float, float], z: float) -> float:
        return p[0] + (q[0] - p[0]) * (z - p[1]) / (q[1] - p[1])

    def cons(line1, line2) -> tuple[float, float, float, float]:
        lo = [at(line1[0], line1[1], z) for z in (z0, z1)]
        hi = [at(line2[0], line2[1], z) for z in (z0, z1)]
        if lo[0] + lo[1] > hi[0] + hi[1]:
            lo, hi = hi, lo
        return lo[0], hi[0], lo[1], hi[1]

    dz = (z1 - z0) / 2
    step = float(lay.step[j])
    shell = (*cons((corners[0, 0], corners[1, 0]), (corners[0, 1], corners[1, 1])), dz)
    band = (*cons((corners[0, 0], corners[0, 1]), (corners[1, 0], corners[1, 1])), dz)
    return (*shell, -step / 2, step), band, (z0 + z1) / 2


def cone_ring_span(lay: RingLayout, j: int, t: float) -> tuple[float, float]:
    """The range of generator arc length ``v`` of the face whose z range is that of the cells of
    ring ``j`` of a cone (:func:`~score4.world.curved.cone_cell` with the layer's thickness
    ``t``): the envelope cut to it between the end planes holds them exactly (the cell's shell
    lies between the face and the face moved out by ``t``, as the envelope's)."""
    face = lay.face
    assert isinstance(face, RevolvedFace)
    a, _, zc = cone_cell(lay, j, t)
    z = lay.ring_z(j) + zc + np.array([-a[4], a[4]])
    v = (z - float(face._mid[1])) / float(face._tangent[1])
    return float(v.min()), float(v.max())


def sphere_cell(lay: RingLayout, j: int, t: float) -> tuple[float, float, float, float, float]:
    """The cell of a patch on ring ``j`` of a sphere, exactly: the G4Sphere segment over the
    patch's azimuths (centred on phi = 0) between the face and the face moved out (in, on an
    inner face) by the layer thickness ``t``, and between the cones of polar angle through the
    patch's ends along the meridian, moved apart by the rows' gap (neighbouring rings' cells
    touch). Returns (rmin, rmax, stheta, dtheta, dphi) of a cell centred on the sphere's
    centre."""
    face = lay.face
    assert isinstance(face, SphereFace)
    r = face.sphere_radius
    lo, hi = (r, r + t) if face.sign > 0 else (r - t, r)
    e = 0.5 * lay.row_gap
    py = lay.patch_size[1]
    a, b = sorted(float(x) for x in face.polar(lay.v[j] + np.array([-py / 2 - e, py / 2 + e])))
    return lo, hi, a, b - a, float(lay.step[j])


@dataclass
class BentVariant:
    """One variant bent onto one ring radius: the closed body (Geant4) and its top (sampling),
    in the ring's frame (cell at phi = 0, z from the ring's centre)."""

    vertices: np.ndarray
    faces: np.ndarray
    n_top: int

    @cached_property
    def mesh(self) -> TriangleMesh:
        return TriangleMesh(self.vertices, self.faces)

    @property
    def top_triangles(self) -> np.ndarray:
        return self.vertices[self.faces[: self.n_top]]


@dataclass
class Footprints:
    """A variant's flat closed body (patch-local vertices and faces) with its triangles binned
    by patch-local (x, y), for :meth:`contains` on the body bent onto any ring.

    The normal line through a point of a bent patch keeps the point's azimuth and generator
    position, so it is the line of the point's patch-local (x, y): a bent triangle it crosses
    is one whose flat footprint holds that (x, y), but for the bending. Bent facets are flat
    between bent corners; their local footprint leaves the flat one by second-order terms of
    the bend, below ``diameter^2 / r`` for a radius ``r`` (each footprint is widened by that),
    so the bin of a point's (x, y) lists every triangle its normal line can cross."""

    vertices: np.ndarray
    faces: np.ndarray
    edges: tuple[np.ndarray, np.ndarray]
    start: np.ndarray
    members: np.ndarray

    @classmethod
    def make(cls, vertices: np.ndarray, faces: np.ndarray, radius: float, n: int = 32):
        tri = vertices[faces]
        lo, hi = tri.min(axis=1), tri.max(axis=1)
        margin = ((hi - lo) ** 2).sum(axis=1) / max(radius, 1e-300) + 1e-9
        edges = tuple(
            np.linspace(vertices[:, a].min(), vertices[:, a].max(), n + 1) for a in (0, 1)
        )
        ij = []
        for a in (0, 1):
            first = np.searchsorted(edges[a], lo[:, a] - margin, side="right") - 1
            last = np.searchsorted(edges[a], hi[:, a] + margin, side="right") - 1
            ij.append((np.clip(first, 0, n - 1), np.clip(last, 0, n - 1)))
        (i0, i1), (j0, j1) = ij
        # every (triangle, bin) pair of each triangle's bin rectangle
        ni, nj = i1 - i0 + 1, j1 - j0 + 1
        tri_id = np.repeat(np.arange(len(faces)), ni * nj)
        k = np.arange(len(tri_id)) - np.repeat(np.cumsum(ni * nj) - ni * nj, ni * nj)
        key = (i0[tri_id] + k // nj[tri_id]) * n + j0[tri_id] + k % nj[tri_id]
        order = np.argsort(key, kind="stable")
        start = np.searchsorted(key[order], np.arange(n * n + 1))
        return cls(vertices, faces, (edges[0], edges[1]), start, tri_id[order].astype(np.int64))

    def contains(
        self,
        lay: RingLayout,
        q: np.ndarray,
        j: np.ndarray,
        i: np.ndarray,
        local: np.ndarray,
        offset: float,
        tol: float,
    ) -> np.ndarray:
        """True for points ``q`` (target frame) of cells ``(j, i)`` at patch-local ``local``
        inside the body bent onto their ring with ``offset`` (:meth:`RingLayout.bend`) or
        within ``tol`` of it: the parity of the crossings of the normal line up from each point
        with the bent triangles of its (x, y) bin, in the frame of its cell at phi = 0."""
        face = lay.face
        phi = lay.phi_mid + (i - (lay.count[j] - 1) / 2) * lay.step[j]  # the cell's azimuth
        c, s = np.cos(-phi), np.sin(-phi)
        o = np.column_stack([c * q[:, 0] - s * q[:, 1], s * q[:, 0] + c * q[:, 1], q[:, 2]])
        o[:, 2] -= face.point(np.zeros(len(j)), lay.v[j])[:, 2]
        d = face.normal(np.arctan2(o[:, 1], o[:, 0]), lay.v[j] + local[:, 1])
        n = len(self.edges[1]) - 1
        bx = np.clip(np.searchsorted(self.edges[0], local[:, 0], side="right") - 1, 0, n - 1)
        by = np.clip(np.searchsorted(self.edges[1], local[:, 1], side="right") - 1, 0, n - 1)
        first, count = self.start[bx * n + by], np.diff(self.start)[bx * n + by]
        out = np.zeros(len(q), dtype=bool)
        ends = np.cumsum(count)
        per_chunk = 200_000  # (point, triangle) pairs at a time: ~15 arrays of 5 MB
        lo = 0
        while lo < len(q):
            hi = max(int(np.searchsorted(ends, ends[lo] - count[lo] + per_chunk)), lo + 1)
            rows = np.arange(lo, min(hi, len(q)))
            out[rows] = self._parity(lay, o, d, j, rows, first, count, offset, tol)
            lo = rows[-1] + 1
        return out

    def _parity(self, lay, o, d, j, rows, first, count, offset, tol) -> np.ndarray:
        cnt = count[rows]
        owner = np.repeat(np.arange(len(rows)), cnt)
        if not len(owner):
            return np.zeros(len(rows), dtype=bool)
        at = np.arange(len(owner)) - np.repeat(np.cumsum(cnt) - cnt, cnt)
        tri_id = self.members[first[rows][owner] + at]
        flat = self.vertices[self.faces[tri_id]].reshape(-1, 3)
        ring = np.repeat(j[rows][owner], 3)
        tri = lay.bend_rows(flat, ring, offset).reshape(-1, 3, 3)
        p, r = o[rows][owner], d[rows][owner]
        e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
        pv = np.cross(r, e2)
        det = np.einsum("nc,nc->n", pv, e1)
        ok = np.abs(det) > 1e-300
        inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
        tv = p - tri[:, 0]
        u = np.einsum("nc,nc->n", tv, pv) * inv
        qv = np.cross(tv, e1)
        w = np.einsum("nc,nc->n", qv, r) * inv
        t = np.einsum("nc,nc->n", qv, e2) * inv
        hit = ok & (u >= 0) & (w >= 0) & (u + w <= 1)
        out = np.zeros(len(rows), dtype=bool)
        out[owner[hit & (np.abs(t) <= tol)]] = True
        ahead = hit & (t > tol)
        who, when = owner[ahead], t[ahead]
        order = np.lexsort((when, who))
        who, when = who[order], when[order]
        # a ray through an edge or corner meets two or more facets at one point: count once
        new = np.ones(len(who), dtype=bool)
        new[1:] = (who[1:] != who[:-1]) | (np.diff(when) > 1e-12)
        odd = np.bincount(who[new], minlength=len(rows)) % 2 == 1
        return out | odd


def measure_floor(
    layout: RingLayout,
    flat: tuple[np.ndarray, np.ndarray, int],
    base: float,
    j: int,
    column: float | None = None,
    lift: float = 0.0,
) -> tuple[float, float]:
    """Lowest and highest height (mm) above the true surface of the bent floor of a patch of
    ring ``j`` lifted by ``lift``: points on its facets (corners, edge midpoints, inner points)
    located exactly. On a sphere also each facet's circumcentre where it lies in the facet:
    a flat triangle with its corners on a sphere dips deepest there (else at the midpoint of
    its longest edge), so the lowest height is exact. ``column``: the floor's columns of this
    width (mm) are alike (a spike grid's), so only the first is measured: bending turns every
    column into the first about z."""
    v, faces, _ = flat
    floor = faces[len(faces) - _n_floor(v, faces, base) :]
    if column is not None:
        x = v[floor, 0]
        floor = floor[(x <= x.min() + column * (1 + 1e-9)).all(axis=1)]
    used = np.unique(floor)
    bent = np.zeros_like(v)
    bent[used] = layout.bend(v[used], j, base + lift)
    bent[:, 2] += layout.ring_z(j)
    tri = bent[floor]
    w = np.array([[1, 0, 0], [0.5, 0.5, 0], [1 / 3, 1 / 3, 1 / 3], [0.5, 0.25, 0.25]])
    pts = np.einsum("kw,twc->tkc", w, tri).reshape(-1, 3)
    if isinstance(layout.face, SphereFace):
        a2 = np.sum((tri[:, 1] - tri[:, 2]) ** 2, axis=1)
        b2 = np.sum((tri[:, 2] - tri[:, 0]) ** 2, axis=1)
        c2 = np.sum((tri[:, 0] - tri[:, 1]) ** 2, axis=1)
        bc = np.column_stack([a2 * (b2 + c2 - a2), b2 * (c2 + a2 - b2), c2 * (a2 + b2 - c2)])
        inside = (bc >= 0).all(axis=1)
        bc = bc[inside] / bc[inside].sum(axis=1, keepdims=True)
        mids = np.array([[0, 0.5, 0.5], [0.5, 0, 0.5]])  # the other two edges' midpoints
        pts = np.vstack(
            [
                pts,
                np.einsum("tw,twc->tc", bc, tri[inside]),
                np.einsum("kw,twc->tkc", mids, tri).reshape(-1, 3),
            ]
        )
    face = layout.face
    if isinstance(face, RevolvedFace):
        # the height above a cone or cylinder is nr rho + (linear in z): on a flat facet convex
        # (nr > 0) or concave, and linear along every ray in the facet's plane from the axis's
        # foot, so its extremes on a facet lie on its edges, where a 1-d search finds them (the
        # points above miss a long edge's deepest point: a strip facet samples one edge's
        # midpoint, and a chord across the patch's far end dips deeper than one at its centre)
        edges = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
        sign = 1.0 if face.nrz[0] > 0 else -1.0
        pts = np.vstack([pts, _edge_extremes(face, edges[:, 0], edges[:, 1], sign)])
    h = face.locate(pts)[2]
    return float(h.min()), float(h.max())


def _edge_extremes(face: RevolvedFace, a: np.ndarray, b: np.ndarray, sign: float) -> np.ndarray:
    """The point of each segment ``a`` -> ``b`` where ``sign`` times the height above ``face``
    (convex along the segment) is least: a golden-section search, its bracket 0.618^48 (1e-10)
    of the segment at the end (the height there is exact to rounding: it is flat at its least,
    by (1e-10 x segment)^2 / radius)."""
    g = (np.sqrt(5.0) - 1) / 2
    lo, hi = np.zeros(len(a)), np.ones(len(a))

    def f(s: np.ndarray) -> np.ndarray:
        return sign * face.locate(a + s[:, None] * (b - a))[2]

    x1, x2 = hi - g * (hi - lo), lo + g * (hi - lo)
    f1, f2 = f(x1), f(x2)
    for _ in range(48):
        left = f1 <= f2  # the least is in [lo, x2]: x1 becomes x2, a new x1; else the mirror
        hi = np.where(left, x2, hi)
        lo = np.where(left, lo, x1)
        new = np.where(left, hi - g * (hi - lo), lo + g * (hi - lo))
        f_new = f(new)
        x1, x2 = np.where(left, new, x2), np.where(left, x1, new)
        f1, f2 = np.where(left, f_new, f2), np.where(left, f1, f_new)
    s = 0.5 * (lo + hi)
    return a + s[:, None] * (b - a)


def top_sagitta(layout: RingLayout, flat: tuple[np.ndarray, np.ndarray, int]) -> float:
    """Bound (mm) of how far a bent top facet bulges beyond its corners' heights: the sagitta
    of its widest azimuthal extent at the smallest ring radius."""
    v, faces, n_top = flat
    x = v[faces[:n_top], 0]
    width = float((x.max(axis=1) - x.min(axis=1)).max()) if n_top else 0.0
    r = layout.min_radius
    return width * width / (8 * r) if r > 0 else 0.0


def _n_floor(v: np.ndarray, faces: np.ndarray, base: float) -> int:
    on = np.abs(v[:, 2] + base) <= 1e-12
    return int(on[faces].all(axis=1).sum())


def check_radius(
    layout: RingLayout, gap: float, limit: float, where: str, target: str, face: str
) -> None:
    """ConfigError when the bent base leaves a gap above ``limit`` (a radius too small)."""
    if gap <= limit:
        return
    r = layout.min_radius
    need = r * gap / limit  # the sagitta falls as 1 / r at a fixed chord
    raise ConfigError(
        f"{where}: face {face} of {target!r} is curved too tightly for this surface: at radius "
        f"{r:.4g} mm the bent patch's base is {gap * 1e3:.3g} um from the true surface, above "
        f"the limit {limit * 1e3:.3g} um (max of 1 % of the roughness height, 0.1 um); use a "
        f"face of radius >= {need:.4g} mm or a surface with more vertices along its edges"
    )
