"""The distance to some faces of a boolean solid, each as it is on the boolean (the part the
other constituents keep: score4.world.kept_face_distance), against an independent brute force
(a dense grid on the constituent's face, kept where a hair outside the boolean along the face's
outward normal and a hair inside against it, nearest node by a k-d tree) and against closed forms
where the kept face has one: a cylinder with a cut (a subtraction, as LEGEND's P00664B), a disk
with a post on it (a union, the stack of tests/helpers/boolean_worlds.py), and (deep) P00664B
itself as legend-pygeom-hpges writes it."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial import cKDTree

from score4.inputs.config import parse_config
from score4.shapes import BooleanShape, G4Box, G4Tubs, Transform
from score4.shapes.base import INSIDE, OUTSIDE, SURFACE, PlaneTriangles, Revolved
from score4.shapes.boolean import PROBE
from score4.world.boolean_distance import leaf_face_distance
from score4.world.kept_face_distance import TOLERANCE, KeptFaceDistance, beyond
from score4.world.resolve import build_scene

from helpers.boolean_worlds import write_world

#: the cut cylinder: r 35 mm, z from -15 to 15 mm, less the part beyond x = 30 mm
R, HZ, CUT = 35.0, 15.0, 30.0


@pytest.fixture(scope="module")
def shapes() -> dict:
    cut = BooleanShape(
        "subtraction",
        G4Tubs(0.0, R, HZ),
        G4Box(2.5, R, HZ + 5),
        Transform(np.eye(3), np.array([CUT + 2.5, 0.0, 0.0])),
    )
    stack = BooleanShape(
        "union", G4Tubs(0.0, 10.0, 5.0), G4Tubs(0.0, 7.0, 5.0), Transform(np.eye(3), [0, 0, 10.0])
    )
    return {"cut": cut, "stack": stack}


@pytest.fixture(scope="module")
def ppc(tmp_path_factory):
    """P00664B of tests/helpers/boolean_worlds.py (a polycone less a box beyond x = 30 mm)."""
    gdml = write_world(tmp_path_factory.mktemp("kept") / "boolean.gdml")
    data = {
        "physics": "lite",
        "world": {"gdml": str(gdml)},
        "targets": [{"volume": "ppc"}],
        "source": {"particle": "geantino", "energy": "1 MeV", "volume": "ppc"},
        "run": {"events": 1, "seed": 1},
    }
    return build_scene(parse_config(data)).target("ppc").shape


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


def check_against_grid(shape, faces: tuple[str, ...], h: float, cut: bool) -> None:
    """Points in the solid: the distance to the listed faces as they are on the boolean is at
    most the nearest kept node's of a grid of spacing ``h`` (1e-9 mm) and at least that less 2 h
    (the nearest kept point's grid cell, or the next one at the rim, has a kept node); with
    ``cut`` (another constituent cuts the faces) the old lower bound (the constituent's faces
    whole) is off by more than that at many points, else it is the same."""
    p = inside_points(shape, 1500, seed=3)
    got = KeptFaceDistance(shape, faces)(p)
    ref = brute(shape, faces, p, h)
    assert np.all(got <= ref + 1e-9)
    assert np.all(ref - got <= 2 * h)
    whole = leaf_face_distance(shape, faces, p)
    assert np.all(got >= whole - TOLERANCE)  # rim chords: within TOLERANCE of the face
    if cut:
        assert (got - whole > 4 * h).mean() > 0.05
    else:  # the post's foot circle, on the disk, is a rim: chords
        np.testing.assert_allclose(got, whole, rtol=0, atol=TOLERANCE)


@pytest.mark.parametrize(
    ("volume", "faces", "h", "cut"),
    [
        ("cut", ("second.-x",), 0.2, True),  # the cut face: the box's face in the cylinder
        ("cut", ("first.outer",), 0.2, True),  # the wall, cut
        ("stack", ("first.+z",), 0.05, True),  # the disk's top less the post's foot (a union)
        ("stack", ("first.outer", "second.outer"), 0.1, False),  # the two walls, each whole
    ],
)
def test_distance_to_kept_faces_matches_a_dense_grid(shapes, volume, faces, h, cut):
    check_against_grid(shapes[volume], faces, h, cut)


@pytest.mark.deep
@pytest.mark.parametrize(
    ("faces", "h"), [(("second.-x",), 0.1), (("first.seg_2", "first.seg_3"), 0.2)]
)
def test_distance_to_kept_faces_of_p00664b_matches_a_dense_grid(ppc, faces, h):
    """P00664B's cut face, and its wall and top taper, both cut: as above."""
    check_against_grid(ppc, faces, h, True)


def test_distance_to_the_cut_wall_and_the_disk_top_in_closed_form(shapes):
    """Closed forms, to score4's stated TOLERANCE (1e-6 mm): the cut cylinder's wall (r 35 mm,
    |z| <= 15 mm) kept where x <= 30 mm: the wall's own distance where the point's azimuth is
    kept, else the nearer of the two cut lines x = 30, y = +-sqrt(35^2 - 30^2); the stack's disk
    top (z = 5 mm) kept for 7 <= r <= 10: the nearest of the annulus."""
    cut = shapes["cut"]
    p = inside_points(cut, 4000, seed=5)
    rho, phi = np.hypot(p[:, 0], p[:, 1]), np.arctan2(p[:, 1], p[:, 0])
    dz = np.maximum(np.abs(p[:, 2]) - HZ, 0.0)
    alpha = math.acos(CUT / R)
    lines = [
        np.hypot(np.hypot(p[:, 0] - CUT, p[:, 1] - sign * R * math.sin(alpha)), dz)
        for sign in (1, -1)
    ]
    expected = np.where(np.abs(phi) >= alpha, np.hypot(R - rho, dz), np.minimum(*lines))
    got = KeptFaceDistance(cut, ("first.outer",))(p)
    assert (np.abs(phi) < alpha).sum() > 50
    np.testing.assert_allclose(got, expected, rtol=0, atol=TOLERANCE)
    stack = shapes["stack"]
    p = inside_points(stack, 4000, seed=6)
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


def test_flush_outer_faces_of_a_union_are_both_kept():
    """A box (half width 10 mm) with a smaller box (half width 5 mm) overlapping its +x edge,
    their +z and -y faces flush (z = 10 mm, y = -10 mm): where the two lie on each other both
    are the union's surface, so the big box's top is kept whole (its distance the rectangle's,
    closed form), and so is the small box's; the grid brute force (the face sampler's probe
    test) agrees. A face lying on another part from inside (the small box's -x face in the big
    box) stays off the surface there."""
    flush = BooleanShape(
        "union", G4Box(10.0, 10.0, 10.0), G4Box(5.0, 5.0, 5.0), Transform(np.eye(3), [10, -5, 5])
    )
    p = inside_points(flush, 3000, seed=8)
    x = np.clip(p[:, 0], -10.0, 10.0) - p[:, 0]
    y = np.clip(p[:, 1], -10.0, 10.0) - p[:, 1]
    got = KeptFaceDistance(flush, ("first.+z",))(p)
    np.testing.assert_allclose(got, np.sqrt(x * x + y * y + (10 - p[:, 2]) ** 2), atol=1e-9)
    x = np.clip(p[:, 0], 5.0, 15.0) - p[:, 0]
    y = np.clip(p[:, 1], -10.0, 0.0) - p[:, 1]
    got = KeptFaceDistance(flush, ("second.+z", "second.-y"))(p)
    expected = np.minimum(
        np.sqrt(x * x + y * y + (10 - p[:, 2]) ** 2),
        np.sqrt(x * x + (p[:, 1] + 10) ** 2 + (np.clip(p[:, 2], 0.0, 10.0) - p[:, 2]) ** 2),
    )
    np.testing.assert_allclose(got, expected, atol=1e-9)
    for faces in [("first.+z", "first.-y"), ("second.+z", "second.-y")]:
        check_against_grid(flush, faces, 0.2, False)
    assert np.isinf(KeptFaceDistance(flush, ("second.-x",))(p)).all()


def test_the_lazy_probe_test_is_the_boolean_inside_test():
    """kept_face_distance.beyond (a boolean's second constituent measured only where its first
    leaves the answer open) says exactly what ``shape.inside`` says, INSIDE and OUTSIDE, for
    points on and within Geant4's tolerance of the surfaces of nested unions, subtractions and
    intersections with turned and shifted constituents (the rim build's probe test)."""
    c, s = math.cos(0.3), math.sin(0.3)
    turn = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    inner = BooleanShape(
        "intersection", G4Box(10.0, 10.0, 10.0), G4Tubs(0.0, 12.0, 8.0), Transform(turn, [1, -2, 3])
    )
    holed = BooleanShape("subtraction", inner, G4Tubs(0.0, 4.0, 20.0), Transform(turn.T, [2, 0, 0]))
    shape = BooleanShape("union", holed, G4Box(3.0, 3.0, 3.0), Transform(np.eye(3), [0, 0, 9.0]))
    rng = np.random.default_rng(11)
    parts = []  # points on every constituent's faces, in the union's frame
    for leaf, at in (
        (G4Box(10.0, 10.0, 10.0), Transform()),
        (G4Tubs(0.0, 12.0, 8.0), inner.transform),
        (G4Tubs(0.0, 4.0, 20.0), holed.transform),
        (G4Box(3.0, 3.0, 3.0), shape.transform),
    ):
        parts.append(at.apply(leaf.sample_surface(rng, 3000).position))
    p = np.concatenate(parts)
    p = np.concatenate([p, p + rng.normal(0.0, 1e-9, p.shape), p + rng.normal(0.0, 1e-7, p.shape)])
    code = shape.inside(p)
    assert (code == SURFACE).sum() > 1000
    assert (code == INSIDE).sum() > 1000
    assert (code == OUTSIDE).sum() > 1000
    np.testing.assert_array_equal(beyond(shape, p, inside=True), code == INSIDE)
    np.testing.assert_array_equal(beyond(shape, p, inside=False), code == OUTSIDE)


def test_a_flush_face_with_a_hole_keeps_the_hole_rim():
    """A box (half width 10 mm) inside a wider box of the same height (their +z faces flush at
    z = 10 mm), less a tube (r 1 mm, 1 mm deep) through the top at x = 3 mm: the small box's
    top is kept where it lies on the wide box's (the probe test) but not over the hole. Its
    pieces' corners all lie on the wide box's top; the hole's rim is found all the same
    (before, a piece whose corners were all flush was taken whole at any size: points under
    the hole measured to the square's edges). Closed form: the square less the disk, 1e-6 mm."""
    union = BooleanShape("union", G4Box(10.0, 10.0, 10.0), G4Box(12.0, 12.0, 10.0), Transform())
    holed = BooleanShape(
        "subtraction", union, G4Tubs(0.0, 1.0, 1.0), Transform(np.eye(3), [3.0, 0.0, 10.0])
    )
    rng = np.random.default_rng(12)
    p = np.column_stack([rng.uniform(-11.5, 11.5, (3000, 2)), rng.uniform(7.0, 8.9, 3000)])
    p[:400, :2] = np.array([3.0, 0.0]) + rng.uniform(-1.0, 1.0, (400, 2))  # under the hole
    p = p[holed.inside(p) == INSIDE]
    dx, dy = np.clip(p[:, 0], -10, 10) - p[:, 0], np.clip(p[:, 1], -10, 10) - p[:, 1]
    r = np.hypot(p[:, 0] - 3.0, p[:, 1])
    dz = 10.0 - p[:, 2]
    expected = np.where(r < 1.0, np.hypot(1.0 - r, dz), np.sqrt(dx * dx + dy * dy + dz * dz))
    under = r < 1.0
    assert under.sum() > 20
    got = KeptFaceDistance(holed, ("first.first.+z",))(p)
    np.testing.assert_allclose(got, expected, rtol=0, atol=TOLERANCE)
