"""Run in a spawned process by tests/test_api.py (pytest itself never imports Geant4): a user's
own geant4_pybind application built with score4.api on a world read from GDML."""

from __future__ import annotations

import numpy as np

PYRAMIDS = {"kind": "spikes", "nx": 10, "ny": 10, "width": "10 um", "height": "10 um"}


def own_run(gdml: str, events: int, seed: int, histories: int) -> dict:
    """Po-210 20 nm below the rough -z face of 'crystal' (10 um pyramids) in the world of
    ``gdml``, tracked in an application made of score4.api calls; per-event deposits per column
    and what the API reported."""
    from score4 import api

    g4 = api.import_geant4("lite")
    run_manager = g4.G4RunManagerFactory.CreateRunManager(g4.G4RunManagerType.Serial)
    for command in ("/control/verbose 0", "/run/verbose 0", "/event/verbose 0"):
        g4.G4UImanager.GetUIpointer().ApplyCommand(command)
    parser = g4.G4GDMLParser()
    parser.Read(gdml, False)
    world_pv = parser.GetWorldVolume()

    world = api.World(g4, world_pv)
    crystal = world.instances("crystal")[0]
    rough = world.roughen("crystal", "-z", PYRAMIDS, base_thickness="1 um")
    holder_lv = world_pv.GetLogicalVolume().GetDaughter(0).GetLogicalVolume()
    holder_columns = [t.column for t in world.targets(holder_lv)]  # by its logical volume
    source = world.source(
        surface=("crystal", "-z"),
        decay="Po210",
        depth={"profile": "exponential", "mean": "20 nm"},
    )
    replay = api.HeavyIonReplay(g4, world_pv, world.scoring, seed=seed, histories=histories)
    generator = api.PrimaryGenerator(g4, source, seed=seed, replay=replay)
    names = list(world.scoring)
    edep = np.zeros((events, len(names)))
    ids: dict[str, int] = {}

    class Detector(g4.G4VUserDetectorConstruction):
        def Construct(self):
            return world_pv

        def ConstructSDandField(self):
            sdm = g4.G4SDManager.GetSDMpointer()
            sdm.SetVerboseLevel(0)
            for name in names:
                mfd = g4.G4MultiFunctionalDetector(f"api_{name}")
                mfd.RegisterPrimitive(g4.G4PSEnergyDeposit("edep"))
                sdm.AddNewDetector(mfd)
                for lv in world.scoring[name]:
                    lv.SetSensitiveDetector(mfd)

    class Events(g4.G4UserEventAction):
        def EndOfEventAction(self, event):
            k = event.GetEventID()
            hce = event.GetHCofThisEvent()
            for j, name in enumerate(names):
                edep[k, j] = sum(value for _, value in hce.GetHC(ids[name]))
            for name, value in generator.end_of_event().items():
                edep[k, names.index(name)] += value

    keep = [Detector(), api.physics_list(g4, "lite")]
    run_manager.SetUserInitialization(keep[0])
    run_manager.SetUserInitialization(keep[1])
    keep += [generator.action(), Events()]
    run_manager.SetUserAction(keep[2])
    run_manager.SetUserAction(keep[3])
    run_manager.Initialize()
    removed = api.after_initialize(g4, "lite")
    sdm = g4.G4SDManager.GetSDMpointer()
    ids.update({name: sdm.GetCollectionID(f"api_{name}/edep") for name in names})
    run_manager.BeamOn(events)
    # where the patches are: every vertex below the rough mesh lies in the crystal's material
    first = source.events(seed, 0, events)
    navigator = g4.G4Navigator()
    navigator.SetWorldVolume(world_pv)
    in_crystal = [
        str(
            navigator.LocateGlobalPointAndSetup(g4.G4ThreeVector(*p))
            .GetLogicalVolume()
            .GetMaterial()
            .GetName()
        )
        for p in first.position[::2][:200]
    ]
    return {
        "names": names,
        "edep": edep,
        "removed": removed,
        "holder_columns": holder_columns,
        "patches": int(rough.layers[0].patch_map.variants.size),
        "scored_lvs": {k: len(v) for k, v in rough.volumes.items()},
        "crystal_rotation": crystal.rotation.tolist(),
        "materials": sorted(set(in_crystal)),
        "replayed": len(generator.replayed),
    }


def api_errors(gdml: str) -> list[str]:
    """The one-line errors of score4.api for bad calls on the world of ``gdml``."""
    from score4 import api
    from score4.errors import ConfigError

    g4 = api.import_geant4("lite")
    parser = g4.G4GDMLParser()
    parser.Read(gdml, False)
    world = api.World(g4, parser.GetWorldVolume())
    copper = g4.G4NistManager.Instance().FindOrBuildMaterial("G4_Cu")
    lonely = g4.G4LogicalVolume(g4.G4Box("x", 1, 1, 1), copper, "lonely")
    calls = [
        lambda: world.roughen("cristal", "-z", PYRAMIDS),
        lambda: world.roughen("crystal", "-z", {**PYRAMIDS, "height": "10"}),
        lambda: world.roughen("crystal", "-z", PYRAMIDS, base_thicknes="1 um"),
        # the holder's top face is 0.5 mm below the crystal: 0.6 mm pyramids meet it
        lambda: world.roughen("holder", "+z", {**PYRAMIDS, "height": "600 um"}),
        lambda: world.source(surface=("crystal", "+q"), particle="alpha", energy="5 MeV"),
        lambda: world.source(volume="crystal", particle="alpha", energy="5"),
        lambda: world.source(
            surface=("crystal", "+z"), decay={"chain": "Po218", "implantation": True}
        ),
        lambda: world.roughen(g4.G4Box("x", 1, 1, 1), "-z", PYRAMIDS),
        lambda: world.roughen(lonely, "-z", PYRAMIDS),
    ]
    out = []
    for call in calls:
        try:
            call()
        except ConfigError as err:
            out.append(str(err))
        else:
            out.append("no error")
    return out


def own_secondaries(gdml: str, events: int) -> dict:
    """5 MeV protons straight into the holder of ``gdml``; at each proton's third step a
    103.144 keV Pb-206 is pushed onto Geant4's stack as a secondary (a heavy-ion secondary made
    without data sets). The replay's stacking action must take it: the same events with and
    without the push, the deposits and the intercepted ions."""
    import ctypes

    from score4 import api

    g4 = api.import_geant4("lite")
    run_manager = g4.G4RunManagerFactory.CreateRunManager(g4.G4RunManagerType.Serial)
    for command in ("/control/verbose 0", "/run/verbose 0", "/event/verbose 0"):
        g4.G4UImanager.GetUIpointer().ApplyCommand(command)
    parser = g4.G4GDMLParser()
    parser.Read(gdml, False)
    world_pv = parser.GetWorldVolume()
    world = api.World(g4, world_pv)
    source = world.source(
        surface=("holder", "+z"), particle="proton", energy="5 MeV", direction="normal"
    )
    replay = api.HeavyIonReplay(g4, world_pv, world.scoring, seed=4, histories=100)
    generator = api.PrimaryGenerator(g4, source, seed=4, replay=replay)
    names = list(world.scoring)
    edep = np.zeros((events, len(names)))
    booked: list[float] = []
    push = [False]
    lead: list = []

    class Detector(g4.G4VUserDetectorConstruction):
        def Construct(self):
            return world_pv

        def ConstructSDandField(self):
            sdm = g4.G4SDManager.GetSDMpointer()
            sdm.SetVerboseLevel(0)
            mfd = g4.G4MultiFunctionalDetector("api_holder")
            mfd.RegisterPrimitive(g4.G4PSEnergyDeposit("edep"))
            sdm.AddNewDetector(mfd)
            for lv in world.scoring["holder"]:
                lv.SetSensitiveDetector(mfd)

    class Push(g4.G4UserSteppingAction):
        def UserSteppingAction(self, step):
            track = step.GetTrack()
            if push[0] and track.GetTrackID() == 1 and track.GetCurrentStepNumber() == 3:
                p = step.GetPostStepPoint().GetPosition()
                particle = g4.G4DynamicParticle(
                    lead[0], g4.G4ThreeVector(0.0, 0.6, -0.8), 0.103144, 0.0
                )
                ion = g4.G4Track(particle, 0.0, g4.G4ThreeVector(p.x, p.y, p.z))
                ion.SetParentID(1)
                for obj in (particle, ion):  # Geant4 deletes them: Python must never do so
                    ctypes.pythonapi.Py_IncRef(ctypes.py_object(obj))
                g4.G4EventManager.GetEventManager().GetStackManager().PushOneTrack(ion)

    class Events(g4.G4UserEventAction):
        def EndOfEventAction(self, event):
            k = event.GetEventID()
            hce = event.GetHCofThisEvent()
            edep[k, names.index("holder")] = sum(v for _, v in hce.GetHC(ids["holder"]))
            extra = generator.end_of_event()
            booked.append(sum(extra.values()))
            for name, value in extra.items():
                edep[k, names.index(name)] += value

    keep = [Detector(), api.physics_list(g4, "lite")]
    run_manager.SetUserInitialization(keep[0])
    run_manager.SetUserInitialization(keep[1])
    keep += [generator.action(), Events(), Push(), replay.stacking_action()]
    for action in keep[2:]:
        run_manager.SetUserAction(action)
    run_manager.Initialize()
    api.after_initialize(g4, "lite")
    lead.append(replay.definition("Pb206"))
    ids = {"holder": g4.G4SDManager.GetSDMpointer().GetCollectionID("api_holder/edep")}
    run_manager.BeamOn(events)
    plain = edep.copy()
    intercepted_plain = len(replay.intercepted)
    push[0] = True
    generator.next_event = 0
    edep[:] = 0
    booked.clear()
    counts = []

    class Count(g4.G4UserEventAction):
        def EndOfEventAction(self, event):
            counts.append(len(replay.intercepted))
            keep[3].EndOfEventAction(event)

    keep.append(Count())
    run_manager.SetUserAction(keep[-1])
    run_manager.BeamOn(events)
    return {
        "names": names,
        "plain": plain,
        "pushed": edep.copy(),
        "booked": list(booked),
        "counts": counts,
        "intercepted_plain": intercepted_plain,
    }


#: A stepped polycone (a ring at z = 1 mm between the walls r = 3 and r = 2 mm: the upper wall
#: meets the ring at a concave edge) and a full tube, far apart (GDML by hand).
STEP_GDML = """<?xml version="1.0" encoding="UTF-8"?>
<gdml>
  <define/>
  <materials/>
  <solids>
    <box name="WorldBox" x="100" y="100" z="100" lunit="mm"/>
    <polycone name="StepCone" startphi="0" deltaphi="360" aunit="deg" lunit="mm">
      <zplane z="0" rmin="0" rmax="3"/>
      <zplane z="1" rmin="0" rmax="3"/>
      <zplane z="1" rmin="0" rmax="2"/>
      <zplane z="2" rmin="0" rmax="2"/>
    </polycone>
    <tube name="Rod" rmin="0" rmax="2" z="2" deltaphi="360" aunit="deg" lunit="mm"/>
  </solids>
  <structure>
    <volume name="StepLV">
      <materialref ref="G4_Ge"/><solidref ref="StepCone"/>
    </volume>
    <volume name="RodLV">
      <materialref ref="G4_Ge"/><solidref ref="Rod"/>
    </volume>
    <volume name="WorldLV">
      <materialref ref="G4_Galactic"/><solidref ref="WorldBox"/>
      <physvol name="step">
        <volumeref ref="StepLV"/><position name="sp" x="-20" unit="mm"/>
      </physvol>
      <physvol name="rod">
        <volumeref ref="RodLV"/><position name="rp" x="20" unit="mm"/>
      </physvol>
    </volume>
  </structure>
  <setup name="Default" version="1.0"><world ref="WorldLV"/></setup>
</gdml>
"""


def api_ring_order(gdml: str) -> dict:
    """Rough rings and walls that meet at an edge, roughened one call after another through
    score4.api on the world of :data:`STEP_GDML`: what was refused, and the rings' radii, cells
    and layers before and after."""
    from score4 import api
    from score4.errors import ConfigError

    g4 = api.import_geant4("lite")
    parser = g4.G4GDMLParser()
    parser.Read(gdml, False)
    world = api.World(g4, parser.GetWorldVolume())
    shape = world.targets("step")[0].shape
    faces = list(shape.faces)

    def state(volume: str) -> list:
        return [
            (r.config.face_name, getattr(r, "ring", None), r.rest_radii, r.mask)
            for r in world.scene.layers_of(volume)
        ]

    def attempt(call) -> str:
        try:
            call()
        except ConfigError as err:
            return str(err)
        return "no error"

    out: dict = {"faces": faces}
    # the shoulder ring (z = 1, r 2 .. 3) placed first, then the wall above it (r = 2)
    ring, wall = out["ring"], out["wall"] = "seg_2", "seg_3"
    world.roughen("step", ring, PYRAMIDS)
    before = state("step")
    out["wall_after_ring"] = attempt(lambda: world.roughen("step", wall, PYRAMIDS))
    after = state("step")
    out["ring_kept"] = len(before) == len(after) and all(
        a[:3] == b[:3] and a[3] is b[3] for a, b in zip(before, after, strict=True)
    )
    out["ring_radii"] = before[0][1]
    # the rod: into on its +z face, then into on its wall (their joint cut would change the
    # +z layer's cells)
    world.roughen("rod", "+z", PYRAMIDS, into=True)
    before = state("rod")
    out["wall_after_end"] = attempt(lambda: world.roughen("rod", "outer", PYRAMIDS, into=True))
    after = state("rod")
    out["end_kept"] = len(before) == len(after) == 1 and before[0][3] is after[0][3]
    out["end_rest"] = after[0][2]
    # into on the far end face shares no edge with +z: the placed layer stays as it is
    world.roughen("rod", "-z", PYRAMIDS, into=True)
    out["ends"] = [f for f, *_ in state("rod")]
    return out


def api_ring_together(gdml: str) -> dict:
    """The wall of :data:`STEP_GDML`'s polycone before the ring it meets, in two calls (the ring
    gives way to the placed wall); the rod's +z face and wall with into in one call. The ring's
    radii and cells, the layers and the volumes scored."""
    from score4 import api

    g4 = api.import_geant4("lite")
    parser = g4.G4GDMLParser()
    parser.Read(gdml, False)
    world = api.World(g4, parser.GetWorldVolume())
    world.roughen("step", "seg_3", PYRAMIDS)
    both = world.roughen("step", "seg_2", PYRAMIDS)
    ring = world.scene.layer("step", "seg_2")
    rod = world.roughen("rod", ["+z", "outer"], PYRAMIDS, into=True)
    end = world.scene.layer("rod", "+z")
    wall = world.scene.layer("rod", "outer")
    return {
        "layers": [r.config.face_name for r in both.layers],
        "ring": ring.ring,
        "ring_cells": int(ring.mask.sum()),
        "scored": {k: len(v) for k, v in world.scoring.items()},
        "rod_layers": [r.config.face_name for r in rod.layers],
        "end_rest": end.rest_radii,
        "wall_thickness": wall.thickness,
        "wall_top": float(wall.ring_layout.face.rz2[1]),
        "end_thickness": end.thickness,
    }


def api_joint(gdml: str, volume: str, faces: list[str], rays: list, together: bool) -> dict:
    """``into`` on two faces of a boolean's constituents that share an edge (``faces``, cut
    together), roughened through score4.api on the world of ``gdml``: in one call
    (``together``), or first one face and then the other (the second call is refused: what it
    says, and whether the placed layer stayed as it was). The layers, the volumes scored and
    the geantino paths of ``rays`` through the world the API leaves."""
    from score4 import api
    from score4.errors import ConfigError

    from helpers.g4_gdml_world import _trace

    g4 = api.import_geant4("lite")
    parser = g4.G4GDMLParser()
    parser.Read(gdml, False)
    world_pv = parser.GetWorldVolume()
    world = api.World(g4, world_pv)
    out: dict = {}
    if together:
        rough = world.roughen(volume, faces, PYRAMIDS, into=True)
        out["layers"] = [r.config.face_name for r in rough.layers]
        out["thickness"] = [r.thickness for r in rough.layers]
        out["scored"] = {k: len(v) for k, v in rough.volumes.items()}
    else:
        world.roughen(volume, faces[0], PYRAMIDS, into=True)
        (first,) = world.scene.layers_of(volume)
        mask = None if first.mask is None else first.mask.copy()
        try:
            world.roughen(volume, faces[1], PYRAMIDS, into=True)
            out["refused"] = "no error"
        except ConfigError as err:
            out["refused"] = str(err)
        (kept,) = world.scene.layers_of(volume)
        same = mask is None if kept.mask is None else np.array_equal(kept.mask, mask)
        out["kept"] = kept is first and same
    nav = g4.G4Navigator()
    nav.SetWorldVolume(world_pv)
    out["paths"] = [_trace(g4, nav, o, d) for o, d in rays]
    return out
