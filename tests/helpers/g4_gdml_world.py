"""Run in spawned processes by test_gdml_world (pytest itself never imports Geant4)."""

from __future__ import annotations

from score4.runner.run_plan import plan_run


def locate(path: str, points: list) -> list:
    """Names of the physical volumes Geant4's navigator finds at world ``points`` of a GDML
    world."""
    from score4.geometry.gdml import read_gdml
    from score4.sim.runtime import import_geant4, resolve_physics

    g4 = import_geant4(resolve_physics("lite"))
    _parser, world = read_gdml(g4, path)
    nav = g4.G4Navigator()
    nav.SetWorldVolume(world)
    found = [nav.LocateGlobalPointAndSetup(g4.G4ThreeVector(*p)) for p in points]
    return [None if v is None else str(v.GetName()) for v in found]


def built_world_locate(config_path: str, points: list) -> dict:
    """Build the run's world (GDML + score4's layers) and locate ``points``: for each, the
    physical volume name and which scoring column its logical volume counts for."""
    from score4.geometry.world import build_world
    from score4.inputs.config import load_config
    from score4.sim.runtime import import_geant4, resolve_physics

    config = load_config(config_path)
    plan = plan_run(config, physics=resolve_physics("lite"), source=False)
    g4 = import_geant4(plan.physics)
    built = build_world(g4, plan)
    column = {id(lv): name for name, lvs in built.scoring.items() for lv in lvs}
    keep = list(built.scoring.values())
    nav = g4.G4Navigator()
    nav.SetWorldVolume(built.world)
    names, columns = [], []
    for p in points:
        pv = nav.LocateGlobalPointAndSetup(g4.G4ThreeVector(*p))
        names.append(None if pv is None else str(pv.GetName()))
        columns.append(None if pv is None else column.get(id(pv.GetLogicalVolume())))
    del keep
    return {"names": names, "columns": columns}


def composition(path: str, volume: str, histories: int) -> dict:
    """The TRIM composition of ``volume``'s material and a TRIM library of Pb-206 in it."""
    from score4.geometry.gdml import read_gdml
    from score4.ions.composition import Composition
    from score4.ions.trim_library import trim_library
    from score4.sim.runtime import import_geant4, resolve_physics

    g4 = import_geant4(resolve_physics("lite"))
    _parser, world = read_gdml(g4, path)
    lv = world.GetLogicalVolume()
    material = None
    for i in range(lv.GetNoDaughters()):
        if str(lv.GetDaughter(i).GetName()) == volume:
            material = lv.GetDaughter(i).GetLogicalVolume().GetMaterial()
    assert material is not None
    comp = Composition.from_g4_material(material)
    lib = trim_library("Pb206", 82, 205.974, 0.103, comp, n=histories, seed=3, cache=False)
    depths = [float(lib.points[lib.offsets[k + 1] - 1, 0]) for k in range(histories)]
    return {
        "name": comp.name,
        "atoms": comp.atoms,
        "masses": comp.masses,
        "density": comp.density,
        "element_names": [
            str(material.GetElementVector()[i].GetName())
            for i in range(material.GetNumberOfElements())
        ],
        "mean_depth_mm": sum(depths) / len(depths),
    }


def _trace(g4, nav, origin, direction, far: float = 1e7, max_steps: int = 5000) -> list:
    """Boundary crossings of a straight ray (what a geantino does): (volume entered, point)."""
    import numpy as np

    vec = g4.G4ThreeVector
    p = np.asarray(origin, float)
    d = np.asarray(direction, float) / np.linalg.norm(direction)
    pv = nav.LocateGlobalPointAndSetup(vec(*p), vec(*d), False, False)
    out = [(None if pv is None else str(pv.GetName()), p.tolist())]
    while pv is not None and len(out) < max_steps:
        step = nav.ComputeStep(vec(*p), vec(*d), far, 0.0)
        if step >= far:
            break
        p = p + step * d
        nav.SetGeometricallyLimitedStep()
        pv = nav.LocateGlobalPointAndSetup(vec(*p), vec(*d), True, False)
        out.append((None if pv is None else str(pv.GetName()), p.tolist()))
    return out


def trace_built(config_path: str, rays: list) -> list:
    """Ray paths through the world score4 builds for a run."""
    from score4.geometry.world import build_world
    from score4.inputs.config import load_config
    from score4.sim.runtime import import_geant4, resolve_physics

    config = load_config(config_path)
    g4 = import_geant4(resolve_physics("lite"))
    built = build_world(g4, plan_run(config, physics=resolve_physics("lite"), source=False))
    nav = g4.G4Navigator()
    nav.SetWorldVolume(built.world)
    return [_trace(g4, nav, o, d) for o, d in rays]


def trace_gdml(path: str, rays: list, points: list | None = None):
    """Ray paths through a GDML world read back by Geant4's parser; with ``points``, also the
    names of the physical volumes at them (one process reads the file once)."""
    from score4.geometry.gdml import read_gdml
    from score4.sim.runtime import import_geant4, resolve_physics

    g4 = import_geant4(resolve_physics("lite"))
    _parser, world = read_gdml(g4, path)
    nav = g4.G4Navigator()
    nav.SetWorldVolume(world)
    paths = [_trace(g4, nav, o, d) for o, d in rays]
    if points is None:
        return paths
    found = [nav.LocateGlobalPointAndSetup(g4.G4ThreeVector(*p)) for p in points]
    return paths, [None if v is None else str(v.GetName()) for v in found]
