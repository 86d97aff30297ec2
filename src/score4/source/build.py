"""The source section of a run configuration turned into primaries, one chunk of events at a time.

:func:`make_source` builds, once per process, what every chunk needs: the vertex sampler on the
configured face (its rough layer if it has one, else the flat face), the depth profile, the
confinement and the emitter; or the rows of a vertex file. ``source.events(seed, first, n)``
then gives the primaries of events ``first .. first + n - 1`` of the run with that seed, drawn in
prefix-stable blocks (:mod:`score4.source.blocks`); ``source.primaries(rng, first, n)`` draws
``n`` events from one given stream.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TypeVar

import numpy as np

from .. import limits
from ..config import DepthConfig, RunConfig, SourceConfig
from ..errors import ConfigError
from ..scene import Scene, face_frame
from .blocks import draw_events
from .depth import VertexSampler
from .emitters import (
    Emitter,
    EnergySpectrum,
    NuclideEmitter,
    ParticleEmitter,
    Po210Emitter,
    make_primaries,
)
from .primaries import Primaries
from .profiles import (
    DepthProfile,
    ExponentialProfile,
    MultiExponentialProfile,
    TableProfile,
    TruncatedGaussianProfile,
    UniformProfile,
    ZeroDepth,
)
from .sampling import SurfaceSampler
from .vertex_file import read_vertex_file, vertex_file_config

_T = TypeVar("_T")


def _given(value: _T | None, key: str) -> _T:
    """A config value the config model requires for the choice made (never None after parsing)."""
    if value is None:
        raise ConfigError(f"{key}: missing")
    return value


def depth_profile(cfg: DepthConfig) -> DepthProfile:
    """The configured depth law (before the min/max window, which the sampler applies)."""
    if cfg.profile == "zero":
        return ZeroDepth()
    if cfg.profile == "exponential":
        return ExponentialProfile(_given(cfg.mean, "source.depth.mean"))
    if cfg.profile == "multi_exponential":
        return MultiExponentialProfile(
            _given(cfg.weights, "source.depth.weights"), _given(cfg.means, "source.depth.means")
        )
    if cfg.profile == "uniform":
        return UniformProfile(cfg.min, _given(cfg.max, "source.depth.max"))
    if cfg.profile == "truncated_gaussian":
        return TruncatedGaussianProfile(
            _given(cfg.mean, "source.depth.mean"), _given(cfg.sigma, "source.depth.sigma")
        )
    return TableProfile.from_file(_given(cfg.file, "source.depth.file"), unit=cfg.unit)


def make_emitter(src: SourceConfig) -> Emitter:
    """ParticleEmitter, Po210Emitter or NuclideEmitter for the configured source."""
    if src.decay == "Po210":
        return Po210Emitter(src.direction)
    if src.nuclide is not None:
        return NuclideEmitter(src.nuclide)
    energy: float | EnergySpectrum | None = (
        src.energy
        if src.spectrum is None
        else EnergySpectrum.from_file(
            src.spectrum.file, kind=src.spectrum.kind, unit=src.spectrum.unit
        )
    )
    if energy is None:  # the config model requires energy or spectrum for a particle
        raise ConfigError("source.energy: missing")
    return ParticleEmitter(_given(src.particle, "source.particle"), energy, src.direction)


def flat_face_sampler(config: RunConfig, volume: str, face: str) -> SurfaceSampler:
    """Two world-coordinate triangles covering a flat box face."""
    frame = face_frame(config.target(volume), face)
    lu, lv = frame.size
    corners = frame.to_world(
        np.array(
            [[-lu / 2, -lv / 2, 0], [lu / 2, -lv / 2, 0], [lu / 2, lv / 2, 0], [-lu / 2, lv / 2, 0]]
        )
    )
    return SurfaceSampler(vertices=corners, faces=[[0, 1, 2], [0, 2, 3]])


@dataclass
class SampledSource:
    """Vertices drawn below a (rough) face, each emitting the configured particles.

    Every vertex drawn is checked inside the world box ``|x_i| < world_half_i`` (Geant4 crashes
    or loses a primary outside its world): a depth profile reaching out of the target with
    ``confine: false`` is refused with the event it would have started.
    """

    sampler: VertexSampler
    emitter: Emitter
    world_half: np.ndarray = field(default_factory=lambda: np.full(3, np.inf))

    def primaries(self, rng: np.random.Generator, first_event: int, n_events: int) -> Primaries:
        v = self.sampler.sample(rng, n_events)
        return make_primaries(
            self.emitter,
            rng,
            v.position,
            v.normal,
            depth=v.depth,
            facet=v.facet,
            patch=v.patch if v.patch is not None else np.full(n_events, -1),
        )

    def events(self, seed: int, first_event: int, n_events: int) -> Primaries:
        """Events ``first_event ..`` of the run with ``seed``, the same in any chunking."""
        p = draw_events(self, seed, first_event, n_events)
        limits.check_vertices(p.position, self.world_half, "source", p.event + first_event)
        return p


@dataclass
class FileSource:
    """Primaries read from a vertex file, event by event (all checked inside the world)."""

    primaries_all: Primaries
    path: str
    world_half: np.ndarray = field(default_factory=lambda: np.full(3, np.inf))

    def __post_init__(self) -> None:
        p = self.primaries_all
        label = f"source.vertices: {self.path}"
        limits.check_vertices(p.position, self.world_half, label, p.event)

    def primaries(self, rng: np.random.Generator, first_event: int, n_events: int) -> Primaries:
        available = self.primaries_all.n_events
        if first_event + n_events > available:
            raise ConfigError(
                f"source.vertices: {self.path} holds {available} events; the run asks for "
                f"events up to {first_event + n_events} (set run.events <= {available})"
            )
        return self.primaries_all.select_events(first_event, first_event + n_events)

    def events(self, seed: int, first_event: int, n_events: int) -> Primaries:
        """Rows of events ``first_event ..`` of the file (``seed`` plays no part)."""
        return self.primaries(np.random.default_rng(0), first_event, n_events)  # rng unused


def needs_radioactive_decay(config: RunConfig) -> bool:
    """True for a nuclide source, also when it is replayed from a vertex file drawn from one."""
    src = config.source
    if src.vertices is not None:
        return bool(vertex_file_config(src.vertices).get("source", {}).get("nuclide"))
    return src.nuclide is not None


def make_source(config: RunConfig, scene: Scene) -> SampledSource | FileSource:
    """What :meth:`primaries` needs, built once: checks files, materials and constraints now."""
    src = config.source
    if src.vertices is not None:
        source = FileSource(read_vertex_file(src.vertices), str(src.vertices), scene.world_half)
        if source.primaries_all.n_events < config.run.events:
            raise ConfigError(
                f"source.vertices: {src.vertices} holds {source.primaries_all.n_events} events, "
                f"fewer than run.events = {config.run.events}"
            )
        return source
    surface_ref = _given(src.surface, "source.surface")
    volume, face = surface_ref.volume, surface_ref.face
    layer = scene.layer(volume, face)
    surface = layer.sampler() if layer is not None else flat_face_sampler(config, volume, face)
    inside = None
    if src.confine is True:
        inside = lambda p: scene.inside_target(volume, p)  # noqa: E731
    elif isinstance(src.confine, str):
        scene.inside_material(src.confine, np.zeros((0, 3)))  # fails now if no target has it
        inside = lambda p: scene.inside_material(src.confine, p)  # noqa: E731
    try:
        sampler = VertexSampler(
            surface,
            depth_profile(src.depth),
            definition=src.depth.definition,
            min_depth=src.depth.min,
            max_depth=src.depth.max if src.depth.max is not None else np.inf,
            inside=inside,
        )
    except (
        ConfigError
    ) as err:  # the library names min_depth/max_depth; the config calls them min/max
        message = str(err).replace("min_depth", "min").replace("max_depth", "max")
        raise ConfigError(f"source.depth: {message}") from None
    try:
        emitter = make_emitter(src)
    except ConfigError as err:
        raise ConfigError(f"source.{err}") from None  # "source.particle: unknown name ..."
    return SampledSource(sampler, emitter, scene.world_half)
