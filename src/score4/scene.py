"""The rough faces of a run, resolved in numpy: surfaces, patch maps, face frames, materials.

Geometry (placing the patches in Geant4) and the source (sampling vertices on the same
patches, confining them to a material) both read this, so they cannot disagree.

Frames. A face of a target box has a right-handed frame ``(u, v, n)``: ``n`` is the outward
normal, ``(u, v)`` span the face (+z: (x, y); -z: (x, -y); +x: (y, z); -x: (-y, z); +y: (z, x);
-y: (x, z)). Face-local coordinates are centred on the face, with z along ``n`` (z = 0 on the
face). The rough layer sits on the face, outside the box: patch ``(i, j)`` is its surface with
the base plane at face-local z = ``base_thickness`` and a slab of material below it down to the
face, so the layer fills 0 <= z <= base_thickness + surface height.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from . import limits
from .config import BoxVolume, RoughFace, RunConfig, SurfaceFile
from .errors import ConfigError
from .surface.blocks import check_patch
from .surface.patchmap import PatchMap, make_patch_map
from .surface.spec import Surface, build_surface
from .surface.store import load_surface

# Face -> (u, v) axes as (axis index, sign); n = u x v is the outward normal.
_FACE_AXES = {
    "+z": ((0, 1), (1, 1)),
    "-z": ((0, 1), (1, -1)),
    "+x": ((1, 1), (2, 1)),
    "-x": ((1, -1), (2, 1)),
    "+y": ((2, 1), (0, 1)),
    "-y": ((0, 1), (2, 1)),
}

#: Points this close (mm) outside a volume's boundary still count as inside (vertices at depth 0
#: lie exactly on the surface).
BOUNDARY_TOLERANCE = 1e-9

#: Gap between the tips of the highest patch and the top of the layer's envelope, mm (1 nm).
ENVELOPE_CLEARANCE = 1e-6


@dataclass(frozen=True)
class FaceFrame:
    """A face of a box: centre, rotation (columns u, v, n) and size (along u, along v)."""

    centre: np.ndarray
    rotation: np.ndarray
    size: tuple[float, float]

    @property
    def normal(self) -> np.ndarray:
        return self.rotation[:, 2]

    def to_world(self, local: np.ndarray) -> np.ndarray:
        return self.centre + np.asarray(local, float) @ self.rotation.T

    def to_local(self, world: np.ndarray) -> np.ndarray:
        return (np.asarray(world, float) - self.centre) @ self.rotation


def face_frame(target: BoxVolume, face: str) -> FaceFrame:
    """The right-handed frame of ``face`` ("+z", "-x", ...) of a box target."""
    (a, sa), (b, sb) = _FACE_AXES[face]
    u, v = np.zeros(3), np.zeros(3)
    u[a], v[b] = sa, sb
    n = np.cross(u, v)
    axis = int(np.flatnonzero(n)[0])
    centre = np.array(target.position, float)
    centre[axis] += n[axis] * target.size[axis] / 2
    return FaceFrame(
        centre, np.column_stack([u, v, n]), (float(target.size[a]), float(target.size[b]))
    )


@dataclass
class RoughLayer:
    """A rough face: patch variants tiled over a face of a target."""

    target: BoxVolume
    config: RoughFace
    frame: FaceFrame
    names: list[str]  # surface name of each variant
    variants: list[Surface]
    patch_map: PatchMap

    @property
    def name(self) -> str:
        return f"{self.target.name}_rough{self.config.face}".replace("+", "p").replace("-", "m")

    @property
    def base_thickness(self) -> float:
        return self.config.base_thickness

    @property
    def patch_size(self) -> tuple[float, float]:
        return self.patch_map.patch_size

    @property
    def thickness(self) -> float:
        """Height of the layer above the face, including the clearance above the highest tip."""
        return self.base_thickness + max(s.max_height for s in self.variants) + ENVELOPE_CLEARANCE

    def solid_kind(self, k: int) -> str:
        """``tessellated``, ``multiunion``, ``frustums`` or ``blocks`` for variant ``k``.

        ``auto`` takes the multi-union for spike grids of equal heights (fastest to track and to
        build, bench_solids.py), ``frustums`` (the multi-union's nodes placed side by side, see
        :mod:`score4.geometry.frustums`) for spike grids with a height spread, and ``blocks``
        otherwise (the closed body cut into small
        tessellated blocks, :mod:`score4.geometry.blocks`): one tessellated solid per patch
        tracked alphas 10-40x slower (benchmarks/bench_surfaces.py), and a multi-union with a
        height spread explodes in voxelisation (50 x 50 pyramids with a 3 um spread: 42 s and
        1.7 GB, against 0.6 s and 10 MB tessellated).
        """
        choice = self.config.solid
        grid = self.variants[k].spikes
        if choice in ("multiunion", "frustums") and grid is None:
            raise ConfigError(
                f"{self.name}: solid {choice} needs a spike-grid surface; {self.names[k]!r} is a "
                "height map"
            )
        if choice == "auto":
            if grid is None:
                return "blocks"
            return "multiunion" if grid.height_sigma == 0 else "frustums"
        return choice

    def cell_centres(self) -> np.ndarray:
        """(ny, nx, 2) face-local centres of the cells."""
        return self.patch_map.cell_centres()

    def sampler(self):
        """A :class:`~score4.source.sampling.TiledSurfaceSampler` on the rough tops."""
        from .source.sampling import SurfaceSampler, TiledSurfaceSampler

        px, py = self.patch_size
        shift = np.array([px / 2, py / 2, 0.0])  # the sampler's patches span [0, px] x [0, py]
        variants = [
            SurfaceSampler(vertices=s.top_mesh.vertices + shift, faces=s.top_mesh.faces)
            for s in self.variants
        ]
        lu, lv = self.frame.size
        origin = self.frame.to_world(np.array([-lu / 2, -lv / 2, self.base_thickness]))
        return TiledSurfaceSampler(
            variants, self.patch_map.variants.T, (px, py), origin, self.frame.rotation
        )

    def contains(self, points: np.ndarray) -> np.ndarray:
        """True for world points inside a patch body (on its boundary within the tolerance)."""
        q = self.frame.to_local(points)
        i, j = self.patch_map.cell_of(q[:, :2])
        inside = (i >= 0) & (q[:, 2] >= -BOUNDARY_TOLERANCE)
        rows = np.flatnonzero(inside)
        centres = self.cell_centres()
        variant = self.patch_map.variants[j[rows], i[rows]]
        for k, surface in enumerate(self.variants):
            r = rows[variant == k]
            c = centres[j[r], i[r]]
            h = surface.height_at(q[r, 0] - c[:, 0], q[r, 1] - c[:, 1])
            inside[r] = q[r, 2] <= self.base_thickness + h + BOUNDARY_TOLERANCE
        return inside


def _in_box(target: BoxVolume, points: np.ndarray) -> np.ndarray:
    half = np.asarray(target.size) / 2 + BOUNDARY_TOLERANCE
    return (np.abs(np.asarray(points, float) - np.asarray(target.position)) <= half).all(axis=1)


@dataclass
class Scene:
    """The targets of a run with their rough layers."""

    config: RunConfig
    surfaces: dict[str, Surface]
    layers: list[RoughLayer] = field(default_factory=list)

    def layer(self, volume: str, face: str) -> RoughLayer | None:
        return next(
            (r for r in self.layers if r.target.name == volume and r.config.face == face), None
        )

    def layers_of(self, volume: str) -> list[RoughLayer]:
        return [r for r in self.layers if r.target.name == volume]

    def inside_target(self, volume: str, points: np.ndarray) -> np.ndarray:
        """True for points in the box of ``volume`` or in one of its rough layers."""
        inside = _in_box(self.config.target(volume), points)
        for layer in self.layers_of(volume):
            inside |= layer.contains(points)
        return inside

    def inside_material(self, material: str, points: np.ndarray) -> np.ndarray:
        """True for points in any target (with its rough layers) made of ``material``."""
        names = [t.name for t in self.config.targets if t.material == material]
        if not names:
            known = sorted({t.material for t in self.config.targets})
            raise ConfigError(
                f"source.confine: no target is made of {material!r}; target materials: "
                f"{', '.join(known)}"
            )
        inside = np.zeros(len(points), dtype=bool)
        for name in names:
            inside |= self.inside_target(name, points)
        return inside

    @cached_property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """(lo, hi) corners of a box holding every target and rough layer."""
        boxes = [_box_of_target(t) for t in self.config.targets] + [
            _box_of_layer(r) for r in self.layers
        ]
        return np.min([lo for lo, _ in boxes], axis=0), np.max([hi for _, hi in boxes], axis=0)

    @cached_property
    def world_half(self) -> np.ndarray:
        """Half-lengths of the world box, centred on the origin, that holds every target, rough
        layer and ``world.margin`` (where particles move; a portal adds subworlds beyond it)."""
        lo, hi = self.bounds
        return np.maximum(np.abs(lo), np.abs(hi)) + self.config.world.margin


def _box_of_target(target: BoxVolume) -> tuple[np.ndarray, np.ndarray]:
    """Axis-aligned (lo, hi) of a target box."""
    half = np.divide(target.size, 2)
    return np.subtract(target.position, half), np.add(target.position, half)


def _box_of_layer(layer: RoughLayer) -> tuple[np.ndarray, np.ndarray]:
    """Axis-aligned (lo, hi) of the layer's envelope: the face extruded by the layer thickness."""
    lu, lv = layer.frame.size
    corners = np.array(
        [
            [su * lu / 2, sv * lv / 2, z]
            for su in (-1, 1)
            for sv in (-1, 1)
            for z in (0.0, layer.thickness)
        ]
    )
    world = layer.frame.to_world(corners)
    return world.min(axis=0), world.max(axis=0)


def _overlap(a: tuple[np.ndarray, np.ndarray], b: tuple[np.ndarray, np.ndarray]) -> bool:
    """Boxes share volume (touching faces are fine)."""
    return bool(np.all(np.minimum(a[1], b[1]) - np.maximum(a[0], b[0]) > BOUNDARY_TOLERANCE))


def check_clearance(scene: Scene) -> None:
    """Refuse targets that overlap, rough layers that run into another target or rough layer,
    and a world beyond :data:`score4.limits.MAX_WORLD_EXTENT`."""
    far = float(np.max(scene.world_half))
    if far > limits.MAX_WORLD_EXTENT:
        raise ConfigError(
            f"targets: the world reaches {far / 1e3:.4g} m from the origin (targets, rough layers "
            "and world.margin); score4's limit is 1 km (move the targets towards the origin)"
        )
    boxes = {t.name: _box_of_target(t) for t in scene.config.targets}
    names = list(boxes)
    for a, name in enumerate(names):
        for other in names[a + 1 :]:
            if _overlap(boxes[name], boxes[other]):
                raise ConfigError(
                    f"targets: {name!r} and {other!r} overlap; Geant4 needs volumes that do not "
                    "overlap"
                )
    layers = [(layer, _box_of_layer(layer)) for layer in scene.layers]
    for n, (layer, box) in enumerate(layers):
        others = [(f"target {name!r}", b) for name, b in boxes.items() if name != layer.target.name]
        others += [(f"the rough layer {o.name}", ob) for o, ob in layers[n + 1 :]]
        for what, other_box in others:
            if _overlap(box, other_box):
                axis = int(np.flatnonzero(layer.frame.normal)[0])
                gap = (
                    (other_box[0][axis] - box[0][axis])
                    if layer.frame.normal[axis] > 0
                    else (box[1][axis] - other_box[1][axis])
                )
                raise ConfigError(
                    f"{layer.name}: the rough layer on face {layer.config.face} of "
                    f"{layer.target.name!r} is {layer.thickness * 1e3:.4g} um thick (base "
                    f"{layer.base_thickness * 1e3:.4g} um + highest tip) and runs into {what} "
                    f"(free gap there: {max(gap, 0.0) * 1e3:.4g} um); move the volumes apart or "
                    "use a lower surface"
                )


def _load(name: str, description) -> Surface:
    where = f"surfaces.{name}"
    try:
        return (
            load_surface(description.file)
            if isinstance(description, SurfaceFile)
            else build_surface(description)
        )
    except ConfigError as err:
        raise ConfigError(f"{where}: {err}") from None


def _same_size(a: float, b: float) -> bool:
    return abs(a - b) <= 1e-9 * max(abs(a), abs(b))


def build_scene(config: RunConfig) -> Scene:
    """Build every surface the targets use and the patch map of every rough face."""
    used = {v.surface for t in config.targets for r in t.rough for v in r.variant_list}
    surfaces = {
        name: _load(name, config.surfaces[name]) for name in config.surfaces if name in used
    }
    scene = Scene(config, surfaces)
    for i, target in enumerate(config.targets):
        for j, rough in enumerate(target.rough):
            where = f"targets.{i}.rough.{j}"
            names = [v.surface for v in rough.variant_list]
            variants = [surfaces[n] for n in names]
            size = (variants[0].size_x, variants[0].size_y)
            for n, s in zip(names, variants, strict=True):
                if not (_same_size(s.size_x, size[0]) and _same_size(s.size_y, size[1])):
                    raise ConfigError(
                        f"{where}: all variants must have the same patch size; {names[0]!r} is "
                        f"{size[0] * 1e3:g} x {size[1] * 1e3:g} um, {n!r} is {s.size_x * 1e3:g} x "
                        f"{s.size_y * 1e3:g} um"
                    )
            frame = face_frame(target, rough.face)
            try:
                patch_map = make_patch_map(
                    frame.size,
                    size,
                    [v.density for v in rough.variant_list],
                    method=rough.fill,
                    seed=rough.seed,
                    n_tiles=rough.n_tiles,
                )
            except ConfigError as err:
                raise ConfigError(f"{where} (face {rough.face} of {target.name}): {err}") from None
            layer = RoughLayer(target, rough, frame, names, variants, patch_map)
            for k, n in enumerate(names):
                try:
                    check_patch(variants[k], layer.solid_kind(k), rough.block_cells)
                except ConfigError as err:
                    raise ConfigError(f"{where} (surface {n!r}): {err}") from None
            scene.layers.append(layer)
    check_clearance(scene)
    return scene
