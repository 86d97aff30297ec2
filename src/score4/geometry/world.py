"""The world volume and box-shaped target volumes."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from score4.common.records import kind_of
from score4.inputs.materials import find_material
from score4.runner.run_plan import RunPlan
from score4.world.scene import TargetVolume

from .built import BuiltGeometry, cut_for_layers, g4_solid
from .gdml_world import build_gdml_world
from .portal import place_portal, subworld_bounds, trigger_extent
from .tiling import place_native

if TYPE_CHECKING:
    from score4.inputs.config import RunConfig


def portal_layout(plan: RunPlan) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """World half-lengths and the first subworld centre of every portal layer (by layer name).

    Particles move in the box of ``plan.scene.world_half`` (``Lab``: every target, rough layer
    and the margin); the subworlds of all portal layers follow each other along +x beyond it,
    one trigger width apart, and the world grows to hold them with the margin.
    """
    scene = plan.scene
    lab = scene.world_half
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
    half = np.maximum(lab, hi + plan.config.world.margin) if origins else lab
    return half, origins


def check_materials(g4, plan: RunPlan) -> None:
    """Resolve every material now, so a typo fails before any output is written."""
    config = plan.config
    for name in config.materials:
        find_material(g4, name, f"materials.{name}", config.materials)
    if config.world.gdml is None:
        find_material(g4, config.world.material, "world.material", config.materials)
    for i, t in enumerate(config.targets):
        if kind_of(t) == "BoxVolume" and t.material is not None:  # a model, or a record of it
            find_material(g4, t.material, f"targets.{i}.material", config.materials)


def _target_material(g4, config: RunConfig, target: TargetVolume):
    return find_material(g4, target.material, f"targets.{target.entry}.material", config.materials)


def build_world(g4, plan: RunPlan) -> BuiltGeometry:
    """World box with the configured targets and their rough layers placed inside it.

    With a portal layer the targets go into a box ``Lab`` of the native world's size (world
    material) and the subworlds beside it, in a larger world of vacuum: a particle leaving
    ``Lab`` flies straight out of the world or into a trigger, where the portal's stepping
    action kills it, so nothing it does after the native world's end counts. A GDML world is
    built by :func:`score4.geometry.gdml_world.build_gdml_world`.
    """
    config, scene = plan.config, plan.scene
    if scene.model is not None:
        return build_gdml_world(g4, plan)
    half, origins = portal_layout(plan)
    world_solid = g4.G4Box("World", *half)
    world_material = find_material(g4, config.world.material, "world.material", config.materials)
    outer = find_material(g4, "G4_Galactic") if origins else world_material
    world_lv = g4.G4LogicalVolume(world_solid, outer, "World")
    world_pv = g4.G4PVPlacement(None, g4.G4ThreeVector(), world_lv, "World", None, False, 0, False)
    built = BuiltGeometry(world=world_pv, keep=[world_solid, world_lv, world_pv])
    mother_lv, reachable = world_lv, None
    if origins:
        lab = scene.world_half
        lab_solid = g4.G4Box("Lab", *lab)
        mother_lv = g4.G4LogicalVolume(lab_solid, world_material, "Lab")
        lab_pv = g4.G4PVPlacement(
            None, g4.G4ThreeVector(), mother_lv, "Lab", world_lv, False, 0, False
        )
        built.keep += [lab_solid, mother_lv, lab_pv]
        reachable = (-lab, lab)
    for t in scene.targets:
        solid = g4_solid(g4, t.described("targets"), t.name)
        solid, shift, keep_cut = cut_for_layers(g4, scene, t, solid, t.name)
        lv = g4.G4LogicalVolume(solid, _target_material(g4, config, t), t.name)
        pv = g4.G4PVPlacement(
            None, g4.G4ThreeVector(*(t.translation + shift)), lv, t.name, mother_lv, False, 0, False
        )
        built.keep += [solid, lv, pv, keep_cut]
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
