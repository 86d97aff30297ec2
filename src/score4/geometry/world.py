"""The world volume and box-shaped target volumes."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..config import RunConfig
from ..scene import Scene
from .materials import find_material
from .portal import PortalGeometry, place_portal, subworld_bounds, trigger_extent
from .tiling import place_native


@dataclass
class BuiltGeometry:
    """What the simulation needs from a built geometry.

    ``scoring`` maps a volume name to the logical volumes whose energy deposits count for
    it (a crystal and the rough patches on its face are scored together). ``keep`` holds
    Python references to every Geant4 object, which Geant4 does not own from Python.
    """

    world: object
    scoring: dict[str, list] = field(default_factory=dict)
    keep: list = field(default_factory=list)
    portals: list[PortalGeometry] = field(default_factory=list)


def world_half_size(config: RunConfig, scene: Scene) -> np.ndarray:
    """Half-lengths of a world box centred on the origin that holds every target, rough layer and the margin."""
    return scene.world_half


def portal_layout(config: RunConfig, scene: Scene) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """World half-lengths and the first subworld centre of every portal layer (by layer name).

    Particles move in the box of :func:`world_half_size` (``Lab``); the subworlds of all portal
    layers follow each other along +x beyond it, one trigger width apart, and the world grows to
    hold them with the margin.
    """
    lab = world_half_size(config, scene)
    origins: dict[str, np.ndarray] = {}
    hi = lab.copy()
    x = lab[0]
    for layer in scene.layers:
        if layer.config.tiling != "portal":
            continue
        e = trigger_extent(layer)
        origins[layer.name] = np.array([x + 3 * e[0], 0.0, 0.0])  # one trigger width of gap
        lo_k, hi_k = subworld_bounds(layer, origins[layer.name])
        hi = np.maximum(hi, np.maximum(np.abs(lo_k), np.abs(hi_k)))
        x = hi_k[0]
    half = np.maximum(lab, hi + config.world.margin) if origins else lab
    return half, origins


def check_materials(g4, config: RunConfig) -> None:
    """Resolve every material now, so a typo fails before any output is written."""
    for name in config.materials:
        find_material(g4, name, f"materials.{name}", config.materials)
    find_material(g4, config.world.material, "world.material", config.materials)
    for i, t in enumerate(config.targets):
        find_material(g4, t.material, f"targets.{i}.material", config.materials)


def build_world(g4, config: RunConfig, scene: Scene) -> BuiltGeometry:
    """World box with the configured targets and their rough layers placed inside it.

    With a portal layer the targets go into a box ``Lab`` of the native world's size (world
    material) and the subworlds beside it, in a larger world of vacuum: a particle leaving
    ``Lab`` flies straight out of the world or into a trigger, where the portal's stepping
    action kills it, so nothing it does after the native world's end counts.
    """
    half, origins = portal_layout(config, scene)
    world_solid = g4.G4Box("World", *half)
    world_material = find_material(g4, config.world.material, "world.material", config.materials)
    outer = find_material(g4, "G4_Galactic") if origins else world_material
    world_lv = g4.G4LogicalVolume(world_solid, outer, "World")
    world_pv = g4.G4PVPlacement(None, g4.G4ThreeVector(), world_lv, "World", None, False, 0, False)
    built = BuiltGeometry(world=world_pv, keep=[world_solid, world_lv, world_pv])
    mother_lv, reachable = world_lv, None
    if origins:
        lab = world_half_size(config, scene)
        lab_solid = g4.G4Box("Lab", *lab)
        mother_lv = g4.G4LogicalVolume(lab_solid, world_material, "Lab")
        lab_pv = g4.G4PVPlacement(
            None, g4.G4ThreeVector(), mother_lv, "Lab", world_lv, False, 0, False
        )
        built.keep += [lab_solid, mother_lv, lab_pv]
        reachable = (-lab, lab)
    for i, t in enumerate(config.targets):
        solid = g4.G4Box(t.name, *(np.asarray(t.size) / 2))
        lv = g4.G4LogicalVolume(
            solid, find_material(g4, t.material, f"targets.{i}.material", config.materials), t.name
        )
        pv = g4.G4PVPlacement(
            None, g4.G4ThreeVector(*t.position), lv, t.name, mother_lv, False, 0, False
        )
        built.keep += [solid, lv, pv]
        built.scoring[t.name] = [lv]
        for layer in scene.layers_of(t.name):
            if layer.config.tiling == "portal":
                portal = place_portal(
                    g4,
                    layer,
                    mother_lv,
                    world_material,
                    lv.GetMaterial(),
                    origins[layer.name],
                    subworld_mother_lv=world_lv,
                    reachable=reachable,
                )
                built.portals.append(portal)
                patch_lvs, keep = portal.patch_lvs, portal.keep
            else:
                patch_lvs, keep = place_native(
                    g4, layer, mother_lv, world_material, lv.GetMaterial()
                )
            built.scoring[t.name] += patch_lvs
            built.keep += keep
    return built
