"""Run in a spawned process by test_shape_sources_g4 (pytest itself never imports Geant4)."""

from __future__ import annotations

from score4.runner.run_plan import plan_run


def locate(config_data: dict, points: list) -> tuple[list[str], list[str]]:
    """Physical volume and material that Geant4's navigator finds at each point of the world
    score4 builds for the config."""
    from score4.geometry.world import build_world
    from score4.inputs.config import parse_config
    from score4.sim.runtime import import_geant4, redirect_native_output, resolve_physics

    config = parse_config(config_data)
    g4 = import_geant4(resolve_physics("lite"))
    with redirect_native_output(None):
        built = build_world(g4, plan_run(config, physics=resolve_physics("lite"), source=False))
        navigator = g4.G4Navigator()
        navigator.SetWorldVolume(built.world)
        names, materials = [], []
        for p in points:
            pv = navigator.LocateGlobalPointAndSetup(g4.G4ThreeVector(*p))
            names.append(pv.GetName())
            materials.append(pv.GetLogicalVolume().GetMaterial().GetName())
    return names, materials
