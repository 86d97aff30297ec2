from pathlib import Path

import pytest

from score4.config import load_config, parse_config
from score4.errors import ConfigError

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
