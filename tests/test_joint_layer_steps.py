"""Steps and activeness on rough layers laid out by two late additions (issue 24): the faces of a
boolean's constituents cut together (``into`` on a post's wall and the disk's top it stands on:
score4.world.boolean_layers.into_joint) and the wall of a subtracted polycone (a tapered bore's
lower cone, ``into``: score4.world.boolean_modes.polycone_wall). In a small Geant4 run each
step's ``dist_to_surf`` and the run's ``active_edep`` are checked against a brute force: every
bent patch top of a curved layer (no search window), the flat layer's tops over the 3 x 3 cells
around the step (helpers.into_steps.brute_rough), and the solids' other faces written out from
their dimensions, combined constituent by constituent as score4.world.boolean_distance states
(the uncut constituents' other faces; a flat layer's rough surface raised below its level to
the face there)."""

from __future__ import annotations

import itertools
from pathlib import Path

import h5py
import numpy as np
import pytest
from test_rough_distance import _brute_triangle

from score4.inputs.config import parse_config
from score4.runner.engine import run
from score4.runner.output import read_results
from score4.world.activeness import weight
from score4.world.resolve import build_scene

from helpers.into_steps import PYRAMIDS, brute_rough

pytestmark = pytest.mark.xdist_group("joint-layer-steps")

#: the polycone's contour in the bore's frame (box frame z less 10 mm): a cone r 2 -> 2.5 mm
#: (z -5 .. -2, seg_1), a ledge at z = -2 out to r 4 mm (seg_2), a cone r 4 -> 4.5 mm (-2 .. 5)
TAPER = [(0.0, -5.0), (2.0, -5.0), (2.5, -2.0), (4.0, -2.0), (4.5, 5.0), (0.0, 5.0)]
HALF = 10.0


@pytest.fixture(scope="module")
def gdml(tmp_path_factory) -> Path:
    """``taper``: a 20 mm copper box less the tapered bore (a G4Polycone from 5 mm under the box's
    top up through it); ``stack``: a copper disk (r 10 mm, z -5 .. 5) with a post (r 7 mm,
    z 5 .. 15) on it, a union. Written as GDML text."""
    from helpers.boolean_worlds import copper_world_text

    full = 'startphi="0" deltaphi="360" aunit="deg" lunit="mm"'
    planes = "".join(
        f'<zplane z="{z}" rmin="0" rmax="{r}"/>' for z, r in ((-5, 2), (-2, 2.5), (-2, 4), (5, 4.5))
    )
    solids = f"""
<box name="world_s" x="200" y="200" z="100" lunit="mm"/>
<box name="taper_a" x="20" y="20" z="20" lunit="mm"/>
<polycone name="taper_b" {full}>{planes}</polycone>
<subtraction name="taper_s"><first ref="taper_a"/><second ref="taper_b"/>
  <position name="taper_p" x="0" y="0" z="10" unit="mm"/></subtraction>
<tube name="stack_a" rmin="0" rmax="10" z="10" {full}/>
<tube name="stack_b" rmin="0" rmax="7" z="10" {full}/>
<union name="stack_s"><first ref="stack_a"/><second ref="stack_b"/>
  <position name="stack_p" x="0" y="0" z="10" unit="mm"/></union>"""
    path = tmp_path_factory.mktemp("joint_steps") / "joint.gdml"
    path.write_text(copper_world_text(solids, {"taper": (0, -40, 0), "stack": (0, 40, 0)}))
    return path


def steps_run(data: dict, volume: str, tmp_path: Path):
    """Run ``data`` (steps written); the results and, per step of ``volume``, the event, the
    deposit (MeV), the world position and dist_to_surf (mm)."""
    cfg = parse_config(data)
    out = tmp_path / "steps.h5"
    run(cfg, out, progress=False, echo=lambda m: None)
    res = read_results(out)
    with h5py.File(out, "r") as f:
        g = f[f"stp/{volume}"]
        evtid = g["evtid"][()]
        edep = g["edep"][()] / 1e3  # keV -> MeV
        world = np.column_stack([g[c][()] * 1e3 for c in ("xloc", "yloc", "zloc")])
        dist = g["dist_to_surf"][()] * 1e3
    return cfg, res, evtid, edep, world, dist


def config(
    gdml: Path, volume: str, faces: list[str], source: str, activeness: list, surface: str = "p"
) -> dict:
    """30 isotropic 5.3 MeV alphas (seed 5) from the pyramids on ``source``; ``into`` with a 1 um
    base and ``surface`` (``p``: 0.5 mm patches, ``f``: 0.25 mm) on each of ``faces``; steps
    written."""
    return {
        "physics": "lite",
        "world": {"gdml": str(gdml)},
        "surfaces": {"p": PYRAMIDS, "f": {**PYRAMIDS, "width": "50 um"}},
        "targets": [
            {
                "volume": volume,
                "rough": [
                    {
                        "face": f,
                        "surface": surface,
                        "base_thickness": "1 um",
                        "into": True,
                    }
                    for f in faces
                ],
                "activeness": activeness,
            }
        ],
        "source": {
            "particle": "alpha",
            "energy": "5.3 MeV",
            "direction": "isotropic",
            "surface": {"volume": volume, "face": source},
        },
        "run": {"events": 30, "seed": 5},
        "output": {"steps": True},
    }


def bent_tops(layer) -> list[np.ndarray]:
    """The bent top facets of each cell of a curved layer ((n, 3, 3) each), in the world,
    placed cell by cell from its ring's z and its cell's azimuth (every cell holds a patch
    here)."""
    lay = layer.ring_layout
    cells = layer.cells()
    assert len(cells) == int(lay.count.sum())  # no cell without a patch
    out = []
    for j, _i, k, phi in cells:
        tri = layer.bent(k, j).top_triangles.copy()
        tri[..., 2] += lay.ring_z(j)
        c, s = np.cos(phi), np.sin(phi)
        x, y = tri[..., 0].copy(), tri[..., 1].copy()
        tri[..., 0], tri[..., 1] = c * x - s * y, s * x + c * y
        out.append(layer.target.to_world(tri.reshape(-1, 3)).reshape(tri.shape))
    return out


def nearest_facet(world: np.ndarray, cells: list[np.ndarray]) -> np.ndarray:
    """Distance of each point to the nearest facet of the cells' facets (brute force by
    closest-point regions, test_rough_distance._brute_triangle), over every cell that can hold
    it: a cell is no nearer than its centre's distance less its radius (the bound: the nearest
    vertex of the nearest centre's cell)."""
    centre = np.array([c.reshape(-1, 3).mean(axis=0) for c in cells])
    radius = np.array(
        [np.linalg.norm(c - m, axis=2).max() for c, m in zip(cells, centre, strict=True)]
    )
    out = np.empty(len(world))
    for n, p in enumerate(world):
        to_centre = np.linalg.norm(centre - p, axis=1)
        bound = np.linalg.norm(cells[int(np.argmin(to_centre))] - p, axis=2).min()
        near = np.flatnonzero(to_centre - radius <= bound)
        out[n] = _brute_triangle(p[None], np.concatenate([cells[k] for k in near])).min()
    return out


def segment(rho: np.ndarray, z: np.ndarray, a, b) -> np.ndarray:
    """Distance in the (rho, z) half plane to the segment a-b (a surface of revolution about
    z: exact in 3D)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    d = b - a
    s = np.clip(((rho - a[0]) * d[0] + (z - a[1]) * d[1]) / (d @ d), 0.0, 1.0)
    return np.hypot(rho - a[0] - s * d[0], z - a[1] - s * d[1])


def test_steps_and_activeness_on_a_grown_polycone_wall(gdml, tmp_path):
    """Alphas from the pyramids on the tapered bore's lower cone (into: the polycone grown
    behind it), 30 events, seed 5, a 3 um transition layer (dlf 0.5) under the cone and a 1 mm
    one (dlf 0.2) along the upper cone: each step's dist_to_surf is the nearest of the bent
    patch tops (brute force over all of them), the polycone's other faces (its floor, ledge and
    upper cone, uncut) and the box's faces, 1e-9 mm; steps in the ring the layer was cut from
    are in patches; active_edep weights each step by the distance to the tops and by that to
    the upper cone as it is in the box (z up to the box's top), each at least the distance to
    the whole surface (1e-9 MeV)."""
    data = config(
        gdml,
        "taper",
        ["second.seg_1"],
        "second.seg_1",
        [
            {"fccd": "3 um", "dlf": 0.5, "faces": ["second.seg_1"]},
            {"fccd": "1 mm", "dlf": 0.2, "faces": ["second.seg_3"]},
        ],
        "f",  # 0.25 mm patches: the bore is narrow
    )
    cfg, res, evtid, edep, world, dist = steps_run(data, "taper", tmp_path)
    scene = build_scene(cfg)
    (layer,) = scene.layers_of("taper")
    assert layer.curved
    assert layer.into_cut > 0
    target = scene.target("taper")
    p = target.to_local(world)
    rho, z = np.hypot(p[:, 0], p[:, 1]), p[:, 2] - HALF  # the bore's frame
    in_patch = layer.contains(world)
    old = 2.0 + 0.5 * (z + 5.0) / 3.0  # the lower cone's radius before it grew
    grown = layer.into_cut * np.hypot(1.0, 0.5 / 3.0)  # radially
    slab = (z > -4.9) & (z < -2.1) & (rho > old + 1e-6) & (rho < old + grown - 1e-6)
    assert slab.sum() > 20
    assert in_patch[slab].all()  # the grown ring next to the old wall: patches only
    rough = nearest_facet(world, bent_tops(layer))
    pairs = list(itertools.pairwise(TAPER))
    others = np.min([segment(rho, z, a, b) for k, (a, b) in enumerate(pairs) if k != 1], axis=0)
    box = np.min(HALF - np.abs(p), axis=1)
    whole = np.minimum(np.minimum(rough, others), box)
    assert (~in_patch & (rough < np.minimum(others, box))).sum() > 10  # in the copper
    np.testing.assert_allclose(dist, whole, rtol=0, atol=1e-9)
    upper = segment(rho, z, (4.0, -2.0), (4.0 + 0.5 * 2.0 / 7.0, 0.0))  # in the box
    assert (upper < 1.0).sum() > 5  # steps the upper cone's entry weights
    w = np.minimum(
        weight(np.maximum(whole, rough), 3e-3, 0.5), weight(np.maximum(whole, upper), 1.0, 0.2)
    )
    again = np.bincount(evtid, weights=edep * w, minlength=res.n_events)
    np.testing.assert_allclose(again, res.scores["active_edep"]["taper"], atol=1e-9, rtol=0)
    assert 0 < again.sum() < res.edep["taper"].sum()


@pytest.mark.deep  # ~6 s CPU: the union's face areas, a Geant4 run, ~700 steps by brute force
def test_steps_and_activeness_on_a_post_wall_and_disk_top_cut_together(gdml, tmp_path):
    """Alphas from the pyramids on the disk's top around the post (into on the disk's top and
    on the post's wall, cut together: the post thinner and grown down into the disk's cut),
    30 events, seed 5, a 3 um transition layer under the disk's top and a 5 um one along the
    post's wall: each step's dist_to_surf is the union of the two constituents' distances
    (each the nearest of its rough surface, by brute force, and its other faces, uncut; the
    disk's rough surface raised below its level to its top there), 1e-9 mm; active_edep
    weights each step by the distances to the two rough surfaces, each at least the distance
    to the whole surface (1e-9 MeV)."""
    data = config(
        gdml,
        "stack",
        ["first.+z", "second.outer"],
        "first.+z",
        [
            {"fccd": "3 um", "dlf": 0.5, "faces": ["first.+z"]},
            {"fccd": "5 um", "dlf": 0.2, "faces": ["second.outer"]},
        ],
    )
    cfg, res, evtid, edep, world, dist = steps_run(data, "stack", tmp_path)
    scene = build_scene(cfg)
    disk, wall = scene.layer("stack", "first.+z"), scene.layer("stack", "second.outer")
    t = disk.thickness
    assert wall.curved
    assert wall.ring_layout.face.rz1[1] == pytest.approx(-5.0 - t, abs=1e-12)
    p = scene.target("stack").to_local(world)
    rho, z = np.hypot(p[:, 0], p[:, 1]), p[:, 2]
    in_disk, in_wall = disk.contains(world), wall.contains(world)
    assert in_disk.sum() > 20
    assert (~in_disk & ~in_wall).sum() > 20
    # the disk: its rough top, raised below the level 5 - t to the disk r <= 10 mm there
    level = np.hypot(np.maximum(rho - 10.0, 0.0), 5.0 - t - z)
    top = np.where(
        z <= 5.0 - t, np.maximum(brute_rough(disk, world), level), brute_rough(disk, world)
    )
    d1 = np.min(
        [top, segment(rho, z, (10.0, -5.0), (10.0, 5.0)), segment(rho, z, (0, -5), (10, -5))],
        axis=0,
    )
    s1 = np.where(((rho < 10.0) & (np.abs(z) < 5.0)) | in_disk, -d1, d1)
    # the post: its bent wall tops, its (uncut) ends r <= 7 mm at z = 5 and 15 mm
    tops = nearest_facet(world, bent_tops(wall))
    ends = np.minimum(segment(rho, z, (0, 5), (7, 5)), segment(rho, z, (0, 15), (7, 15)))
    d2 = np.minimum(tops, ends)
    s2 = np.where(((rho < 7.0) & (z > 5.0) & (z < 15.0)) | in_wall, -d2, d2)
    whole = np.maximum(-np.minimum(s1, s2), 0.0)
    np.testing.assert_allclose(dist, whole, rtol=0, atol=1e-9)
    assert (np.abs(dist - top) < 1e-12).sum() > 20  # the disk's rough top nearest
    near_wall = (rho > 6.9) & (z > 5.0 - t - 0.02)
    assert near_wall.sum() > 5  # steps by the post's foot, where its wall's layer runs down
    # activeness: the disk's rough top raised below its level to its top as it is on the
    # boolean there (the annulus the thinner post leaves, r 7 - c .. 10 mm)
    c = wall.into_cut
    kept = np.hypot(np.maximum(np.maximum(7.0 - c - rho, rho - 10.0), 0.0), 5.0 - t - z)
    rough = brute_rough(disk, world)
    beside = np.where(z <= 5.0 - t, np.maximum(rough, kept), rough)
    w = np.minimum(
        weight(np.maximum(whole, beside), 3e-3, 0.5), weight(np.maximum(whole, tops), 5e-3, 0.2)
    )
    again = np.bincount(evtid, weights=edep * w, minlength=res.n_events)
    np.testing.assert_allclose(again, res.scores["active_edep"]["stack"], atol=1e-9, rtol=0)
    assert 0 < again.sum() < res.edep["stack"].sum()
