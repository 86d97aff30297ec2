"""Sources on any volume (issue 17, item 4): face: all with rough faces, depth along the true
normal of curved faces with every profile and definition, bulk sources with excluded
daughters, the config keys and their bad input. Geant4's view: test_shape_sources_g4.py."""

from __future__ import annotations

import math

import numpy as np
import pytest

from score4.errors import ConfigError
from score4.inputs.config import parse_config
from score4.shapes import OUTSIDE, G4Box, G4Orb, G4Tubs, PlacedShape, Transform
from score4.source.build import make_source, source_geometry
from score4.source.depth import VertexSampler
from score4.source.profiles import (
    ExponentialProfile,
    MultiExponentialProfile,
    TableProfile,
    TruncatedGaussianProfile,
    UniformProfile,
)
from score4.source.sampling import SurfaceSampler, TiledSurfaceSampler
from score4.source.shape_sampling import BulkSampler, CombinedSurfaceSampler, ShapeSurfaceSampler
from score4.world.resolve import build_scene

FACES = ("+x", "-x", "+y", "-y", "+z", "-z")


def _config(source: dict, rough: bool = True) -> dict:
    target = {
        "name": "crystal",
        "material": "G4_Si",
        "size": ["2 mm", "1 mm", "0.5 mm"],
        "position": ["1 mm", "-2 mm", "-0.25 mm"],
    }
    if rough:
        target["rough"] = [{"face": "+z", "surface": "pyramids", "base_thickness": "1 um"}]
    return {
        "physics": "lite",
        "surfaces": {
            "pyramids": {"kind": "spikes", "nx": 10, "ny": 10, "width": "10 um", "height": "10 um"}
        },
        "targets": [target],
        "source": {"particle": "alpha", "energy": "5.3 MeV", **source},
        "run": {"events": 1000, "seed": 1},
    }


def test_face_all_shares_follow_true_areas_with_a_rough_face():
    """Box 2 x 1 x 0.5 mm with 10 um pyramids (area factor sqrt(5)) on +z: the shares of 2 10^5
    vertices per face are the true areas' shares (4 binomial sigma, < 0.5 % absolute)."""
    config = parse_config(_config({"surface": {"volume": "crystal", "face": "all"}}))
    scene = build_scene(config)
    where = source_geometry(config, scene)
    rough_area = 2.0 * math.sqrt(5)  # pyramids of equal width and height: 2 h / (w / 2) = 2
    areas = {"+x": 0.5, "-x": 0.5, "+y": 1.0, "-y": 1.0, "+z": rough_area, "-z": 2.0}
    assert where["area_mm2"] == pytest.approx(sum(areas.values()), rel=1e-12)
    assert where["projected_area_mm2"] == pytest.approx(7.0, rel=1e-12)
    assert where["faces"] == list(FACES)
    n = 200_000
    p = make_source(config, scene).events(1, 0, n)
    face = p.extra["face"]
    total = sum(areas.values())
    for k, name in enumerate(FACES):
        share = areas[name] / total
        got = np.mean(face == k)
        assert abs(got - share) < 4 * math.sqrt(share * (1 - share) / n), name
        assert 4 * math.sqrt(share * (1 - share) / n) < 0.005  # sees a 0.5 % (absolute) slip
    # depth below the right face: flat faces exactly along their inward normal
    centre, half = np.array([1.0, -2.0, -0.25]), np.array([1.0, 0.5, 0.25])
    depth = p.extra["depth"]
    for k, name in enumerate(FACES):
        if name == "+z":
            continue
        axis, sign = "xyz".index(name[1]), 1.0 if name[0] == "+" else -1.0
        rows = face == k
        coord = p.position[rows, axis] - centre[axis]
        np.testing.assert_allclose(coord, sign * (half[axis] - depth[rows]), rtol=0, atol=1e-12)
    # rough-face vertices sit in the rough layer or below it, inside the crystal's material
    rows = face == FACES.index("+z")
    assert (p.extra["patch"][rows] >= 0).all()
    assert (p.extra["patch"][~rows] == -1).all()
    assert scene.inside_target("crystal", p.position[rows]).all()


PROFILES = [
    ExponentialProfile(0.02),
    MultiExponentialProfile([0.3, 0.7], [0.01, 0.1]),
    UniformProfile(0.01, 0.5),
    TruncatedGaussianProfile(0.2, 0.1),
    TableProfile([0.0, 0.1, 0.3], [1.0, 2.0, 0.0]),
]


@pytest.mark.parametrize("profile", PROFILES, ids=lambda p: type(p).__name__)
def test_depth_along_the_true_normal_of_a_cylinder(profile):
    """A tube (R = 35 mm, bore 5 mm), placed rotated and moved: every vertex of the outer face
    lies at exactly its depth below the true cylinder (no facetting: 1e-12 mm), every bore
    vertex at exactly its depth outside the bore; the min/max window holds."""
    rot = np.array([[0, 0, 1.0], [1, 0, 0], [0, 1, 0]])
    tr = Transform(rot, [5, 6, 7])
    sampler = ShapeSurfaceSampler(G4Tubs(5, 35, 10), ["outer", "inner"], tr)
    vs = VertexSampler(sampler, profile, min_depth=0.015, max_depth=0.25)
    v = vs.sample(np.random.default_rng(2), 20000)
    local = tr.inverse_apply(v.position)
    r = np.hypot(local[:, 0], local[:, 1])
    outer = v.face == sampler.face_names.index("outer")
    np.testing.assert_allclose(r[outer], 35 - v.depth[outer], rtol=0, atol=1e-12)
    np.testing.assert_allclose(r[~outer], 5 + v.depth[~outer], rtol=0, atol=1e-12)
    assert v.depth.min() >= 0.015
    assert v.depth.max() <= 0.25
    # the shares of outer and bore follow their areas (7 : 1)
    assert abs(outer.mean() - 35 / 40) < 4 * math.sqrt(35 / 40 * 5 / 40 / 20000)


def test_confinement_redraws_vertices():
    sampler = ShapeSurfaceSampler(G4Orb(10), "all")
    vs = VertexSampler(sampler, UniformProfile(0, 1.0), inside=lambda p: p[:, 2] > 0)
    v = vs.sample(np.random.default_rng(3), 5000)
    assert (v.position[:, 2] > 0).all()
    np.testing.assert_allclose(np.linalg.norm(v.position, axis=1), 10 - v.depth, atol=1e-12)


def test_distance_on_curved_faces_weights_the_parallel_surface():
    """``distance`` at a fixed depth d on an annular tube (bore R1 = 10, outer R2 = 20, long):
    the inner parallel surfaces have areas 2 pi (R1 + d) h and 2 pi (R2 - d) h, so the bore
    gets (R1 + d) / (R1 + R2) of the vertices (normal: R1 / (R1 + R2)); every vertex is exactly
    d from the solid's surface."""
    d, n = 2.0, 40_000
    tube = G4Tubs(10, 20, 200)
    sampler = ShapeSurfaceSampler(tube, ["outer", "inner"])
    share = {"distance": (10 + d) / 30, "normal": 10 / 30}
    for definition in ("distance", "normal"):
        vs = VertexSampler(sampler, UniformProfile(d, d * (1 + 1e-12)), definition=definition)
        v = vs.sample(np.random.default_rng(4), n)
        inner = np.mean(v.face == tube.faces.index("inner"))
        p = share[definition]
        assert abs(inner - p) < 4 * math.sqrt(p * (1 - p) / n), definition
        dist = -tube.signed_distance(v.position)
        if definition == "distance":  # near the end caps vertices would be closer: redrawn
            np.testing.assert_allclose(dist, v.depth, rtol=1e-9)
    # on a box's faces 'distance' redraws what lies closer to a neighbouring face
    box = ShapeSurfaceSampler(G4Box(1, 1, 1), "all")
    vs = VertexSampler(box, UniformProfile(0.5, 0.5 + 1e-9), definition="distance")
    v = vs.sample(np.random.default_rng(5), 2000)
    np.testing.assert_allclose(-G4Box(1, 1, 1).signed_distance(v.position), v.depth, rtol=1e-9)


def test_distance_is_refused_where_it_is_not_defined():
    config = parse_config(
        _config(
            {
                "surface": {"volume": "crystal", "face": "all"},
                "depth": {"profile": "exponential", "mean": "20 nm", "definition": "distance"},
            }
        )
    )
    with pytest.raises(ConfigError, match="'distance' on several faces with a rough one"):
        make_source(config, build_scene(config))


def test_bulk_sampler_excludes_daughters():
    box = G4Box(10, 10, 10)
    hole = PlacedShape(G4Orb(6), Transform(translation=[2, 0, 0]))
    bulk = BulkSampler(
        box,
        Transform(translation=[0, 0, 100]),
        [PlacedShape(hole, Transform(translation=[0, 0, 100]))],
    )
    assert bulk.volume == pytest.approx(8000 - 4 / 3 * math.pi * 216, rel=1e-12)
    p = bulk.sample(np.random.default_rng(6), 50_000)
    local = p - [0, 0, 100]
    assert (box.inside(local) == 2).all()
    assert (hole.inside(local) == OUTSIDE).all()
    # uniform: share in x > 2 (the hole's half) against the exact volumes
    exact = (8 * 20 * 20 - 2 / 3 * math.pi * 216) / bulk.volume
    got = np.mean(local[:, 0] > 2)
    assert abs(got - exact) < 4 * math.sqrt(exact * (1 - exact) / len(p))
    with pytest.raises(ConfigError, match="'holder' has no material of its own left"):
        BulkSampler(G4Box(1, 1, 1), exclude=[G4Box(1, 1, 1)], name="holder")


def test_bulk_source_from_the_config():
    config = parse_config(_config({"volume": "crystal"}, rough=False))
    scene = build_scene(config)
    p = make_source(config, scene).events(3, 0, 20_000)
    assert "depth" not in p.extra
    centre, half = np.array([1.0, -2.0, -0.25]), np.array([1.0, 0.5, 0.25])
    assert (np.abs(p.position - centre) < half).all()
    assert abs(np.mean(p.position[:, 0] > 1.0) - 0.5) < 4 * math.sqrt(0.25 / 20_000)
    where = source_geometry(config, scene)
    assert where == {
        "kind": "bulk",
        "volume": "crystal",
        "volume_mm3": pytest.approx(1.0),
        "mass_kg": None,
    }
    with_density = _config({"volume": "crystal"}, rough=False)
    with_density["materials"] = {"TeO2": {"formula": "TeO2", "density": "6.02 g/cm3"}}
    with_density["targets"][0]["material"] = "TeO2"
    cfg = parse_config(with_density)
    assert source_geometry(cfg, build_scene(cfg))["mass_kg"] == pytest.approx(6.02e-6)


@pytest.mark.parametrize(
    ("source", "message"),
    [
        (
            {"volume": "crystal", "depth": {"profile": "exponential", "mean": "1 um"}},
            "source.depth: used only with volume: null",
        ),
        ({"volume": "crystal", "confine": False}, "source.confine: used only with volume"),
        ({"volume": "crystal", "direction": "outward"}, "a bulk source .* emits isotropically"),
        ({"volume": "crystal", "surface": {"volume": "crystal"}}, "not both"),
        ({"volume": "holder"}, "source.volume: 'holder' is not a target"),
        (
            {"surface": {"volume": "crystal", "face": "top"}},
            r"source.surface.face: a box target has the faces \+x, .* \(or all\), not 'top'",
        ),
    ],
)
def test_bad_source_input(source, message):
    with pytest.raises(ConfigError, match=message):
        parse_config(_config(source, rough=False))


def test_a_partly_rough_face():
    """The +z disk of a tube (R = 2): a rough square of cells in the middle (true area 2x its
    flat 2 x 2 mm) and the flat rest of the disk, as one combined sampler for the face."""
    tube = G4Tubs(0, 2, 1)
    flat_tri = np.array([[[0, 0, 1.0], [2, 0, 1], [0, 2, 1]]])  # a stand-in flat remainder
    flat = SurfaceSampler(flat_tri)
    tent = np.array([[[0, 0, 0], [1, 0, 1.0], [0, 1, 0]], [[1, 0, 1.0], [1, 1, 0], [0, 1, 0]]])
    rough = TiledSurfaceSampler(
        [SurfaceSampler(tent)], np.zeros((2, 2), int), (1.0, 1.0), origin=(-1, -1, 1)
    )
    face = CombinedSurfaceSampler([rough, flat])
    assert face.area == pytest.approx(rough.area + 2.0)
    sampler = ShapeSurfaceSampler(tube, ["+z", "outer"], rough={"+z": face})
    assert sampler.area == pytest.approx(face.area + tube.face_areas["outer"])
    s = sampler.sample(np.random.default_rng(7), 100_000)
    top = s.face == tube.faces.index("+z")
    share = face.area / sampler.area
    assert abs(top.mean() - share) < 4 * math.sqrt(share * (1 - share) / len(top))
    in_rough = top & (s.patch >= 0)
    assert abs(in_rough.sum() / top.sum() - rough.area / face.area) < 0.01
