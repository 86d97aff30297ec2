"""The activeness distance to a curved rough face of a boolean
(score4.world.rough_face_distance, curved layers): a rod's wall through a copper box (a union, as
``cross`` of tests/helpers/boolean_worlds.py), rough where it leaves the box, matches a brute
force over every facet of the patch tops and a 5 um grid on the flat rest (the wall the box
leaves bare, outside the patch footprints: the rings' azimuth gap included)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.spatial import cKDTree

from score4.inputs.config import parse_config
from score4.shapes.base import SURFACE
from score4.shapes.mesh_shape import _tri_distance
from score4.world.activeness import target_distances
from score4.world.resolve import build_scene

from helpers.boolean_worlds import copper_world_text

#: 0.4 mm patches of 5 x 5 pyramids, 20 um high
FINE = {"kind": "spikes", "nx": 5, "ny": 5, "width": "80 um", "height": "20 um"}
H = 0.005  # the brute force's grid on the flat rest, mm
WINDOW = 0.15  # its azimuth window (and the patch tops'), rad


@pytest.fixture
def gdml(tmp_path) -> Path:
    """``cross``: a copper box (20 mm) with a rod (r 5 mm, 40 mm) through it along z."""
    solids = (
        '<box name="world_s" x="200" y="200" z="200" lunit="mm"/>'
        '<box name="cross_a" x="20" y="20" z="20" lunit="mm"/>'
        '<tube name="cross_b" rmin="0" rmax="5" z="40" deltaphi="360" aunit="deg" lunit="mm"/>'
        '<union name="cross_s"><first ref="cross_a"/><second ref="cross_b"/></union>'
    )
    path = tmp_path / "cross.gdml"
    path.write_text(copper_world_text(solids, {"cross": (0.0, 0.0, 0.0)}))
    return path


def brute(layer, target, local: np.ndarray) -> np.ndarray:
    """Every facet of the patch tops within WINDOW and 2.5 mm of the points' z, and a grid of
    H on the face where the boolean keeps it outside the patch footprints (the nearest node
    lies within H / sqrt(2) of any point of the rest)."""
    lay, cells = layer.ring_layout, np.asarray(layer.cell_variants)
    face, px = lay.face, layer.patch_size[0]
    zmin, zmax = local[:, 2].min() - 2.5, local[:, 2].max() + 2.5
    tops = []
    for j, _, k, phi in layer.cells():
        if zmin <= lay.ring_z(j) <= zmax and abs(np.mod(phi + np.pi, 2 * np.pi) - np.pi) < WINDOW:
            t = layer.bent(k, j).top_triangles.reshape(-1, 3)
            c, s = np.cos(phi), np.sin(phi)
            rot = np.column_stack([c * t[:, 0] - s * t[:, 1], s * t[:, 0] + c * t[:, 1]])
            tops.append(np.column_stack([rot, t[:, 2] + lay.ring_z(j)]).reshape(-1, 3, 3))
    best = _tri_distance(local, np.concatenate(tops)).min(axis=1)
    v0, v1 = np.sort(face.locate(np.array([[5.0, 0.0, zmin], [5.0, 0.0, zmax]]))[1])
    v = np.arange(v0, v1, H)
    u = np.arange(-WINDOW, WINDOW, H / 5.0)  # the rod's radius: 5 mm
    uu, vv = np.meshgrid(u, v)
    p = face.point(uu.ravel(), vv.ravel())
    on = layer.on_boolean
    kept = on.shape.inside(on.transform.inverse_apply(target.to_world(p))) == SURFACE
    j, i, xy = lay.locate(p)
    patch = j >= 0
    patch[patch] = cells[j[patch], i[patch]] >= 0
    patch &= np.abs(xy[:, 0]) <= px / 2
    rest = p[kept & ~patch]
    return np.minimum(best, cKDTree(rest).query(local)[0])


def test_distance_to_a_rods_wall_through_a_box_is_exact(gdml):
    """Points within 0.5 mm of the rod's wall (r 5 mm) and 1 mm of the box's +z face (z 10 mm),
    near azimuth 0 (where each ring's gap without cells lies), seed 7: the distance to the wall
    as it is on the union matches the brute force to H / sqrt(2) + 1e-6 mm. Before, the rings
    inside the box (no patch: flat cells hidden in the copper) counted as the face, too near by
    0.9 mm here (the old code fails this test)."""
    data = {
        "physics": "lite",
        "world": {"gdml": str(gdml)},
        "surfaces": {"p": FINE},
        "targets": [
            {
                "volume": "cross",
                "rough": [{"face": "second.outer", "surface": "p"}],
                "activeness": [{"fccd": "1 mm", "dlf": 0.5, "faces": ["second.outer"]}],
            }
        ],
        "source": {"particle": "geantino", "energy": "1 MeV", "volume": "cross"},
        "run": {"events": 1, "seed": 1},
    }
    scene = build_scene(parse_config(data))
    (distance,) = [d for d in target_distances(scene) if d is not None]
    layer, target = scene.layer("cross", "second.outer"), scene.target("cross")
    assert distance.boolean is not None
    rng = np.random.default_rng(7)
    m = 400
    z = rng.uniform(9.0, 11.0, m)
    rho = 5.0 + rng.uniform(-0.5, 0.5, m)
    phi = rng.uniform(-0.04, 0.04, m)
    local = np.column_stack([rho * np.cos(phi), rho * np.sin(phi), z])
    world = target.to_world(local)
    inside = distance.to_surface(world) > 0  # the copper and the patches
    local, world = local[inside][:150], world[inside][:150]
    assert len(local) == 150
    ref = brute(layer, target, local)
    got = distance.boolean.rough_face("second.outer", world)
    np.testing.assert_allclose(got, ref, atol=H / np.sqrt(2) + 1e-6, rtol=0)
    assert ref.max() > 0.9  # points deep in the box, up to ~1 mm from the bare wall
