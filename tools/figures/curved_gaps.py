"""How closely bent rough layers follow curved faces: the gap of the layer's base, per solid.

    .venv/bin/python tools/figures/curved_gaps.py

Generates the table of docs/geometry.md (check ``curved-gaps``): for faces of the solids of
real detectors (a BEGe-like cylinder wall, a thin cylinder, a bore, a cone, an ICPC-like polycone
taper, a sphere and a spherical cavity) and three surfaces, the layer score4 builds (numpy only,
no Geant4) and its measured gap: the largest distance between the patches' base and the true
surface (score4.world.curved: the floor facets are chords of the circle, the patch is lifted by
the deepest one), against the limit
max(1 % of the roughness height, 0.1 um).

With ``--facets``, a second table (check ``facet-gaps``) does the same for flat faces of any
outline (score4.world.facets: a G4Trd's and a G4Trap's slanted faces, the six sides of a
G4Polyhedra face, the eight planes of an octahedral G4TessellatedSolid): the gap is the largest
distance of the patch cells' base corners from the solid's surface (the base lies in the face's
plane), and the rough share the part of the face the whole cells cover (the rest stays flat).
"""

from __future__ import annotations

import argparse

import numpy as np

from score4.inputs.config import GdmlVolume, RoughFace
from score4.shapes import (
    G4Cons,
    G4GenericPolycone,
    G4Orb,
    G4Polyhedra,
    G4Sphere,
    G4Trap,
    G4Trd,
    G4Tubs,
    MeshShape,
    Shape,
    Transform,
)
from score4.surface.spec import build_surface, parse_surface_spec
from score4.world.boolean_layers import target_layers
from score4.world.curved import gap_limit
from score4.world.scene import TargetVolume, make_layer

SURFACES = {
    "10 um pyramids, 0.5 mm patch": {
        "kind": "spikes", "nx": 50, "ny": 50, "width": "10 um", "height": "10 um"
    },
    "10 um pyramids, 2 mm patch": {
        "kind": "spikes", "nx": 200, "ny": 200, "width": "10 um", "height": "10 um"
    },
    "1 um Gaussian field, 0.5 mm": {
        "kind": "random", "model": "gaussian", "nx": 250, "ny": 250, "pitch": "2 um",
        "sq": "1 um", "corr_length": "10 um", "periodic": True, "seed": 1,
    },
}  # fmt: skip

FACES: list[tuple[str, Shape, str]] = [
    ("G4Tubs r 40 mm (BEGe side)", G4Tubs(0.0, 40.0, 20.0), "outer"),
    ("G4Tubs r 5 mm", G4Tubs(0.0, 5.0, 5.0), "outer"),
    ("G4Tubs bore r 5 mm", G4Tubs(5.0, 40.0, 20.0), "inner"),
    ("G4Cons r 30-40 mm", G4Cons(0.0, 30.0, 0.0, 40.0, 20.0), "outer"),
    (
        "G4GenericPolycone taper",
        G4GenericPolycone(0.0, 2 * np.pi, (0, 38, 38, 30, 0), (0, 0, 60, 80, 80)),
        "seg_2",
    ),
    ("G4Orb r 10 mm", G4Orb(10.0), "outer"),
    ("G4Sphere cavity r 5 mm", G4Sphere(5.0, 40.0, 0.0, 2 * np.pi, 0.5, 2.0), "inner"),
]


def _octahedron(a: float) -> MeshShape:
    verts = np.array([[a, 0, 0], [-a, 0, 0], [0, a, 0], [0, -a, 0], [0, 0, a], [0, 0, -a]], float)
    tris = []
    for sx, ix in ((1, 0), (-1, 1)):
        for sy, iy in ((1, 2), (-1, 3)):
            for sz, iz in ((1, 4), (-1, 5)):
                tri = [ix, iy, iz]
                tris.append(tri if sx * sy * sz > 0 else tri[::-1])
    return MeshShape(verts[np.array(tris)])


FACETS: list[tuple[str, Shape, str]] = [
    ("G4Trd 30 x 24 -> 16 x 12 mm", G4Trd(15.0, 8.0, 12.0, 6.0, 20.0), "+x"),
    ("G4Trap", G4Trap(30, 0.1, 0.2, 20, 10, 15, 0.1, 10, 5, 7.5, 0.1), "+x"),
    (
        "G4Polyhedra hexagon, 6 sides",
        G4Polyhedra(0.0, 2 * np.pi, 6, (-20, 20), (0, 0), (16, 16)),
        "seg_1",
    ),
    ("G4TessellatedSolid octahedron, 8 planes", _octahedron(18.0), "mesh"),
]  # fmt: skip


def target(shape: Shape, face: str) -> TargetVolume:
    lo, hi = shape.bounding_box()
    config = GdmlVolume(volume="v", rough=[RoughFace(face=face, surface="s")])
    return TargetVolume("v", 0, config, "G4_Ge", shape.kind, shape, Transform(), lo, hi)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--facets", action="store_true", help="the table of flat faces")
    args = parser.parse_args()
    surfaces = {k: build_surface(parse_surface_spec(v)) for k, v in SURFACES.items()}
    if args.facets:
        facet_table(surfaces)
        return
    print("| face | radius mm | surface | gap um | limit um |")
    print("| --- | --- | --- | --- | --- |")
    for label, shape, face in FACES:
        for name, surface in surfaces.items():
            t = target(shape, face)
            rough = t.config.rough[0]
            layer = make_layer({"s": surface}, t, 0, rough)
            r = layer.ring_layout.min_radius  # type: ignore[attr-defined]
            limit = gap_limit(surface.max_height)
            gap = layer.gap  # type: ignore[attr-defined]
            print(f"| {label} {face} | {r:.4g} | {name} | {gap * 1e3:.2g} | {limit * 1e3:.2g} |")


def facet_table(surfaces: dict) -> None:
    print("| flat face | surface | layers | gap um | rough share % |")
    print("| --- | --- | --- | --- | --- |")
    for label, shape, face in FACETS:
        for name, surface in surfaces.items():
            t = target(shape, face)
            layers = target_layers({"s": surface}, t, 0, t.config.rough[0])
            gap, rough, area = 0.0, 0.0, 0.0
            for layer in layers:
                px, py = layer.patch_size
                c = layer.cell_centres()[layer.mask]
                corners = np.concatenate(
                    [c + np.array([sx * px, sy * py]) for sx in (-0.5, 0.5) for sy in (-0.5, 0.5)]
                )
                base = layer.frame.to_world(np.column_stack([corners, np.zeros(len(corners))]))
                gap = max(gap, float(np.abs(shape.signed_distance(base)).max()))
                rough += layer.rough_share * layer.face_area
                area += layer.face_area
            share = 100 * rough / area
            print(f"| {label} {face} | {name} | {len(layers)} | {gap * 1e3:.2g} | {share:.4g} |")


if __name__ == "__main__":
    main()
