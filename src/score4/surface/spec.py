"""Surface descriptions (YAML) and the :class:`Surface` they build.

A description is one of three kinds, told apart by ``kind``:

* ``spikes``: the paper's spike grid (:class:`~score4.surface.spikes.SpikeGrid`);
* ``random``: a seeded random rough surface (:mod:`score4.surface.random`);
* ``measured``: a topography file (:func:`~score4.surface.readers.read_topography`), levelled,
  cropped, resampled and gap-filled as asked.

Every surface is placed the same way: centred on the origin in x and y, on a base plane z = 0
with all of its material above it (spikes start at z = 0; height maps are shifted so that their
lowest point is at z = 0). A Geant4 patch is this top surface on a slab of ``base_thickness``
below z = 0 (:meth:`Surface.body`).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import cache, cached_property
from pathlib import Path
from typing import Annotated, ClassVar, Literal

import numpy as np
from pydantic import (
    BeforeValidator,
    Field,
    PlainSerializer,
    TypeAdapter,
    ValidationError,
    model_validator,
)

from score4.common import limits
from score4.common.schema import (
    ABOVE_ZERO,
    ConfigPath,
    Length,
    NonNegativeLength,
    PositiveLength,
    StrictModel,
    describe_validation_error,
    quantity,
)
from score4.common.yamlfile import load_yaml

from ..errors import ConfigError
from .heightmap import HeightMap
from .processing import close_periodic, crop, fill_missing, level_plane, resample
from .random import random_surface
from .readers import TEXT_FORMATS, format_of, read_topography
from .simplify import simplified_blocks
from .spikes import SpikeGrid
from .triangle_mesh import TriangleMesh, closed_body, from_heightmap

#: ``tolerance: auto`` keeps a height map's mesh exact up to this many triangles (a map of up to
#: ~500 x 500 pixels, every example and test map: their results do not change); above it the
#: tolerance is the rule issue 24 set for rough layers on curved faces: 1 % of the map's height
#: (peak to valley) or 0.1 um, whichever is larger. A 1024 x 1024 map's 2.1 M exact triangles
#: cost ~30 s and ~1.7 GB to build in Geant4 (docs/surfaces.md).
AUTO_EXACT_FACETS = 500_000
#: The smallest automatic tolerance, mm (0.1 um).
AUTO_MIN_TOLERANCE = 1e-4
#: The automatic tolerance's share of the map's height (peak to valley).
AUTO_HEIGHT_SHARE = 0.01


def _tolerance(value: object) -> float | str:
    """A map's ``tolerance``: ``auto``, 0 (the exact mesh) or a length, mm."""
    if value == "auto":
        return "auto"
    if not isinstance(value, bool) and isinstance(value, (int, float, str)) and value in (0, "0"):
        return 0.0
    try:
        return quantity(value, "length", "tolerance", non_negative=True)
    except ConfigError as err:
        raise ValueError(
            f"{str(err).removeprefix('tolerance: ')}; give a length such as '0.1 um', 0 (the "
            "exact mesh) or auto"
        ) from None


#: ``tolerance:`` of a height map (:attr:`Surface.mesh_tolerance`); stored with its unit.
Tolerance = Annotated[
    float | str,
    BeforeValidator(_tolerance),
    PlainSerializer(lambda v: v if v == "auto" else f"{v!r} mm", when_used="json"),
]

#: Height-map samples per spike cell and axis used to picture and measure a spike grid as a map.
SPIKE_MAP_SAMPLES = 16


class SpikeSurfaceSpec(StrictModel):
    """A grid of ``nx`` x ``ny`` spikes; all lengths are full lengths."""

    exclusive_keys = (("width", "width_x"), ("width", "width_y"))
    # heights are drawn (with the seed, truncated at min_height) only with a spread
    used_only_with: ClassVar[dict[str, object]] = {
        "min_height": ("height_sigma", ABOVE_ZERO),
        "seed": ("height_sigma", ABOVE_ZERO),
    }

    kind: Literal["spikes"]
    nx: int = Field(gt=0)
    ny: int = Field(gt=0)
    width: PositiveLength | None = None  # shorthand for width_x = width_y
    width_x: PositiveLength | None = None
    width_y: PositiveLength | None = None
    height: PositiveLength  # mean spike height, base to tip
    height_sigma: NonNegativeLength = 0.0
    min_height: PositiveLength | None = None
    shape: Literal["pyramid", "bump", "peak"] = "pyramid"
    n_layers: int = Field(1, gt=0)
    seed: int = Field(0, ge=0)

    @model_validator(mode="after")
    def _widths(self) -> SpikeSurfaceSpec:
        wx = self.width_x if self.width_x is not None else self.width
        wy = self.width_y if self.width_y is not None else self.width
        if wx is None or wy is None:
            raise ValueError("give the spike cell size as width (square) or as width_x and width_y")
        object.__setattr__(self, "width_x", wx)
        object.__setattr__(self, "width_y", wy)
        limits.check_memory(
            limits.spike_grid_bytes(self.nx * self.ny, self.n_layers),
            f"a grid of {self.nx} x {self.ny} spikes of {self.n_layers} layer(s)",
            "nx, ny",
            "use fewer, larger spikes; a large face is tiled from one patch (docs/tiling.md)",
        )
        return self


class RandomSurfaceSpec(StrictModel):
    """A random rough surface on an ``nx`` x ``ny`` grid (see :mod:`score4.surface.random`)."""

    _SELF_AFFINE = ("model", ("self_affine",))
    _CORRELATED = ("model", ("gaussian", "exponential"))
    used_only_with: ClassVar[dict[str, object]] = {
        "hurst": _SELF_AFFINE,
        "rms_slope": _SELF_AFFINE,
        "long_cutoff": _SELF_AFFINE,
        "short_cutoff": _SELF_AFFINE,
        "corr_length": _CORRELATED,
        "corr_length_y": _CORRELATED,
    }

    kind: Literal["random"]
    model: Literal["gaussian", "exponential", "self_affine"] = "gaussian"
    nx: int = Field(gt=0)
    ny: int = Field(gt=0)
    pitch: PositiveLength
    pitch_y: PositiveLength | None = None
    sq: PositiveLength | None = None
    corr_length: PositiveLength | None = None  # gaussian/exponential: along x (and y unless given)
    corr_length_y: PositiveLength | None = None
    hurst: float | None = Field(None, gt=0, lt=1)  # self_affine
    rms_slope: float | None = Field(None, gt=0)
    long_cutoff: PositiveLength | None = None
    short_cutoff: PositiveLength | None = None
    skewness: float = 0.0
    kurtosis: float = 3.0
    periodic: bool = True  # tiles join without steps
    seed: int = Field(0, ge=0)
    # the largest vertical error of the map's mesh: 0 the exact mesh, "auto" the rule of
    # Surface.mesh_tolerance (score4.surface.simplify)
    tolerance: Tolerance = "auto"

    @model_validator(mode="after")
    def _model_parameters(self) -> RandomSurfaceSpec:
        if self.model == "self_affine":
            if self.hurst is None:
                raise ValueError("model self_affine needs hurst (0 < H < 1)")
            if (self.sq is None) == (self.rms_slope is None):
                raise ValueError("model self_affine needs exactly one of sq and rms_slope")
        elif self.sq is None or self.corr_length is None:
            raise ValueError(f"model {self.model} needs sq and corr_length")
        limits.check_memory(
            limits.heightmap_bytes(self.nx * self.ny),
            f"a random map of {self.nx} x {self.ny} points",
            "nx, ny",
            "use fewer points or a larger pitch; a large face is tiled from one patch",
        )
        return self


class MeasuredSurfaceSpec(StrictModel):
    """A measured topography file and what to do with it before use."""

    # what the readers of each format take (score4.surface.readers)
    used_only_with: ClassVar[dict[str, object]] = {
        "pitch": ("format", TEXT_FORMATS),
        "xy_unit": ("format", ("xyz", "gwy")),
        "z_unit": ("format", (*TEXT_FORMATS, "xyz", "gwy")),
        "channel": ("format", ("gwy",)),
    }

    kind: Literal["measured"]
    file: ConfigPath
    format: str | None = None  # default: from the extension
    xy_unit: str | None = None  # text/xyz files without units in a header
    z_unit: str | None = None
    pitch: PositiveLength | None = None  # text grids without a header pitch
    channel: str | None = None  # Gwyddion: data field title
    level: bool = True  # subtract the least-squares plane
    crop_x: tuple[Length, Length] | None = None  # (start, stop) in the file's coordinates
    crop_y: tuple[Length, Length] | None = None
    resample_pitch: PositiveLength | None = None
    fill_missing: bool = False  # fill NaN points (Laplace interpolation) instead of refusing them
    # the largest vertical error of the map's mesh: 0 the exact mesh, "auto" the rule of
    # Surface.mesh_tolerance (score4.surface.simplify)
    tolerance: Tolerance = "auto"

    def option_values(self, key: str, root) -> tuple[object, ...] | None:
        """``format`` not given is the file's extension (None if that names no format)."""
        if key != "format" or self.format is not None:
            return super().option_values(key, root)
        try:
            return (format_of(self.file, None),)
        except ConfigError:
            return None


SurfaceSpec = Annotated[
    SpikeSurfaceSpec | RandomSurfaceSpec | MeasuredSurfaceSpec, Field(discriminator="kind")
]


@cache
def _spec_adapter() -> TypeAdapter:
    """The validator of a surface description, built on first use (a worker never needs it)."""
    return TypeAdapter(SurfaceSpec)


KINDS = ("spikes", "random", "measured")


def parse_surface_spec(
    data: object,
    origin: str = "surface",
    base_dir: str | Path | None = None,
    stored: bool = False,
) -> SpikeSurfaceSpec | RandomSurfaceSpec | MeasuredSurfaceSpec:
    """Validate a mapping into a surface description; errors are one :class:`ConfigError` line.

    A relative measured-file path is taken relative to ``base_dir``. ``stored``: a description
    score4 wrote with every key filled in (keys the options ignore are not refused there).
    """
    if not isinstance(data, dict):
        raise ConfigError(
            f"{origin}: a surface description must be a mapping, got {type(data).__name__}"
        )
    if data.get("kind") not in KINDS:
        raise ConfigError(
            f"{origin}: kind: must be one of {', '.join(KINDS)} (got {data.get('kind')!r})"
        )
    try:
        return _spec_adapter().validate_python(
            data, context={"base_dir": base_dir, "stored": stored}
        )
    except ValidationError as err:
        raise ConfigError(describe_validation_error(err, origin, data)) from None


def load_surface_spec(path: str | Path):
    """Read a YAML file that holds one surface description."""
    path = Path(path)
    data = load_yaml(path, "surface")
    return parse_surface_spec(data, origin=str(path), base_dir=path.parent)


@dataclass(frozen=True)
class Surface:
    """A rough surface ready for geometry, sampling and metrology.

    Exactly one of ``spikes`` and ``heightmap`` is the primary description; for a spike grid
    :attr:`map` is a sampled picture of it (for plots and the ISO parameters of maps).
    """

    spec: SpikeSurfaceSpec | RandomSurfaceSpec | MeasuredSurfaceSpec
    spikes: SpikeGrid | None = None
    heightmap: HeightMap | None = None
    metadata: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        if (self.spikes is None) == (self.heightmap is None):
            raise ValueError("Surface needs exactly one of spikes and heightmap")

    @property
    def size_x(self) -> float:
        """Patch size along x, mm (the tile of a rough face)."""
        return self.spikes.size_x if self.spikes is not None else self._extent[0]

    @property
    def size_y(self) -> float:
        """Patch size along y, mm."""
        return self.spikes.size_y if self.spikes is not None else self._extent[1]

    @property
    def _extent(self) -> tuple[float, float]:
        hm = self.heightmap
        assert hm is not None  # a surface holds spikes or a height map
        ny, nx = hm.shape
        return (nx - 1) * hm.pitch_x, (ny - 1) * hm.pitch_y

    @property
    def max_height(self) -> float:
        """Highest point above the base plane z = 0, mm."""
        return (
            float(self.spikes.heights.max())
            if self.spikes is not None
            else float(self.placed_map.heights.max())
        )

    @cached_property
    def placed_map(self) -> HeightMap:
        """The height map centred on the origin, lowest point at z = 0 (height maps only)."""
        hm = self.heightmap
        if hm is None:
            raise ValueError("placed_map: a spike grid has no primary height map; use .map")
        z = hm.heights - np.nanmin(hm.heights)
        return replace(hm, heights=z, origin=(-self._extent[0] / 2, -self._extent[1] / 2))

    @cached_property
    def map(self) -> HeightMap:
        """A height map of the surface for pictures and map metrology (spikes: sampled exactly)."""
        if self.spikes is None:
            return self.placed_map
        g = self.spikes
        limits.check_memory(
            g.nx * g.ny * limits.SPIKE_PICTURE_BYTES,
            f"the picture of {g.nx} x {g.ny} spikes ({SPIKE_MAP_SAMPLES}^2 samples a spike)",
            "nx, ny",
        )
        return g.to_heightmap((g.width_x / SPIKE_MAP_SAMPLES, g.width_y / SPIKE_MAP_SAMPLES))

    @cached_property
    def mesh_tolerance(self) -> float:
        """Largest vertical distance (mm) between a map sample and :attr:`top_mesh`: 0 for an
        exact mesh (spike grids always; maps with ``tolerance: 0`` or small enough for ``auto``).
        """
        t = getattr(self.spec, "tolerance", 0.0)
        if self.heightmap is None or t == 0:
            return 0.0
        if t != "auto":
            return float(t)
        ny, nx = self.placed_map.shape
        if 2 * (nx - 1) * (ny - 1) <= AUTO_EXACT_FACETS:
            return 0.0
        return max(AUTO_HEIGHT_SHARE * self.max_height, AUTO_MIN_TOLERANCE)

    @cached_property
    def quad_cells(self) -> int | None:
        """A simplified map's largest quad side, pixels, which is also its block side
        (:mod:`score4.surface.simplify`); None for an exact mesh."""
        return self._simplified[1]

    @cached_property
    def _simplified(self) -> tuple[TriangleMesh | None, int | None]:
        if not self.mesh_tolerance > 0:
            return None, None
        return simplified_blocks(self.placed_map, self.mesh_tolerance)

    @cached_property
    def top_mesh(self) -> TriangleMesh:
        """The triangle mesh of the rough top (shared by geometry, sampling and metrology):
        exact, or a height map's simplified mesh within :attr:`mesh_tolerance` of every sample."""
        if self.spikes is not None:
            return self.spikes.top_mesh()
        mesh = self._simplified[0]
        return from_heightmap(self.placed_map) if mesh is None else mesh

    def height_at(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Height above the base plane at (x, y), mm (points clipped to the patch): of
        :attr:`top_mesh` exactly for spikes and exact maps; the map's exact mesh (within
        :attr:`mesh_tolerance` of the simplified one) otherwise."""
        if self.spikes is not None:
            return self.spikes.height_at(x, y)
        hm = self.placed_map
        z = hm.heights
        ny, nx = z.shape
        fx = np.clip((np.asarray(x, float) - hm.origin[0]) / hm.pitch_x, 0.0, nx - 1)
        fy = np.clip((np.asarray(y, float) - hm.origin[1]) / hm.pitch_y, 0.0, ny - 1)
        i = np.minimum(fx.astype(np.int64), nx - 2)
        j = np.minimum(fy.astype(np.int64), ny - 2)
        u, v = fx - i, fy - j
        za, zb, zc, zd = z[j, i], z[j, i + 1], z[j + 1, i + 1], z[j + 1, i]
        # from_heightmap splits every cell along (i, j)-(i+1, j+1): linear on each triangle
        return np.where(
            u >= v, za + u * (zb - za) + v * (zc - zb), za + v * (zd - za) + u * (zc - zd)
        )

    def body(self, base_thickness: float) -> TriangleMesh:
        """Closed, watertight patch: the rough top on a slab ``base_thickness`` below z = 0."""
        return closed_body(self.top_mesh, base_thickness)


def build_surface(spec) -> Surface:
    """Build the :class:`Surface` a description asks for (spikes, random field or measured file)."""
    if isinstance(spec, dict):
        spec = parse_surface_spec(spec)
    if isinstance(spec, SpikeSurfaceSpec):
        # the spec's validator fills width_x and width_y in from width
        assert spec.width_x is not None
        assert spec.width_y is not None
        grid = SpikeGrid(
            nx=spec.nx,
            ny=spec.ny,
            width_x=spec.width_x,
            width_y=spec.width_y,
            mean_height=spec.height,
            shape=spec.shape,
            height_sigma=spec.height_sigma,
            n_layers=spec.n_layers,
            seed=spec.seed,
            min_height=spec.min_height,
        )
        return Surface(spec, spikes=grid)
    if isinstance(spec, RandomSurfaceSpec):
        kwargs = dict(
            nx=spec.nx,
            ny=spec.ny,
            pitch_x=spec.pitch,
            pitch_y=spec.pitch_y,
            skewness=spec.skewness,
            kurtosis=spec.kurtosis,
            periodic=spec.periodic,
            seed=spec.seed,
        )
        if spec.model == "self_affine":
            kwargs.update(
                hurst=spec.hurst,
                sq=spec.sq,
                rms_slope=spec.rms_slope,
                long_cutoff=spec.long_cutoff,
                short_cutoff=spec.short_cutoff,
            )
        else:
            kwargs.update(
                sq=spec.sq, corr_length_x=spec.corr_length, corr_length_y=spec.corr_length_y
            )
        hm = random_surface(spec.model, **kwargs)
        # A periodic map holds one period; repeating its first row/column closes it into a tile
        # whose opposite edges match, so tiled patches join without steps.
        return Surface(spec, heightmap=close_periodic(hm) if spec.periodic else hm)
    hm = read_topography(
        spec.file,
        spec.format,
        pitch=spec.pitch,
        xy_unit=spec.xy_unit,
        z_unit=spec.z_unit,
        channel=spec.channel,
    )
    if spec.crop_x is not None or spec.crop_y is not None:
        x = spec.crop_x or (hm.x[0], hm.x[-1])
        y = spec.crop_y or (hm.y[0], hm.y[-1])
        hm = crop(hm, x, y)
    if spec.fill_missing:
        hm = fill_missing(hm)
    elif hm.has_missing:
        n = int(np.isnan(hm.heights).sum())
        raise ConfigError(
            f"file: {spec.file} has {n} missing (NaN) points; set fill_missing: true to fill them "
            "by Laplace interpolation, or crop them away with crop_x/crop_y"
        )
    if spec.level:
        hm = level_plane(hm)
    if spec.resample_pitch is not None:
        hm = resample(hm, spec.resample_pitch)
    return Surface(spec, heightmap=hm)
