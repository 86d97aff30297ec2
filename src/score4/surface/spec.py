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

from functools import cache
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
from .processing import close_periodic, crop, fill_missing, level_plane, resample
from .random import random_surface
from .readers import TEXT_FORMATS, format_of, read_topography
from .rough import AUTO_EXACT_FACETS as AUTO_EXACT_FACETS  # their home was here: re-exported
from .rough import AUTO_HEIGHT_SHARE as AUTO_HEIGHT_SHARE
from .rough import AUTO_MIN_TOLERANCE as AUTO_MIN_TOLERANCE
from .rough import SPIKE_MAP_SAMPLES as SPIKE_MAP_SAMPLES
from .rough import Surface as Surface
from .spikes import SpikeGrid


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
