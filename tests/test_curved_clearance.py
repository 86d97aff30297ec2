"""The clearance check of a curved layer against a flat one is exact where its grid of points is
sparse (:func:`score4.world.clearance.shells_meet`): a 20 um pair of layers that meet between
the grid's points is refused, with the free gap."""

from __future__ import annotations

import math

import numpy as np
import pytest

import score4.world.clearance as clearance
from score4.errors import ConfigError
from score4.inputs.config import parse_config
from score4.world.resolve import build_scene

R = 5.0  # mm, the cylinder's radius
PYRAMIDS = {"kind": "spikes", "nx": 10, "ny": 10, "width": "10 um", "height": "10 um"}


def write_world(path, gap_um: float):
    """A silicon cylinder (radius 5 mm, 4 mm long) and a copper plate (0.5 x 20 x 4 mm) beside
    it, its -x face facing the wall ``gap_um`` from it, turned to azimuth 2.5 degrees (between
    two of the 72 azimuths of the wall's grid of points) and slid 1.25 mm along the wall (half
    the spacing of the plate layer's grid, so no grid point lies where the two come closest)."""
    import pyg4ometry as pg

    reg = pg.geant4.Registry()
    world = pg.geant4.LogicalVolume(
        pg.geant4.solid.Box("world_s", 200, 200, 200, reg), "G4_Galactic", "World", reg
    )
    cyl = pg.geant4.LogicalVolume(
        pg.geant4.solid.Tubs("cyl_s", 0, R, 4.0, 0, 2 * math.pi, reg), "G4_Si", "Cyl", reg
    )
    pg.geant4.PhysicalVolume([0, 0, 0], [0, 0, 0], cyl, "cyl", world, reg)
    plate = pg.geant4.LogicalVolume(
        pg.geant4.solid.Box("plate_s", 0.5, 20, 4, reg), "G4_Cu", "Plate", reg
    )
    phi = math.radians(2.5)
    radial = np.array([math.cos(phi), math.sin(phi), 0.0])
    along = np.array([-math.sin(phi), math.cos(phi), 0.0])
    centre = (R + gap_um * 1e-3 + 0.25) * radial + 1.25 * along
    # (GDML rotations turn the frame: -phi turns the plate by +phi)
    pg.geant4.PhysicalVolume([0, 0, -phi], centre.tolist(), plate, "plate", world, reg)
    reg.setWorld(world.name)
    writer = pg.gdml.Writer()
    writer.addDetector(reg)
    writer.write(str(path))
    return path


def config(gdml) -> dict:
    return {
        "physics": "lite",
        "world": {"gdml": str(gdml)},
        "surfaces": {"p": PYRAMIDS},
        "targets": [
            {"volume": "cyl", "rough": [{"face": "outer", "surface": "p"}]},
            {"volume": "plate", "rough": [{"face": "-x", "surface": "p"}]},
        ],
        "source": {
            "particle": "geantino",
            "energy": "1 MeV",
            "surface": {"volume": "cyl", "face": "outer"},
        },
    }


@pytest.fixture(scope="module")
def near(tmp_path_factory):
    """The scene of the plate 19 um from the wall, built without its clearance check."""
    gdml = write_world(tmp_path_factory.mktemp("near") / "w.gdml", 19.0)
    with pytest.MonkeyPatch.context() as m:
        m.setattr("score4.world.resolve.check_clearance", lambda scene: None)
        return build_scene(parse_config(config(gdml)))


def test_layers_that_meet_between_the_grid_points_are_refused(near, monkeypatch):
    """19 um between the wall and the plate, two 11 um layers: they overlap by 3 um over a
    strip 0.2 mm wide. The grid of points alone lets it pass; the exact search refuses it with
    the free gap (19 um less the plate's 11.001 um layer)."""
    with monkeypatch.context() as m:  # the check as it was: points only
        m.setattr(clearance, "shells_meet", lambda layer, other, tol=0.0: None)
        clearance.check_clearance(near)
    with pytest.raises(ConfigError) as err:
        clearance.check_clearance(near)
    text = str(err.value)
    assert "\n" not in text
    assert text.startswith("cyl_roughouter: the rough layer on face outer of 'cyl'")
    assert "runs into the rough layer plate_roughmx (free gap there: 7.999 um)" in text
    wall, plate = near.layers
    hit = clearance.shells_meet(wall, plate)  # a point in both envelopes
    assert hit is not None
    assert wall.in_shell(hit[None])[0]
    assert plate.envelope_box().contains(hit[None])[0]


def test_layers_apart_pass(tmp_path):
    """23 um apart the two 11 um layers keep 1 um of space: accepted."""
    scene = build_scene(parse_config(config(write_world(tmp_path / "apart.gdml", 23.0))))
    assert len(scene.layers) == 2


@pytest.fixture(scope="module")
def bege_gdml(tmp_path_factory):
    pytest.importorskip("pygeomhpges")
    import runpy

    from test_bege_whole_surface import MINI, WRITER

    gdml = tmp_path_factory.mktemp("bege_depth") / "mini.gdml"
    runpy.run_path(str(WRITER), run_name="write")["main"](str(gdml), metadata=True, detector=MINI)
    return gdml


@pytest.mark.parametrize("face", ["seg_6", "seg_7"])  # a cylinder wall, a cone (G4Cons envelope)
def test_the_depth_agrees_with_the_envelope(bege_gdml, face):
    """The exact search's depth in a curved layer's envelope is positive where ``in_shell``
    holds and negative elsewhere (points scattered around the small BEGe's side and taper),
    and changes by no more than the distance a point moves."""
    from test_bege_whole_surface import config as bege_config

    (layer,) = build_scene(parse_config(bege_config(bege_gdml, face=face, source_face=face))).layers
    rng = np.random.default_rng(4)
    shell = layer.shell_points()
    pts = shell[rng.integers(len(shell), size=20000)] + rng.normal(scale=0.01, size=(20000, 3))
    depth = clearance._depth(layer, pts)
    inside = layer.in_shell(pts)
    assert inside.any()
    assert (~inside).any()
    assert (depth[inside] > 0).all()
    assert (depth[~inside] <= 1e-9).all()
    step = rng.normal(scale=0.003, size=pts.shape)
    moved = clearance._depth(layer, pts + step)
    assert (np.abs(moved - depth) <= np.linalg.norm(step, axis=1) + 1e-12).all()


def test_the_depth_agrees_with_a_boolean_faces_cells_envelope(tmp_path):
    """A union's disk face (a ring) partly covered by its post keeps the prism of its kept
    cells as envelope (``cells_envelope``): the depth follows that prism, not the ring, and the
    post's wall layer rising from it does not meet it."""
    from test_boolean_faces import config as boolean_config

    from helpers.boolean_worlds import write_more_world

    gdml = write_more_world(tmp_path / "more.gdml")
    data = boolean_config(gdml, {"stack": ["first.+z", "second.outer"]})
    top, wall = build_scene(parse_config(data)).layers
    assert top.cells_envelope
    rng = np.random.default_rng(5)
    pts = top.envelope_points()
    pts = pts[rng.integers(len(pts), size=20000)] + rng.normal(scale=0.02, size=(20000, 3))
    depth = clearance._depth(top, pts)
    inside = top.in_envelope(pts)
    assert inside.any()
    assert (~inside).any()
    assert (depth[inside] > 0).all()
    assert (depth[~inside] <= 1e-9).all()
    assert clearance.shells_meet(wall, top) is None


# -- sisters against a curved layer: the certified search on the sister's signed distance ------


def wall_config(gdml) -> dict:
    """Only the cylinder's wall rough (an 11.001 um layer); the plate is a bare sister."""
    data = config(gdml)
    data["targets"] = data["targets"][:1]
    return data


def _gap_um(text: str) -> float:
    return float(text.split("free gap there: ")[1].split(" um")[0])


@pytest.mark.parametrize("gap_um", [8.0, 9.5, 10.5])  # pokes 3, 1.5, 0.5 um into the layer
def test_a_sister_between_the_grid_points_is_refused(tmp_path, gap_um):
    """A copper plate (a bare sister, no layer) whose flat face comes ``gap_um`` from the wall
    pokes ``11 - gap_um`` um into the wall's 11 um layer, over a strip less than 4 degrees wide
    that lies between two of the grid's 72 azimuths. The grid alone lets it pass; the certified
    search on the plate's signed distance finds it (0.5 um is below its 1.1 um resolution, and
    found all the same: the middle of each cell's outer side is tried too), and the error names
    the sister and the free gap, that of the closest approach (the plate's distance, 1e-5 mm)."""
    scene_data = parse_config(wall_config(write_world(tmp_path / "w.gdml", gap_um)))
    with pytest.MonkeyPatch.context() as m:  # the check as it was: the grid of points only
        m.setattr(clearance, "certified_meet", lambda *a, **k: None)
        assert len(build_scene(scene_data).layers) == 1
    with pytest.raises(ConfigError) as err:
        build_scene(scene_data)
    text = str(err.value)
    assert "\n" not in text
    assert text.startswith("cyl_roughouter: the rough layer on face outer of 'cyl'")
    assert "runs into sister volume 'plate'" in text
    assert _gap_um(text) == pytest.approx(gap_um, abs=0.01)


@pytest.mark.parametrize("gap_um", [11.2, 12.0])
def test_a_sister_just_clear_of_the_layer_passes(tmp_path, gap_um):
    """The plate 0.2 um and 1 um beyond the 11.001 um layer: accepted."""
    scene = build_scene(parse_config(wall_config(write_world(tmp_path / "w.gdml", gap_um))))
    assert len(scene.layers) == 1


def _shapes():
    from score4.shapes.boolean import BooleanShape
    from score4.shapes.csg import G4Box, G4Cons, G4Orb, G4Sphere, G4Trap, G4Trd, G4Tubs
    from score4.shapes.mesh_shape import MeshShape
    from score4.shapes.revolved import G4Polycone, G4Polyhedra
    from score4.shapes.transform import Transform

    tet = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    tris = tet[[[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]]
    return {
        "box": G4Box(1.0, 0.5, 0.7),
        "trd": G4Trd(1.0, 0.5, 0.8, 0.3, 0.6),
        "trap": G4Trap(0.6, 0.2, 0.3, 0.5, 0.4, 0.6, 0.1, 0.5, 0.4, 0.6, 0.1),
        "tube segment": G4Tubs(0.3, 1.0, 0.5, 0.4, 4.0),
        "cone": G4Cons(0.2, 0.6, 0.1, 1.0, 0.6),
        "sphere shell": G4Sphere(0.4, 1.0, 0.0, 5.0, 0.3, 2.0),
        "orb": G4Orb(0.8),
        "polycone": G4Polycone(0.0, 2 * math.pi, (-0.6, 0.0, 0.6), (0.0, 0.3, 0.1), (1, 0.8, 1)),
        "polyhedra": G4Polyhedra(0.0, 2 * math.pi, 6, (-0.5, 0.5), (0.2, 0.2), (1.0, 0.8)),
        "tessellated": MeshShape(tris),
        "box less a tube": BooleanShape(
            "subtraction",
            G4Box(1.0, 1.0, 0.5),
            G4Tubs(0.0, 0.5, 1.0),
            Transform(translation=np.array([0.3, 0, 0])),
        ),
    }


@pytest.mark.parametrize("kind", list(_shapes()))
def test_the_signed_distance_of_a_sister_changes_no_faster_than_a_point_moves(kind):
    """What the certified search rests on: a shape's signed distance changes by no more than
    the distance a point moves (points scattered about the solid, steps of 0.1 mm)."""
    shape = _shapes()[kind]
    rng = np.random.default_rng(7)
    pts = rng.uniform(-1.3, 1.3, size=(20000, 3))
    step = rng.normal(scale=0.1, size=pts.shape)
    d0, d1 = shape.signed_distance(pts), shape.signed_distance(pts + step)
    assert (d0 < 0).any()
    assert (d0 > 0).any()
    assert (np.abs(d1 - d0) <= np.linalg.norm(step, axis=1) + 1e-12).all()


def write_sister_world(path, solid: str, crystal: str = "tube", **place):
    """A silicon crystal (``tube``: the cylinder of radius 5 mm, 4 mm long; ``cone``: radius 5
    mm at z = -2 to 4 mm at z = 2; ``orb``: a ball of radius 5 mm) and one copper sister:
    ``sleeve`` a tube about the same axis from radius ``rmin`` (mm) out, ``ball`` a 0.1 mm orb
    centred at ``centre``."""
    import pyg4ometry as pg

    reg = pg.geant4.Registry()
    world = pg.geant4.LogicalVolume(
        pg.geant4.solid.Box("world_s", 200, 200, 200, reg), "G4_Galactic", "World", reg
    )
    if crystal == "cone":
        body = pg.geant4.solid.Cons("cyl_s", 0, R, 0, R - 1, 4.0, 0, 2 * math.pi, reg)
    elif crystal == "orb":
        body = pg.geant4.solid.Orb("cyl_s", R, reg)
    else:
        body = pg.geant4.solid.Tubs("cyl_s", 0, R, 4.0, 0, 2 * math.pi, reg)
    cyl = pg.geant4.LogicalVolume(body, "G4_Si", "Cyl", reg)
    pg.geant4.PhysicalVolume([0, 0, 0], [0, 0, 0], cyl, "cyl", world, reg)
    if solid == "sleeve":
        s = pg.geant4.solid.Tubs("sister_s", place["rmin"], R + 1.0, 2.0, 0, 2 * math.pi, reg)
        centre = [0.0, 0.0, 0.0]
    else:
        s = pg.geant4.solid.Orb("sister_s", 0.1, reg)
        centre = list(place["centre"])
    sister = pg.geant4.LogicalVolume(s, "G4_Cu", "Sister", reg)
    pg.geant4.PhysicalVolume([0, 0, 0], centre, sister, "sister", world, reg)
    reg.setWorld(world.name)
    writer = pg.gdml.Writer()
    writer.addDetector(reg)
    writer.write(str(path))
    return path


LAYER_UM = 11.0035  # the wall's layer (um): 1 um base + 10 um pyramids bent on the wall


@pytest.mark.parametrize(("gap_um", "refused"), [(LAYER_UM, False), (LAYER_UM - 0.5, True)])
def test_a_coaxial_sleeve(tmp_path, gap_um, refused):
    """A copper sleeve about the wall from the layer's top out touches the whole layer and is
    accepted (the search runs on one half-plane of the shell, since the sleeve is round about
    the same axis: within 20 000 cells, where a search over azimuth too needs more); 0.5 um
    further in it is refused with the gap."""
    gdml = write_sister_world(tmp_path / "s.gdml", "sleeve", rmin=R + gap_um * 1e-3)
    data = parse_config(wall_config(gdml))
    if not refused:
        with pytest.MonkeyPatch.context() as m:
            m.setattr(clearance, "MAX_CELLS", 20_000)
            (layer,) = build_scene(data).layers
            assert layer.thickness * 1e3 == pytest.approx(LAYER_UM, abs=1e-6)  # touching
            # over azimuth too, the whole touching area must be halved down to the resolution
            m.setattr(clearance, "_round_shape", lambda shape: False)
            with pytest.raises(ConfigError, match="needs more than 20000 cells"):
                build_scene(data)
        return
    with pytest.raises(ConfigError, match="runs into sister volume 'sister'") as err:
        build_scene(data)
    assert _gap_um(str(err.value)) == pytest.approx(gap_um, abs=0.01)


@pytest.mark.parametrize(("poke_um", "refused"), [(2.0, True), (-0.5, False)])
def test_a_ball_between_the_grid_points(tmp_path, poke_um, refused):
    """A copper ball of radius 0.1 mm at azimuth 2.5 degrees and z = 0.25 mm (between the grid's
    azimuths and generator points) reaching ``poke_um`` into the 11 um layer: its cap in the
    layer is 40 um across, which the grid misses and the search (on the ball's distance, no
    planes to help) finds; 0.5 um short of the layer it passes."""
    phi = math.radians(2.5)
    r = R + (LAYER_UM - poke_um) * 1e-3 + 0.1
    gdml = write_sister_world(
        tmp_path / "b.gdml", "ball", centre=(r * math.cos(phi), r * math.sin(phi), 0.25)
    )
    data = parse_config(wall_config(gdml))
    if not refused:
        assert len(build_scene(data).layers) == 1
        return
    with pytest.MonkeyPatch.context() as m:  # the grid of points alone
        m.setattr(clearance, "certified_meet", lambda *a, **k: None)
        assert len(build_scene(data).layers) == 1
    with pytest.raises(ConfigError, match="runs into sister volume 'sister'") as err:
        build_scene(data)
    assert _gap_um(str(err.value)) == pytest.approx(LAYER_UM - poke_um, abs=0.01)


@pytest.mark.parametrize(
    ("gap_um", "meets"), [(8.0, True), pytest.param(12.0, False, marks=pytest.mark.deep)]
)
def test_geant4_agrees_on_a_sister(tmp_path, gap_um, meets):
    """Geant4's own overlap check (20 000 points on the wall layer's envelope, in a world
    built without score4's check) finds the plate 3 um into the layer and nothing when it is
    1 um clear (deep: a second Geant4 process), as score4's check does."""
    from helpers import g4_geometry_check
    from helpers.spawn import run_in_spawned_process

    data = wall_config(write_world(tmp_path / "w.gdml", gap_um))
    found = run_in_spawned_process(g4_geometry_check.envelope_overlaps, data)
    assert bool(found) is meets
    if meets:
        with pytest.raises(ConfigError, match="runs into sister volume 'plate'"):
            build_scene(parse_config(data))
    else:
        assert len(build_scene(parse_config(data)).layers) == 1


def test_the_plates_planes_keep_the_search_small(tmp_path, monkeypatch):
    """The plate beside the wall 0.2 um clear of the layer: its flat face runs along the
    layer's outer side over a strip, where a bound by distance alone must halve the cells down
    to the resolution. Its planes bound its depth over whole cells: with a budget of 20 000
    cells the check passes; without the planes it needs more."""
    data = parse_config(wall_config(write_world(tmp_path / "w.gdml", 11.2)))
    monkeypatch.setattr(clearance, "MAX_CELLS", 20_000)
    assert len(build_scene(data).layers) == 1
    monkeypatch.setattr(clearance, "_planes_in", lambda body, target: None)
    with pytest.raises(ConfigError, match="needs more than 20000 cells"):
        build_scene(data)


@pytest.mark.parametrize("crystal", ["cone", "orb"])
def test_a_ball_poking_into_a_cone_wall_or_a_sphere(tmp_path, crystal):
    """The same 0.1 mm ball 2 um into the layer of a cone's wall (a G4Cons envelope between
    the wall's z planes) and of a ball's face, at azimuth 2.5 degrees and z = 0.25 mm: the grid
    misses it, the search finds it; 0.5 um short of the layer it passes."""
    phi = math.radians(2.5)
    if crystal == "cone":  # the wall: r = 4.5 - z / 4, outward normal (1, 1/4) / |.|
        foot, normal = np.array([4.5 - 0.25 / 4, 0.25]), np.array([1.0, 0.25]) / math.hypot(1, 0.25)
    else:
        theta = math.acos(0.25 / R)
        foot = R * np.array([math.sin(theta), math.cos(theta)])
        normal = foot / R

    def world(poke_um: float, name: str):
        rz = foot + ((LAYER_UM - poke_um) * 1e-3 + 0.1) * normal
        centre = (rz[0] * math.cos(phi), rz[0] * math.sin(phi), rz[1])
        gdml = write_sister_world(tmp_path / name, "ball", crystal, centre=centre)
        data = wall_config(gdml)
        data["targets"][0]["rough"][0]["face"] = "outer"
        data["source"]["surface"]["face"] = "outer"
        return parse_config(data)

    data = world(2.0, "in.gdml")
    with pytest.MonkeyPatch.context() as m:  # the grid of points alone
        m.setattr(clearance, "certified_meet", lambda *a, **k: None)
        (layer,) = build_scene(data).layers
    with pytest.raises(ConfigError, match="runs into sister volume 'sister'") as err:
        build_scene(data)
    assert _gap_um(str(err.value)) == pytest.approx(layer.thickness * 1e3 - 2.0, abs=0.01)
    assert len(build_scene(world(-0.5, "out.gdml")).layers) == 1
