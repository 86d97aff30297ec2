"""A GDML world in Geant4, with score4's targets, boxes and rough layers added to it.

The world is read with Geant4's own parser (:func:`score4.geometry.gdml.read_gdml`). The volume
model of the same file (:mod:`score4.geometry.volumes`, read by the configuration's process)
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

import numpy as np

from ..config import RunConfig
from ..errors import ConfigError
from ..scene import FaceFrame, Scene, TargetVolume
from .gdml import read_gdml
from .materials import find_material
from .tiling import place_native
from .volumes import GeometryModel, Instance


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


def build_gdml_world(g4, config: RunConfig, scene: Scene):
    """The GDML world with the run's targets scored and its boxes and rough layers placed."""
    from .world import BuiltGeometry, cut_for_layers

    model = scene.model
    assert model is not None
    assert config.world.gdml is not None
    parser, world_pv = read_gdml(g4, config.world.gdml)
    if world_pv is None:
        raise ConfigError(f"world.gdml: {config.world.gdml}: the file has no world volume")
    built = BuiltGeometry(world=world_pv, keep=[parser])
    unshare = _Unsharer(g4, model, world_pv)
    mothers: dict[int, Any] = {0: world_pv.GetLogicalVolume()}

    def mother_lv(inst: Instance):
        if inst.index not in mothers:
            mothers[inst.index] = unshare.path(inst)[1]
        return mothers[inst.index]

    for t in scene.targets:
        assert t.mother is not None  # every target of a GDML world has one
        if t.instance is None:  # a box of the configuration
            lv, mat = _place_box(g4, config, scene, t, mother_lv(t.mother), built)
        else:
            pv, lv = unshare.path(t.instance)
            mat = lv.GetMaterial()
            _cut(g4, scene, t, pv, lv, built, cut_for_layers)
        built.scoring[t.name] = [lv]
        for layer in scene.layers_of(t.name):
            mlv = mother_lv(t.mother)
            patch_lvs, keep = place_native(
                g4, layer, mlv, mlv.GetMaterial(), mat, frame=_mother_frame(layer.frame, t.mother)
            )
            built.scoring[t.name] += patch_lvs
            built.keep += keep
    built.keep.append(unshare.keep)
    return built


def _place_box(g4, config: RunConfig, scene: Scene, t: TargetVolume, mlv, built):
    from .world import cut_for_layers

    solid = g4.G4Box(t.name, *t.half)
    solid, shift, keep_cut = cut_for_layers(g4, scene, t, solid, t.name)
    material = find_material(g4, t.material, f"targets.{t.entry}.material", config.materials)
    lv = g4.G4LogicalVolume(solid, material, t.name)
    assert t.mother is not None
    where = t.mother.to_local(t.translation) + shift  # boxes are not rotated in their mother
    pv = g4.G4PVPlacement(None, g4.G4ThreeVector(*where), lv, t.name, mlv, False, 0, False)
    built.keep += [solid, lv, pv, keep_cut]
    return lv, material


def _cut(g4, scene: Scene, t: TargetVolume, pv, lv, built, cut_for_layers) -> None:
    """Cut a GDML target for its ``into: true`` layers (see :func:`cut_for_layers`)."""
    if not any(r.config.into for r in scene.layers_of(t.name)):
        return
    solid, shift, keep = cut_for_layers(g4, scene, t, lv.GetSolid(), f"{lv.GetName()}_cut")
    if lv.GetNoDaughters():
        raise ConfigError(
            f"{t.name}: into: true cuts the volume, which holds daughters "
            f"({lv.GetDaughter(0).GetName()}, ...); put the layer outside (into: false)"
        )
    lv.SetSolid(solid)
    r = pv.GetObjectRotationValue()
    rot = np.array([[r.xx, r.xy, r.xz], [r.yx, r.yy, r.yz], [r.zx, r.zy, r.zz]])
    old = pv.GetTranslation()
    moved = np.array([old.x, old.y, old.z]) + rot @ shift
    pv.SetTranslation(g4.G4ThreeVector(*moved))
    built.keep += [keep, solid]
