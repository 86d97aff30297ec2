"""``into: true`` on flat faces of subtracted solids other than a G4Box or G4Tubs
(score4.world.boolean_modes): a copper box less a conical blind hole (a G4Cons narrowing to its
floor, and one widening to it: an undercut), less a stepped G4Polycone (its floor and the ledge
at the step), less a G4Trd and less a hexagonal G4Polyhedra. The subtracted solid grows by the
layer's thickness t along the face's own normal, its neighbouring faces' planes and cones
extended; the layer lies in the slab, its cells where the grown solid fills the whole slab.
Geantino paths against an analytic ray trace of each box less its grown hole plus the patch
bodies (1e-9 mm), Geant4's volumes against the analytic ones, Geant4's overlap check."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from score4.inputs.config import parse_config
from score4.world.resolve import build_scene

from helpers.geantinos import geantino_config, rough_targets

# one worker per module: its world is written and its boolean face areas estimated once
pytestmark = pytest.mark.xdist_group("subtracted-faces")

PYRAMIDS = {"kind": "spikes", "nx": 5, "ny": 5, "width": "100 um", "height": "20 um"}
HALF = 10.0  # the boxes' half width, mm
#: volume -> (its y in the world, mm; the into faces)
HOLES = {
    "cone": (-60.0, ["second.-z"]),
    "undercut": (-30.0, ["second.-z"]),
    "pcone": (0.0, ["second.seg_0", "second.seg_2"]),
    "trd": (30.0, ["second.-z"]),
    "hedra": (60.0, ["second.seg_0"]),
}
HEX = np.radians(30.0 + 60.0 * np.arange(6))  # the hexagon's side directions


@pytest.fixture(scope="module")
def gdml(tmp_path_factory) -> Path:
    """Six copper boxes (20 mm), each less a hole whose axis is the box's z axis, from
    z = 5 mm up through its top (hole frame: z = 0 at the box's top), written by pyg4ometry."""
    from helpers.boolean_worlds import write_box_holes

    def holes(s, reg) -> dict:
        at = [0.0, 0.0, 10.0]
        made = {
            "cone": s.Cons("cone_b", 0, 2, 0, 3, 10, 0, 2 * np.pi, reg),
            "undercut": s.Cons("undercut_b", 0, 3, 0, 2, 10, 0, 2 * np.pi, reg),
            "pcone": s.Polycone(
                "pcone_b", 0, 2 * np.pi, [-5, -2, -2, 5], [0, 0, 0, 0], [2, 2.5, 4, 4.5], reg
            ),
            "trd": s.Trd("trd_b", 4, 6, 3, 5, 10, reg),
            "hedra": s.Polyhedra("hedra_b", 0, 2 * np.pi, 6, 2, [-5, 5], [0, 0], [2, 3], reg),
        }
        return {k: (v, at, HOLES.get(k, (90.0,))[0]) for k, v in made.items()}

    return write_box_holes(tmp_path_factory.mktemp("subfaces") / "holes.gdml", holes, HALF)


def config(gdml: Path, holes: dict | None = None) -> dict:
    holes = HOLES if holes is None else holes
    targets = rough_targets({v: faces for v, (_y, faces) in holes.items()}, into=True)
    first = next(iter(holes))
    return geantino_config(
        gdml, {"p": PYRAMIDS}, targets, (first, "first.-z"), output={"track_length": True}
    )


#: into on the sides: the Trd's +x face, the polyhedra's six sides (a deep test)
SIDES = {"trd": (30.0, ["second.+x"]), "hedra": (60.0, ["second.seg_1"])}


def in_hole(name: str, q: np.ndarray, t: float, sides: bool | str = False) -> np.ndarray:
    """True for points ``q`` (n, 3; box frame) in the hole ``name`` grown by ``t`` behind its
    into faces (its floor and ledge; with ``sides``, its sides of :data:`SIDES` instead, each
    plane moved by t along its normal: t sqrt(1.01) across at every z; with ``sides="floor"``,
    both its floor and those sides), written out from the solids' parameters (hole frame: z
    less 10 mm)."""
    if sides:
        return _in_grown_sides(name, q, t * math.sqrt(1.01), t if sides == "floor" else 0.0)
    x, y, z = q[:, 0], q[:, 1], q[:, 2] - 10.0
    rho = np.hypot(x, y)
    top = z <= 5.0
    if name == "cone":
        return (z >= -5.0 - t) & top & (rho <= 2.5 + 0.1 * z)
    if name == "undercut":
        return (z >= -5.0 - t) & top & (rho <= 2.5 - 0.1 * z)
    if name == "pcone":  # floor at z = -5, ledge (r 2.5 .. 4) at z = -2, both moved down
        low = rho <= 2.0 + (z + 5.0) / 6.0
        high = rho <= 4.0 + (z + 2.0) * 0.5 / 7.0
        return (z >= -5.0 - t) & top & np.where(z <= -2.0 - t, low, high)
    if name == "trd":
        w = 0.1 * (z + 5.0)
        return (z >= -5.0 - t) & top & (np.abs(x) <= 2.0 + w) & (np.abs(y) <= 1.5 + w)
    assert name == "hedra"
    apothem = np.max(np.outer(x, np.cos(HEX)) + np.outer(y, np.sin(HEX)), axis=1)
    return (z >= -5.0 - t) & top & (apothem <= 2.0 + 0.1 * (z + 5.0))


def _in_grown_sides(name: str, q: np.ndarray, across: float, floor: float) -> np.ndarray:
    x, y, z = q[:, 0], q[:, 1], q[:, 2] - 10.0
    w = 0.1 * (z + 5.0)  # below the old floor (floor > 0): the sides' planes extended
    inside = (z >= -5.0 - floor) & (z <= 5.0)
    if name == "trd":
        return inside & (x <= 2.0 + w + across) & (x >= -2.0 - w) & (np.abs(y) <= 1.5 + w)
    apothem = np.max(np.outer(x, np.cos(HEX)) + np.outer(y, np.sin(HEX)), axis=1)
    return inside & (apothem <= 2.0 + w + across)


class _Solid:
    """The box less a grown hole, for helpers.ray_trace.polycone_path (its sign only)."""

    def __init__(self, name: str, t: float, sides: bool | str) -> None:
        self.name, self.t, self.sides = name, t, sides

    def signed_distance(self, q: np.ndarray) -> np.ndarray:
        inside = (np.abs(q) < HALF).all(axis=1) & ~in_hole(self.name, q, self.t, self.sides)
        return np.where(inside, -1.0, 1.0)


def hole_volume(name: str, t: float, sides: bool | str = False) -> float:
    """The volume of the grown hole inside the box (z from the floor to the box's top), mm3."""
    if sides:  # the sections' areas are quadratic in z: Simpson
        s = t * math.sqrt(1.01)
        lo = -5 - (t if sides == "floor" else 0.0)

        def section(z: float) -> float:
            w = 0.1 * (z + 5)
            if name == "trd":
                return (4 + 2 * w + s) * (3 + 2 * w)
            return 2 * math.sqrt(3) * (2 + w + s) ** 2

        return -lo / 6 * (section(lo) + 4 * section(lo / 2) + section(0))

    def frustum(h: float, r1: float, r2: float) -> float:
        return math.pi * h / 3 * (r1 * r1 + r1 * r2 + r2 * r2)

    if name == "cone":
        return frustum(5 + t, 2 - 0.1 * t, 2.5)
    if name == "undercut":
        return frustum(5 + t, 3 + 0.1 * t, 2.5)
    if name == "pcone":
        return frustum(3, 2 - t / 6, 2.5 - t / 6) + frustum(2 + t, 4 - t / 14, 4 + 1 / 7)
    if name == "trd":  # the section's area is quadratic in z: Simpson

        def area(z: float) -> float:
            w = 0.1 * (z + 5)
            return 4 * (2 + w) * (1.5 + w)

        return (5 + t) / 6 * (area(-5 - t) + 4 * area(-2.5 - t / 2) + area(0))
    a1, a2 = 2 - 0.1 * t, 2.5  # a hexagon of apothem a: 2 sqrt(3) a^2
    return 2 * math.sqrt(3) * (5 + t) / 3 * (a1 * a1 + a1 * a2 + a2 * a2)


def test_into_subtracted_faces_lie_in_the_grown_slab(gdml):
    """Every layer's base lies t below its old face facing up (into the hole), and each kept
    cell's column lies in the grown hole: cells on the old face and on the grown one (a cone
    or Trd narrowing to its floor loses its outer cells; an undercut keeps the old face's)."""
    scene = build_scene(parse_config(config(gdml)))
    for name, (_y, faces) in HOLES.items():
        target = scene.target(name)
        for face in faces:
            layer = scene.layer(name, face)
            t = layer.thickness
            base = target.to_local(layer.frame.centre[None])[0]
            assert base[2] == pytest.approx((8.0 if face == "second.seg_2" else 5.0) - t, abs=1e-12)
            assert target.rotation.T @ layer.frame.normal == pytest.approx([0, 0, 1], abs=1e-12)
            rows, cols = np.nonzero(layer.mask)
            assert len(rows) >= 4
            centres = layer.cell_centres()[rows, cols]
            px, py = layer.patch_size
            corners = np.concatenate(
                [centres + np.array([sx * px / 2, sy * py / 2]) for sx in (-1, 1) for sy in (-1, 1)]
            )
            for h in (1e-9, t / 2, t - 1e-9):
                local = np.column_stack([corners, np.full(len(corners), h)])
                q = target.to_local(layer.frame.to_world(local))
                assert in_hole(name, q, t).all(), (name, face, h)
    assert scene.layer("cone", "second.-z").rmax == pytest.approx(2.0 - 0.1 * t, abs=1e-12)
    assert scene.layer("undercut", "second.-z").rmax == pytest.approx(3.0, abs=1e-12)
    ledge = scene.layer("pcone", "second.seg_2")
    assert (ledge.rmin, ledge.rmax) == pytest.approx((2.5, 4.0 - t / 14), abs=1e-12)


@pytest.mark.parametrize(
    "sides", [False, pytest.param(True, marks=pytest.mark.deep)], ids=["floors", "sides"]
)
def test_geantino_paths_and_volumes_through_grown_holes(gdml, tmp_path, sides):
    """Geantinos from inside each hole, down through its floor and ledge (or, deep, out through
    the Trd's +x side and the polyhedra's six sides): Geant4's track length in each box (the
    boolean rebuilt around the grown solid) equals the analytic path in the box less the grown
    hole plus the path in the patch bodies, 1e-9 mm; Geant4's volume of each cut boolean (a
    Monte Carlo estimate from 10^6 points) is the analytic one to 2e-4."""
    from helpers.geantinos import assert_box_paths
    from helpers.ray_trace import polycone_path

    holes = SIDES if sides else HOLES
    data = config(gdml, holes)
    scene = build_scene(parse_config(data))
    rng = np.random.default_rng(5)
    per = 6
    starts, directions, owners = [], [], []
    for name, (y, _faces) in holes.items():
        r0 = 3.3 if name == "pcone" else 1.4  # over the ledge (r 2.5 .. 4) or the floor
        phi = rng.uniform(0, 2 * np.pi, per)
        rho = rng.uniform(0.0, 1.0, per) * (0.6 if name == "pcone" else 1.0) + r0 - 0.3
        local = np.column_stack([rho * np.cos(phi), rho * np.sin(phi), np.full(per, 9.5)])
        aim = local + np.column_stack([rng.uniform(-3, 3, (per, 2)), np.full(per, -8.0)])
        if sides:  # from the axis at z 6 .. 9 out through a side, below the box's top
            local = np.column_stack([np.zeros((per, 2)), rng.uniform(6.0, 9.0, per)])
            out = np.column_stack([np.cos(phi), np.sin(phi), rng.uniform(-0.3, 0.1, per)])
            if name == "trd":
                out[:, :2] = np.column_stack([np.ones(per), rng.uniform(-0.4, 0.4, per)])
            aim = local + out
        d = (aim - local) / np.linalg.norm(aim - local, axis=1, keepdims=True)
        starts.append(local + np.array([0.0, y, 0.0]))
        directions.append(d)
        owners += [name] * per
    t = scene.layers[0].thickness
    crossed = assert_box_paths(
        data,
        scene,
        np.concatenate(starts),
        np.concatenate(directions),
        owners,
        lambda name, o, d: polycone_path(o, d, _Solid(name, t, sides)),
        lambda name: (2 * HALF) ** 3 - hole_volume(name, t, sides),
        tmp_path,
    )
    assert crossed >= len(owners) // 2


@pytest.mark.deep
def test_grown_holes_pass_the_overlap_check(gdml, tmp_path):
    """Geant4's overlap check (``score4 geometry check``, in its own process) finds no overlap
    between the patches of the layers and their boxes rebuilt around the grown holes, the Trd's
    and the polyhedra's floors and sides grown together."""
    import yaml

    from helpers.g4_geometry_check import assert_no_overlaps

    holes = {**HOLES, **{k: (y, HOLES[k][1] + faces) for k, (y, faces) in SIDES.items()}}
    path = tmp_path / "holes.yaml"
    path.write_text(yaml.safe_dump(config(gdml, holes)))
    assert_no_overlaps(path)


#: into on two adjacent faces of one subtracted solid: the floor and a side that meets it
FLOOR_AND_SIDE = {
    "hedra": (60.0, ["second.seg_0", "second.seg_1"]),
    "trd": (30.0, ["second.-z", "second.+x"]),
}


def edge_rays(name: str, n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Rays (box frame) from the hole's axis, half aimed at its floor near the edge where floor
    and side meet, half at the side just above that edge."""
    # the floor at box z = 5 mm (0.1 .. 0.8 mm in from the edge), the side 0 .. 0.6 mm above
    # it; the edge: x = 2 mm (Trd), apothem 2 mm (hexagon)
    inward = np.where(np.arange(n) < n // 2, rng.uniform(0.1, 0.8, n), -0.05)
    up = np.where(np.arange(n) < n // 2, 0.0, rng.uniform(0.0, 0.6, n))
    if name == "trd":
        w = 2.0 + 0.1 * up - inward
        edge = np.column_stack([w, rng.uniform(-1.2, 1.2, n), 5.0 + up])
    else:
        a = HEX[rng.integers(0, 6, n)]
        along = rng.uniform(-0.9, 0.9, n)  # a hexagon of apothem 2 has sides 2.31 mm long
        w = 2.0 + 0.1 * up - inward
        edge = np.column_stack(
            [w * np.cos(a) - along * np.sin(a), w * np.sin(a) + along * np.cos(a), 5.0 + up]
        )
    start = np.column_stack([np.zeros((n, 2)), rng.uniform(6.0, 9.0, n)])
    return start, (edge - start) / np.linalg.norm(edge - start, axis=1, keepdims=True)


@pytest.mark.parametrize(
    "name",
    [pytest.param("hedra", id="hedra"), pytest.param("trd", id="trd", marks=pytest.mark.deep)],
)
def test_geantino_paths_through_a_grown_floor_and_side(gdml, tmp_path, name):
    """``into`` on a hole's floor and a side that meets it (the polyhedra's floor and its six
    sides; deep: the Trd's floor and its +x side): the solid grows behind both, and geantinos
    from the hole's axis aimed at the floor up to 0.8 mm from the edge where floor and side meet,
    and at the side up to 0.6 mm above it, cross the floor's layer or the sides' and go on
    through the corner between them into the copper. Geant4's track length in
    the box equals the analytic path in the box less the hole grown behind both faces plus the
    path in the patch bodies of all its layers, 1e-9 mm; Geant4's volume to 2e-4."""
    from helpers.geantinos import assert_box_paths
    from helpers.ray_trace import patches_path, polycone_path

    holes = {name: FLOOR_AND_SIDE[name]}
    data = config(gdml, holes)
    scene = build_scene(parse_config(data))
    assert len(scene.layers_of(name)) >= 2
    y = holes[name][0]
    start, d = edge_rays(name, 16, np.random.default_rng(9))
    n = len(start)
    start = start + np.array([0.0, y, 0.0])
    layers = scene.layers_of(name)
    t = layers[0].thickness
    assert_box_paths(
        data,
        scene,
        start,
        d,
        [name] * n,
        lambda v, o, dd: polycone_path(o, dd, _Solid(v, t, "floor")),
        lambda v: (2 * HALF) ** 3 - hole_volume(v, t, "floor"),
        tmp_path,
    )
    floor, sides = holes[name][1]
    for face in (floor, sides):  # rays through the floor's patches and through the sides'
        on = [layer for layer in layers if layer.config.face_name == face]
        hits = sum(
            sum(patches_path(o, dd, layer) for layer in on) > 0
            for o, dd in zip(start, d, strict=True)
        )
        assert hits >= 3, face


@pytest.mark.deep
def test_grown_floors_and_sides_export_with_the_same_paths(gdml, tmp_path, monkeypatch):
    """The Trd's floor and +x side and the polyhedra's floor and six sides with ``into``, in one
    world written by `score4 geometry export`: Geant4 reads the file back, and the file
    pyg4ometry reads and writes again, with the same geantino paths (volumes and points,
    1e-9 mm) as the world score4 builds (the grown G4Trd and G4GenericPolyhedra in the
    booleans); most rays cross a patch."""
    import yaml

    from score4.cli.main import main

    from helpers.export_paths import assert_same_paths, three_paths

    data = config(gdml, FLOOR_AND_SIDE)
    path = tmp_path / "grown.yaml"
    path.write_text(yaml.safe_dump(data))
    out = tmp_path / "grown.gdml"
    assert main(["geometry", "export", str(path), "--gdml", str(out)]) == 0
    rays = []
    for k, (name, (y, _faces)) in enumerate(FLOOR_AND_SIDE.items()):
        start, d = edge_rays(name, 8, np.random.default_rng(30 + k))
        start[:, 1] += y
        rays += [(o.tolist(), w.tolist()) for o, w in zip(start, d, strict=True)]
    ours, back, relay = three_paths(path, out, rays, monkeypatch)
    assert_same_paths(ours, back, relay)
    assert sum(any("_rough" in (v or "") for v, _ in p) for p in ours) >= len(rays) // 2
    text = out.read_text()
    assert re.search(r'<trd [^>]*name="trd_lv_cut_', text)  # the grown solids, in the booleans
    assert re.search(r'<genericPolyhedra [^>]*name="hedra_lv_cut_', text)
