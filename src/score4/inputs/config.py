"""Run configuration: YAML validated into typed objects.

Every quantity with a dimension is written with its unit ("5.3 MeV", "3 cm") and stored in
Geant4 internal units (mm, MeV). Unknown keys are errors, so a typo never silently falls
back to a default. :func:`load_config` turns any problem into one :class:`ConfigError` line
that names the file, the key path, the value and the rule.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Annotated, ClassVar, Literal

from pydantic import (
    Discriminator,
    Field,
    Tag,
    ValidationError,
    ValidationInfo,
    field_validator,
    model_validator,
)

from score4.common import limits
from score4.common.schema import (
    GIVEN,
    ConfigPath,
    NonNegativeLength,
    NonNegativeTime,
    PositiveEnergy,
    PositiveLength,
    Size3,
    StrictModel,
    Vector3,
    check_option_keys,
    describe_validation_error,
)
from score4.common.units import length_text
from score4.common.yamlfile import load_yaml
from score4.errors import ConfigError
from score4.ions.trim_library import (  # their home was here: re-exported
    EVENTS_PER_THOUSAND_HISTORIES as EVENTS_PER_THOUSAND_HISTORIES,
)
from score4.ions.trim_library import default_trim_histories as default_trim_histories
from score4.ions.trim_library import trim_histories as trim_histories
from score4.surface.patchmap import DEFAULT_TILES
from score4.surface.spec import MeasuredSurfaceSpec, RandomSurfaceSpec, SpikeSurfaceSpec

from .material_spec import MaterialSpec
from .materials import check_material_name
from .response_spec import ResponseConfig

FACES = ("+x", "-x", "+y", "-y", "+z", "-z")


class Activeness(StrictModel):
    """The charge collection of a detector near some of its faces (``targets[].activeness``).

    A deposit at distance ``d`` from the nearest of ``faces`` counts with the weight 0 for
    ``d < dlf * fccd`` (the dead layer), rising linearly to 1 at ``d = fccd`` (the full charge
    collection depth; the transition layer), 1 beyond: LEGEND's piecewise-linear model.
    ``faces``: face names or groups of the volume's shape, or ``all``.
    """

    fccd: PositiveLength
    dlf: float = Field(ge=0.0, le=1.0)
    faces: str | list[str] = "all"


class BoxVolume(StrictModel):
    """A box-shaped volume: full edge lengths, centre position in the world.

    In a GDML world, ``mother`` names the GDML volume the box goes into (one instance); its
    ``position`` is then in that volume's frame.
    """

    name: str = Field(min_length=1, pattern=r"^[A-Za-z_][A-Za-z0-9_\-]*$")
    material: str = "G4_Si"
    size: Size3
    position: Vector3 = (0.0, 0.0, 0.0)
    mother: str | None = None  # a volume of the GDML world (default: the world volume)
    rough: list[RoughFace] = []  # noqa: RUF012 pydantic copies field defaults per instance
    activeness: list[Activeness] = []  # noqa: RUF012 pydantic copies field defaults per instance

    @property
    def label(self) -> str:
        return self.name


class GdmlVolume(StrictModel):
    """A physical volume of the GDML world, scored (and roughened where ``rough`` says so).

    ``volume`` is a physical volume name (all its copies), ``name[k]`` (the k-th copy in the
    order of ``score4 geometry list``), a logical volume name (all its placements), or a glob
    pattern of physical volume names (``V0*``, ``crystal_?``: a name with ``*`` or ``?``).
    ``volume_regex`` selects physical volume names by a regular expression (the whole name
    matches), ``material`` the volumes of a material; given together, a volume must pass each.
    Each copy is one scoring column (``name_0``, ``name_1``, ... when there are several; a
    pattern's volumes are columns by their names).
    """

    volume: str | None = Field(None, min_length=1)
    volume_regex: str | None = Field(None, min_length=1)
    material: str | None = Field(None, min_length=1)
    rough: list[RoughFace] = []  # noqa: RUF012 pydantic copies field defaults per instance
    activeness: list[Activeness] = []  # noqa: RUF012 pydantic copies field defaults per instance

    @model_validator(mode="after")
    def _one_selection(self) -> GdmlVolume:
        if self.volume is None and self.volume_regex is None and self.material is None:
            raise ValueError(
                "give volume (a name or a glob pattern such as 'V0*'), volume_regex or material"
            )
        if self.volume is not None and self.volume_regex is not None:
            raise ValueError("give volume (a name or glob) or volume_regex, not both")
        if self.volume_regex is not None:
            try:
                re.compile(self.volume_regex)
            except re.error as err:
                raise ValueError(
                    f"volume_regex: {self.volume_regex!r} is not a regular expression ({err})"
                ) from None
        return self

    @property
    def pattern(self) -> bool:
        """True when the entry selects volumes by a pattern or a material, not by a name."""
        glob = self.volume is not None and any(c in self.volume for c in "*?")
        return glob or self.volume_regex is not None or self.material is not None

    @property
    def label(self) -> str:
        parts = [self.volume or self.volume_regex or ""]
        if self.material is not None:
            parts.append(f"material {self.material}")
        return " ".join(p for p in parts if p)


def _target_tag(value: object) -> str:
    if isinstance(value, dict):
        named = "volume" in value or "volume_regex" in value
        by_material = "material" in value and not ({"name", "size"} & set(value))
        return "gdml-target" if named or by_material else "box-target"
    return "gdml-target" if isinstance(value, GdmlVolume) else "box-target"


# A target: a box described here (name, size, ...) or a volume of the GDML world (volume: NAME).
Target = Annotated[
    Annotated[BoxVolume, Tag("box-target")] | Annotated[GdmlVolume, Tag("gdml-target")],
    Discriminator(_target_tag),
]


class WorldConfig(StrictModel):
    """The world: a box of ``material`` around the targets (``margin`` beyond them), or the world
    of a GDML file (``gdml``, relative to the configuration), read with Geant4's parser."""

    used_only_with: ClassVar[dict[str, object]] = {
        "material": ("gdml", (None,)),
        "margin": ("gdml", (None,)),
    }

    gdml: ConfigPath | None = None
    material: str = "G4_Galactic"
    margin: PositiveLength = 10.0  # space around the targets, mm
    # run although the GDML file's own volumes overlap (the CLI's --allow-overlaps)
    allow_overlaps: bool = False

    @model_validator(mode="after")
    def _overlaps_need_gdml(self) -> WorldConfig:
        # only true is refused: a dumped configuration carries the default false and re-reads
        if self.allow_overlaps and self.gdml is None:
            raise ValueError(
                "allow_overlaps: true is used only with gdml given (the check it turns off reads "
                "a GDML file's volumes; here gdml is not given); remove allow_overlaps"
            )
        return self


def allowing_overlaps(config: RunConfig) -> RunConfig:
    """``config`` with ``world.allow_overlaps: true``."""
    return config.model_copy(
        update={"world": config.world.model_copy(update={"allow_overlaps": True})}
    )


Face = Literal["+x", "-x", "+y", "-y", "+z", "-z"]


class FaceRef(StrictModel):
    """Faces of a volume: ``face: "+z"`` (one face), ``all`` (every face, area-uniform), a
    face or group name of the volume's solid (:mod:`score4.shapes`; box targets have the six
    faces ``+x`` ... ``-z``), or a list of them (``[seg_2, seg_3, top]``). ``volume`` is a box
    target's name or, in a GDML world, the ``volume`` of a GDML target (or one of its copies,
    ``name[k]``)."""

    volume: str
    face: str | list[Annotated[str, Field(min_length=1)]] = Field("+z", min_length=1)


class SurfaceFile(StrictModel):
    """A surface stored in a score4 surface file (``score4 surface generate``)."""

    file: ConfigPath


def _surface_tag(value: object) -> str | None:
    if isinstance(value, dict):
        return value.get("kind", "surface-file" if "file" in value else None)
    return getattr(value, "kind", "surface-file")


# A surface under ``surfaces``: a description (kind: spikes | random | measured) or a surface file.
SurfaceDescription = Annotated[
    Annotated[SpikeSurfaceSpec, Tag("spikes")]
    | Annotated[RandomSurfaceSpec, Tag("random")]
    | Annotated[MeasuredSurfaceSpec, Tag("measured")]
    | Annotated[SurfaceFile, Tag("surface-file")],
    Discriminator(
        _surface_tag,
        custom_error_type="surface_kind",
        custom_error_message="a surface needs kind: spikes, random or measured, or file: "
        "<name>.s4s.h5",
    ),
]


class PatchVariant(StrictModel):
    surface: str  # a name under ``surfaces``
    density: float  # target fraction of the cells (normalised if the densities do not sum to 1)


class RoughFace(StrictModel):
    """A rough face of a target: its surface, tiled over the face from patches.

    Give ``surface`` (one patch, repeated) or ``variants`` (several patches with target
    densities). The patch size is the surface's size; the face must be a whole number of patches.
    The rough layer (patch bodies: the rough top on a slab ``base_thickness`` thick) sits on the
    face, outside the box, in the target's material, and is scored with the target.
    """

    used_only_with: ClassVar[dict[str, object]] = {
        "n_tiles": ("fill", ("tiles",)),
        "native_layout": ("tiling", ("native",)),
        "block_cells": ("solid", ("blocks",)),  # solid: auto resolves per surface (option_values)
        "fill": ("variants", GIVEN),  # one surface: every cell shows it, there is nothing to fill
        "seed": ("variants", GIVEN),
        "into": ("tiling", ("native",)),
    }

    # a face or group of the volume's solid (score4.shapes), or a list of them: one layer per face
    face: str | list[Annotated[str, Field(min_length=1)]] = Field("+z", min_length=1)
    surface: str | None = None
    variants: list[PatchVariant] | None = Field(None, min_length=1)
    fill: Literal["exact", "random", "tiles"] = "exact"  # how cells get their variant
    n_tiles: int = Field(DEFAULT_TILES, ge=1)  # fill: tiles: random tiles in the library
    seed: int = Field(0, ge=0)  # of the patch map
    tiling: Literal["native", "portal"] = "native"
    # native tiling: auto = nested (2 x 2 groups of cells above 2500 cells, shared per content),
    # one G4PVPlacement per cell in the envelope, or G4PVReplica rows of cells (one variant only)
    native_layout: Literal["auto", "nested", "placements", "replicas"] = "auto"
    # auto: multi-union for spike grids of equal heights, frustums for spike grids with a height
    # spread, blocks otherwise (see RoughLayer.solid_kind)
    solid: Literal["auto", "tessellated", "multiunion", "blocks", "frustums"] = "auto"
    # blocks: cells (height-map pixels or spikes) per block side; None: ~8, any map size
    block_cells: int | None = Field(None, ge=1)
    base_thickness: PositiveLength = 1e-3
    # true: the layer takes the place of the outermost layer-thickness of the volume (which is
    # cut by it), so the outer dimensions stay; false: the layer sits on the face, outside
    into: bool = False

    @model_validator(mode="after")
    def _one_kind(self) -> RoughFace:
        if (self.surface is None) == (self.variants is None):
            raise ValueError(
                "give either surface (one patch) or variants (several, with densities)"
            )
        if self.native_layout == "replicas" and len(self.variant_list) > 1:
            raise ValueError(
                "native_layout replicas repeats one patch: it needs a single surface, not variants"
            )
        return self

    def option_values(self, key: str, root) -> tuple[object, ...] | None:
        """``solid: auto`` stands for the solids its surfaces resolve to (see
        :meth:`score4.world.scene.RoughLayer.solid_kind`), known once the run's surfaces are."""
        if key != "solid" or self.solid != "auto":
            return super().option_values(key, root)
        if root is None:
            return None
        kinds = [auto_solid(root.surfaces.get(v.surface)) for v in self.variant_list]
        return None if None in kinds else tuple(dict.fromkeys(kinds))

    @property
    def face_list(self) -> list[str]:
        """The face names and groups as given (one name or a list)."""
        return [self.face] if isinstance(self.face, str) else list(self.face)

    @property
    def face_name(self) -> str:
        """The one face of a resolved layer (the scene makes one layer per face)."""
        assert isinstance(self.face, str), "a face list is resolved into one layer per face"
        return self.face

    @property
    def variant_list(self) -> list[PatchVariant]:
        if self.variants is not None:
            return self.variants
        assert self.surface is not None  # the validator's rule: surface or variants
        # built without validation (the values are valid): a worker process then never builds
        # the models' validators
        return [PatchVariant.model_construct(surface=self.surface, density=1.0)]


def auto_solid(description) -> str | None:
    """The solid ``solid: auto`` makes of a surface description; None when it cannot be told
    without building the surface (an unreadable surface file).

    Spike grids of equal single-layer spikes become a multi-union, with a height spread or
    several layers (bumps, peaks) frustums, height
    maps blocks (the choice explained at :meth:`score4.world.scene.RoughLayer.solid_kind`).
    """
    if isinstance(description, SurfaceFile):
        from score4.surface.store import stored_spec

        description = stored_spec(description.file)
    if isinstance(description, SpikeSurfaceSpec):
        single = description.height_sigma == 0 and description.n_layers == 1
        return "multiunion" if single else "frustums"
    if isinstance(description, (RandomSurfaceSpec, MeasuredSurfaceSpec)):
        return "blocks"
    return None


class DepthConfig(StrictModel):
    """How deep below the local surface a vertex sits."""

    used_only_with: ClassVar[dict[str, object]] = {
        "mean": ("profile", ("exponential", "truncated_gaussian")),
        "sigma": ("profile", ("truncated_gaussian",)),
        "means": ("profile", ("multi_exponential",)),
        "weights": ("profile", ("multi_exponential",)),
        "file": ("profile", ("table",)),
        "unit": ("profile", ("table",)),
    }

    profile: Literal[
        "zero", "exponential", "multi_exponential", "uniform", "truncated_gaussian", "table"
    ] = "zero"
    mean: NonNegativeLength | None = None  # exponential (> 0), truncated_gaussian
    sigma: PositiveLength | None = None  # truncated_gaussian
    means: list[PositiveLength] | None = None  # multi_exponential
    weights: list[float] | None = None  # multi_exponential
    file: ConfigPath | None = None  # table: "depth weight" rows
    unit: str | None = None  # table: unit of the depth column unless the file has "# unit: nm"
    min: NonNegativeLength = 0.0
    max: PositiveLength | None = None  # uniform: required
    definition: Literal["normal", "distance"] = "normal"

    @model_validator(mode="after")
    def _needs(self) -> DepthConfig:
        need = {
            "exponential": ("mean",),
            "multi_exponential": ("means", "weights"),
            "uniform": ("max",),
            "truncated_gaussian": ("mean", "sigma"),
            "table": ("file",),
            "zero": (),
        }[self.profile]
        missing = [k for k in need if getattr(self, k) is None]
        if missing:
            raise ValueError(f"profile {self.profile} needs {' and '.join(missing)}")
        if self.max is not None and self.max <= self.min:
            raise ValueError(
                f"max ({length_text(self.max)}) must be larger than min ({length_text(self.min)})"
            )
        return self


class SpectrumConfig(StrictModel):
    file: ConfigPath  # "energy weight" rows
    unit: str | None = None
    kind: Literal["linear", "histogram"] = "linear"


class DecayChainConfig(StrictModel):
    """A decay chain as a source: its members' decays in the ratio of their activities.

    ``chain``: the head nuclide (every nuclide its decays lead to, down to a stable one or to
    ``until``, which is excluded) or a list of members in decay order. Activities: secular
    equilibrium (the default), or ``since_deposition``: pure head atoms deposited that long ago.
    A daughter decaying within ``coincidence_window`` of its event's first decay joins that
    event (docs/decay.md). ``implantation``: the unit of the run is a deposited head atom,
    followed down the chain; a decay after an alpha decay happens where the alpha's recoil
    stopped (docs/decay.md#recoil-implantation-along-a-chain).
    """

    used_only_with: ClassVar[dict[str, tuple[str, tuple[object, ...]]]] = {
        # per-atom histories follow every atom to the chain's end: secular equilibrium
        "since_deposition": ("implantation", (False,)),
    }

    chain: str | list[str]
    until: str | None = None
    equilibrium: Literal["secular"] | None = None
    since_deposition: NonNegativeTime | None = None
    coincidence_window: NonNegativeTime = 1e4  # ns: 10 us
    # one deposited head atom per run unit; daughters decay where alpha recoils stopped
    implantation: bool = False

    @model_validator(mode="after")
    def _check(self) -> DecayChainConfig:
        if self.equilibrium is not None and self.since_deposition is not None:
            raise ValueError(
                "give equilibrium: secular or since_deposition (the time since a pure head was "
                "deposited), not both"
            )
        from score4.decay.chain import build_chain

        try:
            build_chain(self.chain, self.until, what="decay")
        except ConfigError as err:
            raise ValueError(str(err).removeprefix("decay.").removeprefix("decay: ")) from None
        return self


def _decay_tag(value: object) -> str:
    return "chain" if isinstance(value, (dict, DecayChainConfig)) else "nuclide"


# ``decay:`` a nuclide name, or a chain (a mapping with chain: ...)
DecaySpec = Annotated[
    Annotated[str, Tag("nuclide")] | Annotated[DecayChainConfig, Tag("chain")],
    Discriminator(_decay_tag),
]


#: What ``run.events`` counts: ``"event"``, or ``"atom"``, a per-atom history: one deposited head
#: atom of a decay chain with recoil implantation and the decays of all its daughters, each where
#: the previous recoil stopped (docs/decay.md).
RunUnit = Literal["event", "atom"]


class SourceConfig(StrictModel):
    """Where decays start and what they emit.

    Where: ``surface`` (one face, or ``face: all``: every face of the volume per true area) with
    a ``depth`` below it, or ``volume`` (bulk: uniform in the volume's own material).
    Emitter: ``particle`` with ``energy`` or ``spectrum``; or ``decay``: a nuclide (``Po210``,
    ``Pb210``, any member of the U/Th chains, K40, Co60, Cs137) or a chain
    (:class:`DecayChainConfig`), sampled from evaluated decay data with no Geant4 data needed
    (docs/decay.md); or ``nuclide`` (Geant4 radioactive decay, needs full physics data). Or
    ``vertices``: a vertex file written by
    ``score4 vertices`` whose rows are used as they are.
    """

    used_only_with: ClassVar[dict[str, object]] = {
        "energy": ("particle", GIVEN),
        "spectrum": ("particle", GIVEN),
        # a bulk source (volume: NAME) has no surface: no depth below it, no confinement
        "depth": ("volume", (None,)),
        "confine": ("volume", (None,)),
    }

    surface: FaceRef | None = None
    # bulk: vertices uniform in this volume's own material (its daughters excluded)
    volume: str | None = Field(None, min_length=1)
    particle: str | None = None
    energy: PositiveEnergy | None = None
    spectrum: SpectrumConfig | None = None
    # a nuclide with evaluated decay data ("Pb210", "Pb-210", "210Pb"), or a chain
    decay: DecaySpec | None = None
    nuclide: str | None = None
    # isotropic (4 pi), inward/outward (isotropic in that half-space), cosine_inward/outward
    # (Lambert), normal (a beam along the inward surface normal)
    direction: Literal[
        "isotropic", "inward", "outward", "cosine_inward", "cosine_outward", "normal"
    ] = "isotropic"
    depth: DepthConfig = Field(default_factory=DepthConfig)
    # Keep vertices inside the material of the face's target (a shift along the normal can leave
    # a thin spike); a material name confines to that material instead; false turns it off.
    confine: bool | str = True
    vertices: ConfigPath | None = None

    @field_validator("decay")
    @classmethod
    def _decay_nuclide(cls, v: str | DecayChainConfig | None) -> str | DecayChainConfig | None:
        if isinstance(v, str):
            from score4.decay.nuclear_data import nuclide_record

            try:
                return nuclide_record(v, "decay")[0]
            except ConfigError as err:
                raise ValueError(str(err).removeprefix("decay: ")) from None
        return v

    @property
    def run_unit(self) -> RunUnit:
        """What ``run.events`` counts with this source (:data:`RunUnit`)."""
        decay = self.decay
        return "atom" if isinstance(decay, DecayChainConfig) and decay.implantation else "event"

    @model_validator(mode="after")
    def _emitter(self) -> SourceConfig:
        if self.vertices is not None:
            extra = sorted(self.model_fields_set - {"vertices"})
            if extra:
                raise ValueError(
                    "vertices: a vertex file already holds positions, directions, depths and "
                    f"particles; drop {', '.join(extra)}"
                )
            return self
        if (self.surface is None) == (self.volume is None):
            raise ValueError(
                "give surface (the faces the source sits on, e.g. {volume: crystal, face: '+z'} "
                "or face: all) or volume (bulk: uniform in a volume), not "
                + ("both" if self.surface is not None else "neither")
            )
        if self.volume is not None and self.direction != "isotropic":
            raise ValueError(
                f"direction: a bulk source (volume) emits isotropically; {self.direction} needs a "
                "surface normal"
            )
        kinds = [k for k in ("particle", "decay", "nuclide") if getattr(self, k) is not None]
        if len(kinds) != 1:
            raise ValueError(
                "give exactly one emitter: particle (with energy or spectrum), decay (a nuclide "
                "such as Pb210, or a chain), or nuclide"
                + (f" (got {', '.join(kinds)})" if kinds else "")
            )
        if self.particle is not None and (self.energy is None) == (self.spectrum is None):
            raise ValueError(f"particle {self.particle}: give exactly one of energy and spectrum")
        if self.particle is None and (self.energy is not None or self.spectrum is not None):
            raise ValueError(
                "energy/spectrum belong to particle; decay and nuclide sources fix their own "
                "energies"
            )
        return self


class PhysicsConfig(StrictModel):
    used_only_with: ClassVar[dict[str, object]] = {
        "trim_max_energy": ("heavy_ions", ("trim",)),
        "trim_histories": (("heavy_ions", ("trim",)), ("alphas", ("trim",))),
    }

    mode: Literal["auto", "full", "lite"] = "auto"
    # Secondary-production threshold as a range. Geant4's default (0.7 mm) suppresses delta rays
    # and, with them, all range straggling of alphas; micrometre surfaces need a micrometre cut.
    production_cut: PositiveLength = 1e-3
    # Ions heavier than helium up to trim_max_energy (e.g. the 103 keV Pb-206 recoil of Po-210)
    # follow TRIM trajectories (lunasrim) replayed in the geometry; Geant4 ranges them ~6x too
    # short with no straggling (docs/physics.md). 'geant4' leaves them to Geant4, for comparison.
    heavy_ions: Literal["trim", "geant4"] = "trim"
    trim_max_energy: PositiveEnergy = 1.0
    # TRIM histories per library; not given: scaled with run.events (default_trim_histories)
    trim_histories: int | None = Field(None, ge=10, le=100_000)
    # Alphas: Geant4 (ASTAR-based stopping; within 3 % of TRIM's ranges in Si, Ge, Cu, 4-6 % off
    # in NaI, CaWO4 and TeO2 at some energies) or TRIM trajectories like heavy ions (SRIM stopping).
    alphas: Literal["geant4", "trim"] = "geant4"


class RunSettings(StrictModel):
    events: int = Field(1000, gt=0)
    seed: int = Field(1, ge=0, lt=2**63)
    chunk_events: int = Field(10_000, gt=0)

    @field_validator("events", "chunk_events")
    @classmethod
    def _not_absurd(cls, n: int) -> int:
        problem = limits.too_many_events(n)
        if problem:
            raise ValueError(problem)
        return n


class HistogramConfig(StrictModel):
    bins: int = Field(100, gt=0, le=limits.MAX_BINS)
    max: PositiveEnergy | None = None  # default: the largest primary energy of the run


class OutputConfig(StrictModel):
    histogram: HistogramConfig = Field(default_factory=HistogramConfig)
    track_length: bool = False  # also score the summed charged/neutral track length per volume (mm)
    # also score each volume's deposit split by the class of the particle that made it: alpha,
    # electron (e-, e+, gamma) and ion (the rest: nuclear recoils); the detector response's
    # quenching needs it (score4 template, docs/templates.md). Costs ~15 us per volume per event.
    split_by_particle: bool = False
    # every step with a deposit in a scored volume, per volume: /stp/<volume> as remage writes
    # its germanium steps (docs/activeness.md); a Python stepping action, off unless asked
    steps: bool = False


class RunConfig(StrictModel):
    """A complete run description."""

    physics: PhysicsConfig = Field(default_factory=PhysicsConfig)
    materials: dict[str, MaterialSpec] = {}  # noqa: RUF012 pydantic copies defaults
    world: WorldConfig = Field(default_factory=WorldConfig)
    surfaces: dict[str, SurfaceDescription] = {}  # noqa: RUF012 pydantic copies defaults
    targets: list[Target] = Field(min_length=1)
    source: SourceConfig
    run: RunSettings = Field(default_factory=RunSettings)
    output: OutputConfig = Field(default_factory=OutputConfig)
    # the detector response 'score4 template' applies (not used by the run itself)
    response: ResponseConfig | None = None

    @field_validator("physics", mode="before")
    @classmethod
    def _physics_shorthand(cls, v):
        return {"mode": v} if isinstance(v, str) else v

    @field_validator("materials")
    @classmethod
    def _material_names(cls, v: dict[str, MaterialSpec]) -> dict[str, MaterialSpec]:
        for name in v:
            check_material_name(name)
        return v

    @model_validator(mode="after")
    def _check_references(self, info: ValidationInfo) -> RunConfig:
        names = [t.label for t in self.targets]
        dupes = sorted({n for n in names if names.count(n) > 1})
        if dupes:
            raise ValueError(f"targets: volume names must be unique, repeated: {', '.join(dupes)}")
        if self.world.gdml is None:
            for i, t in enumerate(self.targets):
                if isinstance(t, GdmlVolume):
                    raise ValueError(
                        f"targets.{i}.volume: {t.label!r}: volumes by name need a GDML world "
                        "(world: {gdml: FILE}); a box target has name, size and position"
                    )
                if t.mother is not None:
                    raise ValueError(
                        f"targets.{i}.mother: {t.mother!r}: a mother volume needs a GDML world "
                        "(world: {gdml: FILE})"
                    )
        src = self.source.surface
        if src is not None and self.world.gdml is None and src.volume not in names:
            raise ValueError(
                f"source.surface.volume: {src.volume!r} is not a target; targets are: "
                f"{', '.join(names)}"
            )
        wrong = [
            f
            for f in ([src.face] if src is not None and isinstance(src.face, str) else [])
            + (list(src.face) if src is not None and isinstance(src.face, list) else [])
            if f not in (*FACES, "all")
        ]
        if src is not None and self.world.gdml is None and wrong:
            raise ValueError(
                f"source.surface.face: a box target has the faces {', '.join(FACES)} (or all), "
                f"not {wrong[0]!r}"
            )
        self._check_implantation()
        volume = self.source.volume
        if volume is not None and self.world.gdml is None and volume not in names:
            raise ValueError(
                f"source.volume: {self.source.volume!r} is not a target; targets are: "
                f"{', '.join(names)}"
            )
        for i, t in enumerate(self.targets):
            faces = [f for r in t.rough for f in r.face_list]
            if len(set(faces)) != len(faces):
                raise ValueError(f"targets.{i}.rough: face given twice ({', '.join(faces)})")
            for j, r in enumerate(t.rough):
                for v in r.variant_list:
                    if v.surface not in self.surfaces:
                        known = ", ".join(self.surfaces) or "none defined"
                        raise ValueError(
                            f"targets.{i}.rough.{j}: surface {v.surface!r} is not under surfaces "
                            f"({known})"
                        )
        if not (info.context or {}).get("stored"):  # a stored description has every key filled in
            check_option_keys(self)  # options that resolve across sections (solid: auto)
        self._check_materials()
        self._check_steps_tiling()
        return self

    def _check_steps_tiling(self) -> None:
        """Steps (``output.steps``, ``targets[].activeness``) take Geant4's one stepping action,
        which a portal layer needs for itself: refused here, before any worker starts."""
        key = "output.steps" if self.output.steps else None
        for i, t in enumerate(self.targets):
            key = key or (f"targets.{i}.activeness" if t.activeness else None)
        if key is None:
            return
        for i, t in enumerate(self.targets):
            for j, r in enumerate(t.rough):
                if r.tiling == "portal":
                    raise ValueError(
                        f"{key}: steps (and activeness) need native tiling; targets.{i}.rough.{j} "
                        "has tiling: portal, whose layer has a stepping action of its own"
                    )

    def _check_materials(self) -> None:
        """Every material named here a NIST name or a ``materials:`` entry: checked without
        Geant4, so that ``score4 vertices`` refuses a typo as ``score4 run`` does (a GDML
        world brings its own materials)."""
        from .materials import check_material

        if self.world.gdml is None:
            check_material(self.world.material, "world.material", self.materials)
        for i, t in enumerate(self.targets):
            if isinstance(t, BoxVolume):
                check_material(t.material, f"targets.{i}.material", self.materials)

    def target(self, name: str) -> BoxVolume | GdmlVolume:
        return next(t for t in self.targets if t.label == name)

    def _check_implantation(self) -> None:
        """A chain with implantation needs every alpha recoil of the chain replayed on TRIM
        (its stop point is the daughter's vertex) and native tiling (a portal subworld point
        is not a place in the world)."""
        decay = self.source.decay
        if not isinstance(decay, DecayChainConfig) or not decay.implantation:
            return
        physics = self.physics
        if physics.heavy_ions != "trim":
            raise ValueError(
                "source.decay.implantation: needs physics.heavy_ions: trim (the daughters decay "
                f"where the TRIM replay stops the alpha recoils), not {physics.heavy_ions}"
            )
        from score4.decay.chain import build_chain
        from score4.decay.scheme import decay_scheme

        recoil = max(
            (
                ln.energy
                for m in build_chain(decay.chain, decay.until).members
                for ln in decay_scheme(m).lines()
                if ln.kind == "recoil"
            ),
            default=0.0,
        )
        if recoil * 1e-3 > physics.trim_max_energy:
            raise ValueError(
                f"source.decay.implantation: the chain's alpha recoils reach {recoil:.4g} keV, "
                f"above physics.trim_max_energy ({physics.trim_max_energy * 1e3:.4g} keV); "
                "raise trim_max_energy so that every recoil is replayed"
            )
        for i, t in enumerate(self.targets):
            for j, r in enumerate(getattr(t, "rough", [])):
                if r.tiling == "portal":
                    raise ValueError(
                        f"targets.{i}.rough.{j}.tiling: source.decay.implantation needs native "
                        "tiling (a recoil in a portal subworld stops at no place of the world)"
                    )


def parse_config(
    data: object, origin: str = "config", base_dir: str | Path | None = None
) -> RunConfig:
    """Validate a mapping (parsed YAML) into a :class:`RunConfig`.

    Relative file paths in it are taken relative to ``base_dir`` (the config file's folder).
    """
    if not isinstance(data, dict):
        raise ConfigError(
            f"{origin}: the top level must be a mapping of keys, got {type(data).__name__}"
        )
    try:
        return RunConfig.model_validate(
            data, context={"base_dir": Path(base_dir) if base_dir else None}
        )
    except ValidationError as err:
        raise ConfigError(describe_validation_error(err, origin, data)) from None


def load_config(path: str | Path) -> RunConfig:
    """Read and validate a YAML run configuration file."""
    path = Path(path)
    data = load_yaml(path, "config")
    return parse_config(data, origin=str(path), base_dir=path.parent)


def config_to_dict(config: RunConfig) -> dict:
    """Plain data (internal units) for storage with the results; ``physics.trim_histories`` is
    the library size the run uses (:func:`trim_histories`) when it replays ions."""
    data = config.model_dump(mode="json")
    if "trim" in (config.physics.heavy_ions, config.physics.alphas):
        data["physics"]["trim_histories"] = trim_histories(config)
    return data
