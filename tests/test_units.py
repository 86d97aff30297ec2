import math

import pytest

from score4.errors import ConfigError
from score4.inputs.units import parse_quantity


@pytest.mark.parametrize(
    ("text", "dimension", "expected"),
    [
        ("5.3 MeV", "energy", 5.3),
        ("103 keV", "energy", 0.103),
        ("20 nm", "length", 20e-6),
        ("20nm", "length", 20e-6),
        ("1e-3 mm", "length", 1e-3),
        ("3 cm", "length", 30.0),
        ("10 um", "length", 0.01),
        ("10 µm", "length", 0.01),
        ("90 deg", "angle", math.pi / 2),
        ("6.02 g/cm3", "density", 6.02),
        ("3070 kg/m3", "density", 3.07),
    ],
)
def test_parse_quantity(text, dimension, expected):
    assert parse_quantity(text, dimension) == pytest.approx(expected, rel=1e-12)


@pytest.mark.parametrize(
    ("value", "message"),
    [
        (5.3, "has no unit"),
        ("5.3", "has no unit"),
        ("5.3 MeVV", "unknown energy unit 'MeVV'"),
        ("five MeV", "cannot read"),
        (True, "expected a energy".replace("a energy", "a energy")),
        ("1 cm", "unknown energy unit 'cm'"),
    ],
)
def test_parse_quantity_errors(value, message):
    with pytest.raises(ConfigError, match=message):
        parse_quantity(value, "energy", name="source.energy")


def test_error_names_parameter():
    with pytest.raises(ConfigError, match=r"^source.energy: "):
        parse_quantity("5", "energy", name="source.energy")
