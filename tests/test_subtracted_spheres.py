"""Rough layers on the sphere face of a subtracted G4Orb or G4Sphere
(score4.world.boolean_layers.turned_wall): the wall of a spherical dimple or cavity is the inner
face of a shell beside the subtracted solid, laid out as on any sphere face; with ``into:
true`` the subtracted solid grows by the layer's cut (score4.world.boolean_modes) and the layer
lies in the shell between the old sphere and the grown one. A copper box (20 mm) less an orb of
r 2 mm centred on its top (a dimple), once without and once with into, and a box less a G4Sphere
of r 2 mm at its centre (a closed cavity) with into: geantino paths from inside the holes out
through the rough walls against an analytic ray trace plus the bent patch bodies (1e-9 mm),
Geant4's volumes against the analytic ones, and Geant4's overlap check (deep)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from score4.inputs.config import parse_config
from score4.world.resolve import build_scene

from helpers.geantinos import geantino_config

# one worker per module: its world is written and its boolean face areas estimated once
pytestmark = pytest.mark.xdist_group("subtracted-spheres")

#: 0.1 mm patches of 10 x 10 pyramids 10 um high (a sphere of r 2 mm takes them)
SMALL = {"kind": "spikes", "nx": 10, "ny": 10, "width": "10 um", "height": "10 um"}
HALF, RADIUS = 10.0, 2.0
#: volume -> (its y in the world, mm; the hole's centre in the box; into)
HOLES = {
    "dimple": (-30.0, (0.0, 0.0, HALF), False),
    "dimple_into": (0.0, (0.0, 0.0, HALF), True),
    "cavity": (30.0, (0.0, 0.0, 0.0), True),
}


@pytest.fixture(scope="module")
def gdml(tmp_path_factory) -> Path:
    from helpers.boolean_worlds import write_box_holes

    def holes(s, reg) -> dict:
        cavity = s.Sphere("cavity_b", 0, RADIUS, 0, 2 * np.pi, 0, np.pi, reg)
        return {
            name: (cavity if name == "cavity" else s.Orb(f"{name}_b", RADIUS, reg), at, y)
            for name, (y, at, _into) in HOLES.items()
        }

    return write_box_holes(tmp_path_factory.mktemp("subspheres") / "spheres.gdml", holes, HALF)


def config(gdml: Path) -> dict:
    targets = [
        {"volume": v, "rough": [{"face": "second.outer", "surface": "s", "into": into}]}
        for v, (_y, _at, into) in HOLES.items()
    ]
    return geantino_config(
        gdml, {"s": SMALL}, targets, ("dimple", "first.-z"), output={"track_length": True}
    )


def _box_less_ball(o: np.ndarray, d: np.ndarray, centre: np.ndarray, r: float) -> float:
    """Path of the ray o + s d (s > 0, box frame) in the box less the ball |x - centre| < r."""
    with np.errstate(divide="ignore"):
        t1, t2 = (-HALF - o) / d, (HALF - o) / d
    s0, s1 = max(float(np.max(np.minimum(t1, t2))), 0.0), float(np.min(np.maximum(t1, t2)))
    if s1 <= s0:
        return 0.0
    q = o - centre
    b, c = q @ d, q @ q - r * r
    disc = b * b - c
    if disc <= 0:
        return s1 - s0
    c0, c1 = -b - math.sqrt(disc), -b + math.sqrt(disc)
    return (s1 - s0) - max(0.0, min(s1, c1) - max(s0, c0))


def test_sphere_faces_of_subtracted_solids(gdml, tmp_path):
    """Each layer's face is the hole's sphere (r 2 mm; grown by the layer's cut with into, the
    patches' tops where the old sphere was), its cells on the boolean's surface (the dimple's
    lower half only); geantinos from inside each hole out through its wall: Geant4's track
    length in the box equals the analytic path in the box less the (grown) ball plus the path
    in the bent patch bodies near the ray, 1e-9 mm; Geant4's volume of each box (a Monte Carlo
    estimate from 10^6 points) is the box less the (grown) ball to 2e-4."""
    from helpers.geantinos import assert_box_paths

    data = config(gdml)
    scene = build_scene(parse_config(data))
    radii = {}
    for name, (_y, at, into) in HOLES.items():
        layer = scene.layer(name, "second.outer")
        face = layer.ring_layout.face
        radii[name] = face.sphere_radius
        if into:  # the base on the grown sphere, the layer's top on the old one
            assert face.sphere_radius - layer.thickness == pytest.approx(RADIUS, abs=1e-9)
        else:
            assert face.sphere_radius == RADIUS
        on_face = layer.target.to_world(face.point(*_cell_uv(layer)))  # the leaf's frame
        corners = scene.target(name).to_local(on_face)
        assert (corners[:, 2] <= HALF + 1e-9).all()  # on the box's side of its top
        assert np.linalg.norm(corners - np.asarray(at), axis=1) == pytest.approx(
            radii[name], abs=1e-9
        )
        assert 0.4 < layer.rough_share <= 1.0
    rng = np.random.default_rng(5)
    per = 6
    starts, directions, owners = [], [], []
    for name, (y, at, _into) in HOLES.items():
        u = rng.normal(size=(per, 3))
        u /= np.linalg.norm(u, axis=1, keepdims=True)
        u[:, 2] = -np.abs(u[:, 2])  # down, into the box, for the dimples
        local = np.asarray(at) + np.array([0.0, 0.0, -0.5 if name != "cavity" else 0.0])
        starts.append(np.tile(local + np.array([0.0, y, 0.0]), (per, 1)))
        directions.append(u)
        owners += [name] * per
    crossed = assert_box_paths(
        data,
        scene,
        np.concatenate(starts),
        np.concatenate(directions),
        owners,
        lambda name, o, d: _box_less_ball(o, d, np.asarray(HOLES[name][1]), radii[name]),
        lambda name: (
            (2 * HALF) ** 3 - 4 / 3 * math.pi * radii[name] ** 3 / (1 if name == "cavity" else 2)
        ),
        tmp_path,
    )
    assert crossed >= len(owners) * 2 // 3


def _cell_uv(layer) -> tuple[np.ndarray, np.ndarray]:
    """(u, v) of the corners of the layer's kept cells."""
    lay = layer.ring_layout
    py = layer.patch_size[1]
    us, vs = [], []
    for j, i, _v, phi in layer.cells():
        if layer.cell_variants[j, i] < 0:
            continue
        us.append(phi + np.array([-0.5, 0.5, 0.5, -0.5]) * lay.step[j])
        vs.append(lay.v[j] + np.array([-0.5, -0.5, 0.5, 0.5]) * py)
    return np.concatenate(us), np.concatenate(vs)


@pytest.mark.deep
def test_sphere_faces_of_subtracted_solids_pass_the_overlap_check(gdml, tmp_path):
    """Geant4's overlap check (in its own process) finds no overlap in the three boxes."""
    import yaml

    from helpers.g4_geometry_check import assert_no_overlaps

    path = tmp_path / "spheres.yaml"
    path.write_text(yaml.safe_dump(config(gdml)))
    assert_no_overlaps(path)
