"""Spike grids as placed solids (``solid: frustums``): one G4Trd per spike layer, one base box.

The paper's multi-union joins a base box and one ``G4Trd`` per spike layer into one solid. With
a height spread every spike height is a voxel boundary of the multi-union, and its voxelisation
explodes (50 x 50 pyramids with a 3 um spread: 42 s, 1.7 GB). Here the same nodes are placed
side by side in the patch's cell box instead: Geant4's navigator voxelises the cell box from the
daughters' extents (milliseconds), and every step is answered by one analytic solid (a G4Trd or
the box), as in the multi-union. The frustums are exactly the multi-union's nodes, so the body
is the same; spikes of equal layer shape share one G4Trd and one logical volume.
"""

from __future__ import annotations

from ..surface.spikes import SpikeGrid


def place_frustums(
    g4,
    grid: SpikeGrid,
    base_thickness: float,
    material,
    mother_lv,
    z: float,
    name: str,
) -> tuple[list, list]:
    """Place the base box and every spike layer of ``grid`` in ``mother_lv``.

    The base plane (the spikes' foot, the slab's top) is at height ``z`` of the mother; the slab
    reaches ``base_thickness`` below it. Returns ``(logical volumes, objects to keep alive)``,
    all logical volumes of ``material``.
    """
    vec = g4.G4ThreeVector
    base = g4.G4Box(f"{name}_base", grid.size_x / 2, grid.size_y / 2, base_thickness / 2)
    base_lv = g4.G4LogicalVolume(base, material, f"{name}_base")
    g4.G4PVPlacement(
        None,
        vec(0.0, 0.0, z - base_thickness / 2),
        base_lv,
        f"{name}_base",
        mother_lv,
        False,
        0,
        False,
    )
    lvs, keep = [base_lv], [base, base_lv]
    shapes: dict[tuple, object] = {}  # (half widths, half height) -> logical volume
    f = grid.frustums()
    cols = ("width_x_bottom", "width_x_top", "width_y_bottom", "width_y_top", "height")
    halves = [(f[c] / 2).tolist() for c in cols]
    xs, ys, zs = f["x"].tolist(), f["y"].tolist(), f["z"].tolist()
    for k in range(len(f)):
        key = tuple(h[k] for h in halves)
        lv = shapes.get(key)
        if lv is None:
            tag = f"{name}_t{len(shapes)}"
            trd = g4.G4Trd(tag, *key)
            lv = g4.G4LogicalVolume(trd, material, tag)
            shapes[key] = lv
            lvs.append(lv)
            keep += [trd, lv]
        # Geant4 owns the placement (its mother deletes it): no Python object kept per spike.
        g4.G4PVPlacement(
            None, vec(xs[k], ys[k], z + zs[k]), lv, f"{name}_s", mother_lv, False, k + 1, False
        )
    return lvs, keep
