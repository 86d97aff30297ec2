"""score4 as a library, for your own geant4_pybind application.

``score4 run`` builds its own Geant4 application from a configuration file. This module gives
the same pieces to a program that builds its world, physics and event loop itself (the
original SCoRe4's use: classes dropped into an existing detector construction, primary
generator and event loop):

* **Geant4 set-up**: :func:`import_geant4` (data locations fixed before the import; ``lite``
  physics runs with no data sets), :func:`physics_list`, :func:`after_initialize`.
* **Surfaces**: :func:`build_surface` from a description (the keys of a ``surfaces:`` entry),
  :func:`load_surface` / :func:`save_surface` for score4 surface files.
* **Your world**: :class:`World` reads the volume tree of your world;
  :meth:`World.roughen` puts a rough layer on a face of one of your volumes (native tiling)
  and returns the logical volumes to score; :meth:`World.source` makes a source on faces of a
  volume (below the rough surface, with a depth profile) or in its bulk, emitting a particle,
  a nuclide's decays (``Po210``) or a chain's (score4's own decay data, no Geant4 data).
* **A run configuration**: :func:`plan_run` resolves one (a ``score4 run`` YAML file read by
  :func:`score4.inputs.config.load_config`) into the :class:`RunPlan` that ``score4 run`` itself
  runs: its source (``plan.source``) and seed (``plan.seed``) give your application the same events.
* **Events**: :class:`PrimaryGenerator` fills your ``G4Event`` s from a source;
  :class:`HeavyIonReplay` moves heavy ions (the Pb-206 recoil of Po-210) along TRIM
  trajectories through your geometry, as a hook for your end-of-event action.

Every function takes the keys and quantities of a run configuration ("20 nm", "5.3 MeV"),
validated by the same models with the same one-line errors (:class:`score4.errors.ConfigError`),
and calls the same code as ``score4 run``: a world built here from the same volumes, with the
same seed, gives the same events and the same energy deposits.

This module imports no Geant4 itself: every function that needs it takes the ``geant4_pybind``
module (``g4``) as its first argument.

Example: ``examples/own_application.py``; the reference part of ``docs/api.md`` is
rendered from these docstrings by ``make docs`` (mkdocstrings).
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import ValidationError

from score4.common.schema import describe_validation_error
from score4.common.units import parse_quantity
from score4.inputs.config import GdmlVolume, PhysicsConfig, RoughFace, SourceConfig
from score4.runner.run_plan import RunPlan, plan_run
from score4.world.boolean_layers import fit_cells, into_joint, target_layers
from score4.world.clearance import check_clearance
from score4.world.gdml_model import GeometryModel, Instance
from score4.world.scene import (
    RingRoughLayer,
    RoughLayer,
    Scene,
    TargetVolume,
    check_into_edges,
    fit_rings,
    gdml_target,
    rough_faces,
)

from .errors import ConfigError
from .source.build import BulkSource, SampledSource, source_from_config
from .source.primaries import Primaries
from .surface.spec import Surface, build_surface
from .surface.store import load_surface, save_surface

__all__ = [
    "BulkSource",
    "HeavyIonReplay",
    "Primaries",
    "PrimaryGenerator",
    "ReplayedIon",
    "RoughenedVolume",
    "RunPlan",
    "SampledSource",
    "Surface",
    "World",
    "after_initialize",
    "build_surface",
    "import_geant4",
    "load_surface",
    "physics_list",
    "plan_run",
    "save_surface",
]


# -- Geant4 set-up ---------------------------------------------------------------------------


def import_geant4(physics: str = "auto"):
    """Import geant4_pybind with the Geant4 data locations score4 uses, and return the module.

    Call it before anything else imports ``geant4_pybind``: Geant4 reads its data locations at
    import (without them geant4_pybind asks on stdin or tries to download). ``physics`` is
    ``lite`` (no data sets needed: alpha and ion transport only), ``full`` (needs the data sets
    ``score4 data install`` fetches) or ``auto`` (``full`` when they are installed).

    Parameters
    ----------
    physics
        ``auto``, ``full`` or ``lite``.

    Returns
    -------
    module
        ``geant4_pybind``.
    """
    from .sim.runtime import import_geant4 as _import
    from .sim.runtime import resolve_physics

    return _import(resolve_physics(_mode(physics)))


def physics_list(g4, physics: str = "auto", production_cut: str = "1 um"):
    """score4's physics list, for your run manager's ``SetUserInitialization``.

    ``full``: ``G4EmStandardPhysics_option4``; ``lite``: ``G4EmStandardPhysics`` (its
    data-hungry processes are removed by :func:`after_initialize`). Both with score4's step
    function for alphas and without nuclear stopping (docs/physics.md says why). Also sets the
    production cut (``/run/setCut``; Geant4's 0.7 mm default makes no delta rays in micrometre
    geometry) and drops Geant4's unused parallel-world region, which costs time at every
    ``BeamOn`` on a large rough face. Call after creating the run manager, before
    ``Initialize()``.

    Parameters
    ----------
    g4
        The geant4_pybind module.
    physics
        ``auto``, ``full`` or ``lite`` (as given to :func:`import_geant4`).
    production_cut
        Secondary-production threshold as a range, with its unit.

    Returns
    -------
    G4VModularPhysicsList
        Keep a reference to it while the run manager lives.
    """
    from .sim.physics import (
        drop_unused_parallel_world_region,
        make_physics_list,
        set_production_cut,
    )
    from .sim.runtime import resolve_physics

    cut = parse_quantity(production_cut, "length", "production_cut")
    if not cut > 0:
        raise ConfigError(f"production_cut: must be > 0, got {production_cut!r}")
    physics_list = make_physics_list(g4, resolve_physics(_mode(physics)))
    set_production_cut(g4, cut)
    drop_unused_parallel_world_region(g4)
    return physics_list


def after_initialize(g4, physics: str = "auto") -> list[str]:
    """Finish the physics: call it after your run manager's ``Initialize()`` and before the
    first ``BeamOn``.

    In ``lite`` mode (no Geant4 data sets, see :func:`import_geant4`) the physics list still
    holds processes whose tables come from the G4EMLOW data set and are read at the first
    event: bremsstrahlung of e- and e+ (``eBrem``) and the gamma process
    (``GammaGeneralProc``). This removes them, so alphas and ions are tracked without data
    (docs/geant4-facts.md); electrons then radiate no bremsstrahlung and gammas are not
    tracked (what lite physics lacks: ``score4.sim.runtime.LITE_LACKS``). In ``full`` mode
    (and ``auto`` with the data installed) it does nothing.

    Returns the removed processes as ``particle:process`` (empty in full mode).
    """
    from .sim.physics import strip_data_hungry_processes
    from .sim.runtime import resolve_physics

    if resolve_physics(_mode(physics)).mode == "lite":
        return strip_data_hungry_processes(g4)
    return []


def _mode(physics: str) -> str:
    if physics not in ("auto", "full", "lite"):
        raise ConfigError(f"physics: must be auto, full or lite, got {physics!r}")
    return physics


# -- your world ------------------------------------------------------------------------------


@dataclass
class RoughenedVolume:
    """What :meth:`World.roughen` made.

    Attributes
    ----------
    layers
        The rough layers, one per copy of the volume (:class:`score4.world.scene.RoughLayer`: face
        frame, patch map, true area through ``score4.source.build.layer_sampler(layer).area``).
    volumes
        Per scoring column (the volume's name, ``name_k`` for copies): the logical volumes whose
        energy deposits count for it, the volume's own first, then the patch bodies of its
        rough layers (of the volume's material). Attach your sensitive detector or scorer to
        all of them.
    """

    layers: list[RoughLayer]
    volumes: dict[str, list]

    @property
    def logical_volumes(self) -> list:
        """All logical volumes of :attr:`volumes`, in order."""
        return [lv for lvs in self.volumes.values() for lv in lvs]


class World:
    """Your Geant4 world as score4 sees it: volumes by object or name, rough faces, sources.

    The volume tree (solids, materials, placements, global transforms) is read once, here,
    from the live world: build it completely first. Volumes are then named by their
    ``G4VPhysicalVolume`` (that placement; all its copies if its mother is placed several
    times), their ``G4LogicalVolume`` (all its placements) or a name as in a configuration
    (``crystal``, ``crystal[1]``, a logical volume name). Each volume used gets a scoring
    column, named as in a configuration (``crystal``, or ``crystal_0``, ``crystal_1``, ... for
    copies): :attr:`scoring`.

    Parameters
    ----------
    g4
        The geant4_pybind module.
    world
        Your world's ``G4VPhysicalVolume`` (what your detector construction returns).

    Attributes
    ----------
    scene
        score4's description of the volumes it uses (:class:`score4.world.scene.Scene`).
    scoring
        Scoring column -> the logical volumes whose deposits count for it (the volume's own,
        then the patches of its rough layers): for your scorer and for
        :class:`HeavyIonReplay`.
    """

    def __init__(self, g4, world) -> None:
        from .geometry.gdml import extract_model
        from .geometry.gdml_world import LiveWorld

        self.g4 = g4
        self.world = world
        self._logicals: list = []
        data = extract_model(g4, world, f"world {world.GetName()}", [], live=self._logicals)
        self.model = GeometryModel.from_dict(data)
        self.scene = Scene(None, {}, model=self.model)
        self._live = LiveWorld(g4, self.model, world)
        self.scoring: dict[str, list] = {}

    # -- volumes ---------------------------------------------------------------------------------

    def instances(self, volume, parameter: str = "volume") -> list[Instance]:
        """The placements (instances of the volume tree) ``volume`` stands for: a
        ``G4VPhysicalVolume``, a ``G4LogicalVolume`` or a name."""
        model = self.model
        if isinstance(volume, str):
            try:
                return model.resolve(volume, parameter)
            except ConfigError as err:
                text = re.sub(r"`score4 geometry list [^`]*`", "World.model.rows()", str(err))
                raise ConfigError(text) from None
        if hasattr(volume, "GetLogicalVolume"):  # a physical volume: match the live objects
            hits = [
                model.instances[i]
                for i in model.by_name.get(str(volume.GetName()), [])
                if self._live_pv(model.instances[i]) is volume
            ]
        elif hasattr(volume, "GetNoDaughters"):  # a logical volume: all its placements
            index = next((k for k, lv in enumerate(self._logicals) if lv is volume), None)
            hits = [i for i in model.instances if index is not None and i.logical == index]
        else:
            raise ConfigError(
                f"{parameter}: give a G4VPhysicalVolume, a G4LogicalVolume or a volume name, "
                f"not a {type(volume).__name__}"
            )
        if not hits:
            raise ConfigError(
                f"{parameter}: {volume.GetName()!s} is not in this world (volumes are read when "
                "the World is made: build the world first)"
            )
        return hits

    def _live_pv(self, inst: Instance):
        if inst.mother is None:
            return self.world
        mother = self.model.instances[inst.mother]
        return self._logicals[mother.logical].GetDaughter(inst.path[-1])

    def targets(self, volume, parameter: str = "volume") -> list[TargetVolume]:
        """The scored volumes (one per copy) ``volume`` stands for, made scored if they were
        not (:attr:`scoring` then has their columns)."""
        instances = self.instances(volume, parameter)
        several = len(instances) > 1
        out, fresh = [], []
        for k, inst in enumerate(instances):
            known = next(
                (t for t in self.scene.targets if t.instance and t.instance.index == inst.index),
                None,
            )
            if known is not None:
                out.append(known)
                continue
            if isinstance(volume, str):
                label = volume
            else:  # an object: its name for several copies, else the name of its one placement
                label = str(volume.GetName()) if several else self.model.label(inst)
            entry = len({t.entry for t in self.scene.targets})
            target = gdml_target(
                self.model, GdmlVolume(volume=label), entry, inst, k if several else None, parameter
            )
            if any(t.column == target.column for t in self.scene.targets):
                raise ConfigError(
                    f"{parameter}: {target.column!r} is already the column of another volume; "
                    "name this one by a placement (name[k])"
                )
            out.append(target)
            fresh.append(target)
        for target in fresh:
            self.scene.targets.append(target)
            lv, _material = self._live.place_target(self.scene, target)
            self.scoring[target.column] = [lv]
        return out

    def _one_target(self, volume, parameter: str) -> TargetVolume:
        targets = self.targets(volume, parameter)
        if len(targets) != 1:
            raise ConfigError(
                f"{parameter}: {_label(volume)} stands for {len(targets)} volumes "
                f"({', '.join(t.column for t in targets)}); give one placement"
            )
        return targets[0]

    # -- rough faces -------------------------------------------------------------------------------

    def roughen(
        self,
        volume,
        face: str | Sequence[str] = "+z",
        surface: Surface | Mapping | Sequence[tuple[Surface | Mapping, float]] | None = None,
        **options: Any,
    ) -> RoughenedVolume:
        """Put a rough layer on ``face`` of ``volume`` (on each face of a group or list) and
        place it in your world (native tiling: Geant4 placements of a few patch volumes,
        navigation in C++).

        The layer sits on the face, outside the volume, in the volume's mother (or, with
        ``into=True``, takes the place of the volume's outermost layer, the volume being cut by
        it, so that its outer dimensions stay); its patches are of the volume's material, its
        envelope of the mother's. It must not meet any other daughter of the mother: the
        error names what it meets and the free gap. Faces: those a configuration's rough entry
        takes (docs/config.md; a G4Box's ``+x`` ... ``-z`` in the box's own frame). Layers
        placed by an earlier call do not change: a flat ring gives way to the layer of a wall
        rising from it (a groove, a shoulder) only when the wall comes first or in the same
        call, and ``into`` on faces that share an edge (a tube's wall and end face; a post's wall
        and the top of the disk it stands on, constituents of a boolean) needs them in one
        call, which cuts them as a configuration does; otherwise the call is refused and
        nothing changes. Call it before your run
        manager's ``Initialize()``.

        Parameters
        ----------
        volume
            A ``G4VPhysicalVolume``, ``G4LogicalVolume`` (every placement gets its layer) or
            a name.
        face
            A face or face group of the volume's solid (``+z``, ``outer``, ``seg_2``, ...), or a
            list of them.
        surface
            A :class:`Surface` (:func:`build_surface`, :func:`load_surface`), a surface
            description (the keys of a ``surfaces:`` entry), or a list of ``(surface,
            density)`` pairs: patch variants with target densities.
        **options
            The other keys of a rough face (docs/config.md): ``base_thickness`` ("1 um"),
            ``into``, ``solid``, ``block_cells``, ``fill``, ``n_tiles``, ``seed``,
            ``native_layout``.

        Returns
        -------
        RoughenedVolume
            The layers and, per scoring column, the logical volumes to score.
        """
        where = f"roughen({_label(volume)}, {face!r})"
        if surface is None:
            raise ConfigError(f"{where}: give surface (a Surface, a description or variants)")
        if "tiling" in options and options["tiling"] != "native":
            raise ConfigError(f"{where}: tiling: your own world takes native tiling only")
        spec: dict[str, Any] = {"face": face if isinstance(face, str) else list(face), **options}
        if isinstance(surface, (Surface, Mapping)):
            spec["surface"] = self._surface_name(surface, where)
        else:
            spec["variants"] = [
                {"surface": self._surface_name(s, where), "density": float(d)} for s, d in surface
            ]
        try:
            rough = RoughFace.model_validate(spec)
        except ValidationError as err:
            raise ConfigError(describe_validation_error(err, where)) from None
        targets = self.targets(volume, where)
        placed = list(self.scene.layers)
        saved = [_LayerState.of(layer) for layer in placed]
        try:
            for t in targets:
                j = len(self.scene.layers_of(t.name))
                for name in rough_faces(t, rough):
                    if self.scene.layer(t.name, name) is not None:
                        raise ConfigError(f"{where}: face {name} of {t.name!r} is rough already")
                    one = rough if rough.face == name else rough.model_copy(update={"face": name})
                    self.scene.layers += target_layers(self.scene.surfaces, t, j, one, where=where)
            for t in targets:
                check_into_edges(self.scene, t, where)
                into_joint(self.scene, t, where)
                fit_rings(self.scene.layers_of(t.name), placed, where)
                fit_cells(self.scene.layers_of(t.name))
            for state in saved:
                state.refuse_change(self.scene, where)
            check_clearance(self.scene)
        except ConfigError as err:
            self.scene.layers[:] = placed  # and every placed layer as it was
            for state in saved:
                state.restore()
            if where in str(err):
                raise
            raise ConfigError(f"{where}: {err}") from None
        layers = [layer for layer in self.scene.layers if not any(layer is p for p in placed)]
        out: dict[str, list] = {}
        for t in targets:
            lv, material = self._live.place_target(self.scene, t)  # cuts the volume for into
            patches = []
            for layer in layers:
                if layer.target.name == t.name:
                    patches += self._live.place_layer(layer, material)
            self.scoring[t.column] += patches
            out[t.column] = [lv, *patches]
        return RoughenedVolume(layers, out)

    def _surface_name(self, surface: Surface | Mapping, where: str) -> str:
        if not isinstance(surface, Surface):
            try:
                surface = build_surface(dict(surface))
            except ConfigError as err:
                raise ConfigError(f"{where}: {err}") from None
        for name, known in self.scene.surfaces.items():
            if known is surface:
                return name
        name = f"surface_{len(self.scene.surfaces) + 1}"
        self.scene.surfaces[name] = surface
        return name

    # -- sources ---------------------------------------------------------------------------------

    def source(self, *, surface=None, volume=None, **keys: Any) -> SampledSource | BulkSource:
        """A source of primaries on faces of one of your volumes, or in its bulk.

        Exactly as a configuration's ``source:`` section (docs/config.md), with the volume given
        as an object or a name: vertices uniform per true area on the faces (a rough face on
        its mesh, the others flat or curved, all in the volume's own frame), ``depth`` below
        the local surface, confined to the volume's own material (its daughters excluded); or
        uniform in the volume's material (``volume``, bulk).

        Parameters
        ----------
        surface
            ``(volume, face)``: a volume (object or name; one placement) and a face name
            (``+z``, a face or group of the volume's solid, ``all``).
        volume
            A volume (bulk source), instead of ``surface``.
        **keys
            ``particle`` with ``energy`` ("5.3 MeV") or ``spectrum``, or ``decay`` ("Po210",
            ``{"chain": "Pb210"}``), or ``nuclide``; ``direction``, ``depth``
            (``{"profile": "exponential", "mean": "20 nm"}``), ``confine``. Relative file paths
            are taken from the current folder.

        Returns
        -------
        SampledSource or BulkSource
            ``events(seed, first_event, n_events)`` gives :class:`Primaries`; hand it to a
            :class:`PrimaryGenerator`.
        """
        data: dict[str, Any] = dict(keys)
        if surface is not None:
            if isinstance(surface, Mapping):
                ref, face = surface.get("volume"), surface.get("face", "+z")
            else:
                ref, face = surface
            target = self._one_target(ref, "source.surface.volume")
            data["surface"] = {"volume": target.column, "face": face}
        if volume is not None:
            data["volume"] = self._one_target(volume, "source.volume").column
        try:
            src = SourceConfig.model_validate(data, context={"base_dir": Path.cwd()})
        except ValidationError as err:
            raise ConfigError(describe_validation_error(err, "source")) from None
        if src.run_unit == "atom":  # the tracker lives in score4's own loop
            raise ConfigError(
                "source.decay.implantation: per-atom histories need score4 run (it moves each "
                "daughter to where the TRIM replay stopped its recoil before Geant4 tracks the "
                "event); the library's PrimaryGenerator would decay every daughter at its deposit"
            )
        return source_from_config(src, self.scene)


@dataclass
class _LayerState:
    """What the fitting of a new rough layer may change in a layer placed already (a ring's
    radii and cells, an end face's cut ring): kept to refuse the change, or to restore it when
    the new layer is refused."""

    layer: RoughLayer
    mask: np.ndarray | None
    rest_radii: tuple[float, float] | None
    ring: tuple[float, float] | None

    @classmethod
    def of(cls, layer: RoughLayer) -> _LayerState:
        ring = layer.ring if isinstance(layer, RingRoughLayer) else None
        return cls(layer, layer.mask, layer.rest_radii, ring)

    def changed(self) -> bool:
        layer = self.layer
        ring = layer.ring if isinstance(layer, RingRoughLayer) else None
        if (layer.rest_radii, ring) != (self.rest_radii, self.ring):
            return True
        if layer.mask is None or self.mask is None:
            return layer.mask is not self.mask
        return not np.array_equal(layer.mask, self.mask)

    def refuse_change(self, scene: Scene, where: str) -> None:
        """ConfigError when the new layers replaced or changed this placed layer (``into`` on
        faces that share an edge: their joint cut lays both out again)."""
        layer = self.layer
        if all(r is not layer for r in scene.layers) or self.changed():
            raise ConfigError(
                f"{where}: the layer on face {layer.config.face_name} of {layer.target.name!r} "
                "is placed already and would change (into on faces that share an edge: both "
                "layers are laid out on their joint cut); give these faces in one call "
                "(a list of faces)"
            )

    def restore(self) -> None:
        layer = self.layer
        layer.mask, layer.rest_radii = self.mask, self.rest_radii
        if isinstance(layer, RingRoughLayer) and self.ring is not None:
            layer.rmin, layer.rmax = self.ring


def _label(volume) -> str:
    return repr(volume) if isinstance(volume, str) else str(volume.GetName())


# -- heavy ions --------------------------------------------------------------------------------


@dataclass
class ReplayedIon:
    """Where a replayed heavy ion ended and what it left behind.

    Attributes
    ----------
    deposits
        Volume name (a key of the replay's ``volumes``) -> energy deposited, MeV.
    lengths
        Volume name -> path length in it, mm.
    position
        Where it stopped or left the world, mm.
    escaped_energy
        Energy it carried out of the world, MeV (0 when it stopped).
    """

    deposits: dict[str, float] = field(default_factory=dict)
    lengths: dict[str, float] = field(default_factory=dict)
    position: np.ndarray = field(default_factory=lambda: np.zeros(3))
    escaped_energy: float = 0.0


class HeavyIonReplay:
    """Heavy ions moved along TRIM trajectories through your geometry: a hook for your event
    loop.

    Geant4 stops a 103 keV Pb-206 ion (the recoil of Po-210) at a sixth of TRIM's depth, with
    no straggling (docs/physics.md). The replay keeps such ions away from Geant4 and moves each
    along a TRIM history (lunasrim's SRIM-2013, computed once per ion, energy and material,
    then cached), through your volumes with a Geant4 navigator of its own, crossing boundaries
    into other materials and vacuum gaps. Energy lost in a volume of ``volumes`` counts for it.

    * Primaries: with a :class:`PrimaryGenerator` (``replay=``) the ions among the primaries are
      held back as events are generated, and :meth:`PrimaryGenerator.end_of_event` replays
      them. Without one, :meth:`takes` and :meth:`transport` do it by hand.
    * Secondaries: :meth:`stacking_action` takes the heavy ions Geant4 creates during an event
      (the recoiling daughter of an alpha decay in Geant4's radioactive decay; a nucleus knocked
      on by a proton) as they are made, replays them, and books their deposits for
      :meth:`end_of_event` (which :meth:`PrimaryGenerator.end_of_event` includes).

    Parameters
    ----------
    g4
        The geant4_pybind module.
    world
        Your world's ``G4VPhysicalVolume``.
    volumes
        Name -> logical volumes whose deposits count under that name (e.g.
        :attr:`World.scoring`). Volumes are matched by their logical volume's name.
    seed
        The run seed: the TRIM libraries' histories are drawn from it, as ``score4 run`` does.
    heavy_ions
        ``trim`` (ions heavier than helium of kinetic energy up to ``max_energy`` are replayed)
        or ``geant4``.
    alphas
        ``geant4`` or ``trim`` (alpha primaries of any energy are replayed too).
    max_energy
        Heavy ions above it stay with Geant4.
    histories
        TRIM histories per ion, energy and material. ``score4 run`` scales its default with the
        run's events (:func:`score4.inputs.config.default_trim_histories`: 1000 per 20 000
        events); with more than 20 000 replayed ions per library, raise it likewise.
    """

    def __init__(
        self,
        g4,
        world,
        volumes: Mapping[str, Sequence | Any],
        *,
        seed: int = 1,
        heavy_ions: str = "trim",
        alphas: str = "geant4",
        max_energy: str = "1 MeV",
        histories: int = 1000,
    ) -> None:
        try:
            self.settings = PhysicsConfig.model_validate(
                {
                    "heavy_ions": heavy_ions,
                    "alphas": alphas,
                    "trim_max_energy": max_energy,
                    "trim_histories": histories,
                }
            )
        except ValidationError as err:
            raise ConfigError(describe_validation_error(err, "HeavyIonReplay")) from None
        if not 0 <= int(seed) < 2**63:
            raise ConfigError(f"HeavyIonReplay: seed: must be 0 <= seed < 2**63, got {seed}")
        self.g4 = g4
        self.world = world
        self.seed = int(seed)
        self.histories = int(histories)
        self.volumes = {
            name: list(lvs) if isinstance(lvs, (list, tuple)) else [lvs]
            for name, lvs in volumes.items()
        }
        self.names = list(self.volumes)
        self._transport: Any = None
        self._definitions: dict[str, Any] = {}
        self._event: tuple[int, int] | None = None  # (index, seed) set by a PrimaryGenerator
        self._booked: dict[str, float] = {}
        self._stacking: Any = None
        self.decay = False  # radioactive decay in your physics (see stacking_action)
        #: heavy-ion secondaries taken from Geant4 and replayed in the current event
        #: (:class:`score4.sim.interception.InterceptedIon`)
        self.intercepted: list = []

    @property
    def transport_engine(self):
        """The :class:`score4.sim.heavy_ions.HeavyIonTransport` (made at first use: Geant4
        must have closed the geometry, i.e. a run must have started)."""
        if self._transport is None:
            from score4.runner.seeds import library_trim_seed

            from .sim.heavy_ions import HeavyIonTransport

            self._transport = HeavyIonTransport(
                self.g4,
                self.world,
                self.volumes,
                histories=self.histories,
                library_seed=library_trim_seed(self.seed),
            )
        return self._transport

    def definition(self, particle: str):
        """The G4ParticleDefinition of a particle or ion name (``alpha``, ``Pb206``)."""
        if particle not in self._definitions:
            from .sim.simulation import resolve_particle

            self._definitions[particle] = resolve_particle(self.g4, particle, "particle")
        return self._definitions[particle]

    def takes(self, primaries: Primaries) -> np.ndarray:
        """Boolean mask of the rows of ``primaries`` the replay moves (not Geant4)."""
        from .sim.heavy_ions import trim_mask

        s = self.settings
        return trim_mask(primaries, self.definition, s.heavy_ions, s.alphas, s.trim_max_energy)

    def transport(
        self,
        particle: str,
        energy: float,
        position: Sequence[float],
        direction: Sequence[float],
        rng: np.random.Generator,
    ) -> ReplayedIon:
        """Move one ion of ``energy`` (MeV) from ``position`` (mm) along ``direction``; call it
        during a run (from an event action), when the geometry is closed."""
        fate = self.transport_engine.transport(
            self.definition(particle), particle, float(energy), position, direction, rng
        )
        return self._named(fate)

    def _named(self, fate) -> ReplayedIon:
        return ReplayedIon(
            {self.names[k]: v for k, v in fate.deposits.items()},
            {self.names[k]: v for k, v in fate.lengths.items()},
            np.asarray(fate.position, float),
            float(fate.escaped_energy),
        )

    # -- secondaries -----------------------------------------------------------------------------

    def stacking_action(self, radioactive_decay: bool = False):
        """A ``G4UserStackingAction`` for ``run_manager.SetUserAction``: every heavy ion (Z > 2)
        Geant4 creates with a kinetic energy from 1 keV to ``max_energy`` is replayed as it is
        made, its deposits booked for :meth:`end_of_event`. An unstable ion that stopped goes
        back to Geant4, at rest where TRIM stopped it, when ``radioactive_decay`` (your physics
        has radioactive decay), so the chain goes on from there; other ions are killed.

        Without a :class:`PrimaryGenerator`, each event's replays draw from a stream of the
        run seed and Geant4's event number."""
        from .sim.interception import make_stacking_action

        self.decay = bool(radioactive_decay)
        if self._stacking is None:
            self._stacking = make_stacking_action(self.g4, self.transport_engine, self)
            self._stacking.heavy = self.settings.heavy_ions == "trim"
        return self._stacking

    @property
    def max_energy(self) -> float:
        return float(self.settings.trim_max_energy)

    def begin_event(self, index: int, seed: int) -> None:
        """Called by :class:`PrimaryGenerator` as it generates an event: its number and seed."""
        self._event = (int(index), int(seed))
        self.intercepted = []

    def current_event(self) -> tuple[int, int]:
        """(number, seed) of the event being tracked (the stacking action's random streams)."""
        if self._event is not None:
            return self._event
        event = self.g4.G4RunManager.GetRunManager().GetCurrentEvent()
        k = int(event.GetEventID()) if event is not None else 0
        return k, self.seed * 1_000_003 + k

    def book(self, event: int, fate) -> None:
        """Book a replayed secondary's deposits for :meth:`end_of_event`."""
        for name, value in self._named(fate).deposits.items():
            self._booked[name] = self._booked.get(name, 0.0) + value

    def untrack(self, event: int, energy: float) -> None:
        """(Photons are left to your physics: nothing to count.)"""

    def end_of_event(self) -> dict[str, float]:
        """Deposits (MeV per volume name) of the heavy-ion secondaries replayed during the event
        (:meth:`stacking_action`); call it once per event, from your ``EndOfEventAction``
        (:meth:`PrimaryGenerator.end_of_event` does, with a generator)."""
        booked, self._booked = self._booked, {}
        self._event = None
        return booked


# -- events ------------------------------------------------------------------------------------


class PrimaryGenerator:
    """Fills your ``G4Event`` s with the primaries of a source, event after event.

    Event ``k`` is drawn exactly as ``score4 run`` draws event ``k`` of a run with the same
    seed (in blocks of 1000 events, each from its own random stream), and by default Geant4's
    random engine is reseeded with the event's own seed before it is filled, so an event's
    result depends on nothing but the seed and its number, as in ``score4 run``.

    Call :meth:`generate` from your ``G4VUserPrimaryGeneratorAction.GeneratePrimaries`` (or
    register :meth:`action`), and, with a ``replay``, :meth:`end_of_event` from your
    ``G4UserEventAction.EndOfEventAction``.

    Parameters
    ----------
    g4
        The geant4_pybind module.
    source
        From :meth:`World.source` (anything with ``events(seed, first_event, n_events)``).
    seed
        The run seed.
    first_event
        Number of the first event to generate (e.g. for the second half of a run).
    replay
        A :class:`HeavyIonReplay`: the primaries it takes are held back from Geant4 and
        replayed by :meth:`end_of_event`.
    reseed_geant4
        Reseed Geant4's engine with each event's seed (False: leave Geant4's random engine
        alone).
    """

    def __init__(
        self,
        g4,
        source,
        *,
        seed: int = 1,
        first_event: int = 0,
        replay: HeavyIonReplay | None = None,
        reseed_geant4: bool = True,
    ) -> None:
        if not 0 <= int(seed) < 2**63:
            raise ConfigError(f"seed: must be 0 <= seed < 2**63, got {seed}")
        if int(first_event) < 0:
            raise ConfigError(f"first_event: must be >= 0, got {first_event}")
        self.g4 = g4
        self.source = source
        self.seed = int(seed)
        self.next_event = int(first_event)
        self.replay = replay
        self.reseed_geant4 = reseed_geant4
        self._gun = g4.G4ParticleGun(1)
        self._feed: Any = None
        self._held: np.ndarray = np.zeros(0, dtype=bool)
        self._first = 0
        self._pending: tuple[Any, int] | None = None
        self._definitions: dict[str, Any] = {}
        self._action: Any = None
        self.replayed: list[ReplayedIon] = []

    def generate(self, event) -> Primaries:
        """Put the next event's primaries into the G4Event ``event`` (heavy ions the replay
        takes are held back); returns all of the event's primaries (rows of event 0)."""
        from score4.source.event_blocks import BLOCK_EVENTS

        k = self.next_event - self._first
        if self._feed is None or k >= self._feed.n_events:
            n = BLOCK_EVENTS - self.next_event % BLOCK_EVENTS
            self._load(self.next_event, n)
            k = 0
        if self.replay is not None:
            self.replay.begin_event(k, int(self._feed.seeds[k]))
        self._feed.fill(self._gun, event, k)
        self._pending = (self._feed, k)
        self.next_event += 1
        return self._feed.primaries.select_events(k, k + 1)

    def _load(self, first: int, n: int) -> None:
        from score4.runner.seeds import event_geant4_seeds

        from .sim.feed import EventFeed

        primaries = self.source.events(self.seed, first, n)
        definitions = [self._definition(str(name)) for name in primaries.particle]
        held = np.zeros(len(primaries), dtype=bool)
        if self.replay is not None:
            held = self.replay.takes(primaries)
            if held.any():
                engine = self.replay.transport_engine
                for name, energy in set(
                    zip(primaries.particle[held], primaries.energy[held], strict=True)
                ):
                    engine.need(str(name), float(energy))
        seeds = event_geant4_seeds(self.seed, first, n)
        self._feed = EventFeed(
            self.g4, primaries, definitions, seeds, held, reseed=self.reseed_geant4
        )
        self._held = held
        self._first = first

    def _definition(self, name: str):
        if name not in self._definitions:
            from .sim.simulation import resolve_particle

            self._definitions[name] = resolve_particle(self.g4, name, "source.particle")
        return self._definitions[name]

    def end_of_event(self) -> dict[str, float]:
        """Replay the heavy ions held back from the last generated event (call it once per
        event, after Geant4 has tracked it: from your ``EndOfEventAction``), and collect the
        deposits of heavy-ion secondaries the replay's :meth:`HeavyIonReplay.stacking_action`
        replayed during the event.

        Returns
        -------
        dict
            Volume name (of the replay's ``volumes``) -> energy the ions deposited there, MeV
            (empty without a replay or when the event had no heavy ion). The held-back ions'
            fates are in :attr:`replayed`.
        """
        self.replayed = []
        if self.replay is None or self._pending is None:
            return {}
        from .sim.feed import replay_row

        feed, k = self._pending
        self._pending = None
        total = self.replay.end_of_event()
        for row in feed.rows_of(k, self._held):
            ion = self.replay._named(replay_row(self.replay.transport_engine, feed, k, int(row)))
            self.replayed.append(ion)
            for name, value in ion.deposits.items():
                total[name] = total.get(name, 0.0) + value
        return total

    def action(self):
        """A ``G4VUserPrimaryGeneratorAction`` that calls :meth:`generate`, for
        ``run_manager.SetUserAction`` (the generator keeps it alive)."""
        g4, generator = self.g4, self

        class _Action(g4.G4VUserPrimaryGeneratorAction):  # type: ignore[name-defined]
            def GeneratePrimaries(self, event) -> None:
                generator.generate(event)

        self._action = _Action()
        return self._action
