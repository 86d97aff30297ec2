"""The source section of a run configuration turned into primaries, one chunk of events at a time.

:func:`make_source` builds, once per process, what every chunk needs: the vertex sampler on the
configured face (its rough layer if it has one, else the flat face), on several faces of a
volume (``face: all``: :class:`~score4.source.shape_sampling.ShapeSurfaceSampler`) or in a volume
(``volume:``, bulk: :class:`~score4.source.shape_sampling.BulkSampler`), the depth profile, the
confinement and the emitter; or the rows of a vertex file. ``source.events(seed, first, n)``
then gives the primaries of events ``first .. first + n - 1`` of the run with that seed, drawn in
prefix-stable blocks (:mod:`score4.source.event_blocks`); ``source.primaries(rng, first, n)`` draws
``n`` events from one given stream. :func:`source_geometry` gives what the run record states
about the source (kind, true and projected area, volume).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from functools import partial
from typing import TYPE_CHECKING, Any, TypeVar

import numpy as np

from score4.common import limits
from score4.world.scene import CurvedRoughLayer, RoughLayer, Scene, TargetVolume, face_frame

from ..errors import ConfigError
from ..shapes import Shape, Transform
from ..shapes.faces import AnnulusFace, PlaneFace
from .decay_source import DecayEmitter
from .depth import VertexSampler
from .emitters import (
    Emitter,
    EnergySpectrum,
    NuclideEmitter,
    ParticleEmitter,
    make_primaries,
)
from .event_blocks import draw_events
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
from .sampling import (
    CurvedRemainderSampler,
    RingSurfaceSampler,
    SurfaceSample,
    SurfaceSampler,
    TiledSurfaceSampler,
)
from .shape_sampling import BulkSampler, CombinedSurfaceSampler, ShapeSurfaceSampler
from .vertex_file import read_vertex_file, vertex_file_config

if TYPE_CHECKING:  # the configuration's models: a worker reads records of them (common.records)
    from score4.inputs.config import DepthConfig, RunConfig, RunUnit, SourceConfig

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


def make_emitter(src: SourceConfig) -> Emitter | DecayEmitter:
    """ParticleEmitter, DecayEmitter or NuclideEmitter for the configured source."""
    if src.decay is not None:
        return decay_emitter(src)
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


def decay_emitter(src: SourceConfig) -> DecayEmitter:
    """The :class:`DecayEmitter` of ``source.decay`` (a nuclide or a chain)."""
    from score4.inputs.config import DecayChainConfig

    decay = src.decay
    if isinstance(decay, DecayChainConfig):
        return DecayEmitter.for_chain(
            decay.chain,
            decay.until,
            None if decay.since_deposition is None else decay.since_deposition * 1e-9,
            decay.coincidence_window * 1e-9,
            src.direction,
            implantation=decay.implantation,
        )
    return DecayEmitter(_given(decay, "source.decay"), direction=src.direction)


def decay_normalisation(config: RunConfig) -> dict:
    """``simulated_decays`` and ``activity_nuclide`` of a run (contract 1 of the run record).

    A ``decay`` source: the decays of its nuclide, or of its chain's head, that the run's events
    stand for (one per event for a nuclide; ``decay_chain`` says how a chain's events share
    them). A ``nuclide`` source (Geant4 decay): one decay per event. Other sources: one
    "decay" per event and no nuclide.
    """
    src = config.source
    n = config.run.events
    if src.decay is not None:
        emitter = decay_emitter(src)
        out: dict = {
            "simulated_decays": n * emitter.decays_per_event,
            "activity_nuclide": emitter.activity_nuclide,
        }
        if emitter.chain is not None:
            ce = emitter.chain
            out["decay_chain"] = {
                "members": list(ce.chain.members),
                "relative_activity": [float(a) for a in ce.activity],
                "coincidence_window_s": ce.window_s,
                "since_deposition_s": ce.since_deposition_s,
                "implantation": emitter.implantation,
            }
            if emitter.implantation:  # whole histories: each member decays as it is fed
                out["decay_chain"]["decays_per_atom"] = [float(a) for a in ce.activity]
            else:
                out["decay_chain"]["event_share"] = [float(x) for x in ce.share / ce.share.sum()]
                out["decay_chain"]["head_decays_per_event"] = ce.head_decays_per_event
        return out
    if src.nuclide is not None:
        return {"simulated_decays": float(n), "activity_nuclide": src.nuclide}
    return {"simulated_decays": float(n), "activity_nuclide": None}


def flat_face_sampler(scene: Scene, volume: str, face: str) -> SurfaceSampler:
    """Two world-coordinate triangles covering a flat box face."""
    target = scene.target(volume)
    if not is_rectangle_face(target, face):
        raise ConfigError(
            f"source.surface: {volume!r} is a {target.solid}; a source on a face needs a G4Box "
            "(or a rough face of a G4Tubs)"
        )
    frame = face_frame(target, face)
    lu, lv = frame.size
    corners = frame.to_world(
        np.array(
            [[-lu / 2, -lv / 2, 0], [lu / 2, -lv / 2, 0], [lu / 2, lv / 2, 0], [-lu / 2, lv / 2, 0]]
        )
    )
    return SurfaceSampler(vertices=corners, faces=[[0, 1, 2], [0, 2, 3]])


def is_rectangle_face(target: TargetVolume, face: str) -> bool:
    """True when ``face`` is a whole flat rectangle of the target's shape (a box face): its
    source is the rough layer on it or the two triangles of the rectangle."""
    shape = target.shape
    if shape is None or face not in shape.faces:
        return False
    geometry = shape.face(face) if shape.box_like else None
    return isinstance(geometry, PlaneFace) and geometry.rectangle


def source_target(scene: Scene, ref: str, parameter: str) -> TargetVolume:
    """The one target a source names (a box, a GDML volume or one copy ``name[k]``)."""
    targets = scene.targets_named(ref, parameter)
    if len(targets) != 1:
        raise ConfigError(
            f"{parameter}: {ref!r} stands for {len(targets)} volumes "
            f"({', '.join(t.name for t in targets)}); give one, e.g. {targets[0].column}"
        )
    return targets[0]


def target_shape(scene: Scene, volume: str) -> tuple[Shape, Transform]:
    """The shape of a target (a box, or a GDML volume's solid) and its local -> world transform."""
    target = source_target(scene, volume, "source")
    if target.shape is None:
        raise ConfigError(
            f"source: {target.name!r} is a {target.solid}, which score4.shapes does not "
            "describe; a source needs a solid it can sample"
        )
    return target.shape, target.transform


def layer_sampler(layer: RoughLayer):
    """Area-uniform points on the rough tops of ``layer``, in world coordinates: a
    :class:`~score4.source.sampling.TiledSurfaceSampler` on a flat face, a
    :class:`~score4.source.sampling.RingSurfaceSampler` on the bent tops of a curved one."""
    if isinstance(layer, CurvedRoughLayer):
        return RingSurfaceSampler(layer)
    px, py = layer.patch_size
    shift = np.array([px / 2, py / 2, 0.0])  # the sampler's patches span [0, px] x [0, py]
    variants = [
        SurfaceSampler(vertices=s.top_mesh.vertices + shift, faces=s.top_mesh.faces)
        for s in layer.variants
    ]
    lu, lv = layer.frame.size
    origin = layer.frame.to_world(np.array([-lu / 2, -lv / 2, layer.base_thickness]))
    return TiledSurfaceSampler(
        variants, layer.cell_variants.T, (px, py), origin, layer.frame.rotation
    )


def shape_face_sampler(scene: Scene, volume: str, face: str | list[str]):
    """Area-uniform sampler on faces of a target, each rough face on its mesh (a round face
    partly rough: its rough cells and the flat rest, :class:`FlatRemainderSampler`)."""
    shape, transform = target_shape(scene, volume)
    rough: dict[str, Any] = {}
    planes: dict[str, list] = {}  # a face of several planes: one layer per plane
    # on a boolean: the flat rests of a face's planes, drawn as one rest on its surface
    rests: dict[str, list] = {}
    for layer in scene.layers_of(volume):
        if layer.mask is None:
            rough[layer.config.face_name] = layer_sampler(layer)
        else:
            rest: Any = (
                CurvedRemainderSampler(layer)
                if isinstance(layer, CurvedRoughLayer)
                else FlatRemainderSampler(layer)
            )
            if layer.on_boolean is not None:
                rests.setdefault(layer.config.face_name, []).append((layer, rest))
                parts = [layer_sampler(layer)]
            else:
                parts = [layer_sampler(layer), rest]
            planes.setdefault(layer.config.face_name, []).extend(p for p in parts if p.area > 0)
    for face_name, layer_rests in rests.items():  # the rest that lies on the boolean's surface
        first, inner = layer_rests[0]
        if len(layer_rests) > 1 or getattr(first, "part", -1) >= 0:  # a face of several planes
            inner = PlanesRemainderSampler([layer for layer, _ in layer_rests])
        rest = BooleanRemainderSampler(first, inner)
        if rest.area > 0:
            planes[face_name].append(rest)
    for face_name, parts in planes.items():
        rough[face_name] = CombinedSurfaceSampler(parts)
    return ShapeSurfaceSampler(shape, face, transform, rough)


class FlatRemainderSampler:
    """Uniform points on the flat part of a round (G4Tubs end) or polygon face that holds no
    patch: the annulus (or the polygon's triangles) less the rough cells, in the plane of the
    layer's base (the cut face with ``into``). Drawn in the annulus (the triangles), points in a
    rough cell rejected."""

    def __init__(self, layer: RoughLayer) -> None:
        self.layer = layer
        outline = getattr(layer, "base_outline", None)
        if outline is None:
            outline = getattr(layer, "outline", None)
        px, py = layer.patch_size
        rough_cells = int((layer.cell_variants >= 0).sum())
        if outline is not None:  # a polygon face: its triangles in the layer's frame
            e1, e2 = outline[:, 1] - outline[:, 0], outline[:, 2] - outline[:, 0]
            tri_area = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
            self.outline, self._cum = outline, np.cumsum(tri_area)
            self.area = float(tri_area.sum() - rough_cells * px * py)
            return
        self.outline = None
        name = layer.config.face_name
        if layer.on_boolean is not None:  # the leaf solid's face the boolean's lies on
            name = layer.on_boolean.clip.face
        ring = layer.target.face(name)
        if not isinstance(ring, AnnulusFace):  # a rectangle (a box face of a boolean)
            self.rmin = self.rmax = -1.0
            lu, lv = layer.frame.size
            self.area = float(lu * lv - rough_cells * px * py)
            return
        self.rmin, self.rmax = layer.rest_radii or (ring.rmin, ring.rmax)
        self.area = float(np.pi * (self.rmax**2 - self.rmin**2) - rough_cells * px * py)

    def sample(self, rng: np.random.Generator, n: int) -> SurfaceSample:
        points = np.empty((0, 2))
        while len(points) < n:
            m = 2 * (n - len(points)) + 16
            if self.outline is not None:
                xy = self._in_outline(rng, m)
            elif self.rmax < 0:
                lu, lv = self.layer.frame.size
                xy = (rng.random((m, 2)) - 0.5) * np.array([lu, lv])
            else:
                r = np.sqrt(rng.uniform(self.rmin**2, self.rmax**2, m))
                phi = rng.uniform(0, 2 * np.pi, m)
                xy = np.column_stack([r * np.cos(phi), r * np.sin(phi)])
            i, j = self.layer.patch_map.cell_of(xy)
            keep = i < 0
            keep[~keep] = self.layer.cell_variants[j[~keep], i[~keep]] < 0
            points = np.concatenate([points, xy[keep]])
        xy = points[:n]
        frame = self.layer.frame
        position = frame.to_world(np.column_stack([xy, np.zeros(n)]))
        normal = np.tile(frame.normal, (n, 1))
        none = np.full(n, -1, np.int64)
        return SurfaceSample(position, normal, none.copy(), none.copy(), none.copy())

    def _in_outline(self, rng: np.random.Generator, m: int) -> np.ndarray:
        """``m`` points uniform per area in the polygon's triangles."""
        assert self.outline is not None
        k = np.minimum(
            np.searchsorted(self._cum, rng.random(m) * self._cum[-1], side="right"),
            len(self._cum) - 1,
        )
        st = rng.random((2, m))
        flip = st.sum(axis=0) > 1
        st[:, flip] = 1 - st[:, flip]
        t = self.outline[k]
        return t[:, 0] + st[0, :, None] * (t[:, 1] - t[:, 0]) + st[1, :, None] * (t[:, 2] - t[:, 0])


class PlanesRemainderSampler:
    """The flat rest of a leaf face of several planes under a boolean's face (its planes' rough
    layers, those planes without a kept cell left out): the leaf face drawn whole, points in a
    rough cell of any plane's layer rejected."""

    def __init__(self, layers: list[RoughLayer]) -> None:
        self.layers = layers
        on = layers[0].on_boolean
        assert on is not None
        self.leaf, self.face, self.flipped = on.clip.leaf, on.clip.face, on.clip.flipped
        self.sampler = self.leaf.face_sampler((self.face,))
        cells = sum(
            int((la.cell_variants >= 0).sum()) * float(np.prod(la.patch_size)) for la in layers
        )
        self.area = float(self.leaf.face_areas[self.face]) - cells

    def sample(self, rng: np.random.Generator, n: int) -> SurfaceSample:
        target = self.layers[0].target
        pos, nrm = np.empty((0, 3)), np.empty((0, 3))
        while len(pos) < n:
            s = self.sampler.sample(rng, 2 * (n - len(pos)) + 16)
            world = target.to_world(s.position)
            keep = np.ones(len(world), dtype=bool)
            for layer in self.layers:
                q = layer.frame.to_local(world)
                i, j = layer.patch_map.cell_of(q[:, :2])
                hit = (i >= 0) & (np.abs(q[:, 2]) < 1e-9)
                hit[hit] = layer.cell_variants[j[hit], i[hit]] >= 0
                keep &= ~hit
            normal = s.normal @ target.rotation.T
            pos = np.concatenate([pos, world[keep]])
            nrm = np.concatenate([nrm, -normal[keep] if self.flipped else normal[keep]])
        none = np.full(n, -1, np.int64)
        return SurfaceSample(pos[:n], nrm[:n], none.copy(), none.copy(), none.copy())


class BooleanRemainderSampler:
    """The flat rest of a rough face of a boolean solid: points of the leaf face's rest
    (``inner``: a :class:`FlatRemainderSampler` or
    :class:`~score4.source.sampling.CurvedRemainderSampler`) kept where they lie on the
    boolean's surface. Its area is the boolean face's (estimated, ``area_error``) less the rough
    cells', which lie wholly on it."""

    def __init__(self, layer: RoughLayer, inner: Any) -> None:
        on = layer.on_boolean
        assert on is not None
        self.layer, self.inner, self.on = layer, inner, on
        shape = on.shape
        full = float(on.clip.leaf.face_areas[on.clip.face])
        covered = full - float(inner.area)
        self.area = max(float(shape.face_areas[on.face]) - covered, 0.0)
        self.area_error = float(getattr(shape, "face_area_errors", {}).get(on.face, 0.0))

    def sample(self, rng: np.random.Generator, n: int) -> SurfaceSample:
        got: list[SurfaceSample] = []
        have, share = 0, max(self.area / max(float(self.inner.area), 1e-300), 1e-3)
        while have < n:
            s = self.inner.sample(rng, int((n - have) / share * 1.2) + 16)
            keep = self.on.on_surface(s.position)
            got.append(
                SurfaceSample(
                    s.position[keep], s.normal[keep], s.facet[keep], s.patch[keep], s.variant[keep]
                )
            )
            have += int(keep.sum())
        cat = [np.concatenate([getattr(g, a) for g in got])[:n] for a in _SAMPLE_FIELDS]
        return SurfaceSample(*cat)


_SAMPLE_FIELDS = ("position", "normal", "facet", "patch", "variant")


def bulk_sampler(scene: Scene, volume: str) -> BulkSampler:
    """Uniform points in a target, outside its daughters (a GDML volume's, placed in the world;
    a box target has none, and its rough layers are separate volumes outside it)."""
    target = source_target(scene, volume, "source.volume")
    shape, transform = target_shape(scene, target.name)
    if target.unknown_daughters:
        raise ConfigError(
            f"source.volume: {target.name!r} holds {', '.join(target.unknown_daughters)}, of a "
            "solid type score4.shapes does not describe, so its material cannot be sampled"
        )
    return BulkSampler(shape, transform, list(target.exclude), name=target.name)


def number_atoms(primaries: Primaries, first: int) -> Primaries:
    """Per-atom histories drawn for atoms ``first, first + 1, ...``: their ``atom`` column
    made the run's atom index (unchanged when there is no such column)."""
    if "atom" in primaries.extra and first:
        primaries.extra["atom"] = primaries.extra["atom"] + first
    return primaries


def run_numbers(primaries: Primaries, first_event: int) -> np.ndarray:
    """Per row, the run's number of its event, or of its atom for per-atom histories (whose
    events are not numbered in the run)."""
    if "atom" in primaries.extra:
        return np.asarray(primaries.extra["atom"])
    return primaries.event + first_event


@dataclass
class SampledSource:
    """Vertices drawn below a (rough) face, each emitting the configured particles.

    Every vertex drawn is checked inside the world box ``|x_i| < world_half_i`` (Geant4 crashes
    or loses a primary outside its world): a depth profile reaching out of the target with
    ``confine: false`` is refused with the event it would have started.
    """

    sampler: VertexSampler
    emitter: Emitter | DecayEmitter
    world_half: np.ndarray = field(default_factory=lambda: np.full(3, np.inf))

    def primaries(self, rng: np.random.Generator, first_event: int, n_events: int) -> Primaries:
        """``n_events`` events (atoms, with implantation: :attr:`unit`) drawn from the stream
        ``rng``; ``first_event`` only numbers the atoms (:meth:`events` gives the prefix-stable
        events of a run)."""
        v = self.sampler.sample(rng, n_events)
        return number_atoms(
            make_primaries(
                self.emitter,
                rng,
                v.position,
                v.normal,
                depth=v.depth,
                facet=v.facet,
                patch=v.patch if v.patch is not None else np.full(n_events, -1),
                face=v.face,
            ),
            first_event,
        )

    @property
    def unit(self) -> RunUnit:
        """What ``run.events`` counts: ``"event"``, or ``"atom"`` (chain with implantation)."""
        return self.emitter.unit if isinstance(self.emitter, DecayEmitter) else "event"

    def events(self, seed: int, first_event: int, n_events: int) -> Primaries:
        """Events ``first_event ..`` of the run with ``seed``, the same in any chunking."""
        p = draw_events(self, seed, first_event, n_events)
        limits.check_vertices(p.position, self.world_half, "source", run_numbers(p, first_event))
        return p


@dataclass
class BulkSource:
    """Vertices uniform in a volume's own material, emitting isotropically (checked inside the
    world like :class:`SampledSource`'s)."""

    sampler: BulkSampler
    emitter: Emitter | DecayEmitter
    world_half: np.ndarray = field(default_factory=lambda: np.full(3, np.inf))

    def primaries(self, rng: np.random.Generator, first_event: int, n_events: int) -> Primaries:
        """As :meth:`SampledSource.primaries`."""
        positions = self.sampler.sample(rng, n_events)
        return number_atoms(make_primaries(self.emitter, rng, positions), first_event)

    @property
    def unit(self) -> RunUnit:
        """What ``run.events`` counts: ``"event"``, or ``"atom"`` (chain with implantation)."""
        return self.emitter.unit if isinstance(self.emitter, DecayEmitter) else "event"

    def events(self, seed: int, first_event: int, n_events: int) -> Primaries:
        """Events ``first_event ..`` of the run with ``seed``, the same in any chunking."""
        p = draw_events(self, seed, first_event, n_events)
        limits.check_vertices(p.position, self.world_half, "source", run_numbers(p, first_event))
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

    unit: RunUnit = "event"

    def events(self, seed: int, first_event: int, n_events: int) -> Primaries:
        """Rows of events ``first_event ..`` of the file (``seed`` plays no part)."""
        return self.primaries(np.random.default_rng(0), first_event, n_events)  # rng unused


def needs_radioactive_decay(config: RunConfig) -> bool:
    """True for a nuclide source, also when it is replayed from a vertex file drawn from one."""
    src = config.source
    if src.vertices is not None:
        return bool(vertex_file_config(src.vertices).get("source", {}).get("nuclide"))
    return src.nuclide is not None


def make_source(config: RunConfig, scene: Scene) -> SampledSource | BulkSource | FileSource:
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
    return source_from_config(src, scene)


def source_from_config(src: SourceConfig, scene: Scene) -> SampledSource | BulkSource:
    """The sampled source (surface or bulk; not a vertex file) that ``src`` describes on the
    targets of ``scene``: a run configuration's ``source`` section, or the keys a user gives
    :meth:`score4.api.World.source`. Files, materials and constraints are checked now."""
    if src.vertices is not None:
        raise ConfigError("source.vertices: a vertex file is read by make_source")
    if src.volume is not None:
        return BulkSource(bulk_sampler(scene, src.volume), _emitter(src), scene.world_half)
    surface_ref = _given(src.surface, "source.surface")
    target = source_target(scene, surface_ref.volume, "source.surface.volume")
    volume, face = target.name, surface_ref.face
    surface: SurfaceSampler | ShapeSurfaceSampler | object
    if isinstance(face, str) and is_rectangle_face(target, face):  # a box face: rough or flat
        layer = scene.layer(volume, face)
        surface = (
            layer_sampler(layer) if layer is not None else flat_face_sampler(scene, volume, face)
        )
    else:
        try:
            surface = shape_face_sampler(scene, volume, face)
        except ConfigError as err:  # "face: G4Box has no face 'top'; its faces: ..."
            text = re.sub(  # the volume and its Geant4 solid, as for rough faces
                r"^face: \S+ has no face ",
                lambda _: f"face: {volume}: no face ",
                str(err),
            )
            text = re.sub(r"^(face: .*?: no face '[^']*'); ", rf"\1 on a {target.solid}; ", text)
            raise ConfigError(
                f"source.surface.{text}" if text.startswith("face:") else text
            ) from None
    inside = None
    if src.confine is True:
        inside = partial(scene.inside_target, volume)  # a partial, not a lambda: picklable
    elif isinstance(src.confine, str):
        scene.inside_material(src.confine, np.zeros((0, 3)))  # fails now if no target has it
        inside = partial(scene.inside_material, src.confine)
    try:
        sampler = VertexSampler(
            surface,  # type: ignore[arg-type]  # a ShapeSurfaceSampler plugs in by its hook
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
    return SampledSource(sampler, _emitter(src), scene.world_half)


def _emitter(src: SourceConfig) -> Emitter | DecayEmitter:
    try:
        return make_emitter(src)
    except ConfigError as err:
        raise ConfigError(f"source.{err}") from None  # "source.particle: unknown name ..."


def source_geometry(config: RunConfig, scene: Scene) -> dict:
    """What the run record states about where the source is (contract 1, ``source`` entry).

    ``kind`` (surface | bulk | vertices), ``volume``, ``face``, ``area_mm2`` (true sampled area:
    rough faces with their mesh area), ``area_error_mm2`` (its standard error where the area is
    estimated by random draws, boolean and other solids; 0 when exact),
    ``projected_area_mm2`` (the faces counted flat),
    ``faces`` (face names; the ``face`` column of the primaries indexes it), ``volume_mm3``
    (bulk: the volume's own material), and ``mass_kg`` when the material's density is known
    without Geant4 (a ``materials:`` entry; NIST densities come from Geant4, left None here).
    """
    src = config.source
    if src.vertices is not None:
        return {"kind": "vertices", "file": str(src.vertices)}
    if src.volume is not None:
        bulk = bulk_sampler(scene, src.volume)
        material = source_target(scene, src.volume, "source.volume").material
        spec = config.materials.get(material)
        mass = None if spec is None else bulk.volume * spec.density * 1e-6  # g/cm3 * mm3 -> kg
        return {
            "kind": "bulk",
            "volume": src.volume,
            "volume_mm3": bulk.volume,
            "mass_kg": mass,
        }
    ref = _given(src.surface, "source.surface")
    target = source_target(scene, ref.volume, "source.surface.volume")
    out = {"kind": "surface", "volume": target.name, "face": ref.face}
    if isinstance(ref.face, str) and is_rectangle_face(target, ref.face):
        frame = face_frame(target, ref.face)
        layer = scene.layer(target.name, ref.face)
        projected = frame.size[0] * frame.size[1]
        area = layer_sampler(layer).area if layer is not None else projected
        names, error = [ref.face], 0.0
    else:
        sampler = shape_face_sampler(scene, target.name, ref.face)
        area, projected, names = sampler.area, sampler.projected_area, list(sampler.face_names)
        error = getattr(sampler, "area_error", 0.0)
    return {
        **out,
        "area_mm2": float(area),
        "area_error_mm2": float(error),
        "projected_area_mm2": float(projected),
        "faces": names,
    }
