"""Portal tiling of a rough layer: one subworld per patch variant and a teleporting stepping action.

The paper's alternative to placing every cell (:func:`score4.geometry.tiling.place_native`):

* the **portal** is the same envelope box native tiling uses (face size x layer thickness, world
  material, on the face, rotated into the face frame), but empty;
* each of the ``K`` variants gets a **subworld**: a box of one cell (patch size x layer thickness,
  world material) holding one placement of that variant's patch exactly as native tiling places
  it in a cell, inside a slightly larger **trigger** box. Subworlds carry the face's rotation,
  so a jump is a pure translation and momentum directions never change. The trigger of each
  variant is placed four times (two along a grid axis of one cell), one copy per parity of the
  cell indices (:func:`cell_slots`): neighbouring cells, diagonal ones included, never share a
  subworld, so a particle that crosses a cell border lands in another copy and its secondaries'
  cells stay known without Python per track (:mod:`score4.sim.portal_action`);
* the subworlds lie outside the region particles can reach: the targets sit in a box ``Lab`` of
  the native world's size, the subworlds beside it in a larger world, and a particle that leaves
  ``Lab`` is killed where the native world would have ended (:mod:`score4.sim.portal_action`).

A particle entering the portal jumps to the matching point of its cell's subworld; leaving a
subworld through a cell border it jumps to the neighbouring cell's subworld; leaving the grid it
jumps back to the matching point of the portal boundary. Jump target = point + ``T[i, j]``, with
``T[i, j] = A[slot(i, j)] - i Eu - j Ev`` (:meth:`PortalMap.translations`, slots from
:func:`cell_slots`).

This module is numpy except :func:`place_portal`, which receives the geant4_pybind module.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from score4.world.scene import RoughLayer

from ..errors import ConfigError
from .tiling import _rotation, place_variant

#: Trigger box half-lengths as a multiple of the subworld's ("slightly larger").
TRIGGER_SCALE = 1.1

#: Distance between neighbouring triggers, in trigger widths (along world x).
TRIGGER_GAP = 1.0


@dataclass(frozen=True)
class PortalMap:
    """Where the cells of a portal layer live: numpy, no Geant4.

    Parameters
    ----------
    layer
        The rough layer (frame, patch map, thickness).
    subworld_centres
        ``(K S, 3)`` world centres of the subworld boxes (rotated like the face), ``S`` per
        variant (:func:`cell_slots`).
    """

    layer: RoughLayer
    subworld_centres: np.ndarray

    @cached_property
    def slots(self) -> np.ndarray:
        """``(ny, nx)`` subworld of each cell (:func:`cell_slots`)."""
        return cell_slots(self.layer)

    @property
    def rotation(self) -> np.ndarray:
        return self.layer.frame.rotation

    @property
    def half(self) -> np.ndarray:
        """Half-lengths of one subworld (face frame: u, v, n)."""
        px, py = self.layer.patch_size
        return np.array([px / 2, py / 2, self.layer.thickness / 2])

    @property
    def portal_centre(self) -> np.ndarray:
        """World centre of the portal box."""
        return self.layer.frame.to_world(np.array([0.0, 0.0, self.layer.thickness / 2]))

    def offsets(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(A, Eu, Ev)``: ``T[i, j] = A[slot] - i Eu - j Ev`` (world vectors, mm)."""
        lu, lv = self.layer.frame.size
        px, py = self.layer.patch_size
        r = self.rotation
        corner_cell = np.array([-lu / 2 + px / 2, -lv / 2 + py / 2, self.layer.thickness / 2])
        a = self.subworld_centres - self.layer.frame.to_world(corner_cell)
        return a, r[:, 0] * px, r[:, 1] * py

    def translations(self, i: np.ndarray, j: np.ndarray) -> np.ndarray:
        """``(n, 3)`` jump vectors portal point -> subworld point of cells ``(i, j)``."""
        a, eu, ev = self.offsets()
        i, j = np.asarray(i), np.asarray(j)
        k = self.slots[j, i]
        return a[k] - i[:, None] * eu - j[:, None] * ev

    def inside_portal(self, points: np.ndarray) -> np.ndarray:
        """True for world points in the closed portal box."""
        q = self.layer.frame.to_local(np.asarray(points, float).reshape(-1, 3))
        lu, lv = self.layer.frame.size
        return (
            (np.abs(q[:, 0]) <= lu / 2)
            & (np.abs(q[:, 1]) <= lv / 2)
            & (q[:, 2] >= 0)
            & (q[:, 2] <= self.layer.thickness)
        )

    def to_subworld(
        self, points: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Map world points in the portal box to their subworld points.

        Returns ``(mapped, inside, i, j)``: ``mapped`` equals ``points`` outside the portal box;
        ``i, j`` are the cells (-1 outside).
        """
        p = np.asarray(points, float).reshape(-1, 3)
        inside = self.inside_portal(p)
        q = self.layer.frame.to_local(p[inside])
        i, j = self.layer.patch_map.cell_of(q[:, :2])
        mapped = p.copy()
        mapped[inside] = p[inside] + self.translations(i, j)
        ii = np.full(len(p), -1, np.int64)
        jj = np.full(len(p), -1, np.int64)
        ii[inside], jj[inside] = i, j
        return mapped, inside, ii, jj


def trigger_extent(layer: RoughLayer) -> np.ndarray:
    """World-axis half-extent of one trigger box (the face rotation permutes the axes)."""
    px, py = layer.patch_size
    half = TRIGGER_SCALE * np.array([px / 2, py / 2, layer.thickness / 2])
    return np.abs(layer.frame.rotation) @ half


def slot_counts(layer: RoughLayer) -> tuple[int, int]:
    """Copies of each variant's subworld along the grid's u and v: 2 (index parities), 1 along an
    axis of one cell."""
    return (2 if layer.patch_map.nx > 1 else 1), (2 if layer.patch_map.ny > 1 else 1)


def cell_slots(layer: RoughLayer) -> np.ndarray:
    """``(ny, nx)`` subworld of each cell: ``variant * S + (i mod su) + su (j mod sv)`` with
    ``(su, sv)`` from :func:`slot_counts`, ``S = su sv`` (-1 stays -1).

    A cell and its eight neighbours lie in different subworlds, so a jump through a cell border
    or corner always enters another subworld than the one left."""
    v = layer.patch_map.variants
    su, sv = slot_counts(layer)
    j, i = np.indices(v.shape)
    return np.where(v < 0, v, v * (su * sv) + i % su + su * (j % sv))


def subworld_centres(layer: RoughLayer, origin) -> np.ndarray:
    """``(K S, 3)`` subworld centres: the first at ``origin``, the others following along +x."""
    pitch = 2 * trigger_extent(layer)[0] * (1 + TRIGGER_GAP)
    su, sv = slot_counts(layer)
    k = np.arange(len(layer.variants) * su * sv)
    return np.asarray(origin, float)[None, :] + np.outer(k * pitch, [1.0, 0.0, 0.0])


def subworld_bounds(layer: RoughLayer, origin) -> tuple[np.ndarray, np.ndarray]:
    """(lo, hi) world corners of the box holding all of the layer's triggers."""
    c = subworld_centres(layer, origin)
    e = trigger_extent(layer)
    return c.min(axis=0) - e, c.max(axis=0) + e


def check_unreachable(layer: RoughLayer, origin, reach_lo, reach_hi) -> None:
    """Refuse subworlds that overlap the box particles can move in (``reach_lo``..``reach_hi``).

    A particle reaching a subworld without passing the portal would see one patch where the map
    has another, and its cell would be unknown.
    """
    lo, hi = subworld_bounds(layer, origin)
    if np.all(lo < np.asarray(reach_hi)) and np.all(hi > np.asarray(reach_lo)):

        def fmt(v: np.ndarray) -> str:
            return "(" + ", ".join(f"{x:g}" for x in v) + ") mm"

        raise ConfigError(
            f"{layer.name}: subworld_origin {fmt(np.asarray(origin, float))} puts the subworlds "
            f"(box {fmt(lo)} to {fmt(hi)}) where particles can move (box {fmt(reach_lo)} to "
            f"{fmt(reach_hi)}); subworlds must lie outside the targets, rough layers and world "
            "margin"
        )


@dataclass
class PortalGeometry:
    """What the teleporting actions need about one placed portal layer.

    ``region`` holds the portal box and the triggers (steps that start in them are the only ones
    the portal's stepping action sees); ``quiet_region`` holds the subworlds and their patches,
    so that steps there stay in C++.
    """

    map: PortalMap
    portal_pv: object
    subworld_pvs: list
    trigger_pvs: list
    patch_lvs: list
    region: object
    quiet_region: object
    keep: list = field(default_factory=list)

    @property
    def layer(self) -> RoughLayer:
        return self.map.layer

    @property
    def frame(self):
        return self.map.layer.frame

    @property
    def patch_map(self):
        return self.map.layer.patch_map

    @property
    def patch_size(self) -> tuple[float, float]:
        return self.map.layer.patch_size


def place_portal(
    g4,
    layer: RoughLayer,
    mother_lv,
    world_material,
    material,
    subworld_origin,
    *,
    subworld_mother_lv=None,
    reachable: tuple | None = None,
) -> PortalGeometry:
    """Place the empty portal box in ``mother_lv`` and one trigger + subworld per variant, the
    trigger placed once per slot of the variant (:func:`cell_slots`).

    The portal and trigger boxes are vacuum (G4_Galactic) whatever the world material: a particle
    is moved out of them after one straight step, which is undone (position, direction, energy and
    time taken from the step's start). Subworlds are of the world material, like native envelopes.

    Parameters
    ----------
    g4
        The geant4_pybind module.
    layer
        The rough layer to tile.
    mother_lv
        Volume holding the target (the portal goes on its face there).
    world_material, material
        Material of the subworld boxes (world) and of the patches (the target's).
    subworld_origin
        World centre of the first subworld; the others follow along +x
        (:func:`subworld_centres`).
    subworld_mother_lv
        Volume the triggers are placed in (default ``mother_lv``).
    reachable
        ``(lo, hi)`` of the box particles can move in; the subworlds must lie outside it
        (:func:`check_unreachable`).
    """
    if reachable is not None:
        check_unreachable(layer, subworld_origin, *reachable)
    pmap = PortalMap(layer, subworld_centres(layer, subworld_origin))
    vacuum = g4.G4NistManager.Instance().FindOrBuildMaterial("G4_Galactic")
    lu, lv = layer.frame.size
    t = layer.thickness
    name = layer.name
    vec = g4.G4ThreeVector
    rot = _rotation(g4, layer.frame.rotation)
    region = g4.G4Region(f"{name}_portal")
    quiet = g4.G4Region(f"{name}_subworlds")
    portal_solid = g4.G4Box(f"{name}_portal", lu / 2, lv / 2, t / 2)
    portal_lv = g4.G4LogicalVolume(portal_solid, vacuum, f"{name}_portal")
    portal_pv = g4.G4PVPlacement(
        g4.G4Transform3D(rot, vec(*pmap.portal_centre)),
        portal_lv,
        f"{name}_portal",
        mother_lv,
        False,
        0,
        False,
    )
    region.AddRootLogicalVolume(portal_lv)
    keep = [region, quiet, rot, portal_solid, portal_lv, portal_pv]
    half = pmap.half
    sub_solid = g4.G4Box(f"{name}_subworld", *half)
    trig_solid = g4.G4Box(f"{name}_trigger", *(TRIGGER_SCALE * half))
    keep += [sub_solid, trig_solid]
    z = -t / 2 + layer.base_thickness  # base plane of the patch, as in a native cell
    patch_lvs, subworld_pvs, trigger_pvs = [], [], []
    su, sv = slot_counts(layer)
    for k in range(len(layer.variants)):
        sub_lv = g4.G4LogicalVolume(sub_solid, world_material, f"{name}_subworld{k}")
        trig_lv = g4.G4LogicalVolume(trig_solid, vacuum, f"{name}_trigger{k}")
        for slot in range(k * su * sv, (k + 1) * su * sv):  # one placement per slot
            trig_pv = g4.G4PVPlacement(
                g4.G4Transform3D(rot, vec(*pmap.subworld_centres[slot])),
                trig_lv,
                f"{name}_trigger{slot}",
                subworld_mother_lv or mother_lv,
                False,
                slot,
                False,
            )
            keep.append(trig_pv)
            trigger_pvs.append(trig_pv)
        sub_pv = g4.G4PVPlacement(
            None, vec(), sub_lv, f"{name}_subworld{k}", trig_lv, False, k, False
        )
        lvs_k, keep_k = place_variant(g4, layer, k, sub_lv, z, material, f"{name}_v{k}", k)
        region.AddRootLogicalVolume(trig_lv)
        quiet.AddRootLogicalVolume(sub_lv)
        keep += [sub_lv, trig_lv, sub_pv, keep_k]
        patch_lvs += lvs_k
        subworld_pvs.append(sub_pv)
    return PortalGeometry(
        pmap, portal_pv, subworld_pvs, trigger_pvs, patch_lvs, region, quiet, keep
    )
