"""Volumes and masses of the scored volumes of a built world (the run record's ``volumes``).

One entry per scoring column in ``events/edep`` order, as contract 1 of the run record says:
``{"name", "material", "density_g_cm3", "volume_mm3", "mass_kg"}``; the rough layers' material
counts with its target. The target's own volume is its solid's (Geant4's ``GetCubicVolume``,
after an ``into`` cut) less its daughters'; a rough layer adds the closed patch bodies (slab +
rough top, :func:`score4.runner.normalisation.layer_volume`) times the cells that hold them.
"""

from __future__ import annotations

from score4.runner.normalisation import layer_volume
from score4.world.scene import Scene


def volume_records(g4, scene: Scene, scoring: dict[str, list]) -> list[dict]:
    """The run record's ``volumes`` from the built world (``scoring``: column -> logical volumes,
    the target's own first)."""
    g_cm3 = float(g4.g / g4.cm3)
    out = []
    for target in scene.targets:
        lv = scoring[target.name][0]
        own = float(lv.GetSolid().GetCubicVolume())
        for i in range(lv.GetNoDaughters()):
            d = lv.GetDaughter(i)
            own -= d.GetMultiplicity() * float(d.GetLogicalVolume().GetSolid().GetCubicVolume())
        layers = sum(layer_volume(r) for r in scene.layers_of(target.name))
        density = float(lv.GetMaterial().GetDensity()) / g_cm3
        volume = own + layers
        out.append(
            {
                "name": target.name,
                "material": str(lv.GetMaterial().GetName()),
                "density_g_cm3": density,
                "volume_mm3": volume,
                "mass_kg": volume * density * 1e-6,
                "layer_volume_mm3": layers,
                "gdml_volume": None
                if target.instance is None or scene.model is None
                else scene.model.label(target.instance),
            }
        )
    return out
