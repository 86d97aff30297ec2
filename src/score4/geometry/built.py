"""What a built world hands the simulation (:class:`BuiltGeometry`), and the Geant4 solids of
the shapes score4 makes itself (configuration boxes, volumes cut for ``into`` layers); used by
the builders of both a configured world (:mod:`score4.geometry.world`) and a GDML world
(:mod:`score4.geometry.gdml_world`)."""

from __future__ import annotations

import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from score4.world.boolean_modes import boolean_cuts
from score4.world.facets import clip_convex, is_convex, mesh_of, solid_triangles
from score4.world.scene import Scene, TargetVolume

from ..errors import ConfigError
from ..shapes import BooleanShape, MeshShape, Shape
from ..shapes import G4Box as G4BoxShape
from ..shapes import G4Cons as G4ConsShape
from ..shapes import G4GenericPolycone as G4GenericPolyconeShape
from ..shapes import G4GenericPolyhedra as G4GenericPolyhedraShape
from ..shapes import G4Orb as G4OrbShape
from ..shapes import G4Sphere as G4SphereShape
from ..shapes import G4Trap as G4TrapShape
from ..shapes import G4Trd as G4TrdShape
from ..shapes import G4Tubs as G4TubsShape
from .boolean_cut import cut_boolean_solid
from .gdml import read_gdml
from .portal import PortalGeometry
from .solids import tessellated_solid


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


def g4_solid(g4, shape: Shape, name: str):
    """The Geant4 solid of a :mod:`score4.shapes` box, tube, cone, sphere, orb, G4Trd, G4Trap,
    generic polycone or polyhedra, or mesh (a G4TessellatedSolid) (the shapes score4 makes
    itself: boxes of the configuration and volumes cut for ``into`` layers)."""
    if isinstance(shape, G4BoxShape):
        return g4.G4Box(name, shape.dx, shape.dy, shape.dz)
    if isinstance(shape, G4TubsShape):
        return g4.G4Tubs(name, shape.rmin, shape.rmax, shape.dz, shape.sphi, shape.dphi)
    if isinstance(shape, G4SphereShape):
        return g4.G4Sphere(
            name, shape.rmin, shape.rmax, shape.sphi, shape.dphi, shape.stheta, shape.dtheta
        )
    if isinstance(shape, G4OrbShape):
        return g4.G4Orb(name, shape.r)
    if isinstance(shape, G4ConsShape):
        return g4.G4Cons(
            name,
            shape.rmin1,
            shape.rmax1,
            shape.rmin2,
            shape.rmax2,
            shape.dz,
            shape.sphi,
            shape.dphi,
        )
    if isinstance(shape, G4TrdShape):
        return g4.G4Trd(name, shape.dx1, shape.dx2, shape.dy1, shape.dy2, shape.dz)
    if isinstance(shape, G4TrapShape):
        return g4.G4Trap(
            name,
            shape.dz,
            shape.theta,
            shape.phi,
            shape.dy1,
            shape.dx1,
            shape.dx2,
            shape.alpha1,
            shape.dy2,
            shape.dx3,
            shape.dx4,
            shape.alpha2,
        )
    if isinstance(shape, MeshShape):  # a tessellated or extruded solid with a face moved
        solid = g4.G4TessellatedSolid(name)
        vec = g4.G4ThreeVector
        for a, b, c in shape.triangles:
            solid.AddFacet(g4.G4TriangularFacet(vec(*a), vec(*b), vec(*c), g4.ABSOLUTE))
        solid.SetSolidClosed(True)
        return solid
    if isinstance(shape, G4GenericPolyconeShape):
        return _generic_polycone(g4, shape, name)
    if isinstance(shape, G4GenericPolyhedraShape):
        return _generic_polycone(g4, shape, name)
    raise ConfigError(f"{name}: score4 builds no Geant4 solid of a {shape.kind}")


_GDML_SOLIDS: list = []  # the parsers and worlds of the solids read from GDML (kept alive)


def _generic_polycone(g4, shape: G4GenericPolyconeShape | G4GenericPolyhedraShape, name: str):
    """A G4GenericPolycone (or, with sides, a G4Polyhedra of (r, z) corners) of ``shape``:
    geant4_pybind binds its constructor's ``r`` and ``z`` arrays as single numbers, so the solid
    is read by Geant4's GDML parser from a small file of its own (unique volume names: Geant4's
    stores are global)."""
    tag = f"score4_pc{len(_GDML_SOLIDS)}"
    points = "".join(
        f'<rzpoint r="{r!r}" z="{z!r}"/>' for r, z in zip(shape.r, shape.z, strict=True)
    )
    world = 2 * max(max(abs(v) for v in shape.r + shape.z), 1.0) + 1.0
    kind, sides = "genericPolycone", ""
    if isinstance(shape, G4GenericPolyhedraShape):
        kind, sides = "genericPolyhedra", f' numsides="{shape.nsides}"'
    text = (
        '<?xml version="1.0" encoding="UTF-8"?><gdml><define/><materials/><solids>'
        f'<{kind} name="{tag}" startphi="{shape.sphi!r}" deltaphi="{shape.dphi!r}"{sides} '
        f'aunit="rad" lunit="mm">{points}</{kind}>'
        f'<box name="{tag}_w" x="{world!r}" y="{world!r}" z="{world!r}" lunit="mm"/></solids>'
        f'<structure><volume name="{tag}_lv"><materialref ref="G4_Galactic"/>'
        f'<solidref ref="{tag}"/></volume><volume name="{tag}_wl">'
        f'<materialref ref="G4_Galactic"/><solidref ref="{tag}_w"/><physvol name="{tag}_pv">'
        f'<volumeref ref="{tag}_lv"/></physvol></volume></structure>'
        f'<setup name="Default" version="1.0"><world ref="{tag}_wl"/></setup></gdml>'
    )
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / f"{tag}.gdml"
        path.write_text(text)
        parser, pv = read_gdml(g4, path)
    _GDML_SOLIDS.append((parser, pv))
    solid = pv.GetLogicalVolume().GetDaughter(0).GetLogicalVolume().GetSolid()
    solid.SetName(name)
    return solid


def cut_for_layers(g4, scene: Scene, target: TargetVolume, solid, name: str):
    """The solid of ``target`` less the slabs its ``into: true`` layers take, and the shift (in
    the volume's own frame) of its placement.

    The target's shape is made thinner behind each such face (:meth:`Shape.trimmed`: a box
    along the face normal, a tube along z or in radius, a cone's or polycone's wall along its
    normal, a sphere in radius) and moved back by half the cut, so its outer faces stay; a
    convex solid of flat facets (G4Trd, G4Trap, G4Polyhedra, a tessellated or extruded solid)
    becomes the G4TessellatedSolid of its facets clipped by each face's plane moved
    inward (:func:`score4.world.facets.clip_convex`), in place. Returns ``(solid, shift, objects
    to keep alive)``.
    """
    layers = [r for r in scene.layers_of(target.name) if r.config.into]
    if not layers:
        return solid, np.zeros(3), []
    cuts: dict[str, float] = {layer.config.face_name: layer.thickness for layer in layers}
    if isinstance(target.shape, BooleanShape):  # constituents cut, the boolean rebuilt
        cuts = boolean_cuts(layers, target.shape)  # a bore's cut widens it
        return cut_boolean_solid(g4, solid, target.shape, cuts, name, g4_solid)
    trimmed = None if target.shape is None else target.shape.trimmed(cuts)
    if trimmed is None:
        triangles = None if target.shape is None else solid_triangles(target.shape)
        if triangles is None or not is_convex(triangles):
            raise ConfigError(
                f"{target.name}: into: true needs a G4Box, a G4Tubs (end faces) or a convex "
                f"solid of flat facets, not a {target.solid}"
            )
        for layer in layers:  # each face's plane moved inward (the layer's shifted frame)
            n = target.rotation.T @ layer.frame.normal
            base = target.to_local(layer.frame.centre[None])[0]
            triangles = clip_convex(triangles, n, float(n @ base))
        cut = tessellated_solid(g4, mesh_of(triangles), name)
        return cut, np.zeros(3), [cut]
    cut = g4_solid(g4, trimmed[0], name)
    return cut, trimmed[1], [cut]
