"""Rough layers on curved faces (score4.world.curved): bent patches on a cylinder wall, in numpy and
in Geant4."""

from __future__ import annotations

import math

import numpy as np
import pytest

from score4.errors import ConfigError
from score4.geometry.curved import bent_corners, bent_traps
from score4.inputs.config import parse_config
from score4.runner.engine import run
from score4.runner.output import read_results
from score4.source.build import make_source, source_geometry
from score4.world.resolve import build_scene
from score4.world.scene import CurvedRoughLayer

from helpers.geantinos import geantino_run
from helpers.ray_trace import mesh_path

RADIUS, HALF_Z = 5.0, 1.0  # mm
PYRAMIDS = {"kind": "spikes", "nx": 10, "ny": 10, "width": "10 um", "height": "10 um"}


def write_cylinder(path, radius=RADIUS, half_z=HALF_Z, rmin=0.0, dphi=2 * math.pi, sister=None):
    """A G4Tubs ``cyl`` of silicon in vacuum; ``sister``: the gap (mm) from its wall to a 1 mm
    copper cube beside it on +x."""
    import pyg4ometry as pg

    reg = pg.geant4.Registry()
    world = pg.geant4.LogicalVolume(
        pg.geant4.solid.Box("world_s", 200, 200, 200, reg), "G4_Galactic", "World", reg
    )
    solid = pg.geant4.solid.Tubs("cyl_s", rmin, radius, 2 * half_z, 0, dphi, reg)
    cyl = pg.geant4.LogicalVolume(solid, "G4_Si", "Cyl", reg)
    pg.geant4.PhysicalVolume([0, 0, 0], [0, 0, 0], cyl, "cyl", world, reg)
    if sister is not None:
        cube = pg.geant4.LogicalVolume(
            pg.geant4.solid.Box("cube_s", 1, 1, 1, reg), "G4_Cu", "Cube", reg
        )
        pg.geant4.PhysicalVolume([0, 0, 0], [radius + sister + 0.5, 0, 0], cube, "cube", world, reg)
    reg.setWorld(world.name)
    writer = pg.gdml.Writer()
    writer.addDetector(reg)
    writer.write(str(path))
    return path


def cylinder_config(gdml, face="outer", surface=PYRAMIDS, source=None, **extra):
    return {
        "physics": "lite",
        "world": {"gdml": str(gdml)},
        "surfaces": {"p": surface},
        "targets": [{"volume": "cyl", "rough": [{"face": face, "surface": "p"}]}],
        "source": source
        or {
            "particle": "geantino",
            "energy": "1 MeV",
            "surface": {"volume": "cyl", "face": face},
        },
        "run": {"events": 100, "seed": 3},
        **extra,
    }


@pytest.fixture(scope="module")
def cylinder(tmp_path_factory):
    return write_cylinder(tmp_path_factory.mktemp("cyl") / "cyl.gdml")


def test_bent_layer_follows_the_cylinder(cylinder):
    scene = build_scene(parse_config(cylinder_config(cylinder)))
    (layer,) = scene.layers
    assert isinstance(layer, CurvedRoughLayer)
    assert layer.gap <= 1e-4  # within max(1 % of 10 um, 0.1 um)
    assert layer.gap == pytest.approx(0.01**2 / (8 * RADIUS), rel=0.05)  # the chord's sagitta
    lay = layer.ring_layout
    assert len(lay.v) == 20  # 2 mm of wall in 0.1 mm rows
    assert lay.count[0] == math.floor(2 * math.pi * RADIUS / 0.1)
    assert 0.99 < layer.rough_share <= 1.0
    # every vertex of every bent body lies on or outside the true surface, within the layer
    bent = layer.bent(0, 0)
    h = lay.face.locate(bent.vertices + np.array([0.0, 0.0, lay.ring_z(0)]))[2]
    assert h.min() >= 0.0
    assert h.max() <= layer.thickness


def test_rough_share_is_the_share_of_the_face_the_cells_cover(cylinder, tmp_path):
    """rough_share of a cylinder wall and a cone's side is the share of the face's area that
    lies in a cell (points uniform per area on the face, located in the rings: 3 sigma); on a
    full cylinder each ring holds floor(2 pi r / px) cells of the patch width px (the ring's
    step x r), the gap of less than one patch left flat."""
    rng = np.random.default_rng(6)
    for gdml in (cylinder, write_cone(tmp_path / "cone.gdml")):
        (layer,) = build_scene(parse_config(cylinder_config(gdml))).layers
        lay = layer.ring_layout
        face = lay.face
        px, py = layer.patch_size
        np.testing.assert_allclose(lay.step * lay.radius, px, rtol=1e-12)
        n = 400_000
        v = rng.uniform(-face.length / 2, face.length / 2, n)
        r = face.radius(v)
        keep = rng.uniform(0, r.max(), n) < r  # uniform per area: density ~ r
        phi = rng.uniform(face.phi0, face.phi0 + face.dphi, int(keep.sum()))
        j, _, _ = lay.locate(face.point(phi, v[keep]))
        share = float(np.mean(j >= 0))
        sigma = math.sqrt(share * (1 - share) / len(phi))
        assert abs(layer.rough_share - share) < 3 * sigma, (layer.rough_share, share, sigma)
        if layer.is_cylinder:
            gap = 2 * math.pi * face.radius(0.0) - lay.count * px
            assert (gap >= 0).all()
            assert (gap < px).all()
            rows = len(lay.v) * py / face.length
            assert layer.rough_share == pytest.approx(
                lay.count[0] * px / (2 * math.pi * RADIUS) * rows, rel=1e-12
            )


def test_samples_lie_on_the_bent_tops_with_the_mesh_area(cylinder):
    config = parse_config(cylinder_config(cylinder))
    scene = build_scene(config)
    (layer,) = scene.layers
    geo = source_geometry(config, scene)
    cells = layer.ring_layout.n_cells
    top = layer.bent(0, 0).top_triangles
    e1, e2 = top[:, 1] - top[:, 0], top[:, 2] - top[:, 0]
    bent_area = 0.5 * np.linalg.norm(np.cross(e1, e2), axis=1).sum()
    # the pyramids' true area (sqrt(5) x the flat one) on each cell, plus the flat remainder
    assert geo["area_mm2"] == pytest.approx(
        cells * bent_area + (2 * math.pi * RADIUS * 2 * HALF_Z - cells * 0.01), rel=1e-9
    )
    assert bent_area == pytest.approx(math.sqrt(5) * 0.01 * (1 + 5e-3 / RADIUS), rel=2e-3)
    p = make_source(config, scene).primaries(np.random.default_rng(2), 0, 2000)
    q = layer.target.to_local(p.position)
    j, _, local = layer.ring_layout.locate(q)
    on = j >= 0
    assert on.mean() > 0.99
    height = layer.variants[0].height_at(local[on, 0], local[on, 1])
    # the bent facets are flat between bent vertices: they leave the bent height map by about
    # slope x (height / R) x facet width / 2 = 2 x 2e-3 x 5 um / 2 = 10 nm here
    expected = layer.lift + layer.base_thickness + height
    np.testing.assert_allclose(local[on, 2], expected, atol=1e-5)
    # confinement agrees with the bent bodies: every point on a bent top is in the target
    assert scene.inside_target("cyl", p.position).all()
    assert not scene.inside_target(
        "cyl", p.position[on] + 1e-4 * lay_normal(layer, p.position[on])
    ).any()


def lay_normal(layer, points):
    """The cylinder's outward normal at world points."""
    q = layer.target.to_local(points)
    u = np.arctan2(q[:, 1], q[:, 0])
    return layer.ring_layout.face.normal(u, 0.0) @ layer.target.rotation.T


def ray_path(origins, directions, layer, radius, half_z, window=4, slope=0.0):
    """Independent ray trace: the path length (mm) of each ray in the cylinder (analytic; a cone
    of radius ``radius + slope z`` with ``slope``) and in the bent patch bodies (Moeller-Trumbore
    on their triangles) near where it crosses the wall."""
    out = np.zeros(len(origins))
    lay = layer.ring_layout
    for n, (o, d) in enumerate(zip(origins, directions, strict=True)):
        r0 = radius + slope * o[2]  # the cone's radius at the ray's origin height
        a = d[0] ** 2 + d[1] ** 2 - (slope * d[2]) ** 2
        b = 2 * (o[0] * d[0] + o[1] * d[1]) - 2 * slope * d[2] * r0
        c = o[0] ** 2 + o[1] ** 2 - r0**2
        disc = b * b - 4 * a * c
        hits = []
        if disc > 0:
            t1, t2 = (-b - math.sqrt(disc)) / (2 * a), (-b + math.sqrt(disc)) / (2 * a)
            zs = o[2] + np.array([t1, t2]) * d[2]
            assert np.all(np.abs(zs) < half_z)  # the test's rays cross the wall, not the ends
            out[n] += t2 - t1
            hits = [o + t1 * d, o + t2 * d]
        for p in hits:  # the patch bodies around each crossing of the wall
            tri_all = []
            phi0 = math.atan2(p[1], p[0])
            for j in range(len(lay.v)):
                if abs(lay.ring_z(j) - p[2]) > window * layer.patch_size[1]:
                    continue
                for i, phi in enumerate(lay.cell_phi(j)):
                    dphi = (phi - phi0 + math.pi) % (2 * math.pi) - math.pi
                    if abs(dphi) * radius > window * layer.patch_size[0]:
                        continue
                    body = layer.bent(int(layer.cell_variants[j, i]), j)
                    c_, s_ = math.cos(phi), math.sin(phi)
                    v = body.vertices @ np.array([[c_, s_, 0], [-s_, c_, 0], [0, 0, 1]])
                    v = v + np.array([0.0, 0.0, lay.ring_z(j)])
                    tri_all.append(v[body.faces])
            if tri_all:  # none where the rings stay flat (a cone's tip)
                out[n] += mesh_path(o, d, np.concatenate(tri_all))  # an edge is hit twice
    return out


BUMPS = {**PYRAMIDS, "shape": "bump", "n_layers": 4, "height_sigma": "2 um", "seed": 3}


@pytest.mark.parametrize(
    ("solid", "surface"),
    [
        pytest.param("frustums", PYRAMIDS, id="pyramids-frustums"),
        pytest.param("tessellated", PYRAMIDS, id="pyramids-tessellated"),
        # deep: the bumps' many frustums build slowly; test_frustums covers them on flat faces
        pytest.param("frustums", BUMPS, id="bumps-spread-frustums", marks=pytest.mark.deep),
    ],
)
def test_geantino_paths_agree_with_an_independent_ray_trace(cylinder, tmp_path, solid, surface):
    """Geantinos from outside the layer, through the rough wall, the cylinder and the rough
    wall on the far side: Geant4's track length in the target (its patches count) equals the
    ray trace of the analytic cylinder plus the bent patch mesh, to 1e-9 mm, with the patches as
    bent G4Trds (``solid: auto`` on a cylinder; also bumps of 4 frustum layers with a height
    spread) and as one tessellated body each."""
    data = cylinder_config(cylinder, surface=surface, output={"track_length": True})
    data["targets"][0]["rough"][0]["solid"] = solid
    config = parse_config(data)
    scene = build_scene(config)
    (layer,) = scene.layers
    assert layer.solid_kind(0) == solid
    rng = np.random.default_rng(7)
    n = 40
    primaries = make_source(config, scene).primaries(np.random.default_rng(1), 0, n)
    phi = rng.uniform(0, 2 * np.pi, n)
    start = np.column_stack(
        [(RADIUS + 0.1) * np.cos(phi), (RADIUS + 0.1) * np.sin(phi), rng.uniform(-0.3, 0.3, n)]
    )
    aim = np.column_stack([rng.uniform(-2, 2, n), rng.uniform(-2, 2, n), rng.uniform(-0.3, 0.3, n)])
    direction = aim - start
    direction /= np.linalg.norm(direction, axis=1)[:, None]
    r = geantino_run(data, primaries, start, direction, tmp_path)
    expected = ray_path(start, direction, layer, RADIUS, HALF_Z)
    np.testing.assert_allclose(r.scores["track_length"]["cyl"], expected, rtol=0, atol=1e-9)


ORDER = [0, 1, 3, 2, 4, 5, 7, 6]  # bent_corners' corners in G4Trap's order


def write_cone(path, r1=3.0, r2=4.0, half_z=1.0):
    """A G4Cons ``cyl`` of silicon in vacuum: radius ``r1`` at -z to ``r2`` at +z."""
    import pyg4ometry as pg

    reg = pg.geant4.Registry()
    world = pg.geant4.LogicalVolume(
        pg.geant4.solid.Box("world_s", 200, 200, 200, reg), "G4_Galactic", "World", reg
    )
    solid = pg.geant4.solid.Cons("cyl_s", 0, r1, 0, r2, 2 * half_z, 0, 2 * math.pi, reg)
    cone = pg.geant4.LogicalVolume(solid, "G4_Si", "Cyl", reg)
    pg.geant4.PhysicalVolume([0, 0, 0], [0, 0, 0], cone, "cyl", world, reg)
    reg.setWorld(world.name)
    writer = pg.gdml.Writer()
    writer.addDetector(reg)
    writer.write(str(path))
    return path


@pytest.fixture(scope="module")
def cone(tmp_path_factory):
    return write_cone(tmp_path_factory.mktemp("cone") / "cone.gdml")


@pytest.mark.parametrize(
    ("solid", "surface", "tol"),
    [
        pytest.param("frustums", PYRAMIDS, 1e-9, id="pyramids-frustums"),
        pytest.param("tessellated", PYRAMIDS, 1e-9, id="pyramids-tessellated"),
        pytest.param("frustums", BUMPS, 2e-5, id="bumps-spread-frustums", marks=pytest.mark.deep),
    ],
)
def test_geantino_paths_through_a_rough_cone(cone, tmp_path, solid, surface, tol):
    """The same on a cone's side (radius 3 to 4 mm over 2 mm): with bent G4Traps and
    G4GenericTraps in cells of two G4Cons (``solid: auto`` on a cone) the track lengths equal
    the ray trace of the analytic cone plus the bent patch mesh to 1e-9 mm for pyramids (their
    faces are the mesh's triangles). Bumps of 4 frustum layers have their bent side faces made
    planar (:func:`score4.geometry.curved.bent_traps`): their corners move by at most 1e-6 mm
    (1 % of the 0.1 um limit, on this 3 mm radius) and rays that graze a moved face differ by
    up to 2e-5 mm."""
    data = cylinder_config(cone, surface=surface, output={"track_length": True})
    data["targets"][0]["rough"][0]["solid"] = solid
    config = parse_config(data)
    scene = build_scene(config)
    (layer,) = scene.layers
    assert layer.solid_kind(0) == solid
    if solid == "frustums":
        f = layer.variants[0].spikes.frustums()
        box = {"x": f["x"], "y": f["y"], "z0": f["z"] - f["height"] / 2}
        box |= {"z1": f["z"] + f["height"] / 2, "wxb": f["width_x_bottom"]}
        box |= {"wxt": f["width_x_top"], "wyb": f["width_y_bottom"], "wyt": f["width_y_top"]}
        for j in (0, len(layer.ring_layout.v) - 1):
            traps = bent_traps(layer, j, box, np.asarray(f["spike"]))
            bottom, top = bent_corners(layer, j, box)
            moved = np.abs(traps.vertices - np.concatenate([bottom, top], axis=1)[:, ORDER])
            assert moved.max() <= (1e-6 if surface is BUMPS else 1e-15)
    rng = np.random.default_rng(7)
    n = 40
    primaries = make_source(config, scene).primaries(np.random.default_rng(1), 0, n)
    phi = rng.uniform(0, 2 * np.pi, n)
    z = rng.uniform(-0.3, 0.3, n)
    r = 3.5 + 0.5 * z + 0.1
    start = np.column_stack([r * np.cos(phi), r * np.sin(phi), z])
    aim = np.column_stack(
        [rng.uniform(-1.5, 1.5, n), rng.uniform(-1.5, 1.5, n), rng.uniform(-0.3, 0.3, n)]
    )
    direction = aim - start
    direction /= np.linalg.norm(direction, axis=1)[:, None]
    res = geantino_run(data, primaries, start, direction, tmp_path)
    expected = ray_path(start, direction, layer, 3.5, 1.0, slope=0.5)
    assert (expected > 1.0).all()  # every ray crosses the cone
    np.testing.assert_allclose(res.scores["track_length"]["cyl"], expected, rtol=0, atol=tol)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"face": "side"}, r"no face 'side' on a G4Tubs; its faces: -z, outer, \+z; groups: all"),
        ({"face": "outer", "solid": "blocks"}, r"solid blocks on a curved face"),
    ],
)
def test_bad_curved_layers_are_one_line_errors(cylinder, change, message):
    data = cylinder_config(cylinder)
    data["targets"][0]["rough"][0].update(change)
    with pytest.raises(ConfigError, match=message):
        build_scene(parse_config(data))


def test_frustums_need_spike_grids_on_a_cylinder(cylinder):
    """A height map cannot be cut into frustums; auto keeps its bent tessellated bodies."""
    bumps = {
        "kind": "random",
        "model": "gaussian",
        "nx": 16,
        "ny": 16,
        "pitch": "5 um",
        "sq": "1 um",
        "corr_length": "10 um",
        "periodic": True,
        "seed": 1,
    }
    data = cylinder_config(cylinder, surface=bumps)
    assert build_scene(parse_config(data)).layers[0].solid_kind(0) == "tessellated"
    data["targets"][0]["rough"][0]["solid"] = "frustums"
    with pytest.raises(ConfigError, match=r"solid frustums on a curved face .* spike-grid"):
        build_scene(parse_config(data))


def test_a_radius_too_small_for_the_patch_states_the_limit(tmp_path):
    gdml = write_cylinder(tmp_path / "thin.gdml", radius=0.2, half_z=0.5)
    flat = {"kind": "spikes", "nx": 1, "ny": 1, "width": "100 um", "height": "2 um"}
    with pytest.raises(ConfigError, match=r"curved too tightly .* radius >= [\d.]+ mm"):
        build_scene(parse_config(cylinder_config(gdml, surface=flat)))


def test_a_layer_meeting_a_sister_names_it_and_the_gap(tmp_path):
    gdml = write_cylinder(tmp_path / "sister.gdml", sister=0.005)
    with pytest.raises(
        ConfigError, match=r"runs into sister volume 'cube' \(free gap there: 5 um\)"
    ):
        build_scene(parse_config(cylinder_config(gdml)))
    far = write_cylinder(tmp_path / "far.gdml", sister=0.05)
    assert build_scene(parse_config(cylinder_config(far))).layers


def test_wall_and_end_faces_rough_together(cylinder):
    """An HPGe-like detector: the side wall and both end faces rough; the layers touch at the
    edges and do not meet."""
    data = cylinder_config(cylinder)
    data["targets"][0]["rough"] += [
        {"face": "+z", "surface": "p"},
        {"face": "-z", "surface": "p"},
    ]
    scene = build_scene(parse_config(data))
    assert [type(layer).__name__ for layer in scene.layers] == [
        "CurvedRoughLayer",
        "RingRoughLayer",
        "RingRoughLayer",
    ]


def alpha_spectra(tmp_path, events: int) -> tuple[np.ndarray, np.ndarray]:
    """Deposits of 5.3 MeV alphas (isotropic, exponential depth of mean 1 um, confined) from
    10 um pyramids on a cylinder wall of radius 50 mm (a 0.04 rad sector, 2 mm x 2 mm) and on
    a flat face of the same size."""
    gdml = write_cylinder(tmp_path / "sector.gdml", radius=50.0, half_z=1.0, rmin=49.7, dphi=0.04)
    source = {
        "particle": "alpha",
        "energy": "5.3 MeV",
        "direction": "isotropic",
        "surface": {"volume": "cyl", "face": "outer"},
        "depth": {"profile": "exponential", "mean": "1 um"},
        "confine": True,
    }
    curved = cylinder_config(gdml, source=source)
    curved["run"] = {"events": events, "seed": 4}
    flat = {
        "physics": "lite",
        "surfaces": {"p": PYRAMIDS},
        "targets": [
            {
                "name": "cyl",
                "material": "G4_Si",
                "size": ["2 mm", "2 mm", "0.3 mm"],
                "rough": [{"face": "+z", "surface": "p"}],
            }
        ],
        "source": {**source, "surface": {"volume": "cyl", "face": "+z"}},
        "run": {"events": events, "seed": 4},
    }
    out = []
    for name, data in (("curved", curved), ("flat", flat)):
        path = run(parse_config(data), tmp_path / f"{name}.h5", progress=False, echo=lambda m: None)
        out.append(np.asarray(read_results(path).edep["cyl"]))
    return out[0], out[1]


def _same_spectrum(curved: np.ndarray, flat: np.ndarray) -> None:
    from scipy.stats import ks_2samp

    assert ks_2samp(curved, flat).pvalue > 0.01
    n = len(curved)
    full_c, full_f = (curved > 5.2).mean(), (flat > 5.2).mean()
    sigma = np.sqrt(full_c * (1 - full_c) / n + full_f * (1 - full_f) / n)
    assert abs(full_c - full_f) < 4 * sigma


def test_alphas_from_a_rough_wall_match_the_same_roughness_on_a_flat_face(tmp_path):
    """R = 50 mm >> the 10 um pyramids: the deposit spectra agree (two-sample KS p > 0.01 and
    full-energy shares within 4 sigma, 800 alphas each; seed fixed)."""
    _same_spectrum(*alpha_spectra(tmp_path, 800))


@pytest.mark.deep
def test_alphas_from_a_rough_wall_match_the_flat_face_deep(tmp_path):
    _same_spectrum(*alpha_spectra(tmp_path, 10000))


def test_bent_frustums_give_the_alphas_of_the_bent_tessellated_bodies(tmp_path):
    """The same wall as bent G4Trds (``solid: auto``) and as bent tessellated bodies: one
    polyhedron, two representations. 300 alphas (seed fixed) from the same vertices: most events
    deposit the same energy to 1e-9 MeV (the navigators' arithmetic differs only in rounding,
    which can change a step and so the random numbers after it), and the spectra agree
    (two-sample KS p > 0.05, means within 3 standard errors)."""
    from scipy.stats import ks_2samp

    gdml = write_cylinder(tmp_path / "sector.gdml", radius=50.0, half_z=1.0, rmin=49.7, dphi=0.04)
    source = {
        "particle": "alpha",
        "energy": "5.3 MeV",
        "direction": "isotropic",
        "surface": {"volume": "cyl", "face": "outer"},
        "depth": {"profile": "exponential", "mean": "1 um"},
        "confine": True,
    }
    out = {}
    for solid in ("frustums", "tessellated"):
        data = cylinder_config(gdml, source=source)
        data["targets"][0]["rough"][0]["solid"] = solid
        data["run"] = {"events": 300, "seed": 5}
        path = run(
            parse_config(data), tmp_path / f"{solid}.h5", progress=False, echo=lambda m: None
        )
        out[solid] = np.asarray(read_results(path).edep["cyl"])
    a, b = out["frustums"], out["tessellated"]
    assert (np.abs(a - b) <= 1e-9).mean() > 0.8
    assert ks_2samp(a, b).pvalue > 0.05
    assert abs(a.mean() - b.mean()) < 3 * np.sqrt((a.var() + b.var()) / len(a))


def test_a_source_on_a_list_of_faces_weighs_the_rough_wall_by_its_mesh_area(cylinder):
    source = {
        "particle": "geantino",
        "energy": "1 MeV",
        "surface": {"volume": "cyl", "face": ["outer", "+z"]},
    }
    config = parse_config(cylinder_config(cylinder, source=source))
    scene = build_scene(config)
    geo = source_geometry(config, scene)
    wall = source_geometry(
        parse_config(cylinder_config(cylinder)),
        build_scene(parse_config(cylinder_config(cylinder))),
    )
    assert geo["faces"] == ["-z", "outer", "+z"]
    assert geo["area_mm2"] == pytest.approx(wall["area_mm2"] + math.pi * RADIUS**2, rel=1e-12)
    p = make_source(config, scene).primaries(np.random.default_rng(3), 0, 4000)
    on_top = np.isclose(p.position[:, 2], HALF_Z, atol=1e-9)
    share = math.pi * RADIUS**2 / geo["area_mm2"]
    assert abs(on_top.mean() - share) < 4 * math.sqrt(share * (1 - share) / 4000)


def test_geant4_finds_no_overlap_in_a_rough_bore(tmp_path):
    """Geant4's own overlap check over every ring and bent patch of a layer in a bore."""
    import yaml

    from helpers.g4_geometry_check import assert_no_overlaps

    gdml = write_cylinder(tmp_path / "bore.gdml", radius=1.0, half_z=0.4, rmin=0.6)
    data = cylinder_config(gdml, face="inner")
    (tmp_path / "bore.yaml").write_text(yaml.safe_dump(data))
    assert_no_overlaps(tmp_path / "bore.yaml")


def test_the_envelope_box_of_a_wall_with_a_phi_segment_holds_its_widest_point(tmp_path):
    """The bounding box of a half cylinder's wall layer (phi 0 .. pi) reaches y = r + t at
    phi = pi/2, which lies between the shell's sampled azimuths (the clearance checks use the
    box to pass over sisters far from the layer; before, it stopped ~1 um short here)."""
    gdml = write_cylinder(tmp_path / "half.gdml", dphi=math.pi)
    scene = build_scene(parse_config(cylinder_config(gdml)))
    (layer,) = scene.layers
    widest = np.array([[0.0, RADIUS + layer.thickness - 1e-6, 0.0]])
    assert layer.envelope_box().contains(scene.target("cyl").to_world(widest), tol=0.0)[0]
