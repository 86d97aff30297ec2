"""Regular grids of spikes (the paper's pyramid / bump / peak roughness), exact and vectorised.

Geometry conventions (all lengths are FULL lengths in mm, unlike the original SCoRe4, which
used half-lengths and a pyramid height twice its "mean height"):

* the grid has ``nx`` x ``ny`` cells of ``width_x`` x ``width_y``, centred on the origin, on the
  base plane z = 0; spike (i, j) sits in cell (i, j) and fills it: its base is the whole cell;
* a spike of height ``h`` has a rectangular cross-section at height z whose half-widths are
  ``(width_x / 2, width_y / 2) * f(z / h)`` for a profile ``f`` with f(0) = 1:

  - ``pyramid``: f(u) = 1 - u (one layer: four triangles to an apex at the cell centre);
  - ``bump``: f(u) = 1 - u², the parabolic side profile w(z) = W (1 - (z/H)²);
  - ``peak``: f(u) = 1 / (1 + 5 u), the paper's "1/x" profile w(z) = W / (1 + 5 z/H); the
    constant 5 (:data:`PEAK_STEEPNESS`) is the original's, so the width at the top of the
    smooth profile is W/6;

* bump and peak are approximated by ``n_layers`` frustums of equal height h / n_layers whose
  corners lie exactly on f; the last layer is a pyramid that ends in a point (no tiny square
  top, hence no degenerate facets). The side faces of a frustum are planar trapezoids.

Heights: one value per spike from ``numpy.random.default_rng(seed).normal(mean, sigma)``,
drawn in C order of the (ny, nx) grid. The Gaussian is truncated below at ``min_height``
(default 1 % of the mean): draws below it are redrawn until all are above, so the heights
follow the truncated normal distribution; :attr:`SpikeGrid.truncated_fraction` reports the
fraction of spikes that needed a redraw. A spread for which more than
:data:`MAX_TRUNCATED_FRACTION` of the Gaussian lies below ``min_height`` is refused: the
result would no longer resemble the requested distribution.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, field

import numpy as np

from score4.common.units import length_text, parse_quantity

from ..errors import ConfigError
from .heightmap import HeightMap
from .triangle_mesh import TriangleMesh

SHAPES = ("pyramid", "bump", "peak")

#: Steepness c of the peak profile w(z) = W / (1 + c z/H) (the original SCoRe4 value).
PEAK_STEEPNESS = 5.0

#: Largest accepted probability that a Gaussian height draw falls below ``min_height``.
MAX_TRUNCATED_FRACTION = 0.25

#: Default ``min_height`` as a fraction of ``mean_height``.
DEFAULT_MIN_HEIGHT_FRACTION = 0.01

#: Smallest allowed layer (frustum) height in mm, 10 pm: Geant4's G4Trd needs a half-height of
#: at least 2e-9 mm (measured with geant4_pybind 0.1.3), this keeps a 2.5x margin.
MIN_LAYER_HEIGHT = 1e-8

#: Per-layer frustum parameters returned by :meth:`SpikeGrid.frustums` (lengths in mm, full).
FRUSTUM_DTYPE = np.dtype(
    [
        ("x", "f8"),  # centre of the layer's bounding box
        ("y", "f8"),
        ("z", "f8"),
        ("width_x_bottom", "f8"),  # full widths at the bottom (z - height/2) and top faces
        ("width_x_top", "f8"),
        ("width_y_bottom", "f8"),
        ("width_y_top", "f8"),
        ("height", "f8"),  # full layer height
        ("spike", "i8"),  # spike index j * nx + i
        ("layer", "i4"),  # 0 = bottom layer
    ]
)

# Corner signs of a ring, counter-clockwise seen from +z: (-,-), (+,-), (+,+), (-,+).
_CORNER_SX = np.array([-1.0, 1.0, 1.0, -1.0])
_CORNER_SY = np.array([-1.0, -1.0, 1.0, 1.0])


def _length(value: object, name: str, allow_zero: bool = False) -> float:
    """A positive (or >= 0) finite length in mm, from a number (mm) or a string with a unit."""
    v = parse_quantity(value, "length", name) if isinstance(value, str) else value
    if (
        isinstance(v, bool)
        or not isinstance(v, numbers.Real)
        or not math.isfinite(v)
        or not (float(v) >= 0 if allow_zero else float(v) > 0)
    ):
        rule = "a length >= 0" if allow_zero else "a positive length"
        raise ConfigError(f"{name}: must be {rule}, got {value!r}")
    return float(v)


def _count(value: object, name: str, minimum: int = 1) -> int:
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < minimum:
        raise ConfigError(f"{name}: must be an integer >= {minimum}, got {value!r}")
    return int(value)


def _normal_cdf(x: float) -> float:
    return 0.5 * math.erfc(-x / math.sqrt(2.0))


@dataclass(frozen=True, kw_only=True, eq=False)
class SpikeGrid:
    """A regular grid of spikes filling their cells (see the module docstring for geometry).

    Parameters
    ----------
    nx, ny
        Number of spikes along x and y (>= 1).
    width_x, width_y
        Full cell size of one spike along x and y, mm (or a string such as ``"5 um"``).
    mean_height
        Mean spike height (base to tip), mm.
    shape
        ``"pyramid"``, ``"bump"`` or ``"peak"``.
    height_sigma
        Standard deviation of the Gaussian spike heights, mm; 0 makes all spikes equal.
    n_layers
        Number of frustum layers per spike: 1 for a pyramid, >= 1 for bump and peak.
    seed
        Seed of ``numpy.random.default_rng`` for the heights.
    min_height
        Lower truncation of the height distribution, mm; None (default) means 1 % of
        ``mean_height`` (see :attr:`height_floor`). Must leave every layer at least
        :data:`MIN_LAYER_HEIGHT` high.
    """

    nx: int
    ny: int
    width_x: float
    width_y: float
    mean_height: float
    shape: str = "pyramid"
    height_sigma: float = 0.0
    n_layers: int = 1
    seed: int = 0
    min_height: float | None = None
    heights: np.ndarray = field(init=False, repr=False)
    truncated_fraction: float = field(init=False, repr=False)

    def __post_init__(self) -> None:
        set_ = self._set
        set_("nx", _count(self.nx, "nx"))
        set_("ny", _count(self.ny, "ny"))
        for name in ("width_x", "width_y", "mean_height"):
            set_(name, _length(getattr(self, name), name))
        if self.shape not in SHAPES:
            raise ConfigError(f"shape: must be one of {', '.join(SHAPES)}, got {self.shape!r}")
        set_("n_layers", _count(self.n_layers, "n_layers"))
        if self.shape == "pyramid" and self.n_layers != 1:
            raise ConfigError(
                f"n_layers: a pyramid is a single layer, got {self.n_layers} (use shape bump or "
                "peak)"
            )
        set_("seed", _count(self.seed, "seed", minimum=0))
        set_("height_sigma", _length(self.height_sigma, "height_sigma", allow_zero=True))
        if self.min_height is not None:
            set_("min_height", _length(self.min_height, "min_height"))
        self._check_heights()
        heights, fraction = self._draw_heights()
        heights.setflags(write=False)
        set_("heights", heights)
        set_("truncated_fraction", fraction)

    # --- validation and heights ---------------------------------------------------------

    def _set(self, name: str, value: object) -> None:
        object.__setattr__(self, name, value)  # the dataclass is frozen: normalise once here

    @property
    def height_floor(self) -> float:
        """The truncation height in mm: ``min_height``, or 1 % of ``mean_height`` if unset."""
        return (
            DEFAULT_MIN_HEIGHT_FRACTION * self.mean_height
            if self.min_height is None
            else self.min_height
        )

    def _check_heights(self) -> None:
        floor = self.height_floor
        if floor >= self.mean_height:
            raise ConfigError(
                f"min_height: must be below mean_height={length_text(self.mean_height)}, got "
                f"{length_text(floor)}"
            )
        if floor / self.n_layers < MIN_LAYER_HEIGHT:
            raise ConfigError(
                f"min_height: {length_text(floor)} over {self.n_layers} layers gives layers "
                "thinner than "
                f"{length_text(MIN_LAYER_HEIGHT)} (Geant4's limit); raise min_height or "
                "mean_height, or use fewer layers"
            )
        if self.height_sigma > 0:
            p_low = _normal_cdf((floor - self.mean_height) / self.height_sigma)
            if p_low > MAX_TRUNCATED_FRACTION:
                raise ConfigError(
                    f"height_sigma: {length_text(self.height_sigma)} puts {100 * p_low:.1f} % of "
                    "the Gaussian heights "
                    f"(mean {length_text(self.mean_height)}) below "
                    f"min_height={length_text(floor)}; at most "
                    f"{100 * MAX_TRUNCATED_FRACTION:.0f} % may be truncated, so use a smaller "
                    "spread"
                )

    def _draw_heights(self) -> tuple[np.ndarray, float]:
        shape = (self.ny, self.nx)
        if self.height_sigma == 0:
            return np.full(shape, self.mean_height), 0.0
        rng = np.random.default_rng(self.seed)
        h = rng.normal(self.mean_height, self.height_sigma, size=shape)
        floor = self.height_floor
        low = h < floor
        fraction = float(low.mean())
        # Rejection rounds, each vectorised; P(low) <= MAX_TRUNCATED_FRACTION so few rounds suffice.
        while low.any():
            h[low] = rng.normal(self.mean_height, self.height_sigma, size=int(low.sum()))
            low = h < floor
        return h, fraction

    # --- geometry helpers -----------------------------------------------------------------

    @property
    def size_x(self) -> float:
        """Full length of the grid along x, mm."""
        return self.nx * self.width_x

    @property
    def size_y(self) -> float:
        """Full length of the grid along y, mm."""
        return self.ny * self.width_y

    @property
    def n_spikes(self) -> int:
        return self.nx * self.ny

    @property
    def x_centres(self) -> np.ndarray:
        """(nx,) x of the spike axes, mm."""
        return (np.arange(self.nx) + 0.5) * self.width_x - 0.5 * self.size_x

    @property
    def y_centres(self) -> np.ndarray:
        """(ny,) y of the spike axes, mm."""
        return (np.arange(self.ny) + 0.5) * self.width_y - 0.5 * self.size_y

    @property
    def ring_scale(self) -> np.ndarray:
        """(n_layers + 1,) half-width of each layer boundary relative to the cell half-width.

        Entry k is f(k / n_layers) for k < n_layers, and 0 for the tip; decreasing from 1.
        """
        u = np.arange(self.n_layers) / self.n_layers
        if self.shape == "pyramid":
            f = 1.0 - u
        elif self.shape == "bump":
            f = 1.0 - u**2
        else:
            f = 1.0 / (1.0 + PEAK_STEEPNESS * u)
        return np.append(f, 0.0)

    # --- outputs --------------------------------------------------------------------------

    def frustums(self) -> np.ndarray:
        """Per-layer frustums (future G4Trd nodes), spike-major then layer, dtype FRUSTUM_DTYPE."""
        n, g = self.n_layers, self.ring_scale
        h = self.heights.ravel()
        out = np.empty((h.size, n), dtype=FRUSTUM_DTYPE)
        xc, yc = np.meshgrid(self.x_centres, self.y_centres)
        out["x"] = xc.ravel()[:, None]
        out["y"] = yc.ravel()[:, None]
        dz = h / n
        out["height"] = dz[:, None]
        out["z"] = (np.arange(n) + 0.5)[None, :] * dz[:, None]
        out["width_x_bottom"] = self.width_x * g[:-1]
        out["width_x_top"] = self.width_x * g[1:]
        out["width_y_bottom"] = self.width_y * g[:-1]
        out["width_y_top"] = self.width_y * g[1:]
        out["spike"] = np.arange(h.size)[:, None]
        out["layer"] = np.arange(n)[None, :]
        return out.ravel()

    def _vertex_layout(self) -> tuple[np.ndarray, np.ndarray]:
        """Vertices and the (ny, nx, n_layers + 1, 4) index of every ring corner.

        Ring 0 (the cell corners) is shared with neighbouring spikes; rings 1..n-1 belong to
        one spike; ring n is the apex, repeated for the four corners.
        """
        nx, ny, n = self.nx, self.ny, self.n_layers
        g = self.ring_scale
        cx = np.arange(nx + 1) * self.width_x - 0.5 * self.size_x
        cy = np.arange(ny + 1) * self.width_y - 0.5 * self.size_y
        gx, gy = np.meshgrid(cx, cy)
        corners = np.column_stack([gx.ravel(), gy.ravel(), np.zeros(gx.size)])
        xs, ys = np.meshgrid(self.x_centres, self.y_centres)
        k = np.arange(1, n)
        # Inner rings: (ny, nx, n-1, 4) coordinates.
        rx = xs[..., None, None] + 0.5 * self.width_x * g[k][:, None] * _CORNER_SX
        ry = ys[..., None, None] + 0.5 * self.width_y * g[k][:, None] * _CORNER_SY
        rz = np.broadcast_to(self.heights[..., None, None] * (k / n)[:, None], rx.shape)
        rings = np.stack([rx, ry, rz], axis=-1).reshape(-1, 3)
        apex = np.column_stack([xs.ravel(), ys.ravel(), self.heights.ravel()])
        vertices = np.vstack([corners, rings, apex])

        index = np.empty((ny, nx, n + 1, 4), dtype=np.int64)
        c = np.arange((nx + 1) * (ny + 1)).reshape(ny + 1, nx + 1)
        index[:, :, 0] = np.stack([c[:-1, :-1], c[:-1, 1:], c[1:, 1:], c[1:, :-1]], axis=-1)
        n_corners, n_rings = len(corners), len(rings)
        index[:, :, 1:n] = n_corners + np.arange(n_rings).reshape(ny, nx, n - 1, 4)
        index[:, :, n] = (n_corners + n_rings + np.arange(nx * ny).reshape(ny, nx))[..., None]
        return vertices, index

    def top_mesh(self) -> TriangleMesh:
        """Exact triangle mesh of the top surface (all faces ``top``; ``facet`` = spike index).

        Each layer side is a planar trapezoid split into two triangles; the last layer's sides
        are single triangles to the apex. Faces per spike: 8 (n_layers - 1) + 4.
        """
        vertices, idx = self._vertex_layout()
        n = self.n_layers
        lo, hi = idx[:, :, :-1], idx[:, :, 1:]  # bottom / top ring of each layer
        lo_next, hi_next = np.roll(lo, -1, axis=-1), np.roll(hi, -1, axis=-1)
        # Outward (away from the axis, upward) orientation: (b_s, b_s+1, t_s+1) and (b_s, t_s+1,
        # t_s).
        first = np.stack([lo, lo_next, hi_next], axis=-1)  # (ny, nx, n, 4, 3)
        second = np.stack([lo, hi_next, hi], axis=-1)[:, :, : n - 1]  # none in the apex layer
        per_spike = [first[:, :, : n - 1], second, first[:, :, n - 1 :]]
        faces = np.concatenate([p.reshape(self.n_spikes, -1, 3) for p in per_spike], axis=1)
        spike = np.repeat(np.arange(self.n_spikes), faces.shape[1])
        return TriangleMesh(vertices, faces.reshape(-1, 3), facet=spike)

    def height_at(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Exact height of the meshed surface at points (x, y), mm (broadcasting).

        Points outside the grid take the height of the nearest cell's profile clipped to its
        base, i.e. 0.
        """
        x, y = np.broadcast_arrays(np.asarray(x, float), np.asarray(y, float))
        i = np.clip(
            np.floor((x + 0.5 * self.size_x) / self.width_x).astype(np.int64), 0, self.nx - 1
        )
        j = np.clip(
            np.floor((y + 0.5 * self.size_y) / self.width_y).astype(np.int64), 0, self.ny - 1
        )
        u = np.abs(x - self.x_centres[i]) / (0.5 * self.width_x)
        v = np.abs(y - self.y_centres[j]) / (0.5 * self.width_y)
        # The surface point lies on the ring contour whose relative half-width equals max(u, v).
        rho = np.minimum(np.maximum(u, v), 1.0)
        g = self.ring_scale
        k = np.clip(np.searchsorted(-g, -rho, side="right") - 1, 0, self.n_layers - 1)
        frac = (g[k] - rho) / (g[k] - g[k + 1])
        return self.heights[j, i] * (k + frac) / self.n_layers

    def to_heightmap(self, pitch: float | tuple[float, float]) -> HeightMap:
        """Sample the exact surface on a regular grid starting at the grid's corner.

        Samples are at ``-size/2 + k * pitch`` for k = 0 .. floor(size / pitch) along each axis
        (the last sample reaches the far edge only when the pitch divides the size).
        """
        pair = pitch if isinstance(pitch, (tuple, list, np.ndarray)) else (pitch, pitch)
        px, py = _length(pair[0], "pitch"), _length(pair[1], "pitch")
        nsx = math.floor(self.size_x / px * (1 + 1e-12)) + 1
        nsy = math.floor(self.size_y / py * (1 + 1e-12)) + 1
        if min(nsx, nsy) < 2:
            raise ConfigError(
                f"pitch: ({length_text(px)}, {length_text(py)}) gives fewer than 2 samples across "
                f"the {length_text(self.size_x)} x {length_text(self.size_y)} grid"
            )
        x = -0.5 * self.size_x + px * np.arange(nsx)
        y = -0.5 * self.size_y + py * np.arange(nsy)
        z = self.height_at(x[None, :], y[:, None])
        meta = {"source": "SpikeGrid", "shape": self.shape, "nx": self.nx, "ny": self.ny}
        return HeightMap(z, px, py, origin=(float(x[0]), float(y[0])), metadata=meta)
