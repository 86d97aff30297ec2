"""Rough layers on the walls of a subtracted polycone (score4.world.boolean_layers.turned_wall):
a copper box less a tapered bore (a G4Polycone: a cone r 2 -> 2.5 mm, a ledge, a cone r 4 ->
4.5 mm) and less a stepped bore (a G4GenericPolycone: cylinders r 2 and 4 mm with a ledge
between). Each cylinder or cone segment of the contour is laid out as the inner wall of a
G4Tubs or G4Cons beside it, as a subtracted tube's or cone's wall is; with ``into`` the
polycone grows by the layer's cut along the segment's normal, its neighbours' lines kept (the
ledge gets shorter). Geantino paths against an analytic ray trace of each box less its (grown)
bore plus the patch bodies (1e-9 mm), Geant4's volumes against the analytic ones, Geant4's
overlap check."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from score4.inputs.config import parse_config
from score4.world.boolean_modes import into_depth
from score4.world.resolve import build_scene

from helpers.geantinos import geantino_config, rough_targets

pytestmark = pytest.mark.xdist_group("subtracted-polycone-walls")

PYRAMIDS = {"kind": "spikes", "nx": 5, "ny": 5, "width": "50 um", "height": "20 um"}
HALF = 10.0  # the boxes' half width, mm
#: volume -> (its y in the world, mm; the rough faces: the lower and the upper wall)
BORES = {
    "taper": (-40.0, ["second.seg_1", "second.seg_3"]),
    "step": (0.0, ["second.seg_1"]),
    "groove": (40.0, ["second.seg_3"]),
}
#: per bore, (r at the bottom, r at the top) of its lower wall (z -5 .. -2 in the bore's
#: frame) and of its upper wall (z -2 .. 5; the box's top is at z = 0)
WALLS = {"taper": ((2.0, 2.5), (4.0, 4.5)), "step": ((2.0, 2.0), (4.0, 4.0))}
#: the groove: an annular G4Polycone (r 4 mm outside; inside a cone r 2 -> 2.5 mm over z -5 .. 5
#: facing the axis) leaves a post in the box; its wall (seg_3) shrinks with into
POST = (2.0, 2.5)


@pytest.fixture(scope="module")
def gdml(tmp_path_factory) -> Path:
    """Two copper boxes (20 mm), each less a bore along the box's z axis from z = 5 mm up
    through its top (bore frame: z = 0 at the box's top), written by pyg4ometry."""
    from helpers.boolean_worlds import write_box_holes

    def holes(s, reg) -> dict:
        at = [0.0, 0.0, 10.0]
        made = {
            "taper": s.Polycone(
                "taper_b", 0, 2 * np.pi, [-5, -2, -2, 5], [0, 0, 0, 0], [2, 2.5, 4, 4.5], reg
            ),
            "step": s.GenericPolycone(
                "step_b", 0, 2 * np.pi, [0, 2, 2, 4, 4, 0], [-5, -5, -2, -2, 5, 5], reg
            ),
            "groove": s.Polycone("groove_b", 0, 2 * np.pi, [-5, 5], [*POST], [4, 4], reg),
            # a ledge 10 um wide: too narrow for the lower wall to grow into (refused)
            "narrow": s.Polycone(
                "narrow_b", 0, 2 * np.pi, [-5, -2, -2, 5], [0, 0, 0, 0], [2, 2, 2.01, 2.01], reg
            ),
        }
        ys = {**{k: y for k, (y, _f) in BORES.items()}, "narrow": 80.0, "cup": -80.0}
        out = {k: (v, at, ys[k]) for k, v in made.items()}
        # a shell sector (r 2 .. 5 mm, theta 0 .. 60 deg) inside the box: its theta cone
        out["cup"] = (s.Sphere("cup_b", 2, 5, 0, 2 * np.pi, 0, np.pi / 3, reg), [0, 0, 0], -80.0)
        return out

    return write_box_holes(tmp_path_factory.mktemp("pwalls") / "bores.gdml", holes, HALF)


def config(gdml: Path, into: bool, bores: dict | None = None) -> dict:
    bores = BORES if bores is None else bores
    targets = rough_targets({v: faces for v, (_y, faces) in bores.items()}, into=into)
    first = next(iter(bores))
    return geantino_config(
        gdml, {"p": PYRAMIDS}, targets, (first, "first.-z"), output={"track_length": True}
    )


def _wall(name: str, upper: bool) -> tuple[float, float, float, float]:
    """(z0, z1, r0, r1) of a bore's wall in its frame."""
    r0, r1 = WALLS[name][upper]
    return (-2.0, 5.0, r0, r1) if upper else (-5.0, -2.0, r0, r1)


def _grow(name: str, upper: bool, t: float) -> float:
    """How far a wall's radius moves out when the wall moves by t along its normal (the
    groove's post: in)."""
    z0, z1, r0, r1 = (-5.0, 5.0, *POST) if name == "groove" else _wall(name, upper)
    return t * math.hypot(1.0, (r1 - r0) / (z1 - z0))


def in_bore(name: str, q: np.ndarray, grown: tuple[float, float]) -> np.ndarray:
    """True for points ``q`` (n, 3; box frame) in the bore ``name`` with its lower and upper
    walls moved out by ``grown`` (radially, mm), the floor and ledge planes kept, written out
    from the solids' parameters (bore frame: z less 10 mm)."""
    rho, z = np.hypot(q[:, 0], q[:, 1]), q[:, 2] - 10.0
    if name == "groove":  # around the post, shrunk by grown[1]
        post = POST[0] + (POST[1] - POST[0]) * (z + 5.0) / 10.0 - grown[1]
        return (z >= -5.0) & (z <= 5.0) & (rho <= 4.0) & (rho >= post)
    radius = []
    for upper in (False, True):
        z0, z1, r0, r1 = _wall(name, upper)
        radius.append(r0 + (r1 - r0) * (z - z0) / (z1 - z0) + grown[upper])
    return (z >= -5.0) & (z <= 5.0) & (rho <= np.where(z <= -2.0, radius[0], radius[1]))


class _Solid:
    """The box less a (grown) bore, for helpers.ray_trace.polycone_path (its sign only)."""

    def __init__(self, name: str, grown: tuple[float, float]) -> None:
        self.name, self.grown = name, grown

    def signed_distance(self, q: np.ndarray) -> np.ndarray:
        inside = (np.abs(q) < HALF).all(axis=1) & ~in_bore(self.name, q, self.grown)
        return np.where(inside, -1.0, 1.0)


def bore_volume(name: str, grown: tuple[float, float]) -> float:
    """The volume of the (grown) bore inside the box (z from -5 to the box's top, 0), mm3."""

    def frustum(h: float, r1: float, r2: float) -> float:
        return math.pi * h / 3 * (r1 * r1 + r1 * r2 + r2 * r2)

    if name == "groove":
        post = POST[0] - grown[1], (POST[0] + POST[1]) / 2 - grown[1]  # at z = -5 and 0
        return math.pi * 16.0 * 5.0 - frustum(5.0, *post)
    (a0, a1), (b0, b1) = WALLS[name]
    top = b0 + (b1 - b0) * 2.0 / 7.0  # the upper wall's radius at the box's top
    return frustum(3.0, a0 + grown[0], a1 + grown[0]) + frustum(2.0, b0 + grown[1], top + grown[1])


def grown_by(scene, name: str) -> tuple[float, float]:
    """The radial growth of the lower and upper wall of bore ``name``: its layers' cuts along
    the walls' normals (0 without ``into``)."""
    out = [0.0, 0.0]
    for layer in scene.layers_of(name):
        if layer.config.into:
            upper = layer.config.face_name == "second.seg_3"
            out[upper] = _grow(name, upper, into_depth(layer, True))
    return out[0], out[1]


def rays(name: str, per: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Rays (bore frame, box z) from the bore's axis out through its walls: half at the lower
    wall (z -5 .. -2), half at the upper one (z -2 .. 0, in the box); in the groove, from r 3 mm
    across the post to the groove's far side."""
    phi = rng.uniform(0, 2 * np.pi, per)
    if name == "groove":
        start = np.column_stack([3 * np.cos(phi), 3 * np.sin(phi), rng.uniform(5.5, 9.5, per)])
        aim = np.column_stack([-start[:, :2], rng.uniform(5.5, 9.5, per)])
        aim[:, :2] += rng.uniform(-0.6, 0.6, (per, 2))
        d = aim - start
        return start, d / np.linalg.norm(d, axis=1, keepdims=True)
    start = np.column_stack([np.zeros((per, 2)), rng.uniform(5.5, 9.5, per)])
    aim_z = np.where(
        np.arange(per) < per // 2, rng.uniform(5.2, 7.8, per), rng.uniform(8.2, 9.8, per)
    )
    aim = np.column_stack([5 * np.cos(phi), 5 * np.sin(phi), aim_z])
    d = aim - start
    return start, d / np.linalg.norm(d, axis=1, keepdims=True)


@pytest.mark.parametrize(
    "into", [pytest.param(False, marks=pytest.mark.deep), True], ids=["outside", "into"]
)
def test_geantino_paths_through_rough_polycone_bore_walls(gdml, tmp_path, into):
    """Geantinos from each bore's axis out through its walls: Geant4's track length in each
    box equals the analytic path in the box less the bore (grown behind the rough walls with
    ``into``) plus the path in the patch bodies, 1e-9 mm; Geant4's volume of each box less its
    layers (a Monte Carlo estimate from 10^6 points) is the analytic one to 2e-4."""
    from helpers.geantinos import assert_box_paths
    from helpers.ray_trace import patches_path, polycone_path

    data = config(gdml, into)
    scene = build_scene(parse_config(data))
    rng = np.random.default_rng(7)
    starts, directions, owners = [], [], []
    for name, (y, _faces) in BORES.items():
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
        lambda name, o, d: polycone_path(o, d, _Solid(name, grown_by(scene, name))),
        lambda name: (2 * HALF) ** 3 - bore_volume(name, grown_by(scene, name)),
        tmp_path,
    )
    assert crossed >= len(owners) // 2
    for name, (_y, faces) in BORES.items():  # rays through each wall's patches
        k = [i for i, o in enumerate(owners) if o == name]
        for face in faces:
            on = [layer for layer in scene.layers_of(name) if layer.config.face_name == face]
            o, d = np.concatenate(starts)[k], np.concatenate(directions)[k]
            hits = sum(patches_path(a, b, on[0]) > 0 for a, b in zip(o, d, strict=True))
            assert hits >= 2, (name, face)


def test_into_a_polycone_wall_refuses_to_swallow_its_ledge(gdml):
    """``into`` on the lower wall of a bore whose ledge is 10 um wide (narrower than the
    layer's cut): growing the polycone would leave no ledge; one line naming the face, the
    ledge and the rule."""
    from score4.errors import ConfigError

    with pytest.raises(ConfigError) as err:
        build_scene(parse_config(config(gdml, True, {"narrow": (80.0, ["second.seg_1"])})))
    line = str(err.value)
    assert "\n" not in line
    assert "into: true on face second.seg_1 of 'narrow'" in line
    assert "leaves no face seg_2 (0.01 mm long)" in line


@pytest.mark.deep
def test_rough_polycone_bore_walls_pass_the_overlap_check(gdml, tmp_path):
    """Geant4's overlap check (``score4 geometry check``, in its own process) finds no overlap
    between the patches of the bores' wall layers and their boxes, with ``into`` (the boxes
    rebuilt around the grown polycones) and without. (The groove's post is left out: cells on
    a convex cone wall overlap their neighbours by nanometres, as on a plain G4Cons's outer
    wall, which this change does not touch.)"""
    import yaml

    from helpers.g4_geometry_check import assert_no_overlaps

    bores = {k: v for k, v in BORES.items() if k != "groove"}
    for into in (False, True):
        path = tmp_path / f"bores_{into}.yaml"
        path.write_text(yaml.safe_dump(config(gdml, into, bores)))
        assert_no_overlaps(path)


@pytest.mark.deep
def test_grown_polycone_bores_export_with_the_same_paths(gdml, tmp_path, monkeypatch):
    """The tapered and stepped bores' walls with ``into``, in one world written by `score4
    geometry export`: Geant4 reads the file back, and the file pyg4ometry reads and writes
    again, with the same geantino paths (volumes and points, 1e-9 mm) as the world score4
    builds (the grown G4GenericPolycone in the booleans); most rays cross a patch."""
    import yaml

    from score4.cli.main import main

    from helpers.export_paths import assert_same_paths, three_paths

    bores = {k: v for k, v in BORES.items() if k != "groove"}
    path = tmp_path / "grown.yaml"
    path.write_text(yaml.safe_dump(config(gdml, True, bores)))
    out = tmp_path / "grown.gdml"
    assert main(["geometry", "export", str(path), "--gdml", str(out)]) == 0
    out_rays = []
    for k, (name, (y, _faces)) in enumerate(bores.items()):
        start, d = rays(name, 8, np.random.default_rng(40 + k))
        start[:, 1] += y
        out_rays += [(o.tolist(), w.tolist()) for o, w in zip(start, d, strict=True)]
    ours, back, relay = three_paths(path, out, out_rays, monkeypatch)
    assert_same_paths(ours, back, relay)
    assert sum(any("_rough" in (v or "") for v, _ in p) for p in ours) >= len(out_rays) // 2
    text = out.read_text()
    for name in bores:  # the grown polycones, in the booleans
        assert re.search(rf'<genericPolycone [^>]*name="{name}_lv_cut_', text), name
