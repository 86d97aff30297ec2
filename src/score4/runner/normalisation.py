"""What a run's events stand for: masses of the scored volumes, the source's area or mass, decays.

A template (counts per keV per kg per day for a unit contamination,
:mod:`score4.analysis.templates`) needs, besides the deposits, numbers that only the run knows: how
many decays its events stand for, how large the contaminated area (or mass) really was, and the
mass of every detector. :func:`run_normalisation` computes them from the configuration in numpy
(the process that reads a configuration never imports Geant4) and the engine stores them in the run
record of every results file (``/run`` attributes, JSON):

``volumes``
    one entry per scored column, in ``events/edep`` order: ``name``, ``material``,
    ``density_g_cm3``, ``volume_mm3`` (a box target plus the solid volume of its rough layers,
    computed from the same meshes Geant4 builds: the layers are scored with their target) and
    ``mass_kg``.
``source``
    ``kind`` (``surface``, ``bulk`` or ``vertices``), ``volume``, ``face``, ``area_mm2`` (the true
    rough area the vertices were drawn on: decays are uniform per true area, so an activity per
    area multiplies this area), ``projected_area_mm2`` (the flat face), ``volume_mm3`` and
    ``mass_kg`` (bulk sources), and for ``vertices`` the ``file`` (its area is known when the
    file was drawn by ``score4 vertices``, whose configuration it stores).
``simulated_decays``
    how many decays of ``activity_nuclide`` the events stand for (a float): one per event for a
    nuclide or particle source; for a decay chain, the decays of its head that the events stand
    for (:func:`score4.source.build.decay_normalisation`, with ``decay_chain``); for a chain
    with ``implantation``, the deposited head atoms (``n_atoms``: each decays once as the head,
    then its daughters as they are fed), so a quoted activity is the head's, the chain in
    secular equilibrium below it.
``activity_nuclide``
    the nuclide a quoted activity refers to (the ``decay`` nuclide or chain head, the ``nuclide``
    of a Geant4 radioactive-decay source), None for a plain particle source (an activity then
    counts emitted particles).

Densities: a ``materials:`` entry's own; a Geant4 NIST material's from
``score4/data/nist_densities.json``, a table that ``tools/nist_densities.py`` writes from
Geant4's ``G4NistManager`` (shipped, so no Geant4 import is needed here; a test compares it
with the installed Geant4).
"""

from __future__ import annotations

import json
from functools import cache
from importlib.resources import files
from typing import TYPE_CHECKING, Any

import numpy as np

from score4.errors import ConfigError

if TYPE_CHECKING:  # a worker imports this module for layer_volume only (geometry.masses)
    from score4.inputs.config import RunConfig
    from score4.world.scene import RoughLayer, Scene

#: Version of the normalisation entries; a results file without ``simulated_decays`` predates them.
NORMALISATION_VERSION = 1


@cache
def nist_density_table() -> dict[str, float]:
    """{Geant4 NIST material name: density in g/cm3} (tools/nist_densities.py wrote it)."""
    text = files("score4").joinpath("data/nist_densities.json").read_text()
    return dict(json.loads(text)["densities"])


def material_density(config: RunConfig, material: str) -> float | None:
    """Density (g/cm3) of a target material: a ``materials:`` entry or a NIST material; None if
    neither knows it (the geometry refuses such a material before any event)."""
    if material in config.materials:
        return float(config.materials[material].density)
    return nist_density_table().get(material)


def layer_volume(layer: RoughLayer) -> float:
    """Solid volume (mm3) of a rough layer: every cell's patch body (slab + rough top).

    The volume under a height-field top mesh is the sum over its triangles of the projected
    (xy) area times the mean height of the three corners, exact for the piecewise-linear mesh.
    """
    variants = np.asarray(layer.cell_variants).ravel()
    counts = np.bincount(variants[variants >= 0], minlength=len(layer.variants))  # -1: no patch
    px, py = layer.patch_size
    total = 0.0
    for count, surface in zip(counts, layer.variants, strict=True):
        mesh = surface.top_mesh
        heights = mesh.vertices[mesh.faces][:, :, 2].mean(axis=1)
        under_top = float(np.dot(mesh.projected_areas, heights))
        total += int(count) * (px * py * layer.base_thickness + under_top)
    return total


def _mass_kg(density: float | None, volume_mm3: float | None) -> float | None:
    # g/cm3 * mm3 = 1e-3 g = 1e-6 kg
    return None if density is None or volume_mm3 is None else density * volume_mm3 * 1e-6


def volume_entries(config: RunConfig, scene: Scene) -> list[dict[str, Any]]:
    """One entry per scored column, computed in numpy: the target's own material (its shape less
    its daughters) plus its rough layers, times the density of a ``materials:`` entry or a NIST
    material. A run's record holds the worker's entries instead (Geant4's solids and materials,
    :func:`score4.geometry.masses.volume_records`), which also know GDML materials."""
    from score4.source.build import bulk_sampler

    entries = []
    for t in scene.targets:
        density = material_density(config, t.material)
        try:
            own: float | None = bulk_sampler(scene, t.name).volume
        except ConfigError:  # no material of its own left
            own = None
        layers = sum(layer_volume(r) for r in scene.layers_of(t.name))
        volume = None if own is None else own + layers
        entries.append(
            {
                "name": t.name,
                "material": t.material,
                "density_g_cm3": density,
                "volume_mm3": volume,
                "mass_kg": _mass_kg(density, volume),
            }
        )
    return entries


def _base_source(config: RunConfig, scene: Scene, volumes: list[dict]) -> dict[str, Any]:
    """The source entry of a surface or bulk source (:func:`score4.source.build.source_geometry`),
    every contract key present; a bulk source's mass from its volume's density."""
    from score4.source.build import source_geometry

    entry: dict[str, Any] = {
        "kind": None,
        "volume": None,
        "face": None,
        "area_mm2": None,
        "projected_area_mm2": None,
        "volume_mm3": None,
        "mass_kg": None,
        **source_geometry(config, scene),
    }
    if entry["kind"] == "bulk" and entry["mass_kg"] is None:
        record = next((v for v in volumes if v["name"] == entry["volume"]), None)
        density = None if record is None else record.get("density_g_cm3")
        entry["mass_kg"] = _mass_kg(density, entry["volume_mm3"])
    return entry


def parse_stored_config(data: dict, origin: str) -> RunConfig:
    """A configuration stored with a file (``config_to_dict``: every key filled in), validated."""
    from pydantic import ValidationError

    from score4.common.schema import describe_validation_error
    from score4.inputs.config import RunConfig

    try:
        return RunConfig.model_validate(data, context={"base_dir": None, "stored": True})
    except ValidationError as err:
        raise ConfigError(describe_validation_error(err, origin)) from None


def _drawn_config(config: RunConfig) -> tuple[RunConfig | None, str | None]:
    """The configuration a vertex file was drawn from (with this run's number of events), or
    None and why not (a hand-made file stores none; a stored one may no longer rebuild)."""
    from score4.source.vertex_file import vertex_file_config
    from score4.world.resolve import build_scene

    path = config.source.vertices
    stored = vertex_file_config(path) if path is not None else {}
    if not stored:
        return None, None
    try:
        drawn = parse_stored_config(stored, f"{path} (stored configuration)")
        build_scene(drawn)  # its surfaces must still load
    except ConfigError as err:  # e.g. a surface file it names has moved: say so, do not guess
        return None, f"the vertex file's stored configuration does not rebuild: {err}"
    run = drawn.run.model_copy(update={"events": config.run.events})
    return drawn.model_copy(update={"run": run}), None


def _vertices_source(config: RunConfig, volumes: list[dict]) -> dict[str, Any]:
    """A vertex file: its area or mass is known if it stores the configuration it was drawn from."""
    entry: dict[str, Any] = {
        "kind": "vertices",
        "file": str(config.source.vertices),
        "volume": None,
        "face": None,
        "area_mm2": None,
        "projected_area_mm2": None,
        "volume_mm3": None,
        "mass_kg": None,
        "drawn_from": None,  # hand-made vertices: only a total activity applies
    }
    from score4.world.resolve import build_scene

    drawn, note = _drawn_config(config)
    if note:
        entry["note"] = note
    if drawn is not None:
        inner = _base_source(drawn, build_scene(drawn), volumes)
        entry.update({k: v for k, v in inner.items() if k != "kind"})
        entry["drawn_from"] = inner["kind"]
    return entry


def source_entry(
    config: RunConfig, scene: Scene, volumes: list[dict] | None = None
) -> dict[str, Any]:
    """The ``source`` entry of the run record (see the module notes); ``volumes`` (default:
    :func:`volume_entries`) give a bulk source's density."""
    volumes = volume_entries(config, scene) if volumes is None else volumes
    if config.source.vertices is not None:
        return _vertices_source(config, volumes)
    return _base_source(config, scene, volumes)


def decays(config: RunConfig) -> dict[str, Any]:
    """``simulated_decays``, ``activity_nuclide`` (and ``decay_chain`` for a chain) of a run,
    from the source's emitter (:func:`score4.source.build.decay_normalisation`); a vertex file
    drawn by ``score4 vertices`` stands for what its configuration's events stood for."""
    from score4.source.build import decay_normalisation

    if config.source.vertices is not None:
        drawn, _ = _drawn_config(config)
        if drawn is None:  # hand-made: one "decay" per event, no nuclide
            return {"simulated_decays": float(config.run.events), "activity_nuclide": None}
        return decay_normalisation(drawn)
    return decay_normalisation(config)


def run_normalisation(
    config: RunConfig, scene: Scene, volumes: list[dict] | None = None
) -> dict[str, Any]:
    """The run record's normalisation entries (``volumes``, ``source``, ``simulated_decays``,
    ``activity_nuclide``, ``decay_chain`` for a chain, ``normalisation_version``) for ``config``
    built into ``scene``.

    ``volumes``: the worker's entries (Geant4's solids and densities, GDML materials included);
    default: :func:`volume_entries` (numpy; NIST and ``materials:`` densities). The rest is
    numpy: areas and volumes from the same meshes and shapes the geometry and the sampler use.
    """
    volumes = volume_entries(config, scene) if volumes is None else volumes
    return {
        "volumes": volumes,
        "source": source_entry(config, scene, volumes),
        **decays(config),
        "normalisation_version": NORMALISATION_VERSION,
    }
