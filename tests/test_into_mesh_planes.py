"""``into: true`` on a mesh face spread over several planes (issue 24): a G4TessellatedSolid of
more than MAX_NAMED_PLANES planes (a curved surface cut into facets) keeps one face, ``mesh``;
subtracted, it grows by the layer's thickness on every plane (``MeshShape.moved``: each vertex
where its planes meet again), refused in one line where a corner's planes, all moved, no longer
meet in a point. Before, such a face was not moved and ``into`` on it was refused.

Numpy tests of the moved mesh (fast); (deep) a copper box less a blind hole cut as a prism of
101 sides: geantino paths against an analytic trace of the box less the grown prism plus the
patch bodies (1e-9 mm), Geant4's volume against the analytic one."""

from __future__ import annotations

import math

import numpy as np
import pytest

from score4.errors import ConfigError
from score4.inputs.config import parse_config
from score4.shapes import MeshShape
from score4.world.resolve import build_scene

SIDES, APOTHEM, HALF_H = 101, 6.0, 5.0  # the prism hole: sides, apothem and half height, mm
HALF = 10.0  # the box's half width, mm
PYRAMIDS = {"kind": "spikes", "nx": 2, "ny": 2, "width": "100 um", "height": "20 um"}


def prism(n: int = SIDES, a: float = APOTHEM, h: float = HALF_H) -> np.ndarray:
    """Outward-wound triangles of a right prism over a regular n-gon of apothem ``a`` (its
    side k's outward normal at azimuth (k + 1) 2 pi / n), z from -h to h, its ends fans."""
    ang = (np.arange(n) + 0.5) * 2 * np.pi / n
    p = a / math.cos(math.pi / n) * np.column_stack([np.cos(ang), np.sin(ang)])
    tris = []
    for k in range(n):
        q0, q1 = p[k], p[(k + 1) % n]
        lo0, lo1, hi1, hi0 = [*q0, -h], [*q1, -h], [*q1, h], [*q0, h]
        tris += [[lo0, lo1, hi1], [lo0, hi1, hi0], [[0, 0, -h], lo1, lo0], [[0, 0, h], hi0, hi1]]
    return np.array(tris, float)


def side_normals(n: int = SIDES) -> np.ndarray:
    ang = (np.arange(n) + 1) * 2 * np.pi / n
    return np.column_stack([np.cos(ang), np.sin(ang), np.zeros(n)])


def test_a_face_of_many_planes_moves_every_plane():
    """The prism of 101 sides is one face ``mesh``; moved outward by t = 30 um every side lies
    t further out (apothem a + t) and both ends t further along z (1e-12 mm), the prism's
    volume that of the grown one."""
    shape = MeshShape.by_planes(prism())
    assert shape.faces == ("mesh",)
    t = 0.03
    moved, shift = shape.moved({"mesh": -t})
    assert np.all(shift == 0)
    v = moved.triangles.reshape(-1, 3)
    np.testing.assert_allclose(v[:, 2].min(), -HALF_H - t, atol=1e-12)
    np.testing.assert_allclose(v[:, 2].max(), HALF_H + t, atol=1e-12)
    # every vertex off the axis lies on two sides' planes moved out by t
    rim = v[np.hypot(v[:, 0], v[:, 1]) > 1.0]
    reach = (rim @ side_normals().T).max(axis=1)
    np.testing.assert_allclose(reach, APOTHEM + t, atol=1e-12)
    area = SIDES * (APOTHEM + t) ** 2 * math.tan(math.pi / SIDES)
    assert moved.volume == pytest.approx(area * 2 * (HALF_H + t), rel=1e-12)


def test_a_corner_whose_moved_planes_miss_each_other_is_one_line():
    """A pyramid over a rectangle (1 x 2 mm, 1 mm high) as one face: its apex joins four planes
    of two slopes, which moved alike meet in no point: refused in one line naming the corner."""
    base = [[-0.5, -1, 0], [0.5, -1, 0], [0.5, 1, 0], [-0.5, 1, 0]]
    apex = [0.0, 0.0, 1.0]
    tris = [[base[k], base[(k + 1) % 4], apex] for k in range(4)]
    tris += [[base[0], base[2], base[1]], [base[0], base[3], base[2]]]
    shape = MeshShape(np.array(tris, float))
    with pytest.raises(ConfigError, match=r"corner \(0, 0, 1\) mm joins 3 other planes") as err:
        shape.moved({"mesh": -0.01})
    assert "\n" not in str(err.value)


def faceted_config(folder) -> dict:
    """The world (written in ``folder``) and configuration of the deep tests: a copper box
    less the prism hole from its top, ``into`` on the hole's face ``mesh``."""
    from helpers.boolean_worlds import write_box_holes

    tri = prism()
    verts, index = np.unique(tri.reshape(-1, 3), axis=0, return_inverse=True)

    def holes(s, reg):
        mesh = [verts.tolist(), index.reshape(-1, 3).tolist()]
        return {"faceted": (s.TessellatedSolid("faceted_h", mesh, reg), [0, 0, HALF], 0.0)}

    gdml = write_box_holes(folder / "faceted.gdml", holes, HALF)
    return {
        "physics": "lite",
        "world": {"gdml": str(gdml)},
        "surfaces": {"p": PYRAMIDS},
        "targets": [
            {"volume": "faceted", "rough": [{"face": "second.mesh", "surface": "p", "into": True}]}
        ],
        "source": {
            "particle": "geantino",
            "energy": "1 MeV",
            "surface": {"volume": "faceted", "face": "first.-z"},
        },
        "run": {"events": 10, "seed": 3},
        "output": {"track_length": True},
    }


@pytest.mark.deep
def test_geantino_paths_through_a_grown_faceted_hole(tmp_path):
    """A box less a blind prism hole of 101 sides from its top (z = 5 .. 10 mm of the box) with
    ``into`` on the hole's one face ``mesh``: a layer per plane (the floor and the sides), the
    prism grown by the layers' thickness t on every plane. Geantinos from the hole's axis aimed
    at its sides and floor: Geant4's track length in the box equals the analytic path in the
    box less the grown prism (its planes, the slab method) plus the path in the patch bodies,
    1e-9 mm, and Geant4's volume the analytic one to 2e-4."""
    from helpers.geantinos import assert_box_paths

    data = faceted_config(tmp_path)
    scene = build_scene(parse_config(data))
    layers = scene.layers_of("faceted")
    assert len(layers) == SIDES + 1  # the floor and every side (the top lies above the box)
    t = layers[0].thickness
    assert all(layer.thickness == t for layer in layers)
    # the grown hole: sides at apothem a + t, floor at z = HALF - HALF_H - t (box frame)
    normals = np.vstack([side_normals(), [[0, 0, -1.0]]])
    offsets = np.concatenate([np.full(SIDES, APOTHEM + t), [-(HALF - HALF_H - t)]])

    def convex_path(o, d, n, h) -> float:
        nd, no = n @ d, n @ o
        lo, hi = 0.0, np.inf
        for a, b, c in zip(nd, no, h, strict=True):
            if abs(a) < 1e-15:
                if b > c:
                    return 0.0
                continue
            s = (c - b) / a
            lo, hi = (max(lo, s), hi) if a < 0 else (lo, min(hi, s))
        return max(hi - lo, 0.0)

    box_n = np.vstack([np.eye(3), -np.eye(3)])
    box_h = np.full(6, HALF)

    def traced(_, o, d):
        both = convex_path(o, d, np.vstack([box_n, normals]), np.concatenate([box_h, offsets]))
        return convex_path(o, d, box_n, box_h) - both

    rng = np.random.default_rng(4)
    n = 16
    phi = rng.uniform(0, 2 * np.pi, n)
    z = np.concatenate([rng.uniform(6.0, 9.0, n - 4), np.full(4, HALF - HALF_H)])
    rho = np.concatenate([np.full(n - 4, APOTHEM), rng.uniform(1.0, 5.0, 4)])
    aim = np.column_stack([rho * np.cos(phi), rho * np.sin(phi), z])
    start = np.tile([0.0, 0.0, 9.5], (n, 1))
    d = aim - start
    d /= np.linalg.norm(d, axis=1)[:, None]
    grown = SIDES * (APOTHEM + t) ** 2 * math.tan(math.pi / SIDES) * (HALF_H + t)
    crossed = assert_box_paths(
        data,
        scene,
        start,
        d,
        ["faceted"] * n,
        traced,
        lambda _: (2 * HALF) ** 3 - grown,
        tmp_path,
    )
    assert crossed >= 8


@pytest.mark.deep
def test_geant4_finds_no_overlap_in_a_grown_faceted_hole(tmp_path):
    """``score4 geometry check`` on the box less the grown prism with its 102 layers."""
    import yaml

    from helpers.g4_geometry_check import assert_no_overlaps

    (tmp_path / "faceted.yaml").write_text(yaml.safe_dump(faceted_config(tmp_path)))
    assert_no_overlaps(tmp_path / "faceted.yaml")
