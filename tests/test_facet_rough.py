"""Rough layers on flat faces of any outline (score4.world.facets): the faces of a G4Trd and a
G4Trap, the six sides of a G4Polyhedra face, every plane of a G4ExtrudedSolid and a
G4TessellatedSolid; in numpy, in Geant4 and exported to GDML."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest
import yaml

from score4.cli.main import main
from score4.errors import ConfigError
from score4.inputs.config import parse_config
from score4.runner.engine import run
from score4.runner.output import read_results
from score4.shapes.base import INSIDE, OUTSIDE, PlaneTriangles
from score4.source.build import layer_sampler, make_source, source_geometry
from score4.source.vertex_file import write_vertex_file
from score4.world.facets import point_in_triangles
from score4.world.resolve import build_scene
from score4.world.scene import PolygonRoughLayer

from helpers.export_paths import assert_same_paths, base_name, built_and_exported
from helpers.geantinos import geantino_run
from helpers.ray_trace import mesh_path

PYRAMIDS = {"kind": "spikes", "nx": 10, "ny": 10, "width": "10 um", "height": "10 um"}

#: volume -> (its rough faces, its position in the world, mm)
SOLIDS = {
    "trd": (["+x", "+z"], (0.0, 0.0, 0.0)),
    "trap": (["+x", "-y"], (12.0, 0.0, 0.0)),
    "ph": (["seg_1"], (-12.0, 0.0, 0.0)),
    "xt": (["mesh"], (0.0, 12.0, 0.0)),
    "tess": (["mesh"], (0.0, -12.0, 0.0)),
}


def octahedron(a: float) -> list:
    """Vertices and outward-wound triangles of an octahedron of half-diagonal ``a``."""
    verts = [[a, 0, 0], [-a, 0, 0], [0, a, 0], [0, -a, 0], [0, 0, a], [0, 0, -a]]
    tris = []
    for sx, ix in ((1, 0), (-1, 1)):
        for sy, iy in ((1, 2), (-1, 3)):
            for sz, iz in ((1, 4), (-1, 5)):
                tri = [ix, iy, iz]
                tris.append(tri if sx * sy * sz > 0 else tri[::-1])
    return [verts, tris]


def write_solids(path: Path, concave: bool = False) -> Path:
    """The solids of :data:`SOLIDS` (silicon, in vacuum), written by pyg4ometry; ``concave``:
    the extruded solid an L shape."""
    import pyg4ometry as pg

    reg = pg.geant4.Registry()
    s = pg.geant4.solid
    world = pg.geant4.LogicalVolume(s.Box("world_s", 60, 60, 60, reg), "G4_Galactic", "W", reg)
    outline = (
        [[-1.5, -1.5], [1.5, -1.5], [1.5, 0], [0, 0], [0, 1.5], [-1.5, 1.5]]
        if concave
        else [[-1.5, -1.2], [1.4, -1.5], [1.6, 0.8], [0.1, 1.6], [-1.4, 1.0]]
    )
    solids = {
        "trd": s.Trd("trd_s", 3, 1.6, 2.4, 1.2, 2.0, reg),
        "trap": s.Trap("trap_s", 1.5, 0.1, 0.2, 1.0, 1.2, 1.5, 0.1, 0.5, 0.6, 0.75, 0.1, reg),
        "ph": s.Polyhedra("ph_s", 0, 2 * math.pi, 6, 2, [-1.2, 1.2], [0, 0], [1.6, 1.6], reg),
        "xt": s.ExtrudedSolid("xt_s", outline, [[-1.0, [0, 0], 1], [1.0, [0, 0], 1]], reg),
        "tess": s.TessellatedSolid("tess_s", octahedron(1.8), reg),
    }
    for name, solid in solids.items():
        lv = pg.geant4.LogicalVolume(solid, "G4_Si", f"{name}_lv", reg)
        pg.geant4.PhysicalVolume([0, 0, 0], list(SOLIDS[name][1]), lv, name, world, reg)
    reg.setWorld(world.name)
    writer = pg.gdml.Writer()
    writer.addDetector(reg)
    writer.write(str(path))
    return path


def config(gdml: Path, solids=SOLIDS, **extra) -> dict:
    return {
        "physics": "lite",
        "world": {"gdml": str(gdml)},
        "surfaces": {"p": PYRAMIDS},
        "targets": [
            {"volume": v, "rough": [{"face": f, "surface": "p"} for f in solids[v][0]]}
            for v in solids
        ],
        "source": {"particle": "geantino", "energy": "1 MeV", "surface": {"volume": "trd"}},
        "run": {"events": 10, "seed": 3},
        **extra,
    }


@pytest.fixture(scope="module")
def gdml(tmp_path_factory) -> Path:
    return write_solids(tmp_path_factory.mktemp("facets") / "solids.gdml")


@pytest.fixture(scope="module")
def scene(gdml):
    return build_scene(parse_config(config(gdml)))


def test_every_plane_gets_a_layer_of_whole_cells_inside_its_polygon(scene):
    """One layer per plane of each face (6 sides of the polyhedra face, 7 planes of the
    extruded pentagon, 8 of the octahedron); each cell that holds a patch lies wholly in the
    face: its corners, a hair below the face, are inside the solid; the rough share is the
    patches' area over the face's."""
    counts: dict[str, int] = {}
    for layer in scene.layers:
        assert isinstance(layer, PolygonRoughLayer)
        counts[layer.target.name] = counts.get(layer.target.name, 0) + 1
        px, py = layer.patch_size
        centres = layer.cell_centres()[layer.mask]
        corners = np.concatenate(
            [
                centres + np.array([sx * px, sy * py])
                for sx in (-0.485, 0.485)
                for sy in (-0.485, 0.485)
            ]
        )
        below = layer.frame.to_world(np.column_stack([corners, np.full(len(corners), -1e-6)]))
        shape, t = layer.target.shape, layer.target
        assert (shape.inside(t.to_local(below)) == INSIDE).all()
        share = layer.mask.sum() * px * py / layer.face_area
        assert layer.rough_share == pytest.approx(share, rel=1e-12)
        assert 0.5 < layer.rough_share <= 1.0 + 1e-12
    assert counts == {"trd": 2, "trap": 2, "ph": 6, "xt": 7, "tess": 8}


def test_samples_lie_on_the_patches_and_the_flat_rest_by_area(gdml, scene):
    """A source on a face of several planes: points on the rough tops (in the target with its
    layers) and on the flat rest, the flat share as the uncovered area's share of the true
    area (4 sigma)."""
    data = config(gdml)
    data["source"]["surface"] = {"volume": "ph", "face": "seg_1"}
    cfg = parse_config(data)
    p = make_source(cfg, scene).primaries(np.random.default_rng(4), 0, 4000)
    assert scene.inside_target("ph", p.position).all()
    geo = source_geometry(cfg, scene)
    layers = scene.layers_of("ph")
    flat_area = sum(la.face_area * (1 - la.rough_share) for la in layers)
    tops = sum(layer_sampler(la).area for la in layers)
    assert geo["area_mm2"] == pytest.approx(tops + flat_area, rel=1e-9)
    on_flat = p.extra["patch"] < 0
    share = flat_area / geo["area_mm2"]
    assert abs(on_flat.mean() - share) < 4 * math.sqrt(share * (1 - share) / 4000)
    shape = layers[0].target
    flat_pos = shape.to_local(p.position[on_flat])
    assert np.abs(shape.shape.signed_distance(flat_pos)).max() < 1e-9


def ray_path(o: np.ndarray, d: np.ndarray, scene, volume: str) -> float:
    """Independent ray trace: the path in the solid's own triangles plus the path in each patch
    body (the surface's closed body at the cell's place in the face frame) near the ray."""
    target = scene.target(volume)
    tri = np.concatenate(
        [p.triangles for p in target.shape.patches if isinstance(p, PlaneTriangles)]
    )
    total = mesh_path(
        o, d, target.to_world(tri.reshape(-1, 3)).reshape(-1, 3, 3), edge=1e-12, merge=1e-10
    )
    for layer in scene.layers_of(volume):
        frame, t = layer.frame, layer.thickness
        lo, dl = frame.to_local(o[None])[0], d @ frame.rotation
        if abs(dl[2]) < 1e-12:
            continue
        ts = np.linspace(-lo[2] / dl[2], (t - lo[2]) / dl[2], 40)
        path = lo[None, :2] + ts[:, None] * dl[None, :2]
        px, py = layer.patch_size
        centres = layer.cell_centres()
        near = np.zeros(layer.mask.shape, dtype=bool)
        for q in path:
            near |= (np.abs(centres[..., 0] - q[0]) < px) & (np.abs(centres[..., 1] - q[1]) < py)
        body = layer.variants[0].body(layer.base_thickness)
        for j, i in zip(*np.nonzero(near & layer.mask), strict=True):
            v = body.vertices + np.array([*centres[j, i], layer.base_thickness])
            total += mesh_path(o, d, frame.to_world(v)[body.faces], edge=1e-12, merge=1e-10)
    return total


def test_geantino_paths_agree_with_an_independent_ray_trace(gdml, scene, tmp_path):
    """Geantinos from outside each solid's layers through a rough face and the solid: Geant4's
    track length in the target (its patches count) equals the ray trace of the solid's facets
    plus the patch meshes, to 1e-9 mm, on every solid."""
    data = config(gdml, output={"track_length": True})
    cfg = parse_config(data)
    rng = np.random.default_rng(7)
    starts, directions, volumes = [], [], []
    for volume in SOLIDS:
        for layer in scene.layers_of(volume):
            target = layer.target
            for _ in range(3 if layer.part < 0 else 1):
                centres = layer.cell_centres()[layer.mask]
                c = centres[rng.integers(len(centres))] + rng.uniform(-0.05, 0.05, 2)
                start = layer.frame.to_world(np.array([*c, 0.03]))
                aim = target.to_world(target.shape.sample_volume(rng, 1))[0]
                starts.append(start)
                directions.append((aim - start) / np.linalg.norm(aim - start))
                volumes.append(volume)
    n = len(starts)
    primaries = make_source(cfg, scene).primaries(np.random.default_rng(1), 0, n)
    r = geantino_run(data, primaries, np.array(starts), np.array(directions), tmp_path)
    for k in range(n):
        got = r.scores["track_length"][volumes[k]][k]
        expected = ray_path(starts[k], directions[k], scene, volumes[k])
        assert got == pytest.approx(expected, abs=1e-9, rel=0), (volumes[k], k)


def _shared(name: str | None) -> str | None:
    """A volume name without its plane inside a layer of the G4TessellatedSolid: its planes are
    faces of their own (``plane_<i>``), and the export places one set of volumes for a target's
    faces of the same make, named after the first (``tess_roughplane_0_cell`` in
    ``tess_roughplane_7``). The planes of one face (the polyhedra's ``seg_1``) do not share."""
    if name and name.startswith("tess_rough"):
        name = re.sub(r"(_rough).*?(_v\d+.*|_cell.*)$", r"\1\2", name)
    return base_name(name)


def test_exported_world_gives_the_same_geantino_paths(gdml, scene, tmp_path):
    """The world with every layer above, written to GDML by `score4 geometry export` and read
    back by Geant4: the same ray paths (volumes and points to 1e-9 mm) as the world score4
    builds, through the rough faces of the G4Trd, the six sides of the G4Polyhedra and the
    G4TessellatedSolid. Each plane's volumes carry its own plane's name (the planes' patch
    volumes were written once, under the first plane's names)."""
    solids = ("trd", "ph", "tess")
    cfg = tmp_path / "solids.yaml"
    cfg.write_text(yaml.safe_dump(config(gdml, {v: SOLIDS[v] for v in solids})))
    out = tmp_path / "world.gdml"
    assert main(["geometry", "export", str(cfg), "--gdml", str(out)]) == 0
    rng = np.random.default_rng(5)
    rays, planes = [], []
    for volume in ("trd", "tess", "ph"):  # the polyhedra's six planes last
        layers = scene.layers_of(volume)
        for layer in layers if volume == "ph" else layers[:3]:
            centres = layer.cell_centres()[layer.mask]
            for c in centres[rng.integers(len(centres), size=1 if volume == "ph" else 3)]:
                start = layer.frame.to_world(np.array([*c, 0.2]))
                tilt = layer.frame.rotation @ np.array([*rng.uniform(-0.3, 0.3, 2), -1.0])
                rays.append((start.tolist(), tilt.tolist()))
                planes.append(layer.name)
    ours, back = built_and_exported(cfg, out, rays)
    assert_same_paths(ours, back, names=_shared)
    assert min(len(a) for a in ours) > 4  # the rays cross layers, cells and spikes
    for plane, path in zip(planes[-6:], back[-6:], strict=True):
        names = [v for v, _ in path]
        rough = [v for v in names[: names.index("ph")] if v and "_rough" in v]  # on the way in
        assert len(rough) >= 2, names  # a cell and its patch
        assert all(v == plane or v.startswith(f"{plane}_") for v in rough), (plane, rough)


def test_geant4_finds_no_overlap_on_neighbouring_rough_faces(gdml, tmp_path, capsys):
    """Geant4's own overlap check on the trd's two neighbouring rough faces (prism envelopes
    that meet at the edge) and the cells in them."""
    solids = {"trd": SOLIDS["trd"]}
    data = config(gdml, solids)
    data["surfaces"]["p"] = {**PYRAMIDS, "nx": 40, "ny": 40}  # 0.4 mm patches: fewer cells
    (tmp_path / "trd.yaml").write_text(yaml.safe_dump(data))
    assert main(["geometry", "check", str(tmp_path / "trd.yaml")]) == 0
    assert "no overlaps" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("volume", "change", "message"),
    [
        ("trd", {"face": "top"}, r"no face 'top' on a G4Trd; its faces: \+x, -x, \+y, -y, \+z, -z"),
        (
            "trap",
            {"face": "+x", "tiling": "portal"},
            r"tiling portal on face \+x of 'trap' \(a G4Trap\): a portal's subworlds must lie",
        ),
        ("ph", {"face": "seg_1", "native_layout": "replicas"}, r"takes auto or placements"),
        ("trd", {"face": "+z", "tiling": "portal"}, r"takes tiling: native"),
        (
            "tess",
            {"face": "plane_8"},
            (
                r"no face 'plane_8' on a G4TessellatedSolid; "
                r"its faces: plane_0, .*; groups: mesh, all$"
            ),
        ),
        (
            "xt",
            {"face": "side_5"},
            r"its faces: -z, \+z, side_0, .*, side_4; groups: mesh, sides, all$",
        ),
    ],
)
def test_bad_facet_layers_are_one_line_errors(gdml, volume, change, message):
    data = config(gdml, {volume: SOLIDS[volume]})
    data["targets"][0]["rough"] = [{"surface": "p", **change}]
    with pytest.raises(ConfigError, match=message):
        build_scene(parse_config(data))


def test_a_face_smaller_than_a_patch_states_its_size(gdml):
    data = config(gdml, {"trd": SOLIDS["trd"]})
    data["surfaces"]["p"] = {**PYRAMIDS, "nx": 400, "ny": 400}  # 4 mm patches
    with pytest.raises(ConfigError, match=r"no whole patch of 4000 x 4000 um fits on face \+x"):
        build_scene(parse_config(data))


def test_layers_meeting_at_a_concave_edge_are_refused(tmp_path):
    """An L-shaped extrusion: the layers of the two faces of its inner corner would overlap."""
    gdml = write_solids(tmp_path / "l.gdml", concave=True)
    with pytest.raises(ConfigError, match=r"xt_roughside_\d+: .* runs into the rough layer"):
        build_scene(parse_config(config(gdml, {"xt": SOLIDS["xt"]})))
    data = config(gdml, {"xt": (["side_0"], SOLIDS["xt"][1])})
    data["targets"][0]["rough"][0]["into"] = True  # into: a solid score4 cannot clip
    with pytest.raises(ConfigError, match=r"into: true on face side_0 of 'xt' \(a G4Extruded"):
        build_scene(parse_config(data))


def test_the_trap_outline_matches_its_shape(scene):
    """The G4Trap read from the GDML: its +x face is the quadrilateral of its corners."""
    layer = scene.layer("trap", "+x")
    e1 = layer.outline[:, 1] - layer.outline[:, 0]
    e2 = layer.outline[:, 2] - layer.outline[:, 0]
    area = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]).sum()
    assert area == pytest.approx(layer.target.shape.face_areas["+x"], rel=1e-12)
    centre = layer.target.to_local(layer.frame.centre[None])
    assert (layer.target.shape.inside(centre) != OUTSIDE).all()


def test_the_planes_of_a_mesh_are_faces_of_their_own(scene):
    """The octahedron's 8 planes are faces plane_0..plane_7 and the extruded pentagon's -z, +z
    and side_0..side_4 (groups mesh and sides): each face is its coplanar facets, -z and +z
    lie at the ends with normals -z and +z, and the faces' areas add up to the solid's."""
    tess, xt = scene.target("tess").shape, scene.target("xt").shape
    assert tess.faces == tuple(f"plane_{i}" for i in range(8))
    assert tess.groups["mesh"] == tess.faces
    assert xt.faces == ("-z", "+z", *(f"side_{i}" for i in range(5)))
    assert xt.groups["sides"] == xt.faces[2:]
    assert xt.groups["mesh"] == xt.faces
    for shape in (tess, xt):
        total = sum(p.area for p in shape.patches)
        assert sum(shape.face_areas.values()) == pytest.approx(total, rel=1e-12)
        for face in shape.faces:
            tri = np.concatenate(
                [p.triangles for p in shape.patches if shape.faces[p.face] == face]
            )
            n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
            n /= np.linalg.norm(n, axis=1)[:, None]
            np.testing.assert_allclose(n, np.broadcast_to(n[0], n.shape), atol=1e-12)
            offset = np.einsum("ij,ij->i", tri.reshape(-1, 3), np.repeat(n, 3, axis=0))
            assert np.ptp(offset) < 1e-12
            if face in ("-z", "+z"):
                sign = 1.0 if face == "+z" else -1.0
                np.testing.assert_allclose(n[0], [0, 0, sign], atol=1e-12)
                assert tri[..., 2].min() == pytest.approx(sign * 1.0, abs=1e-12)


def test_one_plane_of_a_mesh_takes_a_rough_layer_and_a_source(gdml):
    """A rough layer on plane_3 of the octahedron alone, and on side_2 of the extrusion; a
    source on [side_2, -z] of the extrusion draws on those two faces only (the rough tops of
    side_2, the flat rest of side_2 and -z), each point in the target with its layer, with
    the flat share of the true area (4 sigma)."""
    data = config(gdml, {"tess": (["plane_3"], SOLIDS["tess"][1]), "xt": (["side_2"], (0, 12, 0))})
    data["source"]["surface"] = {"volume": "xt", "face": ["side_2", "-z"]}
    cfg = parse_config(data)
    scene = build_scene(cfg)
    assert [la.name for la in scene.layers] == ["tess_roughplane_3", "xt_roughside_2"]
    p = make_source(cfg, scene).primaries(np.random.default_rng(8), 0, 4000)
    assert scene.inside_target("xt", p.position).all()
    layer = scene.layers_of("xt")[0]
    on_flat = p.extra["patch"] < 0
    face = layer.frame.to_local(p.position)
    target = layer.target
    local = target.to_local(p.position[on_flat])
    on_side = np.abs(face[on_flat, 2]) < 1e-9
    on_bottom = np.abs(local[:, 2] + 1.0) < 1e-9
    assert (on_side | on_bottom).all()  # flat points: on side_2 or on -z
    assert not on_side.all()
    assert not on_bottom.all()
    rough = ~on_flat  # rough tops: over side_2, within the layer
    assert (face[rough, 2] > -1e-9).all()
    assert (face[rough, 2] <= layer.thickness).all()
    assert layer.in_face(face[rough, :2]).all()
    geo = source_geometry(cfg, scene)
    flat_area = layer.face_area * (1 - layer.rough_share) + target.shape.face_areas["-z"]
    share = flat_area / geo["area_mm2"]
    assert abs(on_flat.mean() - share) < 4 * math.sqrt(share * (1 - share) / 4000)


def test_geometry_list_names_each_targets_faces_and_groups(gdml, tmp_path, capsys):
    """`score4 geometry list --faces`: each target's faces with their areas, and its groups;
    a source on a face the mesh lacks is one line naming its faces and groups, exit 2."""
    data = config(gdml, {"tess": (["plane_3"], SOLIDS["tess"][1]), "xt": (["side_2"], (0, 12, 0))})
    cfg = tmp_path / "planes.yaml"
    cfg.write_text(yaml.safe_dump(data))
    assert main(["geometry", "list", "--faces", str(cfg)]) == 0
    out = capsys.readouterr().out
    assert "    faces: plane_0 (2.8059 mm2), plane_1 (2.8059 mm2)," in out
    assert "    groups: mesh = plane_0, plane_1, plane_2," in out
    assert "    faces: -z (7.725 mm2), +z (7.725 mm2), side_0 (3.2311 mm2)," in out
    assert "; sides = side_0, side_1, side_2, side_3, side_4\n" in out
    data["source"]["surface"] = {"volume": "tess", "face": "plane_4x"}
    cfg.write_text(yaml.safe_dump(data))
    assert main(["run", str(cfg), "--out", str(tmp_path / "o.h5")]) == 2
    err = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert len(err) == 1, err
    assert (
        "source.surface.face: tess: no face 'plane_4x' on a G4TessellatedSolid; its faces: "
        "plane_0, plane_1, plane_2, plane_3, plane_4, plane_5, plane_6, plane_7; groups: mesh, all"
    ) in err[0]
    assert not (tmp_path / "o.h5").exists()


INTO = {
    "trd": (["+x"], (0.0, 0.0, 0.0)),
    "trap": (["+x"], (12.0, 0.0, 0.0)),
    "xt": (["side_2"], (0.0, 12.0, 0.0)),
    "tess": (["plane_3"], (0.0, -12.0, 0.0)),
}


@pytest.fixture(scope="module")
def into_data(gdml) -> dict:
    data = config(gdml, INTO, output={"track_length": True})
    for t in data["targets"]:
        t["rough"] = [{**r, "into": True} for r in t["rough"]]
    return data


def _clipped_path(o: np.ndarray, d: np.ndarray, tri: np.ndarray, n: np.ndarray, top: float):
    """Path of a ray in a convex solid (its triangles) cut by ``n . x <= top``: the chord of
    the solid (two crossings) clipped by the half-space, apart from score4's clipping."""
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    pv = np.cross(d, e2)
    det = np.einsum("ij,ij->i", e1, pv)
    ok = np.abs(det) > 1e-30
    inv = np.where(ok, 1 / np.where(ok, det, 1), 0)
    tv = o - tri[:, 0]
    u = np.einsum("ij,ij->i", tv, pv) * inv
    w = (np.cross(tv, e1) @ d) * inv
    t = np.einsum("ij,ij->i", e2, np.cross(tv, e1)) * inv
    hit = ok & (u >= -1e-12) & (w >= -1e-12) & (u + w <= 1 + 1e-12)
    if not hit.any():
        return 0.0
    t0, t1 = float(t[hit].min()), float(t[hit].max())
    nd, no = float(n @ d), float(n @ o)
    if abs(nd) > 1e-15:  # n . (o + s d) <= top
        bound = (top - no) / nd
        t0, t1 = (max(t0, bound), t1) if nd < 0 else (t0, min(t1, bound))
    elif no > top:
        return 0.0
    return max(t1 - max(t0, 0.0), 0.0)


def test_into_layers_cut_convex_solids_of_flat_facets(into_data, tmp_path):
    """into: true on a face of a G4Trd, G4Trap, extruded and tessellated solid: the layer's top
    lies in the face's plane, the solid is clipped by that plane moved in by the layer's
    thickness (points of the slab are not in the target unless in a patch, points below are),
    and Geant4's geantino track lengths in the target equal an independent ray trace (the
    solid's chord clipped by the plane, plus the patch meshes) to 1e-9 mm."""
    cfg = parse_config(into_data)
    scene = build_scene(cfg)
    rng = np.random.default_rng(11)
    starts, directions, volumes = [], [], []
    for volume in INTO:
        (layer,) = scene.layers_of(volume)
        target, t = layer.target, layer.thickness
        assert layer.config.into
        tri = np.concatenate([p.triangles for p in target.shape.patches])
        n = target.rotation.T @ layer.frame.normal
        top = float(n @ target.to_local(layer.frame.centre[None])[0])
        assert float((tri.reshape(-1, 3) @ n).max()) == pytest.approx(top + t, abs=1e-12)
        inner = target.to_world(target.shape.sample_volume(rng, 4000))
        depth = layer.frame.to_local(inner)[:, 2]
        inside = scene.inside_target(volume, inner)
        assert inside[depth <= -1e-9].all()  # below the cut: the target's material
        slab = depth > 1e-9  # in the slab: only where a patch body is
        assert slab.sum() > 0
        np.testing.assert_array_equal(inside[slab], layer.contains(inner[slab]))
        # the flat rest is drawn on the face's polygon cut to the solid's section at the cut
        # (narrower where a side leans inward: the G4Trd's and G4Trap's +x faces)
        lu, lv = 2 * np.abs(layer.outline).max(axis=(0, 1))
        xy = rng.uniform(-0.5, 0.5, (100_000, 2)) * [lu, lv]
        base = point_in_triangles(xy, layer.base_outline, 1e-12)
        cut = target.contains(layer.frame.to_world(np.column_stack([xy, np.zeros(len(xy))])))
        np.testing.assert_array_equal(base, cut & layer.in_face(xy))
        face = {**into_data, "source": {**into_data["source"], "confine": False}}
        face["source"]["surface"] = {"volume": volume, "face": INTO[volume][0][0]}
        p = make_source(parse_config(face), scene).primaries(rng, 0, 3000)
        assert scene.inside_target(volume, p.position).all()  # rough tops and the flat rest
        flat = p.extra["patch"] < 0
        assert 0 < flat.mean() < 0.5
        assert np.abs(layer.frame.to_local(p.position[flat])[:, 2]).max() < 1e-9  # on the cut
        for _ in range(4):
            centres = layer.cell_centres()[layer.mask]
            c = centres[rng.integers(len(centres))] + rng.uniform(-0.05, 0.05, 2)
            start = layer.frame.to_world(np.array([*c, t + 0.03]))
            aim = target.to_world(target.shape.sample_volume(rng, 1))[0]
            starts.append(start)
            directions.append((aim - start) / np.linalg.norm(aim - start))
            volumes.append(volume)
    n_rays = len(starts)
    primaries = make_source(cfg, scene).primaries(np.random.default_rng(1), 0, n_rays)
    primaries.position[:] = np.array(starts)
    primaries.direction[:] = np.array(directions)
    vfile = write_vertex_file(tmp_path / "v.h5", primaries, {}, 1)
    replay = parse_config(
        {**into_data, "source": {"vertices": str(vfile)}, "run": {"events": n_rays}}
    )
    r = read_results(run(replay, tmp_path / "g.h5", progress=False, echo=lambda m: None))
    for k in range(n_rays):
        (layer,) = scene.layers_of(volumes[k])
        target = layer.target
        tri = np.concatenate([p.triangles for p in target.shape.patches])
        world_tri = target.to_world(tri.reshape(-1, 3)).reshape(-1, 3, 3)
        n = layer.frame.normal
        top = float(n @ layer.frame.centre)
        expected = _clipped_path(starts[k], directions[k], world_tri, n, top)
        patches = ray_path(starts[k], directions[k], scene, volumes[k]) - mesh_path(
            starts[k], directions[k], world_tri, edge=1e-12, merge=1e-10
        )
        got = r.scores["track_length"][volumes[k]][k]
        assert got == pytest.approx(expected + patches, abs=1e-9, rel=0), (volumes[k], k)
        assert patches > 0 or expected > 0


def test_into_layers_on_neighbouring_faces_are_refused(gdml):
    """The six sides of a polyhedra face: their into layers meet below the common edges."""
    data = config(gdml, {"ph": SOLIDS["ph"]})
    data["targets"][0]["rough"][0]["into"] = True
    with pytest.raises(
        ConfigError,
        match=r"ph_roughseg_1_0: .* runs into the rough layer .*"
        r"into: the layers of two faces that share an edge meet below it",
    ):
        build_scene(parse_config(data))


@pytest.mark.deep
def test_exported_into_world_gives_the_same_geantino_paths(into_data, tmp_path):
    """into layers on the G4Trd and the G4TessellatedSolid written to GDML (the clipped solids
    as tessellated solids) and read back by Geant4: the same ray paths to 1e-9 mm."""
    data = {
        **into_data,
        "targets": [t for t in into_data["targets"] if t["volume"] in ("trd", "tess")],
    }
    cfg = tmp_path / "into.yaml"
    cfg.write_text(yaml.safe_dump(data))
    out = tmp_path / "world.gdml"
    assert main(["geometry", "export", str(cfg), "--gdml", str(out)]) == 0
    scene = build_scene(parse_config(data))
    rng = np.random.default_rng(5)
    rays = []
    for layer in scene.layers:
        centres = layer.cell_centres()[layer.mask]
        for c in centres[rng.integers(len(centres), size=4)]:
            start = layer.frame.to_world(np.array([*c, 0.2]))
            tilt = layer.frame.rotation @ np.array([*rng.uniform(-0.3, 0.3, 2), -1.0])
            rays.append((start.tolist(), tilt.tolist()))
    ours, back = built_and_exported(cfg, out, rays)
    assert_same_paths(ours, back, names=_shared)
    assert min(len(a) for a in ours) > 4
