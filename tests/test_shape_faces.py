"""The face interface of score4.shapes: frames, parametrisation, inverse and distance."""

from __future__ import annotations

import math

import numpy as np
import pytest

from score4.errors import ConfigError
from score4.shapes import G4Box, G4Cons, G4GenericPolycone, G4Tubs
from score4.shapes.faces import AnnulusFace, PlaneFace, RevolvedFace


def test_box_faces_follow_the_face_axes_and_fill_their_rectangle():
    box = G4Box(1.0, 2.0, 3.0)
    for name in box.faces:
        face = box.face(name)
        assert isinstance(face, PlaneFace)
        assert face.rectangle
        assert face.planar
        r = face.frame.rotation
        assert np.allclose(np.cross(r[:, 0], r[:, 1]), r[:, 2])  # right-handed
        assert face.area == pytest.approx(box.face_areas[name], rel=1e-12)
        # the frame's origin is on the face and its normal points out of the box
        assert box.signed_distance(face.frame.translation)[0] == pytest.approx(0.0, abs=1e-12)
        out = face.frame.translation + 1e-3 * r[:, 2]
        assert box.signed_distance(out)[0] == pytest.approx(1e-3)
    assert box.face("+x").size == (4.0, 6.0)  # u = y, v = z


@pytest.mark.parametrize(
    "shape",
    [
        G4Tubs(2.0, 5.0, 3.0),
        G4Tubs(0.0, 5.0, 3.0, 0.3, 2.0),
        G4Cons(1.0, 4.0, 2.0, 6.0, 3.0),
        G4GenericPolycone(0.0, 2 * math.pi, [0, 20, 30, 30, 10, 0], [0, 0, 10, 40, 45, 45]),
    ],
)
def test_curved_faces_round_trip_and_give_the_true_distance(shape):
    rng = np.random.default_rng(1)
    for name in shape.faces:
        face = shape.face(name)
        assert face.area == pytest.approx(shape.face_areas[name], rel=1e-12)
        if not isinstance(face, RevolvedFace):
            continue
        (u0, u1), (v0, v1) = face.extent
        u, v = rng.uniform(u0, u1, 200), rng.uniform(v0, v1, 200)
        p, n = face.point(u, v), face.normal(u, v)
        assert np.allclose(np.linalg.norm(n, axis=1), 1)
        assert np.abs(shape.signed_distance(p)).max() < 1e-9  # on the solid's surface
        h = rng.uniform(-0.1, 0.1, 200)
        uu, vv, hh = face.locate(p + h[:, None] * n)
        assert np.allclose(uu, u, atol=1e-12)
        assert np.allclose(vv, v, atol=1e-12)
        assert np.allclose(hh, h, atol=1e-12)
        # outside along the normal the solid's own safety agrees (convex side of the face)
        step = p + 1e-3 * n
        assert np.all(shape.signed_distance(step) > 0)


def test_end_faces_are_rings_with_the_box_convention():
    tubs = G4Tubs(1.0, 4.0, 2.0)
    top, bottom = tubs.face("+z"), tubs.face("-z")
    assert isinstance(top, AnnulusFace)
    assert top.full_circle
    assert not top.rectangle
    assert top.size == (8.0, 8.0)
    assert np.allclose(top.frame.rotation, np.eye(3))
    assert np.allclose(bottom.frame.rotation[:, 1], [0, -1, 0])
    assert top.area == pytest.approx(math.pi * 15.0)
    cells = np.array([[0.0, 0.0], [2.5, 0.0], [3.9, 0.0]])
    assert top.covers(cells, (0.2, 0.2)).tolist() == [False, True, False]


def test_unknown_face_lists_the_faces():
    with pytest.raises(ConfigError, match=r"no face '\+x'; its faces: -z, outer, \+z; groups: all"):
        G4Tubs(0.0, 4.0, 2.0).face("+x")
