"""``python -m score4.geometry.gdml_reader FILE.gdml OUT.json``: the volume model of a GDML world.

Run as a subprocess by :func:`score4.world.gdml_files.load_geometry_model`, so that the
process reading the configuration never imports Geant4, and so that Geant4 aborting on a broken
GDML file (it calls ``abort()`` on fatal read errors) ends this process only.
"""

from __future__ import annotations

import json
import re
import sys
import tempfile
from pathlib import Path


def main(argv: list[str]) -> int:
    path, out = Path(argv[0]), Path(argv[1])
    from ..sim.runtime import import_geant4, resolve_physics
    from ..world.gdml_files import detector_metadata
    from .gdml import extract_model, read_gdml

    g4 = import_geant4(resolve_physics("lite"))  # reading geometry needs no physics data
    _parser, world = read_gdml(g4, path)
    if world is None:
        print("score4: no world volume: the file has no <setup> with a <world ref=...>", flush=True)
        return 3
    model = extract_model(g4, world, str(path), [str(path)])
    model["overlaps"] = own_overlaps(world)
    model["metadata"] = detector_metadata(path)
    out.write_text(json.dumps(model))
    return 0


#: Surface points per placement for the check of a GDML file's own overlaps (Geant4's default).
OVERLAP_POINTS = 1000
_OVERLAP = re.compile(
    r"Overlap is detected for volume (\S+?)(?::\d+)?(?: \([^)]*\))? with (?:its mother volume )?"
    r"(\S+?)(?::\d+)?(?: \([^)]*\))?\s*\n[^\n]*? by ([-+0-9.eE]+ ?\w+)"
)


def own_overlaps(world) -> list[dict]:
    """The overlaps of a GDML world's own volumes (Geant4 ``CheckOverlaps``, each logical
    volume's daughters once): ``[{"volumes": [a, b], "by": "1 mm"}]``, each pair once."""
    from ..sim.runtime import redirect_native_output
    from .check import check_placements

    with tempfile.TemporaryDirectory(prefix="score4-overlaps-") as folder:
        log = Path(folder) / "geant4.log"
        with redirect_native_output(log):
            report = check_placements(world, OVERLAP_POINTS, 0.0)
        text = log.read_text(errors="replace") if report.overlaps else ""
    found: dict[frozenset, dict] = {}
    for a, b, depth in _OVERLAP.findall(text):
        found.setdefault(frozenset((a, b)), {"volumes": sorted((a, b)), "by": depth})
    return list(found.values())


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
