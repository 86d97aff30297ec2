"""How closely bent rough layers follow curved faces: the gap of the layer's base, per solid.

    .venv/bin/python tools/figures/curved_gaps.py

Generates the table of docs/geometry.md (check ``curved-gaps``): for faces of the solids of
real detectors (a BEGe-like cylinder wall, a thin cylinder, a bore, a cone, an ICPC-like polycone
taper) and three surfaces, the layer score4 builds (numpy only, no Geant4) and its measured gap:
the largest distance between the patches' base and the true surface (score4.world.curved: the floor
facets are chords of the circle, the patch is lifted by the deepest one), against the limit
max(1 % of the roughness height, 0.1 um).
"""

from __future__ import annotations

import argparse

import numpy as np

from score4.inputs.config import GdmlVolume, RoughFace
from score4.shapes import G4Cons, G4GenericPolycone, G4Tubs, Shape, Transform
from score4.surface.spec import build_surface, parse_surface_spec
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
        G4GenericPolycone(0.0, 2 * np.pi, [0, 38, 38, 30, 0], [0, 0, 60, 80, 80]),
        "seg_2",
    ),
]


def target(shape: Shape, face: str) -> TargetVolume:
    lo, hi = shape.bounding_box()
    config = GdmlVolume(volume="v", rough=[RoughFace(face=face, surface="s")])
    return TargetVolume("v", 0, config, "G4_Ge", shape.kind, shape, Transform(), lo, hi)


def main() -> None:
    argparse.ArgumentParser(description=__doc__.split("\n")[0]).parse_args()
    surfaces = {k: build_surface(parse_surface_spec(v)) for k, v in SURFACES.items()}
    print("| face | radius mm | surface | gap um | limit um |")
    print("| --- | --- | --- | --- | --- |")
    for label, shape, face in FACES:
        for name, surface in surfaces.items():
            t = target(shape, face)
            rough = t.config.rough[0]  # type: ignore[union-attr]
            layer = make_layer({"s": surface}, t, 0, rough)
            r = float(layer.ring_layout.radius.min())  # type: ignore[attr-defined]
            limit = gap_limit(surface.max_height)
            gap = layer.gap  # type: ignore[attr-defined]
            print(f"| {label} {face} | {r:.4g} | {name} | {gap * 1e3:.2g} | {limit * 1e3:.2g} |")


if __name__ == "__main__":
    main()
