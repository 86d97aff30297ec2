"""The distance to some faces of a boolean solid, each as it is on the boolean (the part the
other constituents keep: score4.world.kept_face_distance), against an independent brute force
(a dense grid on the constituent's face, kept where a hair outside the boolean along the face's
outward normal and a hair inside against it, nearest node by a k-d tree) and against closed forms
where the kept face has one: P00664B (a polycone less a box: a subtraction) and the stack (a disk
with a post on it: a union) of tests/helpers/boolean_worlds.py."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial import cKDTree

from score4.inputs.config import parse_config
from score4.shapes.base import INSIDE, OUTSIDE, PlaneTriangles, Revolved
from score4.shapes.boolean import PROBE
from score4.world.boolean_distance import leaf_face_distance
from score4.world.kept_face_distance import TOLERANCE, KeptFaceDistance
from score4.world.resolve import build_scene

from helpers.boolean_worlds import write_world


@pytest.fixture(scope="module")
def shapes(tmp_path_factory) -> dict:
    gdml = write_world(tmp_path_factory.mktemp("kept") / "boolean.gdml")
    data = {
        "physics": "lite",
        "world": {"gdml": str(gdml)},
        "targets": [{"volume": "ppc"}, {"volume": "stack"}],
        "source": {"particle": "geantino", "energy": "1 MeV", "surface": {"volume": "ppc"}},
        "run": {"events": 1, "seed": 1},
    }
    scene = build_scene(parse_config(data))
    return {v: scene.target(v).shape for v in ("ppc", "stack")}


def dense_face(shape, face: str, h: float) -> np.ndarray:
    """Nodes of a grid of spacing <= ``h`` on the constituent's face ``face`` of boolean
    ``shape`` (its frame) that lie on the boolean's surface (the probe test of the boolean's face
    sampler: a hair along the outward normal is outside the boolean, a hair against it inside)."""
    clip = shape.face_clip(face)
    index = clip.leaf.faces.index(clip.face)
    pts, normals = [], []
    for patch in clip.leaf.patches:
        if patch.face != index:
            continue
        if isinstance(patch, PlaneTriangles):
            for tri, n in zip(patch.triangles, patch.normals, strict=True):
                k = int(np.ceil(np.linalg.norm(tri - np.roll(tri, 1, 0), axis=1).max() / h))
                i, j = np.meshgrid(np.arange(k + 1), np.arange(k + 1))
                ok = i + j <= k
                u, v = i[ok] / k, j[ok] / k
                pts.append(tri[0] + u[:, None] * (tri[1] - tri[0]) + v[:, None] * (tri[2] - tri[0]))
                normals.append(np.tile(n, (len(u), 1)))
        else:
            assert isinstance(patch, Revolved)
            length = math.hypot(patch.r2 - patch.r1, patch.z2 - patch.z1)
            nt = int(np.ceil(length / h))
            nphi = int(np.ceil(max(patch.r1, patch.r2) * patch.dphi / h))
            t, phi = np.meshgrid(
                np.linspace(0, 1, nt + 1), patch.phi0 + np.linspace(0, patch.dphi, nphi + 1)
            )
            t, phi = t.ravel(), phi.ravel()
            r = patch.r1 + t * (patch.r2 - patch.r1)
            pts.append(
                np.column_stack(
                    [r * np.cos(phi), r * np.sin(phi), patch.z1 + t * (patch.z2 - patch.z1)]
                )
            )
            nr = patch.nr * np.column_stack([np.cos(phi), np.sin(phi)])
            normals.append(np.column_stack([nr, np.full(len(t), patch.nz)]))
    x = clip.transform.apply(np.concatenate(pts))
    n = clip.transform.apply_vectors(np.concatenate(normals)) * (-1.0 if clip.flipped else 1.0)
    keep = (shape.inside(x + PROBE * n) == OUTSIDE) & (shape.inside(x - PROBE * n) == INSIDE)
    return x[keep]


def brute(shape, faces: tuple[str, ...], p: np.ndarray, h: float) -> np.ndarray:
    nodes = np.concatenate([dense_face(shape, f, h) for f in faces])
    return cKDTree(nodes).query(p)[0]


def inside_points(shape, n: int, seed: int) -> np.ndarray:
    lo, hi = shape.bounding_box()
    p = np.random.default_rng(seed).uniform(lo, hi, (n, 3))
    return p[shape.inside(p) == INSIDE]


@pytest.mark.parametrize(
    ("volume", "faces", "h"),
    [
        # the cut face (the box's face where the crystal is); the wall and top taper, both cut
        pytest.param("ppc", ("second.-x",), 0.1, marks=pytest.mark.deep),
        pytest.param("ppc", ("first.seg_2", "first.seg_3"), 0.2, marks=pytest.mark.deep),
        ("stack", ("first.+z",), 0.05),  # the disk's top less the post's foot (a union)
        ("stack", ("first.outer", "second.outer"), 0.1),  # the two walls, each whole
    ],
)
def test_distance_to_kept_faces_matches_a_dense_grid(shapes, volume, faces, h):
    """Points in the solid: the distance to the listed faces as they are on the boolean is at
    most the nearest kept node's of a grid of spacing ``h`` (1e-9 mm) and at least that less 2 h
    (the nearest kept point's grid cell, or the next one at the rim, has a kept node); the old
    lower bound (the constituent's faces whole) is off by more than that at many points."""
    shape = shapes[volume]
    p = inside_points(shape, 2000, seed=3)
    got = KeptFaceDistance(shape, faces)(p)
    ref = brute(shape, faces, p, h)
    assert np.all(got <= ref + 1e-9)
    assert np.all(ref - got <= 2 * h)
    whole = leaf_face_distance(shape, faces, p)
    assert np.all(got >= whole - TOLERANCE)  # rim chords: within TOLERANCE of the face
    if volume == "stack" and faces[0] == "first.outer":
        # walls nothing cuts: as before (the post's foot circle, on the disk, is a rim)
        np.testing.assert_allclose(got, whole, rtol=0, atol=TOLERANCE)
    else:
        assert (got - whole > 4 * h).mean() > 0.05


def test_distance_to_the_cut_wall_and_the_disk_top_in_closed_form(shapes):
    """Closed forms, to score4's stated TOLERANCE (1e-6 mm): P00664B's wall (r 35 mm, z 2 to
    28 mm) kept where x <= 30 mm: the wall's own distance where the point's azimuth is kept, else
    the nearer of the two cut lines x = 30, y = +-sqrt(35^2 - 30^2); the stack's disk top (z = 5
    mm) kept for 7 <= r <= 10: the nearest of the annulus."""
    ppc = shapes["ppc"]
    p = inside_points(ppc, 6000, seed=5)
    rho, phi = np.hypot(p[:, 0], p[:, 1]), np.arctan2(p[:, 1], p[:, 0])
    dz = np.maximum(np.maximum(2.0 - p[:, 2], p[:, 2] - 28.0), 0.0)
    alpha = math.acos(30 / 35)
    lines = [
        np.hypot(np.hypot(p[:, 0] - 30.0, p[:, 1] - sign * 35 * math.sin(alpha)), dz)
        for sign in (1, -1)
    ]
    expected = np.where(np.abs(phi) >= alpha, np.hypot(35 - rho, dz), np.minimum(*lines))
    got = KeptFaceDistance(ppc, ("first.seg_2",))(p)
    assert (np.abs(phi) < alpha).sum() > 100
    np.testing.assert_allclose(got, expected, rtol=0, atol=TOLERANCE)
    stack = shapes["stack"]
    p = inside_points(stack, 6000, seed=6)
    rho, z = np.hypot(p[:, 0], p[:, 1]), p[:, 2]
    expected = np.hypot(np.clip(rho, 7.0, 10.0) - rho, z - 5.0)
    got = KeptFaceDistance(stack, ("first.+z",))(p)
    np.testing.assert_allclose(got, expected, rtol=0, atol=TOLERANCE)
    assert (rho < 6).sum() > 100  # under and in the post: to the post's foot's rim


def test_a_face_the_other_part_covers_whole_is_nowhere(shapes):
    """The post's foot (second.-z) lies on the disk's top: no part of it is the union's
    surface, and no point has a distance to it."""
    stack = shapes["stack"]
    p = inside_points(stack, 500, seed=7)
    assert np.isinf(KeptFaceDistance(stack, ("second.-z",))(p)).all()
