"""A GDML world in Geant4, with score4's targets, boxes and rough layers added to it.

The world is read with Geant4's own parser (:func:`score4.geometry.gdml.read_gdml`). The volume
model of the same file (:mod:`score4.world.gdml_model`, read by the configuration's process)
says which placement path each target instance is; this module finds the live volumes along
those paths.

**Unsharing.** A logical volume placed several times (or inside a mother placed several times)
is one Geant4 object for all its copies. Scoring each copy in its own column, or putting a rough
layer next to one copy only, needs the copy to have logical volumes of its own along its
placement chain: every shared logical volume on the path of a target (or of the mother of a
rough layer or of a box) is cloned (same solid, material and daughters, named
``<name>_u<k>``) and the placement switched to the clone. The last copy keeps the original.
Geometry and navigation are unchanged.
"""

from __future__ import annotations

from collections import Counter
from typing import Any

from score4.inputs.materials import find_material
from score4.runner.run_plan import RunPlan
from score4.world.gdml_model import GeometryModel, Instance
from score4.world.scene import CurvedRoughLayer, FaceFrame, RoughLayer, Scene, TargetVolume

from ..errors import ConfigError
from ..shapes import Transform
from .gdml import read_gdml
from .tiling import place_native


class _Unsharer:
    """Finds live volumes by model path and gives the volumes on a path their own copies."""

    def __init__(self, g4, model: GeometryModel, world_pv) -> None:
        self.g4 = g4
        self.model = model
        self.world_pv = world_pv
        self.counts = Counter(inst.logical for inst in model.instances)
        self.clones: set[int] = set()  # ids of the Python objects of cloned logical volumes
        self.keep: list = []
        self.serial: Counter[str] = Counter()

    def path(self, inst: Instance) -> tuple[Any, Any]:
        """``(physical volume, logical volume)`` of ``inst``, unique to it (cloned if shared)."""
        pv = self.world_pv
        lv = pv.GetLogicalVolume()
        model_lv = self.model.world
        for i in inst.path:
            pv = lv.GetDaughter(i)
            child = pv.GetLogicalVolume()
            self.keep.append(child)  # keeps the Python object, so its id stays the volume's
            model_lv = self.model.logicals[model_lv].daughters[i].logical
            if id(child) not in self.clones and self.counts[model_lv] > 1:
                child = self._clone(child)
                pv.SetLogicalVolume(child)
                self.counts[model_lv] -= 1
            lv = child
        return pv, lv

    def _clone(self, lv):
        g4 = self.g4
        name = str(lv.GetName())
        self.serial[name] += 1
        clone = g4.G4LogicalVolume(lv.GetSolid(), lv.GetMaterial(), f"{name}_u{self.serial[name]}")
        for i in range(lv.GetNoDaughters()):
            d = lv.GetDaughter(i)
            if d.IsReplicated() or d.IsParameterised():
                raise ConfigError(
                    f"{name}: a volume score4 must copy (a target copy or the mother of a rough "
                    f"layer) holds a replica or parameterised volume ({d.GetName()}); score4 "
                    "copies G4PVPlacement daughters only"
                )
            pv = g4.G4PVPlacement(
                g4.G4Transform3D(d.GetObjectRotationValue(), d.GetTranslation()),
                d.GetLogicalVolume(),
                str(d.GetName()),
                clone,
                False,
                int(d.GetCopyNo()),
                False,
            )
            self.keep.append(pv)
        self.clones.add(id(clone))
        self.keep.append(clone)
        return clone


def _mother_frame(frame: FaceFrame, mother: Instance) -> FaceFrame:
    """A world face frame in the coordinates of ``mother``."""
    return FaceFrame(mother.to_local(frame.centre), mother.rotation.T @ frame.rotation, frame.size)


class LiveWorld:
    """score4's additions to a live Geant4 world whose volume model is known.

    Used for a GDML world read by Geant4 (:func:`build_gdml_world`) and for a world a user built
    in their own geant4_pybind application (:class:`score4.api.World`): finds the live volumes
    of targets by their model paths (giving copies their own logical volumes, see the module
    docstring), cuts volumes for ``into`` layers, places boxes of the configuration and rough
    layers. ``keep`` holds the Python references of everything made here.
    """

    def __init__(self, g4, model: GeometryModel, world_pv, materials: dict | None = None) -> None:
        self.g4 = g4
        self.model = model
        self.world_pv = world_pv
        self.materials = materials or {}
        self.unshare = _Unsharer(g4, model, world_pv)
        self.mothers: dict[int, Any] = {0: world_pv.GetLogicalVolume()}
        self.keep: list = [self.unshare.keep]

    def mother_lv(self, inst: Instance):
        """The live logical volume of ``inst``, its own (cloned if it was shared)."""
        if inst.index not in self.mothers:
            self.mothers[inst.index] = self.unshare.path(inst)[1]
        return self.mothers[inst.index]

    def place_target(self, scene: Scene, t: TargetVolume) -> tuple[Any, Any]:
        """The live logical volume of a target and its material: a GDML volume found (and cut
        for its ``into`` layers), a box of the configuration placed in its mother."""
        assert t.mother is not None  # every target of a model world has one
        if t.instance is None:
            return _place_box(self, scene, t)
        pv, lv = self.unshare.path(t.instance)
        _cut(self, scene, t, pv, lv)
        return lv, lv.GetMaterial()

    def place_layer(self, layer: RoughLayer, material) -> list:
        """Place a rough layer (native tiling) in the mother of its target, its envelope of the
        mother's material and its patches of ``material``; returns the patch logical volumes."""
        t = layer.target
        assert t.mother is not None
        mlv = self.mother_lv(t.mother)
        if isinstance(layer, CurvedRoughLayer):
            from .curved import place_curved

            patch_lvs, keep = place_curved(
                self.g4, layer, mlv, mlv.GetMaterial(), material, _target_in_mother(t)
            )
            self.keep.append(keep)
            return patch_lvs
        patch_lvs, keep = place_native(
            self.g4,
            layer,
            mlv,
            mlv.GetMaterial(),
            material,
            frame=_mother_frame(layer.frame, t.mother),
        )
        self.keep.append(keep)
        return patch_lvs


def _target_in_mother(t: TargetVolume) -> Transform:
    """The target's transform in its mother's frame."""
    assert t.mother is not None
    mother = Transform(t.mother.rotation, t.mother.translation)
    return Transform(mother.rotation.T @ t.rotation, mother.inverse_apply(t.translation))


def build_gdml_world(g4, plan: RunPlan):
    """The GDML world with the run's targets scored and its boxes and rough layers placed
    (Geant4 reads the GDML file here, the only time in a worker process)."""
    from .world import BuiltGeometry

    config, scene = plan.config, plan.scene

    model = scene.model
    assert model is not None
    assert config.world.gdml is not None
    parser, world_pv = read_gdml(g4, config.world.gdml)
    if world_pv is None:
        raise ConfigError(f"world.gdml: {config.world.gdml}: the file has no world volume")
    built = BuiltGeometry(world=world_pv, keep=[parser])
    live = LiveWorld(g4, model, world_pv, config.materials)
    for t in scene.targets:
        lv, material = live.place_target(scene, t)
        built.scoring[t.name] = [lv]
        for layer in scene.layers_of(t.name):
            built.scoring[t.name] += live.place_layer(layer, material)
    built.keep.append(live.keep)
    return built


def _place_box(live: LiveWorld, scene: Scene, t: TargetVolume):
    from .world import cut_for_layers, g4_solid

    g4 = live.g4
    assert t.mother is not None
    mlv = live.mother_lv(t.mother)
    solid = g4_solid(g4, t.described("targets"), t.name)
    solid, shift, keep_cut = cut_for_layers(g4, scene, t, solid, t.name)
    material = find_material(g4, t.material, f"targets.{t.entry}.material", live.materials)
    lv = g4.G4LogicalVolume(solid, material, t.name)
    where = t.mother.to_local(t.translation) + shift  # boxes are not rotated in their mother
    pv = g4.G4PVPlacement(None, g4.G4ThreeVector(*where), lv, t.name, mlv, False, 0, False)
    live.keep += [solid, lv, pv, keep_cut]
    return lv, material


def _cut(live: LiveWorld, scene: Scene, t: TargetVolume, pv, lv) -> None:
    """Cut a GDML target for its ``into: true`` layers (see :func:`cut_for_layers`).

    The cut solid and the placement's shift are computed from the volume's solid and placement
    as the model holds them, so cutting again (a second ``into`` layer added later) gives the
    volume cut by both layers, not cut twice.
    """
    from .world import cut_for_layers

    if not any(r.config.into for r in scene.layers_of(t.name)):
        return
    g4 = live.g4
    assert t.instance is not None
    assert t.mother is not None
    if lv.GetNoDaughters():
        raise ConfigError(
            f"{t.name}: into: true cuts the volume, which holds daughters "
            f"({lv.GetDaughter(0).GetName()}, ...); put the layer outside (into: false)"
        )
    solid, shift, keep = cut_for_layers(g4, scene, t, lv.GetSolid(), f"{lv.GetName()}_cut")
    lv.SetSolid(solid)
    placement = live.model.logicals[t.mother.logical].daughters[t.instance.path[-1]]
    moved = placement.translation + placement.rotation @ shift
    pv.SetTranslation(g4.G4ThreeVector(*moved))
    live.keep += [keep, solid]
