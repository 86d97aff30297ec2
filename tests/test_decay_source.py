"""``source.decay`` in configurations, vertex files, runs and the ``score4 decay`` command."""

from __future__ import annotations

import json
import subprocess
import sys

import h5py
import numpy as np
import pytest
import yaml

from score4.errors import ConfigError
from score4.inputs.config import parse_config
from score4.runner.output import read_results
from score4.source.build import decay_emitter, decay_normalisation
from score4.source.emitters import make_primaries

from conftest import config_dict


def run_cli(*args, cwd=None):
    return subprocess.run(
        [sys.executable, "-m", "score4.cli.main", *map(str, args)],
        capture_output=True,
        text=True,
        cwd=cwd,
    )


def decay_config(decay, **run):
    data = config_dict(run={"events": 50, "seed": 3, **run})
    data["source"] = {"decay": decay, "surface": {"volume": "crystal", "face": "+z"}}
    return data


@pytest.mark.parametrize("name", ["Pb210", "Pb-210", "pb210", "210Pb", "210-Pb"])
def test_nuclide_names_are_normalised(name):
    assert parse_config(decay_config(name)).source.decay == "Pb210"


@pytest.mark.parametrize(
    ("decay", "message"),
    [
        ("Pb-21O", "cannot read nuclide 'Pb-21O'"),
        ("Xy210", "unknown element symbol 'Xy'; closest known"),
        ("Pb206", "no decay data for Pb206"),
        ("Am241", "no decay data for Am241"),
        ({"chain": "Pb210", "until": "Pb207"}, "Pb207 is not in the chain of Pb210"),
        ({"chain": "Pb210", "since_deposition": "-5 d"}, "must be 0 or more, got '-5 d'"),
        ({"chain": "Pb210", "since_deposition": "5 keV"}, "unknown time unit 'keV'"),
        ({"chain": "Pb210", "since_deposition": 5}, "5 has no unit"),
        ({"chain": "Pb210", "coincidence_window": "-1 us"}, "must be 0 or more"),
        (
            {"chain": "Pb210", "equilibrium": "secular", "since_deposition": "1 d"},
            "not both",
        ),
        ({"chain": ["Pb210", "Po214"]}, "Po214 is not a daughter of an earlier member"),
        ({"chain": ["Pb210"], "until": "Po210"}, "only with a chain head"),
    ],
)
def test_bad_decay_sources_are_one_line_errors(decay, message):
    with pytest.raises(ConfigError, match=message) as err:
        parse_config(decay_config(decay))
    assert "\n" not in str(err.value)


def test_bad_decay_in_the_cli_exits_2_with_one_line(tmp_path):
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(decay_config({"chain": "U238", "until": "Pb208"})))
    done = run_cli("vertices", path, "--out", tmp_path / "v.h5")
    assert done.returncode == 2
    assert done.stderr.count("\n") == 1
    assert "Pb208 is not in the chain of U238" in done.stderr
    assert not (tmp_path / "v.h5").exists()


def test_po210_decay_keeps_the_two_body_primaries():
    config = parse_config(decay_config("Po210"))
    rng = np.random.default_rng(1)
    normals = np.tile([0.0, 0.0, 1.0], (2000, 1))
    prim = make_primaries(decay_emitter(config.source), rng, np.zeros((2000, 3)), normals)
    alpha = prim.particle == "alpha"
    recoil = prim.particle == "Pb206"
    assert alpha.sum() == recoil.sum() == 2000  # the 803 keV branch (1e-5) did not come up
    assert np.allclose(prim.energy[alpha], 5.30431, atol=5e-5)
    assert np.allclose(prim.energy[recoil], 0.103144, atol=2e-6)
    assert np.allclose(prim.direction[recoil], -prim.direction[alpha])
    assert (prim.extra["nuclide"] == 842100).all()


def test_decay_vertices_carry_nuclide_and_time(tmp_path):
    path = tmp_path / "chain.yaml"
    decay = {"chain": ["Bi212", "Po212"], "coincidence_window": "10 us"}
    path.write_text(yaml.safe_dump(decay_config(decay, events=400)))
    done = run_cli("vertices", path, "--out", tmp_path / "v.h5")
    assert done.returncode == 0, done.stderr
    with h5py.File(tmp_path / "v.h5") as f:
        nuclide = f["vertices/nuclide"][()]
        time = f["vertices/time"][()]
        event = f["vertices/event"][()]
    assert set(np.unique(nuclide)) <= {832120, 842120}
    assert event.max() == 399
    # Po-212 decays ride in Bi-212 events, 0.3 us later
    assert (time[nuclide == 842120] > 0).all()
    assert (time[nuclide == 832120] == 0).all()


def test_chain_normalisation():
    config = parse_config(decay_config({"chain": "Pb210", "since_deposition": "180 d"}))
    norm = decay_normalisation(config)
    chain = norm["decay_chain"]
    assert norm["activity_nuclide"] == "Pb210"
    assert chain["members"] == ["Pb210", "Bi210", "Po210"]
    # one event per decay: the head's share of all decays
    share = chain["relative_activity"][0] / sum(chain["relative_activity"])
    assert norm["simulated_decays"] == pytest.approx(50 * share)
    assert decay_normalisation(parse_config(decay_config("Bi210")))["simulated_decays"] == 50


@pytest.mark.slow
def test_lite_run_of_pb210_from_the_cli(tmp_path):
    path = tmp_path / "pb210.yaml"
    path.write_text(yaml.safe_dump(decay_config("Pb-210", events=200)))
    done = run_cli("run", path, "--out", tmp_path / "r.h5")
    assert done.returncode == 0, done.stderr
    run = read_results(tmp_path / "r.h5").run
    assert run["activity_nuclide"] == "Pb210"
    assert run["simulated_decays"] == 200
    assert "gammas and X-rays are not tracked" in run["physics_lacks"]
    with h5py.File(tmp_path / "r.h5") as f:
        particle = np.char.decode(f["primaries/particle"][()])
        event = f["primaries/event"][()] - f["events/event_id"][0]
        energy = f["primaries/energy"][()]
        edep = f["events/edep/crystal"][()]
        untracked = f["events/untracked_gamma_energy"][()]
    assert {"e-", "gamma"} <= set(particle)
    # lite mode counts the photons (46.5 keV gamma, X-rays) it cannot track, per event
    photons = particle == "gamma"
    assert np.allclose(untracked, np.bincount(event[photons], energy[photons], minlength=200))
    assert len(edep) == 200
    assert edep.max() <= 0.0635 + 1e-9  # nothing above Q = 63.5 keV


def test_decay_command_table_json_and_png(tmp_path):
    done = run_cli("decay", "Pb-210")
    assert done.returncode == 0, done.stderr
    assert "46.539" in done.stdout
    assert "Pb210  half-life 22.2 y" in done.stdout
    done = run_cli("decay", "Rn222", "--chain", "--until", "Pb210", "--json")
    table = json.loads(done.stdout)
    assert [e["nuclide"] for e in table["nuclides"]][:3] == ["Rn222", "Po218", "Pb214"]
    # per nuclide: the transitions whose intensity comes from level feeding (Pb-214: the
    # 9.5 keV line, which ENSDF gives no intensity), per mode the Q and its source
    pb214 = table["nuclides"][2]
    assert pb214["modes"][0]["q_source"] == "AME2020"
    assert any(abs(f["energy_keV"] - 9.5) < 0.01 for f in pb214["lines_from_level_feeding"])
    # Rn-222: its 676 keV level (0.0005 %) has no transition in the data set
    assert [f["energy_keV"] for f in table["nuclides"][0]["lines_from_level_feeding"]] == [676.0]
    png = tmp_path / "bi212.png"
    done = run_cli("decay", "Bi212", "--png", png)
    assert done.returncode == 0
    assert png.stat().st_size > 10_000
    done = run_cli("decay", "Bi212", "--png", png)
    assert done.returncode == 2
    assert "--overwrite" in done.stderr


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["Pb206"], "no decay data for Pb206"),
        (["Pb210", "--chain", "--until", "Tl208"], "Tl208 is not in the chain of Pb210"),
        (["Pb210", "--chain", "--since-deposition", "-2 d"], "must be 0 or more"),
        (["Pb210", "--chain", "--since-deposition", "2 MeV"], "unknown time unit"),
        (["Pb210", "--until", "Po210"], "need --chain"),
        (["U238", "--chain", "--until", "U238"], "decay.until: U238 is the chain's head"),
        (["U238", "--chain", "--until", "Xx12"], "unknown element symbol 'Xx'"),
        (["Foo", "--chain"], "decay.chain: cannot read nuclide 'Foo'"),
    ],
)
def test_decay_command_bad_input(args, message):
    done = run_cli("decay", *args)
    assert done.returncode == 2
    assert done.stderr.count("\n") == 1
    assert message in done.stderr
