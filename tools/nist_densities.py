"""Write ``src/score4/data/nist_densities.json``: the density of every Geant4 NIST material.

The process that reads a run configuration never imports Geant4, yet the run record needs the
mass of every scored volume (:mod:`score4.runner.normalisation`). This script asks Geant4 itself
(``G4NistManager``) for each NIST material's density and writes the table that score4 ships.
Run it again when geant4_pybind moves to a new Geant4 (``tests/test_normalisation.py`` compares
the table with the installed Geant4 and fails when they differ)::

    .venv/bin/python tools/nist_densities.py
"""

from __future__ import annotations

import json
from pathlib import Path

OUT = Path(__file__).resolve().parents[1] / "src" / "score4" / "data" / "nist_densities.json"


def nist_densities() -> tuple[str, dict[str, float]]:
    """(Geant4 version, {NIST material name: density in g/cm3}) from the installed Geant4."""
    from score4.sim.runtime import geant4_version, import_geant4, resolve_physics

    g4 = import_geant4(resolve_physics("lite"))
    nist = g4.G4NistManager.Instance()
    densities = {}
    for name in nist.GetNistMaterialNames():
        material = nist.FindOrBuildMaterial(str(name))
        densities[str(name)] = float(f"{material.GetDensity() / (g4.g / g4.cm3):.10g}")
    return geant4_version(g4), densities


def main() -> None:
    version, densities = nist_densities()
    table = {
        "source": "Geant4 G4NistManager (tools/nist_densities.py)",
        "geant4_version": version,
        "unit": "g/cm3",
        "densities": densities,
    }
    OUT.write_text(json.dumps(table, indent=1, sort_keys=False) + "\n")
    print(f"wrote {OUT}: {len(densities)} materials, Geant4 {version}")


if __name__ == "__main__":
    main()
