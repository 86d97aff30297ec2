"""Run in a spawned process: build a config's world, optionally plant an overlapping box, check."""

from __future__ import annotations

from score4.runner.run_plan import plan_run


def check(config_data: dict, plant_overlap: bool) -> tuple[bool, list[str], int, int]:
    from score4.geometry.check import check_placements
    from score4.geometry.world import build_world
    from score4.inputs.config import parse_config
    from score4.sim.runtime import import_geant4, redirect_native_output, resolve_physics

    config = parse_config(config_data)
    g4 = import_geant4(resolve_physics("lite"))
    with redirect_native_output(None):
        plan = plan_run(config, physics=resolve_physics("lite"), source=False)
        built_scene = plan.scene
        built = build_world(g4, plan)
        world_lv = built.world.GetLogicalVolume()
        if plant_overlap:  # a copper box straddling the top face of the crystal
            solid = g4.G4Box("intruder", 0.05, 0.05, 0.05)
            lv = g4.G4LogicalVolume(
                solid, g4.G4NistManager.Instance().FindOrBuildMaterial("G4_Cu"), "intruder"
            )
            pv = g4.G4PVPlacement(
                None, g4.G4ThreeVector(0, 0, 0.0), lv, "intruder", world_lv, False, 0, False
            )
            built.keep += [solid, lv, pv]
        report = check_placements(
            built.world, points=500, max_placements=20, layers=built_scene.layers
        )
    return report.ok, report.overlaps, report.checked, report.exact, report.total


def check_curved(config_data: dict, plant_overlap: bool, max_placements: int = 20) -> dict:
    """Check a world with a curved layer; ``plant_overlap``: one more copy of the envelope's
    first cell, turned by half a cell about the axis (it overlaps two cells)."""
    from score4.geometry.check import check_placements
    from score4.geometry.world import build_world
    from score4.inputs.config import parse_config
    from score4.sim.runtime import import_geant4, redirect_native_output, resolve_physics

    config = parse_config(config_data)
    g4 = import_geant4(resolve_physics("lite"))
    lines: list[str] = []
    with redirect_native_output(None):
        plan = plan_run(config, physics=resolve_physics("lite"), source=False)
        (layer,) = plan.scene.layers
        built = build_world(g4, plan)
        if plant_overlap:
            world_lv = built.world.GetLogicalVolume()
            env = next(
                world_lv.GetDaughter(i).GetLogicalVolume()
                for i in range(world_lv.GetNoDaughters())
                if str(world_lv.GetDaughter(i).GetName()) == layer.name
            )
            first = env.GetDaughter(0)
            rot = g4.G4RotationMatrix(first.GetObjectRotationValue())
            rot.rotateZ(0.5 * float(layer.ring_layout.step[0]))
            pv = g4.G4PVPlacement(
                g4.G4Transform3D(rot, first.GetObjectTranslation()),
                first.GetLogicalVolume(),
                "planted",
                env,
                False,
                9999,
                False,
            )
            built.keep += [rot, pv]
        report = check_placements(
            built.world,
            points=200,
            max_placements=max_placements,
            layers=plan.scene.layers,
            progress=lines.append,
        )
    return {
        "ok": report.ok,
        "overlaps": report.overlaps,
        "curved": report.curved,
        "sampled": report.sampled,
        "checked": report.checked,
        "no_points": report.no_points,
        "lines": lines,
    }


def assert_no_overlaps(config_path) -> None:
    """``score4 geometry check CONFIG`` in its own process, as a user runs it, reports no
    overlaps (in one process, Geant4's GDML reader would take volumes of an earlier world from
    its stores by name)."""
    import subprocess
    import sys

    done = subprocess.run(
        [sys.executable, "-m", "score4", "geometry", "check", str(config_path)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    assert "no overlaps" in done.stdout


def envelope_overlaps(config_data: dict, points: int = 20000) -> list[str]:
    """Geant4's ``CheckOverlaps(points)`` on the envelope of a world's one rough layer, the world
    built without score4's clearance check (the overlaps Geant4 reports, one line each)."""
    import score4.world.resolve as resolve
    from score4.geometry.world import build_world
    from score4.inputs.config import parse_config
    from score4.sim.runtime import import_geant4, redirect_native_output, resolve_physics

    resolve.check_clearance = lambda scene: None  # type: ignore[attr-defined]
    config = parse_config(config_data)
    g4 = import_geant4(resolve_physics("lite"))
    with redirect_native_output(None):
        plan = plan_run(config, physics=resolve_physics("lite"), source=False)
        (layer,) = plan.scene.layers
        built = build_world(g4, plan)
        world_lv = built.world.GetLogicalVolume()
        env = next(
            world_lv.GetDaughter(i)
            for i in range(world_lv.GetNoDaughters())
            if str(world_lv.GetDaughter(i).GetName()) == layer.name
        )
        met = env.CheckOverlaps(points, 0.0, False, 1)
    return [f"{layer.name} meets a sister"] if met else []


def check_moved_piece(config_data: dict, face: str, index: int, dv: float) -> list[str]:
    """The overlaps ``check_placements`` reports in a world whose curved layer on ``face`` has
    the end of its envelope's piece ``index`` (by generator position) moved by ``dv`` mm along
    the generator (into the next piece for dv > 0), built without score4's clearance check."""
    import score4.world.boolean_layers as boolean_layers
    import score4.world.resolve as resolve
    from score4.geometry.check import check_placements
    from score4.geometry.world import build_world
    from score4.inputs.config import parse_config
    from score4.sim.runtime import import_geant4, redirect_native_output, resolve_physics

    pieces_of = boolean_layers.envelope_pieces

    def moved(layer):
        pieces = pieces_of(layer)
        if pieces is None or layer.config.face_name != face:
            return pieces
        pieces = sorted(pieces, key=lambda p: p.v0)
        pieces[index] = pieces[index]._replace(v1=pieces[index].v1 + dv)
        return pieces

    boolean_layers.envelope_pieces = moved  # type: ignore[assignment]
    resolve.check_clearance = lambda scene: None  # type: ignore[attr-defined]
    config = parse_config(config_data)
    g4 = import_geant4(resolve_physics("lite"))
    with redirect_native_output(None):
        plan = plan_run(config, physics=resolve_physics("lite"), source=False)
        built = build_world(g4, plan)
        report = check_placements(built.world, max_placements=20, layers=plan.scene.layers)
    return report.overlaps
