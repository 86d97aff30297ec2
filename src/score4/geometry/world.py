"""The world volume and box-shaped target volumes."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..config import RunConfig
from ..errors import ConfigError
from ..scene import Scene
from .materials import find_material
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


def world_half_size(config: RunConfig, scene: Scene) -> np.ndarray:
    """Half-lengths of a world box centred on the origin that holds every target, rough layer and the margin."""
    lo, hi = scene.bounds
    return np.maximum(np.abs(lo), np.abs(hi)) + config.world.margin


def check_materials(g4, config: RunConfig) -> None:
    """Resolve every material now, so a typo fails before any output is written."""
    find_material(g4, config.world.material, "world.material")
    for i, t in enumerate(config.targets):
        find_material(g4, t.material, f"targets.{i}.material")


def build_world(g4, config: RunConfig, scene: Scene) -> BuiltGeometry:
    """World box with the configured targets and their rough layers placed inside it."""
    half = world_half_size(config, scene)
    world_solid = g4.G4Box("World", *half)
    world_material = find_material(g4, config.world.material)
    world_lv = g4.G4LogicalVolume(world_solid, world_material, "World")
    world_pv = g4.G4PVPlacement(None, g4.G4ThreeVector(), world_lv, "World", None, False, 0, False)
    built = BuiltGeometry(world=world_pv, keep=[world_solid, world_lv, world_pv])
    for i, t in enumerate(config.targets):
        solid = g4.G4Box(t.name, *(np.asarray(t.size) / 2))
        lv = g4.G4LogicalVolume(solid, find_material(g4, t.material, f"targets.{i}.material"), t.name)
        pv = g4.G4PVPlacement(None, g4.G4ThreeVector(*t.position), lv, t.name, world_lv, False, 0, False)
        built.keep += [solid, lv, pv]
        built.scoring[t.name] = [lv]
        for layer in scene.layers_of(t.name):
            if layer.config.tiling != "native":
                raise ConfigError(f"{layer.name}: tiling {layer.config.tiling!r} is not available yet; use tiling: native")
            patch_lvs, keep = place_native(g4, layer, world_lv, world_material, lv.GetMaterial())
            built.scoring[t.name] += patch_lvs
            built.keep += keep
    return built
