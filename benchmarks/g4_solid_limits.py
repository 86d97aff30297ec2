"""Find the smallest size each Geant4 solid score4 builds accepts without a G4Exception.

Every try runs in its own process (a fatal G4Exception aborts it). A size is accepted when the
solid builds, answers ``Inside`` for its centre and Geant4 printed no G4Exception. The solid is
a cube of full edge ``s`` (G4Box, G4Trd, G4Tubs radius and length, and a closed
G4TessellatedSolid of 12 triangles); the search is a bisection in log scale between 1e-12 mm
and 1e-6 mm. score4.inputs.limits.MIN_SOLID_LENGTH is set from this output with a margin.

    .venv/bin/python benchmarks/g4_solid_limits.py
"""

from __future__ import annotations

import argparse
import math
import subprocess
import sys

TRY = r"""
import sys
from score4.sim.runtime import import_geant4, resolve_physics
g4 = import_geant4(resolve_physics("lite"))
kind, s = sys.argv[1], float(sys.argv[2])
h = s / 2
v = g4.G4ThreeVector
if kind == "G4Box":
    solid = g4.G4Box("b", h, h, h)
elif kind == "G4Trd":
    solid = g4.G4Trd("t", h, h / 2, h, h / 2, h)
elif kind == "G4Tubs":
    solid = g4.G4Tubs("c", 0.0, h, h, 0.0, 6.283185307179586)
else:
    solid = g4.G4TessellatedSolid("m")
    c = [v(x * h, y * h, z * h) for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]
    quads = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    for a, b, cc, d in quads:
        solid.AddFacet(g4.G4TriangularFacet(c[a], c[cc], c[b], g4.ABSOLUTE))
        solid.AddFacet(g4.G4TriangularFacet(c[a], c[d], c[cc], g4.ABSOLUTE))
    solid.SetSolidClosed(True)
code = solid.Inside(v(0, 0, 0))
print("INSIDE", code == g4.EInside.kInside, flush=True)
"""


def accepted(kind: str, size: float) -> tuple[bool, str]:
    """(accepted, first G4Exception line or exit status) for one try."""
    p = subprocess.run(
        [sys.executable, "-c", TRY, kind, repr(size)],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    out = p.stdout + p.stderr
    lines = out.splitlines()
    at = [i for i, line in enumerate(lines) if "G4Exception :" in line]
    exception = " / ".join(x.strip() for x in lines[at[0] : at[0] + 3]) if at else ""
    ok = p.returncode == 0 and "INSIDE True" in out and not exception
    return ok, exception or f"exit {p.returncode}"


def smallest(kind: str, lo: float = 1e-12, hi: float = 1e-6, steps: int = 14) -> float:
    """Bisection in log scale: the smallest accepted full size, to ~1 %."""
    if not accepted(kind, hi)[0]:
        raise SystemExit(f"{kind}: not even {hi} mm is accepted")
    for _ in range(steps):
        mid = math.sqrt(lo * hi)
        if accepted(kind, mid)[0]:
            hi = mid
        else:
            lo = mid
    return hi


def main() -> None:
    argparse.ArgumentParser(description=__doc__.splitlines()[0]).parse_args()
    for kind in ("G4Box", "G4Trd", "G4Tubs", "G4TessellatedSolid"):
        s = smallest(kind)
        _, why = accepted(kind, s * 0.9)
        print(f"{kind:20s} smallest full size {s:.3g} mm; at 0.9x: {why}", flush=True)


if __name__ == "__main__":
    main()
