from pathlib import Path

import pytest
import yaml

from score4.errors import ConfigError
from score4.inputs.config import (
    config_to_dict,
    default_trim_histories,
    load_config,
    parse_config,
    trim_histories,
)

from conftest import ROOT, config_dict


def test_example_config_loads():
    config = load_config(ROOT / "examples" / "flat_alpha.yaml")
    assert config.source.energy == pytest.approx(5.3)
    assert config.targets[0].size == (30.0, 30.0, 10.0)  # mm
    assert config.physics.mode == "auto"


def test_defaults_fill_a_short_config():
    config = parse_config(config_dict(run={}))
    assert config.run.chunk_events > 0
    assert config.output.histogram.bins == 100


@pytest.mark.parametrize(
    ("sections", "message"),
    [
        (
            {"targets": [{"name": "c", "size": ["0 cm", "1 cm", "1 cm"]}]},
            r"targets.0.size.0: .*greater than 0",
        ),
        ({"targets": [{"name": "c", "size": ["-1 cm", "1 cm", "1 cm"]}]}, r"targets.0.size.0"),
        ({"source": {"energy": "5.3"}}, r"source.energy: '5.3' has no unit"),
        ({"source": {"energy": "-5.3 MeV"}}, r"source.energy: .*greater than 0"),
        ({"source": {"surface": {"volume": "nothing"}}}, r"'nothing' is not a target"),
        ({"physics": "medium"}, r"physics.mode"),
        ({"sorce": {}}, r"sorce: unknown key"),
        ({"run": {"events": 0}}, r"run.events"),
    ],
)
def test_bad_values_give_one_clear_line(sections, message):
    with pytest.raises(ConfigError, match=message) as err:
        parse_config(config_dict(**sections))
    assert "\n" not in str(err.value)


def test_duplicate_volume_names():
    targets = [{"name": "a", "size": ["1 cm"] * 3}, {"name": "a", "size": ["1 cm"] * 3}]
    with pytest.raises(ConfigError, match="repeated: a"):
        parse_config(config_dict(targets=targets, source={"surface": {"volume": "a"}}))


def test_missing_file(tmp_path: Path):
    with pytest.raises(ConfigError, match="does not exist"):
        load_config(tmp_path / "nope.yaml")


def test_not_yaml(tmp_path: Path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("targets: [unclosed\n  - x: {")
    with pytest.raises(ConfigError, match=r"bad.yaml line \d+: not valid YAML"):
        load_config(bad)


def test_top_level_not_mapping(tmp_path: Path):
    bad = tmp_path / "list.yaml"
    bad.write_text("- 1\n- 2\n")
    with pytest.raises(ConfigError, match="top level must be a mapping"):
        load_config(bad)


# --- strict input: issue 11 ---------------------------------------------------------------------


def write_yaml(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "c.yaml"
    path.write_text(text)
    return path


def test_a_key_given_twice_names_the_key_both_lines_and_the_file(tmp_path: Path):
    path = write_yaml(
        tmp_path,
        "targets: [{name: c, size: [1 cm, 1 cm, 1 cm]}]\n"
        "source:\n"
        "  particle: alpha\n"
        "  energy: 5.3 MeV\n"
        "  surface: {volume: c}\n"
        "  energy: 1 keV\n",
    )
    with pytest.raises(ConfigError) as err:
        load_config(path)
    assert str(err.value) == (
        f"{path}: source.energy: key given twice (lines 4 and 6); keep one of them"
    )


def test_merge_keys_may_still_be_overridden(tmp_path: Path):
    from score4.common.yamlfile import load_yaml

    path = write_yaml(
        tmp_path,
        "defaults: &box {name: c, material: G4_Cu}\ntargets: [{<<: *box, material: G4_Si}]\n",
    )
    assert load_yaml(path)["targets"] == [{"name": "c", "material": "G4_Si"}]


@pytest.mark.parametrize(
    ("sections", "message"),
    [
        ({"run": {"seed": True}}, "cfg.yaml: run.seed: takes a whole number, not true"),
        ({"run": {"events": False}}, "cfg.yaml: run.events: takes a whole number, not false"),
        (
            {"physics": {"production_cut": True}},
            "cfg.yaml: physics.production_cut: takes a length such as '5 um', not true",
        ),
        (
            {
                "source": {
                    "depth": {
                        "profile": "multi_exponential",
                        "means": ["1 nm", "2 nm"],
                        "weights": [True, 0.5],
                    }
                }
            },
            "cfg.yaml: source.depth.weights.0: takes a number, not true",
        ),
        (
            {"source": {"energy": "1e30 TeV"}},
            (
                "cfg.yaml: source.energy: '1e30 TeV' is above 100 TeV, the top of Geant4's "
                "electromagnetic physics tables"
            ),
        ),
        (
            {"targets": [{"name": "crystal", "size": ["10 km", "1 cm", "1 cm"]}]},
            "cfg.yaml: targets.0.size.0: '10 km' is longer than 100 m",
        ),
        (
            {"targets": [{"name": "crystal", "size": ["1e-6 nm", "1 cm", "1 cm"]}]},
            "cfg.yaml: targets.0.size.0: '1e-6 nm' is shorter than 10 pm",
        ),
        (
            {"source": {"energi": "5 MeV"}},
            "cfg.yaml: source.energi: unknown key; did you mean 'energy'?",
        ),
        (
            {"source": {"depth": {"profile": "uniform", "min": "50 nm", "max": "10 nm"}}},
            "cfg.yaml: source.depth: max (10 nm) must be larger than min (50 nm)",
        ),
        (
            {"source": {"depth": {"profile": "uniform", "min": "0.1 um", "max": "0.0002 mm"}}},
            "",  # fine: 100 nm < 200 nm
        ),
        (
            {
                "surfaces": {
                    "s": {"kind": "spikes", "nx": 2, "ny": 2, "width": "5 um", "height": "2 um"}
                },
                "targets": [
                    {
                        "name": "crystal",
                        "size": ["10 um", "10 um", "1 cm"],
                        "rough": [
                            {"surface": "s", "tiling": "portal", "native_layout": "replicas"}
                        ],
                    }
                ],
            },
            (
                "cfg.yaml: targets.0.rough.0.native_layout: used only with tiling: native (here "
                "tiling is portal); remove native_layout or change tiling"
            ),
        ),
        (
            {"source": {"depth": {"profile": "exponential", "mean": "5 nm", "sigma": "2 nm"}}},
            (
                "cfg.yaml: source.depth.sigma: used only with profile: truncated_gaussian (here "
                "profile is exponential); remove sigma or change profile"
            ),
        ),
    ],
)
def test_strict_values_and_plain_messages(sections, message):
    if not message:
        parse_config(config_dict(**sections), origin="cfg.yaml")
        return
    with pytest.raises(ConfigError) as err:
        parse_config(config_dict(**sections), origin="cfg.yaml")
    text = str(err.value)
    assert text.startswith(message), text
    assert "\n" not in text
    assert "np.float64" not in text
    assert "more problem" not in text


SPIKES = {"kind": "spikes", "nx": 2, "ny": 2, "width": "1 um", "height": "1 um"}


def test_a_typo_is_named_first_with_the_closest_key():
    pyr = {k: v for k, v in SPIKES.items() if k != "height"} | {"hieght": "1 um"}
    with pytest.raises(ConfigError) as err:
        parse_config(config_dict(surfaces={"pyr": pyr}), origin="cfg.yaml")
    assert str(err.value) == "cfg.yaml: surfaces.pyr.hieght: unknown key; did you mean 'height'?"


def test_width_with_width_x_is_refused_unless_equal():
    both = SPIKES | {"width_x": "2 um"}
    with pytest.raises(ConfigError, match=r"surfaces.pyr.width_x: give width or width_x, not both"):
        parse_config(config_dict(surfaces={"pyr": both}))
    same = parse_config(config_dict(surfaces={"pyr": SPIKES | {"width_x": "1 um"}}))
    assert same.surfaces["pyr"].width_x == pytest.approx(1e-3)


def test_readable_quantities():
    from score4.common.units import format_readable

    assert format_readable(1e-05, "length") == "10 nm"
    assert format_readable(0.00019999999999999998, "length") == "200 nm"
    assert format_readable(30.0, "length") == "30 mm"
    assert format_readable(0.103, "energy") == "103 keV"


def test_material_suggestions_read_element_names_and_formulas():
    from score4.inputs.materials import suggest_materials

    known = [
        "G4_S",
        "G4_Sc",
        "G4_Si",
        "G4_Sn",
        "G4_I",
        "G4_Cu",
        "G4_Ge",
        "G4_WATER",
        "G4_SILICON_DIOXIDE",
        "G4_CALCIUM_TUNGSTATE",
        "G4_CADMIUM_TUNGSTATE",
        "G4_TEFLON",
    ]
    for name in ("G4_SILICON", "G4_Silicon", "silicon", "G4_Sl", "G4_SI", "Si"):
        assert suggest_materials(name, known)[0] == "G4_Si", name
    assert suggest_materials("G4_COPER", known)[0] == "G4_Cu"
    assert suggest_materials("germanium", known)[0] == "G4_Ge"
    assert suggest_materials("CaWO4", known)[0] == "G4_CALCIUM_TUNGSTATE"
    assert suggest_materials("SiO2", known)[0] == "G4_SILICON_DIOXIDE"
    assert suggest_materials("PTFE", known)[0] == "G4_TEFLON"


def test_depth_table_errors_name_the_table_line_and_the_config(tmp_path: Path, capsys):
    from score4.cli.main import main

    table = tmp_path / "depth.txt"
    table.write_text("# unit: nm\n0 1\n10 x\n")
    data = config_dict(source={"depth": {"profile": "table", "file": "depth.txt"}})
    config = tmp_path / "c.yaml"
    config.write_text(yaml.safe_dump(data))
    assert main(["vertices", str(config), "--out", str(tmp_path / "v.h5")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"score4: error: {config}: source.depth: ")
    assert "\n" not in err
    assert f"depth table {table} line 3: cannot read '10 x'" in err
    # a depth window outside the table: the table is named, not a class
    table.write_text("# unit: nm\n0 1\n10 1\n")
    data["source"]["depth"] |= {"min": "20 nm", "max": "30 nm"}
    config.write_text(yaml.safe_dump(data))
    assert main(["vertices", str(config), "--out", str(tmp_path / "v.h5")]) == 2
    err = capsys.readouterr().err.strip()
    assert (
        f"the depth table {table} (depths 0 mm to 10 nm) has no probability between 20 nm and 30 nm"
        in err
    )
    assert "Profile" not in err


def _rough_target(**rough) -> list[dict]:
    return [{"name": "crystal", "size": ["1 mm"] * 3, "rough": [{"surface": "s", **rough}]}]


_SURFACES = {
    "s": {
        "kind": "spikes",
        "shape": "pyramid",
        "width": "10 um",
        "height": "5 um",
        "nx": 2,
        "ny": 2,
    }
}


@pytest.mark.parametrize(
    ("sections", "message"),
    [
        (
            {"surfaces": _SURFACES, "targets": _rough_target(n_tiles=8)},
            (
                "targets.0.rough.0.n_tiles: used only with fill: tiles (here fill is exact); "
                "remove n_tiles or change fill"
            ),
        ),
        (
            {"physics": {"heavy_ions": "geant4", "trim_max_energy": "2 MeV"}},
            (
                "physics.trim_max_energy: used only with heavy_ions: trim (here heavy_ions is "
                "geant4); remove trim_max_energy or change heavy_ions"
            ),
        ),
    ],
)
def test_a_key_the_chosen_option_ignores_is_refused(sections, message):
    """schema.StrictModel.used_only_with: one generic rule for option-dependent keys."""
    with pytest.raises(ConfigError) as err:
        parse_config(config_dict(**sections))
    assert message in str(err.value)


_TWO = [{"surface": "s", "density": 0.5}, {"surface": "s", "density": 0.5}]


def test_a_key_under_the_option_that_uses_it_is_accepted():
    config = parse_config(
        config_dict(
            surfaces=_SURFACES,
            targets=_rough_target(fill="tiles", n_tiles=8, surface=None, variants=_TWO),
        )
    )
    assert config.targets[0].rough[0].n_tiles == 8
    physics = parse_config(config_dict(physics={"trim_max_energy": "2 MeV"})).physics
    assert physics.trim_max_energy == pytest.approx(2.0)


@pytest.mark.parametrize(
    ("events", "histories"),
    [
        (1, 1000),
        (20_000, 1000),
        (20_001, 2000),
        (100_000, 5000),
        (2_000_000, 100_000),
        (10**9, 100_000),
    ],
)
def test_the_default_trim_library_grows_with_the_run(events, histories):
    """At most 20 events per history (docs/physics.md, Library size), 1000 to 100 000."""
    assert default_trim_histories(events) == histories
    config = parse_config(config_dict(run={"events": events}))
    assert config.physics.trim_histories is None
    assert trim_histories(config) == histories


def test_a_given_trim_library_size_is_kept_and_a_dump_reads_back():
    config = parse_config(config_dict(run={"events": 10**6}, physics={"trim_histories": 300}))
    assert trim_histories(config) == 300
    stored = config_to_dict(parse_config(config_dict(run={"events": 10**5})))
    assert stored["physics"]["trim_histories"] == 5000  # the size the run used
    assert trim_histories(parse_config(stored)) == 5000
    geant4 = config_dict(physics={"mode": "lite", "heavy_ions": "geant4"})
    assert config_to_dict(parse_config(geant4))["physics"]["trim_histories"] is None
