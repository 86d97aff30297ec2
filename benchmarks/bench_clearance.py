"""CPU time of the clearance check of a LEGEND BEGe's whole surface rough (examples/rough_hpge/
po210_whole_rough.yaml: every face, 10 um pyramids; its layers against each other and the world).

    .venv/bin/python benchmarks/bench_clearance.py [--rounds 5] [--baseline OLD/src]
        [--share 0.5,0.1] [--no-axis] [--case bege|module]

The scene is built once per child process without its check (examples/bege/write_bege.py
--metadata writes the GDML), then ``check_clearance`` runs ``--rounds`` times; the figure is the
median CPU time (``time.process_time``) of the rounds. ``--share``: the resolution of the
certified search as shares of the thinner layer (``RESOLUTION_SHARE``; 0.1 is the default
since session 11, 0.5 before). ``--baseline``: the same with another source tree first on the
path (``git archive OLD src``), interleaved with this tree's rounds. ``--no-axis``: this tree's
cases also with every pair searched over azimuth (no half-plane search of coaxial round pairs).
``--case module``: the detector module instead (examples/detector_module/po210_1um.yaml: a flat
layer on the crystal's +x face against its sisters, a frame that is a box less a box, eight
clamps and a housing, searched by the flat layer's certified search since session 13).
"""

from __future__ import annotations

import argparse
import json
import os
import runpy
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parent.parent


def child(share: float | None, rounds: int, no_axis: bool = False, case: str = "bege") -> None:
    """Build the scene without its check, then time the check (prints JSON)."""
    import score4.world.clearance as clearance
    from score4.inputs.config import parse_config
    from score4.world import resolve

    work = Path(tempfile.mkdtemp())
    if case == "module":
        gdml = work / "module.gdml"
        runpy.run_path(str(ROOT / "examples" / "detector_module" / "write_module.py"))["module"](
            gdml
        )
        config = ROOT / "examples" / "detector_module" / "po210_1um.yaml"
    else:
        gdml = work / "bege.gdml"
        runpy.run_path(str(ROOT / "examples" / "bege" / "write_bege.py"), run_name="write")["main"](
            str(gdml), metadata=True
        )
        config = ROOT / "examples" / "rough_hpge" / "po210_whole_rough.yaml"
    data = yaml.safe_load(config.read_text())
    data["world"]["gdml"] = str(gdml)
    resolve.__dict__["check_clearance"] = lambda scene: None  # built without its check
    scene = resolve.build_scene(parse_config(data))
    if share is not None:
        clearance.RESOLUTION_SHARE = share
    if no_axis:  # every pair searched over azimuth too (as before session 11)
        clearance._round_layer = lambda layer: False
    times = []
    for _ in range(rounds):
        t0 = time.process_time()
        clearance.check_clearance(scene)
        times.append(time.process_time() - t0)
    print(json.dumps({"times": times, "layers": len(scene.layers)}))


def run(src: Path, share: float | None, rounds: int, no_axis: bool = False, case: str = "") -> dict:
    env = dict(os.environ, PYTHONPATH=str(src))
    args = [sys.executable, __file__, "--child", "--rounds", str(rounds), "--case", case]
    if no_axis:
        args.append("--no-axis")
    if share is not None:
        args += ["--share", str(share)]
    done = subprocess.run(args, env=env, capture_output=True, text=True, check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--share", default="")
    ap.add_argument("--baseline", type=Path)
    ap.add_argument("--child", action="store_true")
    ap.add_argument("--case", default="bege", choices=["bege", "module"])
    ap.add_argument(
        "--no-axis",
        action="store_true",
        help="this tree's cases also without the half-plane search of coaxial round pairs",
    )
    args = ap.parse_args()
    if args.child:
        child(float(args.share) if args.share else None, args.rounds, args.no_axis, args.case)
        return
    cases: list[tuple[str, Path, float | None, bool]] = []
    if args.baseline is not None:
        cases.append(("baseline", args.baseline.resolve(), None, False))
    shares: list[float | None] = [float(s) for s in args.share.split(",") if s] or [None]
    for no_axis in [False, True] if args.no_axis else [False]:
        cases += [
            (
                "this tree"
                + (f", share {s}" if s else "")
                + (", no half-plane search" if no_axis else ""),
                ROOT / "src",
                s,
                no_axis,
            )
            for s in shares
        ]
    sys.path.insert(0, str(Path(__file__).parent))
    from stamp import stamp  # this folder

    print(stamp())
    print(f"case: {args.case}")
    times: dict[str, list[float]] = {name: [] for name, _, _, _ in cases}
    for _ in range(args.rounds):  # interleaved: one check per case and child
        for name, src, share, no_axis in cases:
            times[name] += run(src, share, 1, no_axis, args.case)["times"]
    for name, t in times.items():
        print(
            f"{name}: clearance check {statistics.median(t):.3f} s CPU (median of {len(t)}, "
            f"{min(t):.3f}-{max(t):.3f})"
        )
    print(f"load {os.getloadavg()[0]:.1f} at the end")


if __name__ == "__main__":
    main()
