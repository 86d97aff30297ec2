"""Rough layers on the theta cones of a subtracted G4Sphere (score4.world.boolean_layers
.theta_wall, theta_rims): a copper box less a shell sector opening up (``cup``: r 2 .. 5 mm,
theta 0 .. 60 deg; its theta_end cone faces the axis from outside, laid out as the inner wall
of a hollow G4Cons) and less a belt (``belt``: r 2 .. 5 mm, theta 50 .. 130 deg; its two theta
cones face away from the axis, laid out as the outer walls of full G4Cons). The sphere faces
meet the cones at right angles, so the envelope ends on the rings' band cones and only rings
whose band lies in the shell keep their cells. Geantino paths against an analytic ray trace of
each box less its sphere plus the patch bodies (1e-9 mm), Geant4's overlap check (deep)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from score4.inputs.config import parse_config
from score4.shapes import G4Sphere
from score4.world.resolve import build_scene
from score4.world.scene import CurvedRoughLayer

from helpers.geantinos import geantino_config, rough_targets

pytestmark = pytest.mark.xdist_group("theta-cones")

PYRAMIDS = {"kind": "spikes", "nx": 5, "ny": 5, "width": "50 um", "height": "20 um"}
HALF = 10.0  # the boxes' half width, mm
#: volume -> (its y in the world, mm; the sphere's theta range, deg; the rough faces)
SPHERES = {
    "cup": (-20.0, (0.0, 60.0), ["second.theta_end"]),
    "belt": (20.0, (50.0, 130.0), ["second.theta_start", "second.theta_end"]),
}
RMIN, RMAX = 2.0, 5.0
#: a sector of three quarters of a circle reaching out of its box (r 5 .. 14 mm, theta 20 ..
#: 60 deg): (rmin, rmax, phi range in deg, theta range in deg)
WIDE = (5.0, 14.0, 270, (20.0, 60.0))


@pytest.fixture(scope="module")
def gdml(tmp_path_factory) -> Path:
    """A copper box (20 mm) less each sphere sector (and ``apex``: a sector without an inner
    radius, theta 0 .. 60 deg), written as GDML text."""
    from helpers.boolean_worlds import copper_world_text

    holes = {name: (RMIN, RMAX, 360, t) for name, (_y, t, _f) in SPHERES.items()}
    holes["apex"] = (0.0, RMAX, 360, (0.0, 60.0))
    holes["wide"] = WIDE
    at = {name: (0.0, y, 0.0) for name, (y, _t, _f) in SPHERES.items()}
    at["apex"], at["wide"] = (0.0, 60.0, 0.0), (0.0, -60.0, 0.0)
    solids = '<box name="world_s" x="200" y="200" z="100" lunit="mm"/>'
    for name, (rmin, rmax, dphi, (t0, t1)) in holes.items():
        solids += f"""
<box name="{name}_a" x="{2 * HALF}" y="{2 * HALF}" z="{2 * HALF}" lunit="mm"/>
<sphere name="{name}_b" rmin="{rmin}" rmax="{rmax}" startphi="0" deltaphi="{dphi}"
  starttheta="{t0}" deltatheta="{t1 - t0}" aunit="deg" lunit="mm"/>
<subtraction name="{name}_s"><first ref="{name}_a"/><second ref="{name}_b"/></subtraction>"""
    path = tmp_path_factory.mktemp("theta") / "theta.gdml"
    path.write_text(copper_world_text(solids, at))
    return path


def config(gdml: Path, into: bool = False, spheres: dict | None = None) -> dict:
    spheres = SPHERES if spheres is None else spheres
    targets = rough_targets({v: faces for v, (_y, _t, faces) in spheres.items()}, into=into)
    first = next(iter(spheres))
    return geantino_config(
        gdml, {"p": PYRAMIDS}, targets, (first, "first.-z"), output={"track_length": True}
    )


def sphere(name: str) -> G4Sphere:
    t0, t1 = SPHERES[name][1]
    return G4Sphere(RMIN, RMAX, 0.0, 2 * np.pi, math.radians(t0), math.radians(t1 - t0))


class _Solid:
    """The box less the sphere sector, for helpers.ray_trace.polycone_path (its sign only)."""

    def __init__(self, name: str) -> None:
        self.hole = sphere(name)

    def signed_distance(self, q: np.ndarray) -> np.ndarray:
        inside = (np.abs(q) < HALF).all(axis=1) & (self.hole.signed_distance(q) > 0)
        return np.where(inside, -1.0, 1.0)


def test_theta_cone_layers_keep_only_rings_in_the_shell(gdml):
    """Every theta cone's layer has one piece per run of kept rings ending on band cones; each
    kept cell's band, moved out by the layer's thickness along the face's normal, lies in the
    sphere's shell (r from rmin to rmax), and the rings dropped at the rims are the ones whose
    band does not (checked on the bands' four corners, in the sphere's frame); the pieces span
    the kept rings' bands."""
    scene = build_scene(parse_config(config(gdml)))
    for name, (_y, _t, faces) in SPHERES.items():
        for face in faces:
            layer = scene.layer(name, face)
            assert isinstance(layer, CurvedRoughLayer)
            assert layer.pieces
            assert all(p.normal_ends for p in layer.pieces)
            lay = layer.ring_layout
            half = 0.5 * (lay.patch_size[1] + lay.row_gap)
            kept = (layer.cell_variants >= 0).any(axis=1)
            assert kept.sum() >= 10
            # the layer's target frame is the turned cone's; back to the sphere's frame
            to_sphere = scene.target(name).to_local
            radii = []
            for d in (-half, half):
                for h in (0.0, layer.thickness):
                    p = lay.face.point(np.zeros(len(lay.v)), lay.v + d)
                    p = p + h * lay.face.normal(np.zeros(len(lay.v)), lay.v + d)
                    radii.append(np.linalg.norm(to_sphere(layer.target.to_world(p)), axis=1))
            r = np.array(radii)
            inside = ((r >= RMIN - 1e-12) & (r <= RMAX + 1e-12)).all(axis=0)
            assert not kept[~inside].any(), (name, face)
            rings = np.flatnonzero(kept)
            piece_v = sorted((p.v0, p.v1) for p in layer.pieces)
            assert piece_v[0][0] == pytest.approx(float(lay.v[rings[0]]) - half, abs=1e-12)
            assert piece_v[-1][1] == pytest.approx(float(lay.v[rings[-1]]) + half, abs=1e-12)


def test_an_envelope_ending_on_z_planes_runs_into_the_solid(gdml, monkeypatch):
    """The cup's layer with its envelope as a cone wall's elsewhere (the face's whole shell
    between z planes where nothing is cut): the planes across the axis leave the sphere's shell
    into the box at a rim, and the layer is refused in one line."""
    from score4.errors import ConfigError
    from score4.world import boolean_layers

    pieces = boolean_layers.envelope_pieces
    monkeypatch.setattr(
        boolean_layers, "envelope_pieces", lambda layer, normal=False: pieces(layer)
    )
    with pytest.raises(ConfigError) as err:
        build_scene(parse_config(config(gdml, False, {"cup": SPHERES["cup"]})))
    assert "runs into the solid itself" in str(err.value)
    assert "\n" not in str(err.value)


def rays(name: str, per: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Rays (box frame) from inside the sphere sector through its theta cones: from theta 25
    deg (the cup) or 90 deg (the belt), at r 3.5 mm, to points 0.3 mm beyond a cone at r 2.4 ..
    4.6 mm (half through each of the belt's two cones)."""
    phi = rng.uniform(0, 2 * np.pi, per)
    (t0, t1) = (math.radians(t) for t in SPHERES[name][1])
    from_theta = math.radians(25.0) if name == "cup" else math.pi / 2
    start = 3.5 * np.column_stack(
        [np.sin(from_theta) * np.cos(phi), np.sin(from_theta) * np.sin(phi),
         np.full(per, np.cos(from_theta))]
    )  # fmt: skip
    s = rng.uniform(2.4, 4.6, per)
    cone = np.where(np.arange(per) % 2 == 0, t1, t0) if name == "belt" else np.full(per, t1)
    beyond = cone + np.where(cone == t1, 1.0, -1.0) * 0.3 / s
    phi_aim = phi + rng.uniform(-0.3, 0.3, per)
    aim = s[:, None] * np.column_stack(
        [np.sin(beyond) * np.cos(phi_aim), np.sin(beyond) * np.sin(phi_aim), np.cos(beyond)]
    )
    d = aim - start
    return start, d / np.linalg.norm(d, axis=1, keepdims=True)


def test_geantino_paths_through_rough_theta_cones(gdml, tmp_path):
    """Geantinos from inside each sphere sector out through its theta cones: Geant4's track
    length in each box equals the analytic path in the box less the sphere plus the path in the
    patch bodies, 1e-9 mm; Geant4's volume of each box less its layers (a Monte Carlo estimate
    from 10^6 points) is the analytic one to 2e-4; most rays cross a patch."""
    from helpers.geantinos import assert_box_paths
    from helpers.ray_trace import polycone_path

    data = config(gdml)
    scene = build_scene(parse_config(data))
    rng = np.random.default_rng(11)
    starts, directions, owners = [], [], []
    for name, (y, _t, _faces) in SPHERES.items():
        start, d = rays(name, 8, rng)
        starts.append(start + np.array([0.0, y, 0.0]))
        directions.append(d)
        owners += [name] * len(start)
    crossed = assert_box_paths(
        data,
        scene,
        np.concatenate(starts),
        np.concatenate(directions),
        owners,
        lambda name, o, d: polycone_path(o, d, _Solid(name)),
        lambda name: (2 * HALF) ** 3 - sphere(name).volume,
        tmp_path,
    )
    assert crossed >= len(owners) // 2


def test_into_on_a_theta_cone_is_refused_saying_why(gdml):
    """``into`` on a theta cone would grow the sphere by a slab along the cone (an offset cone
    is no G4Sphere's theta cone): one line naming the face and why."""
    from score4.errors import ConfigError

    with pytest.raises(ConfigError) as err:
        build_scene(parse_config(config(gdml, True, {"cup": SPHERES["cup"]})))
    line = str(err.value)
    assert "\n" not in line
    assert "into: true on face second.theta_end of 'cup'" in line
    assert "theta cone" in line


def test_a_theta_cone_reaching_the_centre_is_refused_saying_why(gdml):
    """A theta cone of a subtracted G4Sphere without an inner radius closes to a point at the
    sphere's centre: one line naming the face and why."""
    from score4.errors import ConfigError

    apex = {"apex": (60.0, (0.0, 60.0), ["second.theta_end"])}
    with pytest.raises(ConfigError) as err:
        build_scene(parse_config(config(gdml, False, apex)))
    line = str(err.value)
    assert "\n" not in line
    assert "theta cone theta_end of a subtracted G4Sphere" in line
    assert "reaches the sphere's centre (rmin 0)" in line


@pytest.mark.deep
def test_rough_theta_cones_pass_the_overlap_check(gdml, tmp_path):
    """Geant4's overlap check (``score4 geometry check``, in its own process) finds no overlap
    between the theta cones' layers and their boxes."""
    import yaml

    from helpers.g4_geometry_check import assert_no_overlaps

    path = tmp_path / "theta.yaml"
    path.write_text(yaml.safe_dump(config(gdml)))
    assert_no_overlaps(path)


@pytest.mark.deep
def test_rough_theta_cones_export_with_the_same_paths(gdml, tmp_path, monkeypatch):
    """The cup's and the belt's theta cone layers in one world written by `score4 geometry
    export`: Geant4 reads the file back, and the file pyg4ometry reads and writes again, with
    the same geantino paths (volumes and points, 1e-9 mm) as the world score4 builds (the
    envelope pieces, G4GenericPolycones between band cones); most rays cross a patch."""
    import yaml

    from score4.cli.main import main

    from helpers.export_paths import assert_same_paths, three_paths

    path = tmp_path / "theta.yaml"
    path.write_text(yaml.safe_dump(config(gdml)))
    out = tmp_path / "theta.gdml"
    assert main(["geometry", "export", str(path), "--gdml", str(out)]) == 0
    out_rays = []
    for k, (name, (y, _t, _faces)) in enumerate(SPHERES.items()):
        start, d = rays(name, 8, np.random.default_rng(40 + k))
        start[:, 1] += y
        out_rays += [(o.tolist(), w.tolist()) for o, w in zip(start, d, strict=True)]
    ours, back, relay = three_paths(path, out, out_rays, monkeypatch)
    assert_same_paths(ours, back, relay)
    assert sum(any("_rough" in (v or "") for v, _ in p) for p in ours) >= len(out_rays) // 2


@pytest.mark.deep
def test_a_sector_with_a_phi_segment_cut_by_its_box_passes_the_overlap_check(gdml, tmp_path):
    """Both theta cones of a sector of three quarters of a circle that reaches out through its
    box's faces: the cones' cells outside the box are left flat, the envelope is in pieces over
    the kept cells' azimuths and rings (every piece ending on band cones), and Geant4's overlap
    check finds no overlap."""
    import yaml

    from helpers.g4_geometry_check import assert_no_overlaps

    wide = {"wide": (-60.0, WIDE[3], ["second.theta_start", "second.theta_end"])}
    data = config(gdml, False, wide)
    scene = build_scene(parse_config(data))
    start, end = (scene.layer("wide", f) for f in wide["wide"][2])
    assert start.pieces is not None
    assert end.pieces is not None
    assert start.pieces[0].dphi == pytest.approx(1.5 * np.pi, abs=1e-12)
    assert len(end.pieces) > 1  # the box's faces cut the cone at theta 60 deg (r up to 14)
    assert all(p.normal_ends for p in [*start.pieces, *end.pieces])
    path = tmp_path / "wide.yaml"
    path.write_text(yaml.safe_dump(data))
    assert_no_overlaps(path)
