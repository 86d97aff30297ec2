"""``score4 surface``: generate -> stats -> show -> export, and one-line errors."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from score4.cli.main import main
from score4.surface.metrology import PARAMETERS
from score4.surface.plot import nice_length
from score4.surface.store import load_surface
from score4.surface.triangle_mesh import TriangleMesh, is_watertight, signed_volume

from conftest import ROOT
from helpers.spawn import run_in_spawned_process

UM = 1e-3  # mm
SYMBOLS = [symbol for symbol, _, _ in PARAMETERS]

# 25.6 correlation lengths per side at 10 samples per correlation length: a fair grid for Sq.
RANDOM = {
    "kind": "random",
    "nx": 256,
    "ny": 256,
    "pitch": "1 um",
    "sq": "1 um",
    "corr_length": "10 um",
    "seed": 7,
}
# Equal pyramids 10 um wide and 4 um high: slope 0.8 on every facet.
PYRAMIDS = {"kind": "spikes", "nx": 6, "ny": 5, "width": "10 um", "height": "4 um"}
# Unequal pyramids of unequal cell sides for geometry checks.
SPIKES = {
    "kind": "spikes",
    "nx": 4,
    "ny": 3,
    "width_x": "10 um",
    "width_y": "15 um",
    "height": "8 um",
    "height_sigma": "2 um",
    "seed": 2,
}
SMALL_RANDOM = {
    "kind": "random",
    "nx": 16,
    "ny": 12,
    "pitch": "1 um",
    "sq": "0.5 um",
    "corr_length": "2 um",
    "seed": 1,
}


def write_yaml(folder: Path, name: str, data: dict) -> Path:
    path = folder / f"{name}.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def run(capsys, *args) -> tuple[int, str, str]:
    code = main([str(a) for a in args])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def generate(tmp_path: Path, capsys, name: str, data: dict) -> Path:
    out = tmp_path / f"{name}.s4s.h5"
    code, stdout, err = run(
        capsys, "surface", "generate", write_yaml(tmp_path, name, data), "--out", out
    )
    assert code == 0, err
    assert stdout.startswith(f"wrote {out}: {data['kind']}, ")
    return out


# --- generate and stats ---------------------------------------------------------------------


def test_generate_then_stats_json_random(tmp_path, capsys):
    out = tmp_path / "rough.s4s.h5"
    code, stdout, err = run(
        capsys, "surface", "generate", write_yaml(tmp_path, "rough", RANDOM), "--out", out
    )
    assert code == 0, err
    assert stdout.startswith(
        f"wrote {out}: random, 256 x 256 um, {2 * 256 * 256} top mesh facets, Sq "
    )
    code, stdout, err = run(capsys, "surface", "stats", out, "--json")
    assert code == 0, err
    doc = json.loads(stdout)
    assert set(SYMBOLS) <= set(doc)
    assert "map" not in doc
    assert doc["exact"] == []
    assert doc["units"] == {
        s: ("um" if kind == "length" else "%" if kind == "percent" else "dimensionless")
        for s, kind, _ in PARAMETERS
    }
    assert doc["surface"]["kind"] == "random"
    assert doc["surface"]["map_points"] == [257, 257]
    assert doc["surface"]["size_x_um"] == pytest.approx(256.0)
    # Fixed seed 7; the generator makes Sq exact on the periodic map, levelling and the closing
    # row/column move it by well under the stated 2 %.
    assert doc["Sq"] == pytest.approx(1.0, rel=0.02)
    # Gaussian heights: Sku near 3 (+-0.3 at 25 correlation lengths per side); Gaussian ACF:
    # Sal = sqrt(ln 5) * 10 um = 12.69 um, within 15 % on one 256 um map.
    assert doc["Sku"] == pytest.approx(3.0, abs=0.3)
    assert doc["Sal"] == pytest.approx(math.sqrt(math.log(5)) * 10, rel=0.15)
    assert doc["Sp"] + doc["Sv"] == pytest.approx(doc["Sz"])


def test_stats_json_spikes_mesh_values_are_exact(tmp_path, capsys):
    out = generate(tmp_path, capsys, "pyr", PYRAMIDS)
    code, stdout, err = run(capsys, "surface", "stats", out, "--json")
    assert code == 0, err
    doc = json.loads(stdout)
    mesh, sampled = doc, doc["map"]  # top level: exact mesh values; "map": the sampled map
    assert doc["exact"] == ["Sa", "Sq", "Sp", "Sv", "Sz", "Ssk", "Sku", "Sdq", "Sdr"]
    h, slope = 4.0, 0.8  # um, height / half width
    # Equal square pyramids: the area fraction above z is (1 - z/h)^2, so u = 1 - z/h has density
    # 2u on [0, 1]: Sq = h / sqrt(18), Ssk = 0.5657 (= 2 sqrt(2) / 5), Sku = 2.4; every facet has
    # gradient 0.8, so Sdq = 0.8 and Sdr = (sqrt(1 + 0.64) - 1) * 100 %.
    assert mesh["Sq"] == pytest.approx(h / math.sqrt(18), rel=1e-9)
    assert mesh["Ssk"] == pytest.approx(2 * math.sqrt(2) / 5, rel=1e-9)
    assert mesh["Sku"] == pytest.approx(2.4, rel=1e-9)
    assert mesh["Sdq"] == pytest.approx(slope, rel=1e-9)
    assert mesh["Sdr"] == pytest.approx((math.sqrt(1 + slope**2) - 1) * 100, rel=1e-9)
    assert mesh["Sz"] == pytest.approx(h, rel=1e-9)
    # mesh metrology has no ACF parameters: Sal and Str are the map's
    assert "Sal" not in doc["exact"]
    assert doc["Sal"] == sampled["Sal"] is not None
    # The map (16 samples per cell) agrees with the exact values to the sampling error.
    assert sampled["Sq"] == pytest.approx(mesh["Sq"], rel=0.05)
    assert sampled["Sq"] != mesh["Sq"]
    assert sampled["Sdq"] == pytest.approx(slope, rel=0.01)
    assert doc["surface"]["n_spikes"] == 30


def test_stats_text_and_all_file_kinds(tmp_path, capsys):
    desc = write_yaml(tmp_path, "pyr", PYRAMIDS)
    code, stdout, err = run(capsys, "surface", "stats", desc)  # a description is built on the fly
    assert code == 0, err
    assert "(exact, mesh)" in stdout
    assert "(map)" in stdout
    lines = {line.split()[0]: line for line in stdout.splitlines()[2:]}
    assert list(lines) == SYMBOLS
    assert "um" in lines["Sq"].split()
    assert "%" in lines["Sdr"].split()
    # A measured file is read directly; its missing points are left out, not refused.
    sdf = ROOT / "tests" / "data" / "topography" / "sdfio_iso1_surface_binary.sdf"
    code, stdout, err = run(capsys, "surface", "stats", sdf, "--json")
    assert code == 0, err
    doc = json.loads(stdout)
    assert doc["surface"]["kind"] == "topography (sdf)"
    assert doc["surface"]["map_points"] == [32, 48]
    assert doc["Sq"] > 0
    assert math.isfinite(doc["Sq"])


def test_stats_of_the_shipped_measured_example_matches_its_surface_file(tmp_path, capsys):
    desc = ROOT / "examples" / "surfaces" / "measured.yaml"
    out = tmp_path / "m.s4s.h5"
    assert run(capsys, "surface", "generate", desc, "--out", out)[0] == 0
    from_desc = json.loads(run(capsys, "surface", "stats", desc, "--json")[1])
    from_file = json.loads(run(capsys, "surface", "stats", out, "--json")[1])
    assert {s: from_desc[s] for s in SYMBOLS} == {s: from_file[s] for s in SYMBOLS}


def test_generate_refuses_to_overwrite(tmp_path, capsys):
    out = generate(tmp_path, capsys, "pyr", PYRAMIDS)
    before = out.read_bytes()
    other = write_yaml(tmp_path, "other", SPIKES)
    code, _, err = run(capsys, "surface", "generate", other, "--out", out)
    assert code == 2
    assert "already exists; use --overwrite" in err
    assert out.read_bytes() == before
    assert run(capsys, "surface", "generate", other, "--out", out, "--overwrite")[0] == 0
    assert load_surface(out).spec.nx == 4


# --- show -----------------------------------------------------------------------------------


def test_nice_length():
    assert [nice_length(v) for v in (0.73, 1.0, 3.0, 9.99, 125.0, 2e-4)] == pytest.approx(
        [0.5, 1, 2, 5, 100, 2e-4]
    )


@pytest.mark.parametrize("data", [PYRAMIDS, SMALL_RANDOM], ids=["spikes", "random"])
def test_show_writes_a_png(tmp_path, capsys, data):
    out = generate(tmp_path, capsys, data["kind"], data)
    png = tmp_path / "pic.png"
    code, _stdout, err = run(capsys, "surface", "show", out, "--png", png, "--dpi", 50)
    assert code == 0, err
    raw = png.read_bytes()
    assert raw[:8] == b"\x89PNG\r\n\x1a\n"
    assert raw[12:16] == b"IHDR"
    width, height = int.from_bytes(raw[16:20], "big"), int.from_bytes(raw[20:24], "big")
    assert (width, height) == (550, 230)  # 11 x 4.6 inches at 50 dpi
    import matplotlib.image

    pixels = matplotlib.image.imread(png)
    assert pixels.shape[:2] == (230, 550)
    assert pixels[..., :3].std() > 0.1  # a picture, not a blank canvas
    assert sorted(
        p.name for p in tmp_path.iterdir() if p.suffix == ".png" or "partial" in p.name
    ) == ["pic.png"]


def test_show_keeps_labels_inside_and_pyramids_at_true_aspect(tmp_path, monkeypatch):
    """Nothing drawn touches the figure's border; 1:1 pyramids are not stretched in 3D."""
    import matplotlib.image

    from score4.surface import plot as surface_plot

    titles = []
    original = surface_plot.Figure.savefig

    def spy(fig, *args, **kwargs):
        titles.extend(ax.get_title() for ax in fig.axes)
        return original(fig, *args, **kwargs)

    monkeypatch.setattr(surface_plot.Figure, "savefig", spy)
    measured = ROOT / "examples" / "surfaces" / "measured.yaml"
    pyramids = ROOT / "examples" / "surfaces" / "pyramids.yaml"
    for source in (measured, pyramids):
        png = tmp_path / f"{source.stem}.png"
        assert main(["surface", "show", str(source), "--png", str(png), "--dpi", "80"]) == 0
        grey = matplotlib.image.imread(png)[..., :3].mean(axis=2)
        border = np.concatenate(
            [grey[:2].ravel(), grey[-2:].ravel(), grey[:, :2].ravel(), grey[:, -2:].ravel()]
        )
        assert (border > 0.8).all(), f"{source.name}: something is drawn on the figure's border"
    # the measured map is nearly flat: its heights are stretched and the title says so;
    # the paper's pyramids (10 um wide, 10 um high) are drawn at their true aspect
    assert any("heights x" in t for t in titles[: len(titles) // 2])
    assert any("true aspect" in t for t in titles[len(titles) // 2 :])


# --- export ---------------------------------------------------------------------------------


def read_binary_stl(path: Path) -> TriangleMesh:
    raw = path.read_bytes()
    n = int(np.frombuffer(raw, "<u4", 1, 80)[0])
    rec = np.frombuffer(
        raw, np.dtype([("normal", "<f4", (3,)), ("v", "<f4", (3, 3)), ("attr", "<u2")]), n, 84
    )
    assert len(raw) == 84 + 50 * n
    corners = rec["v"].reshape(-1, 3).astype(float)
    vertices, index = np.unique(
        corners, axis=0, return_inverse=True
    )  # shared corners are bit-identical
    return TriangleMesh(vertices, index.reshape(-1, 3))


def read_binary_ply(path: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    raw = path.read_bytes()
    end = raw.index(b"end_header\n") + len(b"end_header\n")
    header = raw[:end].decode("ascii").splitlines()
    nv = int(next(line for line in header if line.startswith("element vertex")).split()[-1])
    nf = int(next(line for line in header if line.startswith("element face")).split()[-1])
    vertices = np.frombuffer(raw, "<f8", nv * 3, end).reshape(nv, 3)
    faces = np.frombuffer(
        raw, np.dtype([("n", "u1"), ("v", "<i4", (3,)), ("top", "u1")]), nf, end + nv * 24
    )
    assert len(raw) == end + nv * 24 + nf * 14
    assert (faces["n"] == 3).all()
    return vertices, faces["v"], faces["top"].astype(bool)


def spike_volume(surface) -> float:
    g = surface.spikes
    return float(g.heights.sum() * g.width_x * g.width_y / 3.0)  # pyramids: base area x height / 3


def test_export_stl_is_a_watertight_body(tmp_path, capsys):
    out = generate(tmp_path, capsys, "spikes", SPIKES)
    stl = tmp_path / "body.stl"
    code, _stdout, err = run(
        capsys, "surface", "export", out, "--stl", stl, "--base-thickness", "3 um"
    )
    assert code == 0, err
    mesh = read_binary_stl(stl)
    surface = load_surface(out)
    assert mesh.n_faces == surface.body(3 * UM).n_faces
    assert is_watertight(mesh)
    expected = spike_volume(surface) + surface.size_x * surface.size_y * 3 * UM
    assert signed_volume(mesh) == pytest.approx(expected, rel=1e-5)  # float32 coordinates
    assert mesh.bounds[0] == pytest.approx([-20 * UM, -22.5 * UM, -3 * UM], abs=1e-9)


def test_export_ply_keeps_the_exact_body(tmp_path, capsys):
    out = generate(tmp_path, capsys, "rough", SMALL_RANDOM)
    ply = tmp_path / "body.ply"
    code, _, err = run(
        capsys, "surface", "export", out, "--ply", ply
    )  # default base thickness 1 um
    assert code == 0, err
    vertices, faces, top = read_binary_ply(ply)
    body = load_surface(out).body(1 * UM)
    assert np.array_equal(vertices, body.vertices)
    assert np.array_equal(faces, body.faces)
    assert np.array_equal(top, body.top)
    mesh = TriangleMesh(vertices, faces)
    assert is_watertight(mesh)
    assert signed_volume(mesh) > 0
    assert vertices[:, 2].min() == pytest.approx(-1 * UM)


def _classify(gdml_path, points):
    sys.path.insert(0, str(Path(__file__).parent))
    from helpers.g4_surface_cli import classify

    return classify(gdml_path, points)


def test_export_gdml_tessellated_and_multiunion(tmp_path, capsys):
    spikes_file = generate(tmp_path, capsys, "spikes", SPIKES)
    random_file = generate(tmp_path, capsys, "rough", SMALL_RANDOM)
    surface = load_surface(spikes_file)
    grid, t = surface.spikes, 2 * UM
    rng = np.random.default_rng(3)
    lo = np.array([-grid.size_x / 2 * 1.1, -grid.size_y / 2 * 1.1, -t * 1.1])
    hi = np.array([grid.size_x / 2 * 1.1, grid.size_y / 2 * 1.1, grid.heights.max() * 1.1])
    points = lo + rng.uniform(size=(1500, 3)) * (hi - lo)
    # Reference from numpy: inside the footprint, above the slab bottom, below the exact top.
    in_xy = (np.abs(points[:, 0]) < grid.size_x / 2) & (np.abs(points[:, 1]) < grid.size_y / 2)
    top = grid.height_at(
        np.clip(points[:, 0], -grid.size_x / 2, grid.size_x / 2),
        np.clip(points[:, 1], -grid.size_y / 2, grid.size_y / 2),
    )
    expected = in_xy & (points[:, 2] > -t) & (points[:, 2] < top)
    assert 0.1 < expected.mean() < 0.9  # both sides are sampled
    jobs = {
        "tess": (
            spikes_file,
            tmp_path / "tess.gdml",
            ["--base-thickness", "2 um"],
            points.tolist(),
        ),
        "union": (
            spikes_file,
            tmp_path / "union.gdml",
            ["--base-thickness", "2 um", "--solid", "multiunion", "--material", "G4_Cu"],
            points.tolist(),
        ),
        "random": (random_file, tmp_path / "random.gdml", [], [[0.0, 0.0, -0.5 * UM]]),
    }
    # the exports here (each writes from a process of its own); the reading in one fresh process
    # per file: Geant4 keeps volumes in global stores, and reading a second GDML file with the
    # same volume names in one process returned the first file's world
    results = {}
    for k, (surface_file, gdml_path, extra_args, job_points) in jobs.items():
        code, _, err = run(
            capsys, "surface", "export", surface_file, "--gdml", gdml_path, *extra_args
        )
        assert code == 0, err  # before the reading
        results[k] = (code, *run_in_spawned_process(_classify, str(gdml_path), job_points))
    for name in ("tess", "union"):
        status, kind, _material, blo, bhi, codes = results[name]
        assert status == 0
        inside = np.array(codes) == 2
        # Random points lie on a facet (within 1e-9 mm) with probability ~0: exact agreement.
        assert np.array_equal(inside, expected), (
            f"{name}: {np.count_nonzero(inside != expected)} points disagree"
        )
    assert results["tess"][1:3] == ("G4TessellatedSolid", "G4_Si")
    assert results["union"][1:3] == ("G4MultiUnion", "G4_Cu")
    assert (tmp_path / "tess.gdml").read_text().count("<triangular ") == surface.body(t).n_faces
    # A random surface: a tessellated body whose extent is the surface's, slab 1 um (default).
    status, kind, _, blo, bhi, codes = results["random"]
    rough = load_surface(random_file)
    assert status == 0
    assert kind == "G4TessellatedSolid"
    assert codes == [2]
    assert blo == pytest.approx([-rough.size_x / 2, -rough.size_y / 2, -1 * UM], abs=1e-9)
    assert bhi == pytest.approx([rough.size_x / 2, rough.size_y / 2, rough.max_height], abs=1e-9)
    assert not [p for p in tmp_path.iterdir() if "partial" in p.name]


def _exports_in_one_process(jobs: list[list[str]]) -> bool:
    """``score4 surface export`` once per argument list, all in this process; whether Geant4
    was imported into it."""
    from score4.cli.main import main

    for args in jobs:
        assert main(["surface", "export", *args]) == 0
    return "geant4_pybind" in sys.modules


def test_two_gdml_exports_in_one_process_give_the_files_each_gives_alone(tmp_path, capsys):
    """A program that exports two surfaces to GDML (main() twice in one process) gets the files
    each export writes alone: each solid is built and written in a process of its own
    (sim.export_surface), and the calling process never imports Geant4."""
    spikes_file = generate(tmp_path, capsys, "spikes", SPIKES)
    random_file = generate(tmp_path, capsys, "rough", SMALL_RANDOM)
    jobs = {
        "union": [spikes_file, "--solid", "multiunion", "--material", "G4_Cu"],
        "tess": [random_file, "--base-thickness", "2 um"],
    }

    def args(name: str, prefix: str) -> list[str]:
        surface, *rest = jobs[name]
        return [str(surface), "--gdml", str(tmp_path / f"{prefix}_{name}.gdml"), *rest]

    imported = run_in_spawned_process(_exports_in_one_process, [args(n, "both") for n in jobs])
    assert not imported  # Geant4 ran in processes of their own
    # other tests on this worker may have imported Geant4 already: only a new import counts
    had_geant4 = "geant4_pybind" in sys.modules
    for name in jobs:
        code, _, err = run(capsys, "surface", "export", *args(name, "alone"))
        assert code == 0, err
        alone = (tmp_path / f"alone_{name}.gdml").read_bytes()
        assert (tmp_path / f"both_{name}.gdml").read_bytes() == alone, name
    assert ("geant4_pybind" in sys.modules) == had_geant4


# --- errors ---------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["stats", "{tmp}/none.s4s.h5"], "does not exist"),
        (["stats", "{tmp}/pic.jpg"], "cannot tell what"),
        (["stats", "{tmp}/bad.yaml"], "not valid YAML"),
        (["stats", "{tmp}/typo.yaml"], "heigth: unknown key"),
        (["stats", "{tmp}/foreign.h5"], "is not a score4 surface file"),
        (["show", "{tmp}/none.yaml", "--png", "{tmp}/x.png"], "does not exist"),
        (["generate", "{tmp}/none.yaml", "--out", "{tmp}/x.s4s.h5"], "does not exist"),
        (["generate", "{tmp}/typo.yaml", "--out", "{tmp}/x.s4s.h5"], "heigth: unknown key"),
        (["generate", "{tmp}/good.yaml", "--out", "{tmp}/x.stl"], "--out: "),
        (
            ["export", "{tmp}/good.yaml", "--stl", "{tmp}/a.stl", "--ply", "{tmp}/b.ply"],
            "exactly one of --stl, --ply and --gdml",
        ),
        (["export", "{tmp}/good.yaml"], "exactly one of --stl, --ply and --gdml (got none)"),
        (
            ["export", "{tmp}/good.yaml", "--stl", "{tmp}/a.stl", "--base-thickness", "5"],
            "--base-thickness: '5' has no unit",
        ),
        (
            ["export", "{tmp}/good.yaml", "--stl", "{tmp}/a.stl", "--base-thickness", "0 um"],
            "--base-thickness: must be greater than 0",
        ),
        (
            ["export", "{tmp}/good.yaml", "--stl", "{tmp}/a.stl", "--solid", "multiunion"],
            "applies to --gdml only",
        ),
        (
            ["export", "{tmp}/rough.yaml", "--gdml", "{tmp}/a.gdml", "--solid", "multiunion"],
            "needs a spike grid",
        ),
        (
            ["export", "{tmp}/good.yaml", "--stl", "{tmp}/exists.stl"],
            "already exists; use --overwrite",
        ),
        (["show", "{tmp}/gap.txt", "--png", "{tmp}/x.png"], "missing (NaN) points"),
    ],
)
def test_errors_are_one_line_with_exit_status_2(tmp_path, capsys, args, message):
    write_yaml(tmp_path, "good", PYRAMIDS)
    write_yaml(tmp_path, "rough", SMALL_RANDOM)
    write_yaml(tmp_path, "typo", {**PYRAMIDS, "heigth": "2 um"})
    (tmp_path / "bad.yaml").write_text("kind: spikes\nnx: [1, 2\n")
    (tmp_path / "pic.jpg").write_bytes(b"\xff\xd8")
    (tmp_path / "exists.stl").write_bytes(b"keep")
    import h5py

    with h5py.File(tmp_path / "foreign.h5", "w") as f:
        f["x"] = np.arange(3)
    (tmp_path / "gap.txt").write_text("# pitch = 1 um\n# z_unit = nm\n1 2 3\n4 nan 6\n7 8 9\n")
    code, _stdout, err = run(capsys, "surface", *(a.format(tmp=tmp_path) for a in args))
    assert code == 2
    err = err.strip()
    assert err.startswith("score4: error: ")
    assert message in err
    assert "\n" not in err
    assert (tmp_path / "exists.stl").read_bytes() == b"keep"
    assert not (tmp_path / "x.s4s.h5").exists()
    assert not (tmp_path / "a.stl").exists()


def test_help_documents_units(capsys):
    assert main(["surface", "stats", "--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "Sa Sq Sp Sv Sz Sal in um" in text
    assert "Sdr in %" in text
    assert main(["surface", "--help"]) == 0
    out = capsys.readouterr().out
    assert all(cmd in out for cmd in ("generate", "stats", "show", "export"))
