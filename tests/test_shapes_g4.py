"""Shapes against Geant4 itself (issue 17, item 4): areas, volumes, Inside, SurfaceNormal, and
shapes read from live solids, for solids built by constructors and read from GDML written by
pyg4ometry, including a LEGEND HPGe detector from legend-pygeom-hpges."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

from score4.shapes import (
    BooleanShape,
    G4Box,
    G4Cons,
    G4GenericPolycone,
    G4GenericPolyhedra,
    G4Orb,
    G4Polycone,
    G4Polyhedra,
    G4Sphere,
    G4Trap,
    G4Trd,
    G4Tubs,
    Shape,
    Transform,
    shape_from_dict,
)

from helpers.spawn import run_in_spawned_process

# Its module fixture runs once, on one pytest-xdist worker (not once per worker).
pytestmark = pytest.mark.xdist_group("shapes-g4")

TWO_PI = 2 * math.pi

# A LEGEND inverted-coaxial detector (metadata in the legend-metadata layout; invented numbers)
ICPC = {
    "name": "V99000A",
    "type": "icpc",
    "production": {"enrichment": {"val": 0.9, "unc": 0.003}, "mass_in_g": 2000},
    "geometry": {
        "height_in_mm": 80,
        "radius_in_mm": 40,
        "borehole": {"depth_in_mm": 50, "radius_in_mm": 5},
        "groove": {"depth_in_mm": 2, "radius_in_mm": {"outer": 10, "inner": 7}},
        "pp_contact": {"radius_in_mm": 5, "depth_in_mm": 0},
        "taper": {
            "top": {"angle_in_deg": 45, "height_in_mm": 5},
            "bottom": {"angle_in_deg": 45, "height_in_mm": 2},
            "borehole": {"angle_in_deg": 0, "height_in_mm": 0},
        },
    },
}

PC = dict(
    sphi=0.0, dphi=TWO_PI, z=[0, 10, 10, 20, 30], rmin=[0, 0, 3, 5, 5], rmax=[10, 20, 15, 20, 20]
)
PC_SEG = dict(sphi=0.5, dphi=4.0, z=[-5, 5, 15], rmin=[2, 4, 4], rmax=[10, 12, 8])
GPC = dict(sphi=0.0, dphi=TWO_PI, r=[0, 10, 12, 12, 6, 0], z=[0, 0, 3, 20, 25, 25])
PH = dict(sphi=0.0, dphi=TWO_PI, nsides=6, z=[0, 10, 20], rmin=[0, 2, 2], rmax=[10, 12, 12])
PH_SEG = dict(sphi=0.2, dphi=3.0, nsides=3, z=[0, 10], rmin=[3, 3], rmax=[10, 8])
GPH = dict(sphi=0.0, dphi=TWO_PI, nsides=8, r=[0, 10, 10, 0], z=[0, 0, 10, 20])

HAND: dict[str, Shape] = {
    "box": G4Box(10, 20, 30),
    "trd": G4Trd(10, 5, 20, 8, 15),
    "trap": G4Trap(30, 0.1, 0.2, 20, 10, 15, 0.1, 10, 5, 7.5, 0.1),
    "tubs": G4Tubs(5, 35, 10, 0.3, 4.0),
    "tubs_full": G4Tubs(0, 35, 10),
    "cons": G4Cons(2, 10, 5, 20, 15, 0.5, 5.0),
    "sphere": G4Sphere(5, 10, 0.2, 2.0, 0.3, 1.0),
    "hemisphere": G4Sphere(3, 10, 0, TWO_PI, 0, 0.5 * math.pi),
    "orb": G4Orb(12),
    "pc": G4Polycone(**PC),
    "pc_seg": G4Polycone(**PC_SEG),
    "gpc": G4GenericPolycone(**GPC),
    "ph": G4Polyhedra(**PH),
    "ph_seg": G4Polyhedra(**PH_SEG),
    "gph": G4GenericPolyhedra(**GPH),
}
GDML_NAMES = ["pc", "pc_seg", "gpc", "ph", "ph_seg", "gph", "V99000A"]


def _rotation_x_then_z() -> np.ndarray:
    """Object rotation of test_shapes_g4's subtracted hole: Geant4's rotMatrix (rotateX(0.4),
    then rotateZ(0.3)) is a frame rotation; the object rotation is its inverse."""
    cx, sx, cz, sz = math.cos(0.4), math.sin(0.4), math.cos(0.3), math.sin(0.3)
    rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return (rz @ rx).T


def _write_gdml(path: Path) -> Shape:
    """GDML with the polycone family and an HPGe, written by pyg4ometry; returns the HPGe's
    hand-built shape (from legend-pygeom-hpges' own (r, z) profile)."""
    pyg4ometry = pytest.importorskip("pyg4ometry")
    pygeomhpges = pytest.importorskip("pygeomhpges")
    g4 = pyg4ometry.geant4
    reg = g4.Registry()
    det = pygeomhpges.make_hpge(ICPC, reg)
    solid = g4.solid
    solid.Polycone("pc", PC["sphi"], PC["dphi"], PC["z"], PC["rmin"], PC["rmax"], reg)
    solid.Polycone(
        "pc_seg", PC_SEG["sphi"], PC_SEG["dphi"], PC_SEG["z"], PC_SEG["rmin"], PC_SEG["rmax"], reg
    )
    solid.GenericPolycone("gpc", GPC["sphi"], GPC["dphi"], GPC["r"], GPC["z"], reg)
    for name, p in (("ph", PH), ("ph_seg", PH_SEG)):
        solid.Polyhedra(
            name, p["sphi"], p["dphi"], p["nsides"], len(p["z"]), p["z"], p["rmin"], p["rmax"], reg
        )
    solid.GenericPolyhedra("gph", GPH["sphi"], GPH["dphi"], GPH["nsides"], GPH["r"], GPH["z"], reg)
    world_s = solid.Box("ws", 400, 400, 400, reg)
    world = g4.LogicalVolume(world_s, g4.MaterialPredefined("G4_Galactic"), "world", reg)
    g4.PhysicalVolume([0, 0, 0], [0, 0, 0], det, "det", world, reg)
    reg.setWorld(world)
    writer = pyg4ometry.gdml.Writer()
    writer.addDetector(reg)
    writer.write(str(path))
    return G4GenericPolycone(0.0, TWO_PI, det.solid.pR, det.solid.pZ)


def _measure(gdml: str, requests: dict) -> dict:
    sys.path.insert(0, str(Path(__file__).parent))
    from helpers.g4_shapes import measure

    return measure(gdml, GDML_NAMES, requests)


@pytest.fixture(scope="module")
def measured(tmp_path_factory):
    gdml = tmp_path_factory.mktemp("shapes") / "solids.gdml"
    hand = dict(HAND)
    hand["V99000A"] = _write_gdml(gdml)
    hand["box_minus_tubs"] = BooleanShape(
        "subtraction",
        G4Box(10, 20, 30),
        G4Tubs(0, 4, 40),
        Transform(_rotation_x_then_z(), [2, 3, 1]),
    )
    hand["tubs_as_union"] = BooleanShape(
        "union", G4Tubs(0, 35, 10, 0, math.pi), G4Tubs(0, 35, 10, math.pi, math.pi)
    )
    rng = np.random.default_rng(11)
    requests, samples = {}, {}
    for name, shape in hand.items():
        surf = shape.sample_surface(rng, 3000)
        vol = shape.sample_volume(rng, 2000)
        lo, hi = shape.bounding_box()
        box = lo + rng.random((3000, 3)) * (hi - lo)
        samples[name] = (surf, vol, box)
        requests[name] = {
            "points": np.concatenate([surf.position, vol, box]).tolist(),
            "normals_at": surf.position[:500].tolist(),
        }
    requests["tessellated"] = {}
    requests["torus"] = {"n_live": 3000, "max_lines": 100_000}
    requests["tubs_live"] = {
        "solid": "tubs_as_union",
        "live": True,
        "n_live": 3000,
        "max_lines": 100_000,
    }
    got = run_in_spawned_process(_measure, str(gdml), requests)
    return hand, samples, got


ANALYTIC = {  # pure formulas, written independently of score4.shapes
    "box": (2 * (20 * 40 + 20 * 60 + 40 * 60), 8 * 10 * 20 * 30),
    "orb": (4 * math.pi * 144, 4 / 3 * math.pi * 12**3),
    "tubs_full": (2 * math.pi * 35 * 20 + 2 * math.pi * 35**2, math.pi * 35**2 * 20),
    "tubs": (
        4.0 * (35 + 5) * 20 + 4.0 * (35**2 - 5**2) + 2 * 30 * 20,
        0.5 * 4.0 * (35**2 - 5**2) * 20,
    ),
    "hemisphere": (
        2 * math.pi * (100 + 9) + math.pi * (100 - 9),
        2 / 3 * math.pi * (1000 - 27),
    ),
}


@pytest.mark.parametrize("name", [*HAND, "V99000A", "box_minus_tubs", "tubs_as_union"])
def test_area_volume_inside_normals_against_geant4(measured, name):
    hand, samples, got = measured
    shape, res = hand[name], got[name]
    surf, vol, box = samples[name]
    n_s, n_v = len(surf.position), len(vol)
    codes = np.array(res["codes"])
    # every sampled surface point is on the surface and every volume point inside, for Geant4
    assert (codes[:n_s] == 1).all(), f"{(codes[:n_s] != 1).sum()} surface points off"
    assert (codes[n_s : n_s + n_v] == 2).all(), f"{(codes[n_s : n_s + n_v] != 2).sum()} not inside"
    # random points of the bounding box: the same classification (none lands within 1e-9 mm)
    assert np.array_equal(shape.inside(box), codes[n_s + n_v :])
    # outward normals agree with SurfaceNormal
    dots = np.einsum("ij,ij->i", np.array(res["normals"]), surf.normal[:500])
    assert dots.min() > 1 - 1e-9
    if isinstance(shape, BooleanShape):  # areas and volume estimated: 4 standard errors
        err = math.sqrt(sum(e * e for e in shape.face_area_errors.values()))
        assert abs(shape.area - res["g4_area"]) < 4 * err + 0.01 * res["g4_area"]
        assert abs(shape.volume - res["g4_volume"]) < 4 * shape.volume_error + 0.01 * shape.volume
    else:  # exact, and so is Geant4 for these types
        assert shape.area == pytest.approx(res["g4_area"], rel=1e-9)
        assert shape.volume == pytest.approx(res["g4_volume"], rel=1e-9)
        read = shape_from_dict(res["shape"])
        assert read.faces == shape.faces
        for face, area in shape.face_areas.items():
            assert read.face_areas[face] == pytest.approx(area, rel=1e-12, abs=1e-9)
        if hasattr(shape, "canonical"):  # contour solids: Geant4 keeps the contour only
            np.testing.assert_allclose(read.canonical(), shape.canonical(), rtol=0, atol=1e-9)
        else:
            assert type(read) is type(shape)
            assert read.to_dict() == pytest.approx(shape.to_dict())
    if name in ANALYTIC:
        assert shape.area == pytest.approx(ANALYTIC[name][0], rel=1e-12)
        assert shape.volume == pytest.approx(ANALYTIC[name][1], rel=1e-12)


def test_tubs_as_a_boolean_has_the_area_of_the_tubs(measured):
    hand, _, got = measured
    union = hand["tubs_as_union"]
    exact = ANALYTIC["tubs_full"][0]
    err = math.sqrt(sum(e * e for e in union.face_area_errors.values()))
    assert err < 0.002 * exact  # the estimate is good to 0.2 % (1 sigma)
    assert abs(union.area - exact) <= 4 * err + 1e-9 * exact  # here every piece is whole
    assert got["tubs_as_union"]["shape_type"] == "BooleanShape"


def test_tessellated_solid_is_read_exactly(measured):
    _, _, got = measured
    res = got["tessellated"]
    assert res["shape_type"] == "MeshShape"
    shape = shape_from_dict(res["shape"])
    n = 360
    side = 2 * 35 * math.sin(math.pi / n)
    mesh_area = n * side * 20 + 2 * n * 0.5 * 35**2 * math.sin(TWO_PI / n)
    assert shape.area == pytest.approx(mesh_area, rel=1e-12)
    assert shape.area == pytest.approx(res["g4_area"], rel=1e-9)
    assert shape.volume == pytest.approx(n * 0.5 * 35**2 * math.sin(TWO_PI / n) * 20, rel=1e-12)


def test_any_other_solid_through_the_live_solid(measured):
    """A G4Torus has no dataclass: random lines give its true area and true-surface points."""
    _, _, got = measured
    res = got["torus"]
    assert res["shape_type"] == "LiveSolidShape"
    exact = 4 * math.pi**2 * 20 * 5
    assert res["live_area_error"] < 0.0075 * exact  # 10^5 lines: 0.6 % (1 sigma)
    assert abs(res["live_area"] - exact) < 4 * res["live_area_error"]
    assert set(res["live_codes"]) == {1}
    p = np.array(res["live_positions"])
    # true surface of the torus: (sqrt(x^2 + y^2) - 20)^2 + z^2 = 25, to 1e-9 mm
    rho = np.hypot(p[:, 0], p[:, 1])
    assert np.abs(np.hypot(rho - 20, p[:, 2]) - 5).max() < 1e-9
    # uniform per area on a torus: the tube angle t has density (20 + 5 cos t) / (2 pi 20)
    t = np.arctan2(p[:, 2], rho - 20)
    outer = np.mean(np.abs(t) < 0.5 * math.pi)  # exact share: 1/2 + 5 * 2 / (2 pi 20)
    share = 0.5 + 10 / (TWO_PI * 20)
    assert abs(outer - share) < 4 * math.sqrt(share * (1 - share) / len(t))


def test_a_boolean_through_the_live_solid(measured):
    """The same two half tubes, sampled through the live G4UnionSolid by random lines: the true
    area within its error, every point on the true cylinder or end disks (1e-9 mm)."""
    _, _, got = measured
    res = got["tubs_live"]
    exact = ANALYTIC["tubs_full"][0]
    assert res["live_area_error"] < 0.0075 * exact
    assert abs(res["live_area"] - exact) < 4 * res["live_area_error"]
    p = np.array(res["live_positions"])
    off_side = np.abs(np.hypot(p[:, 0], p[:, 1]) - 35)
    off_cap = np.abs(np.abs(p[:, 2]) - 10)
    assert np.minimum(off_side, off_cap).max() < 1e-9
    assert set(res["live_codes"]) == {1}
    side = np.mean(off_side < 1e-9)
    share = 2 * math.pi * 35 * 20 / exact
    assert abs(side - share) < 4 * math.sqrt(share * (1 - share) / len(p))


def test_hpge_faces(measured):
    """The ICPC's faces from Geant4's contour: the groove, the borehole and the tapers."""
    hand, _, got = measured
    det = hand["V99000A"]
    read = shape_from_dict(got["V99000A"]["shape"])
    assert read.faces == det.faces
    assert set(det.groups) >= {"outer", "inner", "top", "bottom", "all"}
    # borehole: radius 5, depth 50 (its wall), and its bottom disk at z = 30
    assert det.face_area("inner") == pytest.approx(
        TWO_PI * 5 * 50 + TWO_PI * 10 * 2,
        rel=1e-12,  # borehole wall + the groove wall at r = 10
    )


def _placement(points):
    sys.path.insert(0, str(Path(__file__).parent))
    from helpers.g4_shapes import placement_check

    return placement_check(points)


def test_transform_from_a_geant4_placement():
    """Transform.from_g4(pv.GetObjectRotationValue(), pv.GetTranslation()) is the placement's
    local -> mother map: Geant4's navigator takes the mapped points back to the same local
    coordinates, inside the placed box."""
    rng = np.random.default_rng(12)
    local = G4Box(10, 20, 30).sample_volume(rng, 200)
    got = run_in_spawned_process(_placement, local.tolist())
    assert {g[0] for g in got} == {"b"}
    np.testing.assert_allclose(np.array([g[1:] for g in got]), local, atol=1e-9)
