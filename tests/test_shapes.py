"""score4.shapes in numpy alone: exact areas and volumes against closed formulas, area-uniform
sampling (shares of the faces and uniformity inside a face), outward normals, volume sampling,
inside, serialisation and bad input (issue 17, item 4). Geant4's view: test_shapes_g4.py."""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest

from score4.errors import ConfigError
from score4.shapes import (
    INSIDE,
    OUTSIDE,
    SURFACE,
    BooleanShape,
    G4Box,
    G4Cons,
    G4GenericPolycone,
    G4GenericPolyhedra,
    G4Orb,
    G4Polycone,
    G4Polyhedra,
    G4Sphere,
    G4Trd,
    G4Tubs,
    MeshShape,
    PlacedShape,
    Transform,
    shape_from_dict,
)

TWO_PI = 2 * math.pi

SHAPES = {
    "box": G4Box(10, 20, 30),
    "trd": G4Trd(10, 5, 20, 8, 15),
    "tubs": G4Tubs(5, 35, 10, 0.3, 4.0),
    "cons": G4Cons(2, 10, 5, 20, 15, 0.5, 5.0),
    "sphere": G4Sphere(5, 10, 0.2, 2.0, 0.3, 1.0),
    "orb": G4Orb(12),
    "polycone": G4Polycone(0.5, 4.0, [0, 10, 10, 20, 30], [0, 0, 3, 5, 5], [10, 20, 15, 20, 20]),
    "generic_polycone": G4GenericPolycone(0, TWO_PI, [0, 10, 12, 12, 6, 0], [0, 0, 3, 20, 25, 25]),
    "polyhedra": G4Polyhedra(0.2, 3.0, 3, [0, 10], [3, 3], [10, 8]),
    "generic_polyhedra": G4GenericPolyhedra(0, TWO_PI, 8, [0, 10, 10, 0], [0, 0, 10, 20]),
}

# Closed formulas per face, written from the geometry (not from score4.shapes)
c_tubs = (4.0 * (35 + 5) * 20, 0.5 * 4.0 * (35**2 - 5**2))
sl_out, sl_in = math.hypot(10, 30), math.hypot(3, 30)
FACE_FORMULAS = {
    "box": {"+x": 2400, "-x": 2400, "+y": 1200, "-y": 1200, "+z": 800, "-z": 800},
    "tubs": {
        "outer": 4.0 * 35 * 20,
        "inner": 4.0 * 5 * 20,
        "+z": c_tubs[1],
        "-z": c_tubs[1],
        "phi_start": 600,
        "phi_end": 600,
    },
    "cons": {
        "outer": 5.0 * sl_out * 15,
        "inner": 5.0 * sl_in * 3.5,
        "-z": 2.5 * (100 - 4),
        "+z": 2.5 * (400 - 25),
        "phi_start": 0.5 * 30 * (10 + 20) - 0.5 * 30 * (2 + 5),
        "phi_end": 0.5 * 30 * (10 + 20) - 0.5 * 30 * (2 + 5),
    },
    "sphere": {
        "outer": 100 * 2.0 * (math.cos(0.3) - math.cos(1.3)),
        "inner": 25 * 2.0 * (math.cos(0.3) - math.cos(1.3)),
        "phi_start": 0.5 * 1.0 * 75,
        "phi_end": 0.5 * 1.0 * 75,
        "theta_start": 2.0 * math.sin(0.3) * 0.5 * 75,
        "theta_end": 2.0 * math.sin(1.3) * 0.5 * 75,
    },
    "orb": {"outer": 4 * math.pi * 144},
}
VOLUME_FORMULAS = {
    "box": 48000,
    "trd": 30 * (800 + 4 * 15 * 28 + 160) / 6,  # prismatoid: h (A1 + 4 Amid + A2) / 6
    "tubs": 0.5 * 4.0 * (35**2 - 5**2) * 20,
    "cons": 5.0 / 3 * 30 * (100 + 200 + 400 - (4 + 10 + 25)) / 2,
    "sphere": 2.0 * (math.cos(0.3) - math.cos(1.3)) * (1000 - 125) / 3,
    "orb": 4 / 3 * math.pi * 12**3,
    "generic_polyhedra": 8 * math.tan(math.pi / 8) * 10**2 * 10 * math.cos(math.pi / 8) ** 2
    + 8 * math.tan(math.pi / 8) * (10 * math.cos(math.pi / 8)) ** 2 * 10 / 3,
}


@pytest.mark.parametrize("name", sorted(FACE_FORMULAS))
def test_face_areas_match_closed_formulas(name):
    shape = SHAPES[name]
    for face, area in FACE_FORMULAS[name].items():
        assert shape.face_areas[face] == pytest.approx(area, rel=1e-12), face
    assert set(shape.faces) == set(FACE_FORMULAS[name])


@pytest.mark.parametrize("name", sorted(VOLUME_FORMULAS))
def test_volumes_match_closed_formulas(name):
    assert SHAPES[name].volume == pytest.approx(VOLUME_FORMULAS[name], rel=1e-12)


N_SHARES = 1_000_000


@pytest.mark.parametrize("name", sorted(SHAPES))
def test_sampled_face_shares_match_the_exact_areas(name):
    """Shares of 10^6 points per face against area shares; tolerance 4 binomial sigma, which is
    below 0.2 % absolute (0.5 % of any face holding >= 40 % of the area)."""
    shape = SHAPES[name]
    s = shape.sample_surface(np.random.default_rng(3), N_SHARES)
    counts = np.bincount(s.face, minlength=len(shape.faces)) / N_SHARES
    for k, face in enumerate(shape.faces):
        p = shape.face_areas[face] / shape.area
        sigma = math.sqrt(max(p * (1 - p), 1e-12) / N_SHARES)
        assert abs(counts[k] - p) < 4 * sigma + 1e-12, (face, counts[k], p)


@pytest.mark.parametrize("name", sorted(SHAPES))
def test_points_are_on_the_surface_with_outward_normals(name):
    shape = SHAPES[name]
    s = shape.sample_surface(np.random.default_rng(4), 20000)
    assert (shape.inside(s.position) == SURFACE).all()
    np.testing.assert_allclose(np.linalg.norm(s.normal, axis=1), 1, atol=1e-12)
    # a step of 1e-6 mm along the normal leaves the solid, against it enters (points within
    # 1e-6 mm of an edge, probability ~1e-7 here, would be the only exceptions)
    assert (shape.inside(s.position + 1e-6 * s.normal) == OUTSIDE).all()
    assert (shape.inside(s.position - 1e-6 * s.normal) == INSIDE).all()


def test_points_are_uniform_inside_curved_faces():
    """Within a face: a cone's slant (density proportional to r), a sphere zone (uniform in
    cos theta), an annulus; fractions of 2 10^5 points below a cut, 4 sigma."""
    rng = np.random.default_rng(5)
    n = 200_000
    cons = SHAPES["cons"]
    p = cons.sample_surface(rng, n, "outer").position
    # outer slant from r = 10 (z = -15) to r = 20 (z = 15): area below z = 0 is
    # L/2 * (10 + 15) / 2 against L * (10 + 20) / 2
    share = (10 + 15) / (2 * 30)
    got = (p[:, 2] < 0).mean()
    assert abs(got - share) < 4 * math.sqrt(share * (1 - share) / n)
    sphere = SHAPES["sphere"]
    p = sphere.sample_surface(rng, n, "outer").position
    zc = 10 * 0.5 * (math.cos(0.3) + math.cos(1.3))  # middle of the zone's z range
    assert abs((p[:, 2] > zc).mean() - 0.5) < 4 * math.sqrt(0.25 / n)
    tubs = SHAPES["tubs"]
    p = tubs.sample_surface(rng, n, "+z").position
    r = np.hypot(p[:, 0], p[:, 1])
    share = (20**2 - 5**2) / (35**2 - 5**2)
    assert abs((r < 20).mean() - share) < 4 * math.sqrt(share * (1 - share) / n)
    phi = np.mod(np.arctan2(p[:, 1], p[:, 0]) - 0.3, TWO_PI)
    assert phi.max() <= 4.0 + 1e-12
    assert abs((phi < 1.0).mean() - 0.25) < 4 * math.sqrt(0.1875 / n)


@pytest.mark.parametrize("name", sorted(SHAPES))
def test_volume_points_are_uniform(name):
    """Volume samples: all inside; the share in the lower half of the bounding box equals the
    share of uniform box points that are inside there (two independent estimates, 4 sigma)."""
    shape = SHAPES[name]
    rng = np.random.default_rng(6)
    v = shape.sample_volume(rng, 100_000)
    assert (shape.inside(v) == INSIDE).all()
    lo, hi = shape.bounding_box()
    assert (v >= lo - 1e-9).all()
    assert (v <= hi + 1e-9).all()
    axis = int(np.argmax(hi - lo))
    cut = 0.5 * (lo[axis] + hi[axis]) + 0.1 * (hi[axis] - lo[axis])
    box = lo + rng.random((400_000, 3)) * (hi - lo)
    kept = box[shape.inside(box) == INSIDE]
    p_box = (kept[:, axis] < cut).mean()
    p_vol = (v[:, axis] < cut).mean()
    sigma = math.sqrt(p_box * (1 - p_box) * (1 / len(v) + 1 / len(kept)))
    assert abs(p_vol - p_box) < 4 * sigma + 1e-12
    # and the volume itself: the kept share of the bounding box (4 sigma)
    frac = len(kept) / len(box)
    box_volume = float(np.prod(hi - lo))
    assert (
        abs(frac * box_volume - shape.volume)
        <= 4 * box_volume * math.sqrt(frac * (1 - frac) / len(box)) + 1e-9 * box_volume
    )


def test_groups_and_selections():
    pc = SHAPES["generic_polycone"]
    assert pc.faces == ("seg_0", "seg_1", "seg_2", "seg_3", "seg_4")
    assert pc.groups["bottom"] == ("seg_0",)
    assert pc.groups["top"] == ("seg_4",)
    assert set(pc.groups["outer"]) == {"seg_1", "seg_2", "seg_3"}
    assert pc.face_area("outer") == pytest.approx(
        math.pi * (0 + 0)
        + TWO_PI * 0.5 * (10 + 12) * math.hypot(2, 3)
        + TWO_PI * 12 * 17
        + TWO_PI * 0.5 * (12 + 6) * math.hypot(6, 5),
        rel=1e-12,
    )
    assert pc.resolve_faces(["top", "seg_1"]) == ("seg_4", "seg_1")
    with pytest.raises(
        ConfigError,
        match=r"face: G4GenericPolycone has no face 'side'; its faces: "
        r"seg_0, .*; groups: outer, top, bottom, all$",
    ):
        pc.resolve_faces("side")


def test_contour_solids_name_faces_like_geant4_keeps_them():
    """Geant4 merges collinear corners and orders the contour itself: a polycone and the same
    contour as a generic polycone, given in the other direction, have the same faces."""
    pc = G4Polycone(0, TWO_PI, [0, 5, 10], [0, 0, 0], [10, 15, 20])  # (15, 5) is on a line
    gp = G4GenericPolycone(0, TWO_PI, [0, 0, 20, 10], [0, 10, 10, 0])
    np.testing.assert_allclose(pc.canonical(), gp.canonical())
    assert pc.faces == gp.faces == ("seg_0", "seg_1", "seg_2")


def test_round_trip_through_dict():
    for shape in SHAPES.values():
        again = shape_from_dict(shape.to_dict())
        assert again == shape
    mesh = MeshShape(
        G4Box(1, 2, 3).patches[0].triangles.tolist() * 1
        + [t for p in G4Box(1, 2, 3).patches[1:] for t in p.triangles.tolist()]
    )
    again = shape_from_dict(mesh.to_dict())
    assert again.area == mesh.area == pytest.approx(88.0)
    boolean = BooleanShape("union", G4Box(1, 1, 1), G4Orb(1), Transform(np.eye(3), [1, 0, 0]))
    assert shape_from_dict(boolean.to_dict()).to_dict() == boolean.to_dict()


def test_mesh_shape_of_a_box():
    box = G4Box(1, 2, 3)
    tris = np.concatenate([p.triangles for p in box.patches])
    mesh = MeshShape(tris)
    assert mesh.volume == pytest.approx(48.0, rel=1e-12)
    assert mesh.area == pytest.approx(88.0, rel=1e-12)
    rng = np.random.default_rng(7)
    pts = rng.uniform(-4, 4, (5000, 3))
    assert np.array_equal(mesh.inside(pts), box.inside(pts))
    s = mesh.sample_surface(rng, 2000)
    assert (box.inside(s.position) == SURFACE).all()


def test_boolean_union_of_two_half_tubes_is_the_tube():
    union = BooleanShape(
        "union", G4Tubs(0, 35, 10, 0, math.pi), G4Tubs(0, 35, 10, math.pi, math.pi)
    )
    tube = G4Tubs(0, 35, 10)
    assert union.area == pytest.approx(tube.area, rel=1e-12)  # the cut faces are inside
    assert union.face_areas["first.phi_start"] == 0
    s = union.sample_surface(np.random.default_rng(8), 20000)
    assert (tube.inside(s.position) == SURFACE).all()
    assert abs(np.mean(s.position[:, 2] > 9.999999) - tube.face_areas["+z"] / tube.area) < 0.01


def test_boolean_subtraction_areas_within_their_errors():
    """A box minus a through-going cylinder: exact area 2400 - 2 pi 16 + 2 pi 4 * 20."""
    cut = BooleanShape("subtraction", G4Box(10, 10, 10), G4Tubs(0, 4, 20))
    exact = 2400 - 2 * math.pi * 16 + TWO_PI * 4 * 20
    err = math.sqrt(sum(e * e for e in cut.face_area_errors.values()))
    assert 0 < err < 0.002 * exact
    assert abs(cut.area - exact) < 4 * err
    s = cut.sample_surface(np.random.default_rng(9), 20000)
    assert (cut.inside(s.position) == SURFACE).all()
    assert (cut.inside(s.position + 1e-6 * s.normal) == OUTSIDE).all()  # the bore faces inwards
    assert abs(cut.volume - (8000 - math.pi * 16 * 20)) < 4 * cut.volume_error


def test_boolean_area_estimate_is_per_face_on_demand_and_kept(tmp_path, monkeypatch):
    """A face's area is estimated when it is read, alone, with its own seed: the same number
    whichever faces were read before it and in which order. The estimate is made once per face
    and solid description: a new shape of the same parameters takes it from memory, another
    process from the folder (one file per face, read back with the same numbers); another
    placement of the cut is another solid, estimated anew; a damaged file or one of another
    format is estimated anew."""
    from score4.shapes import boolean

    def cut(dx: float = 0.0) -> BooleanShape:
        at = Transform(np.eye(3), [dx, 0, 0])
        return BooleanShape("subtraction", G4Box(10, 10, 10), G4Tubs(0, 4, 20), at, n_area=4000)

    made: list[tuple[str, str]] = []
    real = BooleanShape._estimate_area

    def counted(self, name):
        made.append((self.area_key, name))
        return real(self, name)

    monkeypatch.setattr(BooleanShape, "_estimate_area", counted)
    monkeypatch.setattr(boolean, "_AREAS", {})
    first = replace(cut(), area_cache=tmp_path)
    assert "first.+z" in first.face_areas
    assert len(first.face_areas) == len(first.faces)
    assert made == []  # names and length without estimating
    bore = first.face_areas["second.outer"]
    assert made == [(first.area_key, "second.outer")]
    assert len(list(tmp_path.glob("*.json"))) == 1
    areas = dict(first.face_areas)
    assert areas["second.outer"] == bore
    assert len(made) == len(first.faces) == len(list(tmp_path.glob("*.json")))
    assert cut().face_areas == areas  # from memory
    assert len(made) == len(first.faces)

    monkeypatch.setattr(boolean, "_AREAS", {})  # a new process, no folder: the same numbers,
    other = cut()  # in the reverse order
    assert {f: other.face_areas[f] for f in reversed(other.faces)} == areas
    made.clear()
    monkeypatch.setattr(boolean, "_AREAS", {})  # as in a new process: from the files
    again = replace(cut(), area_cache=tmp_path)
    assert again.face_areas == areas
    assert again.face_area_errors == first.face_area_errors
    assert made == []

    moved = replace(cut(1.0), area_cache=tmp_path)
    assert moved.area_key != first.area_key
    assert moved.face_seed("first.+z") != first.face_seed("first.+z")
    assert moved.face_areas["first.+z"] != areas["first.+z"]
    assert len(made) == 1
    files = {p.read_text(): p for p in tmp_path.glob("*.json")}
    path = next(p for t, p in files.items() if moved.area_key in t)
    path.write_text("{not json")  # a damaged file: estimated
    monkeypatch.setattr(boolean, "_AREAS", {})
    assert (
        replace(cut(1.0), area_cache=tmp_path).face_areas["first.+z"]
        == moved.face_areas["first.+z"]
    )
    assert len(made) == 2
    stale = json.loads(path.read_text())
    path.write_text(json.dumps({**stale, "format": boolean.AREA_FORMAT - 1, "area": 1.0}))
    monkeypatch.setattr(boolean, "_AREAS", {})  # another format's file: estimated
    assert (
        replace(cut(1.0), area_cache=tmp_path).face_areas["first.+z"]
        == moved.face_areas["first.+z"]
    )
    assert len(made) == 3


def test_placed_shape_moves_points_and_normals():
    r = np.array([[0, -1, 0], [1, 0, 0], [0, 0, 1.0]])
    placed = PlacedShape(G4Box(1, 2, 3), Transform(r, [10, 0, 0]))
    s = placed.sample_surface(np.random.default_rng(10), 1000, "+x")
    np.testing.assert_allclose(s.position[:, 1], 1.0)  # +x of the box now faces +y
    np.testing.assert_allclose(s.normal, np.tile([0, 1.0, 0], (1000, 1)), atol=1e-12)
    assert (placed.inside(s.position) == SURFACE).all()


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda: G4Box(1, -2, 3), "G4Box: dy must be > 0"),
        (lambda: G4Tubs(5, 4, 1), "G4Tubs: need 0 <= rmin < rmax"),
        (lambda: G4GenericPolycone(0, TWO_PI, [0, 1, 1], [0, 0, 0]), "encloses no area"),
        (lambda: G4GenericPolycone(0, TWO_PI, [0, 3, 1, 3], [0, 0, 2, 2]), "crosses itself"),
        (lambda: G4Polycone(0, TWO_PI, [0, 1], [2, 0], [1, 1]), "rmin must be <= rmax"),
        (lambda: G4Polyhedra(0, TWO_PI, 0, [0, 1], [0, 0], [1, 1]), "nsides must be"),
        (lambda: G4Orb(1).face_sampler("top"), "G4Orb has no face 'top'"),
        (lambda: shape_from_dict({"type": "G4Nothing"}), "unknown type 'G4Nothing'"),
        (lambda: Transform(np.diag([1.0, 1, -1])), "reflections are not supported"),
        (lambda: Transform(np.diag([1.0, 1, 1 + 1e-4])), "rotation must be orthonormal"),
    ],
)
def test_bad_input_names_the_rule(make, message):
    with pytest.raises(ConfigError, match=message):
        make()


def _rotation(rng: np.random.Generator) -> np.ndarray:
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    return q * np.sign(np.linalg.det(q))


def test_relative_to_is_the_placement_in_the_mother_frame():
    """``t.relative_to(m)`` is ``m``'s inverse composed with ``t``, computed as the GDML builder
    did before (bit for bit: R_m^T R_t and (t_t - t_m) R_m)."""
    rng = np.random.default_rng(7)
    mother = Transform(_rotation(rng), rng.normal(size=3) * 50)
    placed = Transform(_rotation(rng), rng.normal(size=3) * 50)
    local = placed.relative_to(mother)
    x = rng.normal(size=(20, 3)) * 10
    assert np.allclose((mother @ local).apply(x), placed.apply(x), rtol=0, atol=1e-12)
    assert np.array_equal(local.rotation, mother.rotation.T @ placed.rotation)
    assert np.array_equal(
        local.translation, (placed.translation - mother.translation) @ mother.rotation
    )


def test_frames_and_boxes_apply_shapes_transform_bit_for_bit():
    """FaceFrame, GDML Instance and OrientedBox go through shapes.Transform; the results are the
    bits of the formulas each had of its own before."""
    from score4.world.obb import OrientedBox
    from score4.world.scene import FaceFrame

    rng = np.random.default_rng(11)
    r, c = _rotation(rng), rng.normal(size=3) * 100
    x = rng.normal(size=(50, 3)) * 7
    frame = FaceFrame(c, r, (3.0, 4.0))
    assert np.array_equal(frame.to_world(x), c + x @ r.T)
    assert np.array_equal(frame.to_local(x), (x - c) @ r)
    box = OrientedBox(c, r, np.array([1.0, 2.0, 3.0]))
    signs = np.array([[a, b, d] for a in (-1, 1) for b in (-1, 1) for d in (-1, 1)], float)
    assert np.array_equal(box.corners(), c + (signs * box.half) @ r.T)
    inside = np.abs((x - c) @ r) < box.half - 1e-9
    assert np.array_equal(box.contains(x), inside.all(axis=1))


def test_shapes_never_import_geant4():
    import subprocess
    import sys

    code = (
        "import sys, score4.shapes, numpy as np; "
        "score4.shapes.G4Tubs(1, 2, 3).sample_surface(np.random.default_rng(0), 10); "
        "assert 'geant4_pybind' not in sys.modules"
    )
    subprocess.run([sys.executable, "-c", code], check=True)
