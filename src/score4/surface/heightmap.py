"""The one height-map type every surface source (generated or measured) is turned into."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from score4.common import limits

from ..errors import ConfigError


@dataclass(frozen=True)
class HeightMap:
    """Heights z(x, y) on a regular grid, in internal units (mm).

    Parameters
    ----------
    heights
        2-D array of shape ``(ny, nx)``: row ``j`` is y = y0 + j*pitch_y, column ``i`` is
        x = x0 + i*pitch_x. NaN marks a missing measurement point.
    pitch_x, pitch_y
        Grid spacing in mm (sample-to-sample distance, not the map length divided by n-1).
    origin
        (x0, y0) of sample [0, 0], in mm.
    metadata
        Free-form provenance (file name, instrument, generator parameters).
    """

    heights: np.ndarray
    pitch_x: float
    pitch_y: float
    origin: tuple[float, float] = (0.0, 0.0)
    metadata: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        z = np.asarray(self.heights, dtype=float)
        if z.ndim != 2 or min(z.shape) < 2:
            raise ConfigError(
                f"heights: need a 2-D grid of at least 2 x 2 points, got shape {z.shape}"
            )
        for name in ("pitch_x", "pitch_y"):
            p = getattr(self, name)
            if not (np.isfinite(p) and p > 0):
                raise ConfigError(f"{name}: must be a positive length, got {p!r}")
            limits.check_length(p, name)
        ny, nx = z.shape
        extent = max((nx - 1) * self.pitch_x, (ny - 1) * self.pitch_y)
        limits.check_length(extent, "map size (points - 1) x pitch")
        if np.isnan(z).all():
            raise ConfigError("heights: every point is NaN (no valid measurement)")
        if np.isinf(z).any():
            j, i = np.argwhere(np.isinf(z))[0]
            raise ConfigError(
                f"heights: point (row {j}, column {i}) is {z[j, i]}; heights must be finite (NaN "
                "marks a missing point)"
            )
        span = float(np.nanmax(z) - np.nanmin(z))
        if span > limits.MAX_LENGTH:
            raise ConfigError(
                f"heights: span {span / 1e3:.4g} m, more than 100 m, score4's limit for any length "
                "(a unit slip?)"
            )
        object.__setattr__(self, "heights", z)

    @property
    def shape(self) -> tuple[int, int]:
        """(ny, nx)."""
        return self.heights.shape

    @property
    def size_x(self) -> float:
        """Extent in x covered by the samples, (nx - 1) * pitch_x, in mm."""
        return (self.shape[1] - 1) * self.pitch_x

    @property
    def size_y(self) -> float:
        """Extent in y covered by the samples, (ny - 1) * pitch_y, in mm."""
        return (self.shape[0] - 1) * self.pitch_y

    @property
    def x(self) -> np.ndarray:
        return self.origin[0] + self.pitch_x * np.arange(self.shape[1])

    @property
    def y(self) -> np.ndarray:
        return self.origin[1] + self.pitch_y * np.arange(self.shape[0])

    @property
    def has_missing(self) -> bool:
        return bool(np.isnan(self.heights).any())
