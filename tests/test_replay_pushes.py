"""Stuck recoils of the TRIM replay are counted (``HeavyIonTransport.pushes``, ``replay_pushes``).

Among the tessellated blocks of the shipped measured map (docs/howto-measured-surface.md's run)
the replay's navigator sometimes takes zero steps: the Pb-206 recoil of event 528 (seed 1) sits
on the wall between two blocks where one of them also says it leaves through its top facet, so
it bounces between the block and the cell until G4Navigator pushes it 1e-7 mm after ten zero
steps. The count is what the run record reports; a fresh locate of the point, or one a little
ahead of it, lands in the same two volumes, so the push is not avoided (session 9).
Geant4 runs in a spawned process.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from helpers.spawn import run_in_spawned_process

pytest.importorskip("lunasrim")
pytestmark = pytest.mark.xdist_group("heavy-ions")

ROOT = Path(__file__).resolve().parents[1]

RUN = """
surfaces:
  turned: {file: measured.s4s.h5}
targets:
  - name: crystal
    material: G4_Si
    size: [0.38 mm, 0.295 mm, 0.2 mm]
    position: [0 mm, 0 mm, -0.1 mm]
    rough:
      - {face: "+z", surface: turned}
source:
  decay: Po210
  surface: {volume: crystal, face: "+z"}
  depth: {profile: exponential, mean: 20 nm}
run: {events: 2000, seed: 1}
"""


def _events(folder: str, events: list[int]) -> list[dict]:
    from score4.inputs.config import load_config
    from score4.runner.run_plan import plan_run
    from score4.sim.simulation import Simulation
    from score4.sim.worker import Chunk, WorkerSpec, simulate_chunk

    plan = plan_run(load_config(Path(folder) / "run.yaml"))
    sim = Simulation(plan, log_path=Path(folder) / "g4.log")
    spec = WorkerSpec(plan, Path(folder))
    out = []
    for e in events:
        simulate_chunk(sim, spec, Chunk(0, e, 1))
        out.append(sim.run_counts())
    return out


def test_a_stuck_recoil_among_measured_blocks_is_counted(tmp_path):
    desc = ROOT / "examples" / "surfaces" / "measured.yaml"
    cmd = [sys.executable, "-m", "score4", "surface", "generate", str(desc)]
    subprocess.run([*cmd, "--out", str(tmp_path / "measured.s4s.h5")], check=True)
    (tmp_path / "run.yaml").write_text(RUN)
    stuck, plain = run_in_spawned_process(_events, str(tmp_path), [528, 527])
    assert stuck["replay_pushes"] == 1
    assert plain["replay_pushes"] == 0  # counted per run, not carried over
    log = (tmp_path / "g4.log").read_text()
    assert log.count("Stuck Track") == 1  # the one push, Geant4's own warning
