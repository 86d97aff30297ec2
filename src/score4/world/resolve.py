"""A run's resolved world: :func:`build_scene` turns a configuration into a checked
:class:`~score4.world.scene.Scene` (surfaces built, targets resolved, rough layers laid out,
clearances and the world's extent checked)."""

from __future__ import annotations

import numpy as np

from score4.common import limits
from score4.errors import ConfigError
from score4.inputs.config import RunConfig, SurfaceFile
from score4.shapes.faces import SphereFace
from score4.surface.spec import Surface, build_surface
from score4.surface.store import load_surface

from .boolean_layers import fit_cells, into_joint, target_layers
from .clearance import check_clearance
from .gdml_model import GeometryModel
from .scene import (
    CurvedRoughLayer,
    Scene,
    check_into_edges,
    fit_rings,
    resolve_targets,
    rough_faces,
)


def _load(name: str, description) -> Surface:
    where = f"surfaces.{name}"
    try:
        return (
            load_surface(description.file)
            if isinstance(description, SurfaceFile)
            else build_surface(description)
        )
    except ConfigError as err:
        raise ConfigError(f"{where}: {err}") from None


def build_scene(config: RunConfig, model: GeometryModel | None = None) -> Scene:
    """Build every surface the targets use and the patch map of every rough face.

    A GDML world's volume model is read (and cached) here unless given.
    """
    if model is None and config.world.gdml is not None:
        from .gdml_files import load_geometry_model

        model = load_geometry_model(config.world.gdml)
    if model is not None and model.overlaps and not config.world.allow_overlaps:
        first = model.overlaps[0]
        more = f" (and {len(model.overlaps) - 1} more pair(s))" if len(model.overlaps) > 1 else ""
        raise ConfigError(
            f"world.gdml: in {model.source}, volumes {first['volumes'][0]!r} and "
            f"{first['volumes'][1]!r} overlap by {first['by']}{more} (Geant4 CheckOverlaps); "
            "particles in an overlap are tracked wrongly: fix the GDML file, or run anyway "
            "with --allow-overlaps (world: {allow_overlaps: true})"
        )
    used = {v.surface for t in config.targets for r in t.rough for v in r.variant_list}
    surfaces = {
        name: _load(name, config.surfaces[name]) for name in config.surfaces if name in used
    }
    targets = resolve_targets(config, model)
    scene = Scene(config, surfaces, targets=targets, model=model)
    for target in targets:
        seen: dict[str, int] = {}
        for j, rough in enumerate(target.config.rough):
            where = f"targets.{target.entry}.rough.{j}"
            try:
                faces = rough_faces(target, rough)
            except ConfigError as err:
                raise ConfigError(f"{where}: {err}") from None
            for face in faces:
                if face in seen:
                    raise ConfigError(
                        f"{where}: face {face} of {target.name!r} is rough already "
                        f"(targets.{target.entry}.rough.{seen[face]})"
                    )
                seen[face] = j
                one = rough if rough.face == face else rough.model_copy(update={"face": face})
                scene.layers += target_layers(surfaces, target, j, one)
        check_into_edges(scene, target)  # walls re-laid on a joint cut, before rings fit
        into_joint(scene, target, f"targets.{target.entry}.rough")  # a boolean's constituents
        fit_rings(scene.layers_of(target.name))
        fit_cells(scene.layers_of(target.name))
    check_clearance(scene)
    far = float(np.max(scene.world_half))
    if np.isfinite(far) and far > limits.MAX_WORLD_EXTENT:
        raise ConfigError(
            f"targets: the world reaches {far / 1e3:.4g} m from the origin (targets, rough layers "
            "and world.margin); score4's limit is 1 km (move the targets towards the origin)"
        )
    if config.output.steps or any(t.config.activeness for t in scene.targets):
        _check_distances_defined(scene)
    if any(t.config.activeness for t in scene.targets):
        from .activeness import volume_activeness

        volume_activeness(scene)  # faces the shape lacks: refused before anything is written
    return scene


def _check_distances_defined(scene: Scene) -> None:
    """Steps and activeness need each step's distance to the rough surface; for patches bent
    onto a sphere that distance is not implemented, and on a boolean's face it needs the other
    faces of its constituent measured: refused before anything is written."""
    from .boolean_distance import check_measurable

    for layer in scene.layers:
        if layer.on_boolean is not None:
            check_measurable(layer, f"targets.{layer.target.entry}.rough")
            continue
        if isinstance(layer, CurvedRoughLayer) and isinstance(layer.ring_layout.face, SphereFace):
            raise ConfigError(
                f"targets.{layer.target.entry}.rough: face {layer.config.face_name} of "
                f"{layer.target.name!r} is a rough sphere face; steps (output.steps) and "
                "activeness need the distance to its rough surface, which score4 does not compute "
                "for sphere faces yet (use them without steps and activeness)"
            )
