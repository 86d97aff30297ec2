"""The run plan (score4.runner.run_plan) and the run record (score4.runner.run_record),
without Geant4 runs: a plan is made once, pickles small, and rebuilds to the same scene and
events."""

from __future__ import annotations

import copy
import json
import pickle
import re
import subprocess
import sys
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from score4.errors import ConfigError, Score4Warning
from score4.inputs.config import parse_config
from score4.runner import run_plan
from score4.runner.run_plan import RunPlan, config_fingerprint, plan_run
from score4.runner.run_record import RunRecord
from score4.sim.runtime import resolve_physics

from conftest import config_dict

ROUGH = config_dict(
    surfaces={
        "pyramids": {"kind": "spikes", "nx": 5, "ny": 5, "width": "10 um", "height": "10 um"}
    },
    targets=[
        {
            "name": "crystal",
            "material": "G4_Si",
            "size": ["2 mm", "2 mm", "1 mm"],
            "position": ["0 mm", "0 mm", "-0.5 mm"],
            "rough": [{"face": "+z", "surface": "pyramids"}],
        }
    ],
    source={
        "particle": "alpha",
        "energy": "5.3 MeV",
        "direction": "isotropic",
        "surface": {"volume": "crystal", "face": "+z"},
        "depth": {"profile": "exponential", "mean": "20 nm"},
    },
    run={"events": 200, "seed": 5},
)

# One silicon box in a vacuum world, as a user's GDML file (NIST materials by name).
GDML = """<?xml version="1.0" encoding="UTF-8"?>
<gdml>
 <define/>
 <materials/>
 <solids>
  <box name="world_s" x="100" y="100" z="100" lunit="mm"/>
  <box name="crystal_s" x="10" y="10" z="4" lunit="mm"/>
 </solids>
 <structure>
  <volume name="Crystal">
   <materialref ref="G4_Si"/>
   <solidref ref="crystal_s"/>
  </volume>
  <volume name="World">
   <materialref ref="G4_Galactic"/>
   <solidref ref="world_s"/>
   <physvol name="crystal">
    <volumeref ref="Crystal"/>
   </physvol>
  </volume>
 </structure>
 <setup name="Default" version="1.0">
  <world ref="World"/>
 </setup>
</gdml>
"""


def _same_events(a: RunPlan, b: RunPlan, n: int = 300) -> None:
    assert a.source is not None
    assert b.source is not None
    pa, pb = a.source.events(a.seed, 0, n), b.source.events(b.seed, 0, n)
    assert np.array_equal(pa.position, pb.position)
    assert np.array_equal(pa.direction, pb.direction)
    assert np.array_equal(pa.energy, pb.energy)


def _rebuilt(plan: RunPlan) -> tuple[RunPlan, int]:
    """The plan as a worker gets it (pickled, unpickled afresh) and the pickle's size."""
    blob = pickle.dumps(plan)
    run_plan._REBUILT.clear()  # as in a new process
    return pickle.loads(blob), len(blob)


def test_equal_configs_give_equal_plans_and_other_seeds_do_not():
    a, b = plan_run(parse_config(ROUGH)), plan_run(parse_config(ROUGH))
    assert a == b
    assert hash(a) == hash(b)
    assert a.fingerprint == config_fingerprint(a.config, 5)
    _same_events(a, b)
    other = plan_run(parse_config(config_dict(**{**ROUGH, "run": {"events": 200, "seed": 6}})))
    assert other != a
    assert other.fingerprint != a.fingerprint
    assert plan_run(parse_config(ROUGH), seed=6) != a  # a seed override is part of the plan


def test_a_plan_pickles_as_its_recipe_and_rebuilds_the_same_scene_and_events():
    plan = plan_run(parse_config(ROUGH))
    back, size = _rebuilt(plan)
    assert back == plan
    assert back is not plan
    assert size < 20_000  # the recipe; the resolved scene of a 10 cm face is MBs
    assert back.scene.columns == plan.scene.columns
    (layer,) = back.scene.layers
    assert np.array_equal(layer.patch_map.variants, plan.scene.layers[0].patch_map.variants)
    _same_events(back, plan)
    # unpickled again in the same process (a Dask worker gets the plan with every task): the
    # plan rebuilt before, not a new one
    assert pickle.loads(pickle.dumps(plan)) is back


def test_a_worker_rebuilds_a_gdml_plan_without_reading_the_gdml_file(tmp_path: Path):
    gdml = tmp_path / "world.gdml"
    gdml.write_text(GDML)
    config = parse_config(
        config_dict(
            world={"gdml": str(gdml)},
            targets=[{"volume": "crystal"}],
            source={
                "particle": "alpha",
                "energy": "5.3 MeV",
                "surface": {"volume": "crystal", "face": "+z"},
            },
        )
    )
    plan = plan_run(config)
    assert plan.model is not None
    assert plan.gdml_key is not None
    assert plan.fingerprint == config_fingerprint(config, config.run.seed)
    gdml.unlink()  # the worker has neither the file nor the configuration's folder
    back, _ = _rebuilt(plan)
    assert back == plan
    assert back.model is not None
    assert back.scene.columns == plan.scene.columns == ["crystal"]
    _same_events(back, plan)


def test_a_plan_of_the_world_alone_has_no_source():
    plan = plan_run(parse_config(ROUGH), physics=resolve_physics("lite"), source=False)
    assert plan.source is None
    back, _ = _rebuilt(plan)
    assert back.source is None
    assert back == plan


def test_bad_input_fails_when_planning():
    bad = config_dict(
        **{**ROUGH, "source": {**ROUGH["source"], "surface": {"volume": "crystal", "face": "top"}}}
    )
    with pytest.raises(ConfigError, match="face"):
        plan_run(parse_config(bad))


def test_the_run_record_writes_optional_fields_only_when_set():
    record = RunRecord(
        config={"run": {"events": 10}},
        patch_maps={},
        seed=1,
        physics_mode="lite",
        physics_requested="auto",
        physics_lacks="no decay",
        missing_data_sets=["G4EMLOW"],
        removed_processes=[],
        rough_shares={},
        gdml_files=[],
        score4_version="0",
        geant4_pybind_version="0",
        geant4_version="11",
        n_events=10,
        n_chunks=1,
        chunk_events=10,
        jobs=1,
        backend="local processes (1)",
        resumed_chunks=0,
        wall_time_s=1.0,
        created_utc="2026-01-01T00:00:00+00:00",
        host="h",
        geant4_warnings=[],
        stuck_tracks_pushed=0,
        stuck_events_aborted=0,
        energy_check="skipped",
        normalisation={"volumes": [], "normalisation_version": 1},
    )
    data = record.to_dict()
    assert "n_atoms" not in data
    assert "trim_library_seed" not in data
    assert "normalisation" not in data
    assert data["volumes"] == []
    assert list(data)[:3] == ["config", "patch_maps", "seed"]
    assert list(data)[-2:] == ["volumes", "normalisation_version"]
    assert RunRecord.from_dict(data) == record
    atoms = replace(record, n_atoms=5, trim_library_seed=7)
    data = atoms.to_dict()
    assert list(data).index("n_atoms") == list(data).index("n_events") - 1
    assert RunRecord.from_dict(data) == atoms


def test_every_run_record_field_is_documented_with_the_results_file():
    from dataclasses import fields

    from conftest import ROOT

    text = (ROOT / "docs" / "getting-started.md").read_text()
    table = text[text.index("| entry | what it holds |") :].split("\n\n")[0]
    named = set(re.findall(r"`(\w+)`", "\n".join(r.split("|")[1] for r in table.splitlines())))
    assert named >= {f.name for f in fields(RunRecord)} - {"normalisation"}
    assert named - {f.name for f in fields(RunRecord)} == {
        "volumes",
        "source",
        "simulated_decays",
        "activity_nuclide",
        "decay_chain",
        "normalisation_version",
    }


def test_a_worker_rebuilds_silently_what_warned_in_the_parent():
    data = copy.deepcopy(ROUGH)
    data["targets"][0]["rough"] = [
        {"variants": [{"surface": "pyramids", "density": 1}, {"surface": "pyramids", "density": 1}]}
    ]
    with pytest.warns(Score4Warning, match="densities"):
        plan = plan_run(parse_config(data))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        back, _ = _rebuilt(plan)
    assert back == plan


def test_a_worker_rebuilds_a_plan_without_yaml_tqdm_or_building_validators(tmp_path: Path):
    """A worker unpickles validated models and rebuilds the scene and source from them: it
    needs no YAML parser, no progress bar and none of the configuration models' validators
    (pydantic builds them on first validation, ``defer_build``; building one loads pydantic's
    plugin loader). Checked in a fresh interpreter, as a spawned worker starts."""
    data = copy.deepcopy(ROUGH)
    data["targets"][0]["rough"][0]["native_layout"] = "placements"
    blob = tmp_path / "plan.pkl"
    blob.write_bytes(pickle.dumps(plan_run(parse_config(data))))
    code = (
        "import json, pickle, sys; "
        f"plan = pickle.loads(open({str(blob)!r}, 'rb').read()); "
        "n = len(plan.source.events(plan.seed, 0, 5).energy); "
        "import score4.sim.worker, score4.sim.simulation; "
        "print(json.dumps({'events': n, 'loaded': sorted(m for m in sys.modules "
        "if m in ('yaml', 'tqdm', 'pydantic.plugin._loader', 'geant4_pybind'))}))"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], check=False, capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 0, done.stderr[-2000:]
    assert json.loads(done.stdout.strip().splitlines()[-1]) == {"events": 5, "loaded": []}
