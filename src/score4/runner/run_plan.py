"""The run plan: a configuration resolved once, in the process that reads it.

:func:`plan_run` turns a validated :class:`~score4.inputs.config.RunConfig` into a :class:`RunPlan`:
the resolved world (every target volume, its rough layers with their patch maps, the volume
model of a GDML world), the source, the physics choice, the output settings and the
fingerprint that names what the run's chunk files were made from. Everything after it takes the
plan: the engine's checks before the run (:func:`score4.runner.engine.run`), the worker's Geant4
application (:class:`score4.sim.simulation.Simulation`), the world builders
(:func:`score4.geometry.world.build_world`).

A plan travels to a worker process resolved (:func:`worker_pickle`; to a local worker through
its pipe, to the workers of a Dask cluster scattered once): the scene and the source as the
parent built them, with every validated model of the configuration in them
replaced by a :class:`~score4.common.records.Record` of its values. So the worker rebuilds
nothing and never imports pydantic or :mod:`score4.inputs.config` (0.13-0.16 s of a worker's
0.7-1 s start-up, ``benchmarks/bench_runloop.py --parts startup``). ``pickle.dumps(plan)``
writes the plan's *recipe* instead (what a program that pickles a plan itself gets): the
configuration, the seed, the physics choice, the fingerprint and the GDML volume model;
unpickling it rebuilds the scene and the source, deterministically (same seeds, same patch
maps) and without the checks the parent made before the run: no configuration file is read
again and a GDML world is not read again in Python (Geant4 parses it once, when it builds the
world). The recipe of a 10 cm rough face is some 2 kB against several MB for the resolved
scene, and rebuilding it takes milliseconds (``benchmarks/bench_run_plan.py`` prints both).
"""

from __future__ import annotations

import hashlib
import io
import json
import pickle
import warnings
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from score4.common.records import Record
from score4.errors import Score4Warning

if TYPE_CHECKING:
    from score4.inputs.config import OutputConfig, RunConfig
    from score4.runner.physics_choice import PhysicsChoice
    from score4.source.build import BulkSource, FileSource, SampledSource
    from score4.world.gdml_model import GeometryModel
    from score4.world.scene import Scene


def config_fingerprint(config: RunConfig, seed: int, gdml_key: str | None = None) -> str:
    """Identifies what a chunk file was made from, so resume never mixes runs (a GDML world by
    the content of its files, ``gdml_key`` = :func:`~score4.world.gdml_files.model_key`,
    not only their names; computed here when not given)."""
    from score4.inputs.config import config_to_dict

    data: dict[str, Any] = {"config": config_to_dict(config), "seed": seed}
    if config.world.gdml is not None:
        if gdml_key is None:
            from score4.world.gdml_files import gdml_files, model_key

            gdml_key = model_key(gdml_files(config.world.gdml))
        data["gdml"] = gdml_key
    text = json.dumps(data, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


@dataclass(frozen=True, eq=False)
class RunPlan:
    """One run configuration, resolved: what every later step of a run reads.

    Two plans are equal when their fingerprints, seeds and physics choices are. A plan pickles
    as its recipe and is rebuilt from it on unpickling; :func:`worker_pickle` sends it resolved,
    to the workers of a run (:mod:`score4.runner.run_plan`).

    Attributes
    ----------
    config
        The validated configuration (its ``run.seed`` may differ from ``seed``: see
        :func:`plan_run`); in a local worker, a :class:`~score4.common.records.Record` of it.
    seed
        The run seed: every random stream of the run derives from it (:mod:`score4.runner.seeds`).
    physics
        The physics the run uses (:class:`~score4.sim.runtime.PhysicsChoice`: mode, decay,
        what lite physics lacks, missing data sets).
    scene
        The resolved world: targets (one per scoring column), rough layers with their patch
        maps, the GDML volume model (``scene.model``).
    source
        What draws the primaries (a sampled surface or bulk source, or a vertex file); None in
        a plan of the world alone (``plan_run(config, source=False)``: geometry commands).
    fingerprint
        16 hex digits naming the configuration, the seed and a GDML world's file contents; every
        chunk file carries it, and a resume reuses only chunks with the same one.
    gdml_key
        The content key of a GDML world's files (None without one).
    """

    config: RunConfig
    seed: int
    physics: PhysicsChoice
    scene: Scene
    source: SampledSource | BulkSource | FileSource | None
    fingerprint: str
    gdml_key: str | None = None

    @property
    def output(self) -> OutputConfig:
        """What the run writes (``output:`` of the configuration)."""
        return self.config.output

    @property
    def model(self) -> GeometryModel | None:
        """The volume model of a GDML world (None for a generated world)."""
        return self.scene.model

    @property
    def per_atom(self) -> bool:
        """True when ``run.events`` counts atoms (a chain with implantation: per-atom histories)."""
        return self.config.source.run_unit == "atom"

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, RunPlan):
            return NotImplemented
        return _identity(self) == _identity(other)

    def __hash__(self) -> int:
        return hash((self.fingerprint, self.seed))

    def __reduce__(self) -> tuple[Any, tuple[Any, ...]]:
        return _rebuild, (
            self.config,
            self.seed,
            self.physics,
            self.fingerprint,
            self.gdml_key,
            self.scene.model,
            self.source is not None,
        )


def plan_run(
    config: RunConfig,
    *,
    seed: int | None = None,
    physics: PhysicsChoice | None = None,
    source: bool = True,
) -> RunPlan:
    """Resolve ``config`` once: the one function that makes a :class:`RunPlan`.

    ``seed`` defaults to ``config.run.seed``; ``physics`` to the choice for
    ``config.physics.mode`` and the installed data (:func:`~score4.sim.runtime.resolve_physics`).
    Bad surfaces, files, constraints and faces raise :class:`~score4.errors.ConfigError` here.
    A GDML world's files are checked and its volume model read (from score4's cache) once.
    ``source=False`` leaves the source out (a plan of the world, for the geometry commands).
    """
    from score4.runner.physics_choice import resolve_physics
    from score4.source.build import make_source, needs_radioactive_decay
    from score4.world.resolve import build_scene

    seed = config.run.seed if seed is None else int(seed)
    if physics is None:
        physics = resolve_physics(config.physics.mode, needs_decay=needs_radioactive_decay(config))
    model, key = None, None
    if config.world.gdml is not None:
        from score4.world.gdml_files import keyed_geometry_model

        model, key = keyed_geometry_model(config.world.gdml)
    scene = build_scene(config, model)
    sampler = make_source(config, scene) if source else None
    return RunPlan(
        config, seed, physics, scene, sampler, config_fingerprint(config, seed, key), key
    )


def _rebuild(
    config: RunConfig,
    seed: int,
    physics: PhysicsChoice,
    fingerprint: str,
    gdml_key: str | None,
    model: GeometryModel | None,
    source: bool = True,
) -> RunPlan:
    """A plan from its recipe (on unpickling, in a worker): the same scene and source, built
    from the configuration already validated and the GDML model already read. Built once per
    process: unpickling the same recipe again gives the same object."""
    key = (fingerprint, seed, physics, source)
    held = _REBUILT.get("plan")
    if held is not None and (*_identity(held), held.source is not None) == key:
        return held
    from score4.source.build import make_source
    from score4.world.resolve import build_scene

    with warnings.catch_warnings():  # the parent showed them when it planned
        warnings.simplefilter("ignore", Score4Warning)
        scene = build_scene(config, model)
        sampler = make_source(config, scene) if source else None
    plan = RunPlan(config, seed, physics, scene, sampler, fingerprint, gdml_key)
    _REBUILT["plan"] = plan
    return plan


#: The last plan rebuilt from its recipe in this process (see :func:`_rebuild`).
_REBUILT: dict[str, RunPlan] = {}


def _identity(plan: RunPlan) -> tuple[str, int, PhysicsChoice]:
    return plan.fingerprint, plan.seed, plan.physics


def worker_pickle(obj: object) -> bytes:
    """``obj`` (a worker's spec holding a :class:`RunPlan`) pickled for a worker process: the
    plan resolved (its scene and source as they are, not its recipe) and every pydantic model
    in it as a :class:`~score4.common.records.Record` of its fields and property values.

    Unpickling it imports neither pydantic nor the configuration's models, and rebuilds no scene.
    """
    from pydantic import BaseModel

    buffer = io.BytesIO()
    _WorkerPickler(buffer, BaseModel).dump(obj)
    return buffer.getvalue()


class _WorkerPickler(pickle.Pickler):
    def __init__(self, file: io.BytesIO, model_class: type) -> None:
        super().__init__(file, protocol=pickle.HIGHEST_PROTOCOL)
        self.model_class = model_class

    def reducer_override(self, obj: object) -> Any:
        if isinstance(obj, RunPlan):
            return _resolved, (
                obj.config,
                obj.seed,
                obj.physics,
                obj.scene,
                obj.source,
                obj.fingerprint,
                obj.gdml_key,
            )
        if isinstance(obj, self.model_class):
            return Record, (type(obj).__name__, _model_values(obj))
        return NotImplemented


def _model_values(model: Any) -> dict[str, Any]:
    """A model's fields, then the values of its properties (those that have one)."""
    values = {name: getattr(model, name) for name in type(model).model_fields}
    for cls in type(model).__mro__:
        if cls.__module__.startswith("pydantic"):
            continue
        for name, attr in vars(cls).items():
            if isinstance(attr, property) and name not in values:
                try:
                    values[name] = getattr(model, name)
                except Exception:  # noqa: BLE001 a property this model cannot answer is left out
                    continue
    return values


def _resolved(
    config: Any,
    seed: int,
    physics: PhysicsChoice,
    scene: Scene,
    source: SampledSource | BulkSource | FileSource | None,
    fingerprint: str,
    gdml_key: str | None,
) -> RunPlan:
    """A plan as its parent resolved it (unpickled from :func:`worker_pickle`)."""
    return RunPlan(config, seed, physics, scene, source, fingerprint, gdml_key)
