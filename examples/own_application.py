"""score4 in your own geant4_pybind application (docs/api.md).

A world built by hand: a copper holder plate, a CaWO4 crystal 0.5 mm above it, turned by
20 degrees about z, and a copper clamp on the crystal. score4 roughens the crystal's lower face
(10 um pyramids), puts Po-210 20 nm (mean) below that rough surface, generates the events, and
replays the Pb-206 recoils along TRIM trajectories; the program scores the deposits per volume
with Geant4's own scorers and prints them.

    python examples/own_application.py [--events N] [--seed S]

Lite physics (no Geant4 data sets needed); about 1000 events a second on one core, plus a few
seconds the first time, while TRIM computes the recoil's trajectories (then cached).
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from score4 import api
from score4.source.build import layer_sampler

# geant4_pybind must be imported through score4 (or after it): the data locations come first.
g4 = api.import_geant4("lite")


def build_world():
    """Your detector construction: plain geant4_pybind. Returns the world and the volumes."""
    nist = g4.G4NistManager.Instance()
    vacuum, copper = nist.FindOrBuildMaterial("G4_Galactic"), nist.FindOrBuildMaterial("G4_Cu")
    cawo4 = nist.FindOrBuildMaterial("G4_CALCIUM_TUNGSTATE")
    mm = g4.mm

    world_lv = g4.G4LogicalVolume(g4.G4Box("world", 30 * mm, 30 * mm, 30 * mm), vacuum, "world")
    world = g4.G4PVPlacement(None, g4.G4ThreeVector(), world_lv, "world", None, False, 0)

    holder_lv = g4.G4LogicalVolume(g4.G4Box("holder", 15 * mm, 15 * mm, 1 * mm), copper, "holder")
    holder = g4.G4PVPlacement(
        None, g4.G4ThreeVector(0, 0, -1 * mm), holder_lv, "holder", world_lv, False, 0
    )
    # the crystal: 10 x 10 x 5 mm, its lower face 0.5 mm above the holder, turned about z
    crystal_lv = g4.G4LogicalVolume(g4.G4Box("crystal", 5 * mm, 5 * mm, 2.5 * mm), cawo4, "crystal")
    turn = g4.G4RotationMatrix()
    turn.rotateZ(20 * g4.deg)
    crystal = g4.G4PVPlacement(
        turn, g4.G4ThreeVector(0, 0, 3 * mm), crystal_lv, "crystal", world_lv, False, 0
    )
    clamp_lv = g4.G4LogicalVolume(g4.G4Box("clamp", 2 * mm, 8 * mm, 1 * mm), copper, "clamp")
    clamp = g4.G4PVPlacement(
        None, g4.G4ThreeVector(0, 0, 6.5 * mm), clamp_lv, "clamp", world_lv, False, 0
    )
    return world, {"crystal": crystal, "holder": holder, "clamp": clamp}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--events", type=int, default=2000)
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    start = time.perf_counter()

    run_manager = g4.G4RunManagerFactory.CreateRunManager(g4.G4RunManagerType.Serial)
    for command in ("/control/verbose 0", "/run/verbose 0", "/event/verbose 0"):
        g4.G4UImanager.GetUIpointer().ApplyCommand(command)
    world_pv, pv = build_world()

    # score4: the rough face, its source, the generator and the heavy-ion replay
    world = api.World(g4, world_pv)
    pyramids = {"kind": "spikes", "nx": 10, "ny": 10, "width": "10 um", "height": "10 um"}
    rough = world.roughen(pv["crystal"], "-z", pyramids, base_thickness="1 um")
    source = world.source(
        surface=(pv["crystal"], "-z"),
        decay="Po210",
        depth={"profile": "exponential", "mean": "20 nm"},
    )
    # what each score counts: the crystal with its rough layer's patches, the copper parts
    volumes = {
        "crystal": rough.volumes["crystal"],
        "holder": [pv["holder"].GetLogicalVolume()],
        "clamp": [pv["clamp"].GetLogicalVolume()],
    }
    replay = api.HeavyIonReplay(g4, world_pv, volumes, seed=args.seed, histories=500)
    generator = api.PrimaryGenerator(g4, source, seed=args.seed, replay=replay)

    deposits = np.zeros((args.events, len(volumes)))  # MeV per event and volume
    scorers: dict[str, int] = {}

    class Detector(g4.G4VUserDetectorConstruction):
        def Construct(self):
            return world_pv

        def ConstructSDandField(self):
            manager = g4.G4SDManager.GetSDMpointer()
            manager.SetVerboseLevel(0)
            for name, lvs in volumes.items():
                detector = g4.G4MultiFunctionalDetector(name)
                detector.RegisterPrimitive(g4.G4PSEnergyDeposit("edep"))
                manager.AddNewDetector(detector)
                for lv in lvs:
                    lv.SetSensitiveDetector(detector)
                scorers[name] = detector

    class EventAction(g4.G4UserEventAction):
        def EndOfEventAction(self, event):
            k = event.GetEventID()
            hits = event.GetHCofThisEvent()
            for j, name in enumerate(volumes):
                deposits[k, j] = sum(e for _, e in hits.GetHC(ids[name]))
            for name, e in generator.end_of_event().items():  # the replayed Pb-206 recoils
                deposits[k, list(volumes).index(name)] += e

    detector = Detector()
    physics = api.physics_list(g4, "lite")
    run_manager.SetUserInitialization(detector)
    run_manager.SetUserInitialization(physics)
    actions = [generator.action(), EventAction()]
    for action in actions:
        run_manager.SetUserAction(action)
    run_manager.Initialize()
    api.after_initialize(g4, "lite")
    manager = g4.G4SDManager.GetSDMpointer()
    ids = {name: manager.GetCollectionID(f"{name}/edep") for name in volumes}
    run_manager.BeamOn(args.events)

    layer = rough.layers[0]
    print(
        f"rough face -z of crystal: {layer.patch_map.variants.size} patches of 10 x 10 pyramids, "
        f"true area {layer_sampler(layer).area:.2f} mm2 on {math.prod(layer.frame.size):.2f} mm2"
    )
    print(f"{args.events} events of Po-210, 20 nm below the rough face (seed {args.seed})")
    print(f"{'volume':8s} {'mean MeV':>9s} {'events > 10 keV':>16s} {'> 5 MeV':>8s}")
    for j, name in enumerate(volumes):
        e = deposits[:, j]
        print(f"{name:8s} {e.mean():9.4f} {np.sum(e > 0.01):16d} {np.sum(e > 5):8d}")
    total = deposits.sum(axis=1)
    print(f"sum over volumes: mean {total.mean():.4f} MeV, max {total.max():.4f} MeV")
    print(f"time: {time.perf_counter() - start:.1f} s")


if __name__ == "__main__":
    main()
