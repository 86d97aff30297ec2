"""The rough faces of a run, resolved in numpy: surfaces, patch maps, face frames, materials.

Geometry (placing the patches in Geant4) and the source (sampling vertices on the same
patches, confining them to a material) both read this, so they cannot disagree.

Targets. A :class:`TargetVolume` is one scored volume: a box of the configuration or one
instance (copy) of a volume of a GDML world, with its solid, material and global transform
(rotation columns = the volume's axes in the world, translation = its origin). A GDML target
named by a volume with several copies becomes one target per copy.

Frames. A face of a target box has a right-handed frame ``(u, v, n)`` in the box's own frame:
``n`` is the outward normal, ``(u, v)`` span the face (+z: (x, y); -z: (x, -y); +x: (y, z); -x:
(-y, z); +y: (z, x); -y: (x, z)); the end faces ``+z``/``-z`` of a G4Tubs use the same axes. The
target's global rotation turns it into the world. Face-local coordinates are centred on the
face, with z along ``n`` (z = 0 on the face). The rough layer sits on the face, outside the
volume: patch ``(i, j)`` is its surface with the base plane at face-local z = ``base_thickness``
and a slab of material below it down to the face, so the layer fills
0 <= z <= base_thickness + surface height. With ``into: true`` the face is moved inward by the
layer's thickness (the volume is cut by it), so the layer's top is where the face was.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np

from score4.errors import ConfigError
from score4.inputs import limits
from score4.inputs.config import BoxVolume, GdmlVolume, RoughFace, RunConfig, SurfaceFile
from score4.shapes import G4Box as G4BoxShape
from score4.shapes import PlacedShape, Shape, Transform, shape_from_dict
from score4.surface.block_cut import check_patch
from score4.surface.patchmap import PatchMap, make_patch_map
from score4.surface.spec import Surface, build_surface
from score4.surface.store import load_surface

from .gdml_model import GeometryModel, Instance
from .obb import OrientedBox

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


#: Rough faces supported, by solid type (the words of the error for the others).
SUPPORTED_FACES = (
    "the six faces (+x, -x, +y, -y, +z, -z) of a G4Box and the flat end faces (+z, -z) of a "
    "G4Tubs with a full circle"
)


@dataclass(frozen=True)
class FaceFrame:
    """A face: centre, rotation (columns u, v, n) and size (along u, along v), in the world."""

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

    def shifted(self, distance: float) -> FaceFrame:
        """The same frame moved by ``distance`` along its normal."""
        return FaceFrame(self.centre + distance * self.normal, self.rotation, self.size)


@dataclass(frozen=True, eq=False)
class TargetVolume:
    """One scored volume: a box of the configuration or one copy of a GDML volume.

    ``params`` are the solid's parameters in Geant4's conventions (G4Box: half-lengths ``x, y,
    z``; G4Tubs: ``rmin, rmax, dz, sphi, dphi``); ``rotation`` (columns: the volume's axes) and
    ``translation`` (its origin) are global. ``mother`` is the GDML instance the volume is
    placed in (None: the world volume).
    """

    column: str
    entry: int
    config: BoxVolume | GdmlVolume
    material: str
    solid: str
    params: dict
    rotation: np.ndarray
    translation: np.ndarray
    lo: np.ndarray  # bounding limits in the volume's frame
    hi: np.ndarray
    instance: Instance | None = None
    mother: Instance | None = None
    shape: Shape | None = None  # the solid as score4.shapes describes it (None: not described)
    exclude: tuple[Shape, ...] = ()  # in world coordinates: daughters, not this volume's material
    unknown_daughters: tuple[str, ...] = ()  # daughters whose solid score4.shapes cannot describe

    @property
    def name(self) -> str:
        return self.column

    @property
    def half(self) -> np.ndarray:
        """Half-lengths of a G4Box target."""
        return np.array([self.params["x"], self.params["y"], self.params["z"]], float)

    @property
    def size(self) -> tuple[float, float, float]:
        h = 2 * self.half
        return (float(h[0]), float(h[1]), float(h[2]))

    @property
    def position(self) -> tuple[float, float, float]:
        t = self.translation
        return (float(t[0]), float(t[1]), float(t[2]))

    def to_world(self, local: np.ndarray) -> np.ndarray:
        return self.translation + np.asarray(local, float) @ self.rotation.T

    def to_local(self, world: np.ndarray) -> np.ndarray:
        return (np.asarray(world, float) - self.translation) @ self.rotation

    def contains(self, points: np.ndarray) -> np.ndarray:
        """True for world points in the volume's own material: inside its solid (exact for
        G4Box, G4Tubs and every solid :mod:`score4.shapes` describes; the bounding box for
        others) and not strictly inside one of its daughters (:attr:`exclude`)."""
        points = np.asarray(points, float).reshape(-1, 3)
        local = self.to_local(points)
        if self.shape is not None and self.solid not in ("G4Box", "G4Tubs"):
            inside = np.asarray(self.shape.signed_distance(local) <= BOUNDARY_TOLERANCE)
        else:
            inside = solid_contains(self.solid, self.params, self.lo, self.hi, local)
        if self.unknown_daughters:
            raise ConfigError(
                f"{self.column}: holds {', '.join(self.unknown_daughters)}, of a solid type "
                "score4.shapes does not describe, so points in its own material cannot be told "
                "apart from points in that daughter"
            )
        for daughter in self.exclude:
            rows = np.flatnonzero(inside)
            if len(rows):
                inside[rows] = daughter.signed_distance(points[rows]) >= -BOUNDARY_TOLERANCE
        return inside


def solid_contains(
    solid: str, params: dict, lo: np.ndarray, hi: np.ndarray, q: np.ndarray
) -> np.ndarray:
    """Inside test in the solid's frame: exact for G4Box and G4Tubs, the bounding box otherwise."""
    q = np.asarray(q, float).reshape(-1, 3)
    tol = BOUNDARY_TOLERANCE
    if solid == "G4Box":
        half = np.array([params["x"], params["y"], params["z"]]) + tol
        return (np.abs(q) <= half).all(axis=1)
    if solid == "G4Tubs":
        r = np.hypot(q[:, 0], q[:, 1])
        inside = (r <= params["rmax"] + tol) & (r >= params["rmin"] - tol)
        inside &= np.abs(q[:, 2]) <= params["dz"] + tol
        if params["dphi"] < 2 * np.pi - 1e-12:
            phi = np.mod(np.arctan2(q[:, 1], q[:, 0]) - params["sphi"], 2 * np.pi)
            inside &= phi <= params["dphi"] + 1e-12
        return np.asarray(inside)
    return np.asarray(((q >= np.asarray(lo) - tol) & (q <= np.asarray(hi) + tol)).all(axis=1))


def face_frame(target: TargetVolume | BoxVolume, face: str) -> FaceFrame:
    """The right-handed frame of ``face`` ("+z", "-x", ...) of a G4Box or G4Tubs target, in the
    world (a G4Tubs end face: its bounding square)."""
    if isinstance(target, BoxVolume):
        target = box_target(target, 0)
    (a, sa), (b, sb) = _FACE_AXES[face]
    u, v = np.zeros(3), np.zeros(3)
    u[a], v[b] = sa, sb
    n = np.cross(u, v)
    axis = int(np.flatnonzero(n)[0])
    rotation = np.column_stack([u, v, n])
    centre = np.zeros(3)
    if target.solid == "G4Box":
        half = target.half
        centre[axis] = n[axis] * half[axis]
        size = (float(2 * half[a]), float(2 * half[b]))
    elif target.solid == "G4Tubs" and face in ("+z", "-z"):
        p = target.params
        if p["dphi"] < 2 * np.pi - 1e-9:
            raise ConfigError(
                f"{target.column}: face {face} of a G4Tubs cut to {np.degrees(p['dphi']):.4g} "
                f"degrees of phi; rough faces are {SUPPORTED_FACES}"
            )
        centre[2] = n[2] * p["dz"]
        size = (2 * float(p["rmax"]), 2 * float(p["rmax"]))
    else:
        what = (
            f"face {face} of a G4Tubs (its curved side)"
            if target.solid == "G4Tubs"
            else (f"a {target.solid}")
        )
        raise ConfigError(
            f"{target.column}: no rough face on {what}; rough faces are {SUPPORTED_FACES}"
        )
    return FaceFrame(target.to_world(centre), target.rotation @ rotation, size)


def box_target(box: BoxVolume, entry: int, mother: Instance | None = None) -> TargetVolume:
    """The :class:`TargetVolume` of a box of the configuration (in ``mother``'s frame if given)."""
    half = np.asarray(box.size, float) / 2
    rotation = np.eye(3) if mother is None else mother.rotation
    translation = np.asarray(box.position, float)
    if mother is not None:
        translation = mother.to_world(translation)
    params = {"x": float(half[0]), "y": float(half[1]), "z": float(half[2])}
    return TargetVolume(
        box.name,
        entry,
        box,
        box.material,
        "G4Box",
        params,
        rotation,
        translation,
        -half,
        half,
        None,
        mother,
    )


@dataclass
class RoughLayer:
    """A rough face: patch variants tiled over a face of a target.

    ``mask`` (``(ny, nx)``, None: all) marks the cells that hold a patch: on the round end face
    of a G4Tubs, the cells wholly inside the face; the others stay flat.
    """

    target: TargetVolume
    config: RoughFace
    frame: FaceFrame
    names: list[str]  # surface name of each variant
    variants: list[Surface]
    patch_map: PatchMap
    mask: np.ndarray | None = None
    face_area: float = 0.0  # the flat face's area, mm2

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

    @property
    def cell_variants(self) -> np.ndarray:
        """``(ny, nx)`` variant of each cell, -1 where the cell holds no patch (see ``mask``)."""
        v = self.patch_map.variants
        return v if self.mask is None else np.where(self.mask, v, -1)

    @property
    def rough_share(self) -> float:
        """Share of the face's flat area covered by patches."""
        px, py = self.patch_size
        n = self.patch_map.variants.size if self.mask is None else int(self.mask.sum())
        return float(n * px * py / self.face_area) if self.face_area > 0 else 1.0

    def solid_kind(self, k: int) -> str:
        """``tessellated``, ``multiunion``, ``frustums`` or ``blocks`` for variant ``k``.

        ``auto`` takes the multi-union for spike grids of equal heights (fastest to track and to
        build, bench_solids.py), ``frustums`` (the multi-union's nodes placed side by side, see
        :mod:`score4.geometry.frustums`) for spike grids with a height spread, and ``blocks``
        otherwise (the closed body cut into small
        tessellated blocks, :mod:`score4.geometry.block_solids`): one tessellated solid per patch
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
        from score4.source.sampling import SurfaceSampler, TiledSurfaceSampler

        px, py = self.patch_size
        shift = np.array([px / 2, py / 2, 0.0])  # the sampler's patches span [0, px] x [0, py]
        variants = [
            SurfaceSampler(vertices=s.top_mesh.vertices + shift, faces=s.top_mesh.faces)
            for s in self.variants
        ]
        lu, lv = self.frame.size
        origin = self.frame.to_world(np.array([-lu / 2, -lv / 2, self.base_thickness]))
        return TiledSurfaceSampler(
            variants, self.cell_variants.T, (px, py), origin, self.frame.rotation
        )

    def contains(self, points: np.ndarray) -> np.ndarray:
        """True for world points inside a patch body (on its boundary within the tolerance)."""
        q = self.frame.to_local(points)
        i, j = self.patch_map.cell_of(q[:, :2])
        inside = (i >= 0) & (q[:, 2] >= -BOUNDARY_TOLERANCE)
        rows = np.flatnonzero(inside)
        centres = self.cell_centres()
        variant = self.cell_variants[j[rows], i[rows]]
        inside[rows[variant < 0]] = False
        for k, surface in enumerate(self.variants):
            r = rows[variant == k]
            c = centres[j[r], i[r]]
            h = surface.height_at(q[r, 0] - c[:, 0], q[r, 1] - c[:, 1])
            inside[r] = q[r, 2] <= self.base_thickness + h + BOUNDARY_TOLERANCE
        return inside

    def in_cut(self, points: np.ndarray) -> np.ndarray:
        """With ``into``: True for world points in the slab cut from the target for the layer."""
        q = self.frame.to_local(points)
        lu, lv = self.frame.size
        return (
            (np.abs(q[:, 0]) <= lu / 2)
            & (np.abs(q[:, 1]) <= lv / 2)
            & (q[:, 2] > BOUNDARY_TOLERANCE)
            & (q[:, 2] <= self.thickness + BOUNDARY_TOLERANCE)
        )

    def envelope_box(self) -> OrientedBox:
        """The layer's envelope (face size x thickness) as an oriented box in the world."""
        lu, lv = self.frame.size
        t = self.thickness
        return OrientedBox(
            self.frame.to_world(np.array([0.0, 0.0, t / 2])),
            self.frame.rotation,
            np.array([lu / 2, lv / 2, t / 2]),
        )


@dataclass
class Scene:
    """The targets of a run with their rough layers (and the volume model of a GDML world).

    ``config`` is the run configuration the scene was built from (None for a scene of a live
    world built through :mod:`score4.api`).
    """

    config: RunConfig | None
    surfaces: dict[str, Surface]
    layers: list[RoughLayer] = field(default_factory=list)
    targets: list[TargetVolume] = field(default_factory=list)
    model: GeometryModel | None = None

    @property
    def columns(self) -> list[str]:
        """Scoring columns, one per target volume (copy), in ``events/edep`` order."""
        return [t.column for t in self.targets]

    def target(self, name: str) -> TargetVolume:
        """The target of column ``name`` (or of the single copy a configured name stands for)."""
        hits = self.targets_named(name, "volume")
        if len(hits) != 1:
            raise ConfigError(
                f"{name!r} stands for {len(hits)} volumes ({', '.join(t.column for t in hits)}); "
                "name one copy, e.g. " + f"{name}[0]"
            )
        return hits[0]

    def targets_named(self, ref: str, parameter: str) -> list[TargetVolume]:
        """The targets ``ref`` names: a column, a target's configured name, or (GDML) a volume
        name or ``name[k]`` whose instances are targets."""
        hits = [t for t in self.targets if t.column == ref]
        if hits:
            return hits
        hits = [t for t in self.targets if t.config.label == ref]
        if hits:
            return hits
        if self.model is not None:
            instances = {i.index for i in self.model.resolve(ref, parameter)}
            hits = [t for t in self.targets if t.instance and t.instance.index in instances]
            if hits:
                return hits
        raise ConfigError(
            f"{parameter}: {ref!r} is not a target; targets are: {', '.join(self.columns)}"
        )

    def layer(self, volume: str, face: str) -> RoughLayer | None:
        return next(
            (r for r in self.layers if r.target.name == volume and r.config.face == face), None
        )

    def layers_of(self, volume: str) -> list[RoughLayer]:
        return [r for r in self.layers if r.target.name == volume]

    def inside_target(self, volume: str, points: np.ndarray) -> np.ndarray:
        """True for points in the volume (less the slabs of ``into`` layers) or its rough layers."""
        points = np.asarray(points, float).reshape(-1, 3)
        inside = self.target(volume).contains(points)
        for layer in self.layers_of(volume):
            if layer.config.into:
                inside &= ~layer.in_cut(points)
        for layer in self.layers_of(volume):
            inside |= layer.contains(points)
        return inside

    def inside_material(self, material: str, points: np.ndarray) -> np.ndarray:
        """True for points in any target (with its rough layers) made of ``material``."""
        names = [t.name for t in self.targets if t.material == material]
        if not names:
            known = sorted({t.material for t in self.targets})
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
        boxes = [target_aabb(t) for t in self.targets] + [layer_aabb(r) for r in self.layers]
        return np.min([lo for lo, _ in boxes], axis=0), np.max([hi for _, hi in boxes], axis=0)

    @cached_property
    def world_half(self) -> np.ndarray:
        """Half-lengths of the world box, centred on the origin, that holds every target, rough
        layer and ``world.margin`` (where particles move; a portal adds subworlds beyond it)."""
        if self.config is None or self.config.world.gdml is not None:
            return np.full(3, np.inf)  # a GDML or user's world: its own extent (not read here)
        lo, hi = self.bounds
        return np.maximum(np.abs(lo), np.abs(hi)) + self.config.world.margin


def target_aabb(target: TargetVolume) -> tuple[np.ndarray, np.ndarray]:
    """Axis-aligned (lo, hi) of a target's bounding box in the world."""
    return target_obb(target).aabb()


def layer_aabb(layer: RoughLayer) -> tuple[np.ndarray, np.ndarray]:
    """Axis-aligned (lo, hi) of the layer's envelope: the face extruded by the layer thickness."""
    return layer.envelope_box().aabb()


def target_obb(target: TargetVolume) -> OrientedBox:
    """The target's bounding box as an oriented box in the world."""
    lo, hi = np.asarray(target.lo, float), np.asarray(target.hi, float)
    return OrientedBox(target.to_world((lo + hi) / 2), target.rotation, (hi - lo) / 2)


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


def resolve_targets(config: RunConfig, model: GeometryModel | None) -> list[TargetVolume]:
    """One :class:`TargetVolume` per configured box and per copy of each GDML target."""
    out: list[TargetVolume] = []
    for i, t in enumerate(config.targets):
        if isinstance(t, BoxVolume):
            mother = model.instances[0] if model is not None else None
            if t.mother is not None:
                assert model is not None  # the config refuses a mother without a GDML world
                hits = model.resolve(t.mother, f"targets.{i}.mother")
                if len(hits) != 1:
                    raise ConfigError(
                        f"targets.{i}.mother: {t.mother!r} has {len(hits)} copies; name one, "
                        f"e.g. {t.mother}[0]"
                    )
                mother = hits[0]
            out.append(box_target(t, i, mother))
            continue
        assert model is not None
        out += gdml_targets(model, t, i)
    out = _exclude_boxes_in_targets(out)
    claimed: dict[int, int] = {}
    for tv in out:
        if tv.instance is None:
            continue
        first = claimed.setdefault(tv.instance.index, tv.entry)
        if first != tv.entry:
            raise ConfigError(
                f"targets.{tv.entry}.volume: {tv.config.label!r} includes {tv.column!r}, already a "
                f"target through targets.{first}; score each volume once"
            )
    columns = [t.column for t in out]
    dupes = sorted({c for c in columns if columns.count(c) > 1})
    if dupes:
        raise ConfigError(
            f"targets: scoring columns must be unique, repeated: {', '.join(dupes)} (a copy of "
            "a GDML volume is column NAME_k)"
        )
    return out


def gdml_targets(model: GeometryModel, t: GdmlVolume, entry: int) -> list[TargetVolume]:
    """One :class:`TargetVolume` per instance (copy) the target's ``volume`` names
    (``targets.{entry}.volume`` in errors)."""
    instances = model.resolve(t.volume, f"targets.{entry}.volume")
    return [
        gdml_target(model, t, entry, inst, k if len(instances) > 1 else None)
        for k, inst in enumerate(instances)
    ]


def _exclude_boxes_in_targets(targets: list[TargetVolume]) -> list[TargetVolume]:
    """Boxes of the configuration placed in a GDML target are not that target's material."""
    boxes = [t for t in targets if t.instance is None and t.mother is not None]
    out = []
    for t in targets:
        inside = [
            PlacedShape(
                G4BoxShape(*b.half), Transform(rotation=b.rotation, translation=b.translation)
            )
            for b in boxes
            if t.instance is not None
            and b.mother is not None
            and b.mother.index == t.instance.index
        ]
        out.append(replace(t, exclude=t.exclude + tuple(inside)) if inside else t)
    return out


def daughter_shapes(
    model: GeometryModel, inst: Instance
) -> tuple[tuple[Shape, ...], tuple[str, ...]]:
    """The daughters of ``inst`` as shapes in world coordinates, and the labels of those whose
    solid :mod:`score4.shapes` does not describe."""
    known: list[Shape] = []
    unknown: list[str] = []
    for d in model.daughters(inst):
        data = model.logicals[d.logical].solid.get("shape")
        if data is None:
            unknown.append(f"{model.label(d)!r} ({model.logicals[d.logical].solid_type})")
            continue
        placed = Transform(rotation=d.rotation, translation=d.translation)
        known.append(PlacedShape(shape_from_dict(data), placed))
    return tuple(known), tuple(unknown)


def gdml_target(
    model: GeometryModel,
    t: GdmlVolume,
    entry: int,
    inst: Instance,
    k: int | None,
    where: str | None = None,
) -> TargetVolume:
    """The target of GDML volume entry ``t`` (``targets[entry]``) at placement ``inst``.

    ``k`` numbers the placement when the entry names several (its column is ``name_k``), else
    ``None``. ``where`` names the configuration key in errors (default ``targets.<entry>.volume``).
    Raises :class:`~score4.errors.ConfigError` for the world volume, a reflected placement or a
    volume inside a replica.
    """
    where = where or f"targets.{entry}.volume"
    if inst.index == 0:
        raise ConfigError(f"{where}: {t.volume!r} is the world volume; score a volume inside it")
    if inst.reflected:
        raise ConfigError(
            f"{where}: {model.label(inst)!r} is placed with a reflection (a G4ReflectedSolid on "
            "its placement chain); score4 refuses reflected volumes: place a mirrored solid "
            "without reflection"
        )
    if inst.replicated:
        raise ConfigError(
            f"{where}: {model.label(inst)!r} lies in a replica or parameterised volume; score4 "
            "takes volumes placed with G4PVPlacement only"
        )
    lv = model.logicals[inst.logical]
    column = t.volume if k is None else f"{t.volume.split('[')[0]}_{k}"
    if k is None and "[" in t.volume:
        column = f"{inst.name}_{inst.occurrence}"
    assert inst.mother is not None  # only the world has none
    mother = model.instances[inst.mother]
    data = lv.solid.get("shape")
    exclude, unknown = daughter_shapes(model, inst)
    return TargetVolume(
        column,
        entry,
        t,
        lv.material,
        lv.solid_type,
        dict(lv.solid.get("params", {})),
        inst.rotation,
        inst.translation,
        np.asarray(lv.solid["lo"], float),
        np.asarray(lv.solid["hi"], float),
        inst,
        mother,
        shape_from_dict(data) if data else None,
        exclude,
        unknown,
    )


def _tubs_mask(target: TargetVolume, patch_map: PatchMap) -> np.ndarray:
    """Cells wholly inside the annulus rmin <= r <= rmax of a G4Tubs end face."""
    px, py = patch_map.patch_size
    c = patch_map.cell_centres()
    x, y = np.abs(c[..., 0]), np.abs(c[..., 1])
    far = np.hypot(x + px / 2, y + py / 2)
    near = np.hypot(np.maximum(x - px / 2, 0.0), np.maximum(y - py / 2, 0.0))
    rmin, rmax = target.params["rmin"], target.params["rmax"]
    return (far <= rmax * (1 + 1e-12)) & (near >= rmin * (1 - 1e-12))


def make_layer(
    surfaces: dict[str, Surface],
    target: TargetVolume,
    j: int,
    rough: RoughFace,
    where: str | None = None,
) -> RoughLayer:
    """The rough layer of ``rough`` (entry ``j`` of the target's rough faces) on ``target``:
    variants from ``surfaces`` by name, face frame, patch map, cell mask of a round face, the
    frame moved inward for ``into``. Errors start with ``where`` (default
    ``targets.{entry}.rough.{j}``)."""
    where = where or f"targets.{target.entry}.rough.{j}"
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
    try:
        frame = face_frame(target, rough.face)
    except ConfigError as err:
        raise ConfigError(f"{where}: {err}") from None
    round_face = target.solid == "G4Tubs"
    if round_face:  # the whole cells of the bounding square, centred
        cells = [max(int(np.floor(frame.size[a] / size[a] * (1 + 1e-9))), 1) for a in (0, 1)]
        frame = FaceFrame(frame.centre, frame.rotation, (cells[0] * size[0], cells[1] * size[1]))
    if rough.tiling == "portal" and target.instance is not None:
        raise ConfigError(
            f"{where}: tiling portal works on boxes of the configuration in a generated world; "
            "a GDML volume takes tiling: native (the default)"
        )
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
    mask, area = None, frame.size[0] * frame.size[1]
    if round_face:
        mask = _tubs_mask(target, patch_map)
        p = target.params
        area = float(np.pi * (p["rmax"] ** 2 - p["rmin"] ** 2))
        if not mask.any():
            raise ConfigError(
                f"{where}: no whole patch of {size[0] * 1e3:g} x {size[1] * 1e3:g} um fits on "
                f"face {rough.face} of {target.name!r}"
            )
        if rough.native_layout == "replicas":
            raise ConfigError(
                f"{where}: native_layout replicas fills a rectangle; a round face takes auto, "
                "nested or placements"
            )
    layer = RoughLayer(target, rough, frame, names, variants, patch_map, mask, area)
    for k, n in enumerate(names):
        try:
            check_patch(variants[k], layer.solid_kind(k), rough.block_cells)
        except ConfigError as err:
            raise ConfigError(f"{where} (surface {n!r}): {err}") from None
    if rough.into:
        extent = (
            2 * target.half[int(np.argmax(np.abs(target.rotation.T @ frame.normal)))]
            if target.solid == "G4Box"
            else 2 * target.params["dz"]
        )
        if layer.thickness >= extent:
            raise ConfigError(
                f"{where}: into: the layer ({layer.thickness * 1e3:.4g} um) is not thinner than "
                f"{target.name!r} ({extent * 1e3:.4g} um along the face normal)"
            )
        layer.frame = frame.shifted(-layer.thickness)
    return layer


def build_scene(config: RunConfig, model: GeometryModel | None = None) -> Scene:
    """Build every surface the targets use and the patch map of every rough face.

    A GDML world's volume model is read (and cached) here unless given.
    """
    if model is None and config.world.gdml is not None:
        from .gdml_files import load_geometry_model

        model = load_geometry_model(config.world.gdml)
    used = {v.surface for t in config.targets for r in t.rough for v in r.variant_list}
    surfaces = {
        name: _load(name, config.surfaces[name]) for name in config.surfaces if name in used
    }
    targets = resolve_targets(config, model)
    scene = Scene(config, surfaces, targets=targets, model=model)
    for target in targets:
        for j, rough in enumerate(target.config.rough):
            scene.layers.append(make_layer(surfaces, target, j, rough))
    from .clearance import check_clearance

    check_clearance(scene)
    far = float(np.max(scene.world_half))
    if np.isfinite(far) and far > limits.MAX_WORLD_EXTENT:
        raise ConfigError(
            f"targets: the world reaches {far / 1e3:.4g} m from the origin (targets, rough layers "
            "and world.margin); score4's limit is 1 km (move the targets towards the origin)"
        )
    return scene
