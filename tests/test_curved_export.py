"""A rough curved face exported to GDML (issue 24 item 5): the side wall of a copper disk (a
G4Tubs) with 1 mm patches bent onto it, written by `score4 geometry export`; Geant4 reads the
file back with the same geantino paths (1e-9 mm), and so does the file pyg4ometry reads and
writes again."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from score4.cli.main import main
from score4.inputs.config import load_config
from score4.world.resolve import build_scene

from helpers.export_paths import assert_same_paths, three_paths

HERE = Path(__file__).parent
sys.path.insert(0, str(HERE))
from helpers import gdml_worlds as W  # noqa: E402


def test_rough_wall_exports_with_the_same_paths(tmp_path, monkeypatch):
    world = W.cached("pyg4", W.pyg4ometry_world)
    data = {
        "physics": "lite",
        "world": {"gdml": str(world)},
        "surfaces": {
            "coarse": {"kind": "spikes", "nx": 10, "ny": 10, "width": "100 um", "height": "20 um"}
        },
        "targets": [{"volume": "disk", "rough": [{"face": "outer", "surface": "coarse"}]}],
        "source": {
            "surface": {"volume": "disk", "face": "outer"},
            "particle": "alpha",
            "energy": "5 MeV",
        },
        "run": {"events": 10, "seed": 1},
    }
    cfg = tmp_path / "wall.yaml"
    cfg.write_text(yaml.safe_dump(data))
    out = tmp_path / "wall.gdml"
    assert main(["geometry", "export", str(cfg), "--gdml", str(out)]) == 0
    assert out.stat().st_size < 20e6
    target = build_scene(load_config(cfg)).target("disk")
    rng = np.random.default_rng(3)
    rays = []
    for _ in range(12):  # from 0.5 mm outside the wall, inwards, tilted
        phi, z = rng.uniform(0, 2 * np.pi), rng.uniform(-4, 4)
        radial = np.array([np.cos(phi), np.sin(phi), 0.0])
        start = target.to_world((15.5 * radial + [0, 0, z])[None, :])[0]
        tilt = target.rotation @ (-radial + [0, 0, rng.uniform(-0.3, 0.3)])
        rays.append((start.tolist(), (tilt / np.linalg.norm(tilt)).tolist()))
    ours, back, relay = three_paths(cfg, out, rays, monkeypatch)
    assert max(len(a) for a in ours) > 6  # the rays cross patches and spikes
    assert_same_paths(ours, back, relay)


pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")
