"""``score4 surface export --gdml``: one surface's closed body as a Geant4 solid, in GDML.

The solid (a G4TessellatedSolid of the body, or the paper's G4MultiUnion of a spike grid) is
built and written in a spawned process (:func:`score4.sim.runtime.in_own_process`), as the
world export and the overlap check build theirs: the calling process never imports Geant4, and
a program that exports several surfaces gets each file from a process whose Geant4 stores hold
that surface alone.
"""

from __future__ import annotations

import tempfile
from pathlib import Path
from typing import TYPE_CHECKING

from ..errors import Score4Error

if TYPE_CHECKING:
    from score4.surface.spikes import SpikeGrid
    from score4.surface.triangle_mesh import TriangleMesh


def _write(
    spikes: SpikeGrid | None, body: TriangleMesh | None, out: str, thickness: float, material: str
) -> None:
    """In the spawned process: build the solid and write it with G4GDMLParser; Geant4's console
    goes to a log, whose last lines an error quotes."""
    from ..geometry.gdml import write_solid_gdml
    from ..geometry.solids import multiunion_solid, tessellated_solid
    from .runtime import import_geant4, redirect_native_output, resolve_physics

    # Geometry and NIST materials need no data sets: lite mode's stand-ins let Geant4 start.
    g4 = import_geant4(resolve_physics("lite"))
    with tempfile.TemporaryDirectory(prefix="score4-gdml-") as tmp:
        log = Path(tmp) / "geant4.log"
        try:
            with redirect_native_output(log):
                if spikes is not None:
                    solid, parts = multiunion_solid(g4, spikes, thickness, "rough_surface")
                else:
                    assert body is not None  # a tessellated body where no spike grid is given
                    solid, parts = tessellated_solid(g4, body, "rough_surface"), ()
                write_solid_gdml(g4, solid, out, material=material)
                del parts  # the node solids must outlive the write
        except Score4Error as err:
            tail = (
                " | ".join(log.read_text(errors="replace").strip().splitlines()[-3:])
                if log.exists()
                else ""
            )
            raise Score4Error(f"{err}{'; Geant4 said: ' + tail if tail else ''}") from err


def export_surface_gdml(
    spikes: SpikeGrid | None,
    body: TriangleMesh | None,
    out: Path,
    thickness: float,
    material: str,
) -> None:
    """Write the G4MultiUnion of ``spikes`` on a slab ``thickness`` (mm) thick, or else the
    G4TessellatedSolid of ``body``, in a world box as a standalone GDML file ``out`` (NIST
    ``material``), from a spawned process."""
    from .runtime import in_own_process

    in_own_process(_write, spikes, body, str(out), thickness, material)
