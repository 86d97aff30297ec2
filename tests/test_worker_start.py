"""What a worker process imports before its first event (issue 25, start-up).

A local worker receives the run plan resolved, with the configuration's pydantic models as
plain records (:func:`score4.runner.run_plan.worker_pickle`), so it never imports pydantic or the
configuration's models; the ``score4`` command's workers do not import the command line either.
Timing is in ``benchmarks/bench_runloop.py --parts startup``; these tests check what is imported.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import h5py
import pytest

from score4.inputs.config import load_config
from score4.runner.run_plan import plan_run, worker_pickle
from score4.sim.worker import WorkerSpec, chunk_path

from helpers.spawn import run_in_spawned_process
from helpers.worker_modules import run_worker

ROOT = Path(__file__).resolve().parent.parent
#: Modules of the parent's side that a worker has no use for: the configuration's models and
#: their validation library, the surface descriptions' models, the command line; and scipy's
#: k-d trees, which this run (no distances measured) does not build.
NOT_IN_A_WORKER = (
    "pydantic",
    "pydantic_core",
    "score4.common.schema",
    "score4.inputs.config",
    "score4.inputs.material_spec",
    "score4.surface.spec",
    "score4.world.resolve",
    "score4.cli",
    "click",
    "scipy.spatial",
)


def _config(events: int):
    config = load_config(ROOT / "examples" / "paper_a_rough.yaml")
    return config.model_copy(update={"run": config.run.model_copy(update={"events": events})})


def test_a_worker_runs_its_chunk_without_pydantic_or_the_configuration_models(tmp_path):
    plan = plan_run(_config(5))
    blob = worker_pickle(WorkerSpec(plan, tmp_path))
    modules, messages = run_in_spawned_process(run_worker, blob, 5, timeout=300)
    assert messages[0] == ("ready",), messages
    assert messages[-1] == ("done", 0), messages
    assert "geant4_pybind" in modules  # it did build Geant4 and track
    assert [m for m in NOT_IN_A_WORKER if m in modules] == []
    with h5py.File(chunk_path(tmp_path, 0)) as f:
        assert f["events/event_id"][:].tolist() == [0, 1, 2, 3, 4]


def test_the_worker_plan_is_the_parents_resolved_plan_with_records_of_the_models(tmp_path):
    import pickle

    from score4.common.records import Record

    plan = plan_run(_config(5))
    spec = pickle.loads(worker_pickle(WorkerSpec(plan, tmp_path)))
    worker = spec.plan
    assert isinstance(worker.config, Record)
    assert worker.config.kind == "RunConfig"
    assert worker.config.physics.production_cut == plan.config.physics.production_cut
    assert worker.per_atom is plan.per_atom  # a property of a model, kept as a value
    layer, parent_layer = worker.scene.layers[0], plan.scene.layers[0]
    assert layer.config.face_name == parent_layer.config.face_name == "+z"
    assert layer.name == parent_layer.name
    assert (layer.patch_map.variants == parent_layer.patch_map.variants).all()
    # the same source: the same first events, bit for bit
    a, b = worker.source.events(plan.seed, 0, 50), plan.source.events(plan.seed, 0, 50)
    assert (a.position == b.position).all()
    assert (a.direction == b.direction).all()
    with pytest.raises(AttributeError, match="read-only"):
        worker.config.seed = 3


@pytest.mark.skipif(
    not (Path(sys.executable).parent / "score4").exists(), reason="needs the score4 script"
)
def test_the_score4_command_starts_workers_that_do_not_import_the_command_line(tmp_path):
    # CPython's -X importtime lists each module once per process that imports it: the parent
    # imports the command line and pydantic, its one worker Geant4 and neither of those
    env = dict(os.environ, PYTHONPROFILEIMPORTTIME="1")
    config = ROOT / "examples" / "flat_alpha.yaml"
    out = tmp_path / "a.h5"
    script = Path(sys.executable).parent / "score4"
    done = subprocess.run(
        [str(script), "-q", "run", str(config), "--events", "2", "--out", str(out)],
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    imported = [
        line.rsplit("|", 1)[1].strip()
        for line in done.stderr.splitlines()
        if line.startswith("import time:") and "|" in line
    ]
    assert imported.count("geant4_pybind") == 1  # the worker
    assert imported.count("score4.cli.main") == 1  # the parent only
    assert imported.count("pydantic") == 1
    assert imported.count("score4.inputs.config") == 1
