"""GDML worlds (issue 17): the volume model, names and copies, transforms, materials by Z, rough
faces on GDML volumes, bad input. The GDML files are written at test time by pyg4ometry (with a
legend-pygeom-hpges detector) and by Geant4's own writer (tests/helpers/gdml_worlds.py)."""

from __future__ import annotations

import html
import json
import math
import re
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from score4.cli.main import main
from score4.errors import ConfigError
from score4.inputs.config import parse_config
from score4.runner.normalisation import layer_volume
from score4.world.gdml_files import _read_in_subprocess, load_geometry_model
from score4.world.resolve import build_scene

from helpers.export_paths import assert_same_paths, built_and_exported, pyg4ometry_registry
from helpers.spawn import run_in_spawned_process

HERE = Path(__file__).parent
sys.path.insert(0, str(HERE))
from helpers import gdml_worlds as W  # noqa: E402


def _call(name, *args):
    sys.path.insert(0, str(HERE))
    from helpers import g4_gdml_world

    return getattr(g4_gdml_world, name)(*args)


def spawned(name, *args):
    return run_in_spawned_process(_call, name, *args)


@pytest.fixture(scope="module")
def worlds() -> dict[str, Path]:
    """The worlds of tests/helpers/gdml_worlds.py, written once, kept in score4's cache folder."""
    return {
        "pyg4ometry": W.cached("pyg4", W.pyg4ometry_world),
        "geant4": W.cached("g4", W.geant4_world),
        "reflected": W.cached("refl", W.reflected_world),
    }


def _rz(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def _rx(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def test_model_lists_every_volume_of_both_writers(worlds):
    # the model is cached; Geant4 reading the file now gives the same
    fresh = _read_in_subprocess(worlds["pyg4ometry"], "world.gdml")
    model = load_geometry_model(worlds["pyg4ometry"])
    assert fresh["logicals"] == model.to_dict()["logicals"]
    assert fresh["materials"] == model.materials
    names = [i.name for i in model.instances]
    # the module comes from <file>, the materials from an XML entity
    for name in ("cavity", "crystal_0", "crystal_1", "crystal_2", "disk", "holder", "chip", "bege"):
        assert name in names
    assert len(model.resolve("CrystalLV", "t")) == 3  # a logical volume name: all placements
    rows = {r["label"]: r for r in model.rows()}
    assert rows["disk"]["solid"] == "G4Tubs"
    assert rows["bege"]["solid"] == "G4GenericPolycone"
    assert rows["boolpart"]["solid"] == "G4SubtractionSolid"
    # masses: own material only (a box of CaWO4 6.062 g/cm3, NIST)
    crystal_cm3 = np.prod(W.CRYSTAL) / 1e3
    assert rows["crystal_1"]["mass_kg"] == pytest.approx(crystal_cm3 * 6.062e-3, rel=1e-3)
    assert rows["holder"]["volume_mm3"] == pytest.approx(30 * 10 * 10 - 4 * 4 * 2)
    assert rows["disk"]["area_mm2"] == pytest.approx(
        2 * math.pi * 15**2 + 2 * math.pi * 15 * 10, rel=1e-9
    )
    g4 = load_geometry_model(worlds["geant4"])
    # Geant4's writer appends pointers to names; the reader strips them: two copies of "crystal"
    crystals = g4.resolve("crystal", "t")
    assert [c.occurrence for c in crystals] == [0, 1]
    assert [g4.label(c) for c in crystals] == ["crystal[0]", "crystal[1]"]
    assert g4.resolve("crystal[1]", "t") == [crystals[1]]


def test_global_transforms_compose_the_placement_chain(worlds):
    """Positions from the chain equal the analytic ones, and Geant4's navigator finds each volume
    just inside each of its faces and not just outside (rotations included)."""
    g4m = load_geometry_model(worlds["geant4"])
    outer_r = _rx(W.G4_OUTER["rot_x"])
    inner_r = outer_r @ _rz(W.G4_INNER["rot_z"])
    inner_t = outer_r @ np.array(W.G4_INNER["pos"]) + np.array(W.G4_OUTER["pos"])
    points, expect = [], []
    for k, crystal in enumerate(g4m.resolve("crystal", "t")):
        centre = inner_r @ np.array(W.G4_CRYSTAL["pos"][k]) + inner_t
        np.testing.assert_allclose(crystal.translation, centre, atol=1e-9)
        np.testing.assert_allclose(crystal.rotation, inner_r, atol=1e-12)
        half = np.array(W.G4_CRYSTAL["half"])
        for axis in range(3):
            for sign in (-1, 1):
                for f, name in ((0.99, "crystal"), (1.01, "inner")):
                    local = np.zeros(3)
                    local[axis] = sign * f * half[axis]
                    points.append(crystal.to_world(local).tolist())
                    expect.append(name)
    n = len(points)
    pym = load_geometry_model(worlds["pyg4ometry"])
    for inst in pym.resolve("CrystalLV", "t") + pym.resolve("disk", "t"):
        lo = np.asarray(pym.logicals[inst.logical].solid["lo"])
        if inst.name == "disk":  # towards the rim at 45 degrees, and the bottom
            lo = np.array([15 / math.sqrt(2), 15 / math.sqrt(2), -5.0])
        for f, name in ((0.99, inst.name), (1.01, "cavity")):
            points.append(inst.to_world(lo * f).tolist())  # near a corner: all three axes count
            expect.append(name)
    assert spawned("locate", str(worlds["geant4"]), points[:n]) == expect[:n]
    assert spawned("locate", str(worlds["pyg4ometry"]), points[n:]) == expect[n:]


def test_enriched_germanium_goes_to_trim_by_z(worlds):
    """legend-pygeom-hpges defines germanium from Ge-74/Ge-76 (element EnrGe0.880): TRIM gets
    Z = 32 with the isotopic molar mass, and a Pb-206 library is built in it."""
    model = load_geometry_model(worlds["pyg4ometry"])
    material = model.materials[model.logicals[model.resolve("bege", "t")[0].logical].material]
    (element,) = material["elements"]
    assert element["Z"] == 32
    assert {i["N"] for i in element["isotopes"]} == {74, 76}
    molar = 0.12 * 73.9211778 + 0.88 * 75.9214026  # AME atomic masses, g/mol
    assert element["A_g_mole"] == pytest.approx(molar, rel=1e-4)
    got = spawned("composition", str(worlds["pyg4ometry"]), "bege", 20)
    assert got["element_names"] != ["Ge"]  # not a NIST element: found by Z, not by symbol
    assert [s for s, _ in got["atoms"]] == ["Ge"]
    assert dict(got["masses"])["Ge"] == pytest.approx(molar, rel=1e-4)
    assert 5e-6 < got["mean_depth_mm"] < 1e-4  # 103 keV Pb-206 in Ge: tens of nm


def _config(tmp_path: Path, gdml: Path, targets: list, source: dict | None = None, **more) -> Path:
    data = {
        "physics": "lite",
        "world": {"gdml": str(gdml)},
        "surfaces": {
            # 1 mm patches of 10 x 10 pyramids: few cells, for the export test
            "coarse": {
                "kind": "spikes",
                "shape": "pyramid",
                "nx": 10,
                "ny": 10,
                "width": "100 um",
                "height": "20 um",
            },
            "pyr": {
                "kind": "spikes",
                "shape": "pyramid",
                "nx": 10,
                "ny": 10,
                "width": "50 um",
                "height": "20 um",
            },
        },
        "targets": targets,
        "source": source
        or {
            "surface": {"volume": "crystal_1", "face": "+z"},
            "particle": "alpha",
            "energy": "5 MeV",
            "direction": "inward",
        },
        "run": {"events": 100, "seed": 3},
        **more,
    }
    path = tmp_path / "run.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def test_rough_faces_on_a_rotated_box_copy_and_a_disk(worlds, tmp_path):
    cfg = _config(
        tmp_path,
        worlds["pyg4ometry"],
        [
            {"volume": "crystal_1", "rough": [{"face": "+z", "surface": "pyr"}]},
            {"volume": "disk", "rough": [{"face": "-z", "surface": "pyr"}]},
            {"volume": "crystal_0"},
        ],
    )
    scene = build_scene(parse_config(yaml.safe_load(cfg.read_text()), base_dir=tmp_path))
    assert scene.columns == ["crystal_1", "disk", "crystal_0"]
    disk = scene.layer("disk", "-z")
    # cells of 0.5 mm wholly inside the r = 15 mm disk, counted corner by corner
    c = (np.arange(60) - 29.5) * 0.5
    x, y = np.meshgrid(c, c)
    corners = [np.hypot(np.abs(x) + 0.25, np.abs(y) + 0.25) <= 15]
    assert disk.mask.sum() == corners[0].sum()
    assert disk.rough_share == pytest.approx(corners[0].sum() * 0.25 / (math.pi * 15**2))
    # the layer's material: one patch body per rough cell (cells outside the disk hold none)
    box_layer = scene.layer("crystal_1", "+z")  # same surface, every cell rough
    one_cell = layer_volume(box_layer) / box_layer.cell_variants.size
    assert layer_volume(disk) == pytest.approx(one_cell * corners[0].sum(), rel=1e-12)
    # the layer sits on the rotated face, outside the crystal
    layer = scene.layer("crystal_1", "+z")
    inst = scene.target("crystal_1").instance
    np.testing.assert_allclose(layer.frame.normal, inst.rotation[:, 2], atol=1e-12)
    np.testing.assert_allclose(layer.frame.centre, inst.to_world([0, 0, 20]), atol=1e-9)
    # Geant4: just above the face a patch of crystal_1, above the tips the cavity
    up = layer.frame.normal
    pts = [
        layer.frame.to_world([0.01, 0.01, 0.0005]).tolist(),  # in the base slab (1 um)
        (layer.frame.centre + 0.03 * up).tolist(),  # above the layer (21 um)
        (layer.frame.centre - 0.01 * up).tolist(),  # in the crystal
        scene.layer("disk", "-z").frame.to_world([0.01, 0.01, 0.0005]).tolist(),
    ]
    got = spawned("built_world_locate", str(cfg), pts)
    assert got["columns"] == ["crystal_1", None, "crystal_1", "disk"]
    assert got["names"][1] == "cavity"


def test_into_keeps_the_outer_dimensions(worlds, tmp_path):
    cfg = _config(
        tmp_path,
        worlds["pyg4ometry"],
        [{"volume": "crystal_1", "rough": [{"face": "+z", "surface": "pyr", "into": True}]}],
    )
    scene = build_scene(parse_config(yaml.safe_load(cfg.read_text()), base_dir=tmp_path))
    layer = scene.layer("crystal_1", "+z")
    inst = scene.target("crystal_1").instance
    face = inst.to_world([0, 0, 20])
    np.testing.assert_allclose(layer.frame.centre + layer.thickness * layer.frame.normal, face)
    n = layer.frame.normal
    pts = [
        (face + 1e-4 * n).tolist(),  # 100 nm outside the original face: cavity
        (face - 0.0205 * n + [0.0, 0.0, 0.0]).tolist(),  # in the base slab of the layer
        (face - 0.03 * n).tolist(),  # below the layer: the (cut) crystal
    ]
    got = spawned("built_world_locate", str(cfg), pts)
    assert got["names"][0] == "cavity"
    assert got["columns"][1:] == ["crystal_1", "crystal_1"]
    assert got["names"][2] == "crystal_1"


def test_run_scores_copies_in_columns(worlds, tmp_path):
    cfg = _config(
        tmp_path,
        worlds["pyg4ometry"],
        [{"volume": "CrystalLV", "rough": [{"face": "+z", "surface": "pyr"}]}],
        source={
            "surface": {"volume": "CrystalLV_1", "face": "+z"},
            "particle": "alpha",
            "energy": "5 MeV",
            "direction": "inward",
        },
    )
    out = tmp_path / "r.h5"
    assert main(["run", str(cfg), "--out", str(out)]) == 0
    from score4.runner.output import read_results

    res = read_results(out)
    assert list(res.edep) == ["CrystalLV_0", "CrystalLV_1", "CrystalLV_2"]
    assert (res.edep["CrystalLV_1"] > 0).all()
    assert not res.edep["CrystalLV_0"].any()
    assert not res.edep["CrystalLV_2"].any()
    # inward alphas (range ~17 um in CaWO4) on pyramids: most stop in the crystal or its layer
    assert np.mean(res.edep["CrystalLV_1"] > 4.99) > 0.8


def test_geometry_list_json_and_text(worlds, tmp_path, capsys):
    cfg = _config(
        tmp_path,
        worlds["geant4"],
        [{"volume": "crystal"}],
        source={
            "surface": {"volume": "crystal[0]", "face": "+x"},
            "particle": "alpha",
            "energy": "5 MeV",
        },
    )
    assert main(["geometry", "list", str(cfg), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert [t["target"] for t in data["targets"]] == ["crystal_0", "crystal_1"]
    assert [v["label"] for v in data["volumes"]][-3:] == ["crystal[0]", "crystal[1]", "unionpart"]
    assert main(["geometry", "list", str(cfg)]) == 0
    text = capsys.readouterr().out
    for word in ("crystal[1]", "G4UnionSolid", "G4_Ge"):
        assert word in text


@pytest.mark.parametrize(
    ("case", "message"),
    [
        ("missing", r"world.gdml: GDML file .* does not exist"),
        ("broken_xml", r"line \d+, column \d+: not well-formed XML \(mismatched tag\)"),
        (
            "bad_reference",
            r"Referenced volume 'NoSuchLV[^']*' was not found! \(ReadError in G4GDML",
        ),
        ("unknown", r"targets.0.volume: no volume named 'crystl' .*closest: crystal_\d"),
        ("copy_range", r"'disk\[2\]': 'disk' has 1 copy"),
        (
            "curved",
            (
                r"no face '\+z' on a G4GenericPolycone; "
                r"its faces: seg_0, .*; groups: outer, inner, top"
            ),
        ),
        ("tubs_side", r"no face '\+x' on a G4Tubs; its faces: -z, outer, \+z; groups: all$"),
        ("reflected", r"'mirrored' is placed with a reflection"),
        ("portal", r"tiling portal works on boxes of the configuration"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(worlds, tmp_path, capsys, case, message):
    gdml = worlds["pyg4ometry"]
    targets: list = [{"volume": "crystal_1"}]
    if case == "missing":
        gdml = tmp_path / "none.gdml"
    elif case == "broken_xml":
        gdml = tmp_path / "broken.gdml"
        gdml.write_text(worlds["geant4"].read_text().replace("</physvol>", "</physvo>", 1))
    elif case == "bad_reference":
        gdml = tmp_path / "badref.gdml"
        text = worlds["geant4"].read_text()
        gdml.write_text(text.replace('volumeref ref="Crystal', 'volumeref ref="NoSuchLV', 1))
    elif case == "unknown":
        targets = [{"volume": "crystl"}]
    elif case == "copy_range":
        targets = [{"volume": "disk[2]"}]
    elif case == "curved":
        targets = [{"volume": "bege", "rough": [{"face": "+z", "surface": "pyr"}]}]
    elif case == "tubs_side":
        targets = [{"volume": "disk", "rough": [{"face": "+x", "surface": "pyr"}]}]
    elif case == "reflected":
        gdml = worlds["reflected"]
        targets = [{"volume": "mirrored"}]
    elif case == "portal":
        targets = [
            {"volume": "crystal_1", "rough": [{"face": "+z", "surface": "pyr", "tiling": "portal"}]}
        ]
    source = {
        "surface": {"volume": targets[0]["volume"], "face": "+z"},
        "particle": "alpha",
        "energy": "5 MeV",
    }
    cfg = _config(tmp_path, gdml, targets, source=source)
    out = tmp_path / "out.h5"
    assert main(["run", str(cfg), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert __import__("re").search(message, err[0]), err[0]
    assert not out.exists()
    assert not (tmp_path / "out.h5.parts").exists()


def test_layer_meeting_a_sister_names_it_and_the_gap(worlds, tmp_path):
    """The holder of the <file> module touches nothing; a box of the configuration put 5 um
    above crystal_1's +z face leaves a 5 um gap for a 21 um layer."""
    model = load_geometry_model(worlds["pyg4ometry"])
    c1 = model.resolve("crystal_1", "t")[0]
    cavity = model.resolve("cavity", "t")[0]
    top = cavity.to_local(c1.to_world([0, 0, 20.005 + 0.5]))  # box centre: 5 um above the face
    targets = [
        {"volume": "crystal_1", "rough": [{"face": "+z", "surface": "pyr"}]},
        {
            "name": "lid",
            "material": "G4_Cu",
            "size": ["1 mm", "1 mm", "1 mm"],
            "position": [f"{float(x)!r} mm" for x in top],
            "mother": "cavity",
        },
    ]
    cfg = _config(tmp_path, worlds["pyg4ometry"], targets)
    with pytest.raises(ConfigError, match=r"runs into target 'lid' \(free gap there: 5 um\)"):
        build_scene(parse_config(yaml.safe_load(cfg.read_text()), base_dir=tmp_path))


def _ray_hits_box(origin, direction, inst, half) -> np.ndarray:
    """Slab test: rays (world) against the box ``half`` of instance ``inst``."""
    o = inst.to_local(origin)
    d = direction @ inst.rotation
    with np.errstate(divide="ignore", invalid="ignore"):
        t1, t2 = (-half - o) / d, (half - o) / d
    near = np.nanmax(np.minimum(t1, t2), axis=1)
    far = np.nanmin(np.maximum(t1, t2), axis=1)
    return (far >= np.maximum(near, 0)) & (far > 0)


def test_po210_on_a_crystal_hits_its_neighbour_multiplicity_2(worlds, tmp_path, capsys):
    """Po-210 on crystal_0's +x face: alpha and recoil fly back to back; whichever goes inward
    stays in crystal_0, and crystal_1 (rotated) is hit exactly when the other one's ray meets
    its box: multiplicity 2."""
    cfg = _config(
        tmp_path,
        worlds["pyg4ometry"],
        [{"volume": "crystal_0"}, {"volume": "crystal_1"}],
        source={"surface": {"volume": "crystal_0", "face": "+x"}, "decay": "Po210"},
        physics={"mode": "lite", "heavy_ions": "geant4"},
    )
    data = yaml.safe_load(cfg.read_text())
    data["run"]["events"] = 400
    cfg.write_text(yaml.safe_dump(data))
    out = tmp_path / "m.h5"
    assert main(["run", str(cfg), "--out", str(out)]) == 0
    from score4.runner.output import read_results

    res = read_results(out)
    p = res.primaries
    model = load_geometry_model(worlds["pyg4ometry"])
    c1 = model.resolve("crystal_1", "t")[0]
    rays = _ray_hits_box(p.position, p.direction, c1, np.array(W.CRYSTAL) / 2)
    expect = np.zeros(res.n_events, dtype=bool)  # the alpha or the recoil flies into crystal_1
    np.logical_or.at(expect, p.event - p.event.min(), rays)
    hit = res.edep["crystal_1"] > 0.01
    # a ray grazing an edge of crystal_1 may leave less than the 10 keV threshold: at most 1 %
    assert not (hit & ~expect).any()
    assert (expect & ~hit).sum() <= 0.01 * res.n_events
    assert 5 < hit.sum() < 200
    capsys.readouterr()
    assert main(["summary", str(out), "--json", "--threshold", "10 keV"]) == 0
    s = json.loads(capsys.readouterr().out)
    two = int(hit.sum())
    assert s["multiplicity"]["events"] == {"0": 0, "1": 400 - two, "2": two}
    masses = {v["name"]: v["mass_kg"] for v in s["volumes"]}
    assert masses["crystal_1"] == pytest.approx(np.prod(W.CRYSTAL) * 6.062e-6, rel=1e-9)


def _base(name: str | None) -> str | None:
    """A physical volume name of score4's additions without the export's numbering (the export
    names repeated placements ``name``, ``name_1``, ...) and face (a target's layers of the same
    make share their volumes, named after the first)."""
    if not name or "_rough" not in name:
        return name
    return re.sub(r"_\d+$", "", re.sub(r"_rough[pm][xyz]", "_rough", name))


def test_exported_world_gives_the_same_paths_and_reads_in_pyg4ometry(worlds, tmp_path, monkeypatch):
    """The whole world with its rough layers, written to GDML: Geant4's reader gives the same
    ray (geantino) paths to 1e-9 mm, pyg4ometry reads it, and score4's vertices lie in the
    exported world's rough layer (the same frame)."""
    cfg = _config(
        tmp_path,
        worlds["pyg4ometry"],
        [
            {
                "volume": "crystal_1",
                "rough": [{"face": "+z", "surface": "coarse", "solid": "blocks"}],
            },
            {"volume": "disk", "rough": [{"face": "-z", "surface": "coarse", "into": True}]},
        ],
        source={
            "surface": {"volume": "crystal_1", "face": "+z"},
            "particle": "alpha",
            "energy": "5 MeV",
            "depth": {"profile": "uniform", "min": "100 nm", "max": "1 um"},
        },
    )
    out = tmp_path / "world.gdml"
    assert main(["geometry", "export", str(cfg), "--gdml", str(out)]) == 0
    assert out.stat().st_size < 20e6
    scene = build_scene(parse_config(yaml.safe_load(cfg.read_text()), base_dir=tmp_path))
    rng = np.random.default_rng(5)
    rays = []
    for name, face in (("crystal_1", "+z"), ("disk", "-z")):
        frame = scene.layer(name, face).frame
        for _ in range(6):
            uv = rng.uniform(-4, 4, 2)
            start = frame.to_world([uv[0], uv[1], 0.5])
            tilt = frame.rotation @ np.array([*rng.uniform(-0.3, 0.3, 2), -1.0])
            rays.append((start.tolist(), tilt.tolist()))
    # score4's vertices, drawn for the run, in the exported world (the same frame)
    vtx = tmp_path / "v.h5"
    assert main(["vertices", str(cfg), "--n", "20", "--out", str(vtx)]) == 0
    from score4.source.vertex_file import read_vertex_file

    pos = read_vertex_file(vtx).position
    ours, (back, names) = built_and_exported(cfg, out, rays, pos.tolist())
    assert_same_paths(ours, back, names=_base)
    assert max(len(a) for a in ours) > 6  # the rays cross patch cells and spikes
    reg = pyg4ometry_registry(out, monkeypatch)  # pyg4ometry reads it
    lvs = [n.split("0x")[0] for n in reg.logicalVolumeDict]
    assert {"crystal_1_roughpz", "disk_roughmz", "B00000T", "CrystalLV_u1"} <= set(lvs)
    # vertices drawn by score4 lie in the exported world's crystal_1 material
    assert set(names) <= {"crystal_1", "crystal_1_roughpz_v0"} | {
        n for n in names if n and n.startswith("crystal_1_roughpz")
    }
    assert all(n is not None and n.startswith("crystal_1") for n in names)


BOX_WORLD = {
    "physics": "lite",
    "surfaces": {
        "pyr": {"kind": "spikes", "nx": 5, "ny": 5, "width": "10 um", "height": "10 um"},
        "low": {"kind": "spikes", "nx": 5, "ny": 5, "width": "10 um", "height": "6 um"},
    },
    "targets": [
        {
            "name": "crystal",
            "material": "G4_Ge",
            "size": ["1 mm", "1 mm", "1 mm"],
            "position": ["0 mm", "0 mm", "-0.5 mm"],
            "rough": [
                {
                    "face": "+z",
                    "variants": [
                        {"surface": "pyr", "density": 0.5},
                        {"surface": "low", "density": 0.5},
                    ],
                },
                {"face": "-x", "surface": "low", "solid": "tessellated"},
            ],
        },
        {
            "name": "plate",
            "material": "G4_Cu",
            "size": ["1 mm", "1 mm", "0.2 mm"],
            "position": ["0 mm", "0 mm", "-1.5 mm"],
        },
    ],
    "source": {"particle": "alpha", "energy": "5 MeV", "surface": {"volume": "crystal"}},
    "run": {"events": 10},
}


def _box_name(name: str | None) -> str | None:
    """The first placement of a name keeps it, a repeated one is ``name_k`` in the export, and
    Geant4's reader makes the world's placement itself, ``World_PV``."""
    return "World" if name == "World_PV" else re.sub(r"_cell_\d+$", "_cell", name or "") or name


def test_a_box_world_exports_with_clean_unique_names(tmp_path, monkeypatch):
    """A world of configuration boxes with rough layers, written by Geant4's writer: no pointer
    suffixes, every name unique within its kind (repeated placements numbered), and Geant4
    reads it back with the same ray paths and names as the world score4 builds; pyg4ometry reads
    it too."""
    cfg = tmp_path / "box.yaml"
    cfg.write_text(yaml.safe_dump(BOX_WORLD))
    out = tmp_path / "box.gdml"
    assert main(["geometry", "export", str(cfg), "--gdml", str(out)]) == 0
    text = out.read_text()
    assert "0x" not in text
    for tag in ("physvol", "volume", "position", "multiUnionNode", "trd", "box", "tessellated"):
        names = re.findall(rf'<{tag}\b[^>]*\bname="([^"]+)"', text)
        assert names, tag
        assert len(set(names)) == len(names), tag
    assert 'name="crystal_roughpz_cell_1"' in text  # a repeated placement, numbered
    scene = build_scene(parse_config(BOX_WORLD))
    rng = np.random.default_rng(3)
    rays = []
    for face in ("+z", "-x"):
        frame = scene.layer("crystal", face).frame
        for _ in range(5):
            start = frame.to_world([*rng.uniform(-0.45, 0.45, 2), 0.05])
            tilt = frame.rotation @ np.array([*rng.uniform(-0.3, 0.3, 2), -1.0])
            rays.append((start.tolist(), tilt.tolist()))
    ours, back = built_and_exported(cfg, out, rays)
    assert_same_paths(ours, back, names=_box_name)
    assert max(len(a) for a in ours) > 6
    reg = pyg4ometry_registry(out, monkeypatch)
    assert {"World", "crystal", "plate", "crystal_roughpz", "crystal_roughmx"} <= set(
        reg.logicalVolumeDict
    )


def test_layer_meeting_a_gdml_sister_and_into(worlds, tmp_path):
    """Two GDML cubes touch: a layer on the touching face meets the sister (gap 0); with
    into: true it fits, and the cube keeps its outer faces."""
    gdml = W.touching_world(tmp_path / "touch")
    rough = {"face": "+x", "surface": "pyr"}
    source = {"surface": {"volume": "left", "face": "+x"}, "particle": "alpha", "energy": "5 MeV"}
    cfg = _config(tmp_path, gdml, [{"volume": "left", "rough": [rough]}], source=source)
    with pytest.raises(
        ConfigError, match=r"runs into sister volume 'right' \(free gap there: 0 um\)"
    ):
        build_scene(parse_config(yaml.safe_load(cfg.read_text()), base_dir=tmp_path))
    cfg = _config(
        tmp_path, gdml, [{"volume": "left", "rough": [{**rough, "into": True}]}], source=source
    )
    scene = build_scene(parse_config(yaml.safe_load(cfg.read_text()), base_dir=tmp_path))
    layer = scene.layer("left", "+x")
    assert layer.frame.centre[0] + layer.thickness == pytest.approx(0.0, abs=1e-12)


def test_into_on_a_box_of_a_generated_world(tmp_path):
    data = {
        "physics": "lite",
        "surfaces": {
            "pyr": {"kind": "spikes", "nx": 10, "ny": 10, "width": "50 um", "height": "20 um"}
        },
        "targets": [
            {
                "name": "c",
                "size": ["1 mm", "1 mm", "1 mm"],
                "rough": [{"face": "+z", "surface": "pyr", "into": True}],
            }
        ],
        "source": {
            "surface": {"volume": "c", "face": "+z"},
            "particle": "alpha",
            "energy": "5 MeV",
        },
    }
    cfg = tmp_path / "box.yaml"
    cfg.write_text(yaml.safe_dump(data))
    # the top face stays at z = 0.5 mm: the layer (21 um) fills 0.479 .. 0.5 mm
    pts = [[0.01, 0.01, 0.5 + 1e-4], [0.01, 0.01, 0.5 - 0.0205], [0.01, 0.01, 0.45]]
    got = spawned("built_world_locate", str(cfg), pts)
    assert got["names"][0] == "World"
    assert got["columns"][1:] == ["c", "c"]
    assert got["names"][2] == "c"


def test_sources_on_gdml_volumes_by_their_shapes(worlds, tmp_path):
    """Through score4.shapes: a bulk source in the holder (its daughter chip excluded), a source
    on every face of the BEGe (G4GenericPolycone) below the surface, and a partly rough disk face
    sampled per true area (pyramid faces against the flat rest); Geant4 locates the vertices."""
    from score4.source.vertex_file import read_vertex_file

    def draw(name: str, targets: list, source: dict, n: int) -> np.ndarray:
        cfg = _config(tmp_path, worlds["pyg4ometry"], targets, source=source)
        cfg = cfg.rename(tmp_path / f"{name}.yaml")
        out = tmp_path / f"{name}.h5"
        assert main(["vertices", str(cfg), "--n", str(n), "--out", str(out)]) == 0
        return read_vertex_file(out)

    alpha = {"particle": "alpha", "energy": "5 MeV"}
    below = {"profile": "uniform", "min": "100 nm", "max": "1 um"}
    bulk = draw("bulk", [{"volume": "holder"}], {"volume": "holder", **alpha}, 300)
    bege = draw(
        "bege",
        [{"volume": "bege"}],
        {"surface": {"volume": "bege", "face": "all"}, "depth": below, **alpha},
        300,
    )
    names = spawned(
        "locate", str(worlds["pyg4ometry"]), bulk.position.tolist() + bege.position.tolist()
    )
    assert set(names[:300]) == {"holder"}  # never in the chip inside it
    assert set(names[300:]) == {"bege"}
    disk = draw(
        "disk",
        [{"volume": "disk", "rough": [{"face": "-z", "surface": "pyr"}]}],
        {"surface": {"volume": "disk", "face": "-z"}, **alpha},
        4000,
    )
    on_patch = np.mean(disk.extra["patch"] >= 0)
    c = (np.arange(60) - 29.5) * 0.5
    x, y = np.meshgrid(c, c)
    cells = int((np.hypot(np.abs(x) + 0.25, np.abs(y) + 0.25) <= 15).sum())
    slant = math.hypot(0.025, 0.020)  # pyramid 50 um wide, 20 um high: 4 triangles each
    rough_area = cells * 100 * 4 * 0.5 * 0.05 * slant
    flat_area = math.pi * 15**2 - cells * 0.25
    expect = rough_area / (rough_area + flat_area)
    assert on_patch == pytest.approx(expect, abs=4 * math.sqrt(expect * (1 - expect) / 4000))


def _with_userinfo(tmp_path: Path, source: Path) -> Path:
    """The pyg4ometry world of the fixtures with remage's detector registration (as
    legend-pygeom-tools writes it) and auxiliary tags on volumes, its includes copied along."""
    folder = tmp_path / "user"
    folder.mkdir()
    for f in source.parent.iterdir():
        if f.suffix in (".xml", ".gdml"):
            (folder / f.name).write_text(f.read_text())
    text = (folder / source.name).read_text()
    text = text.replace(
        '<solidref ref="disk_s"/>',
        '<solidref ref="disk_s"/>\n\t\t\t<auxiliary auxtype="rmg_color" auxvalue="0.1,0.2,0.3,1"/>',
    )
    text = text.replace(
        "</structure>",
        "</structure>\n\t<userinfo>\n"
        '\t\t<auxiliary auxtype="RMG_detector" auxvalue="germanium">\n'
        '\t\t\t<auxiliary auxtype="disk" auxvalue="7"/>\n'
        '\t\t\t<auxiliary auxtype="bege" auxvalue="8"/>\n'
        "\t\t</auxiliary>\n"
        '\t\t<auxiliary auxtype="RMG_detector_meta" auxvalue="">\n'
        f'\t\t\t<auxiliary auxtype="bege" auxvalue="{html.escape(json.dumps(W.BEGE))}"/>\n'
        "\t\t</auxiliary>\n"
        "\t</userinfo>",
        1,
    )
    out = folder / source.name
    out.write_text(text)
    return out


def test_export_keeps_the_users_file_and_registers_the_rough_layer(worlds, tmp_path, monkeypatch):
    """The export is the user's file with lines added: every name, auxiliary tag and the
    userinfo block unchanged (only the includes point back to the user's folder); the rough
    layer's patch bodies join the disk's remage detector (UID 7, reuse allowed, the disk's
    table); Geant4 reads it with the same paths; pyg4ometry reads names and userinfo."""
    import difflib

    gdml = _with_userinfo(tmp_path, worlds["pyg4ometry"])
    cfg = _config(
        tmp_path,
        gdml,
        [
            {
                "volume": "disk",
                "rough": [
                    {"face": "-z", "surface": "coarse", "solid": "blocks"},
                    {"face": "+z", "surface": "coarse", "solid": "blocks"},
                ],
            }
        ],
        source={
            "surface": {"volume": "disk", "face": "-z"},
            "particle": "alpha",
            "energy": "5 MeV",
        },
    )
    out = tmp_path / "export" / "world.gdml"
    out.parent.mkdir()
    assert main(["geometry", "export", str(cfg), "--gdml", str(out)]) == 0
    before = gdml.read_text().splitlines()
    after = out.read_text().splitlines()
    changed = []
    for op, i1, i2, _, _ in difflib.SequenceMatcher(
        None, before, after, autojunk=False
    ).get_opcodes():
        if op in ("replace", "delete"):
            changed += before[i1:i2]
    # only the includes (relative to the new folder) and the empty <define/> (now holding ours)
    assert changed == [
        '<!ENTITY materials SYSTEM "materials.xml">',
        "\t<define/>",
        '\t\t\t\t<file name="module.gdml"/>',
    ]
    text = out.read_text()
    assert '<!ENTITY materials SYSTEM "../user/materials.xml">' in text
    # the disk's patch bodies in its detector group, after the disk
    patches = re.findall(r'<auxiliary auxtype="([^"]+)" auxvalue=":7,true,disk"/>', text)
    assert patches
    assert all(p.startswith("disk_roughmz_v0_b") for p in patches)
    physvols = re.findall(r'<physvol\b[^>]*name="([^"]+)"', text)
    assert len(physvols) == len(set(physvols))  # unique names
    assert set(patches) <= set(physvols)
    # Geant4: the same paths as score4's own world
    rng = np.random.default_rng(2)
    scene = build_scene(parse_config(yaml.safe_load(cfg.read_text()), base_dir=tmp_path))
    rays = []
    for k in range(12):
        frame = scene.layer("disk", "-z" if k % 2 else "+z").frame
        start = frame.to_world([*rng.uniform(-8, 8, 2), 0.5])
        rays.append(
            (start.tolist(), (frame.rotation @ [*rng.uniform(-0.3, 0.3, 2), -1.0]).tolist())
        )
    ours, back = built_and_exported(cfg, out, rays)
    assert_same_paths(ours, back, names=_base)
    assert max(len(a) for a in ours) > 6
    # the two faces are of the same make: one envelope volume placed twice
    envelopes = re.findall(r'<physvol name="(disk_rough[pm]z)">\s*<volumeref ref="([^"]+)"', text)
    assert envelopes == [("disk_roughmz", "disk_roughmz"), ("disk_roughpz", "disk_roughmz")]
    reg = pyg4ometry_registry(out, monkeypatch)
    assert {"disk", "bege", "crystal_0", "crystal_1", "cavity"} <= set(reg.physicalVolumeDict)
    det = next(a for a in reg.userInfo if a.auxtype == "RMG_detector")
    entries = {a.auxtype: a.auxvalue for a in det.subaux}
    assert entries["disk"] == "7"
    assert entries["bege"] == "8"
    assert {k for k, v in entries.items() if v == ":7,true,disk"} == set(patches)
    disk = reg.logicalVolumeDict["DiskLV"]
    assert [(a.auxtype, a.auxvalue) for a in disk.auxiliary] == [("rmg_color", "0.1,0.2,0.3,1")]
    # LEGEND's readers: legend-pygeom-tools reads the registration, revertex finds the BEGe
    from pygeomtools.detectors import get_all_sensvols
    from revertex.utils import get_hpges

    sensvols = get_all_sensvols(reg)
    assert sensvols["disk"].uid == 7
    assert not sensvols["disk"].allow_uid_reuse
    for p in patches:
        assert (sensvols[p].uid, sensvols[p].allow_uid_reuse, sensvols[p].ntuple_name) == (
            7,
            True,
            "disk",
        )
    hpges, pos = get_hpges(reg, ["bege"])
    assert list(hpges) == ["bege"]
    np.testing.assert_allclose(pos["bege"], W.BEGE_POSITION)


def test_export_adds_a_configured_box_and_cuts_one_copy_of_a_shared_volume(worlds, tmp_path):
    """A box of the configuration in a GDML mother (rough), and into: true on one copy of the
    shared CrystalLV: the export gives Geant4 the same paths as score4's own world."""
    cfg = _config(
        tmp_path,
        worlds["pyg4ometry"],
        [
            {
                "name": "foil",
                "material": "G4_Cu",
                "size": ["4 mm", "4 mm", "1 mm"],
                "mother": "cavity",
                "position": ["0 mm", "-30 mm", "0 mm"],
                "rough": [{"face": "+z", "surface": "coarse"}],
            },
            {"volume": "crystal_1", "rough": [{"face": "+z", "surface": "coarse", "into": True}]},
        ],
        source={
            "surface": {"volume": "foil", "face": "+z"},
            "particle": "alpha",
            "energy": "5 MeV",
        },
    )
    out = tmp_path / "world.gdml"
    assert main(["geometry", "export", str(cfg), "--gdml", str(out)]) == 0
    text = out.read_text()
    assert '<volume name="CrystalLV_u1">' in text
    assert re.search(r"<physvol name=\"foil\"[^>]*>\s*<volumeref ref=\"foil\" ?/>", text)
    scene = build_scene(parse_config(yaml.safe_load(cfg.read_text()), base_dir=tmp_path))
    rng = np.random.default_rng(1)
    rays = []
    for name in ("foil", "crystal_1"):
        frame = scene.layer(name, "+z").frame
        for _ in range(5):
            start = frame.to_world([*rng.uniform(-1.5, 1.5, 2), 0.5])
            tilt = frame.rotation @ [*rng.uniform(-0.3, 0.3, 2), -1.0]
            rays.append((start.tolist(), tilt.tolist()))
    ours, back = built_and_exported(cfg, out, rays)
    assert_same_paths(ours, back, names=_base)
    assert max(len(a) for a in ours) > 5
