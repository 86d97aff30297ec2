"""CPU per alpha event on rough faces, one tessellated solid per patch vs blocks, and build cost.

    .venv/bin/python benchmarks/bench_surfaces.py [--events 10000] [--slow-events 2000]
        [--cases a,b] [--sizes 256,512] [--warm] [--markdown] [--rounds 3]

``--markdown`` prints the tables of docs/tiling.md (with ``--warm``: the CPU per event; with
``--cases ""``: the build cost), checked by ``make docs-check-all``. ``--warm --faces
1.5,30,100`` runs each case on faces of about 1.5 mm, 3 cm and 10 cm (a whole number of
patches), with ratios to the pyramid face of the same size, the build CPU and the peak RSS;
``--warm --baseline OLD/src`` also runs every case with another score4 checkout's sources
first on the path, interleaved in each round (before/after; each version's ratios are to its
own pyramid face, and the mean deposits of the pyramid and flat faces must agree).
``--rounds N`` (or ``--repeat N``) runs N rounds, each over all cases (and faces, versions) in
turn, and prints each row's median; ``--warmup`` sets the events each ``--warm`` process runs
before the timed ones (200).

First table: each case is a whole ``score4 run`` in its own process (``--jobs 1``, lite physics,
5.3 MeV alphas, isotropic, exponential depth 20 nm below the local surface, the +z face of a
silicon box about 1.5 mm x 1.5 mm, a whole number of patches). Each case runs twice, with
``--events`` (``--slow-events`` for the one-tessellated-solid cases ``*_tess``) and with a
tenth of that; the CPU per event is the difference of the two
processes' CPU times (children's user + system) over the difference of events, so start-up and
geometry building cancel. ``ratio`` is that figure over the equal-height pyramid face's (the
multi-union, score4's fastest rough face) from the same invocation; ``mean MeV`` is the mean
deposit as a check.

``--stages N [--map gauss] [--tolerance auto]`` builds one such patch stage by stage and prints
the CPU, resident memory and peak after each stage; ``--set MODULE.NAME=VALUE`` sets a module
constant first (as in bench_instructions.py).

Second table (``--sizes``): build cost of one patch of a Gaussian random map of n x n pixels
(0.5 um pitch) as ``solid: blocks`` in a fresh process: numpy (cutting the mesh into closed
blocks), Geant4 (solids and placements), the growth of resident memory while Geant4 builds per
facet, the peak RSS of the process and its growth over a process that only imported Geant4.
benchmarks/bench_facet_handoff.py splits Geant4's part per facet.

The machine is shared with other jobs: absolute figures vary by +-30 %; ratios from one
invocation are firmer, and firmer still with ``--repeat N`` (N rounds over all cases, each row
the round with the median CPU per event of its case).

This docstring says what the script measures; what it measured (tables of past runs, with
date and load) is in benchmarks/README.md, section bench_surfaces.py.
"""

from __future__ import annotations

import argparse
import importlib
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml

from score4.runner.run_plan import plan_run

ROOT = Path(__file__).resolve().parents[1]
SURF = ROOT / "examples" / "surfaces"
PYRAMIDS = {"kind": "spikes", "nx": 50, "ny": 50, "width": "10 um", "height": "10 um"}
MEASURED = {
    "kind": "measured",
    "file": str(SURF / "turned_grid.txt"),
    "level": True,
    "crop_x": ["0 um", "30 um"],
    "crop_y": ["0 um", "25 um"],
}


def _yaml(name: str) -> dict:
    return yaml.safe_load((SURF / name).read_text())


#: The Gaussian map of ``--sizes`` (map_spec: 0.5 um pitch, Sq 0.3 um, correlation length 3 um)
#: as a run surface: 1024 x 1024 pixels under ``tolerance: auto`` (simplified: blocks of ~420
#: facets), and 256 x 256 pixels exact (blocks of 2 x 2 pixels) for the same statistics.
BIG_GAUSS = {"kind": "random", "pitch": "0.5 um", "sq": "0.3 um", "corr_length": "3 um", "seed": 1}


#: case -> (surface spec or None for flat, patch size in mm, solid)
CASES = {
    "flat": (None, 0.5, None),
    "pyramids": (PYRAMIDS, 0.5, "multiunion"),
    "pyramids_tess": (PYRAMIDS, 0.5, "tessellated"),
    "pyramids_blocks": (PYRAMIDS, 0.5, "blocks"),
    "pyramids_frustums": (PYRAMIDS, 0.5, "frustums"),
    "spread_tess": ({**PYRAMIDS, "height_sigma": "2 um", "seed": 3}, 0.5, "tessellated"),
    "spread_blocks": ({**PYRAMIDS, "height_sigma": "2 um", "seed": 3}, 0.5, "blocks"),
    "spread_frustums": ({**PYRAMIDS, "height_sigma": "2 um", "seed": 3}, 0.5, "frustums"),
    "bumps_union": ({**PYRAMIDS, "shape": "bump", "n_layers": 4}, 0.5, "multiunion"),
    "bumps_blocks": ({**PYRAMIDS, "shape": "bump", "n_layers": 4}, 0.5, "blocks"),
    "bumps_frustums": ({**PYRAMIDS, "shape": "bump", "n_layers": 4}, 0.5, "frustums"),
    "gauss_tess": (_yaml("random_gaussian.yaml"), 0.256, "tessellated"),
    "gauss_blocks": (_yaml("random_gaussian.yaml"), 0.256, "blocks"),
    "selfaff_tess": (_yaml("self_affine.yaml"), 0.128, "tessellated"),
    "selfaff_blocks": (_yaml("self_affine.yaml"), 0.128, "blocks"),
    "measured_tess": (MEASURED, 0.03, "tessellated"),
    "measured_blocks": (MEASURED, 0.03, "blocks"),
    "simplified_blocks": (
        {**BIG_GAUSS, "nx": 1025, "ny": 1025, "periodic": False, "tolerance": "auto"},
        0.512,
        "blocks",
    ),
    "exact256_blocks": ({**BIG_GAUSS, "nx": 256, "ny": 256, "periodic": True}, 0.128, "blocks"),
}


def config(case: str, events: int, face: float = 1.5) -> dict:
    """Run configuration of ``case`` on a face of about ``face`` x ``face`` mm (a whole number
    of patches); ``<case>_b<N>`` is ``<case>`` with ``block_cells: N``."""
    base, _, cells = case.rpartition("_b")
    block_cells = int(cells) if base in CASES and cells.isdigit() else None
    surface, patch, solid = CASES[base if block_cells else case]
    n = max(1, round(face / patch))
    size_x = size_y = n * patch
    if case.startswith("measured"):  # 30 um x 25 um patches
        size_x, size_y = max(1, round(face / 0.030)) * 0.030, max(1, round(face / 0.025)) * 0.025
    target: dict[str, object] = {
        "name": "crystal",
        "material": "G4_Si",
        "size": [f"{size_x} mm", f"{size_y} mm", "0.3 mm"],
        "position": ["0 mm", "0 mm", "-0.15 mm"],
    }
    data: dict[str, object] = {"physics": "lite"}
    if surface is not None:
        data["surfaces"] = {"s": surface}
        rough: dict[str, object] = {
            "face": "+z",
            "surface": "s",
            "solid": solid,
            "base_thickness": "1 um",
        }
        if block_cells:
            rough["block_cells"] = block_cells
        target["rough"] = [rough]
    data.update(
        targets=[target],
        source={
            "particle": "alpha",
            "energy": "5.3 MeV",
            "direction": "isotropic",
            "surface": {"volume": "crystal", "face": "+z"},
            "depth": {"profile": "exponential", "mean": "20 nm"},
        },
        run={"events": events, "seed": 1},
        output={"histogram": {"bins": 106, "max": "5.3 MeV"}},
    )
    return data


def run_case(case: str, events: int, tmp: Path) -> tuple[float, float]:
    """(CPU seconds of the whole run process, mean deposit MeV)."""
    cfg = tmp / f"{case}_{events}.yaml"
    cfg.write_text(yaml.safe_dump(config(case, events)))
    out = tmp / f"{case}_{events}.h5"
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    cmd = [
        sys.executable,
        "-m",
        "score4.cli.main",
        "run",
        str(cfg),
        "--out",
        str(out),
        "-q",
        "--overwrite",
    ]
    subprocess.run(cmd, check=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime
    from score4.runner.output import read_results

    return cpu, float(read_results(out).scores["edep"]["crystal"].mean())


def warm_case(case: str, events: int, face: float = 1.5, warmup: int = 200) -> None:
    """Child process: build ``case`` once, run ``warmup`` events, then time ``events`` events
    (CPU of this process) in one BeamOn; print ms per event, the mean deposit, the CPU seconds
    of building and the peak RSS (MB)."""

    from score4.inputs.config import parse_config
    from score4.sim.runtime import resolve_physics
    from score4.sim.simulation import Simulation

    b0 = time.process_time()
    config_ = parse_config(config(case, events, face))
    sim = Simulation(plan_run(config_, physics=resolve_physics("lite")))
    build = time.process_time() - b0
    primaries = sim.source.primaries(np.random.default_rng(5), 0, warmup + events)
    sim.run(primaries.select_events(0, warmup), 1)
    c0 = time.process_time()
    scores = sim.run(primaries.select_events(warmup, warmup + events), 2)
    per = (time.process_time() - c0) / events
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    mean = float(scores["edep"][:, 0].mean())
    print(f"WARM {per * 1e3:.4f} {mean:.4f} {build:.2f} {rss:.0f}")


#: docs/tiling.md's labels of the cases: (surface, solid)
LABELS = {
    "flat": ("flat face (no rough layer)", "-"),
    "pyramids": ("pyramids 10 um, equal heights", "multiunion (auto)"),
    "spread": ("pyramids 10 um, 2 um height spread", "frustums (auto)"),
    "bumps": ("bumps, 4 layers, equal heights", "frustums (auto)"),
    "gauss": ("Gaussian random field, 1 um pixels", "blocks (auto)"),
    "selfaff": ("self-affine random field, 0.5 um pixels", "blocks (auto)"),
    "measured": ("measured map, 60 x 50 pixels", "blocks (auto)"),
    "simplified": ("Gaussian map 1024 x 1024 pixels of 0.5 um, tolerance auto", "blocks (auto)"),
    "exact256": ("the same statistics, 256 x 256 pixels, exact", "blocks (auto)"),
}


def label(case: str) -> tuple[str, str]:
    """(surface, solid) of a case as docs/tiling.md names them."""
    surface, auto = LABELS[case.split("_")[0]]
    solid = CASES[case][2] or "-"
    return surface, auto if auto.startswith(solid) else solid


def warm_table(
    cases: list[str],
    events: int,
    repeat: int,
    slow_events: int,
    markdown: bool = False,
    faces: tuple[float, ...] = (1.5,),
    baseline: str | None = None,
    warmup: int = 200,
) -> None:
    """CPU per event with building and start-up left out: one process per case, face, version
    and round; the rounds interleave all cases, faces and versions (this checkout's sources and
    ``baseline``'s, a ``src`` folder, if given). Ratios are to the equal-pyramid face of the
    same size and version."""
    if markdown:
        from stamp import stamp  # this folder is on sys.path when run as a script

        print(stamp())
    else:
        print(f"load average at start: {os.getloadavg()}")
    from stamp import child_figures  # this folder is on sys.path when run as a script

    versions = {"this": None} if baseline is None else {"this": None, "baseline": baseline}
    runs: dict[tuple[str, float, str], list[tuple[float, ...]]] = {}
    failures: list[str] = []
    for _ in range(repeat):
        for face in faces:
            for case in cases:
                for version, src in versions.items():
                    n = slow_events if case.endswith("_tess") else events
                    env = [] if src is None else ["env", f"PYTHONPATH={os.path.abspath(src)}"]
                    cmd = [*env, sys.executable, __file__, "--warm-child", case, "--events", str(n)]
                    cmd += ["--warmup", str(warmup)]
                    figures = child_figures([*cmd, "--faces", str(face)], "WARM")
                    if isinstance(figures, str):
                        failures.append(f"{case} {face} mm {version}: {figures}")
                        print(failures[-1])
                        continue
                    runs.setdefault((case, face, version), []).append(figures)

    def med(key: tuple[str, float, str], k: int = 0) -> float:
        return float(np.median([r[k] for r in runs[key]])) if key in runs else float("nan")

    one_face = len(faces) == 1
    if markdown:
        head = "| surface | solid |" + ("" if one_face else " face mm |")
        print(head + " ms CPU per alpha event | ratio to equal pyramids |")
        print("| --- " * (head.count("|") + 1) + "|")
        for case, face, version in runs:
            if version != "this":
                continue
            per, ref = med((case, face, version)), med(("pyramids", face, version))
            where = "" if one_face else f" {face:g} |"
            print(f"| {' | '.join(label(case))} |{where} {per:.3f} | {per / ref:.2f} |")
        _fail_on(failures)
        return
    print(f"load average at end: {os.getloadavg()}")
    if baseline is not None:
        print(f"baseline: {baseline}")
    print(
        f"{'case':18s} {'face mm':>7s} {'version':>8s} {'ms/event':>9s} {'ratio':>6s} "
        f"{'build s':>7s} {'RSS MB':>6s} {'mean MeV':>8s}  all rounds ms/event"
    )
    for key in sorted(runs, key=lambda k: (k[1], cases.index(k[0]), k[2] != "this")):
        case, face, version = key
        per, ref = med(key), med(("pyramids", face, version))
        every = " ".join(f"{r[0]:.3f}" for r in runs[key])
        print(
            f"{case:18s} {face:7g} {version:>8s} {per:9.3f} {per / ref:6.2f} {med(key, 2):7.2f} "
            f"{med(key, 3):6.0f} {med(key, 1):8.4f}  {every}"
        )
    _fail_on(failures)


def _fail_on(failures: list[str]) -> None:
    """Exit with status 1 if a case failed (its row is missing: the table is not the docs')."""
    if failures:
        raise SystemExit(f"{len(failures)} case run(s) failed: {'; '.join(failures)}")


def _resident() -> int:
    """The process's resident memory now, bytes."""
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def build_case(n: int, tolerance: str = "0", kind: str = "gauss") -> None:
    """Child process: build one n x n pixel patch as blocks, print numpy s, Geant4 s, RSS and
    the growth of resident memory while Geant4 builds, per facet; then the mesh's tolerance (um)
    and its largest vertical error at the map's samples (um).

    ``tolerance``: the surface's ``tolerance`` (a length, ``0`` the exact mesh, or ``auto``).
    ``kind``: ``gauss`` (the Gaussian map below, correlation length 6 pixels), ``noise`` (the
    same with a correlation length of 2 pixels, the shortest allowed: noise-like) or ``measured``
    (examples/surfaces/measured.yaml as it is, 76 x 59 pixels; ``n`` is ignored).

    The blocks are built as a run builds them (``place_blocks``: each block's closed body is
    cut, handed to Geant4 and dropped); a first pass only cuts the bodies, for the numpy time
    (with the exact top mesh), and Geant4's time is the rest of ``place_blocks``.
    """

    from score4.sim.runtime import import_geant4, resolve_physics

    g4 = import_geant4(resolve_physics("lite"))
    rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    from score4.geometry.block_solids import place_blocks
    from score4.surface.block_cut import iter_block_bodies
    from score4.surface.spec import build_surface

    tm = time.process_time()
    surface = build_surface(map_spec(n, tolerance, kind))
    mesh = surface.top_mesh  # the mesh, built once (counted in numpy)
    t0 = time.process_time()
    blocks = facets = 0
    for body in iter_block_bodies(surface, 1e-3):
        blocks, facets = blocks + 1, facets + body.n_faces
    t1 = time.process_time()
    mat = g4.G4NistManager.Instance().FindOrBuildMaterial("G4_Si")
    box = g4.G4Box("m", 1.0, 1.0, 1.0)
    mother = g4.G4LogicalVolume(box, mat, "m")
    resident = _resident()
    t2 = time.process_time()
    keep = place_blocks(g4, surface, 1e-3, None, mat, mother, 0.0, "p")
    t3 = time.process_time()
    per_facet = (_resident() - resident) / facets
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    numpy_s, g4_s = t1 - tm, (t3 - t2) - (t1 - t0)
    print(
        f"{n} {blocks} {facets} {numpy_s:.2f} {g4_s:.2f} {rss:.0f} {rss - rss0:.0f} {per_facet:.0f}"
        f" {surface.mesh_tolerance * 1e3:.4g} {max_error(surface, mesh) * 1e3:.6g} {mesh.n_faces}"
    )
    del keep


def stages_case(n: int, tolerance: str = "auto", kind: str = "gauss") -> None:
    """Child process: build_case's patch stage by stage, printing each stage's CPU seconds, the
    resident memory after it and the peak so far (MB): importing Geant4, the height map, its
    (simplified) mesh, the cut into blocks, and ``place_blocks`` (cutting each block again,
    handing it to Geant4, placing it). Where the build's memory goes (issue 25 item 2): the C
    heap in use (glibc ``mallinfo2``: numpy's arrays and Geant4's objects alive, without the
    freed memory the process keeps) against the resident memory."""
    from g4_facet_memory import heap_in_use  # this folder is on sys.path when run as a script

    last = [time.process_time()]

    def stage(name: str) -> None:
        now = time.process_time()
        peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
        print(
            f"| {name} | {now - last[0]:.2f} | {_resident() / 2**20:.0f} | {peak:.0f} "
            f"| {heap_in_use() / 2**20:.0f} |"
        )
        last[0] = now

    print("| stage | CPU s | RSS after, MB | peak so far, MB | C heap in use, MB |")
    print("| --- | --- | --- | --- | --- |")
    stage("Python, numpy, score4's imports")
    from score4.sim.runtime import import_geant4, resolve_physics

    g4 = import_geant4(resolve_physics("lite"))
    stage("import Geant4")
    from score4.geometry.block_solids import place_blocks
    from score4.surface.block_cut import block_rects
    from score4.surface.spec import build_surface

    surface = build_surface(map_spec(n, tolerance, kind))
    _ = surface.placed_map
    stage(f"height map {n} x {n} ({kind})")
    mesh = surface.top_mesh
    stage(f"mesh: {mesh.n_faces} top facets (tolerance {surface.mesh_tolerance * 1e3:.3g} um)")
    rects = block_rects(surface, None)[1]
    stage(f"cut into {len(rects)} blocks (block_rects; place_blocks cuts again)")
    mat = g4.G4NistManager.Instance().FindOrBuildMaterial("G4_Si")
    mother = g4.G4LogicalVolume(g4.G4Box("m", 1.0, 1.0, 1.0), mat, "m")
    keep = place_blocks(g4, surface, 1e-3, None, mat, mother, 0.0, "p")
    stage("place_blocks: bodies cut, Geant4 solids, volumes, placements")
    del keep


def map_spec(n: int, tolerance: str, kind: str) -> dict:
    """The n x n-pixel map of build_case (a surface description)."""
    if kind == "measured":
        spec = yaml.safe_load((SURF / "measured.yaml").read_text())
        return {**spec, "file": str(SURF / spec["file"]), "tolerance": tolerance}
    spec = {"kind": "random", "nx": n + 1, "ny": n + 1, "pitch": "0.5 um", "sq": "0.3 um"}
    corr = "1 um" if kind == "noise" else "3 um"
    return {**spec, "corr_length": corr, "periodic": False, "seed": 1, "tolerance": tolerance}


def max_error(surface, mesh) -> float:
    """Largest |z_mesh - z_map| over the map's samples, mm, by matplotlib's own interpolation
    (0 for the exact mesh, whose vertices are the samples: matplotlib needs minutes for 2 M
    triangles)."""
    import matplotlib.tri as mtri

    if surface.mesh_tolerance == 0:
        return 0.0

    hm = surface.placed_map
    tri = mtri.Triangulation(mesh.vertices[:, 0], mesh.vertices[:, 1], mesh.faces)
    xx, yy = np.meshgrid(hm.x, hm.y)
    z = mtri.LinearTriInterpolator(tri, mesh.vertices[:, 2])(xx, yy)
    return float(np.abs(z - hm.heights).max())


def tolerance_table(n: int, maps: list[str], tolerances: list[str], repeat: int) -> None:
    """docs/surfaces.md's table: facets, build CPU and peak memory of one simplified map patch
    per tolerance (medians of ``repeat`` interleaved rounds), and the largest error measured."""
    from stamp import stamp  # this folder is on sys.path when run as a script

    print(stamp())
    runs: dict[tuple[str, str], list[list[str]]] = {}
    for _ in range(repeat):
        for m in maps:
            for entry in tolerances:  # "0.1um", or "gauss:0.1um" for that map only
                on, _, t = entry.rpartition(":")
                if on not in ("", m):
                    continue
                r = subprocess.run(
                    [
                        sys.executable,
                        __file__,
                        "--build-child",
                        str(n),
                        "--tolerance",
                        t,
                        "--map",
                        m,
                    ],
                    check=True,
                    capture_output=True,
                    text=True,
                )
                runs.setdefault((m, t), []).append(r.stdout.split()[-11:])
    print(
        "| map | tolerance um | max error um | top facets | facets with walls | blocks | numpy s "
        "| Geant4 s | build CPU s | peak RSS MB |"
    )
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for (m, t), rows in runs.items():

        def med(i: int, rows: list[list[str]] = rows) -> float:
            return float(np.median([float(r[i]) for r in rows]))

        f = rows[0]
        pixels = "76 x 59" if m == "measured" else f"{n} x {n}"
        print(
            f"| {m} {pixels} | {t} ({f[8]}) | {f[9]} | {int(f[10]):,} | {int(f[2]):,} | {f[1]} | "
            f"{med(3):.2f} | "
            f"{med(4):.2f} | {med(3) + med(4):.2f} | {med(5):.0f} |".replace(",", " ")
        )


def build_table(sizes: list[int]) -> None:
    """docs/tiling.md's build-cost table: one patch of an n x n pixel map as blocks."""
    from stamp import stamp  # this folder is on sys.path when run as a script

    print(stamp())
    print("| map | blocks | facets | numpy s | Geant4 s | bytes per facet | peak RSS MB |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for n in sizes:
        r = subprocess.run(
            [sys.executable, __file__, "--build-child", str(n), "--tolerance", "0"],
            check=True,
            capture_output=True,
            text=True,
        )
        f = r.stdout.split()[-11:]
        facets = f"{int(f[2]):,}".replace(",", " ")
        print(f"| {n} x {n} pixels | {f[1]} | {facets} | {f[3]} | {f[4]} | {f[7]} | {f[5]} |")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--events", type=int, default=10000)
    p.add_argument(
        "--slow-events", type=int, default=2000, help="events of the *_tess cases (10-70x slower)"
    )
    p.add_argument("--cases", default=",".join(CASES))
    p.add_argument("--sizes", default="256,512,1024,2048")
    p.add_argument(
        "--repeat",
        "--rounds",
        type=int,
        default=1,
        help="interleaved rounds over the cases; each row is the median",
    )
    p.add_argument(
        "--warm",
        action="store_true",
        help="instead: one process per case, --warmup events, then --events timed",
    )
    p.add_argument(
        "--warmup", type=int, default=200, help="--warm: events run before the timed ones"
    )
    p.add_argument("--markdown", action="store_true", help="docs/tiling.md's tables")
    p.add_argument(
        "--faces", default="1.5", help="--warm: face sides, mm (e.g. 1.5,30,100), each a table row"
    )
    p.add_argument(
        "--baseline",
        help="--warm: also time the score4 sources in this src folder, interleaved (before/after)",
    )
    p.add_argument("--build-child", type=int, help=argparse.SUPPRESS)
    p.add_argument(
        "--tolerance",
        default="0",
        help="--build-child: the map's tolerance (a length such as '0.1 um', 0 exact, or auto)",
    )
    p.add_argument(
        "--map", default="gauss", help="--build-child: gauss, noise or measured (build_case)"
    )
    p.add_argument(
        "--tolerances",
        help="instead: the simplified-map table (docs/surfaces.md): for each --map (comma list) "
        "and each tolerance here (comma list; MAP:TOLERANCE for one map only), one n x n patch "
        "(--sizes' first) built in its own process, --repeat interleaved rounds, medians",
    )
    p.add_argument("--warm-child", help=argparse.SUPPRESS)
    p.add_argument(
        "--set",
        action="append",
        default=[],
        dest="sets",
        metavar="MODULE.NAME=VALUE",
        help="--stages, --build-child: set a module constant first (as bench_instructions.py)",
    )
    p.add_argument(
        "--stages",
        type=int,
        metavar="N",
        help="instead: one N x N patch (--map, --tolerance) built stage by stage in this process: "
        "CPU, resident memory and peak after each stage",
    )
    a = p.parse_args()
    for item in a.sets:
        target, _, value = item.partition("=")
        module, _, name = target.rpartition(".")
        mod = importlib.import_module(module)
        setattr(mod, name, type(getattr(mod, name))(float(value)))
    if a.stages:
        stages_case(a.stages, a.tolerance, a.map)
        return
    if a.build_child:
        build_case(a.build_child, a.tolerance, a.map)
        return
    if a.tolerances:
        tolerance_table(
            int(a.sizes.split(",")[0]), a.map.split(","), a.tolerances.split(","), a.repeat
        )
        return
    if a.warm_child:
        warm_case(a.warm_child, a.events, float(a.faces), a.warmup)
        return
    if a.warm:
        cases = [c for c in a.cases.split(",") if c]
        faces = tuple(float(f) for f in a.faces.split(",") if f)
        warm_table(
            cases, a.events, a.repeat, a.slow_events, a.markdown, faces, a.baseline, a.warmup
        )
        return
    cases = [c for c in a.cases.split(",") if c]
    if a.markdown and not cases:
        build_table([int(s) for s in a.sizes.split(",") if s])
        return
    runs: dict[str, list] = {}
    failed: set[str] = set()
    print(f"load average at start: {os.getloadavg()}")
    with tempfile.TemporaryDirectory() as d:
        for _ in range(a.repeat):  # rounds over all cases, so a load change hits them alike
            for case in cases:
                if case in failed:
                    continue
                events = a.slow_events if case.endswith("_tess") else a.events
                try:
                    big, mean = run_case(case, events, Path(d))
                    small, _ = run_case(case, events // 10, Path(d))
                except subprocess.CalledProcessError:
                    print(f"{case}: the run failed (see its error above)")
                    failed.add(case)
                    continue
                per = (big - small) / (events - events // 10)
                runs.setdefault(case, []).append((per, big, small, mean))
    print(f"load average at end: {os.getloadavg()}")
    # the round with the median CPU per event, per case
    rows = {c: sorted(r)[(len(r) - 1) // 2] for c, r in runs.items()}
    ref = rows.get("pyramids", (float("nan"),))[0]
    print(
        f"{'case':18s} {'ms/event':>9s} {'ratio':>6s} {'CPU big s':>9s} {'CPU small s':>11s} "
        f"{'mean MeV':>8s}  all rounds ms/event"
    )
    for case, (per, big, small, mean) in rows.items():
        every = " ".join(f"{r[0] * 1e3:.3f}" for r in runs[case])
        print(
            f"{case:18s} {per * 1e3:9.3f} {per / ref:6.2f} {big:9.2f} {small:11.2f} {mean:8.3f}"
            f"  {every}"
        )
    sizes = [int(s) for s in a.sizes.split(",") if s]
    if sizes:
        print(
            f"\n{'pixels':>7s} {'blocks':>6s} {'facets':>8s} {'numpy s':>7s} {'G4 s':>6s} "
            f"{'RSS MB':>6s} {'dRSS MB':>7s} {'B/facet':>7s}"
        )
    for n in sizes:
        r = subprocess.run(
            [sys.executable, __file__, "--build-child", str(n), "--tolerance", "0"],
            check=False,
            capture_output=True,
            text=True,
        )
        if r.returncode:
            print(f"{n:7d} failed: {r.stderr.strip().splitlines()[-1:]}")
            continue
        f = r.stdout.split()[-11:]
        print(
            f"{int(f[0]):7d} {int(f[1]):6d} {int(f[2]):8d} {f[3]:>7s} {f[4]:>6s} "
            f"{f[5]:>6s} {f[6]:>7s} {f[7]:>7s}"
        )


if __name__ == "__main__":
    main()
