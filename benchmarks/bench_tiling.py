"""Native tiling vs portal vs a flat face on a 10 cm x 10 cm face, and one patch vs one 1 cm patch.

    .venv/bin/python benchmarks/bench_tiling.py [--events 2000] [--limit 300]
    .venv/bin/python benchmarks/bench_tiling.py --markdown   # docs/tiling.md's table, no patches

Face: the +z face of a 10 cm x 10 cm x 1 mm silicon box, covered with 10 um pyramids (10 um wide
and high) in 0.5 mm patches: a 200 x 200 grid, 50 x 50 pyramids per patch, three variants with
densities 0.3 / 0.5 / 0.2 and height spreads 0 / 1 / 2 um (solid auto: multi-union for the equal
heights, tessellated for the spreads), placed with fill exact, seed 7. Each case runs in its own
process (so the RSS is the case's own):

  build s     score4.geometry.world.build_world (Geant4 solids, placements / portal, subworlds)
  init s      the whole Simulation set-up (surfaces, patch map, source, Geant4 initialisation)
  1st run s   the first 20 events (geometry optimisation/voxels and physics tables happen here)
  RSS MB      peak resident size of the process (ru_maxrss) after all events
  ev/s        5.3 MeV alphas from the face (exponential depth 20 nm, isotropic, lite physics,
              production cut 1 um), events per second of wall time and of process CPU time (the
              machine is shared: CPU time is the steadier figure); mean deposit as a sanity check
  jumps/ev    portal only: jumps per event

Second table: one patch solid alone (no world), built in its own process with a time limit:
the 0.5 mm patch (2 500 pyramids) and a 1 cm patch (10^6 pyramids as one solid), as multi-union
(equal heights) and tessellated solid. A case that does not finish within --limit seconds is
killed and reported as "> limit" with the peak RSS it had reached (VmHWM read from /proc).

This docstring says what the script measures; what it measured (tables of past runs, with
date and load) is in benchmarks/README.md, section bench_tiling.py.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import resource
import subprocess
import sys
import time
from typing import Any

import numpy as np

from score4.runner.run_plan import plan_run

MARK = "BENCH_RESULT "
FACE_CM = 10.0
PATCH_MM = 0.5
SPREADS_UM = (0.0, 1.0, 2.0)
DENSITIES = (0.3, 0.5, 0.2)
WARMUP = 20


def _rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # kB on Linux


def run_config(tiling: str, face_cm: float = FACE_CM) -> dict:
    """The benchmark's run configuration; ``tiling`` is native, portal, flat, or with one variant
    (the equal-height pyramids) placements1 / replicas1 (native placements vs G4PVReplica rows)."""
    n = round(PATCH_MM / 0.010)
    surfaces = {
        f"v{k}": {
            "kind": "spikes",
            "nx": n,
            "ny": n,
            "width": "10 um",
            "height": "10 um",
            "height_sigma": f"{s} um",
            **({"seed": k + 1} if s > 0 else {}),  # a seed only where heights are drawn
        }
        for k, s in enumerate(SPREADS_UM)
    }
    target: dict[str, Any] = {
        "name": "crystal",
        "material": "G4_Si",
        "size": [f"{face_cm} cm", f"{face_cm} cm", "1 mm"],
        "position": ["0 cm", "0 cm", "-0.5 mm"],
    }
    if tiling in ("placements1", "replicas1"):
        target["rough"] = [{"face": "+z", "surface": "v0", "native_layout": tiling[:-1]}]
    elif tiling != "flat":
        target["rough"] = [
            {
                "face": "+z",
                "tiling": tiling,
                "fill": "exact",
                "seed": 7,
                "variants": [{"surface": f"v{k}", "density": d} for k, d in enumerate(DENSITIES)],
            }
        ]
    return {
        "physics": "lite",
        "surfaces": surfaces if tiling != "flat" else {},
        "targets": [target],
        "source": {
            "particle": "alpha",
            "energy": "5.3 MeV",
            "direction": "isotropic",
            "surface": {"volume": "crystal", "face": "+z"},
            "depth": {"profile": "exponential", "mean": "20 nm"},
        },
        "run": {"events": 1000, "seed": 3},
    }


def timed_simulation(data: dict):
    """A lite :class:`Simulation` of config dict ``data`` and ``{"init_s", "build_s"}``: wall
    seconds of its whole set-up and of ``build_world`` within it (the config parsed before)."""
    from score4.inputs.config import parse_config
    from score4.sim import simulation
    from score4.sim.runtime import resolve_physics

    timed = {}
    build_world = simulation.build_world  # type: ignore[attr-defined]  # patched where it is used

    def timed_build(*args):
        t0 = time.perf_counter()
        out = build_world(*args)
        timed["build_s"] = time.perf_counter() - t0
        return out

    simulation.build_world = timed_build  # type: ignore[attr-defined]
    config = parse_config(data)
    t0 = time.perf_counter()
    sim = simulation.Simulation(plan_run(config, physics=resolve_physics("lite")))
    return sim, {"init_s": time.perf_counter() - t0, **timed}


def measure_tiling(tiling: str, events: int, face_cm: float = FACE_CM) -> dict:
    """One case, in this process: build, warm up, time ``events`` alphas."""
    sim, timed = timed_simulation(run_config(tiling, face_cm))
    out = {"case": tiling, **timed}
    primaries = sim.source.primaries(np.random.default_rng(5), 0, WARMUP + events)
    t0 = time.perf_counter()
    sim.run(primaries.select_events(0, WARMUP), 1)
    out["first_run_s"] = time.perf_counter() - t0
    jumps0 = sim.teleporter.jumps if sim.teleporter else 0
    t0, c0 = time.perf_counter(), time.process_time()
    scores = sim.run(primaries.select_events(WARMUP, WARMUP + events), 2)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    out.update(
        events=events,
        ev_per_s_wall=events / wall,
        ev_per_s_cpu=events / cpu,
        mean_edep_mev=float(scores["edep"][:, 0].mean()),
        rss_mb=_rss_mb(),
    )
    if sim.teleporter:
        out["jumps_per_event"] = (sim.teleporter.jumps - jumps0) / events
    return out


def measure_patch(size_mm: float, solid: str) -> dict:
    """One patch solid of 10 um pyramids, ``size_mm`` wide, built alone in this process."""
    from score4.geometry.solids import multiunion_solid, tessellated_solid
    from score4.sim.runtime import import_geant4, resolve_physics
    from score4.surface.spikes import SpikeGrid
    from score4.surface.triangle_mesh import closed_body

    g4 = import_geant4(resolve_physics("lite"))
    base = _rss_mb()
    n = round(size_mm / 0.010)
    t0 = time.perf_counter()
    grid = SpikeGrid(nx=n, ny=n, width_x=0.010, width_y=0.010, mean_height=0.010)
    if solid == "multiunion":
        built = multiunion_solid(g4, grid, 1e-3, "patch")
    else:
        built = tessellated_solid(g4, closed_body(grid.top_mesh(), 1e-3), "patch")
    seconds = time.perf_counter() - t0
    _ = built
    return {
        "size_mm": size_mm,
        "solid": solid,
        "pyramids": n * n,
        "build_s": seconds,
        "rss_mb": _rss_mb(),
        "rss_delta_mb": _rss_mb() - base,
    }


def _peak_rss_mb(pid: int) -> float:
    try:
        with open(f"/proc/{pid}/status") as f:
            for line in f:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    return float("nan")


def in_subprocess(args: list[str], limit: float) -> dict:
    """Run this script with ``args`` in a fresh process: its figures, or ``{"timeout": True,
    ...}`` if it exceeded ``limit`` seconds."""
    cmd = [sys.executable, os.path.abspath(__file__), *args]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    t0, peak = time.perf_counter(), 0.0
    while proc.poll() is None:
        rss = _peak_rss_mb(proc.pid)
        peak = peak if math.isnan(rss) else max(peak, rss)  # NaN once the process is gone
        if time.perf_counter() - t0 > limit:
            proc.kill()
            proc.wait()
            return {"timeout": True, "seconds": time.perf_counter() - t0, "peak_rss_mb": peak}
        time.sleep(0.5)
    assert proc.stdout is not None
    lines = [line for line in proc.stdout.read().splitlines() if line.startswith(MARK)]
    if proc.returncode != 0 or not lines:
        raise RuntimeError(f"{' '.join(args)}: failed (exit code {proc.returncode})")
    return json.loads(lines[-1][len(MARK) :])


# the rows of docs/tiling.md's table (--markdown)
MARKDOWN_LABELS = {
    "flat": "flat face",
    "native": "native, 3 variants (2 with a height spread; solid auto)",
    "portal": "portal, same 3 variants",
    "placements1": "native placements, 1 equal-height variant (multi-union)",
    "replicas1": "native replicas (`native_layout: replicas`), same variant",
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--events", type=int, default=2000)
    parser.add_argument(
        "--limit", type=float, default=300.0, help="seconds per case before it is killed"
    )
    parser.add_argument(
        "--face-cm", type=float, default=FACE_CM, help="face side (a quick check: 1)"
    )
    parser.add_argument("--skip-patches", action="store_true", help="only the tiling table")
    parser.add_argument(
        "--cases",
        default="flat,native,portal,placements1,replicas1",
        help="comma-separated tiling cases (placements1/replicas1: one variant)",
    )
    parser.add_argument(
        "--markdown", action="store_true", help="the tiling table as docs/tiling.md's rows"
    )
    parser.add_argument("--tiling", help=argparse.SUPPRESS)
    parser.add_argument("--patch", nargs=2, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.tiling:
        print(MARK + json.dumps(measure_tiling(args.tiling, args.events, args.face_cm)), flush=True)
        return
    if args.patch:
        print(MARK + json.dumps(measure_patch(float(args.patch[0]), args.patch[1])), flush=True)
        return

    if args.markdown:
        from stamp import stamp  # this folder is on sys.path when run as a script

        print(stamp())
        print("| case | build s | RSS MB | events/s |")
        print("|---|---|---|---|")
    else:
        print(
            f"{'case':11} {'build s':>8} {'init s':>7} {'1st run s':>9} {'RSS MB':>7} "
            f"{'ev/s wall':>9} {'ev/s CPU':>8} {'mean MeV':>8} {'jumps/ev':>8}"
        )
    for tiling in args.cases.split(","):
        r = in_subprocess(
            ["--tiling", tiling, "--events", str(args.events), "--face-cm", str(args.face_cm)],
            max(args.limit, 3600),
        )
        if args.markdown:  # events per second of CPU: the steadier figure on a shared machine
            print(
                f"| {MARKDOWN_LABELS[tiling]} | {r.get('build_s', 0.0):.2f} | {r['rss_mb']:.0f} "
                f"| {r['ev_per_s_cpu']:.0f} |",
                flush=True,
            )
            continue
        print(
            f"{tiling:11} {r.get('build_s', 0.0):8.2f} {r['init_s']:7.2f} {r['first_run_s']:9.2f} "
            f"{r['rss_mb']:7.0f} {r['ev_per_s_wall']:9.0f} {r['ev_per_s_cpu']:8.0f} "
            f"{r['mean_edep_mev']:8.3f} {r.get('jumps_per_event', float('nan')):8.2f}",
            flush=True,
        )
    if args.skip_patches or args.markdown:
        return
    print()
    print(f"{'patch':>8} {'solid':12} {'pyramids':>9} {'build s':>9} {'RSS MB':>8} {'dRSS MB':>8}")
    for size in (PATCH_MM, 10.0):
        for solid in ("multiunion", "tessellated"):
            r = in_subprocess(["--patch", str(size), solid], args.limit)
            n = round(size / 0.010) ** 2
            if r.get("timeout"):
                print(
                    f"{size:6.1f}mm {solid:12} {n:9d} {'> ' + format(args.limit, 'g'):>9} "
                    f"{'>= ' + format(r['peak_rss_mb'], '.0f'):>8} {'':>8}",
                    flush=True,
                )
            else:
                print(
                    f"{size:6.1f}mm {solid:12} {n:9d} {r['build_s']:9.2f} {r['rss_mb']:8.0f} "
                    f"{r['rss_delta_mb']:8.0f}",
                    flush=True,
                )


if __name__ == "__main__":
    main()
