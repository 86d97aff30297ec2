"""Real (small) Geant4 runs through the engine: physics checks, reproducibility, bad input."""

from pathlib import Path

import h5py
import numpy as np
import pytest

from score4 import api
from score4.errors import ConfigError, Score4Error
from score4.inputs.config import load_config, parse_config
from score4.runner.engine import run
from score4.runner.output import read_results, summarize
from score4.runner.run_record import RunRecord

from conftest import ROOT


def test_flat_example_half_the_alphas_deposit_everything(tmp_path: Path):
    config = load_config(ROOT / "examples" / "flat_alpha.yaml")
    out = run(config, tmp_path / "flat.h5", progress=False, echo=lambda m: None)
    res = read_results(out)
    edep, emitted = res.edep["crystal"], res.primary_energy
    n = len(edep)
    assert n == 2000
    # Isotropic emission from a flat face at depth 0: half go into the crystal and stop
    # (full energy), half fly away (zero). "Full" allows 10 keV: delta electrons made near the
    # surface can leave it (measured: 734 of ~1000 within 1 eV, 988 within 10 keV).
    # Binomial: |f - 0.5| < 3 sigma, sigma = sqrt(0.25/n).
    full = np.count_nonzero(emitted - edep < 0.010)
    assert abs(full / n - 0.5) < 3 * np.sqrt(0.25 / n)
    # never more than emitted (nuclear stopping, which overshot it, is off: sim.physics)
    assert (edep <= emitted + 1e-6).all()
    # zero deposit exactly for the alphas emitted away from the crystal (dz > 0)
    into = res.primaries.direction[:, 2] < 0
    assert np.array_equal(into, edep > 0)
    # partial deposits (grazing alphas scattered back out) are rare on a flat face
    assert np.count_nonzero((edep > 0) & (emitted - edep >= 0.010)) < 0.03 * n


def test_same_seed_same_output_and_jobs_do_not_matter(tmp_path: Path, make_config):
    config = make_config(run={"events": 300, "seed": 11, "chunk_events": 100})
    a = read_results(run(config, tmp_path / "a.h5", progress=False, echo=lambda m: None))
    b = read_results(run(config, tmp_path / "b.h5", jobs=2, progress=False, echo=lambda m: None))
    assert np.array_equal(a.edep["crystal"], b.edep["crystal"])
    assert np.array_equal(a.primaries.position, b.primaries.position)
    assert np.array_equal(a.event_id, np.arange(300))
    other = make_config(run={"events": 300, "seed": 12, "chunk_events": 100})
    c = read_results(run(other, tmp_path / "c.h5", progress=False, echo=lambda m: None))
    assert not np.array_equal(a.primaries.position, c.primaries.position)


def test_run_record_and_summary(tmp_path: Path, make_config):
    config = make_config(run={"events": 50, "seed": 3})
    res = read_results(run(config, tmp_path / "r.h5", progress=False, echo=lambda m: None))
    # a library user's plan of the same configuration draws the events the run tracked
    plan = api.plan_run(config)
    assert plan.source is not None
    drawn = plan.source.events(plan.seed, 0, 50)
    assert np.array_equal(drawn.position, res.primaries.position)
    assert np.array_equal(drawn.direction, res.primaries.direction)
    rec = res.run
    assert rec["seed"] == 3
    assert rec["n_events"] == 50
    assert rec["physics_mode"] == "lite"
    assert "no radioactive decay" in rec["physics_lacks"]
    assert rec["geant4_version"].startswith("11.")
    assert rec["geant4_pybind_version"]
    assert (
        rec["config"]["source"]["energy"] == "5.3 MeV"
    )  # stored with units: parse_config reads it back
    assert parse_config(rec["config"]).source.energy == pytest.approx(5.3)
    assert rec["wall_time_s"] > 0
    # the typed record reads the file's /run attributes back, every one of them
    record = RunRecord.from_dict(rec)
    assert (record.seed, record.n_events, record.n_atoms, record.jobs) == (3, 50, None, 1)
    assert {"volumes", "source", "normalisation_version"} <= set(record.normalisation)
    assert record.to_dict() == rec
    s = summarize(res)
    (vol,) = s["volumes"]
    assert vol["name"] == "crystal"
    assert len(vol["histogram"]["counts"]) == 100
    assert (
        sum(vol["histogram"]["counts"]) == 50
    )  # the top edge is the largest primary energy: no overflow
    assert vol["histogram"]["edges_MeV"][-1] == pytest.approx(5.3)
    assert vol["n_nonzero"] == int(np.count_nonzero(res.edep["crystal"]))


def test_existing_output_is_refused_and_untouched(tmp_path: Path, make_config):
    out = tmp_path / "exists.h5"
    out.write_bytes(b"precious")
    with pytest.raises(ConfigError, match="already exists; use --overwrite"):
        run(make_config(), out, progress=False)
    assert out.read_bytes() == b"precious"


def test_output_folder_must_exist(tmp_path: Path, make_config):
    with pytest.raises(ConfigError, match="does not exist"):
        run(make_config(), tmp_path / "missing" / "x.h5", progress=False)


def test_unknown_material_lists_close_names_and_leaves_nothing(tmp_path: Path, make_config):
    """Refused when the configuration is read (score4 ships Geant4's NIST names): nothing runs."""
    with pytest.raises(
        ConfigError,
        match=r"targets.0.material: unknown material 'G4_Silicon'; closest NIST names: .*G4_Si",
    ):
        make_config(targets=[{"name": "crystal", "material": "G4_Silicon", "size": ["1 cm"] * 3}])
    assert list(tmp_path.iterdir()) == []


def test_unknown_particle(tmp_path: Path, make_config):
    config = make_config(source={"particle": "alpah"})
    with pytest.raises(ConfigError, match=r"source\.particle: unknown name 'alpah'"):
        run(config, tmp_path / "p.h5", progress=False, echo=lambda m: None)
    assert list(tmp_path.iterdir()) == []


def test_overwrite_replaces_only_when_complete(tmp_path: Path, make_config):
    out = tmp_path / "o.h5"
    run(make_config(run={"events": 20}), out, progress=False, echo=lambda m: None)
    run(make_config(run={"events": 30}), out, overwrite=True, progress=False, echo=lambda m: None)
    assert read_results(out).n_events == 30
    assert not list(tmp_path.glob("*.partial"))
    assert not list(tmp_path.glob("*.parts"))


def test_ion_primary_pb206_recoil_stops_in_silicon(tmp_path: Path, make_config):
    # The 103 keV Pb-206 recoil of a Po-210 decay, shot into silicon, stops and deposits all its
    # energy. It follows TRIM trajectories (physics.heavy_ions: trim): its path in silicon is
    # tens of nm (TRIM: projected range 46 nm); Geant4 alone moved it 283 nm in one step.
    config = make_config(
        source={"particle": "Pb206", "energy": "103 keV", "direction": "normal"},
        run={"events": 20},
        output={"track_length": True},
    )
    res = read_results(run(config, tmp_path / "pb.h5", progress=False, echo=lambda m: None))
    assert np.allclose(res.edep["crystal"], 0.103, atol=1e-6)
    path = res.scores["track_length"]["crystal"]
    assert (path > 10e-6).all()  # 10 nm < path < 200 nm
    assert (path < 200e-6).all()
    assert res.run["physics_mode"] == "lite"


def test_results_reader_rejects_other_files(tmp_path: Path):
    other = tmp_path / "other.h5"
    with h5py.File(other, "w") as f:
        f["x"] = 1
    with pytest.raises(Score4Error, match="not a score4 results file"):
        read_results(other)
    (tmp_path / "text.h5").write_text("hello")
    with pytest.raises(Score4Error, match="not an HDF5 file"):
        read_results(tmp_path / "text.h5")


def test_resume_reuses_only_chunks_of_the_same_run(tmp_path: Path, make_config):
    from score4.runner.output import write_chunk
    from score4.runner.run_plan import config_fingerprint
    from score4.sim.worker import chunk_path
    from score4.source.primaries import Primaries

    config = make_config(run={"events": 30, "seed": 9, "chunk_events": 10})
    out = tmp_path / "r.h5"
    parts = tmp_path / "r.h5.parts"
    parts.mkdir()

    def planted(first_event, fingerprint, marker):
        p = Primaries(
            np.arange(10), ["alpha"] * 10, [5.3] * 10, np.zeros((10, 3)), [[0, 0, -1.0]] * 10
        )
        edep = {"edep": np.full((10, 1), marker)}
        write_chunk(
            chunk_path(parts, first_event // 10), first_event, ["crystal"], edep, p, fingerprint
        )

    planted(
        0, config_fingerprint(config, 9), 1.2345
    )  # a finished chunk of this run: kept (markers below 5.3 MeV: no energy-check warning)
    planted(10, "another-run", 4.5678)  # left over from a different configuration: redone
    with pytest.raises(ConfigError, match="--resume"):
        run(config, out, progress=False, echo=lambda m: None)
    res = read_results(run(config, out, resume=True, progress=False, echo=lambda m: None))
    edep = res.edep["crystal"]
    assert (edep[:10] == 1.2345).all()
    assert not (edep[10:] == 4.5678).any()
    assert (edep[10:] <= 5.3 + 1e-9).all()
    assert not parts.exists()


def test_first_events_of_a_longer_run_are_the_same_events(tmp_path: Path, make_config):
    # Prefix-stable sampling (source/event_blocks.py) and one Geant4 seed per event
    # (runner/seeds.py):
    # the 3000 events of a one-chunk run are the first 3000 of a 5000-event run cut into
    # 700-event chunks (not on the 1000-event block boundaries) on 2 workers. Exact equality.
    fast = {"particle": "alpha", "energy": "1 MeV"}  # ~4 um range: a few steps per event
    short = make_config(source=fast, run={"events": 3000, "seed": 5})
    long = make_config(source=fast, run={"events": 5000, "seed": 5, "chunk_events": 700})
    a = read_results(run(short, tmp_path / "a.h5", progress=False, echo=lambda m: None))
    b = read_results(run(long, tmp_path / "b.h5", jobs=2, progress=False, echo=lambda m: None))
    assert a.run["n_chunks"] == 1
    assert b.run["n_chunks"] == 8
    first = b.primaries.select_events(0, 3000)
    for field in ("event", "particle", "energy", "position", "direction"):
        assert np.array_equal(getattr(a.primaries, field), getattr(first, field)), field
    assert np.count_nonzero(a.edep["crystal"]) > 1000  # about half the alphas enter the crystal
    assert np.array_equal(a.edep["crystal"], b.edep["crystal"][:3000])


def test_resume_keeps_the_chunks_of_the_interrupted_run_whatever_jobs_is_now(
    tmp_path: Path, make_config
):
    from score4.runner.engine import plan_chunks
    from score4.runner.output import write_chunk
    from score4.runner.run_plan import config_fingerprint
    from score4.sim.worker import chunk_path
    from score4.source.primaries import Primaries

    config = make_config(run={"events": 30, "seed": 9})
    assert plan_chunks(30, 10_000, 3).size == 10
    assert plan_chunks(30, 10_000, 1).size == 30
    parts = tmp_path / "r.h5.parts"
    parts.mkdir()
    (parts / "plan.json").write_text('{"n_events": 30, "chunk_size": 10}')  # run with --jobs 3
    extra = {"depth": np.zeros(10), "facet": np.zeros(10, np.int64), "patch": np.full(10, -1)}
    p = Primaries(
        np.arange(10), ["alpha"] * 10, [5.3] * 10, np.zeros((10, 3)), [[0, 0, -1.0]] * 10, extra
    )
    edep = {"edep": np.full((10, 1), 1.2345)}
    write_chunk(chunk_path(parts, 1), 10, ["crystal"], edep, p, config_fingerprint(config, 9))
    said = []
    res = read_results(
        run(config, tmp_path / "r.h5", resume=True, progress=False, echo=said.append)
    )
    assert "resume: 1 of 3 chunks already finished" in said[0]
    assert res.run["n_chunks"] == 3
    assert res.run["resumed_chunks"] == 1
    assert (res.edep["crystal"][10:20] == 1.2345).all()
