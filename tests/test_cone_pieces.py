"""Envelope pieces of a cone's wall cut by a boolean's other part (issue 24): a cone through a
box (a union) takes two pieces, each ending exactly where its outer ring's cells end along the
generator. Geant4's overlap check and geantino paths through both pieces are deep, in one test with
the rod's wall: test_boolean_faces.py::test_a_wall_through_a_box_in_geant4."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from test_boolean_faces import CONE_CROSS_ROUGH, FINE, config

from score4.geometry.check import _cell_corners, curved_cells_tile
from score4.inputs.config import parse_config
from score4.shapes.base import INSIDE
from score4.world.resolve import build_scene
from score4.world.scene import CurvedRoughLayer

from helpers.boolean_worlds import write_cone_cross

# one worker per module: its world is written and its boolean face areas estimated once
pytestmark = pytest.mark.xdist_group("cone-pieces")


@pytest.fixture(scope="module")
def gdml(tmp_path_factory) -> Path:
    return write_cone_cross(tmp_path_factory.mktemp("cone") / "conecross.gdml")


def test_a_cones_wall_through_a_box_takes_two_pieces(gdml):
    """The cone (r 4 to 6 mm over 40 mm) runs through a box (20 mm): its rings inside the box
    keep no cell, and the envelope is two pieces over the full circle, one from each end of the
    cone to the z plane where its last kept ring's cells end (their corners, exactly, as
    generator length), short of the box's face; every cell lies in a piece (exact tiling), no
    point of the envelope is inside the solid. On main before, the piece spanned the cone's
    length, through the box, and the layer was refused."""
    scene = build_scene(parse_config(config(gdml, CONE_CROSS_ROUGH, FINE)))
    wall = scene.layer("conecross", "second.outer")
    assert isinstance(wall, CurvedRoughLayer)
    assert wall.pieces is not None
    a, b = sorted(wall.pieces, key=lambda p: p.v0)
    (_, da, va0, va1, a_normal), (_, db, vb0, vb1, b_normal) = a, b
    assert (a_normal, b_normal) == (False, False)  # full rings: the pieces end on z planes
    assert da == db == pytest.approx(2 * np.pi, abs=1e-12)
    lay = wall.ring_layout
    face = lay.face
    (_, _), (fv0, fv1) = face.extent
    assert (va0, vb1) == (fv0, fv1)
    kept = np.flatnonzero((wall.cell_variants >= 0).any(axis=1))
    gap = np.flatnonzero(np.diff(kept) > 1)
    assert len(gap) == 1
    below, above = int(kept[gap[0]]), int(kept[gap[0] + 1])

    def v_of(j: int) -> np.ndarray:  # the cell's corners as generator length (z planes)
        return (_cell_corners(wall, j)[:, 2] - face._mid[1]) / face._tangent[1]

    assert va1 == pytest.approx(v_of(below).max(), abs=1e-12)
    assert vb0 == pytest.approx(v_of(above).min(), abs=1e-12)
    # the cells reach beyond their ring's band, by the layer's thickness along the slanted normal
    # (here ~1 um: the cone's slant is 1 in 20)
    reach = wall.thickness * abs(face.nrz[1]) / abs(face._tangent[1])
    band = lay.patch_size[1] + lay.row_gap
    assert np.ptp(v_of(below)) == pytest.approx(band + reach, abs=1e-12)
    # the box's faces at z = -10 and +10: both pieces stop short of them
    z = face._mid[1] + np.array([va1, vb0]) * face._tangent[1]
    assert z[0] < -10
    assert z[1] > 10
    on = wall.on_boolean
    codes = on.shape.inside(on.transform.inverse_apply(wall.shell_points(n_v=41)))
    assert not (codes == INSIDE).any()
    assert not curved_cells_tile(wall)[1]
    wall.pieces = [a._replace(v1=va1 - 1e-6), b]  # a cell's reach cut off
    assert any("outside the pieces" in p for p in curved_cells_tile(wall)[1])
