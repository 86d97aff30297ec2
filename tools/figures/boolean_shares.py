"""Rough shares of the layers on boolean faces, and what the kept area estimate saves.

    .venv/bin/python tools/figures/boolean_shares.py

Writes the test world of tests/test_boolean_rough.py (a copper box less a tube, a disk with a
post on it, LEGEND's P00664B) and builds the scene of three rough faces with 0.4 mm patches of
5 x 5 pyramids 20 um high: the bore of the box (the subtracted tube's wall), the box's +z face
around it, and the post's wall. Prints a Markdown table (volume, face, kept cells, rough share)
and the CPU time of the first scene build (areas estimated, in an empty cache folder) and of a
second one in a new process (areas read back). Checked by docs/geometry.md (check
``boolean-shares``).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve()
FACES = {"cutbox": ["second.outer", "first.+z"], "stack": ["second.outer"]}
SURFACE = {"kind": "spikes", "nx": 5, "ny": 5, "width": "80 um", "height": "20 um"}


def _build(gdml: str) -> None:
    """Build the scene and print its table and the build's CPU time."""
    from score4.inputs.config import parse_config
    from score4.world.resolve import build_scene

    data = {
        "physics": "lite",
        "world": {"gdml": gdml},
        "surfaces": {"p": SURFACE},
        "targets": [
            {"volume": v, "rough": [{"face": f, "surface": "p"} for f in faces]}
            for v, faces in FACES.items()
        ],
        "source": {"particle": "geantino", "energy": "1 MeV", "surface": {"volume": "cutbox"}},
        "run": {"events": 10, "seed": 3},
    }
    config = parse_config(data)
    t = time.process_time()
    scene = build_scene(config)
    cpu = time.process_time() - t
    print("| volume | face | kept cells | rough share |")
    print("|---|---|---|---|")
    for layer in scene.layers:
        kept = int(layer.mask.sum()) if layer.mask is not None else layer.cell_variants.size
        print(
            f"| {layer.target.name} | {layer.config.face_name} | {kept} "
            f"| {100 * layer.rough_share:.2f} % |"
        )
    print(f"scene build: {cpu:.2f} s CPU")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("gdml", nargs="?", help="build the scene of this world only (the child)")
    args = parser.parse_args()
    if args.gdml:
        _build(args.gdml)
        return
    sys.path.insert(0, str(HERE.parents[2] / "tests"))
    from helpers.boolean_worlds import write_world

    with tempfile.TemporaryDirectory(prefix="score4-boolean-") as folder:
        gdml = write_world(Path(folder) / "boolean.gdml")
        env = {**os.environ, "XDG_CACHE_HOME": str(Path(folder) / "cache")}
        for label in ("areas estimated", "areas from the cache"):
            out = subprocess.run(
                [sys.executable, str(HERE), str(gdml)],
                env=env,
                check=True,
                capture_output=True,
                text=True,
            ).stdout.splitlines()
            if label == "areas estimated":
                print("\n".join(out[:-1]))
            print(f"{out[-1]} ({label})")


if __name__ == "__main__":
    main()
