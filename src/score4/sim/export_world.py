"""``score4 geometry export``: the run's whole world, rough layers included, as one GDML file.

A GDML world is the user's file with the rough layers added (:mod:`score4.geometry.gdml_splice`:
every name, ``<auxiliary>`` and the ``<userinfo>`` block kept). A world of the configuration's
boxes is built exactly as the workers build it (:func:`score4.geometry.world.build_world`)
in a spawned process (the calling process never imports Geant4) and written with Geant4's own
writer, without its pointer suffixes (``crystal0x55d1...``): every logical volume, physical
volume and solid of the world gets a unique name first (:func:`unique_names`: the first keeps
its name, repeats become ``name_1``, ``name_2``, ...; a placement repeated in a row of patches is
such a repeat), since GDML readers (Geant4's, pyg4ometry's) look volumes and solids up by name.
The nested tiling's shared logical volumes are written once, so a 10 cm face of a few thousand
placements stays at megabytes. ``<T>``/``<P>`` are removed from NIST materials, which
pyg4ometry refuses on them (:func:`score4.geometry.gdml.drop_nist_state`).
"""

from __future__ import annotations

import tempfile
from pathlib import Path

from score4.inputs.config import RunConfig

from .. import files as score4_files
from ..errors import ConfigError, Score4Error


def _solids_of(solid, seen: dict) -> None:
    """``solid`` and the solids it is made of (boolean constituents, displaced and multi-union
    nodes), by identity into ``seen``."""
    if solid is None or id(solid) in seen:
        return
    seen[id(solid)] = solid
    for i in (0, 1):  # a boolean's two constituents (None for any other solid)
        _solids_of(solid.GetConstituentSolid(i), seen)
    if hasattr(solid, "GetConstituentMovedSolid"):
        _solids_of(solid.GetConstituentMovedSolid(), seen)
    if hasattr(solid, "GetNumberOfSolids"):
        for i in range(solid.GetNumberOfSolids()):
            _solids_of(solid.GetSolid(i), seen)


def unique_names(world) -> int:
    """Give every physical volume, logical volume and solid under the world volume ``world`` a
    name of its own within its kind, in the order of a walk from the world (the first of a
    name keeps it; the others get ``_1``, ``_2``, ... not yet taken). Returns how many were
    renamed."""
    pvs: dict = {}
    lvs: dict = {}
    solids: dict = {}
    stack = [world]
    while stack:
        pv = stack.pop()
        pvs.setdefault(id(pv), pv)
        lv = pv.GetLogicalVolume()
        if id(lv) in lvs:
            continue
        lvs[id(lv)] = lv
        _solids_of(lv.GetSolid(), solids)
        stack += [lv.GetDaughter(i) for i in reversed(range(lv.GetNoDaughters()))]
    renamed = 0
    for kind in (pvs, lvs, solids):
        objects = list(kind.values())
        taken = {str(o.GetName()) for o in objects}
        seen: set[str] = set()
        count: dict[str, int] = {}
        for o in objects:
            name = str(o.GetName())
            if name not in seen:
                seen.add(name)
                continue
            k = count.get(name, 0)
            while True:
                k += 1
                new = f"{name}_{k}"
                if new not in taken:
                    break
            count[name] = k
            taken.add(new)
            seen.add(new)
            o.SetName(new)
            renamed += 1
    return renamed


def _write(config: RunConfig, out: str) -> dict:
    from score4.runner.run_plan import plan_run

    from ..geometry.gdml import drop_nist_state
    from ..geometry.world import build_world
    from .runtime import import_geant4, redirect_native_output, resolve_physics

    lite = resolve_physics("lite")  # geometry and NIST materials need no data
    g4 = import_geant4(lite)
    plan = plan_run(config, physics=lite, source=False)
    scene = plan.scene
    path = Path(out)
    complete = score4_files.ends_with(b"</gdml>", "GDML file")
    with (
        score4_files.atomic_output(path, complete, ".partial.gdml") as tmp,
        tempfile.TemporaryDirectory(prefix="score4-export-") as folder,
    ):
        tmp.unlink()  # Geant4's writer refuses to overwrite
        log = Path(folder) / "geant4.log"
        if scene.model is not None:  # a GDML world: the user's file, layers added
            from ..geometry.gdml_splice import splice

            with redirect_native_output(log):
                info = splice(g4, config, scene, tmp, Path(folder) / "additions.gdml")
        else:
            with redirect_native_output(log):
                built = build_world(g4, plan)
                unique_names(built.world)
                parser = g4.G4GDMLParser()
                parser.SetAddPointerToName(False)
                parser.Write(str(tmp), built.world, False)  # False: no pointer suffixes
            if not tmp.is_file():
                tail = " | ".join(log.read_text(errors="replace").strip().splitlines()[-3:])
                raise Score4Error(f"--gdml: Geant4 did not write {path} ({tail})")
            tmp.write_text(drop_nist_state(tmp.read_text()))
            info = {"layers": [layer.name for layer in scene.layers]}
    return {"size": path.stat().st_size, **info}


def export_world(config: RunConfig, out: Path) -> dict:
    """Write the world of ``config`` (GDML world or generated box, with rough layers) to ``out``.

    Returns ``{"size": bytes, "layers": [layer names]}``. Portal layers (their subworlds sit
    outside the world particles move in) are refused: export native tiling.
    """
    portal = [
        f"targets.{i}.rough.{j}"
        for i, t in enumerate(config.targets)
        for j, r in enumerate(t.rough)
        if r.tiling == "portal"
    ]
    if portal:
        raise ConfigError(
            f"{portal[0]}: tiling portal teleports particles and cannot be written to GDML; "
            "export tiling: native (the same surface in other tools)"
        )
    from .runtime import in_own_process

    return in_own_process(_write, config, str(out))
