"""A rough surface ready for geometry, sampling and metrology (:class:`Surface`).

Its description (``spec``) is a validated model of :mod:`score4.surface.spec`, where
:func:`~score4.surface.spec.build_surface` makes it; this module needs no pydantic, so a worker
process that receives built surfaces (with a record of their description) never imports it.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np

from score4.common import limits

from .heightmap import HeightMap
from .simplify import simplified_blocks
from .spikes import SpikeGrid
from .triangle_mesh import TriangleMesh, closed_body, from_heightmap

if TYPE_CHECKING:
    from .spec import MeasuredSurfaceSpec, RandomSurfaceSpec, SpikeSurfaceSpec

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
#: ``tolerance: auto`` keeps the exact mesh when the simplified one would still hold more than
#: this share of its triangles: a noise-like map hardly simplifies, and its simplified blocks,
#: cut down to few facets each for per-event speed, would cost more to build than the exact ones.
AUTO_MIN_SAVING = 0.5


#: Height-map samples per spike cell and axis used to picture and measure a spike grid as a map.
SPIKE_MAP_SAMPLES = 16


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
        exact mesh (spike grids always; maps with ``tolerance: 0``, and under ``auto`` maps
        small enough or too noise-like to gain from simplifying)."""
        return self._mesh_choice[0]

    @cached_property
    def quad_cells(self) -> int | None:
        """A simplified map's largest quad side, pixels, which is also its block side
        (:mod:`score4.surface.simplify`); None for an exact mesh."""
        return self._simplified[1]

    @cached_property
    def _simplified(self) -> tuple[TriangleMesh | None, int | None]:
        return self._mesh_choice[1]

    @cached_property
    def _mesh_choice(self) -> tuple[float, tuple[TriangleMesh | None, int | None]]:
        exact: tuple[TriangleMesh | None, int | None] = (None, None)
        t = getattr(self.spec, "tolerance", 0.0)
        if self.heightmap is None or t == 0:
            return 0.0, exact
        if t != "auto":
            simplified = simplified_blocks(self.placed_map, float(t))
            assert simplified is not None  # no bound on its triangles
            return float(t), simplified
        ny, nx = self.placed_map.shape
        exact_faces = 2 * (nx - 1) * (ny - 1)
        if exact_faces <= AUTO_EXACT_FACETS:
            return 0.0, exact
        tolerance = max(AUTO_HEIGHT_SHARE * self.max_height, AUTO_MIN_TOLERANCE)
        # None: more than AUTO_MIN_SAVING of the exact triangles (given up early, a noise-like map)
        simplified = simplified_blocks(
            self.placed_map, tolerance, int(AUTO_MIN_SAVING * exact_faces)
        )
        if simplified is None:
            return 0.0, exact
        return tolerance, simplified

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
