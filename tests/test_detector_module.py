"""examples/detector_module (issue 17 item 8): the module's GDML written by pyg4ometry, the
configs on it (a source on the walls of a boolean frame's window, a rough crystal face in the
gap, eight clamp columns), the clearance against the frame's true shape, and a small run."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from score4.cli.main import main
from score4.errors import ConfigError
from score4.inputs.config import load_config
from score4.runner.output import read_results
from score4.source.build import make_source, source_geometry
from score4.world.resolve import build_scene

# Its module fixture runs once, on one pytest-xdist worker (not once per worker).
pytestmark = pytest.mark.xdist_group("detector-module")

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "detector_module"
pytest.importorskip("pyg4ometry")


@pytest.fixture(scope="module")
def module(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("module")
    subprocess.run(
        [sys.executable, str(EXAMPLE / "write_module.py"), str(folder / "module.gdml")],
        check=True,
        capture_output=True,
    )
    for name in ("po210_1um.yaml", "po210_20nm.yaml"):
        shutil.copy(EXAMPLE / name, folder / name)
    return folder


def test_configs_on_the_module(module):
    config = load_config(module / "po210_1um.yaml")
    scene = build_scene(config)
    assert scene.columns == ["crystal", "frame", *(f"clamp_{k}" for k in range(8)), "housing"]
    (layer,) = scene.layers
    assert layer.patch_map.variants.size == 300 * 200  # 30 x 20 mm face, 0.1 mm patches
    where = source_geometry(config, scene)
    # the window's walls: 4 x 34 mm x 20 mm (a Monte Carlo estimate of the boolean's faces)
    assert where["area_mm2"] == pytest.approx(4 * 34 * 20, rel=2e-3)
    p = make_source(config, scene).primaries(np.random.default_rng(2), 0, 2000)
    x, y, z = np.abs(p.position[::2].T)
    depth = p.extra["depth"][::2]
    # every vertex lies its depth behind a wall of the window (at |x| or |y| = 17 mm)
    behind = np.minimum(np.where(x >= 17, x - 17, np.inf), np.where(y >= 17, y - 17, np.inf))
    np.testing.assert_allclose(behind, depth, atol=1e-9)
    assert (z <= 10).all()
    assert depth.mean() == pytest.approx(1e-3, rel=0.1)  # exponential, mean 1 um


def test_a_layer_too_thick_for_the_gap_names_the_frame(module):
    text = (module / "po210_1um.yaml").read_text().replace("height: 10 um", "height: 2.5 mm")
    (module / "tall.yaml").write_text(text.replace("width: 10 um", "width: 100 um"))
    with pytest.raises(
        ConfigError, match=r"runs into sister volume 'frame' \(free gap there: 2000 um\)"
    ):
        build_scene(load_config(module / "tall.yaml"))


def test_a_small_run_of_the_module(module, tmp_path):
    out = tmp_path / "m.h5"
    cfg = module / "po210_20nm.yaml"
    assert main(["run", str(cfg), "--events", "300", "--out", str(out), "-q"]) == 0
    res = read_results(out)
    total = sum(res.edep.values())
    assert total.max() <= 5.4075 + 1e-3  # Po-210's Q value
    assert (res.edep["frame"] > 0).all()  # the recoil or the alpha starts in the copper
    crystal = res.edep["crystal"]
    # about a third of the alphas cross the 2 mm gap: most arrive nearly whole from 20 nm
    assert 0.2 < np.mean(crystal > 0.05) < 0.5
    assert np.mean(crystal[crystal > 4] > 5.0) > 0.9
