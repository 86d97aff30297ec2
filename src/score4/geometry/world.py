"""The world volume and box-shaped target volumes."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..config import RunConfig
from .materials import find_material


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


def world_half_size(config: RunConfig) -> np.ndarray:
    """Half-lengths of a world box that holds every target plus the margin."""
    lo = np.min([np.subtract(t.position, np.divide(t.size, 2)) for t in config.targets], axis=0)
    hi = np.max([np.add(t.position, np.divide(t.size, 2)) for t in config.targets], axis=0)
    return np.maximum(np.abs(lo), np.abs(hi)) + config.world.margin


def check_materials(g4, config: RunConfig) -> None:
    """Resolve every material now, so a typo fails before any output is written."""
    find_material(g4, config.world.material, "world.material")
    for i, t in enumerate(config.targets):
        find_material(g4, t.material, f"targets.{i}.material")


def build_world(g4, config: RunConfig) -> BuiltGeometry:
    """World box with the configured targets placed inside it."""
    half = world_half_size(config)
    world_solid = g4.G4Box("World", *half)
    world_lv = g4.G4LogicalVolume(world_solid, find_material(g4, config.world.material), "World")
    world_pv = g4.G4PVPlacement(None, g4.G4ThreeVector(), world_lv, "World", None, False, 0, False)
    built = BuiltGeometry(world=world_pv, keep=[world_solid, world_lv, world_pv])
    for i, t in enumerate(config.targets):
        solid = g4.G4Box(t.name, *(np.asarray(t.size) / 2))
        lv = g4.G4LogicalVolume(solid, find_material(g4, t.material, f"targets.{i}.material"), t.name)
        pv = g4.G4PVPlacement(None, g4.G4ThreeVector(*t.position), lv, t.name, world_lv, False, 0, False)
        built.keep += [solid, lv, pv]
        built.scoring[t.name] = [lv]
    return built
