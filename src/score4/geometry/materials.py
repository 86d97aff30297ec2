"""Material look-up in Geant4's NIST database with helpful errors."""

from __future__ import annotations

import difflib

from ..errors import ConfigError


def find_material(g4, name: str, parameter: str = "material"):
    """Return the G4Material ``name`` from the NIST database, or raise listing close names."""
    nist = g4.G4NistManager.Instance()
    known = list(nist.GetNistMaterialNames())
    if name not in known:
        close = difflib.get_close_matches(name, known, n=5, cutoff=0.5)
        if not close and not name.startswith("G4_"):
            close = difflib.get_close_matches("G4_" + name, known, n=5, cutoff=0.5)
        hint = (
            f"; closest NIST names: {', '.join(close)}"
            if close
            else "; NIST names look like G4_Si, G4_Cu, G4_Galactic"
        )
        raise ConfigError(f"{parameter}: unknown material {name!r}{hint}")
    return nist.FindOrBuildMaterial(name)
