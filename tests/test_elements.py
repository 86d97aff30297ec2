"""score4.elements: the one home of element symbols, English element names and nuclide and ion
names, and the callers that read names through it (messages as before)."""

from __future__ import annotations

import pytest

from score4.decay.nuclear_data import ZAI, nuclide_name
from score4.elements import (
    ELEMENT_NAMES,
    ELEMENTS,
    ground_state_name,
    split_ion_name,
    split_nuclide,
)
from score4.errors import ConfigError
from score4.ions.species import parse_ion
from score4.source.emitters import normalise_nuclide, normalise_particle


@pytest.mark.parametrize(
    ("text", "parts"),
    [
        ("Po210", ("Po", "210", False)),
        ("po-210", ("po", "210", False)),
        (" 210Po ", ("Po", "210", False)),
        ("Pa234m", None),
        ("210", None),
        ("Pb 210", None),
        ("Pb2100", None),
    ],
)
def test_split_nuclide(text, parts):
    assert split_nuclide(text) == parts


@pytest.mark.parametrize(
    ("text", "parts"),
    [
        ("Pa234m", ("Pa", "234", True)),
        ("234mPa", ("Pa", "234", True)),
        ("Pa234M", ("Pa", "234", True)),
        ("Pb210", ("Pb", "210", False)),
        ("210Mo", ("o", "210", True)),  # read as metastable: nuclide_za then refuses 'o'
    ],
)
def test_split_nuclide_with_metastable_states(text, parts):
    assert split_nuclide(text, metastable=True) == parts


def test_geant4_ion_names():
    assert split_ion_name("Pb206") == ("Pb", 206)
    assert split_ion_name("Pb-206") == ("Pb", 206)
    assert split_ion_name("pb206") is None
    assert split_ion_name("alpha") is None
    assert ground_state_name("Pb210[0.000]") == "Pb210"
    assert ground_state_name("Pa234[73.920]") == "Pa234"
    assert ground_state_name("alpha") == "alpha"


def test_english_names_name_known_symbols():
    assert ELEMENT_NAMES["lead"] == "Pb"
    assert ELEMENT_NAMES["aluminium"] == ELEMENT_NAMES["aluminum"] == "Al"
    assert set(ELEMENT_NAMES.values()) == set(ELEMENTS[:98])


def test_callers_read_names_through_it_with_their_own_messages():
    assert normalise_nuclide("210po") == "Po210"
    assert normalise_particle("Po-210") == "Po210"
    assert nuclide_name("234mPa") == "Pa234m"
    assert ZAI("Pa234m") == 912341
    assert parse_ion("206-pb").name == "Pb206"
    with pytest.raises(ConfigError, match=r"^nuclide: cannot read 'Pa234m'; write element"):
        normalise_nuclide("Pa234m")
    with pytest.raises(ConfigError, match=r"^decay: 'Xx210' has unknown element symbol 'Xx'$"):
        nuclide_name("Xx210")
    with pytest.raises(ConfigError, match=r"^ION: unknown ion 'Xx210'"):
        parse_ion("Xx210")
