"""Portal tiling: same paths and spectra as native tiling (and as one large patch), per-track cells,
bad input."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from scipy import stats

from score4.errors import ConfigError
from score4.geometry.portal import (
    PortalMap,
    check_unreachable,
    subworld_bounds,
    subworld_centres,
)
from score4.geometry.world import portal_layout
from score4.inputs.config import parse_config
from score4.runner.engine import run
from score4.runner.output import read_results
from score4.runner.run_plan import plan_run
from score4.sim.portal_action import _Layer
from score4.source.build import make_source
from score4.source.primaries import Primaries
from score4.source.vertex_file import write_vertex_file
from score4.world.resolve import build_scene
from score4.world.scene import face_frame

from conftest import config_dict
from helpers.spawn import run_in_spawned_process

# Two patch variants, 20 um x 20 um: four 10 um pyramids with a height spread, or sixteen low 5 um
# ones.
VARIANTS = {
    "a": {
        "kind": "spikes",
        "nx": 2,
        "ny": 2,
        "width": "10 um",
        "height": "10 um",
        "height_sigma": "2 um",
        "seed": 4,
    },
    "b": {"kind": "spikes", "nx": 4, "ny": 4, "width": "5 um", "height": "4 um"},
}
# +z face: 10 x 6 cells; -x face (u = -y, v = z): 6 x 5 cells.
CRYSTAL = {
    "name": "crystal",
    "material": "G4_Si",
    "size": ["0.2 mm", "0.12 mm", "0.1 mm"],
    "position": ["0 mm", "0 mm", "-0.05 mm"],
}
# Copper plates facing the two rough faces: particles leaving a portal must come out at the right
# place.
COVERS = [
    {
        "name": "cover",
        "material": "G4_Cu",
        "size": ["0.3 mm", "0.2 mm", "0.05 mm"],
        "position": ["0 mm", "0 mm", "0.075 mm"],
    },
    {
        "name": "side",
        "material": "G4_Cu",
        "size": ["0.04 mm", "0.2 mm", "0.14 mm"],
        "position": ["-0.18 mm", "0 mm", "-0.05 mm"],
    },
]


def rough(tiling: str, faces=("+z", "-x"), base: str = "20 um", layout: str = "auto") -> list[dict]:
    variants = [{"surface": "a", "density": 0.5}, {"surface": "b", "density": 0.5}]
    # native_layout is a key of native tiling only (schema: used_only_with)
    layout_key = {"native_layout": layout} if tiling == "native" else {}
    return [
        {"face": f, "variants": variants, "tiling": tiling, "seed": 3, "base_thickness": base}
        | layout_key
        for f in faces
    ]


def tiled_config(
    tiling: str,
    source: dict,
    faces=("+z", "-x"),
    base: str = "20 um",
    covers: bool = True,
    layout: str = "auto",
    **sections,
) -> dict:
    targets = [{**CRYSTAL, "rough": rough(tiling, faces, base, layout)}] + (
        COVERS if covers else []
    )
    return config_dict(surfaces=VARIANTS, targets=targets, source=source, **sections)


def face_source(
    face: str, particle: str = "geantino", energy: str = "1 MeV", mean: str = "0.5 um"
) -> dict:
    return {
        "particle": particle,
        "energy": energy,
        "surface": {"volume": "crystal", "face": face},
        "depth": {"profile": "exponential", "mean": mean},
    }


def oblique_directions(rng, frame, n: int, max_normal: float) -> np.ndarray:
    """Directions with a normal component below ``max_normal`` (either sign): many cells crossed."""
    phi = rng.uniform(0, 2 * np.pi, n)
    cz = rng.uniform(-max_normal, max_normal, n)
    s = np.sqrt(1 - cz**2)
    return np.column_stack([s * np.cos(phi), s * np.sin(phi), cz]) @ frame.rotation.T


def corner_crossers(config, face: str, lift: float = 0.08) -> Primaries:
    """Geantinos through every inner cell corner of ``face``, diagonally, from 0.5 um below the
    spike bases, rising into the spikes of the diagonal cell."""
    layer = build_scene(config).layer("crystal", face)
    (px, py), (lu, lv) = layer.patch_size, layer.frame.size
    pm = layer.patch_map
    xs = -lu / 2 + px * np.arange(1, pm.nx)
    ys = -lv / 2 + py * np.arange(1, pm.ny)
    cx, cy = (a.ravel() for a in np.meshgrid(xs, ys))
    signs = np.array([[1, 1], [-1, 1], [1, -1], [-1, -1]])[np.arange(len(cx)) % 4]
    s = 3e-3  # start 3 um before the corner along each axis
    local = np.column_stack(
        [cx - signs[:, 0] * s, cy - signs[:, 1] * s, np.full(len(cx), layer.base_thickness - 5e-4)]
    )
    d = np.column_stack([signs, np.full(len(cx), lift)]).astype(float)
    d /= np.linalg.norm(d, axis=1)[:, None]
    n = len(cx)
    return Primaries(
        event=np.arange(n),
        particle=np.full(n, "geantino"),
        energy=np.ones(n),
        position=layer.frame.to_world(local),
        direction=d @ layer.frame.rotation.T,
    )


def replay(tmp_path, data: dict, vfile, name: str):
    n = int(np.max(read_vertex_events(vfile))) + 1
    replayed = parse_config(
        {
            **data,
            "source": {"vertices": str(vfile)},
            "output": {"track_length": True},
            "run": {"events": n, "seed": 5},
        }
    )
    return read_results(run(replayed, tmp_path / f"{name}.h5", progress=False, echo=lambda m: None))


def read_vertex_events(vfile):
    import h5py

    with h5py.File(vfile) as f:
        return f["vertices/event"][()]


def geantino_vertices(tmp_path, n_face: int = 250):
    """Vertices below both rough faces (sampled in the patches), oblique, isotropic, corners."""
    rng = np.random.default_rng(11)
    parts = []
    for face in ("+z", "-x"):
        config = parse_config(tiled_config("native", face_source(face)))
        p = make_source(config, build_scene(config)).primaries(
            np.random.default_rng(len(parts)), 0, n_face
        )
        frame = face_frame(config.targets[0], face)
        p.direction[: n_face // 2] = oblique_directions(rng, frame, n_face // 2, 0.02)
        parts.append(Primaries(p.event, p.particle, p.energy, p.position, p.direction))
        parts.append(corner_crossers(config, face))
    return write_vertex_file(tmp_path / "v.h5", Primaries.concatenate(parts), {}, 1)


def test_geantino_paths_per_volume_match_native_tiling(tmp_path):
    """The same geantinos (from the same vertex file) through native tiling and through the portal:
    identical path lengths in the crystal with its patches and in both copper covers, on a rotated
    face (-x) and on +z, for oblique geantinos crossing up to the whole face in the slab or the
    spike tips, for geantinos through every inner cell corner (diagonal jumps), and for those
    leaving one portal into the other (both faces are portals). The same for native tiling in
    nested 2 x 2 groups of cells (grids of 10 x 6 and 6 x 5 cells: three levels, odd edges)
    against one placement per cell. Tolerance 1e-9 mm."""
    vfile = geantino_vertices(tmp_path)
    native = replay(
        tmp_path, tiled_config("native", face_source("+z"), layout="placements"), vfile, "native"
    )
    portal = replay(tmp_path, tiled_config("portal", face_source("+z")), vfile, "portal")
    nested = replay(
        tmp_path, tiled_config("native", face_source("+z"), layout="nested"), vfile, "nested"
    )
    for volume in ("crystal", "cover", "side"):
        a, b = native.scores["track_length"][volume], portal.scores["track_length"][volume]
        np.testing.assert_allclose(b, a, rtol=0, atol=1e-9, err_msg=volume)
        c = nested.scores["track_length"][volume]
        np.testing.assert_allclose(c, a, rtol=0, atol=1e-9, err_msg=f"nested {volume}")
    crystal = native.scores["track_length"]["crystal"]
    # Measured (565 geantinos): 57 go more than 0.1 mm (5 cells) in the crystal group, 97 reach the
    # cover, 47 the side plate; largest difference 2e-13 mm.
    assert (crystal > 0.1).sum() > 40
    assert (native.scores["track_length"]["cover"] > 0).sum() > 60
    assert (native.scores["track_length"]["side"] > 0).sum() > 30


# --- one large patch
# -------------------------------------------------------------------------------

PITCH = 2e-3  # mm
SAMPLES = 10  # map cells per patch side: patches of 20 um


def bump_maps() -> list[np.ndarray]:
    """Two patch height maps (um) that are zero on their border, so tiles join like one map."""
    t = np.linspace(0, 1, SAMPLES + 1)
    x, y = np.meshgrid(t, t)
    one = 6 * np.sin(np.pi * x) ** 2 * np.sin(np.pi * y) ** 2
    two = (
        4 * np.sin(2 * np.pi * x) ** 2 * np.sin(np.pi * y) ** 2
        + 1.5 * np.sin(np.pi * x) * np.sin(3 * np.pi * y) ** 2
    )
    return [one, two]


def write_grid(path, heights_um: np.ndarray) -> str:
    lines = [f"# pitch = {PITCH * 1e3:g} um", "# z_unit = um"] + [
        " ".join(f"{v:.12g}" for v in row) for row in heights_um
    ]
    path.write_text("\n".join(lines) + "\n")
    return str(path)


def test_tiles_match_one_large_patch(tmp_path):
    """Two height-map variants tiled over a 0.12 mm x 0.08 mm face (6 x 4 cells), natively and
    through the portal, against the same surface as ONE patch (the tiles' map assembled into one
    height map, tiling native with a 1 x 1 grid): the same geantino path lengths to 1e-9 mm.

    One exception, measured and allowed for native tiling: a geantino that grazes the seam of two
    tiles (the tiles' surfaces meet the slab top at the border) can enter the neighbour tile
    through its side facet up to ~0.3 nm above the facet's edge (G4TessellatedSolid's facet
    tolerance), counting a sub-nm stretch of vacuum as silicon. Seed 3: 1 event of 300, 0.87 nm
    more than the single patch; the portal matched the single patch in all 300 (< 1e-12 mm)."""
    maps = bump_maps()
    surfaces = {
        f"v{k}": {"kind": "measured", "file": write_grid(tmp_path / f"v{k}.txt", m), "level": False}
        for k, m in enumerate(maps)
    }
    crystal = {
        **CRYSTAL,
        "size": ["0.12 mm", "0.08 mm", "0.05 mm"],
        "position": ["0 mm", "0 mm", "-0.025 mm"],
    }
    variants = [{"surface": "v0", "density": 0.5}, {"surface": "v1", "density": 0.5}]

    def config(tiling, rough_face):
        return config_dict(
            surfaces=surfaces,
            targets=[{**crystal, "rough": [rough_face]}],
            source=face_source("+z"),
        )

    tiled = {"face": "+z", "variants": variants, "seed": 8, "base_thickness": "5 um"}
    native_data = config("native", {**tiled, "tiling": "native"})
    layer = build_scene(parse_config(native_data)).layers[0]
    ny, nx = layer.patch_map.variants.shape
    big = np.zeros((ny * SAMPLES + 1, nx * SAMPLES + 1))
    for j in range(ny):
        for i in range(nx):
            big[j * SAMPLES : (j + 1) * SAMPLES + 1, i * SAMPLES : (i + 1) * SAMPLES + 1] = maps[
                layer.patch_map.variants[j, i]
            ]
    assert len(set(layer.patch_map.variants.ravel().tolist())) == 2
    surfaces["big"] = {
        "kind": "measured",
        "file": write_grid(tmp_path / "big.txt", big),
        "level": False,
    }
    single_data = config("native", {"face": "+z", "surface": "big", "base_thickness": "5 um"})
    assert build_scene(parse_config(single_data)).layers[0].patch_map.n_cells == 1

    p = make_source(parse_config(native_data), build_scene(parse_config(native_data))).primaries(
        np.random.default_rng(3), 0, 300
    )
    p.direction[:200] = oblique_directions(np.random.default_rng(4), layer.frame, 200, 0.05)
    vfile = write_vertex_file(
        tmp_path / "v.h5", Primaries(p.event, p.particle, p.energy, p.position, p.direction), {}, 1
    )
    single = replay(tmp_path, single_data, vfile, "single").scores["track_length"]["crystal"]
    native = replay(tmp_path, native_data, vfile, "native").scores["track_length"]["crystal"]
    portal = replay(
        tmp_path, config("portal", {**tiled, "tiling": "portal"}), vfile, "portal"
    ).scores["track_length"]["crystal"]
    np.testing.assert_allclose(portal, single, rtol=0, atol=1e-9)
    same = np.abs(native - single) <= 1e-9
    assert same.mean() >= 0.98
    assert np.abs(native - single).max() < 1e-5
    assert (single > 0.06).sum() > 20  # oblique paths through several patches


# --- alphas
# ------------------------------------------------------------------------------------------


@pytest.mark.parametrize("events", [1500, pytest.param(3000, marks=pytest.mark.deep)])
def test_alpha_spectra_of_native_and_portal_tiling_agree(tmp_path, events):
    """5.3 MeV alphas from 20 nm below the rough -x face (isotropic), ``events`` per tiling, the
    same seed: the deposited-energy spectra agree (two-sample Kolmogorov-Smirnov p > 0.01). The
    runs differ event by event once a particle jumps (the vacuum step undone by the jump draws
    random numbers, and the next step starts with another status, see score4.sim.portal_action).
    Measured with 3000 events: KS distance 0.008, p = 0.9999; 26 % of the events agree to 1e-9
    MeV."""
    source = {
        "particle": "alpha",
        "energy": "5.3 MeV",
        "direction": "isotropic",
        "surface": {"volume": "crystal", "face": "-x"},
        "depth": {"profile": "exponential", "mean": "20 nm"},
    }
    spectra = {}
    for tiling in ("native", "portal"):
        data = tiled_config(
            tiling,
            source,
            faces=("-x",),
            base="1 um",
            covers=False,
            run={"events": events, "seed": 21},
        )
        spectra[tiling] = read_results(
            run(parse_config(data), tmp_path / f"{tiling}.h5", progress=False, echo=lambda m: None)
        )
    a, b = spectra["native"].edep["crystal"], spectra["portal"].edep["crystal"]
    np.testing.assert_array_equal(
        spectra["native"].primaries.position, spectra["portal"].primaries.position
    )
    assert stats.ks_2samp(a, b).pvalue > 0.01
    # the rough face matters here: many alphas deposit only a part (the figure's shoulder)
    assert ((b > 0.2) & (b < 4.0)).mean() > 0.1


# --- deposits at jumps and secondaries ------------------------------------------------------------


def _spawned(config_data, primaries):
    return run_in_spawned_process(_run_primaries, config_data, primaries)


def _run_primaries(config_data, primaries):
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).parent))
    from helpers.g4_portal import run_primaries

    return run_primaries(config_data, primaries)


def slab_primaries(config_data, particle: str, energy: float, n: int, seed: int) -> dict:
    """Particles started 30 um deep in a 60 um base slab under +z, moving nearly along the face."""
    from helpers.g4_portal import as_lists

    layer = build_scene(parse_config(config_data)).layer("crystal", "+z")
    rng = np.random.default_rng(seed)
    local = np.column_stack(
        [rng.uniform(-0.03, 0.03, n), rng.uniform(-0.02, 0.02, n), np.full(n, 0.03)]
    )
    d = oblique_directions(rng, layer.frame, n, 0.1)
    p = Primaries(
        event=np.arange(n),
        particle=np.full(n, particle),
        energy=np.full(n, energy),
        position=layer.frame.to_world(local),
        direction=d,
    )
    return as_lists(p)


def test_deposits_of_jumping_steps_and_of_secondaries_are_kept():
    """Inside a 60 um silicon slab (no escape) every event must deposit its whole energy. 5.3 MeV
    alphas cross 20 um cells in the slab (each crossing is two jumps' worth of steps ending on a
    subworld face): a deposit lost on the step that triggers a jump, or after it, would show as a
    missing few keV. 50 keV electrons make secondaries that cross cell borders themselves: they
    must know their cell (inherited from the parent at their creation time), else they would be
    killed as anomalies and their energy lost. Tolerance: 1e-6 relative below (Geant4 may exceed the
    emitted energy by about 1 keV in rare events)."""
    data = tiled_config("portal", face_source("+z"), faces=("+z",), base="60 um", covers=False)
    alpha = _spawned(data, slab_primaries(data, "alpha", 5.3, 200, 1))
    edep = np.array(alpha["edep"])[:, 0]
    assert alpha["anomalies"] == 0
    assert alpha["jumps"] > 200
    assert edep.min() > 5.3 * (1 - 1e-6)
    assert edep.max() < 5.3 + 2e-3
    electron = _spawned(data, slab_primaries(data, "e-", 0.05, 300, 2))
    edep = np.array(electron["edep"])[:, 0]
    assert electron["anomalies"] == 0
    assert electron["secondary_jumps"] > 0
    assert edep.min() > 0.05 * (1 - 1e-6)
    assert edep.max() < 0.05 + 2e-3


# --- geometry and bad input (no Geant4)
# -------------------------------------------------------------


@pytest.mark.parametrize("face", ["+z", "-z", "+x", "-x", "+y", "-y"])
def test_portal_map_moves_points_to_the_same_place_in_their_cell(face):
    """Every face: a point of cell (i, j) lands in its subworld (one of its variant's) at the
    same cell-local position (in the face frame), and the jump is a translation (directions never
    change)."""
    config = parse_config(tiled_config("portal", face_source(face), faces=(face,), covers=False))
    layer = build_scene(config).layers[0]
    centres = subworld_centres(layer, (5.0, 1.0, -2.0))
    pmap = PortalMap(layer, centres)
    rng = np.random.default_rng(0)
    lu, lv = layer.frame.size
    local = np.column_stack(
        [
            rng.uniform(-lu / 2, lu / 2, 500),
            rng.uniform(-lv / 2, lv / 2, 500),
            rng.uniform(0, layer.thickness, 500),
        ]
    )
    moved, inside, i, j = pmap.to_subworld(layer.frame.to_world(local))
    assert inside.all()
    k = pmap.slots[j, i]  # the cell's subworld
    in_cell = (
        moved - centres[k]
    ) @ layer.frame.rotation  # face frame, relative to the subworld centre
    c = layer.cell_centres()[j, i]
    expected = np.column_stack(
        [local[:, 0] - c[:, 0], local[:, 1] - c[:, 1], local[:, 2] - layer.thickness / 2]
    )
    np.testing.assert_allclose(in_cell, expected, atol=1e-12)
    outside = layer.frame.to_world(
        np.array([[0.0, 0.0, -1e-3], [0.0, 0.0, layer.thickness + 1e-3]])
    )
    moved, inside, i, _ = pmap.to_subworld(outside)
    assert not inside.any()
    assert (i == -1).all()
    assert np.array_equal(moved, outside)


def test_neighbouring_cells_never_share_a_subworld():
    """Each variant has one subworld per parity of the cell indices: a cell's eight neighbours
    all lie in other subworlds of the variant (so a jump through a border or a corner never makes
    an event's cells ambiguous), and every subworld holds its variant."""
    config = parse_config(tiled_config("portal", face_source("+z"), faces=("+z",), covers=False))
    layer = build_scene(config).layers[0]
    slots = PortalMap(layer, subworld_centres(layer, (1.0, 0.0, 0.0))).slots
    variants = layer.patch_map.variants
    ny, nx = slots.shape
    assert min(nx, ny) > 2
    assert len(subworld_centres(layer, (1.0, 0.0, 0.0))) == 4 * len(layer.variants)
    np.testing.assert_array_equal(slots // 4, variants)
    for j in range(ny):
        for i in range(nx):
            for dj in (-1, 0, 1):
                for di in (-1, 0, 1):
                    if (di or dj) and 0 <= i + di < nx and 0 <= j + dj < ny:
                        assert slots[j + dj, i + di] != slots[j, i]
    same = variants[:, 2:] == variants[:, :-2]  # two cells apart: the same subworld again
    assert (slots[:, 2:] == slots[:, :-2])[same].all()


def test_exit_faces_of_a_subworld():
    """Faces left through, from the exit point and direction: sides, top/bottom, corners within
    the tolerance; none for a particle on the boundary moving back in."""
    config = parse_config(tiled_config("portal", face_source("+z"), faces=("+z",), covers=False))
    layer = build_scene(config).layers[0]
    lay = _Layer(PortalMap(layer, subworld_centres(layer, (1.0, 0.0, 0.0))))
    hu, hv, hz = lay.half
    assert lay.exit_faces((hu, 0.0, 0.0), (1.0, 0.0, 0.0)) == (1, 0, False)
    assert lay.exit_faces((-hu, 0.3 * hv, 0.1 * hz), (-0.6, 0.8, 0.0)) == (-1, 0, False)
    assert lay.exit_faces((0.1 * hu, 0.2 * hv, hz), (0.6, 0.0, 0.8)) == (0, 0, True)
    assert lay.exit_faces((0.1 * hu, -hv, -hz), (0.0, -0.6, -0.8)) == (
        0,
        -1,
        True,
    )  # bottom edge: leaves the layer
    assert lay.exit_faces((hu, hv - 1e-12, 0.0), (0.6, 0.8, 0.0)) == (
        1,
        1,
        False,
    )  # corner: diagonal neighbour
    assert lay.exit_faces((-hu, -hv, 0.0), (-0.6, 0.8, 0.0)) == (
        -1,
        0,
        False,
    )  # on an edge, moving back in along v
    assert lay.exit_faces((hu, hv - 1e-6, 0.0), (0.6, 0.8, 0.0)) == (
        1,
        0,
        False,
    )  # 1 nm from the corner: one face
    assert (
        lay.exit_faces((hu, 0.0, 0.0), (-0.6, 0.8, 0.0)) is None
    )  # on the boundary, turned back in
    assert lay.exit_faces((0.5 * hu, 0.0, 0.0), (1.0, 0.0, 0.0)) is None  # not on the boundary


def test_subworlds_lie_outside_the_region_particles_reach():
    """The layout puts every portal layer's subworlds beyond Lab (the native world) and inside the
    world; a subworld origin where particles can move is refused with a clear error."""
    plan = plan_run(parse_config(tiled_config("portal", face_source("+z"))))
    scene = plan.scene
    lab = scene.world_half
    half, origins = portal_layout(plan)
    assert set(origins) == {layer.name for layer in scene.layers}
    boxes = [subworld_bounds(layer, origins[layer.name]) for layer in scene.layers]
    for lo, hi in boxes:
        assert lo[0] > lab[0]
        assert np.all(hi < half)
        assert np.all(lo > -half)
        check_unreachable(scene.layers[0], origins[scene.layers[0].name], -lab, lab)  # no error
    assert (
        boxes[0][1][0] < boxes[1][0][0] or boxes[1][1][0] < boxes[0][0][0]
    )  # the layers' subworlds apart
    with pytest.raises(
        ConfigError,
        match=(
            r"crystal_roughpz: subworld_origin \(0.05, 0, 0\) mm puts the subworlds .* "
            r"where particles can move"
        ),
    ):
        check_unreachable(scene.layers[0], (0.05, 0.0, 0.0), -lab, lab)
    native = parse_config(tiled_config("native", face_source("+z")))
    assert portal_layout(plan_run(native))[1] == {}


# --- per-track cells without a tracking action (no Geant4) --------------------------------------


class _Track:
    def __init__(self, tid, parent, where, time=0.0):
        self.tid, self.parent, self.where, self.time = tid, parent, where, time

    def GetTrackID(self):
        return self.tid

    def GetParentID(self):
        return self.parent

    def GetPosition(self):
        x, y, z = self.where
        return SimpleNamespace(x=x, y=y, z=z)

    def GetGlobalTime(self):
        return self.time


def test_tracking_action_runs_only_while_an_events_cells_are_ambiguous():
    """The teleporter switches its tracking action on when an event enters a second cell of one
    subworld (by its primaries or by a jump), off when the next event begins; a track with no
    history is in its subworld's first cell, a secondary of a parent with no history gets the
    first cell of the subworld it is born in (none in Lab)."""
    from score4.sim.portal_action import Teleporter

    config = parse_config(tiled_config("portal", face_source("+z"), faces=("+z",), covers=False))
    layer = build_scene(config).layers[0]
    centres = subworld_centres(layer, (1.0, 0.0, 0.0))
    g4 = SimpleNamespace(
        G4TransportationManager=SimpleNamespace(
            GetTransportationManager=lambda: SimpleNamespace(GetNavigatorForTracking=lambda: None)
        ),
        G4TrackStatus=SimpleNamespace(fStopAndKill=2),
        G4ThreeVector=lambda *v: v,
    )
    portal = SimpleNamespace(map=PortalMap(layer, centres), portal_pv="portal", trigger_pvs=[])
    t = Teleporter(g4, [portal])
    switched = []
    t.set_tracking, t.tracking = switched.append, False
    v = portal.map.slots
    (j1, i1), (j2, i2) = np.argwhere(v == 0)[:2]  # two cells of subworld 0
    (j3, i3) = np.argwhere(v == 1)[0]
    c = layer.cell_centres()
    z = layer.thickness / 2

    def point(i, j):
        return layer.frame.to_world(np.array([c[j, i, 0], c[j, i, 1], z]))

    positions = [point(i1, j1), point(i3, j3), point(i1, j1), point(i2, j2), point(i1, j1)]
    t.map_primaries(np.array(positions))
    t.begin_event(0, 2)  # two primaries, two subworlds: unambiguous
    assert switched == []
    assert t.first_cell == {(0, 0): (0, i1, j1), (0, 1): (0, i3, j3)}
    t.begin_event(2, 4)  # two cells of subworld 0
    assert switched == [True]
    assert t.tracking
    t.begin_event(4, 5)
    assert switched == [True, False]
    assert t.first_cell == {(0, 0): (0, i1, j1)}
    t._record(7, 1.0, (0, i3, j3), (0, i1, j1))  # a jump into another subworld: still fine
    assert switched == [True, False]
    t._record(7, 2.0, (0, i2, j2), (0, i3, j3))  # back into subworld 0, another cell
    assert switched == [True, False, True]
    sub0 = centres[0]
    t.start_track(_Track(9, 8, sub0))  # parent 8 has no history: born in subworld 0
    assert t.history[9][1] == [(0, i1, j1)]
    t.start_track(_Track(10, 7, sub0, time=1.5))  # parent 7 was in (i3, j3) at t = 1.5
    assert t.history[10][1] == [(0, i3, j3)]
    t.start_track(_Track(11, 8, (0.0, 0.0, 0.0)))  # born in Lab: no cell
    assert 11 not in t.history
