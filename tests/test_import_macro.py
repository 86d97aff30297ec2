"""``score4 import-macro``: original SCoRe4 macros -> score4 run configurations.

The expected numbers are worked out by hand from the macros (half-lengths doubled; a pyramid is
2 x setSpikeMeanHeight high, a bump or peak 1 x), never taken from the converter.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from score4.cli.main import main
from score4.errors import ConfigError
from score4.inputs.config import load_config, parse_config
from score4.macro import import_macro
from score4.world.resolve import build_scene

from conftest import ROOT

MACROS = ROOT / "tests" / "data" / "macros"
PAPER = MACROS / "paper_example.mac"  # the paper's Listing lst:surface_macro, verbatim
PORTAL = MACROS / "portal_example.mac"  # portal route + depth table + unknown commands
UM = 1e-3  # mm
NM = 1e-6  # mm


def run(capsys, *args) -> tuple[int, str, str]:
    code = main([str(a) for a in args])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def macro(tmp_path: Path, text: str, name: str = "test.mac") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


# A RoughnessHelper block the small tests vary (named helper "r"; 4 x 4 spikes of half-width 5 um).
HELPER = """\
/Surface/RoughnessHelper/r/setBasisDx 20 um
/Surface/RoughnessHelper/r/setBasisDy 20 um
/Surface/RoughnessHelper/r/setBasisDz 1 um
/Surface/RoughnessHelper/r/setSpikeDx 5 um
/Surface/RoughnessHelper/r/setSpikeDy 5 um
/Surface/RoughnessHelper/r/setSpikesNx 4
/Surface/RoughnessHelper/r/setSpikesNy 4
/Surface/RoughnessHelper/r/setSpikeMeanHeight 3 um
"""


def items(report_list) -> dict[str, str]:
    """{"line N": command text} of a report list."""
    return {i.where: i.command for i in report_list}


# --- the paper's macro ------------------------------------------------------------------------


def test_paper_macro_converts_to_full_lengths(tmp_path):
    config, report = import_macro(PAPER, out=tmp_path / "paper.yaml")
    rc = parse_config(config, base_dir=tmp_path)
    spikes = rc.surfaces["rough"]  # the paper's short paths have no helper name
    # setSpikeDx/Dy 5 um are half-widths: a spike cell is 2 x 5 = 10 um wide
    assert spikes.width_x == pytest.approx(10 * UM)
    assert spikes.width_y == pytest.approx(10 * UM)
    # StandardPyramid with setSpikeMeanHeight 5 um: one G4Trd of half-height 5 um -> 10 um high
    assert spikes.height == pytest.approx(10 * UM)
    # setSpikeDevHeight 1 mm is ignored by StandardPyramid: all spikes equal
    assert spikes.height_sigma == 0.0
    assert (spikes.nx, spikes.ny, spikes.shape) == (100, 100, "pyramid")
    target = rc.targets[0]
    # setBasisDx/Dy 0.5 mm half -> a 1 mm x 1 mm face (= 100 x 10 um); the 1 mm thickness is the
    # default
    assert target.size == pytest.approx((1.0, 1.0, 1.0))
    assert target.position == pytest.approx((0.0, 0.0, -0.5))  # face at z = 0
    assert target.material == "G4_Si"  # setMaterial G4_Si
    rough = target.rough[0]
    # setBasisDz 0.25 mm half-height -> a 0.5 mm slab under the spikes
    assert rough.base_thickness == pytest.approx(0.5)
    assert (rough.face, rough.surface, rough.tiling) == ("+z", "rough", "native")
    assert rc.source.surface.volume == target.name

    converted = items(report.converted)
    assert set(converted) == {f"line {n}" for n in (6, 7, 8, 10, 11, 12, 14, 16, 17, 19)}
    assert converted["line 12"] == "/Surface/RoughnessHelper/setSpikeMeanHeight 5 um"
    detail = {i.where: i.detail for i in report.converted}
    assert detail["line 12"].startswith("surfaces.rough.height = 10 um (2 x setSpikeMeanHeight")
    assert detail["line 8"].startswith("targets.0.rough.0.base_thickness = 0.5 mm")
    assert set(items(report.ignored)) == {f"line {n}" for n in (4, 13, 21, 22, 23)}
    assert report.unknown == []
    # every one of the 15 commands is accounted for exactly once
    n_commands = sum(1 for line in PAPER.read_text().splitlines() if line.startswith("/"))
    assert len(report.converted) + len(report.ignored) + len(report.unknown) == n_commands == 15
    keys = [key for key, _ in report.defaults]
    assert {"targets.0", "source.particle", "source.energy", "run.events"} <= set(keys)


def test_paper_macro_surface_builds(tmp_path):
    config, _ = import_macro(PAPER, out=tmp_path / "paper.yaml")
    scene = build_scene(parse_config(config, base_dir=tmp_path))
    layer = scene.layers[0]
    assert layer.patch_size == pytest.approx((1.0, 1.0))  # one 1 mm patch covers the 1 mm face
    assert layer.patch_map.variants.shape == (1, 1)
    grid = scene.surfaces["rough"].spikes
    assert (grid.nx, grid.ny) == (100, 100)
    assert np.allclose(grid.heights, 10 * UM)  # equal 10 um pyramids


def test_cli_writes_yaml_that_round_trips(tmp_path, capsys):
    out = tmp_path / "paper.yaml"
    code, stdout, err = run(capsys, "import-macro", PAPER, "--out", out)
    assert code == 0, err
    assert err == ""
    assert stdout.splitlines()[-1].startswith(
        f"wrote {out} from {PAPER}: 10 command(s) converted, 5 ignored"
    )
    text = out.read_text()
    header = [line for line in text.splitlines() if line.startswith("#")]
    assert f"# source macro: {PAPER.resolve()}" in header
    assert any(line.startswith("# date:         20") for line in header)  # the date
    assert "#   targets.0.size.2" not in text  # defaults are listed by their keys below
    assert any(
        line.startswith("#   targets.0 = a G4_Si block named 'target', 1 mm thick")
        for line in header
    )
    i = header.index("# NOT converted (unknown commands or values score4 cannot represent):")
    assert header[i + 1] == "#   (none)"
    loaded = load_config(out)
    direct = parse_config(yaml.safe_load(text), base_dir=tmp_path)
    assert loaded == direct
    assert loaded.surfaces["rough"].height == pytest.approx(10 * UM)


# --- the portal macro -------------------------------------------------------------------------


def test_portal_macro(tmp_path):
    config, report = import_macro(PORTAL, out=tmp_path / "portal.yaml")
    rc = parse_config(config, base_dir=tmp_path)
    spikes = rc.surfaces["RoughnessHelper"]
    # UniformPyramid, mean 10 um, sigma 1 um: heights 2 x N(10, 1) um -> mean 20 um, sigma 2 um
    assert spikes.height == pytest.approx(20 * UM)
    assert spikes.height_sigma == pytest.approx(2 * UM)
    assert spikes.width_x == pytest.approx(50 * UM)  # 2 x 25 um; 20 x 50 um = the 1 mm patch
    target = rc.targets[0]
    # portal half-sizes 1 mm x 1.5 mm -> a 2 mm x 3 mm face of 2 x 3 patches (setN[xy]Subworld 2, 3)
    assert target.size[:2] == pytest.approx((2.0, 3.0))
    assert target.rough[0].tiling == "portal"
    assert (
        rc.world.material == "G4_Galactic"
    )  # the portal's setMaterial: the medium around the patches
    src = rc.source
    assert (src.particle, src.energy, src.direction) == ("alpha", pytest.approx(5.3), "isotropic")
    depth = src.depth
    assert depth.profile == "table"
    assert depth.unit == "nm"
    assert depth.definition == "normal"
    assert depth.file.resolve() == (MACROS / "shift_table.csv").resolve()  # found beside the macro
    assert (depth.min, depth.max) == (pytest.approx(10 * NM), pytest.approx(110 * NM))
    assert src.confine == "G4_Si"
    assert rc.run.events == 500
    assert rc.run.seed == 12345 * 2**32 + 678  # /random/setSeeds 12345 678, folded into one seed
    assert items(report.unknown) == {
        "line 42": "/process/em/fluo true",
        "line 43": "/score4test/madeUp 42",
    }
    assert "line 41" in items(report.ignored)  # /run/initialize

    scene = build_scene(rc)
    assert scene.layers[0].patch_map.variants.shape == (3, 2)  # (ny, nx) cells
    from score4.source.build import make_source

    primaries = make_source(rc, scene).primaries(np.random.default_rng(3), 0, 500)
    d = primaries.extra["depth"]
    assert d.min() >= 10 * NM
    assert d.max() <= 110 * NM


def test_cli_warns_on_unknown_commands_and_strict_fails(tmp_path, capsys):
    out = tmp_path / "portal.yaml"
    code, stdout, err = run(capsys, "import-macro", PORTAL, "--out", out, "--strict")
    assert code == 2
    assert stdout == ""
    assert not out.exists()
    lines = err.splitlines()
    assert lines[-1] == (
        f"score4: error: {PORTAL}: 2 command(s) not converted (--strict; nothing written): "
        "line 42 /process/em/fluo; line 43 /score4test/madeUp"
    )
    code, _, err = run(capsys, "import-macro", PORTAL, "--out", out)
    assert code == 0
    assert (
        f"score4: warning: {PORTAL} line 43: /score4test/madeUp 42: not converted (unknown command)"
        in err
    )
    header = [line for line in out.read_text().splitlines() if line.startswith("#")]
    assert "#   line 43: /score4test/madeUp 42 -> unknown command" in header
    assert load_config(out).source.depth.file.resolve() == (MACROS / "shift_table.csv").resolve()


# --- errors -----------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("line", "message"),
    [
        (
            "/Surface/RoughnessHelper/r/setSpikeDx abc",
            "/Surface/RoughnessHelper/r/setSpikeDx: 'abc' is not a length",
        ),
        (
            "/Surface/RoughnessHelper/r/setSpikeDx 5",
            "/Surface/RoughnessHelper/r/setSpikeDx: '5' has no unit",
        ),
        (
            "/Surface/RoughnessHelper/r/setSpikeDx 5 MeV",
            "'5 MeV' is not a length: 'MeV' is an energy unit",
        ),
        ("/Surface/RoughnessHelper/r/setSpikeDx -5 um", "'-5 um': the length must be > 0"),
        (
            "/Surface/RoughnessHelper/r/setSpikesNx 1.5",
            "/Surface/RoughnessHelper/r/setSpikesNx: '1.5' is not an integer >= 1",
        ),
        (
            "/Surface/RoughnessHelper/r/setSpikeform Cone",
            "'Cone' is not one of StandardPyramid, UniformPyramid",
        ),
        ("/gps/ene/mono fast", "/gps/ene/mono: 'fast' is not an energy"),
        ("/run/beamOn many", "/run/beamOn: 'many' is not an integer >= 0"),
    ],
)
def test_bad_values_name_file_and_line(tmp_path, capsys, line, message):
    path = macro(tmp_path, HELPER + "# a comment\n\n" + line + "\n")  # the bad value is on line 11
    with pytest.raises(ConfigError) as err:
        import_macro(path)
    assert str(err.value).startswith(f"{path} line 11: ")
    assert message in str(err.value)
    code, stdout, stderr = run(capsys, "import-macro", path, "--out", tmp_path / "c.yaml")
    assert code == 2
    assert stdout == ""
    assert stderr == f"score4: error: {err.value}\n"  # one line
    assert not (tmp_path / "c.yaml").exists()


def test_sizes_the_original_refuses_are_errors(tmp_path):
    # 4 spikes x 5 um (half) = 20 um, but the basis says 25 um: RoughnessHelper::CheckValues exits
    path = macro(tmp_path, HELPER.replace("setBasisDx 20 um", "setBasisDx 25 um"))
    with pytest.raises(
        ConfigError,
        match=r"line 1: .*setBasisDx: basis half-length 25 um must equal setSpikesNx x "
        r"setSpikeDx = 4 x 5 um = 20 um",
    ):
        import_macro(path)
    # a required parameter missing (the original's default 0 builds no spike)
    path = macro(
        tmp_path, HELPER.replace("/Surface/RoughnessHelper/r/setSpikeMeanHeight 3 um\n", "")
    )
    with pytest.raises(ConfigError, match="setSpikeMeanHeight is missing"):
        import_macro(path)
    with pytest.raises(ConfigError, match="no rough surface"):
        import_macro(macro(tmp_path, "/run/beamOn 10\n"))


def test_missing_file_and_existing_output(tmp_path, capsys):
    code, _, err = run(
        capsys, "import-macro", tmp_path / "nothere.mac", "--out", tmp_path / "c.yaml"
    )
    assert (code, err) == (
        2,
        f"score4: error: FILE.mac: '{tmp_path / 'nothere.mac'}' does not exist\n",
    )
    out = tmp_path / "c.yaml"
    out.write_text("keep me\n")
    code, _, err = run(capsys, "import-macro", PAPER, "--out", out)
    assert (code, err) == (
        2,
        f"score4: error: --out: '{out}' already exists; use --overwrite to replace it\n",
    )
    assert out.read_text() == "keep me\n"
    code, _, err = run(capsys, "import-macro", PAPER, "--out", out, "--overwrite")
    assert code == 0, err
    assert load_config(out).surfaces["rough"].nx == 100


# --- conversion rules -------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("form", "extra", "height", "sigma", "shape", "layers"),
    [
        # pyramids: one G4Trd of half-height MeanHeight -> 2 x 3 um; the deviation only for
        # UniformPyramid
        ("StandardPyramid", "setSpikeDevHeight 0.5 um", 6.0, 0.0, "pyramid", 1),
        ("UniformPyramid", "setSpikeDevHeight 0.5 um", 6.0, 1.0, "pyramid", 1),
        # bump and peak: layers add up to MeanHeight -> 1 x 3 um, setNLayer layers
        ("Bump", "setNLayer 4", 3.0, 0.0, "bump", 4),
        ("Peak", "setNLayer 3", 3.0, 0.0, "peak", 3),
    ],
)
def test_height_factor_per_spike_form(tmp_path, form, extra, height, sigma, shape, layers):
    text = (
        HELPER
        + f"/Surface/RoughnessHelper/r/setSpikeform {form}\n/Surface/RoughnessHelper/r/{extra}\n"
    )
    config, _ = import_macro(macro(tmp_path, text))
    spec = parse_config(config).surfaces["r"]
    assert spec.height == pytest.approx(height * UM)
    assert spec.height_sigma == pytest.approx(sigma * UM)
    assert (spec.shape, spec.n_layers) == (shape, layers)
    assert spec.width_x == pytest.approx(10 * UM)


def test_geant4_units_defaults_and_ions(tmp_path):
    text = HELPER.replace("setSpikeDx 5 um", "setSpikeDx 5000 nanometer") + (
        "/gps/particle ion\n/gps/ion 84 210\n/gps/energy 0\n"  # an ion at rest: it decays
        "/shift/loadShiftTable table.txt\n/shift/setMaxShift 0.0001\n"  # default unit mm: 100 nm
        "/run/setCut 1 nm\n/run/beamOn\n"  # beamOn without a number runs 1 event
    )
    (tmp_path / "table.txt").write_text("0,1\n50,2\n200,0\n")  # depths 50 and 150 nm apart
    config, report = import_macro(macro(tmp_path, text))
    rc = parse_config(config, base_dir=tmp_path)
    assert rc.surfaces["r"].width_x == pytest.approx(10 * UM)  # 2 x 5000 nm
    assert rc.source.nuclide == "Po210"
    assert rc.source.particle is None
    assert rc.source.depth.max == pytest.approx(100 * NM)
    assert rc.physics.production_cut == pytest.approx(1 * NM)
    assert rc.run.events == 1
    assert rc.source.confine is True  # score4's default, reported as such
    assert "source.confine" in [key for key, _ in report.defaults]
    assert any("not equally spaced" in note for note in report.notes)
    with pytest.raises(ConfigError, match=r"line 9: /gps/ene/mono: score4 needs a positive energy"):
        import_macro(macro(tmp_path, HELPER + "/gps/ene/mono 0 MeV\n"))


def test_included_macros_repeated_commands_and_after_initialize(tmp_path):
    macro(
        tmp_path,
        "/Surface/RoughnessHelper/r/setSpikeMeanHeight 4 um\n/gps/particle e-\n",
        "sub.mac",
    )
    text = HELPER + (
        "/control/execute sub.mac\n"  # line 9: overrides the mean height of line 8
        "/run/initialize\n"
        # line 11: after Construct(), so it has no effect
        "/Surface/RoughnessHelper/r/setSpikeMeanHeight 9 um\n"
        "/gps/energy 2 MeV\n"
    )
    path = macro(tmp_path, text)
    config, report = import_macro(path)
    rc = parse_config(config)
    assert rc.surfaces["r"].height == pytest.approx(8 * UM)  # 2 x 4 um from sub.mac
    assert (rc.source.particle, rc.source.energy) == ("e-", pytest.approx(2.0))
    ignored = {i.where: i.detail for i in report.ignored}
    assert ignored["line 8"] == "overridden by sub.mac line 1"
    assert ignored["line 11"].startswith("after /run/initialize (line 10)")
    assert (
        items(report.converted)["sub.mac line 1"]
        == "/Surface/RoughnessHelper/r/setSpikeMeanHeight 4 um"
    )


def test_two_tables_are_merged_into_a_file_beside_the_config(tmp_path, capsys):
    (tmp_path / "a.csv").write_text("0,1\n10,2\n20,3\n")
    (tmp_path / "b.csv").write_text("30,2\n40,1\n50,0\n")
    path = macro(tmp_path, HELPER + "/shift/loadShiftTable a.csv\n/shift/loadShiftTable b.csv\n")
    out = tmp_path / "out" / "merged.yaml"
    out.parent.mkdir()
    code, _, err = run(capsys, "import-macro", path, "--out", out)
    assert code == 0, err
    table = out.parent / "merged.depth.txt"
    rows = [line for line in table.read_text().splitlines() if line and not line.startswith("#")]
    assert rows == ["0,1", "10,2", "20,3", "30,2", "40,1", "50,0"]  # appended, as the original does
    rc = load_config(out)
    assert rc.source.depth.file == table
    assert rc.source.depth.unit is None
    # tables whose depths go back cannot be merged: an error on the second load's line
    (tmp_path / "c.csv").write_text("5,1\n8,1\n")
    path = macro(tmp_path, HELPER + "/shift/loadShiftTable a.csv\n/shift/loadShiftTable c.csv\n")
    with pytest.raises(
        ConfigError, match=r"line 10: /shift/loadShiftTable: the tables cannot be merged"
    ):
        import_macro(path)


def test_describer_commands(tmp_path):
    # without a RoughnessHelper the Describer's /geometry/surface values (and defaults) are used
    config, report = import_macro(
        macro(tmp_path, "/geometry/surface/setNrSpike_X 3\n/geometry/surface/setSpikeform Bump\n")
    )
    spec = parse_config(config).surfaces["surface"]
    # Describer defaults: half-width 0.005 mm -> 10 um cells; Bump height = MeanHeight 0.005 mm
    assert (spec.nx, spec.ny, spec.shape) == (3, 1, "bump")
    assert spec.width_y == pytest.approx(10 * UM)
    assert spec.height == pytest.approx(5 * UM)
    # with a RoughnessHelper they are overridden (RoughnessHelper::BuildSurface)
    _, report = import_macro(macro(tmp_path, "/geometry/surface/setNrSpike_X 3\n" + HELPER))
    assert items(report.ignored) == {"line 1": "/geometry/surface/setNrSpike_X 3"}


def test_deviations_from_the_original_are_reported(tmp_path):
    """The original's RoughnessHelper limits steps in its roughness volume to 1 % of the smaller
    spike half-width (5 um -> 50 nm) unless setStepLimit is given, and its MultiportalHelper
    material fills only the portal, subworlds and triggers; score4 does neither, and says so."""
    _, report = import_macro(macro(tmp_path, HELPER), out=tmp_path / "a.yaml")
    step = [n for n in report.notes if "limits steps" in n]
    assert len(step) == 1
    assert "deviation" in step[0]
    assert "50 nm" in step[0]
    assert "'r'" in step[0]
    limited = macro(tmp_path, HELPER + "/Surface/RoughnessHelper/r/setStepLimit 1 nm\n", "b.mac")
    _, report = import_macro(limited, out=tmp_path / "b.yaml")
    assert not [n for n in report.notes if "limits steps" in n]
    assert "deviation" in items_detail(report.ignored)["line 9"]
    _, report = import_macro(PORTAL, out=tmp_path / "portal.yaml")
    material = [n for n in report.notes if "portal, its subworlds and triggers" in n]
    assert len(material) == 1
    assert "G4_Galactic" in material[0]
    assert "deviation" in material[0]


def items_detail(report_list) -> dict[str, str]:
    """{"line N": what became of it} of a report list."""
    return {i.where: i.detail for i in report_list}
