"""Rough shares of the layers on boolean faces, and what the kept area estimate saves.

    .venv/bin/python tools/figures/boolean_shares.py

Writes the test world of tests/test_boolean_rough.py (a copper box less a tube, a disk with a
post on it, LEGEND's P00664B) and builds the scene of three rough faces with 0.4 mm patches of
5 x 5 pyramids 20 um high: the bore of the box (the subtracted tube's wall), the box's +z face
around it, and the post's wall. Prints a Markdown table (volume, face, kept cells, rough share)
and the CPU time of the first scene build (areas estimated, in an empty cache folder) and of a
second one in a new process (areas read back). Then the same table for the second test world
(tests/test_boolean_faces.py): a box's +z face around a post standing on it, the disk's +z face
around its post with the post's wall, the bore a subtracted cone leaves, and the sphere face of
an orb less a box (0.1 mm patches of 10 x 10 pyramids 10 um high), and the six side planes of
a G4Polyhedra less a box over one corner. Checked by docs/geometry.md (check
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
#: in the second test world: faces of a union partly covered by its other part (a box's +z
#: face around a post on it, a disk's +z face around a post with the post's wall), and the
#: bore a subtracted cone leaves
MORE_FACES = {
    "postbox": ["first.+z"],
    "stack": ["first.+z", "second.outer"],
    "conebore": ["second.outer"],
    "orbcut": ["first.outer"],
    "hexcut": ["first.outer"],
}
#: the orb (r 3 mm) of the second world takes 0.1 mm patches of 10 x 10 pyramids 10 um high
SMALL = {"kind": "spikes", "nx": 10, "ny": 10, "width": "10 um", "height": "10 um"}
SURFACE = {"kind": "spikes", "nx": 5, "ny": 5, "width": "80 um", "height": "20 um"}


def _plane(layer) -> str:
    """`` (plane k)`` for a layer on one plane of a face of several planes."""
    part = getattr(layer, "part", -1)
    return f" (plane {part})" if part >= 0 else ""


def _build(gdml: str, more: bool) -> None:
    """Build the scene and print its table and the build's CPU time."""
    from score4.inputs.config import parse_config
    from score4.world.resolve import build_scene

    data = {
        "physics": "lite",
        "world": {"gdml": gdml},
        "surfaces": {"p": SURFACE, "s": SMALL},
        "targets": [
            {
                "volume": v,
                "rough": [{"face": f, "surface": "s" if v == "orbcut" else "p"} for f in faces],
            }
            for v, faces in (MORE_FACES if more else FACES).items()
        ],
        "source": {
            "particle": "geantino",
            "energy": "1 MeV",
            "surface": {"volume": "stack" if more else "cutbox"},
        },
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
            f"| {layer.target.name} | {layer.config.face_name}{_plane(layer)} | {kept} "
            f"| {100 * layer.rough_share:.2f} % |"
        )
    print(f"scene build: {cpu:.2f} s CPU")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("gdml", nargs="?", help="build the scene of this world only (the child)")
    parser.add_argument("--more", action="store_true", help="(the child) the second world")
    args = parser.parse_args()
    if args.gdml:
        _build(args.gdml, args.more)
        return
    sys.path.insert(0, str(HERE.parents[2] / "tests"))
    from helpers.boolean_worlds import write_more_world, write_world

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
        more = write_more_world(Path(folder) / "more.gdml")
        out = subprocess.run(
            [sys.executable, str(HERE), str(more), "--more"],
            env=env,
            check=True,
            capture_output=True,
            text=True,
        ).stdout.splitlines()
        print("\nSecond world (union faces partly covered, a cone's bore, an orb, a polyhedra):")
        print("\n".join(out[:-1]))


if __name__ == "__main__":
    main()
