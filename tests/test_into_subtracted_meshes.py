"""``into: true`` on flat faces of a subtracted G4Trap, G4ExtrudedSolid and G4TessellatedSolid
(score4.world.boolean_modes): the subtracted solid grows by the layer's thickness t along the
face's normal, its other planes kept (``G4Trap.moved``: a G4Trap again, rebuilt from its eight
moved corners; ``MeshShape.moved``: each vertex of the face where its planes meet again; in
Geant4 the grown extruded or tessellated solid is a G4TessellatedSolid). Moves that would not
leave a valid solid are refused in one line naming the face and why.

Numpy tests of the moved solids (fast), then a copper box less a G4Trap (its floor), less an
extruded L-shaped pocket (one side moved) and less a tessellated frustum whose floor has a
vertex inside it and one on an edge: geantino paths against an analytic ray trace of each box
less its grown hole plus the patch bodies (1e-9 mm), Geant4's volumes against the analytic
ones, and (deep) Geant4's overlap check."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from score4.errors import ConfigError
from score4.inputs.config import parse_config
from score4.shapes import G4Trap, MeshShape
from score4.world.resolve import build_scene

# one worker per module: its boolean solids' face areas are estimated once
pytestmark = pytest.mark.xdist_group("subtracted-meshes")

PYRAMIDS = {"kind": "spikes", "nx": 5, "ny": 5, "width": "100 um", "height": "20 um"}
HALF = 10.0  # the boxes' half width, mm
#: the trap's parameters (G4Trap's order), scaled by 1.5 from -z to +z (its x faces planar)
TRAP = (5.0, 0.1, 0.4, 2.0, 1.6, 2.0, 0.1, 3.0, 2.4, 3.0, 0.1)
#: the extruded pocket's outline (counter-clockwise; a reflex corner at (0.3, 0.8))
OUTLINE = np.array([[-2.5, -2.0], [2.5, -2.0], [2.0, 0.5], [0.3, 0.8], [0.0, 2.2], [-2.5, 2.0]])
#: volume -> (its y in the world, mm; its into face)
HOLES = {
    "trap": (-30.0, "second.-z"),
    "xt": (0.0, "second.side_2"),
    "tess": (30.0, "second.plane_0"),
}


def trap_planes(t: float = 0.0, face: str = "") -> tuple[np.ndarray, np.ndarray]:
    """Unit outward normals and offsets of the six planes of :data:`TRAP` (n . x <= h inside),
    written out from Geant4's definition of the corners; ``face`` moved outward by ``t``."""
    dz, th, ph, dy1, dx1, dx2, a1, dy2, dx3, dx4, a2 = TRAP
    tx, ty = math.tan(th) * math.cos(ph), math.tan(th) * math.sin(ph)
    c = {}
    for z, dy, dxm, dxp, al, s in ((-dz, dy1, dx1, dx2, a1, -1), (dz, dy2, dx3, dx4, a2, 1)):
        for y, dx, sy in ((-dy, dxm, -1), (dy, dxp, 1)):
            for sx in (-1, 1):
                c[sx, sy, s] = np.array([z * tx + y * math.tan(al) + sx * dx, z * ty + y, z])
    normals, offsets = [], []
    for name, (a, b, d) in {
        "+x": ((1, -1, -1), (1, 1, -1), (1, -1, 1)),
        "-x": ((-1, -1, -1), (-1, -1, 1), (-1, 1, -1)),
        "+y": ((-1, 1, -1), (-1, 1, 1), (1, 1, -1)),
        "-y": ((-1, -1, -1), (1, -1, -1), (-1, -1, 1)),
        "+z": ((-1, -1, 1), (1, -1, 1), (-1, 1, 1)),
        "-z": ((-1, -1, -1), (-1, 1, -1), (1, -1, -1)),
    }.items():
        n = np.cross(c[b] - c[a], c[d] - c[a])
        n /= np.linalg.norm(n)
        normals.append(n)
        offsets.append(n @ c[a] + (t if name == face else 0.0))
    return np.array(normals), np.array(offsets)


def moved_outline(t: float, edge: int) -> np.ndarray:
    """:data:`OUTLINE` with edge ``edge`` (from corner ``edge`` to the next) moved outward by
    ``t``, its neighbours' lines kept."""
    p = OUTLINE
    m = len(p)

    def line(k: int, shift: float) -> tuple[np.ndarray, float]:
        a, b = p[k], p[(k + 1) % m]
        n = np.array([b[1] - a[1], a[0] - b[0]]) / np.hypot(*(b - a))  # outward (ccw)
        return n, float(n @ a) + shift

    out = p.copy()
    moved = line(edge, t)
    for corner, other in ((edge, (edge - 1) % m), ((edge + 1) % m, (edge + 1) % m)):
        kept = line(other, 0.0)
        out[corner] = np.linalg.solve(np.array([moved[0], kept[0]]), [moved[1], kept[1]])
    return out


def in_polygon(poly: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """Even-odd test of points (n, 2) in a polygon (m, 2)."""
    x, y = xy[:, 0:1], xy[:, 1:2]
    a, b = poly, np.roll(poly, -1, axis=0)
    crosses = (a[:, 1] > y) != (b[:, 1] > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        xs = a[:, 0] + (y - a[:, 1]) * (b[:, 0] - a[:, 0]) / (b[:, 1] - a[:, 1])
    return (crosses & (x < xs)).sum(axis=1) % 2 == 1


def shoelace(poly: np.ndarray) -> float:
    x, y = poly[:, 0], poly[:, 1]
    return 0.5 * float(x @ np.roll(y, -1) - y @ np.roll(x, -1))


def frustum_mesh() -> tuple[list, list]:
    """Vertices and outward-wound triangles of a tessellated square frustum (half width 2 at
    z = -5, 3 at z = 5): its floor first (plane_0: a fan around a vertex at its centre, with a
    vertex in the middle of its +x edge), then its +x side (plane_1), the others and its top."""
    lo = [[2, -2, -5], [2, 2, -5], [-2, 2, -5], [-2, -2, -5]]
    hi = [[3, -3, 5], [3, 3, 5], [-3, 3, 5], [-3, -3, 5]]
    verts = lo + hi + [[0, 0, -5], [2, 0, -5]]  # 8: floor centre, 9: on the floor's +x edge
    floor = [[8, 9, 0], [8, 1, 9], [8, 2, 1], [8, 3, 2], [8, 0, 3]]  # normal -z
    plus_x = [[0, 9, 4], [9, 5, 4], [9, 1, 5]]
    sides = [[1, 2, 6], [1, 6, 5], [2, 3, 7], [2, 7, 6], [3, 0, 4], [3, 4, 7]]
    top = [[4, 5, 6], [4, 6, 7]]
    return [[float(v) for v in p] for p in verts], floor + plus_x + sides + top


def frustum_shape() -> MeshShape:
    verts, tris = frustum_mesh()
    return MeshShape.by_planes(np.asarray(verts)[np.asarray(tris)])


# -- numpy: the moved solids ---------------------------------------------------------------


@pytest.mark.parametrize("face", ["+x", "-x", "+y", "-y", "+z", "-z"])
def test_a_moved_trap_face_moves_its_plane_only(face):
    """G4Trap.moved: the named face's plane lies t further out (t = 30 um), the other five
    planes where they were (1e-12 mm), in the frame shifted by the returned origin."""
    t = 0.03
    trap = G4Trap(*TRAP)
    grown, shift = trap.moved({face: -t})
    assert isinstance(grown, G4Trap)
    n, h = trap_planes(t, face)
    corners = grown.corners() + shift
    for k in range(6):  # every plane holds four corners, none lies outside
        d = corners @ n[k] - h[k]
        assert np.sort(np.abs(d))[:4] == pytest.approx(0.0, abs=1e-12), (face, k)
        assert (d <= 1e-12).all()
    assert grown.volume > trap.volume


def test_a_trap_cut_deeper_than_it_is_thin_is_refused():
    with pytest.raises(ConfigError, match=r"^G4Trap: moving face \+z by 1\.1e\+04 um turns"):
        G4Trap(*TRAP).moved({"+z": 11.0})


def test_a_moved_mesh_face_keeps_the_other_planes():
    """MeshShape.moved on the frustum's floor and its +x side: the floor's centre vertex moves
    along -z, the vertex on its +x edge along that side's plane; every facet of the other
    planes stays in its plane, the volume grows by the analytic amount (1e-9)."""
    shape = frustum_shape()
    assert shape.face_names[:2] == ("plane_0", "plane_1")
    t = 0.05
    grown, shift = shape.moved({"plane_0": -t, "plane_1": -t})
    assert isinstance(grown, MeshShape)
    assert shift == pytest.approx([0, 0, 0])
    slope = math.sqrt(1.01)
    hx = lambda z: 2 + 0.1 * (z + 5)  # noqa: E731
    for tri, face in zip(grown.triangles, grown.facet_faces, strict=True):
        name = grown.face_names[face]
        x, _y, z = tri.T
        if name == "plane_0":
            assert z == pytest.approx(-5 - t, abs=1e-12)
        elif name == "plane_1":
            assert x == pytest.approx(hx(z) + t * slope, abs=1e-12)
    # the section at z: (2 hx(z) + t slope) x 2 hx(z), from z = -5 - t to 5 (quadratic: Simpson)
    area = lambda z: (2 * hx(z) + t * slope) * 2 * hx(z)  # noqa: E731
    z0, z1 = -5 - t, 5.0
    expected = (z1 - z0) / 6 * (area(z0) + 4 * area((z0 + z1) / 2) + area(z1))
    assert grown.volume == pytest.approx(expected, rel=1e-12)


def test_mesh_moves_that_leave_no_valid_solid_are_refused():
    """One line naming the face and why: a corner on three other planes (an octahedron's
    face), a face that turns over (the frustum's floor moved further out than it is wide: its
    sides lean in), and a face that would cross another part of the solid (a hook's tab 10 um
    above its other arm)."""
    from test_facet_rough import octahedron

    verts, tris = octahedron(1.8)
    octa = MeshShape.by_planes(np.asarray(verts)[np.asarray(tris)])
    with pytest.raises(ConfigError) as err:
        octa.moved({"plane_0": -0.01})
    assert str(err.value).startswith("MeshShape: face plane_0 by 10 um outward: its corner (")
    assert "joins 3 other planes, which the moved plane does not meet in one point" in str(
        err.value
    )
    with pytest.raises(ConfigError, match=r"^MeshShape: face plane_0 by 2e\+04 um outward: facet"):
        frustum_shape().moved({"plane_0": -20.0})
    hook = _prism(HOOK, -0.5, 0.5)
    assert hook.volume == pytest.approx(shoelace(HOOK), rel=1e-12)
    tip = next(  # the tab's end, facing down at y = 0.41
        hook.faces[p.face]
        for p in hook.patches
        if p.normals[0] @ [0, -1, 0] > 0.99 and abs(p.triangles[..., 1].mean() - 0.41) < 1e-12
    )
    with pytest.raises(ConfigError) as err:
        hook.moved({tip: -0.02})
    message = str(err.value)
    assert message.startswith(f"MeshShape: face {tip} by 20 um outward: the moved facets would")
    assert "cross facet" in message
    assert "\n" not in message
    assert hook.moved({tip: -0.005}) is not None  # less than the gap: fine


def _cross(u: np.ndarray, v: np.ndarray) -> float:
    return float(u[0] * v[1] - u[1] * v[0])


def _prism(outline: np.ndarray, z0: float, z1: float) -> MeshShape:
    """The closed mesh of a polygon (counter-clockwise, (m, 2)) extruded from z0 to z1, its
    ends cut into triangles by ear clipping."""
    m = len(outline)
    lo = np.column_stack([outline, np.full(m, z0)])
    hi = np.column_stack([outline, np.full(m, z1)])
    tris = []
    for a in range(m):
        b = (a + 1) % m
        tris += [[lo[a], lo[b], hi[b]], [lo[a], hi[b], hi[a]]]
    left = list(range(m))
    while len(left) > 3:
        for k in range(len(left)):
            i, j, n = left[k - 1], left[k], left[(k + 1) % len(left)]
            a, b, c = outline[i], outline[j], outline[n]
            if _cross(b - a, c - b) <= 0:
                continue  # a reflex corner
            others = [outline[q] for q in left if q not in (i, j, n)]
            if any(
                _cross(b - a, p - a) >= 0 and _cross(c - b, p - b) >= 0
                and _cross(a - c, p - c) >= 0 for p in others
            ):  # fmt: skip
                continue
            tris += [[hi[i], hi[j], hi[n]], [lo[i], lo[n], lo[j]]]
            left.pop(k)
            break
    i, j, n = left
    tris += [[hi[i], hi[j], hi[n]], [lo[i], lo[n], lo[j]]]
    return MeshShape.by_planes(np.array(tris))


#: a C whose upper arm ends in a tab reaching down to 10 um above the lower arm
HOOK = np.array([[0, 0], [2, 0], [2, 0.4], [0.4, 0.4], [0.4, 1.6], [1.6, 1.6], [1.6, 0.41],
                 [2, 0.41], [2, 2], [0, 2]], float)  # fmt: skip


@pytest.mark.parametrize(
    "name", ["pocket", "pocket grown", "frustum grown", "frustum inward", "hook"]
)
def test_mesh_signed_distances_are_those_measured_against_every_facet(name):
    """MeshShape.signed_distance, which measures only the facets that can be nearest and reads
    the side from the nearest facet where it can, gives the same numbers (bit for bit) as the
    distance to every facet with the side from the winding number: random points in and around
    the mesh, on its faces and 1e-14 to 0.1 mm off them either way, at its corners (and 1e-7
    and 1e-3 mm around them) and edges."""
    from score4.shapes.mesh_shape import _tri_distance, _winding

    pocket = MeshShape.by_planes(_prism(OUTLINE, -5, 5).triangles, extruded=True)
    mesh = {
        "pocket": pocket,
        "pocket grown": pocket.moved({"side_2": -0.02}),
        "frustum grown": frustum_shape().moved({"plane_0": -0.02}),
        "frustum inward": MeshShape(frustum_shape().triangles[:, ::-1]),  # facets wound inward
        "hook": _prism(HOOK, 0, 1),
    }[name]
    if isinstance(mesh, tuple):
        mesh = mesh[0]
    assert mesh._search is not None  # closed: the pruned search
    rng = np.random.default_rng(11)
    lo, hi = mesh.bounding_box()
    s = mesh.sample_surface(rng, 1000)
    corners = mesh.triangles.reshape(-1, 3)
    points = [rng.uniform(lo - 1, hi + 1, (8000, 3)), corners,
              0.5 * (mesh.triangles[:, 0] + mesh.triangles[:, 1])]  # fmt: skip
    points += [corners + rng.normal(0, r, corners.shape) for r in (1e-7, 1e-3)]
    points += [s.position + o * s.normal for o in (0, 1e-14, 1e-10, 5e-10, 1e-7, 1e-3, 0.1)]
    points += [s.position - o * s.normal for o in (1e-14, 1e-10, 5e-10, 1e-7, 1e-3, 0.1)]
    p = np.concatenate(points)
    dist = _tri_distance(p, mesh.triangles).min(axis=1)
    expected = np.where(np.abs(_winding(p, mesh.triangles)) > 0.5, -dist, dist)
    got = mesh.signed_distance(p)
    assert np.array_equal(got, expected)
    assert (got < 0).sum() > 3000
    assert (got > 0).sum() > 3000


# -- Geant4: boxes less grown holes ------------------------------------------------------------


@pytest.fixture(scope="module")
def gdml(tmp_path_factory) -> Path:
    """Copper boxes (20 mm) less a hole whose axis is the box's z axis, from z = 5 mm up through
    its top (hole frame: z = 0 at the box's top), written by pyg4ometry."""
    from helpers.boolean_worlds import write_box_holes

    def holes(s, reg) -> dict:
        at = [0.0, 0.0, 10.0]
        made = {
            "trap": s.Trap(
                "trap_b", *(v if k in (1, 2, 6, 10) else 2 * v for k, v in enumerate(TRAP)), reg
            ),  # full lengths
            "xt": s.ExtrudedSolid("xt_b", OUTLINE.tolist(), [[-5, [0, 0], 1], [5, [0, 0], 1]], reg),
            "tess": s.TessellatedSolid("tess_b", list(frustum_mesh()), reg),
        }
        # three quarters of a tube: its phi faces' into is refused
        made["pie"] = s.Tubs("pie_b", 0, 3, 10, 0, 1.5 * math.pi, reg)
        return {k: (v, at, HOLES.get(k, (60.0,))[0]) for k, v in made.items()}

    return write_box_holes(tmp_path_factory.mktemp("submeshes") / "holes.gdml", holes, HALF)


def config(gdml: Path, faces: dict[str, str]) -> dict:
    return {
        "physics": "lite",
        "world": {"gdml": str(gdml)},
        "surfaces": {"p": PYRAMIDS},
        "targets": [
            {"volume": v, "rough": [{"face": f, "surface": "p", "into": True}]}
            for v, f in faces.items()
        ],
        "source": {
            "particle": "geantino",
            "energy": "1 MeV",
            "surface": {"volume": next(iter(faces)), "face": "first.-z"},
        },
        "run": {"events": 10, "seed": 3},
        "output": {"track_length": True},
    }


def in_hole(name: str, q: np.ndarray, t: float) -> np.ndarray:
    """True for points ``q`` (n, 3; box frame) in the hole ``name`` grown by ``t`` behind its
    into face (:data:`HOLES`), written out from the solids' parameters (hole frame: z less 10)."""
    p = q - [0.0, 0.0, 10.0]
    x, y, z = p.T
    if name == "trap":
        n, h = trap_planes(t, "-z")
        return (p @ n.T <= h).all(axis=1)
    if name == "xt":
        return (np.abs(z) <= 5.0) & in_polygon(moved_outline(t, 2), p[:, :2])
    w = 2.0 + 0.1 * (z + 5.0)
    return (z >= -5.0 - t) & (z <= 5.0) & (np.abs(x) <= w) & (np.abs(y) <= w)


def hole_volume(name: str, t: float) -> float:
    """The grown hole's volume inside the box (from its floor up to the box's top), mm3."""
    if name == "trap":  # the section's area is quadratic in z: Simpson from -5 - t to 0
        dz, _th, _ph, dy1, dx1, dx2, _a1, dy2, dx3, dx4, _a2 = TRAP

        def area(z: float) -> float:
            f = (z + dz) / (2 * dz)
            dy = dy1 + (dy2 - dy1) * f
            return 2 * dy * (dx1 + (dx3 - dx1) * f + dx2 + (dx4 - dx2) * f)

        z0 = -dz - t
        return -z0 / 6 * (area(z0) + 4 * area(z0 / 2) + area(0.0))
    if name == "xt":
        return 5.0 * shoelace(moved_outline(t, 2))
    w0, w1 = 2.0 - 0.1 * t, 2.5
    return 4 * (5 + t) / 3 * (w0 * w0 + w0 * w1 + w1 * w1)


class _Solid:
    """The box less a grown hole, for helpers.ray_trace.polycone_path (its sign only)."""

    def __init__(self, name: str, t: float) -> None:
        self.name, self.t = name, t

    def signed_distance(self, q: np.ndarray) -> np.ndarray:
        inside = (np.abs(q) < HALF).all(axis=1) & ~in_hole(self.name, q, self.t)
        return np.where(inside, -1.0, 1.0)


@pytest.mark.parametrize(
    "names",
    [
        # the extruded and tessellated holes cost ~16 s CPU with a cold cache (~59 s before
        # MeshShape measured only the nearest facets; bench_boolean_area.py --mesh): deep
        pytest.param(("trap",), id="trap"),
        pytest.param(("xt", "tess"), id="xt-tess", marks=pytest.mark.deep),
    ],
)
def test_geantino_paths_and_volumes_through_grown_mesh_holes(gdml, tmp_path, names):
    """Geantinos from inside each hole down through the trap's and the frustum's floors and
    out through the extruded pocket's side: Geant4's track length in each box (the boolean
    rebuilt around the grown G4Trap or G4TessellatedSolid) equals the analytic path in the box
    less the grown hole plus the path in the patch bodies, 1e-9 mm; Geant4's volume of each
    cut boolean (a Monte Carlo estimate from 10^6 points) is the analytic one to 2e-4."""
    from helpers.geantinos import assert_box_paths
    from helpers.ray_trace import polycone_path

    data = config(gdml, {k: HOLES[k][1] for k in names})
    scene = build_scene(parse_config(data))
    rng = np.random.default_rng(5)
    per = 6
    starts, directions, owners = [], [], []
    for name in names:
        y = HOLES[name][0]
        if name == "xt":  # from inside the pocket out through side_2 ((2, 0.5) to (0.3, 0.8))
            local = np.column_stack([rng.uniform(0.6, 1.6, per), rng.uniform(-1.5, -0.5, per),
                                     rng.uniform(6, 9, per)])  # fmt: skip
            aim = np.column_stack([local[:, 0] + rng.uniform(-0.3, 0.3, per), np.full(per, 1.5),
                                   local[:, 2] + rng.uniform(-0.5, 0.2, per)])  # fmt: skip
        else:  # from above the floor, down through it
            phi = rng.uniform(0, 2 * np.pi, per)
            rho = rng.uniform(0.0, 1.2, per)
            local = np.column_stack([rho * np.cos(phi), rho * np.sin(phi), np.full(per, 9.5)])
            aim = local + np.column_stack([rng.uniform(-3, 3, (per, 2)), np.full(per, -8.0)])
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
        lambda name, o, d: polycone_path(o, d, _Solid(name, t)),
        lambda name: (2 * HALF) ** 3 - hole_volume(name, t),
        tmp_path,
    )
    assert crossed >= len(owners) // 2


def test_into_on_a_subtracted_phi_face_is_refused(gdml):
    """The phi face of a subtracted tube segment stays refused (growing the tube would move the
    plane off its axis), in one line that says so, before any face area is estimated."""
    with pytest.raises(ConfigError) as err:
        build_scene(parse_config(config(gdml, {"pie": "second.phi_start"})))
    message = str(err.value)
    assert message.startswith(
        "targets.0.rough.0: into: true on face second.phi_start of 'pie' (a G4SubtractionSolid) "
        "(face phi_start of the subtracted G4Tubs with a phi segment): growing that solid by "
        "the layer's thickness would move the plane off the axis, parallel to itself, and every "
        "G4Tubs's phi faces pass through its axis: the grown solid would be the G4Tubs joined "
        "to a slab along the face, a boolean of its own"
    )
    assert message.endswith("put the layer outside the volume (into: false)")
    assert "\n" not in message


@pytest.mark.deep
def test_grown_mesh_holes_pass_the_overlap_check(gdml, tmp_path):
    """Geant4's overlap check (``score4 geometry check``, in its own process) finds no overlap
    between the layers' patches and their boxes rebuilt around the grown trap, extruded and
    tessellated holes."""
    import yaml

    from helpers.g4_geometry_check import assert_no_overlaps

    path = tmp_path / "holes.yaml"
    path.write_text(yaml.safe_dump(config(gdml, {k: f for k, (_y, f) in HOLES.items()})))
    assert_no_overlaps(path)


@pytest.mark.deep
def test_grown_trap_and_mesh_holes_export_with_the_same_paths(gdml, tmp_path, monkeypatch):
    """The boxes less the grown trap, extruded pocket and tessellated frustum, in one world
    written by `score4 geometry export`: Geant4 reads the file back, and the file pyg4ometry
    reads and writes again, with the same geantino paths (volumes and points, 1e-9 mm) as the
    world score4 builds; the grown holes are in the file as a G4Trap and G4TessellatedSolids;
    most rays cross a patch (deep: ~1-2 min)."""
    import re

    import yaml

    from score4.cli.main import main

    from helpers.export_paths import assert_same_paths, three_paths

    path = tmp_path / "holes.yaml"
    path.write_text(yaml.safe_dump(config(gdml, {k: f for k, (_y, f) in HOLES.items()})))
    out = tmp_path / "holes.gdml"
    assert main(["geometry", "export", str(path), "--gdml", str(out)]) == 0
    rng = np.random.default_rng(21)
    rays = []
    for name, (y, _face) in HOLES.items():
        for _ in range(5):
            if name == "xt":  # out through side_2, as in the paths test
                o = [rng.uniform(0.6, 1.6), rng.uniform(-1.5, -0.5), rng.uniform(6, 9)]
                aim = [o[0] + rng.uniform(-0.3, 0.3), 1.5, o[2] + rng.uniform(-0.5, 0.2)]
            else:  # down through the floor
                phi, rho = rng.uniform(0, 2 * np.pi), rng.uniform(0.0, 1.2)
                o = [rho * math.cos(phi), rho * math.sin(phi), 9.5]
                aim = [o[0] + rng.uniform(-1.5, 1.5), o[1] + rng.uniform(-1.5, 1.5), 1.5]
            d = np.subtract(aim, o)
            rays.append(([o[0], o[1] + y, o[2]], (d / np.linalg.norm(d)).tolist()))
    ours, back, relay = three_paths(path, out, rays, monkeypatch)
    assert_same_paths(ours, back, relay)
    assert sum(any("_rough" in (v or "") for v, _ in p) for p in ours) >= len(rays) // 2
    text = out.read_text()
    assert re.search(r'<trap [^>]*name="trap_lv_cut_', text)
    for name in ("xt", "tess"):
        assert re.search(rf'<tessellated [^>]*name="{name}_lv_cut_', text), name
