"""Shared fixtures. Geant4 runs happen in spawned worker processes, so each test run is isolated."""

from __future__ import annotations

import copy
from pathlib import Path

import pytest

from score4.config import parse_config

ROOT = Path(__file__).resolve().parents[1]

BASE_CONFIG = {
    "physics": "lite",
    "targets": [{"name": "crystal", "material": "G4_Si", "size": ["1 cm", "1 cm", "1 cm"], "position": ["0 cm", "0 cm", "-0.5 cm"]}],
    "source": {"particle": "alpha", "energy": "5.3 MeV", "direction": "isotropic", "surface": {"volume": "crystal", "face": "+z"}},
    "run": {"events": 100, "seed": 7},
}


def config_dict(**sections) -> dict:
    """BASE_CONFIG with top-level sections updated (shallow per section)."""
    data = copy.deepcopy(BASE_CONFIG)
    for key, value in sections.items():
        if isinstance(value, dict) and isinstance(data.get(key), dict):
            data[key] = {**data[key], **value}
        else:
            data[key] = value
    return data


@pytest.fixture
def make_config():
    return lambda **sections: parse_config(config_dict(**sections))
