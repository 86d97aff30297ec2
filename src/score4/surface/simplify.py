"""An error-bounded simplified mesh of a height map: fewer triangles, each sample within a bound.

The exact mesh of an n x n-pixel map has 2 n^2 triangles (a 1024 x 1024 map: 2.1 M), and Geant4
needs ~600 bytes and ~6 us per facet to build them (benchmarks/bench_facet_handoff.py). Here the
map's pixel grid is covered by square quads of 1, 2, 4, ... ``max_quad`` pixels, aligned on
multiples of their size (a quadtree under each ``max_quad`` x ``max_quad`` root). A quad keeps its
size when the mesh over it is within ``tolerance`` of every map sample it covers, edges included;
otherwise it is split in four. The mesh of a quad of one pixel is the exact mesh's two triangles
(the same diagonal as :func:`~score4.surface.triangle_mesh.from_heightmap`); a larger quad is a
fan from its centre sample over its boundary: its four corners and every corner of a smaller
neighbouring quad on its sides (so neighbours share their edges: no T-junction, no crack). Every
vertex is a map sample with its measured height: nothing is smoothed or moved.

The bound is verified, not assumed: after the quads are chosen the mesh is evaluated at every
sample (:func:`sample_errors`), and any quad with a sample further than ``tolerance`` from the
mesh is split (quads of one pixel are exact), until none is. So ``max |z_mesh - z_map| <=
tolerance`` at every sample of the map.

Each triangle's ``facet`` id is the cell (pixel) index ``j * (nx - 1) + i`` of its quad's lowest
corner cell, so a triangle lies in the block of that cell as long as block edges fall on
multiples of ``max_quad`` cells (:func:`score4.surface.block_cut.iter_split_top`).
"""

from __future__ import annotations

import numpy as np

from ..errors import ConfigError
from .heightmap import HeightMap
from .triangle_mesh import TriangleMesh, from_heightmap

#: Largest quad side, pixels: also the largest block side of a simplified map (its quads never
#: cross a block edge).
MAX_QUAD = 64
#: At most about this many blocks for a simplified map (an exact one: block_cut.AUTO_MAX_BLOCKS,
#: 16 384). Each block adds walls, a floor and two volumes: a 1024 x 1024 Gaussian map at 0.1 um
#: in 16 384 blocks of 8 x 8 pixels had 697 k facets (266 k of them walls and floors) and built in
#: 13.9 s and 632 MB; in 1024 blocks of 32 x 32, 478 k facets, 7.6 s and 461 MB; in 256 of 64 x 64,
#: 452 k, 5.6 s, 461 MB (bench_surfaces.py --build-child 1024 --tolerance auto, load 4-8).
#: Fewer, larger blocks hold more facets each, which costs per event: block_cut.block_rects cuts
#: a block of more than block_cut.SIMPLIFIED_BLOCK_FACETS top facets along its quads.
SIMPLIFIED_MAX_BLOCKS = 1024
#: Top facets per block aimed at, as block_cut.AUTO_BLOCK_FACETS for exact meshes.
BLOCK_FACETS = 8


def _fan_weights(s: int) -> np.ndarray:
    """(s + 1, s + 1, 5) weights of the corners (0, 0), (s, 0), (s, s), (0, s) (as (x, y) in the
    quad) and the centre on each sample of a quad of side ``s`` under the four-triangle fan."""
    h = s / 2
    b, a = np.meshgrid(np.arange(s + 1) - h, np.arange(s + 1) - h)  # x, y from the centre
    w = np.zeros((s + 1, s + 1, 5))
    # each triangle: centre and two corners; barycentric weights are linear in (x, y)
    tri = [  # (region, corner p, corner q): p -> q anticlockwise
        ((a <= 0) & (np.abs(b) <= -a), 0, 1),  # bottom y = -h
        ((b >= 0) & (np.abs(a) <= b), 1, 2),  # right x = h
        ((a >= 0) & (np.abs(b) <= a), 2, 3),  # top y = h
        ((b <= 0) & (np.abs(a) <= -b), 3, 0),  # left x = -h
    ]
    cx = np.array([-h, h, h, -h])
    cy = np.array([-h, -h, h, h])
    for region, p, q in tri:
        d = cx[p] * cy[q] - cx[q] * cy[p]  # centre at the origin
        lp = (b * cy[q] - a * cx[q]) / d
        lq = (cx[p] * a - cy[p] * b) / d
        m = region & ~(w.sum(axis=2) > 0)
        w[m, p], w[m, q], w[m, 4] = lp[m], lq[m], 1 - lp[m] - lq[m]
    return w


def _windows(z: np.ndarray, i0: np.ndarray, j0: np.ndarray, s: int) -> np.ndarray:
    """(n, s + 1, s + 1) samples of the quads of side ``s`` at cells (i0, j0)."""
    r = np.arange(s + 1)
    return z[j0[:, None, None] + r[None, :, None], i0[:, None, None] + r[None, None, :]]


def _fan_error(z: np.ndarray, i0: np.ndarray, j0: np.ndarray, s: int) -> np.ndarray:
    """Largest |fan - map| over each quad's samples (the fan of its corners and centre only)."""
    out = np.empty(len(i0))
    w = _fan_weights(s)
    for lo in range(0, len(i0), max(1, 2_000_000 // (s + 1) ** 2)):  # bounded memory
        sl = slice(lo, lo + max(1, 2_000_000 // (s + 1) ** 2))
        win = _windows(z, i0[sl], j0[sl], s)
        h = s // 2
        v = np.stack([win[:, 0, 0], win[:, 0, s], win[:, s, s], win[:, s, 0], win[:, h, h]], 1)
        out[sl] = np.abs(np.einsum("abk,nk->nab", w, v) - win).max(axis=(1, 2))
    return out


def _initial_quads(z: np.ndarray, tolerance: float, max_quad: int) -> list[np.ndarray]:
    """Top-down: the largest quads whose four-triangle fan is within the tolerance."""
    ny, nx = z.shape[0] - 1, z.shape[1] - 1
    jj, ii = np.meshgrid(np.arange(0, ny, max_quad), np.arange(0, nx, max_quad), indexing="ij")
    i0, j0 = ii.ravel(), jj.ravel()
    leaves: list[np.ndarray] = []
    s = max_quad
    while len(i0):
        if s == 1:
            leaves.append(np.column_stack([i0, j0, np.ones_like(i0)]))
            break
        ok = (i0 + s <= nx) & (j0 + s <= ny)
        ok[ok] = _fan_error(z, i0[ok], j0[ok], s) <= tolerance
        leaves.append(np.column_stack([i0[ok], j0[ok], np.full(int(ok.sum()), s)]))
        i0, j0, s = _children(i0[~ok], j0[~ok], s, nx, ny)
    return leaves


def _children(i0: np.ndarray, j0: np.ndarray, s: int, nx: int, ny: int):
    """The four quads of side s / 2 of each quad, those that start inside the map."""
    h = s // 2
    ci = (i0[:, None] + np.array([0, h, 0, h])).ravel()
    cj = (j0[:, None] + np.array([0, 0, h, h])).ravel()
    inside = (ci < nx) & (cj < ny)
    return ci[inside], cj[inside], h


def _boundary(i0: np.ndarray, j0: np.ndarray, s: int) -> tuple[np.ndarray, np.ndarray]:
    """(n, 4 s) sample columns and rows round each quad, anticlockwise from its (i0, j0) corner."""
    k = np.arange(s)
    di = np.concatenate([k, np.full(s, s), s - k, np.zeros(s, np.int64)])
    dj = np.concatenate([np.zeros(s, np.int64), k, np.full(s, s), s - k])
    return i0[:, None] + di, j0[:, None] + dj


def _triangles(quads: np.ndarray, shape: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """Faces (as flat sample indices j * nx_samples + i) and their quad's row in ``quads``."""
    nx_s = shape[1]
    corner = np.zeros(shape, bool)  # samples that are a corner of some quad
    i0, j0, s = quads[:, 0], quads[:, 1], quads[:, 2]
    for di, dj in ((0, 0), (1, 0), (1, 1), (0, 1)):
        corner[j0 + dj * s, i0 + di * s] = True
    faces, owner = [], []
    for size in np.unique(s):
        rows = np.flatnonzero(s == size)
        qi, qj = i0[rows], j0[rows]
        if size == 1:
            a, b = qj * nx_s + qi, qj * nx_s + qi + 1
            c, d = b + nx_s, a + nx_s
            faces += [np.column_stack([a, b, c]), np.column_stack([a, c, d])]
            owner += [rows, rows]
            continue
        bi, bj = _boundary(qi, qj, int(size))
        q, k = np.nonzero(corner[bj, bi])  # row-major: each quad's points in loop order
        first = np.flatnonzero(np.r_[True, q[1:] != q[:-1]])
        nxt = np.arange(1, len(q) + 1)
        nxt[np.r_[first[1:] - 1, len(q) - 1]] = first  # each quad's last point closes the loop
        p = bj[q, k] * nx_s + bi[q, k]
        centre = (qj[q] + size // 2) * nx_s + qi[q] + size // 2
        faces.append(np.column_stack([centre, p, p[nxt]]))
        owner.append(rows[q])
    return np.concatenate(faces), np.concatenate(owner)


def sample_errors(
    z: np.ndarray, faces: np.ndarray, owner: np.ndarray, quads: np.ndarray
) -> np.ndarray:
    """Largest |mesh - map| over the samples of each quad (faces as flat sample indices of the
    grid ``z``; ``owner`` the quad of each face). A sample on a shared edge counts in both
    triangles; the mesh is continuous there, so both give its one height."""
    nx_s = z.shape[1]
    zf = z.ravel()
    err = np.zeros(len(quads))
    s_of = quads[owner, 2]
    for size in np.unique(s_of):
        rows = np.flatnonzero(s_of == size)
        q = owner[rows]
        f = faces[rows]
        x, y = f % nx_s, f // nx_s  # integer sample coordinates of the corners
        r = np.arange(int(size) + 1)
        step = max(1, 2_000_000 // (int(size) + 1) ** 2)
        for lo in range(0, len(rows), step):
            sl = slice(lo, lo + step)
            px = quads[q[sl], 0][:, None, None] + r[None, None, :]
            py = quads[q[sl], 1][:, None, None] + r[None, :, None]
            ax, ay = x[sl, 0, None, None], y[sl, 0, None, None]
            ex1, ey1 = x[sl, 1, None, None] - ax, y[sl, 1, None, None] - ay
            ex2, ey2 = x[sl, 2, None, None] - ax, y[sl, 2, None, None] - ay
            d = ex1 * ey2 - ey1 * ex2  # integers: exact
            u = (px - ax) * ey2 - (py - ay) * ex2
            v = ex1 * (py - ay) - ey1 * (px - ax)
            inside = (u >= 0) & (v >= 0) & (u + v <= d)
            zt = zf[f[sl]]
            zm = (
                zt[:, 0, None, None]
                + (
                    u * (zt[:, 1] - zt[:, 0])[:, None, None]
                    + v * (zt[:, 2] - zt[:, 0])[:, None, None]
                )
                / d
            )
            dev = np.where(inside, np.abs(zm - z[py, px]), 0.0).max(axis=(1, 2))
            np.maximum.at(err, q[sl], dev)
    return err


def simplified_mesh(
    hm: HeightMap, tolerance: float, max_quad: int = MAX_QUAD, max_faces: int | None = None
) -> TriangleMesh | None:
    """The mesh of ``hm`` with every sample within ``tolerance`` (mm) of it (module docstring).

    ``tolerance`` 0 gives the exact mesh (:func:`from_heightmap`). ``max_quad`` is a power of two.
    ``max_faces``: None instead as soon as the mesh is sure to have more triangles (splitting a
    quad never lowers the count: its children have at least its fan's triangles), so a map that
    does not simplify is given up after its first triangulation.
    """
    if not tolerance > 0:
        return from_heightmap(hm)
    if max_quad < 1 or max_quad & (max_quad - 1):
        raise ConfigError(f"max_quad: must be a power of two, got {max_quad}")
    z = hm.heights
    if np.isnan(z).any():
        return from_heightmap(hm)  # refuses the missing points with its own message
    nx = z.shape[1] - 1
    quads = np.concatenate(_initial_quads(z, tolerance, max_quad))
    while True:
        faces, owner = _triangles(quads, z.shape)
        if max_faces is not None and len(faces) > max_faces:
            return None
        bad = (sample_errors(z, faces, owner, quads) > tolerance) & (quads[:, 2] > 1)
        if not bad.any():
            break
        i0, j0 = quads[bad, 0], quads[bad, 1]
        split = []
        for size in np.unique(quads[bad, 2]):
            m = quads[bad, 2] == size
            ci, cj, h = _children(i0[m], j0[m], int(size), nx, z.shape[0] - 1)
            split.append(np.column_stack([ci, cj, np.full(len(ci), h)]))
        quads = np.concatenate([quads[~bad], *split])
    used, local = np.unique(faces, return_inverse=True)
    nx_s = z.shape[1]
    vertices = np.column_stack([hm.x[used % nx_s], hm.y[used // nx_s], z.ravel()[used]])
    cell = quads[owner, 1] * nx + quads[owner, 0]
    order = np.argsort(cell, kind="stable")
    return TriangleMesh(vertices, local.reshape(-1, 3)[order], facet=cell[order])


def simplified_blocks(
    hm: HeightMap, tolerance: float, max_faces: int | None = None
) -> tuple[TriangleMesh, int] | None:
    """The simplified mesh and its block side (pixels, a power of two): blocks of about
    :data:`BLOCK_FACETS` triangles, as for an exact mesh, but at most about
    :data:`SIMPLIFIED_MAX_BLOCKS` of them and no larger than :data:`MAX_QUAD`.

    None if the mesh would have more than ``max_faces`` triangles, found out as early as
    :func:`simplified_mesh` can. ``max_faces`` should be at least the number of pixels and the map
    at least 8192 pixels (``tolerance: auto``'s maps): the block side is then that of the bound
    on blocks, whatever the count of a first mesh given up on."""
    cells = (hm.shape[0] - 1) * (hm.shape[1] - 1)
    n_faces = None if max_faces is None else max(max_faces, cells)
    mesh = simplified_mesh(hm, tolerance, MAX_QUAD, n_faces)
    per_block = np.sqrt(cells / SIMPLIFIED_MAX_BLOCKS)
    if mesh is None:  # more than cells triangles: BLOCK_FACETS' side is below 2 ** 2
        assert n_faces is not None  # given up on only against a bound
        want = max(np.sqrt(BLOCK_FACETS * cells / (n_faces + 1)), per_block)
    else:
        want = max(np.sqrt(BLOCK_FACETS * cells / mesh.n_faces), per_block)
    quad = int(min(MAX_QUAD, 2 ** max(0, int(np.ceil(np.log2(want))))))
    if mesh is None or quad < MAX_QUAD:  # smaller quads: again, no larger than the blocks
        mesh = simplified_mesh(hm, tolerance, quad, max_faces)
    if mesh is None or (max_faces is not None and mesh.n_faces > max_faces):
        return None
    return mesh, quad
