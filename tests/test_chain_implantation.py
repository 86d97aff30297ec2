"""Recoil implantation along decay chains: per-atom histories, daughters at the recoil stops.

The reference for where a daughter decays is lunasrim (a digit-exact SRIM-2013 TRIM), run here
with another seed than the run's trajectory libraries. Tolerances as for the heavy-ion replay
(tests/test_heavy_ions.py): mean within 10 %, spread within 30 % (the deep test: 5 % and 15 %
with more atoms and histories). Geant4 runs in spawned processes.
"""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest
import yaml

from score4.cli.main import main
from score4.decay.chain import ChainEvents, build_chain
from score4.errors import ConfigError
from score4.inputs.config import parse_config
from score4.runner.output import read_results
from score4.runner.seeds import atom_event_geant4_seeds
from score4.source.build import decay_normalisation, make_source
from score4.world.scene import build_scene

from conftest import config_dict
from helpers.spawn import run_in_spawned_process

PB214_RECOIL_KEV = 112.35  # Po-218 alpha decay (Q 6114.7 keV): the Pb-214 recoil
PB214_AMU = 213.9998


def _spawned(function, *args):
    return run_in_spawned_process(_call, function, *args)


def _call(function, *args):
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).parent))
    from helpers import g4_implantation

    return getattr(g4_implantation, function)(*args)


def chain_config(decay: dict, depth: dict | None = None, **sections) -> dict:
    data = config_dict(**sections)
    data["source"] = {"decay": decay, "surface": {"volume": "crystal", "face": "+z"}}
    if depth is not None:
        data["source"]["depth"] = depth
    return data


IMPLANT = {"chain": ["Po218", "Pb214"], "implantation": True}


# -- configuration -----------------------------------------------------------------------------


def _since(data):
    data["source"]["decay"]["since_deposition"] = "1 d"


def _geant4_ions(data):
    data["physics"] = {"mode": "lite", "heavy_ions": "geant4"}


def _low_trim_max(data):
    data["physics"] = {"mode": "lite", "trim_max_energy": "50 keV"}


def _portal(data):
    data["surfaces"] = {
        "pyr": {"kind": "spikes", "nx": 4, "ny": 4, "width": "10 um", "height": "10 um"}
    }
    data["targets"][0]["size"] = ["80 um", "80 um", "1 mm"]
    data["targets"][0]["rough"] = [{"face": "+z", "surface": "pyr", "tiling": "portal"}]


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (_since, "since_deposition: used only with implantation: false"),
        (_geant4_ions, "needs physics.heavy_ions: trim"),
        (_low_trim_max, "recoils reach 112.4 keV, above physics.trim_max_energy (50 keV)"),
        (_portal, "tiling: source.decay.implantation needs native tiling"),
    ],
)
def test_implantation_needs_whole_histories_and_the_trim_replay(change, message):
    data = chain_config(dict(IMPLANT))
    change(data)
    with pytest.raises(ConfigError) as err:
        parse_config(data)
    assert message in str(err.value)
    assert "\n" not in str(err.value)


def test_vertices_command_refuses_implantation(tmp_path):
    path = tmp_path / "c.yaml"
    path.write_text(yaml.safe_dump(chain_config(IMPLANT)))
    done = subprocess.run(
        [sys.executable, "-m", "score4.cli.main", "vertices", path, "--out", tmp_path / "v.h5"],
        capture_output=True,
        text=True,
    )
    assert done.returncode == 2
    assert done.stderr.startswith("score4: error: ")
    assert done.stderr.count("\n") == 1
    assert "cannot be drawn beforehand" in done.stderr


# -- histories and sampling (no Geant4) --------------------------------------------------------


def test_history_branches_agree_with_the_radiation_emitted():
    """Bi-212 decays by alpha (to Tl-208, with a Tl-208 recoil) or beta (to Po-212): the next
    decay of the atom is the nuclide the emitted radiation leads to."""
    rows = ChainEvents(build_chain("Pb212"), None, 0.0).histories(np.random.default_rng(2), 3000)
    bi212 = rows["nuclide"] == 832120
    atom, index = rows["atom"], rows["decay_index"]
    alpha = {
        (a, i)
        for a, i, k in zip(atom[bi212], index[bi212], rows["kind"][bi212], strict=True)
        if k == 0
    }
    recoil = rows["particle"][bi212 & (rows["kind"] == 1)]
    assert set(recoil) == {"Tl208"}
    nxt = {(a, i): z for a, i, z in zip(atom, index, rows["nuclide"], strict=True)}
    after = [
        (nxt[(a, i + 1)], (a, i) in alpha) for a, i in zip(atom[bi212], index[bi212], strict=True)
    ]
    assert all(z == (812080 if was_alpha else 842120) for z, was_alpha in after)
    decays = set(zip(atom[bi212], index[bi212], strict=True))
    share = len(alpha) / len(decays)
    assert share == pytest.approx(0.3594, abs=0.03)  # ENSDF: 35.94 % alpha


def test_atoms_are_the_unit_and_stay_whole_in_any_chunking():
    config = parse_config(chain_config(IMPLANT, run={"events": 2500, "seed": 4}))
    source = make_source(config, build_scene(config))
    assert source.unit == "atom"
    whole = source.events(4, 0, 2500)
    atom = whole.extra["atom"]
    assert np.array_equal(np.unique(atom), np.arange(2500))
    # chunks of atoms (across sampling blocks) are the same atoms with the same rows
    for first, n in ((0, 700), (998, 5), (1700, 800)):
        part = source.events(4, first, n)
        rows = (atom >= first) & (atom < first + n)
        assert np.array_equal(part.extra["atom"], atom[rows])
        assert np.array_equal(part.position, whole.position[rows])
        assert np.array_equal(part.energy, whole.energy[rows])
        event_atoms = part.extra["atom"][part.event_offsets()[:-1]]
        seeds = atom_event_geant4_seeds(4, event_atoms)
        whole_atoms = atom[whole.event_offsets()[:-1]]
        sel = (whole_atoms >= first) & (whole_atoms < first + n)
        assert np.array_equal(seeds, atom_event_geant4_seeds(4, whole_atoms)[sel])
    # the events of one atom have distinct seeds; the normalisation counts head atoms
    seeds = atom_event_geant4_seeds(4, atom[whole.event_offsets()[:-1]])
    assert len(np.unique(seeds)) == len(seeds)
    norm = decay_normalisation(config)
    assert norm["simulated_decays"] == 2500
    assert norm["decay_chain"]["implantation"] is True


def test_depth_below_a_pyramid_face_is_the_distance_to_it():
    """A point moved under a rough face gets its true distance to the mesh: below a pyramid
    facet it is the distance to the facet's plane, also in a neighbouring cell."""
    data = chain_config(IMPLANT, {"profile": "uniform", "min": "0.5 um", "max": "0.6 um"})
    data["surfaces"] = {
        "pyr": {"kind": "spikes", "nx": 4, "ny": 4, "width": "10 um", "height": "10 um"}
    }
    data["targets"][0]["size"] = ["80 um", "80 um", "1 mm"]
    data["targets"][0]["rough"] = [{"face": "+z", "surface": "pyr"}]
    config = parse_config(data)
    sampler = make_source(config, build_scene(config)).sampler
    v = sampler.sample(np.random.default_rng(1), 400)
    # move each vertex 0.2 um along the facet plane (stays under the same facet if far from
    # the edges) and 0.1 um deeper: its depth grows by 0.1 um
    t = np.cross(v.normal, [0.0, 0.0, 1.0])
    t /= np.linalg.norm(t, axis=1)[:, None]
    moved = v.position + 2e-4 * t - 1e-4 * v.normal
    depth = sampler.depth_of(moved, v.position, v.normal, v.depth)
    far = np.abs(depth - (v.depth + 1e-4)) < 1e-9
    assert far.mean() > 0.7  # the rest moved closer to another facet (near an edge)
    assert (depth[~far] < v.depth[~far] + 1e-4).all()


# -- Geant4 runs ---------------------------------------------------------------------------


def trim_distances(tmp, ions: int, seed: int) -> np.ndarray:
    """3D distances (nm) from start to stop of 112 keV Pb-214 in Si (lunasrim, normal
    incidence into 2 um of silicon)."""
    lunasrim = pytest.importorskip("lunasrim")
    res = lunasrim.trim(
        "Pb",
        {"Si": 1},
        energy=PB214_RECOIL_KEV,
        thickness=2000,
        unit="nm",
        ions=ions,
        seed=seed,
        density=2.33,
        mass=PB214_AMU,
        directory=str(tmp),
    )
    x, y, z = (np.asarray(c, float) for c in res.range3d.positions)
    return np.sqrt(x**2 + y**2 + z**2) / 10.0


def deep_deposit(atoms: int, histories: int) -> dict:
    """Po-218 atoms 1 um under a flat Si face: the Pb-214 recoil cannot leave."""
    data = chain_config(
        IMPLANT,
        {"profile": "uniform", "min": "1 um", "max": "1.0001 um"},
        physics={"mode": "lite", "trim_histories": histories},
        run={"events": atoms, "seed": 7},
    )
    return _spawned("implant_chunk", data, atoms, 7)


def check_daughters_at_recoil_stops(out: dict, tmp, ions: int, rel_mean: float, rel_std: float):
    ex = out["extra"]
    first = np.r_[0, np.flatnonzero(np.diff(out["event"])) + 1]
    atom, index = ex["atom"][first], ex["decay_index"][first]
    nuclide, vertex = ex["nuclide"][first], ex["vertex"][first]
    pos, depth = out["position"][first], ex["depth"][first]
    head = (index == 0) & (nuclide == 842180)
    daughter = (index == 1) & (nuclide == 822140)
    assert (vertex[head] == 0).all()
    assert (vertex[daughter] == 1).all()
    both = np.intersect1d(atom[head], atom[daughter])
    assert len(both) >= 0.99 * head.sum()  # At-218 (0.02 %) is the other branch
    h = np.searchsorted(atom[head], both)
    d = np.searchsorted(atom[daughter], both)
    move = pos[daughter][d] - pos[head][h]
    r = np.linalg.norm(move, axis=1) * 1e6  # nm
    ref = trim_distances(tmp, ions, 4243)
    assert r.mean() == pytest.approx(ref.mean(), rel=rel_mean)
    assert r.std() == pytest.approx(ref.std(), rel=rel_std)
    # isotropic recoils: the depth changes by the displacement along the face normal (+z out)
    dz = (depth[daughter][d] - depth[head][h]) * 1e6
    assert np.allclose(dz, -move[:, 2] * 1e6, atol=1e-6)
    rms = np.sqrt(np.mean(ref**2) / 3)
    assert abs(dz.mean()) < 4 * rms / np.sqrt(len(dz))
    assert dz.std() == pytest.approx(rms, rel=rel_std)
    counts = out["counts"]["implantation"]
    assert counts["recoils"] == len(both)
    assert counts["deeper"] + counts["shallower"] == len(both)
    assert counts["left_world"] == counts["lost_decays"] == 0
    assert counts["deeper"] == int((dz > 0).sum())
    # no event deposits more than it emitted
    emitted = np.bincount(out["event"], out["energy"], minlength=len(out["edep"]))
    assert (out["edep"].sum(axis=1) <= emitted + 1e-9).all()


def test_daughters_decay_where_the_recoils_stopped_like_trim(tmp_path):
    out = deep_deposit(300, 300)
    check_daughters_at_recoil_stops(out, tmp_path, 300, 0.10, 0.30)


@pytest.mark.deep
def test_daughters_decay_where_the_recoils_stopped_like_trim_deep(tmp_path):
    out = deep_deposit(5000, 2000)
    check_daughters_at_recoil_stops(out, tmp_path, 2000, 0.05, 0.15)


FACING = {
    "physics": {"mode": "lite", "trim_histories": 200},
    "targets": [
        {
            "name": "bottom",
            "material": "G4_Si",
            "size": ["10 mm", "10 mm", "1 mm"],
            "position": ["0 mm", "0 mm", "-0.5 mm"],
        },
        {
            "name": "top",
            "material": "G4_Si",
            "size": ["10 mm", "10 mm", "1 mm"],
            "position": ["0 mm", "0 mm", "0.505 mm"],  # 5 um above the bottom box
        },
    ],
    "source": {
        "surface": {"volume": "bottom", "face": "+z"},
        "decay": {"chain": "Po218", "until": "Pb210", "implantation": True},
        "depth": {"profile": "zero"},
    },
}


def run_cli(tmp_path, name: str, jobs: int, chunk: int, atoms: int):
    data = {**FACING, "run": {"events": atoms, "seed": 11, "chunk_events": chunk}}
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump(data))
    out = tmp_path / f"{name}.h5"
    done = subprocess.run(
        [sys.executable, "-m", "score4.cli.main", "run", path, "--out", out, "--jobs", str(jobs)],
        capture_output=True,
        text=True,
    )
    assert done.returncode == 0, done.stderr
    return read_results(out)


def test_recoils_across_a_gap_decay_in_the_opposite_face(tmp_path, capsys):
    """Po-218 on the surface of the bottom box, a second box 5 um above: a Pb-214 recoil sent
    outward crosses the gap and stops in the top box, where Pb-214, Bi-214 and Po-214 decay.
    The same run in 4 chunks on 2 jobs gives the same results (one test: the two runs are
    made once)."""
    r = run_cli(tmp_path, "one", 1, 10_000, 150)
    p, ex = r.primaries, r.primaries.extra
    first = p.event_offsets()[:-1]
    vertex, z = ex["vertex"][first], p.position[first, 2]
    moved = vertex == 2
    # in the top box, within TRIM's reach of its face (z = 5 um)
    assert (z[moved] > 0.005).all()
    assert (z[moved] < 0.005 + 200e-6).all()
    assert np.isnan(ex["depth"][first][moved]).all()
    assert (z[vertex == 1] < 0).all()  # implanted into the bottom box
    counts = r.run["implantation"]
    head = ex["decay_index"][first] == 0
    # every Po-218 recoil goes on to a decay; outward ones (half) meet the top box
    assert counts["recoils"] == head.sum() + counts["not_replayed"]
    assert counts["other_volume"] / counts["recoils"] == pytest.approx(0.5, abs=0.12)
    assert counts["stopped_in"]["top"] >= counts["other_volume"]
    assert counts["left_world"] <= 0.05 * counts["recoils"]
    # the decays of atoms that left the world are not in the results, and are counted
    assert not (ex["vertex"] == 3).any()
    assert counts["lost_decays"] >= counts["left_world"]
    assert r.run["n_atoms"] == 150
    assert r.run["n_events"] == len(r.event_id)
    assert np.array_equal(r.event_id, np.arange(len(r.event_id)))
    assert r.run["energy_violations"] == 0
    assert r.run["intercepted_ions"] == 0  # alphas and electrons knock on no heavy ions here
    check_template_counts_per_head_decay(r, tmp_path, capsys)
    assert main(["summary", str(tmp_path / "one.h5")]) == 0
    atoms = next(ln for ln in capsys.readouterr().out.splitlines() if "atoms " in ln)
    assert f"{counts['left_world']} left the world" in atoms
    assert "150 deposited Po218 atoms" in atoms
    # the JSON summary carries the same atoms line
    assert main(["summary", str(tmp_path / "one.h5"), "--json"]) == 0
    js = json.loads(capsys.readouterr().out)["atoms"]
    assert js["n_atoms"] == 150
    assert js["nuclide"] == "Po218"
    assert js["left_world"] == counts["left_world"]
    assert js["recoils"] == counts["recoils"]
    assert js["lost_decays"] == counts["lost_decays"]
    assert js["simulated_decays"] == 150
    check_same_in_any_chunking(r, run_cli(tmp_path, "two", 2, 40, 150))


def check_template_counts_per_head_decay(r, tmp_path, capsys) -> None:
    """The unit of the run is a deposited Po-218 atom, i.e. one Po-218 decay: a template for a
    quoted Po-218 activity counts every event of the chain's decays over the atoms."""
    assert r.run["simulated_decays"] == 150
    assert r.run["activity_nuclide"] == "Po218"
    out = tmp_path / "t.h5"
    args = ["template", str(tmp_path / "one.h5"), "--activity", "1 mBq/cm2"]
    assert main([*args, "--emax", "20 MeV", "--out", str(out), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    for name, det in report["detectors"].items():
        hits = np.count_nonzero(r.edep[name])  # Po-214 alphas (7.7 MeV) are below 20 MeV
        per_kg_day = hits / 150 * 1e-5 * 100.0 * 86400 / det["mass_kg"]  # 1 cm2 face
        assert det["counts_per_kg_day"] == pytest.approx(per_kg_day, rel=1e-12)


def check_same_in_any_chunking(one, two) -> None:
    assert two.run["n_chunks"] == 4
    assert two.run["jobs"] == 2
    assert np.array_equal(one.event_id, two.event_id)
    for name in one.edep:
        assert np.array_equal(one.edep[name], two.edep[name])
    assert np.array_equal(one.primaries.position, two.primaries.position)
    assert np.array_equal(one.primaries.event, two.primaries.event)
    assert np.array_equal(one.columns["atom"], two.columns["atom"])
    assert one.run["implantation"] == two.run["implantation"]
