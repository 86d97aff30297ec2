"""Cost of one rough-surface solid in Geant4: G4TessellatedSolid vs the paper's G4MultiUnion.

    .venv/bin/python benchmarks/bench_solids.py [--max-spikes 1e5] [--timeout 600] [--events 5000]

Surface: square pyramids 10 um wide and 10 um high (all equal) on a square n x n grid
(n = round(sqrt(N))), on a base 50 um thick. For each N and each solid, one fresh process:
  numpy s     score4's numpy description (closed mesh for tessellated, frustum table for union)
  build s     Geant4 solid from it (AddFacet / AddNode loop, from Python)
  voxel s     SetSolidClosed(True) (vertex list + voxels) / G4MultiUnion::Voxelize()
  RSS MB      peak resident size of the process (ru_maxrss), and dRSS = peak minus the peak
              right after importing Geant4 (nothing built)
  us/event    geantinos shot straight down (-z) from 1 um above the highest tip at uniform
              random (x, y) over the patch, serial run manager with transportation only,
              Python primary generator; after 200 warm-up events, the fastest of --repeats
              batches of --events (the machine is shared)
  path nm     a check, from 200 further events with a stepping action: largest difference
              between the geantino's path in the solid and top height + base (numpy)
`box` is a flat G4Box of the patch footprint and the base thickness (the floor of tracking cost).
A case that does not finish within --timeout is killed and reported as "> timeout".

This docstring says what the script measures; what it measured (tables of past runs, with
date and load) is in benchmarks/README.md, section bench_solids.py.
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
from pathlib import Path
from typing import Any

import numpy as np

WIDTH = 0.010  # mm, pyramid base side
HEIGHT = 0.010  # mm, pyramid height
THICKNESS = 0.050  # mm, material under the base plane
SOLIDS = ("box", "multiunion", "tessellated")
WARMUP, CHECK = 200, 200


def _rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # kB on Linux


class _Timed:
    """Stands in for a Geant4 solid and times one named method (the voxelising step).

    The library builders are used unchanged; this proxy only splits their time in two.
    """

    def __init__(self, solid, method: str) -> None:
        self._solid, self._method, self.seconds = solid, method, 0.0

    def __getattr__(self, name):
        attr = getattr(self._solid, name)
        if name != self._method:
            return attr

        def timed(*args):
            t0 = time.perf_counter()
            out = attr(*args)
            self.seconds += time.perf_counter() - t0
            return out

        return timed


class _G4WithTimedSolid:
    """The geant4_pybind module, except that one solid class returns a :class:`_Timed` proxy."""

    def __init__(self, g4, cls: str, method: str, max_voxels: int | None = None) -> None:
        self._g4, self._cls, self._method, self._max_voxels = g4, cls, method, max_voxels
        self.proxy: _Timed | None = None

    @property
    def timed(self) -> _Timed:
        """The proxy of the solid built through this module."""
        assert self.proxy is not None, f"no {self._cls} was built"
        return self.proxy

    def __getattr__(self, name):
        if name != self._cls:
            return getattr(self._g4, name)

        def make(*args):
            solid = getattr(self._g4, name)(*args)
            if self._max_voxels:
                solid.SetMaxVoxels(self._max_voxels)
            self.proxy = _Timed(solid, self._method)
            return self.proxy

        return make


def measure(
    solid_kind: str, n_side: int, events: int, max_voxels: int | None, repeats: int = 3
) -> dict:
    """Build one solid, place it in a world, track geantinos; runs in its own process."""
    from score4.geometry.solids import multiunion_solid, tessellated_solid
    from score4.sim.runtime import import_geant4, resolve_physics
    from score4.surface.spikes import SpikeGrid
    from score4.surface.triangle_mesh import closed_body

    g4 = import_geant4(resolve_physics("lite"))
    rss_import = _rss_mb()
    out: dict[str, Any] = {
        "solid": solid_kind,
        "n_spikes": n_side * n_side,
        "rss_import_mb": rss_import,
    }

    t0 = time.perf_counter()
    grid = SpikeGrid(nx=n_side, ny=n_side, width_x=WIDTH, width_y=WIDTH, mean_height=HEIGHT)
    if solid_kind == "tessellated":
        description = closed_body(grid.top_mesh(), THICKNESS)
        out["facets"] = description.n_faces
    elif solid_kind == "multiunion":
        out["nodes"] = 1 + len(grid.frustums())
    out["numpy_s"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    if solid_kind == "tessellated":
        wrapped = _G4WithTimedSolid(g4, "G4TessellatedSolid", "SetSolidClosed", max_voxels)
        tessellated_solid(wrapped, description, "rough")
        solid, keep = wrapped.timed._solid, ()
    elif solid_kind == "multiunion":
        wrapped = _G4WithTimedSolid(g4, "G4MultiUnion", "Voxelize")
        _, keep = multiunion_solid(wrapped, grid, THICKNESS, "rough")
        solid = wrapped.timed._solid
    else:
        wrapped, keep = None, ()
        solid = g4.G4Box("rough", grid.size_x / 2, grid.size_y / 2, THICKNESS / 2)
    total = time.perf_counter() - t0
    out["voxelise_s"] = wrapped.timed.seconds if wrapped else 0.0
    out["build_s"] = total - out["voxelise_s"]
    out["rss_built_mb"] = _rss_mb()

    out.update(_track(g4, solid, grid, events, repeats))
    out["rss_peak_mb"] = _rss_mb()
    out["rss_delta_mb"] = out["rss_peak_mb"] - rss_import
    _ = keep  # the union's node solids must outlive the run
    return out


def _track(g4, solid, grid, events: int, repeats: int) -> dict:
    """Geantino tracking time through a world holding ``solid``, plus a path-length check."""
    rng = np.random.default_rng(12345)
    n_total = WARMUP + events + CHECK
    xy = rng.uniform(
        [-grid.size_x / 2, -grid.size_y / 2], [grid.size_x / 2, grid.size_y / 2], (n_total, 2)
    )
    z_start = float(grid.heights.max()) + 1e-3
    box_solid = solid.GetEntityType() == "G4Box"
    # Expected path inside the solid for a vertical line: from the top surface to the bottom.
    top = np.zeros(n_total) if box_solid else grid.height_at(xy[:, 0], xy[:, 1])
    expected = top + THICKNESS

    nist = g4.G4NistManager.Instance()
    margin = 0.1
    world_solid = g4.G4Box(
        "world", grid.size_x / 2 + margin, grid.size_y / 2 + margin, THICKNESS + z_start + margin
    )
    world_lv = g4.G4LogicalVolume(world_solid, nist.FindOrBuildMaterial("G4_Galactic"), "world")
    world_pv = g4.G4PVPlacement(None, g4.G4ThreeVector(), world_lv, "world", None, False, 0)
    lv = g4.G4LogicalVolume(solid, nist.FindOrBuildMaterial("G4_Si"), "rough")
    where = g4.G4ThreeVector(0, 0, -THICKNESS / 2) if box_solid else g4.G4ThreeVector()
    g4.G4PVPlacement(None, where, lv, "rough", world_lv, False, 0)

    class Detector(g4.G4VUserDetectorConstruction):
        def Construct(self):
            return world_pv

    class Transport(g4.G4VModularPhysicsList):
        # The C++ ConstructProcess adds transportation; a geantino needs nothing else, no data.
        def ConstructParticle(self):
            g4.G4Geantino.GeantinoDefinition()

    class Gun(g4.G4VUserPrimaryGeneratorAction):
        def __init__(self):
            super().__init__()
            self.gun = g4.G4ParticleGun(1)
            self.gun.SetParticleDefinition(g4.G4Geantino.GeantinoDefinition())
            self.gun.SetParticleEnergy(1.0)
            self.gun.SetParticleMomentumDirection(g4.G4ThreeVector(0, 0, -1))
            self.k = 0

        def GeneratePrimaries(self, event):
            x, y = xy[self.k % len(xy)]
            self.k += 1
            self.gun.SetParticlePosition(g4.G4ThreeVector(float(x), float(y), z_start))
            self.gun.GeneratePrimaryVertex(event)

    paths = np.zeros(n_total)

    class PathInSolid(g4.G4UserSteppingAction):
        def UserSteppingAction(self, step):
            if step.GetPreStepPoint().GetTouchable().GetVolume().GetLogicalVolume() == lv:
                paths[gun.k - 1] += step.GetStepLength()

    run_manager = g4.G4RunManagerFactory.CreateRunManager(g4.G4RunManagerType.Serial)
    detector, physics = Detector(), Transport()
    run_manager.SetUserInitialization(detector)
    run_manager.SetUserInitialization(physics)
    gun = Gun()  # Geant4 aborts if an action exists before the physics list is registered
    run_manager.SetUserAction(gun)
    for cmd in ("/control/verbose 0", "/run/verbose 0", "/event/verbose 0", "/tracking/verbose 0"):
        g4.G4UImanager.GetUIpointer().ApplyCommand(cmd)
    t0 = time.perf_counter()
    run_manager.Initialize()  # closes the geometry: builds the world's navigation voxels
    init_s = time.perf_counter() - t0
    run_manager.BeamOn(WARMUP)
    batches = []
    for _ in range(repeats):  # the machine is shared: the fastest batch is the least disturbed
        t0 = time.perf_counter()
        run_manager.BeamOn(events)
        batches.append(1e6 * (time.perf_counter() - t0) / events)
    gun.k = WARMUP + events  # the check events follow; their expected paths are indexed from here
    stepping = PathInSolid()
    run_manager.SetUserAction(stepping)
    run_manager.BeamOn(CHECK)
    err = float(np.abs(paths[-CHECK:] - expected[-CHECK:]).max())
    return {
        "init_s": init_s,
        "us_per_event": min(batches),
        "us_batches": batches,
        "path_err_mm": err,
        "events": events,
    }


def _spikes(text: str) -> int:
    return int(float(text))


def _row(r: dict) -> str:
    if "error" in r:
        return f"{r['n_spikes']:>8d} {r['solid']:12s} {r['error']}"
    return (
        f"{r['n_spikes']:>8d} {r['solid']:12s} {r['numpy_s']:8.2f} {r['build_s']:8.2f} "
        f"{r['voxelise_s']:8.2f} {r['init_s']:7.2f} {r['rss_peak_mb']:8.0f} "
        f"{r['rss_delta_mb']:8.0f} {r['us_per_event']:9.1f} {r['path_err_mm'] * 1e6:9.3f}"
    )


HEADER = (
    f"{'N':>8s} {'solid':12s} {'numpy s':>8s} {'build s':>8s} {'voxel s':>8s} {'init s':>7s} "
    f"{'RSS MB':>8s} {'dRSS MB':>8s} {'us/event':>9s} {'path nm':>9s}"
)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--max-spikes",
        type=_spikes,
        default=100_000,
        help="largest N of 1e2, 1e3, 1e4, 1e5, 3e5, 1e6 to run (default 1e5)",
    )
    parser.add_argument(
        "--timeout", type=float, default=600.0, help="seconds per case before it is killed"
    )
    parser.add_argument(
        "--events", type=int, default=5000, help="timed geantino events per case (>= 2000)"
    )
    parser.add_argument(
        "--repeats", type=int, default=3, help="timed batches of --events; the fastest is reported"
    )
    parser.add_argument(
        "--solids", default=",".join(SOLIDS), help=f"comma-separated subset of {SOLIDS}"
    )
    parser.add_argument(
        "--tess-max-voxels",
        type=_spikes,
        default=None,
        help="call G4TessellatedSolid::SetMaxVoxels(K) before closing (default: Geant4's)",
    )
    parser.add_argument("--case", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.events < 2000:
        parser.error(f"--events: must be >= 2000 for a stable figure, got {args.events}")
    if args.case:  # child process: one measurement, JSON on the last line of stdout
        kind, n_side = args.case.split(":")
        from score4.sim.runtime import redirect_native_output

        with redirect_native_output(Path(os.devnull)):
            result = measure(kind, int(n_side), args.events, args.tess_max_voxels, args.repeats)
        print(json.dumps(result))
        return

    solids = [s for s in args.solids.split(",") if s]
    for s in solids:
        if s not in SOLIDS:
            parser.error(f"--solids: unknown solid {s!r}; use {', '.join(SOLIDS)}")
    sizes = [n for n in (100, 1000, 10_000, 100_000, 300_000, 1_000_000) if n <= args.max_spikes]
    extra = f", tessellated SetMaxVoxels({args.tess_max_voxels})" if args.tess_max_voxels else ""
    print(
        f"pyramids {WIDTH * 1e3:g} um wide, {HEIGHT * 1e3:g} um high, base {THICKNESS * 1e3:g} um; "
        f"{args.events} geantinos per case{extra}"
    )
    print(HEADER, flush=True)
    for n in sizes:
        n_side = round(math.sqrt(n))
        for kind in solids:
            cmd = [
                sys.executable,
                __file__,
                "--case",
                f"{kind}:{n_side}",
                "--events",
                str(args.events),
                "--repeats",
                str(args.repeats),
            ]
            if args.tess_max_voxels:
                cmd += ["--tess-max-voxels", str(args.tess_max_voxels)]
            try:
                done = subprocess.run(
                    cmd, check=False, capture_output=True, text=True, timeout=args.timeout
                )
            except subprocess.TimeoutExpired:  # subprocess.run kills the child
                r = {
                    "n_spikes": n_side * n_side,
                    "solid": kind,
                    "error": f"> {args.timeout:g} s (killed)",
                }
            else:
                if done.returncode == 0:
                    r = json.loads(done.stdout.strip().splitlines()[-1])
                else:
                    tail = (done.stderr.strip().splitlines() or ["no output"])[-1]
                    r = {
                        "n_spikes": n_side * n_side,
                        "solid": kind,
                        "error": f"failed ({done.returncode}): {tail}",
                    }
            print(_row(r), flush=True)


if __name__ == "__main__":
    main()
