"""A rough patch cut into blocks of cells: the numpy half of ``solid: blocks``.

One large ``G4TessellatedSolid`` per patch is slow to track charged particles through: every
step of an alpha inside it asks the solid for a safety distance and a distance to its boundary,
and with 10^4-10^6 facets those queries walk many voxels and candidate facets. Here the patch
body is cut along the surface's cell grid into blocks of ``block_cells x block_cells`` cells
(pixels of a height map, spikes of a spike grid). Each block is a closed tessellated solid: its
share of the exact top mesh, vertical walls under its edges and a flat bottom at the patch's
bottom plane. The blocks are placed side by side in the patch's mother volume, so Geant4's
voxelised navigation hands each step to one small solid.

Exactness. The blocks are made from the faces of the one triangle mesh (:attr:`Surface.top_mesh`)
without moving a vertex: the top of the blocks is that mesh face for face, and neighbouring
blocks share their walls exactly (the same boundary vertices, so the same planes): there is no
gap and no overlap between them. Their union is the old closed body (:meth:`Surface.body`).

Floors. In Geant4 each block is cut once more, at a plane :data:`FLOOR_GAP` below its lowest
top vertex (:func:`floored_blocks`): a box (its floor) under a thin tessellated cap. The cut
moves no vertex either; cap and floor share the plane and the block's side planes.
"""

from __future__ import annotations

import itertools
import math
import numbers
from collections.abc import Iterator
from typing import NamedTuple

import numpy as np

from ..errors import ConfigError
from .rough import Surface
from .triangle_mesh import TriangleMesh, boundary_half_edges, closed_body, longest_edge_last

#: Top facets per block that ``block_cells: auto`` aims at. Measured (bench_surfaces.py, alphas,
#: ratio to the equal-height pyramid multi-union, shared machine): measured map 2 x 2 pixels
#: (8 facets) 1.27, 5 x 5 1.54, 10 x 10 2.60, 1 x 1 4.9 (too many daughters and boundaries);
#: pyramids with a spread 1 spike (4 facets) 1.11, 2 x 2 1.39, 5 x 5 1.83; bumps (28 facets per
#: spike) 1 spike 1.82, 2 x 2 2.15.
AUTO_BLOCK_FACETS = 8
#: ... but at most this many blocks per patch (each is a solid, a logical and a physical volume
#: of ~1-3 KB): a 1024 x 1024 map gets 8 x 8 pixel blocks instead of 262 144 blocks of 2 x 2.
#: The number of placed copies of the patch does not enter: the copies share the patch's
#: logical volumes, and the walk over the volume tree before each ``BeamOn`` stops at each level
#: of shared volumes (score4.geometry.tiling.level_regions). A bound on copies x blocks (2e6,
#: until 2026-11) gave a 3 cm face of 30 um x 25 um measured patches one block of ~4600 facets
#: per patch, and 12x the pyramid face's CPU per alpha event (bench_surfaces.py --faces).
AUTO_MAX_BLOCKS = 16_384

#: Each block stands on a box, its floor, from the slab's bottom up to this far below the block's
#: lowest top vertex; the tessellated block is only the rough cap above it. Most steps inside
#: the surface are then in boxes, whose safety and distances are cheap: an exact safety inside a
#: tessellated block measures the distance to each nearby facet, and most of the work per event
#: on a height map went there (bench_surfaces.py --faces: a Gaussian map cost 1.5 x the pyramid
#: face's CPU per alpha event without floors, 1.1-1.3 x with). Not less than 1 um: a
#: G4TriangularFacet accepts a hit up to ~4 kCarTolerance / h^2 (h its lowest altitude, in mm)
#: of its size outside itself, so low walls let rays in far from the cap (measured: a 50 nm gap
#: gave 10-100 nm too much path on ~2 % of grazing geantinos; 1 um walls are what the 1 um slab
#: gave before).
FLOOR_GAP = 1e-3  # mm
#: No floor under a block whose floor would be thinner than this: the block then reaches down to
#: the slab's bottom, as without floors.
MIN_FLOOR = 10e-6  # mm

#: Top facets a block of a simplified map (``tolerance``) may hold before it is cut in four
#: (down to the quads it is made of: a cut never crosses a quad). A simplified map's blocks are
#: its quads' side, ~SIMPLIFIED_MAX_BLOCKS a patch, and hold a few hundred facets each where the
#: map is rough; a block's exact safety measures the distance to each facet near the point.
#: Measured on a 1024 x 1024 Gaussian map at 0.1 um (bench_instructions.py, instructions per
#: alpha event against the pyramid face; benchmarks/README.md): uncut (~420 facets a block)
#: 3.75x; cut to 256 1.60x, to 128 1.37x, to 64 1.06x, to 32 1.00x. Each cut adds walls, floors
#: and volumes to build: 64 builds that map in 9.9 s and 600 MB against 5.3 s and 440 MB uncut
#: (128: 7.4 s, 504 MB; 32: 14.9 s, 736 MB; under load).
SIMPLIFIED_BLOCK_FACETS = 64
#: A simplified patch with more top facets than this has its dense blocks cut in two, across
#: the longer side, instead of in four: its blocks then hold SIMPLIFIED_BLOCK_FACETS / 2 to
#: SIMPLIFIED_BLOCK_FACETS top facets instead of a quarter of that to all of it, so there are
#: fewer of them, and each block costs Geant4 memory and time to build whatever its facets (a
#: cap's walls, bottom and voxels, a floor, two volumes: ~9 kB). Smaller patches (every example)
#: keep the cut in four. Measured on the 1024 x 1024 Gaussian map at 0.1 um (430 k top
#: facets; benchmarks/README.md, session 12): in four 15 559 blocks, 539 MB peak, 1.077x the
#: pyramid face's instructions per alpha event; in two 9775 blocks, 484 MB, 1.198x.
SPLIT_IN_TWO_FACETS = 2**18

#: Top facets of one patch variant above which building is refused (a 1024 x 1024 map has 2.1e6).
MAX_PATCH_FACETS = 4_000_000
#: Rough Geant4 memory per facet, bytes (used in the message only; bench_surfaces.py measures it).
FACET_BYTES = 1000


def cell_shape(surface: Surface) -> tuple[int, int]:
    """(ny, nx) cells: the spikes of a spike grid, the pixels (sample gaps) of a height map."""
    if surface.spikes is not None:
        return surface.spikes.ny, surface.spikes.nx
    ny, nx = surface.placed_map.heights.shape
    return ny - 1, nx - 1


def auto_block_cells(surface: Surface) -> int:
    """Cells per block side for ``block_cells: auto``.

    ~AUTO_BLOCK_FACETS top facets a block, at most ~AUTO_MAX_BLOCKS blocks a patch, whatever
    the size of the face the patch is tiled over.
    """
    if surface.quad_cells is not None:
        return surface.quad_cells  # a simplified map's quads never cross its blocks' edges
    ny, nx = cell_shape(surface)
    per_cell = surface.top_mesh.n_faces / (nx * ny)
    cells = max(1, round(float(np.sqrt(AUTO_BLOCK_FACETS / per_cell))))
    return max(cells, int(np.ceil(np.sqrt(nx * ny / AUTO_MAX_BLOCKS))))


def block_edges(
    n_cells: int, block_cells: int | None, axis: str, auto_cells: int = 2
) -> np.ndarray:
    """Cell indices where blocks start along one axis, with ``n_cells`` appended.

    ``block_cells=None`` (auto) splits into ``ceil(n_cells / auto_cells)`` nearly equal blocks,
    so any number of cells works; an explicit size must divide the number of cells.
    """
    if block_cells is None:
        n_blocks = max(1, -(-n_cells // auto_cells))
        return np.linspace(0, n_cells, n_blocks + 1).round().astype(np.int64)
    value: object = block_cells  # callers outside the config may pass anything
    ok = isinstance(value, numbers.Integral) and not isinstance(value, bool)
    if not ok or block_cells < 1:
        raise ConfigError(f"block_cells: must be a positive whole number, got {block_cells!r}")
    if n_cells % block_cells:
        divisors = [d for d in range(1, n_cells + 1) if n_cells % d == 0]
        raise ConfigError(
            f"block_cells: {block_cells} does not divide the {n_cells} cells of the surface along "
            f"{axis}; use a divisor ({', '.join(map(str, divisors[:12]))}"
            f"{', ...' if len(divisors) > 12 else ''}) or leave it out (auto splits any size)"
        )
    return np.arange(0, n_cells + 1, block_cells, dtype=np.int64)


def surface_block_edges(surface: Surface, block_cells: int | None) -> tuple[np.ndarray, np.ndarray]:
    """Cell indices where the surface's blocks start along x and along y (:func:`block_edges`),
    with the number of cells appended; a simplified map's blocks start at multiples of its quad
    side (the last one may be short), and where a block is cut (:func:`block_rects`) along
    part of a line, that line is listed too."""
    ny, nx = cell_shape(surface)
    q = surface.quad_cells
    if q is not None:
        rects = block_rects(surface, block_cells)[1]
        return np.unique(rects[:, [0, 1]]), np.unique(rects[:, [2, 3]])
    auto = auto_block_cells(surface)
    return block_edges(nx, block_cells, "x", auto), block_edges(ny, block_cells, "y", auto)


def block_rects(surface: Surface, block_cells: int | None) -> tuple[np.ndarray, np.ndarray]:
    """``(block, rects)``: the block of each top face and each block's cells ``[i0, i1, j0, j1]``
    (x from i0 to i1, y from j0 to j1), row by row for a grid of equal blocks.

    A simplified map's blocks of its quad side are then cut in four, again and again, while a
    block holds more than :data:`SIMPLIFIED_BLOCK_FACETS` top faces and no face crosses the
    cut lines (a face never crosses a line its quad does not: the cuts follow the quadtree).
    """
    mesh = surface.top_mesh
    ny, nx = cell_shape(surface)
    q = surface.quad_cells
    if q is None:
        ex, ey = surface_block_edges(surface, block_cells)
    else:
        ex, ey = np.r_[np.arange(0, nx, q), nx], np.r_[np.arange(0, ny, q), ny]
    cell = mesh.facet
    assert cell is not None  # surface meshes carry the cell of each face
    ci, cj = cell % nx, cell // nx
    bi = np.searchsorted(ex, ci, side="right") - 1
    bj = np.searchsorted(ey, cj, side="right") - 1
    block = bj * (len(ex) - 1) + bi
    ii, jj = np.meshgrid(np.arange(len(ex) - 1), np.arange(len(ey) - 1))
    rects = np.column_stack(
        [ex[ii.ravel()], ex[ii.ravel() + 1], ey[jj.ravel()], ey[jj.ravel() + 1]]
    )
    if q is None:
        return block, rects
    return _split_dense(surface, block, rects)


def _split_dense(
    surface: Surface, block: np.ndarray, rects: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`block_rects`' cuts of a simplified map's dense blocks."""
    mesh = surface.top_mesh
    hm = surface.placed_map
    vi = np.searchsorted(hm.x, mesh.vertices[:, 0])  # vertices are map samples
    vj = np.searchsorted(hm.y, mesh.vertices[:, 1])
    fi, fj = vi[mesh.faces], vj[mesh.faces]
    lo_i, hi_i, lo_j, hi_j = fi.min(axis=1), fi.max(axis=1), fj.min(axis=1), fj.max(axis=1)
    order = np.argsort(block, kind="stable")
    starts = np.searchsorted(block[order], np.arange(len(rects) + 1))
    todo = [(rects[b], order[starts[b] : starts[b + 1]]) for b in range(len(rects))]
    out_rects, out_faces = [], []
    halves = mesh.n_faces > SPLIT_IN_TWO_FACETS
    while todo:
        (i0, i1, j0, j1), rows = todo.pop()
        im, jm = (i0 + i1) // 2, (j0 + j1) // 2
        if halves:  # across the longer side only (x first where they are equal)
            along_x = i1 - i0 >= j1 - j0
            cut = len(rows) > SIMPLIFIED_BLOCK_FACETS and (i1 - i0 if along_x else j1 - j0) >= 2
            if cut:
                lo, hi, mid = (lo_i, hi_i, im) if along_x else (lo_j, hi_j, jm)
                cut = not ((lo[rows] < mid) & (hi[rows] > mid)).any()
            if cut:
                upper = (lo_i if along_x else lo_j)[rows] >= (im if along_x else jm)
                low_rect, high_rect = (
                    ((i0, im, j0, j1), (im, i1, j0, j1))
                    if along_x
                    else ((i0, i1, j0, jm), (i0, i1, jm, j1))
                )
                todo += [(low_rect, rows[~upper]), (high_rect, rows[upper])]
                continue
            out_rects.append((i0, i1, j0, j1))
            out_faces.append(rows)
            continue
        cut = len(rows) > SIMPLIFIED_BLOCK_FACETS and i1 - i0 >= 2 and j1 - j0 >= 2
        if cut:
            cross_i = (lo_i[rows] < im) & (hi_i[rows] > im)
            cross_j = (lo_j[rows] < jm) & (hi_j[rows] > jm)
            cut = not (cross_i.any() or cross_j.any())
        if not cut:
            out_rects.append((i0, i1, j0, j1))
            out_faces.append(rows)
            continue
        right, up = lo_i[rows] >= im, lo_j[rows] >= jm
        for r, u, rect in (
            (False, False, (i0, im, j0, jm)),
            (True, False, (im, i1, j0, jm)),
            (False, True, (i0, im, jm, j1)),
            (True, True, (im, i1, jm, j1)),
        ):
            todo.append((rect, rows[(right == r) & (up == u)]))
    new_block = np.empty(len(block), dtype=np.int64)
    for b, rows in enumerate(out_faces):
        new_block[rows] = b
    return new_block, np.array(out_rects, dtype=np.int64)


def check_patch(surface: Surface, kind: str, block_cells: int | None) -> None:
    """Refuse, before any Geant4 work, a patch too large to build or blocks that do not fit.

    ``kind`` is the solid the patch becomes (``tessellated``, ``multiunion``, ``frustums``,
    ``blocks``).
    """
    if kind in ("multiunion", "frustums"):
        return
    mesh = surface.top_mesh
    if mesh.n_faces > MAX_PATCH_FACETS:
        ny, nx = cell_shape(surface)
        raise ConfigError(
            f"surface: {nx} x {ny} cells give {mesh.n_faces} facets, above the limit of "
            f"{MAX_PATCH_FACETS} facets per patch (~{MAX_PATCH_FACETS * FACET_BYTES / 1e9:.0f} GB "
            "of Geant4 memory); crop the map (crop_x, crop_y), resample it on a coarser grid "
            "(resample_pitch) or give the surface a tolerance (a length: the mesh's largest "
            "vertical error)"
        )
    if kind == "blocks" and surface.quad_cells is not None and block_cells is not None:
        raise ConfigError(
            f"block_cells: {block_cells} is not allowed on a simplified height map (tolerance "
            f"{surface.mesh_tolerance * 1e3:.4g} um): its blocks are its quads of "
            f"{surface.quad_cells} x {surface.quad_cells} pixels; leave block_cells out or set "
            "the surface's tolerance: 0"
        )
    if kind == "blocks":
        ny, nx = cell_shape(surface)
        block_edges(nx, block_cells, "x")
        block_edges(ny, block_cells, "y")


def split_top(surface: Surface, block_cells: int | None = None) -> list[TriangleMesh]:
    """The surface's top mesh cut into blocks of cells, row by row (y outer, x inner).

    Every face of :attr:`Surface.top_mesh` lands in exactly one block (faces never cross a cell
    edge); vertices are copied, not moved.
    """
    return list(iter_split_top(surface, block_cells))


def iter_split_top(surface: Surface, block_cells: int | None = None) -> Iterator[TriangleMesh]:
    """:func:`split_top` one block at a time (the patch is checked before the first)."""
    cell = surface.top_mesh.facet
    assert cell is not None  # surface meshes carry the cell of each face
    for piece in _iter_pieces(surface, block_cells):
        yield TriangleMesh(piece.vertices, piece.faces, facet=cell[piece.rows])


class _Piece(NamedTuple):
    """One block's share of the top mesh, as :func:`iter_split_top`'s mesh holds it: the rows
    of its faces in the top mesh, its vertices (ascending ids of the top mesh), its faces
    (local ids) and its boundary half-edges as :func:`boundary_half_edges` orders them."""

    rows: np.ndarray
    vertices: np.ndarray
    faces: np.ndarray
    edges: np.ndarray


def _iter_pieces(surface: Surface, block_cells: int | None) -> Iterator[_Piece]:
    """The blocks' pieces of the top mesh, row by row, computed for many blocks at once (a few
    sorts per :data:`PIECE_FACES` faces instead of a few small numpy calls per block: a
    1024 x 1024 map has 10^4 blocks); the same arrays as a per-block ``np.unique`` and
    :func:`boundary_half_edges`."""
    check_patch(surface, "blocks", block_cells)
    mesh = surface.top_mesh
    block, rects = block_rects(surface, block_cells)
    order = np.argsort(block, kind="stable")
    starts = np.searchsorted(block[order], np.arange(len(rects) + 1))
    del block
    b0 = 0
    while b0 < len(rects):  # blocks b0 .. b1 - 1 together, about PIECE_FACES faces
        b1 = max(b0 + 1, int(np.searchsorted(starts, starts[b0] + PIECE_FACES, side="right")) - 1)
        b1 = min(b1, len(rects))
        yield from _pieces(mesh, order, starts[b0 : b1 + 1])
        b0 = b1


#: Faces of the top mesh :func:`_iter_pieces` cuts into blocks at a time (its arrays stay small).
PIECE_FACES = 1 << 15


def _pieces(mesh: TriangleMesh, order: np.ndarray, starts: np.ndarray) -> Iterator[_Piece]:
    """:func:`_iter_pieces` of the consecutive blocks whose rows of ``order`` start at
    ``starts`` (the next block's start appended)."""
    n_blocks = len(starts) - 1
    rows = order[starts[0] : starts[-1]]
    of_face = np.repeat(np.arange(n_blocks, dtype=np.int64), np.diff(starts))
    n = np.int64(mesh.n_vertices)
    key = of_face[:, None] * n + mesh.faces[rows]  # (block, vertex) of each corner
    used, inverse = np.unique(key, return_inverse=True)
    first = np.searchsorted(used, np.arange(n_blocks + 1, dtype=np.int64) * n)
    local = inverse.reshape(-1, 3) - first[of_face][:, None]  # ids within the block, ascending
    vertex = used - np.repeat(np.arange(n_blocks, dtype=np.int64) * n, np.diff(first))
    # boundary half-edges: undirected edges of one face only, ordered by (block, low, high)
    he = local[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    wide = np.int64(max(1, int(np.diff(first).max())))
    ekey = (np.repeat(of_face, 3) * wide + he.min(axis=1)) * wide + he.max(axis=1)
    eorder = np.argsort(ekey, kind="stable")
    k = ekey[eorder]
    if (k[2:] == k[:-2]).any():
        raise ConfigError("top_mesh: some edges are shared by more than two faces (not a surface)")
    differs = k[1:] != k[:-1]
    single = np.concatenate([[True], differs]) & np.concatenate([differs, [True]])
    kept = eorder[single]
    edges, edge_block = he[kept], np.repeat(of_face, 3)[kept]
    edge_starts = np.searchsorted(edge_block, np.arange(n_blocks + 1))
    face_starts = starts - starts[0]
    for b in range(n_blocks):
        s0, s1 = face_starts[b], face_starts[b + 1]
        yield _Piece(
            rows[s0:s1],
            mesh.vertices[vertex[first[b] : first[b + 1]]],
            local[s0:s1],
            edges[edge_starts[b] : edge_starts[b + 1]],
        )


def block_bodies(
    surface: Surface, base_thickness: float, block_cells: int | None = None
) -> list[TriangleMesh]:
    """Closed bodies of the blocks: each block's top on walls down to ``z = -base_thickness``."""
    return list(iter_block_bodies(surface, base_thickness, block_cells))


def iter_block_bodies(
    surface: Surface, base_thickness: float, block_cells: int | None = None
) -> Iterator[TriangleMesh]:
    """:func:`block_bodies` one at a time, so a caller that hands each to Geant4 and drops it
    never holds them all (a 1024 x 1024-pixel map: ~390 MB of numpy bodies)."""
    return (block_body(top, base_thickness) for top in iter_split_top(surface, block_cells))


def floored_blocks(
    surface: Surface, base_thickness: float, block_cells: int | None = None
) -> Iterator[tuple[TriangleMesh, np.ndarray | None]]:
    """The blocks as Geant4 gets them, one at a time: ``(cap, floor)`` per block, row by row.

    ``floor`` is the ``(2, 3)`` array of the low and high corners (x, y, z) of the box under the
    block, from ``z = -base_thickness`` up to :data:`FLOOR_GAP` below the block's lowest top
    vertex; ``cap`` is the block's closed body down to the floor's top. Cap and floor together
    are the block of :func:`block_bodies` exactly: the cap's top faces unchanged, its walls in
    the same planes x = const, y = const (the floor's corners are the block's own outline
    coordinates), the cut between them a plane z = const. Where the floor would be thinner than
    :data:`MIN_FLOOR` it is None and the cap is the whole block.
    """
    for top in iter_split_top(surface, block_cells):
        v = top.vertices
        z = float(v[:, 2].min()) - FLOOR_GAP
        if z + base_thickness < MIN_FLOOR:
            yield block_body(top, base_thickness), None
            continue
        lo, hi = v[:, :2].min(axis=0), v[:, :2].max(axis=0)
        floor = np.array([[lo[0], lo[1], -base_thickness], [hi[0], hi[1], z]])
        yield block_body(top, -z), floor


def _closed_body(top: TriangleMesh, thickness: float) -> TriangleMesh:
    """:func:`closed_body` with its bottom at ``z = -thickness``, also above the base plane
    (``thickness`` <= 0: a cap on a floor); the bottom must lie below every top vertex."""
    if thickness > 0:
        return closed_body(top, thickness)
    zmin = float(top.vertices[:, 2].min())
    if not zmin > -thickness:
        raise ConfigError(
            f"thickness: the bottom plane z = {-thickness!r} mm must lie below the lowest top "
            f"vertex (z = {zmin!r} mm)"
        )
    body = closed_body(top, 1.0)  # then the bottom vertices (all after the top's) moved up
    v = body.vertices.copy()
    v[top.n_vertices :, 2] = -float(thickness)
    return TriangleMesh(v, body.faces, top=body.top, patch=body.patch, facet=body.facet)


#: Geant4's surface tolerance kCarTolerance, mm. G4TriangularFacet refuses a facet ("Facet is too
#: small or too narrow") with an edge of at most this length or a lowest altitude (twice its area
#: over its longest edge) of at most this; the G4TessellatedSolid it was meant for then has a
#: hole ("there are holes in the surface!").
G4_FACET_TOLERANCE = 1e-9  # mm
#: A block whose few-facet walls (:func:`block_body`) would have a triangle with its lowest
#: altitude at most this (10x Geant4's limit, for rounding) gets :func:`closed_body`'s walls
#: instead (a quad per top edge over a bottom vertex under each outline vertex, a bottom fan).
#: Measured: a fan triangle of a long side from a bottom corner to two top vertices nearly in
#: line with it, 8.4e-15 mm^2 (altitude 3e-12 mm), in one cap of the exact 1024 x 1024
#: noise-like map (bench_surfaces.py --map noise); 5 of its 16384 caps get closed_body's walls.
MIN_FACET_ALTITUDE = 10 * G4_FACET_TOLERANCE  # mm


def _sliver(p: tuple, q: tuple, r: tuple, turn: float) -> bool:
    """True if the wall triangle of points ``p``, ``q``, ``r`` (distance along the side, z) with
    ``turn`` (twice its area) has a lowest altitude (``turn`` over its longest edge) below
    :data:`MIN_FACET_ALTITUDE`."""
    longest = max(math.dist(p, q), math.dist(q, r), math.dist(r, p))
    return turn <= MIN_FACET_ALTITUDE * longest


def _upright(
    v: np.ndarray, thickness: float, a: int, b: int, low_a: int, tris: list[tuple]
) -> bool:
    """True if the wall triangles ``tris`` (vertex ids; ids >= len(v) are bottom corners:
    ``low_a`` under ``a``, another under ``b``) all turn the same way as the wall from ``a`` to
    ``b`` (anticlockwise in (distance along the side, z)): none folds over the polygon, and none
    is a sliver (:func:`_sliver`)."""
    d = v[b, :2] - v[a, :2]
    d = d / np.hypot(*d)

    def sz(i: int) -> tuple[float, float]:
        if i < len(v):
            return float((v[i, :2] - v[a, :2]) @ d), float(v[i, 2])
        return (0.0 if i == low_a else float((v[b, :2] - v[a, :2]) @ d)), -float(thickness)

    for p, q, r in tris:
        (ps, pz), (qs, qz), (rs, rz) = pt = sz(p), sz(q), sz(r)
        turn = (qs - ps) * (rz - pz) - (qz - pz) * (rs - ps)
        if turn <= 0 or _sliver(*pt, turn):
            return False
    return True


def narrow_faces(
    vertices: np.ndarray, faces: np.ndarray, limit: float = G4_FACET_TOLERANCE
) -> np.ndarray:
    """Indices of the ``faces`` (vertex ids into ``vertices``) with an edge or a lowest altitude
    of at most ``limit`` (mm): with the default, the facets Geant4's G4TriangularFacet refuses
    (the same rule, in numpy)."""
    tri = np.asarray(vertices)[np.asarray(faces)]
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    lengths = np.linalg.norm(np.stack([e1, tri[:, 2] - tri[:, 1], e2], axis=1), axis=2)
    twice_area = np.linalg.norm(np.cross(e1, e2), axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        narrow = ~(twice_area / lengths.max(axis=1) > limit)
    return np.flatnonzero((lengths.min(axis=1) <= limit) | narrow)


def _terrain_wall(
    v: np.ndarray, thickness: float, chain: list[int], low_a: int, low_b: int
) -> list[tuple[int, int, int]] | None:
    """The wall polygon under a side of 4 or more top edges as ``len(chain)`` triangles over the
    side's two bottom corners (``low_a`` under ``chain[0]``, ``low_b`` under ``chain[-1]``).

    In (distance along the side, z) the polygon is a terrain over a segment: the top chain is
    monotone along the side and lies above the bottom edge, so the stack triangulation of a
    monotone polygon (sweep along the side; the bottom corner first, the other last) cuts it
    without folds; where that gives a triangle thinner than :data:`WALL_MIN_ALTITUDE` (Geant4
    accepts hits far beyond its edges), the fattest triangulation (:func:`_fattest`) instead.
    Each triangle turns anticlockwise, as :func:`_upright` asks. ``None`` if a
    triangle would have no area (three points on a line) or be a sliver (:func:`_sliver`): the
    caller keeps closed_body's walls.
    """
    a, b = chain[0], chain[-1]
    d = v[b, :2] - v[a, :2]
    d = d / np.hypot(*d)
    sz = {i: (float((v[i, :2] - v[a, :2]) @ d), float(v[i, 2])) for i in chain}
    sz[low_a] = (0.0, -float(thickness))
    sz[low_b] = (float((v[b, :2] - v[a, :2]) @ d), -float(thickness))

    def turn(p: int, q: int, r: int) -> float:
        (ps, pz), (qs, qz), (rs, rz) = sz[p], sz[q], sz[r]
        return (qs - ps) * (rz - pz) - (qz - pz) * (rs - ps)

    tris: list[tuple[int, int, int]] = []
    stack = [low_a, a]
    for u in chain[1:]:  # every new vertex is on the top chain, as the stack's top
        q = stack.pop()
        while stack and turn(stack[-1], u, q) > 0:  # q above the diagonal: cut it off
            tris.append((stack[-1], u, q))
            q = stack.pop()
        stack += [q, u]
    tris += [(p, low_b, q) for p, q in itertools.pairwise(stack)]
    if len(tris) != len(chain) or min(turn(*t) for t in tris) <= 0:
        return None
    if min(_altitude(sz[p], sz[q], sz[r]) for p, q, r in tris) < WALL_MIN_ALTITUDE:
        # some wall triangle is long and thin: the polygon's fattest triangulation instead
        fat = _fattest([low_a, low_b, *chain[::-1]], sz)
        if fat is not None:
            tris = fat
    # a sliver: its turn is at most MIN_FACET_ALTITUDE x its longest edge, which is at most the
    # wall's diagonal; only such triangles are measured
    height = max(sz[i][1] for i in chain) + thickness
    bound = math.hypot(sz[low_b][0], height) * MIN_FACET_ALTITUDE
    for t in tris:
        bent = turn(*t)
        if bent <= bound and _sliver(sz[t[0]], sz[t[1]], sz[t[2]], bent):
            return None
    return tris


#: A wall of :func:`_terrain_wall` with a triangle of a lowest altitude below this (mm) is cut
#: by :func:`_fattest` instead: Geant4 accepts a ray's crossing up to ~2 kCarTolerance / w beyond
#: a facet's edges even with its corners turned (triangle_mesh.intersect_tolerance), and 8 x
#: 8-pixel blocks' sweep triangulation gave walls with w down to 2 nm (~1 um too far;
#: benchmarks/README.md, session 13).
WALL_MIN_ALTITUDE = 1e-4  # mm


def _altitude(p: tuple, q: tuple, r: tuple) -> float:
    """The lowest altitude of the triangle of 2-d points ``p``, ``q``, ``r``: twice its area over
    its longest edge."""
    twice = abs((q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0]))
    return twice / max(math.dist(p, q), math.dist(q, r), math.dist(r, p))


def _fattest(
    polygon: list[int], sz: dict[int, tuple[float, float]]
) -> list[tuple[int, int, int]] | None:
    """The triangulation of a wall polygon (vertex ids: the two bottom corners, then the top
    chain back to the first corner; anticlockwise in the points ``sz``, the chain monotone along
    the side) whose thinnest triangle (:func:`_altitude`) is the fattest, by dynamic programming
    over its sub-polygons; each triangle anticlockwise. None if none is found. A triangle whose
    sides are sides of the polygon or chords inside it (crossing no side, touching no other
    vertex) is a face of a triangulation; the chords are tested in numpy."""
    m = len(polygon)
    pts = np.array([sz[i] for i in polygon])
    i, j = np.triu_indices(m, 1)
    p, q = pts[i], pts[j]  # the chords from p to q
    d = q - p
    e0, e1 = pts, np.roll(pts, -1, axis=0)  # the sides from e0 to e1

    def cross(o: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        """(u - o) x (v - o), broadcast: exactly 0 where v or u is o."""
        return (u[..., 0] - o[..., 0]) * (v[..., 1] - o[..., 1]) - (u[..., 1] - o[..., 1]) * (
            v[..., 0] - o[..., 0]
        )

    # a side meets a chord at a point inside both, or a vertex lies on the open chord
    side0 = cross(p[:, None], q[:, None], e0[None, :])
    side1 = cross(p[:, None], q[:, None], e1[None, :])
    other0 = cross(e0[None, :], e1[None, :], p[:, None])
    other1 = cross(e0[None, :], e1[None, :], q[:, None])
    meets = (side0 * side1 < 0) & (other0 * other1 < 0)
    rel = e0[None, :] - p[:, None]
    t = np.einsum("pnc,pc->pn", rel, d) / np.einsum("pc,pc->p", d, d)[:, None]
    on = (side0 == 0) & (t > 0) & (t < 1)
    mid = p + d / 2  # inside: above the bottom, below the top chain
    chain = pts[:1:-1]
    below = mid[:, 1] < np.interp(mid[:, 0], chain[:, 0], chain[:, 1])
    inside = below & (mid[:, 1] > pts[0, 1]) & (mid[:, 0] > pts[0, 0]) & (mid[:, 0] < pts[1, 0])
    good = ~(meets.any(axis=1) | on.any(axis=1)) & inside
    good |= (j - i == 1) | ((i == 0) & (j == m - 1))  # the polygon's sides
    chord = dict(zip(zip(i.tolist(), j.tolist(), strict=True), good.tolist(), strict=True))
    # every triple's twice signed area (> 0: anticlockwise) and lowest altitude
    u = pts[None, :, None] - pts[:, None, None]
    v = pts[None, None, :] - pts[:, None, None]
    twice = u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]
    edge = np.sqrt(((pts[:, None] - pts[None, :]) ** 2).sum(axis=2))
    longest = np.maximum(np.maximum(edge[:, :, None], edge[None, :, :]), edge[:, None, :])
    with np.errstate(divide="ignore", invalid="ignore"):
        fat = np.where(twice > 0, twice / longest, -1.0).tolist()
    best: dict[tuple[int, int], tuple[float, list[tuple[int, int, int]]]] = {
        (k, k + 1): (math.inf, []) for k in range(m - 1)
    }
    for span in range(2, m):
        for lo in range(m - span):
            hi = lo + span
            if not chord[lo, hi]:
                continue
            found: tuple[float, list[tuple[int, int, int]]] | None = None
            for mid_k in range(lo + 1, hi):
                if (lo, mid_k) not in best or (mid_k, hi) not in best:
                    continue
                alt = fat[lo][mid_k][hi]
                if alt < 0:  # clockwise or flat
                    continue
                worst = min(best[lo, mid_k][0], best[mid_k, hi][0], alt)
                if found is None or worst > found[0]:
                    tri = (polygon[lo], polygon[mid_k], polygon[hi])
                    found = (worst, best[lo, mid_k][1] + best[mid_k, hi][1] + [tri])
            if found is not None:
                best[lo, hi] = found
    return best[0, m - 1][1] if (0, m - 1) in best else None


def block_body(top: TriangleMesh, thickness: float) -> TriangleMesh:
    """One block's closed body with few facets: walls over the block's four bottom corners only.

    Geant4 asks a block for its exact safety at every step inside it, a distance to each nearby
    facet (bench_surfaces.py, docs/tiling.md): fewer facets, cheaper steps. :func:`closed_body`
    gives every top edge on the outline a wall quad (2 triangles) reaching a bottom vertex under
    each outline vertex, and fans the bottom from a centre vertex: 32 facets for 2 x 2 pixels.
    Here each side's wall polygon (its 2 or 3 top vertices over the side's two bottom corners)
    is 2, 3 or 4 triangles and the bottom is 2: 22 facets for 2 x 2 pixels, 36 instead of 54
    for 3 x 3. The walls lie in the same planes with the same top edges, so neighbouring blocks
    still share their walls exactly. A side of n >= 4 edges gets n + 1 triangles
    (:func:`_terrain_wall`; closed_body gave 2n and a bottom fan: 166 instead of 224 facets for
    8 x 8 pixels, the blocks of a 1024 x 1024 map).

    ``thickness`` may be negative: the bottom plane ``z = -thickness`` above the base plane, for
    a cap on a floor (:func:`floored_blocks`).
    """
    extra = _few_walls(top.vertices, boundary_half_edges(top), thickness)
    if extra is None:
        return _closed_body(top, thickness)
    bottom, walls = extra
    faces = np.vstack([top.faces, np.array(walls, dtype=top.faces.dtype)])
    n_extra = len(walls)
    return TriangleMesh(
        np.vstack([top.vertices, bottom]),
        faces,
        top=np.concatenate([top.top, np.zeros(n_extra, bool)]),
        patch=None if top.patch is None else np.concatenate([top.patch, np.full(n_extra, -1)]),
        facet=None if top.facet is None else np.concatenate([top.facet, np.full(n_extra, -1)]),
    )


def _few_walls(
    v: np.ndarray, edges: np.ndarray, thickness: float
) -> tuple[np.ndarray, list[tuple[int, int, int]]] | None:
    """:func:`block_body`'s additions to a top of vertices ``v`` and boundary half-edges
    ``edges`` (:func:`boundary_half_edges`): the four bottom corners (appended after ``v``) and
    the wall and bottom faces; None where closed_body's walls are needed."""
    lo, hi = v[:, :2].min(axis=0), v[:, :2].max(axis=0)
    starts = edges[:, 0]
    nxt = dict(zip(starts.tolist(), edges[:, 1].tolist(), strict=True))
    xy = v[starts, :2]
    at_corner = ((xy[:, 0] == lo[0]) | (xy[:, 0] == hi[0])) & (
        (xy[:, 1] == lo[1]) | (xy[:, 1] == hi[1])
    )
    corner = starts[at_corner].tolist()
    if len(corner) != 4 or len(nxt) != len(edges):
        return None
    # the outline (anticlockwise) cut at the corners into the four sides' chains
    corners = set(corner)
    chains, start = [], corner[0]
    for _ in range(4):
        chain = [start]
        while True:
            chain.append(nxt[chain[-1]])
            if chain[-1] in corners:
                break
            if len(chain) > len(nxt):
                return None  # not a loop through the corners
        chains.append(chain)
        start = chain[-1]
    if start != corner[0]:
        return None
    n_top = len(v)
    ends = [c[0] for c in chains]  # the corners, in loop order
    low = {c: n_top + k for k, c in enumerate(ends)}
    bottom = np.column_stack([v[ends, :2], np.full(4, -float(thickness))])
    walls: list[tuple[int, int, int]] = []
    for chain in chains:  # orientation as in closed_body: each top edge reversed on its wall
        a, b = chain[0], chain[-1]
        la, lb = low[a], low[b]
        if len(chain) == 2:
            walls += [(b, a, la), (b, la, lb)]
        elif len(chain) == 3:
            m = chain[1]
            walls += [(m, a, la), (b, m, lb), (m, la, lb)]
        elif len(chain) == 4:  # the quad m1, A, B, m2 between the end triangles: a valid diagonal
            m1, m2 = chain[1], chain[2]
            walls += [(m1, a, la), (b, m2, lb)]
            first, other = [(m1, la, m2), (la, lb, m2)], [(m1, la, lb), (m1, lb, m2)]
            if _upright(v, thickness, a, b, la, first):
                walls += first
            elif _upright(v, thickness, a, b, la, other):
                walls += other
            else:
                return None  # a sliver either way
        else:
            long_wall = _terrain_wall(v, thickness, chain, la, lb)
            if long_wall is None:
                return None
            walls += long_wall
    c0, c1, c2, c3 = (low[c] for c in ends)
    walls += [(c1, c0, c3), (c3, c2, c1)]  # the bottom
    # each corner turned to face its triangle's longest edge: Geant4 then accepts crossings at
    # most ~2 kCarTolerance / w beyond a long thin wall triangle's edges, not 4 kCarTolerance L /
    # w^2 (intersect_tolerance; benchmarks/README.md, session 13: 8 x 8-pixel blocks)
    turned = longest_edge_last(np.vstack([v, bottom]), np.array(walls, dtype=np.int64))
    return bottom, [(int(p), int(q), int(r)) for p, q, r in turned.tolist()]


def block_caps(
    surface: Surface, base_thickness: float, block_cells: int | None = None
) -> Iterator[tuple[np.ndarray, list, np.ndarray | None]]:
    """:func:`floored_blocks` as Geant4 gets it, faster: ``(vertices, faces, floor)`` per block,
    the cap's vertex array and its faces as a list of vertex-id triples, the same values in the
    same order as ``floored_blocks``' caps (no mesh object and its checks per block)."""
    cell = surface.top_mesh.facet
    for piece in _iter_pieces(surface, block_cells):
        v = piece.vertices
        z = float(v[:, 2].min()) - FLOOR_GAP
        floor = None
        thickness = base_thickness
        if z + base_thickness >= MIN_FLOOR:
            lo, hi = v[:, :2].min(axis=0), v[:, :2].max(axis=0)
            floor = np.array([[lo[0], lo[1], -base_thickness], [hi[0], hi[1], z]])
            thickness = -z
        extra = _few_walls(v, piece.edges, thickness)
        if extra is None:
            assert cell is not None
            top = TriangleMesh(v, piece.faces, facet=cell[piece.rows])
            body = _closed_body(top, thickness)
            yield body.vertices, body.faces.tolist(), floor
            continue
        bottom, walls = extra
        yield np.vstack([v, bottom]), piece.faces.tolist() + walls, floor
