"""``python -m score4.geometry.gdml_reader FILE.gdml OUT.json``: the volume model of a GDML world.

Run as a subprocess by :func:`score4.world.gdml_files.load_geometry_model`, so that the
process reading the configuration never imports Geant4, and so that Geant4 aborting on a broken
GDML file (it calls ``abort()`` on fatal read errors) ends this process only.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path


def main(argv: list[str]) -> int:
    path, out = Path(argv[0]), Path(argv[1])
    from ..sim.runtime import import_geant4, resolve_physics
    from .gdml import extract_model, read_gdml

    g4 = import_geant4(resolve_physics("lite"))  # reading geometry needs no physics data
    _parser, world = read_gdml(g4, path)
    if world is None:
        print("score4: no world volume: the file has no <setup> with a <world ref=...>", flush=True)
        return 3
    model = extract_model(g4, world, str(path), [str(path)])
    out.write_text(json.dumps(model))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
