"""The world volume and box-shaped target volumes."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from score4.inputs.config import BoxVolume, RunConfig
from score4.inputs.materials import find_material
from score4.runner.run_plan import RunPlan
from score4.world.scene import Scene, TargetVolume

from ..errors import ConfigError
from ..shapes import G4Box as G4BoxShape
from ..shapes import G4Tubs as G4TubsShape
from ..shapes import Shape
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
        if isinstance(t, BoxVolume):
            find_material(g4, t.material, f"targets.{i}.material", config.materials)


def _target_material(g4, config: RunConfig, target: TargetVolume):
    return find_material(g4, target.material, f"targets.{target.entry}.material", config.materials)


def g4_solid(g4, shape: Shape, name: str):
    """The Geant4 solid of a :mod:`score4.shapes` box or tube (the shapes score4 makes itself:
    boxes of the configuration and volumes cut for ``into`` layers)."""
    if isinstance(shape, G4BoxShape):
        return g4.G4Box(name, shape.dx, shape.dy, shape.dz)
    if isinstance(shape, G4TubsShape):
        return g4.G4Tubs(name, shape.rmin, shape.rmax, shape.dz, shape.sphi, shape.dphi)
    raise ConfigError(f"{name}: score4 builds no Geant4 solid of a {shape.kind}")


def cut_for_layers(g4, scene: Scene, target: TargetVolume, solid, name: str):
    """The solid of ``target`` less the slabs its ``into: true`` layers take, and the shift (in
    the volume's own frame) of its placement.

    The target's shape is made thinner behind each such face (:meth:`Shape.trimmed`: a box
    along the face normal, a tube along z) and moved back by half the cut, so its outer faces
    stay. Returns ``(solid, shift, objects to keep alive)``.
    """
    layers = [r for r in scene.layers_of(target.name) if r.config.into]
    if not layers:
        return solid, np.zeros(3), []
    cuts: dict[str, float] = {layer.config.face_name: layer.thickness for layer in layers}
    trimmed = None if target.shape is None else target.shape.trimmed(cuts)
    if trimmed is None:
        raise ConfigError(
            f"{target.name}: into: true needs a G4Box or G4Tubs (end faces), not a {target.solid}"
        )
    cut = g4_solid(g4, trimmed[0], name)
    return cut, trimmed[1], [cut]


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
        from .gdml_world import build_gdml_world

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
