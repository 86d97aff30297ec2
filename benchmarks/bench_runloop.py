"""The run loop's fixed and per-event costs: start-up, per-BeamOn, per-event, large faces, jobs.

    .venv/bin/python benchmarks/bench_runloop.py [--events 2000]
        [--parts startup,faces,spread,portal,jobs] (also: plans, python) [--markdown]
        [--rounds 5] [--baseline OLD/src]

``--markdown`` prints the faces part as docs/tiling.md's table (``make docs-check-all``).

Parts (each case runs in its own process, so its RSS and start-up are its own):

``startup``
    A one-event run of examples/paper_a_rough.yaml with one worker: CPU seconds of importing
    ``score4.runner.engine`` (what the parent and every spawned worker import) and its RSS, of the
    parent process and of the worker (everything before the first event, plus one event); then
    the same run by the ``score4`` command (``score4 -q run ... --events 1``): CPU of its
    process and its worker together (a spawned worker of a console script may import the
    script's modules again).
    Medians of ``--rounds`` rounds; ``--baseline OLD/src`` times another score4 checkout in the
    same rounds (before/after). The figures depend on Python's bytecode cache: with
    PYTHONDONTWRITEBYTECODE set and no ``__pycache__`` in ``src/``, every process compiles
    score4's modules again (printed in the heading).
``faces``
    The paper's pyramid face (10 um pyramids, 0.5 mm patches of 50 x 50, one variant, multi-union)
    on a 10 cm and a 1 m square face (200 x 200 and 2000 x 2000 cells), in the default layout
    (``auto``: nested 2 x 2 groups above 2500 cells) and flat (one placement per cell, the old
    default; the 1 m flat case only with ``--flat-1m``: 20 s and 2.6 GB). Two more 1 m cases with
    two variants (10 um and 5 um pyramids, ``fill: random`` and ``fill: exact`` 50 %): nothing is
    shared between their groups above the lowest levels. A last 1 m case with ``fill: tiles``
    (the map made of 64 random tiles of 40 x 40 cells, each a shared group). Columns:

      build s     score4.geometry.world.build_world
      init s      the whole Simulation set-up (scene, source, Geant4 initialisation)
      1st s       the first run (20 events: geometry voxels, physics tables)
      BeamOn ms   fixed CPU cost of a BeamOn, B, and
      ms/ev       CPU per event, e, of 5.3 MeV alphas from 20 nm below the face (isotropic, lite):
                  a BeamOn of n events costs B + n e; measured with ten BeamOns of one event
                  and one of --events events
      run ms/ev   CPU per event of that one BeamOn, B included (what a chunk of that size costs)
      RSS MB      peak resident size of the process
``spread``
    Pyramids with a 2 um height spread (seed 3) on a 2.5 cm face of 50 x 50 cells (one
    placement per cell), as ``solid: frustums`` (auto) and as ``solid: blocks``: the same
    columns; the BeamOn cost shows the walk of the volume tree (~2500 volumes per patch).
``portal``
    Po-210 events (alpha + Pb-206 recoil) on the 10 cm pyramid face: native (default layout)
    against portal tiling, CPU per event in one process each, and the share of portal events that
    needed the tracking action (see score4.sim.portal_action); then a third run with CPU timers
    on the portal's Python (``Teleporter.on_step`` per portal/trigger step, ``start_track`` per
    track while the tracking action is on, ``_move`` per jump inside ``on_step``). The first
    two runs work on older score4 versions too (PYTHONPATH=old/src), for a before/after
    comparison.
``python``
    Alphas (5.3 MeV, isotropic, 20 nm deep) on the paper's 3 cm pyramid face: CPU per event
    and the time spent in score4's Python per event (feeding the primaries, reading the
    scores, progress and stop checks; wall-clock timers inside them, as a share of the
    run's wall time), medians of
    ``--rounds`` processes, interleaved with ``--baseline OLD/src`` if given.
``plans``
    No Geant4, no timing (seconds): the nested layout's plan for the faces of ``faces``, the
    group sizes per level, how many distinct groups each has and the placements they need
    (distinct groups x cells per group, per level, then the envelope's daughters).
``jobs``
    examples/paper_a_rough.yaml, 20000 events (two chunks) with 1 and 2 worker processes: wall
    seconds and their ratio, and the speed-up estimated from the CPU of the parent and the
    workers (see part_jobs). The machine is shared: read the wall ratio with the load printed.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from bench_tiling import timed_simulation  # this folder is on sys.path when run as a script

MARK = "BENCH_RESULT "
ROOT = Path(__file__).resolve().parent.parent
WARMUP = 20
PYRAMIDS = {"kind": "spikes", "nx": 50, "ny": 50, "width": "10 um", "height": "10 um"}
LOW = {"kind": "spikes", "nx": 50, "ny": 50, "width": "10 um", "height": "5 um"}
SPREAD = {**PYRAMIDS, "height_sigma": "2 um", "seed": 3}


def _rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # kB on Linux


def face_config(
    side_cm: float, layout: str = "auto", tiling: str = "native", variants: str = "one"
) -> dict:
    """Pyramid face of ``side_cm``; ``variants``: one, one-<solid> (one as that solid), random
    (two, fill random), exact (two),
    tiles (two, fill tiles: 64 random tiles of the first group size);
    spread-<solid>: one variant of pyramids with a 2 um height spread as that solid."""
    rough: dict = {"face": "+z", "tiling": tiling}
    if layout != "default" and tiling == "native":  # native_layout is a native-tiling key
        rough["native_layout"] = layout
    if variants == "one":
        rough["surface"] = "p"
    elif variants.startswith("one-"):
        rough.update(surface="p", solid=variants.split("-", 1)[1])
    elif variants.startswith("spread-"):
        rough.update(surface="spread", solid=variants.split("-", 1)[1])
    else:
        rough.update(
            variants=[{"surface": "p", "density": 0.5}, {"surface": "low", "density": 0.5}],
            fill=variants,
            seed=7,
        )
    return {
        "physics": "lite",
        "surfaces": {"p": PYRAMIDS, "low": LOW, "spread": SPREAD},
        "targets": [
            {
                "name": "crystal",
                "material": "G4_Si",
                "size": [f"{side_cm} cm", f"{side_cm} cm", "1 mm"],
                "position": ["0 cm", "0 cm", "-0.5 mm"],
                "rough": [rough],
            }
        ],
        "source": {
            "particle": "alpha",
            "energy": "5.3 MeV",
            "direction": "isotropic",
            "surface": {"volume": "crystal", "face": "+z"},
            "depth": {"profile": "exponential", "mean": "20 nm"},
        },
        "run": {"events": 1000, "seed": 3},
    }


def measure_face(side_cm: float, layout: str, variants: str, events: int) -> dict:
    sim, out = timed_simulation(face_config(side_cm, layout, variants=variants))
    primaries = sim.source.primaries(np.random.default_rng(5), 0, WARMUP + 10 + events)
    t0 = time.perf_counter()
    sim.run(primaries.select_events(0, WARMUP), 1)
    out["first_run_s"] = time.perf_counter() - t0
    c0 = time.process_time()
    for k in range(10):  # ten BeamOns of one event each
        sim.run(primaries.select_events(WARMUP + k, WARMUP + k + 1), 10 + k)
    ten = time.process_time() - c0
    c0 = time.process_time()
    scores = sim.run(primaries.select_events(WARMUP + 10, WARMUP + 10 + events), 2)
    whole = time.process_time() - c0
    # one BeamOn of n events costs B + n e: from n = 1 (ten times) and n = events
    per_event = (whole - ten / 10) / (events - 1)
    out.update(
        per_event_ms=per_event * 1e3,
        beamon_ms=(ten / 10 - per_event) * 1e3,
        run_ms_per_event=whole / events * 1e3,
        mean_edep_mev=float(scores["edep"][:, 0].mean()),
        rss_mb=_rss_mb(),
    )
    return out


def _time_python_actions() -> dict:
    """Wrap the teleporter's per-step and per-track Python methods with CPU timers (class level,
    before the actions bind them); returns {name: [calls, CPU s]}, filled as they run."""
    from score4.sim import portal_action

    spent: dict = {}
    for name in ("on_step", "start_track", "_move"):
        inner = getattr(portal_action.Teleporter, name)

        def timed(*args, _inner=inner, _name=name):
            c0 = time.process_time()
            _inner(*args)
            row = spent.setdefault(_name, [0, 0.0])
            row[0] += 1
            row[1] += time.process_time() - c0

        setattr(portal_action.Teleporter, name, timed)
    return spent


def portal_config(tiling: str) -> dict:
    """The portal part's run: Po-210 20 nm below the 10 cm pyramid face, ``tiling`` native or
    portal (also bench_instructions.py's cases ``runloop_native`` and ``runloop_portal``)."""
    data = face_config(10.0, layout="default", tiling=tiling)
    data["source"] = {
        "decay": "Po210",
        "direction": "isotropic",
        "surface": {"volume": "crystal", "face": "+z"},
        "depth": {"profile": "exponential", "mean": "20 nm"},
    }
    return data


def measure_portal(tiling: str, events: int) -> dict:
    timed_actions = tiling == "portal-timed"
    spent = _time_python_actions() if timed_actions else {}
    tiling = "portal" if timed_actions else tiling
    sim, out = timed_simulation(portal_config(tiling))
    primaries = sim.source.primaries(np.random.default_rng(5), 0, WARMUP + events)
    sim.run(primaries.select_events(0, WARMUP), 1)
    t = sim.teleporter
    tracked0 = getattr(t, "tracked_events", 0)
    c0 = time.process_time()
    scores = sim.run(primaries.select_events(WARMUP, WARMUP + events), 2)
    out.update(
        per_event_ms=(time.process_time() - c0) / events * 1e3,
        mean_edep_mev=float(scores["edep"][:, 0].mean()),
        tracked_share=(getattr(t, "tracked_events", np.nan) - tracked0) / events,
        jumps_per_event=t.jumps / (WARMUP + events) if t else float("nan"),
        quick_exits_per_event=getattr(t, "quick_exits", np.nan) / (WARMUP + events)
        if t
        else float("nan"),
    )
    for name, (calls, cpu) in spent.items():  # warm-up included: per call figures
        out[f"{name}_per_event"] = calls / (WARMUP + events)
        out[f"{name}_us_per_call"] = cpu / calls * 1e6
    return out


def measure_python_share(events: int, side_cm: float = 3.0) -> dict:
    """CPU per alpha event on the pyramid face of ``side_cm`` and the part of it spent in
    score4's Python per event: the bodies of the primary generator (``Simulation._generate``:
    feeding the primaries) and of the event action (``_score``: reading the scores; the
    progress and stop checks), timed with ``perf_counter`` inside them (the binding's calls
    into them are not included). The share is of the run's wall time: the process CPU clock
    costs ~2 us a reading here, too much for a timer around every call, and a busy machine
    pauses the process as often inside those parts as outside them."""
    from score4.sim import simulation

    spent: dict[str, list] = {}
    names = ["_generate", "_read_scores"]  # scores read after each BeamOn, checks in _generate
    if hasattr(simulation.Simulation, "_score"):  # older versions: a Python event action
        names = ["_generate", "_score", "_report_progress", "_check_stop"]
    for name in names:
        inner = getattr(simulation.Simulation, name)

        def timed(*args, _inner=inner, _name=name, **kwargs):
            t0 = time.perf_counter()
            _inner(*args, **kwargs)
            row = spent.setdefault(_name, [0, 0.0])
            row[0] += 1
            row[1] += time.perf_counter() - t0

        setattr(simulation.Simulation, name, timed)
    sim, out = timed_simulation(face_config(side_cm))
    primaries = sim.source.primaries(np.random.default_rng(5), 0, WARMUP + events)
    sim.run(primaries.select_events(0, WARMUP), 1)
    spent.clear()
    c0, t0 = time.process_time(), time.perf_counter()
    scores = sim.run(primaries.select_events(WARMUP, WARMUP + events), 2)
    cpu, wall = time.process_time() - c0, time.perf_counter() - t0
    out.update(
        cpu_ms=cpu / events * 1e3,
        wall_ms=wall / events * 1e3,
        mean_edep_mev=float(scores["edep"][:, 0].mean()),
    )
    for name, (calls, seconds) in spent.items():
        out[f"{name}_ms"] = seconds / events * 1e3
        out[f"{name}_calls"] = calls / events
    return out


def part_python(events: int, rounds: int, baseline: str | None) -> None:
    """The Python share per event of an alpha run on the 3 cm pyramid face (medians of
    ``rounds`` rounds, one process each, interleaved with ``baseline`` if given)."""
    import statistics

    versions = {"this": None} if baseline is None else {"this": None, "baseline": baseline}
    rows: dict[str, list[dict]] = {name: [] for name in versions}
    for _ in range(rounds):
        for name, src in versions.items():
            rows[name].append(in_subprocess(["--python-share", "--events", str(events)], src))
    print(
        f"Python per event: {events} alphas of 5.3 MeV on the 3 cm pyramid face, medians of "
        f"{rounds} rounds (load after: {os.getloadavg()})"
    )
    for name, src in versions.items():
        med = {k: statistics.median(r[k] for r in rows[name]) for k in rows[name][0]}
        scores = med.get("_score_ms", med.get("_read_scores_ms", 0.0))
        python = med["_generate_ms"] + scores
        python += med.get("_report_progress_ms", 0.0) + med.get("_check_stop_ms", 0.0)
        print(
            f"  {name}{f' ({src})' if src else ''}: CPU {med['cpu_ms']:.3f} ms/event (wall "
            f"{med['wall_ms']:.3f}); primaries {med['_generate_ms'] * 1e3:.1f} us, scores "
            f"{scores * 1e3:.1f} us, progress and stop "
            f"{(python - med['_generate_ms'] - scores) * 1e3:.1f} us: Python "
            f"{python / med['wall_ms']:.1%} of the event's wall time; mean deposit "
            f"{med['mean_edep_mev']:.4f} MeV"
        )


def in_subprocess(args: list[str], src: str | None = None) -> dict:
    """Run this script with ``args`` in a new process (``src``: another score4's sources
    first on the path) and return the figures it prints."""
    cmd = [sys.executable, os.path.abspath(__file__), *args]
    env = dict(os.environ)
    if src:
        env["PYTHONPATH"] = os.pathsep.join(p for p in (src, env.get("PYTHONPATH")) if p)
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False, env=env)
    lines = [line for line in proc.stdout.splitlines() if line.startswith(MARK)]
    if proc.returncode != 0 or not lines:
        raise RuntimeError(f"{' '.join(args)}: failed ({proc.returncode}): {proc.stderr[-2000:]}")
    return json.loads(lines[-1][len(MARK) :])


def timed_command(cmd: list[str], cwd: str | None = None) -> tuple[float, float, float]:
    """(wall s, CPU s of the command and its children, peak RSS MB of the largest child)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, capture_output=True, cwd=cwd)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu, after.ru_maxrss / 1024.0


def score4_cmd() -> list[str]:
    return [sys.executable, "-m", "score4.cli.main"]


_STARTUP_PROBE = """
import resource, sys, time
c0 = time.process_time()
from score4.runner import engine
from score4.inputs.config import load_config
imported = time.process_time() - c0
rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
config = load_config(sys.argv[1])
config = config.model_copy(update={"run": config.run.model_copy(update={"events": 1})})
engine.run(config, sys.argv[2], overwrite=True, jobs=1, progress=False, echo=lambda m: None)
me = resource.getrusage(resource.RUSAGE_SELF)
kids = resource.getrusage(resource.RUSAGE_CHILDREN)
cpu_self, cpu_kids = me.ru_utime + me.ru_stime, kids.ru_utime + kids.ru_stime
print(imported, rss, cpu_self, cpu_kids, kids.ru_maxrss / 1024)
"""


def _startup_round(src: str | None, config: Path, out: Path) -> list[float]:
    """One one-event run in a fresh interpreter (``src``: score4 sources to put first on the
    path, an older version for a before/after comparison); the probe's five figures."""
    env = dict(os.environ)
    if src:
        env["PYTHONPATH"] = os.pathsep.join(p for p in (src, env.get("PYTHONPATH")) if p)
    text = subprocess.run(
        [sys.executable, "-c", _STARTUP_PROBE, str(config), str(out)],
        check=True,
        capture_output=True,
        text=True,
        env=env,
    ).stdout.split()
    return [float(x) for x in text[-5:]]


def _cli_round(src: str | None, config: Path, out: Path) -> float:
    """CPU seconds of ``score4 -q run CONFIG --events 1 --jobs 1``, the console script (its
    process and the worker it waits for), with ``src`` first on the path if given."""
    env = dict(os.environ)
    if src:
        env["PYTHONPATH"] = os.pathsep.join(p for p in (src, env.get("PYTHONPATH")) if p)
    script = Path(sys.executable).parent / "score4"
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    args = ["-q", "run", str(config), "--events", "1", "--jobs", "1", "--out", str(out)]
    subprocess.run(
        [str(script), *args, "--overwrite"],
        check=True,
        capture_output=True,
        env=env,
    )
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)


def part_startup(rounds: int = 5, baseline: str | None = None) -> None:
    """CPU of a one-event run of paper_a_rough: the parent (import, scene, merge) and its worker.

    Medians of ``rounds`` rounds; with ``baseline`` (the ``src`` folder of another score4
    checkout) each round runs that version right after this one, and both are printed.
    """
    import statistics

    versions = {"this": None} if baseline is None else {"this": None, "baseline": baseline}
    print(
        f"start-up: one-event run of examples/paper_a_rough.yaml, --jobs 1 (median of {rounds} "
        f"interleaved rounds; Python writes bytecode caches: {not sys.flags.dont_write_bytecode})"
    )
    rows: dict[str, list[list[float]]] = {name: [] for name in versions}
    config = ROOT / "examples" / "paper_a_rough.yaml"
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(rounds):
            for name, src in versions.items():
                row = _startup_round(src, config, Path(tmp) / "a.h5")
                rows[name].append([*row, _cli_round(src, config, Path(tmp) / "b.h5")])
    print(f"  load average after: {os.getloadavg()}")
    for name, src in versions.items():
        imported, rss, parent, worker, worker_rss = (
            statistics.median(r[k] for r in rows[name]) for k in range(5)
        )
        if baseline is not None:
            print(f"  {name}{f' ({src})' if src else ''}:")
        print(f"  import score4.runner.engine: CPU {imported:5.2f} s, RSS {rss:4.0f} MB")
        print(f"  parent process (import, scene, 1 event drawn, merge): CPU {parent:5.2f} s")
        print(
            f"  worker process (import, Geant4 set-up, 1 event): CPU {worker:5.2f} s, "
            f"RSS {worker_rss:4.0f} MB"
        )
        print(f"  worker CPU, all rounds: {', '.join(f'{r[3]:.2f}' for r in rows[name])} s")
        command = statistics.median(r[5] for r in rows[name])
        print(f"  the score4 command (its process and its worker): CPU {command:5.2f} s")


def part_faces(events: int, flat_1m: bool) -> None:
    cases = FACE_CASES
    if flat_1m:
        cases = [*cases, (100.0, "placements", "one")]
    _face_table(cases, events)


#: The faces part: (side cm, layout, variants).
FACE_CASES = [
    (10.0, "auto", "one"),
    (10.0, "placements", "one"),
    (100.0, "auto", "one"),
    (100.0, "auto", "random"),
    (100.0, "auto", "exact"),
    (100.0, "auto", "tiles"),
]
#: The spread part: a 2.5 cm face of 50 x 50 cells (flat placements) of spread pyramids.
SPREAD_CASES = [(2.5, "auto", "spread-frustums"), (2.5, "auto", "spread-blocks")]


#: docs/tiling.md's labels of the faces part
FACE_LABELS = {
    (10.0, "auto", "one"): ("10 cm (200 x 200 cells)", "one", "auto (nested groups)"),
    (10.0, "placements", "one"): ("10 cm", "one", "placements"),
    (100.0, "auto", "one"): ("1 m (2000 x 2000 cells)", "one", "auto (nested groups)"),
    (100.0, "auto", "random"): ("1 m", "two, `fill: random`", "auto"),
    (100.0, "auto", "exact"): ("1 m", "two, `fill: exact`", "auto"),
    (100.0, "auto", "tiles"): ("1 m", "two, `fill: tiles`", "auto"),
    (100.0, "placements", "one"): ("1 m", "one", "placements"),
}


def _markdown_faces(cases: list, events: int, scale: float = 1.0) -> None:
    from stamp import stamp  # this folder is on sys.path when run as a script

    print(stamp())
    print(
        "| face | variants | layout | build s | initialisation s | ms per BeamOn "
        "| ms per event | RSS MB |"
    )
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    for case in cases:
        side, layout, variants = case
        r = in_subprocess(["--face", str(side * scale), layout, variants, "--events", str(events)])
        print(
            f"| {' | '.join(FACE_LABELS[case])} | {r['build_s']:.2f} | {r['init_s']:.2f} "
            f"| {r['beamon_ms']:.1f} | {r['per_event_ms']:.3f} | {r['rss_mb']:.0f} |",
            flush=True,
        )


def _face_table(cases: list, events: int) -> None:
    print(
        f"{'face':6} {'variants':15} {'layout':10} {'build s':>7} {'init s':>6} {'1st s':>6} "
        f"{'BeamOn ms':>9} {'ms/ev':>6} {'run ms/ev':>9} {'RSS MB':>6} {'mean MeV':>8}"
    )
    for side, layout, variants in cases:
        r = in_subprocess(
            ["--face", str(side), layout, variants, "--events", str(events)],
        )
        print(
            f"{side / 100:4g} m {variants:15} {layout:10} {r['build_s']:7.2f} {r['init_s']:6.2f} "
            f"{r['first_run_s']:6.2f} {r['beamon_ms']:9.1f} {r['per_event_ms']:6.3f} "
            f"{r['run_ms_per_event']:9.3f} "
            f"{r['rss_mb']:6.0f} {r['mean_edep_mev']:8.3f}",
            flush=True,
        )


def _spaced(n: int) -> str:
    """5 or more digits in groups of three (as the docs write them): 2500, 250 000."""
    return f"{n:,}".replace(",", " ") if n >= 10_000 else str(n)


def part_plans() -> None:
    """The nested layout's levels for the faces of ``part_faces`` (numpy only: exact counts)."""
    from score4.geometry.tiling import grouping_plan
    from score4.inputs.config import parse_config
    from score4.world.resolve import build_scene

    for side, variants in [(10.0, "one"), (100.0, "one"), (100.0, "random"), (100.0, "exact")]:
        layer = build_scene(parse_config(face_config(side, variants=variants))).layers[0]
        cells = layer.patch_map.variants
        plan = grouping_plan(cells)
        placed = [len(p) * g * g for g, p, _ in plan] + [plan[-1][2].size]
        levels = " then ".join(f"{g} x {g} ({_spaced(len(p))} distinct)" for g, p, _ in plan)
        print(
            f"{side / 100:g} m {variants}: {cells.shape[1]} x {cells.shape[0]} cells; groups "
            f"{levels}; placements {' + '.join(_spaced(n) for n in placed)} = "
            f"{_spaced(sum(placed))}"
        )


def part_portal(events: int, rounds: int = 1, baseline: str | None = None) -> None:
    import statistics

    versions = {"this": None} if baseline is None else {"this": None, "baseline": baseline}
    runs: dict[tuple[str, str], list[dict]] = {}
    for _ in range(rounds):  # interleaved: each round runs every version and tiling once
        for name, src in versions.items():
            for tiling in ("native", "portal"):
                args = ["--portal", tiling, "--events", str(events)]
                runs.setdefault((name, tiling), []).append(in_subprocess(args, src))
    print(f"portal part: medians of {rounds} rounds (load after: {os.getloadavg()})")
    print(f"{'version':8} {'tiling':7} {'ms/ev':>6} {'mean MeV':>8} {'jumps/ev':>8} {'tracked':>7}")
    res = {}
    for name in versions:
        for tiling in ("native", "portal"):
            rows = runs[(name, tiling)]
            r = res[(name, tiling)] = {k: statistics.median(x[k] for x in rows) for k in rows[0]}
            print(
                f"{name:8} {tiling:7} {r['per_event_ms']:6.3f} {r['mean_edep_mev']:8.3f} "
                f"{r['jumps_per_event']:8.2f} {r['tracked_share']:7.3f}",
                flush=True,
            )
        ratios = [
            p["per_event_ms"] / n["per_event_ms"]
            for p, n in zip(runs[(name, "portal")], runs[(name, "native")], strict=True)
        ]
        print(
            f"{name}: portal / native per event: median {statistics.median(ratios):.2f} "
            f"(rounds: {', '.join(f'{x:.2f}' for x in ratios)})"
        )
    this = {tiling: res[("this", tiling)] for tiling in ("native", "portal")}
    # where the difference goes: the portal's Python, timed in a third run (timers add cost)
    r = in_subprocess(["--portal", "portal-timed", "--events", str(events)])
    python_ms = 0.0
    for name in ("on_step", "start_track", "_move"):
        # a method never called (start_track in runs with no ambiguous event) has no figures
        n, us = r.get(f"{name}_per_event", 0.0), r.get(f"{name}_us_per_call", 0.0)
        print(f"  {name:12s} {n:5.2f} calls per event, {us:6.1f} us CPU per call")
        if name != "_move":  # _move runs inside on_step
            python_ms += n * us / 1e3
    print(
        f"  portal Python per event: {python_ms:.3f} ms of the "
        f"{this['portal']['per_event_ms'] - this['native']['per_event_ms']:.3f} ms difference"
    )


_JOBS_PROBE = """
import resource, sys, time
from score4.runner import engine
from score4.inputs.config import load_config
config = load_config(sys.argv[1])
events = int(sys.argv[3])
config = config.model_copy(update={"run": config.run.model_copy(update={"events": events})})
t0 = time.perf_counter()
engine.run(config, sys.argv[2], overwrite=True, jobs=int(sys.argv[4]), progress=False,
           echo=lambda m: None)
wall = time.perf_counter() - t0
me = resource.getrusage(resource.RUSAGE_SELF)
kids = resource.getrusage(resource.RUSAGE_CHILDREN)
print(wall, me.ru_utime + me.ru_stime, kids.ru_utime + kids.ru_stime)
"""


def part_jobs(events: int) -> None:
    """paper_a_rough with 1 and 2 workers: wall time, and CPU of the parent and the workers.

    On a shared machine the wall-time ratio says little; the CPU figures give the speed-up an
    idle 2-core machine would show if the two workers (one chunk each) ran side by side:
    (parent + workers at --jobs 1) / (parent + workers / 2 at --jobs 2).
    """
    from stamp import stamp  # this folder is on sys.path when run as a script

    print(f"  {stamp()}")
    res = {}
    with tempfile.TemporaryDirectory() as tmp:
        for jobs in (1, 2):
            load = os.getloadavg()[0]
            out = subprocess.run(
                [
                    sys.executable,
                    "-c",
                    _JOBS_PROBE,
                    str(ROOT / "examples" / "paper_a_rough.yaml"),
                    str(Path(tmp) / f"j{jobs}.h5"),
                    str(events),
                    str(jobs),
                ],
                check=True,
                capture_output=True,
                text=True,
            ).stdout.split()
            wall, parent, workers = (float(x) for x in out[-3:])
            res[jobs] = (wall, parent, workers)
            print(
                f"  --jobs {jobs}: wall {wall:6.2f} s, CPU parent {parent:5.2f} s, workers "
                f"{workers:6.2f} s (load before: {load:.1f})"
            )
    (w1, p1, c1), (w2, p2, c2) = res[1], res[2]
    print(f"  speed-up jobs 2 / jobs 1, wall: {w1 / w2:.2f}")
    print(
        f"  speed-up an idle 2-core machine would give (from CPU): {(p1 + c1) / (p2 + c2 / 2):.2f}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--events", type=int, default=2000, help="alpha / Po-210 events per case")
    parser.add_argument("--jobs-events", type=int, default=20000)
    parser.add_argument("--parts", default="startup,faces,spread,portal,jobs")
    parser.add_argument("--rounds", type=int, default=5, help="start-up: rounds (median)")
    parser.add_argument(
        "--baseline", help="start-up: also time the score4 sources in this src folder, interleaved"
    )
    parser.add_argument("--flat-1m", action="store_true", help="also the 1 m face, flat placements")
    parser.add_argument("--markdown", action="store_true", help="the faces as docs' table")
    parser.add_argument(
        "--face-scale",
        type=float,
        default=1.0,
        help="--markdown: the faces' sides times this (a quick check of the script: 0.05; the "
        "rows keep their labels)",
    )
    parser.add_argument("--face", nargs=3, help=argparse.SUPPRESS)
    parser.add_argument("--portal", help=argparse.SUPPRESS)
    parser.add_argument("--python-share", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.face:
        side, layout, variants = args.face
        print(MARK + json.dumps(measure_face(float(side), layout, variants, args.events)))
        return
    if args.portal:
        print(MARK + json.dumps(measure_portal(args.portal, args.events)))
        return
    if args.python_share:
        print(MARK + json.dumps(measure_python_share(args.events)))
        return
    parts = args.parts.split(",")
    if args.markdown:
        _markdown_faces(FACE_CASES, args.events, args.face_scale)
        return
    print(f"load average at start: {os.getloadavg()}")
    if "plans" in parts:
        part_plans()
    if "startup" in parts:
        part_startup(args.rounds, args.baseline)
    if "faces" in parts:
        part_faces(args.events, args.flat_1m)
    if "spread" in parts:
        _face_table(SPREAD_CASES, args.events)
    if "portal" in parts:
        part_portal(args.events, args.rounds, args.baseline)
    if "python" in parts:
        part_python(args.events, args.rounds, args.baseline)
    if "jobs" in parts:
        part_jobs(args.jobs_events)


if __name__ == "__main__":
    main()
