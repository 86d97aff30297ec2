"""Rays that lie exactly in a wall shared by two neighbouring volumes of a rough layer.

The patch cells of a rough face are boxes placed side by side, and ``solid: blocks`` cuts each
patch into blocks placed side by side; neighbours share their walls exactly (planes x = const,
y = const in the face frame). Geant4 cannot tell which side a ray lying exactly (to ~1e-9 mm) in
such a plane is on: a G4Box does not let in a ray that runs along its face, and a
G4TessellatedSolid finds no exit for a ray that runs along its wall ~1e-17 mm outside it (the
rounding of the placement transform) and returns a zero distance. Such rays lose the path
through the volumes along the wall, or are bounced between the neighbours with zero steps
until Geant4 kills them (docs/tiling.md#rays-on-block-walls). Sampled vertices and directions
hit these planes with probability ~0; a hand-made pencil beam (e.g. at the face centre of an
even grid of patches) does. This module finds such rays before a run, in numpy.
"""

from __future__ import annotations

import numpy as np

from score4.surface.block_cut import cell_shape, surface_block_edges

from .scene import RoughLayer, Scene

#: A ray closer than this to a wall plane (and parallel to it) counts as lying in it: Geant4's
#: surface tolerance (kCarTolerance, 1e-9 mm) is what makes such a ray ambiguous.
WALL_TOLERANCE = 1e-9  # mm


def wall_planes(layer: RoughLayer) -> tuple[np.ndarray, np.ndarray]:
    """Face-local u and v of every wall plane shared by neighbouring volumes of ``layer``.

    Patch-cell walls, and for ``blocks`` patches the cuts between blocks (the automatic or set
    block size of each variant, taken in every column / row of cells: with several variants of
    different cuts this lists a few planes too many, which only makes the check stricter).
    """
    px, py = layer.patch_size
    variants = layer.patch_map.variants
    ny, nx = variants.shape
    lu, lv = layer.frame.size
    u = [-lu / 2 + np.arange(nx + 1) * px]
    v = [-lv / 2 + np.arange(ny + 1) * py]
    centres = layer.cell_centres()
    for k, surface in enumerate(layer.variants):
        if layer.solid_kind(k) != "blocks":
            continue
        cy, cx = cell_shape(surface)
        bx, by = surface_block_edges(surface, layer.config.block_cells)
        ex = bx[1:-1] * (surface.size_x / cx) - surface.size_x / 2
        ey = by[1:-1] * (surface.size_y / cy) - surface.size_y / 2
        u.append((np.unique(centres[..., 0])[:, None] + ex[None, :]).ravel())
        v.append((np.unique(centres[..., 1])[:, None] + ey[None, :]).ravel())
    return np.unique(np.concatenate(u)), np.unique(np.concatenate(v))


def rays_in_walls(layer: RoughLayer, positions: np.ndarray, directions: np.ndarray) -> np.ndarray:
    """True for each ray (world position and direction) lying in a wall plane of ``layer``."""
    d = np.asarray(directions, float) @ layer.frame.rotation
    hit = np.zeros(len(d), dtype=bool)
    parallel = np.abs(d[:, :2]) <= WALL_TOLERANCE * np.linalg.norm(d, axis=1)[:, None]
    rows = np.flatnonzero(parallel.any(axis=1))  # only these can lie in a wall (few, if any)
    if not len(rows):
        return hit
    q = layer.frame.to_local(np.asarray(positions, float)[rows])
    for axis, planes in enumerate(wall_planes(layer)):
        i = np.clip(np.searchsorted(planes, q[:, axis]), 1, len(planes) - 1)
        near = np.minimum(np.abs(q[:, axis] - planes[i - 1]), np.abs(q[:, axis] - planes[i]))
        hit[rows] |= parallel[rows, axis] & (near <= WALL_TOLERANCE)
    return hit


def warn_rays_in_walls(scene: Scene, positions: np.ndarray, directions: np.ndarray) -> str | None:
    """The warning text for rays lying in a shared wall of any rough layer, or None."""
    texts = []
    for layer in scene.layers:
        n = int(rays_in_walls(layer, positions, directions).sum())
        if n:
            texts.append(f"{n} on {layer.name}")
    if not texts:
        return None
    return (
        f"{' and '.join(texts)} of the {len(positions)} source rays lie exactly (within "
        f"{WALL_TOLERANCE:g} mm) in a wall shared by neighbouring patch cells or blocks (e.g. a "
        "beam along the normal at the centre of an even grid of patches): Geant4 loses their path "
        "through the volumes along that wall or kills them as stuck; offset such rays by >= 1 nm "
        "from the cell grid (docs/tiling.md#rays-on-block-walls)"
    )
