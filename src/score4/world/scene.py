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

import copy
from collections.abc import Collection, Sequence
from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from score4.errors import ConfigError
from score4.files import cache_dir
from score4.shapes import G4Box as G4BoxShape
from score4.shapes import G4GenericPolycone, PlacedShape, Shape, Transform, shape_from_dict
from score4.shapes import G4Orb as G4OrbShape
from score4.shapes import G4Sphere as G4SphereShape
from score4.shapes.boolean import BooleanShape, FaceClip
from score4.shapes.faces import AnnulusFace, Face, PlaneFace, RevolvedFace, SphereFace
from score4.shapes.hpge import HPGE_GROUPS, hpge_groups, is_hpge_metadata
from score4.shapes.revolved import RevolvedShape
from score4.surface.block_cut import check_patch
from score4.surface.patchmap import PatchMap, make_patch_map
from score4.surface.rough import Surface
from score4.surface.triangle_mesh import TriangleMesh

from .curved import (
    BentVariant,
    Footprints,
    RingLayout,
    check_radius,
    cone_cell,
    cone_ring_span,
    flat_body,
    gap_limit,
    measure_floor,
    solid_body,
    top_sagitta,
)
from .facets import (
    boundary_edges,
    ccw,
    cells_inside,
    check_one_plane,
    clip_to_convex,
    face_triangles,
    is_convex,
    plane_face,
    point_in_triangles,
    prism_mesh,
    section,
    solid_triangles,
)
from .gdml_model import GeometryModel, Instance
from .obb import OrientedBox

if TYPE_CHECKING:  # the configuration's models: a worker reads records of them (common.records)
    from score4.inputs.config import BoxVolume, GdmlVolume, RoughFace, RunConfig

#: Points this close (mm) outside a volume's boundary still count as inside (vertices at depth 0
#: lie exactly on the surface).
BOUNDARY_TOLERANCE = 1e-9

#: Folder of score4's cache (:func:`score4.files.cache_dir`) where boolean solids' area
#: estimates are kept (:attr:`score4.shapes.BooleanShape.area_key`).
BOOLEAN_AREAS = "boolean-areas"

#: Gap between the tips of the highest patch and the top of the layer's envelope, mm (1 nm).
ENVELOPE_CLEARANCE = 1e-6

#: ``solid: auto`` takes the multi-union for a spike grid of equal heights up to this many
#: spikes, frustums above (see :meth:`RoughLayer.solid_kind`).
AUTO_MULTIUNION_MAX_SPIKES = 100_000


#: Rough faces supported, by solid type (the words of the error for the others).
SUPPORTED_FACES = (
    "the flat faces of any solid (a G4Box's six, the end faces of a G4Tubs, a facet group that "
    "lies in one plane) and the curved faces swept around z of G4Tubs, G4Cons and polycones"
)


@dataclass(frozen=True)
class FaceFrame:
    """A face: centre, rotation (columns u, v, n) and size (along u, along v), in the world."""

    centre: np.ndarray
    rotation: np.ndarray
    size: tuple[float, float]

    @cached_property
    def transform(self) -> Transform:
        """Face-local coordinates (u, v, n) -> world."""
        return Transform(self.rotation, self.centre)

    @property
    def normal(self) -> np.ndarray:
        return self.rotation[:, 2]

    def to_world(self, local: np.ndarray) -> np.ndarray:
        return self.transform.apply(local)

    def to_local(self, world: np.ndarray) -> np.ndarray:
        return self.transform.inverse_apply(world)

    def shifted(self, distance: float) -> FaceFrame:
        """The same frame moved by ``distance`` along its normal."""
        return FaceFrame(self.centre + distance * self.normal, self.rotation, self.size)


@dataclass(frozen=True, eq=False)
class TargetVolume:
    """One scored volume: a box of the configuration or one copy of a GDML volume.

    ``shape`` is its solid as :mod:`score4.shapes` describes it, in the solid's own frame (None
    only for a GDML solid of a type score4.shapes does not describe: then ``lo``/``hi``, the
    solid's bounding limits, stand for it); ``solid`` is the solid's type name (for messages);
    ``transform`` takes the solid's frame to the world (rotation columns: the volume's axes,
    translation: its origin). ``mother`` is the GDML instance the volume is placed in (None:
    the world volume).
    """

    column: str
    entry: int
    config: BoxVolume | GdmlVolume
    material: str
    solid: str
    shape: Shape | None
    transform: Transform
    lo: np.ndarray  # bounding limits in the volume's frame
    hi: np.ndarray
    instance: Instance | None = None
    mother: Instance | None = None
    exclude: tuple[Shape, ...] = ()  # in world coordinates: daughters, not this volume's material
    unknown_daughters: tuple[str, ...] = ()  # daughters whose solid score4.shapes cannot describe

    @property
    def name(self) -> str:
        return self.column

    @property
    def rotation(self) -> np.ndarray:
        return self.transform.rotation

    @property
    def translation(self) -> np.ndarray:
        return self.transform.translation

    @property
    def position(self) -> tuple[float, float, float]:
        t = self.translation
        return (float(t[0]), float(t[1]), float(t[2]))

    def to_world(self, local: np.ndarray) -> np.ndarray:
        return self.transform.apply(local)

    def to_local(self, world: np.ndarray) -> np.ndarray:
        return self.transform.inverse_apply(world)

    def described(self, what: str) -> Shape:
        """The target's shape; ConfigError (``what`` needs it) for a solid score4.shapes does
        not describe."""
        if self.shape is None:
            raise ConfigError(
                f"{what}: {self.name!r} is a {self.solid}, which score4.shapes does not "
                f"describe; {what} needs a solid it can describe"
            )
        return self.shape

    def face(self, name: str) -> Face:
        """The geometry of face ``name`` of the target's shape (its own frame)."""
        return self.described("face").face(name)

    def contains(self, points: np.ndarray) -> np.ndarray:
        """True for world points in the volume's own material: inside its solid (exact for
        every solid :mod:`score4.shapes` describes; the bounding box for others) and not
        strictly inside one of its daughters (:attr:`exclude`)."""
        points = np.asarray(points, float).reshape(-1, 3)
        local = self.to_local(points)
        inside = shape_contains(self.shape, self.lo, self.hi, local)
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


def shape_contains(
    shape: Shape | None, lo: np.ndarray, hi: np.ndarray, q: np.ndarray, touching: bool = True
) -> np.ndarray:
    """Inside test in the solid's frame (points within the tolerance of the surface count,
    unless ``touching`` is False): exact for a shape, the bounding limits (lo, hi) without."""
    q = np.asarray(q, float).reshape(-1, 3)
    tol = BOUNDARY_TOLERANCE
    if shape is not None:
        d = shape.signed_distance(q)
        return np.asarray(d <= tol if touching else d < -tol)
    return np.asarray(((q >= np.asarray(lo) - tol) & (q <= np.asarray(hi) + tol)).all(axis=1))


def target_face(target: TargetVolume, face: str) -> Face:
    """Face ``face`` of a target's shape; ConfigError naming the faces and groups it has."""
    try:
        return target.face(face)
    except ConfigError as err:
        text = str(err).removeprefix("face: ")
        if f"has no face {face!r}" in text:
            text = f"no face {face!r} on a {target.solid}; " + text.split("; ", 1)[1]
        raise ConfigError(f"{target.column}: {text}") from None


def face_frame(target: TargetVolume | BoxVolume, face: str) -> FaceFrame:
    """The right-handed frame of a flat ``face`` of a target, in the world: a box face
    ("+z", "-x", ...) with the axes of :data:`score4.shapes.csg.BOX_FACE_AXES`, a ring (the end
    face of a tube) in its bounding square."""
    if not isinstance(target, TargetVolume):  # a box of the configuration
        target = box_target(target, 0)
    geometry = target_face(target, face)
    if not isinstance(geometry, PlaneFace):
        raise ConfigError(
            f"{target.column}: no rough face on face {face} of a {target.solid} (curved); rough "
            f"faces are {SUPPORTED_FACES}"
        )
    if not geometry.rectangle and not (isinstance(geometry, AnnulusFace) and geometry.full_circle):
        cut = (
            f" cut to {np.degrees(geometry.dphi):.4g} degrees of phi"
            if isinstance(geometry, AnnulusFace)
            else ""
        )
        raise ConfigError(
            f"{target.column}: face {face} of a {target.solid}{cut}; rough faces are "
            f"{SUPPORTED_FACES}"
        )
    placed = target.transform @ geometry.frame
    return FaceFrame(placed.translation, placed.rotation, geometry.size)


def box_target(box: BoxVolume, entry: int, mother: Instance | None = None) -> TargetVolume:
    """The :class:`TargetVolume` of a box of the configuration (in ``mother``'s frame if given)."""
    half = np.asarray(box.size, float) / 2
    rotation = np.eye(3) if mother is None else mother.rotation
    translation = np.asarray(box.position, float)
    if mother is not None:
        translation = mother.to_world(translation)
    return TargetVolume(
        box.name,
        entry,
        box,
        box.material,
        "G4Box",
        G4BoxShape(float(half[0]), float(half[1]), float(half[2])),
        Transform(rotation, translation),
        -half,
        half,
        None,
        mother,
    )


class EnvelopePiece(NamedTuple):
    """A piece of the envelope of a curved layer whose face a boolean's other parts cut
    (:attr:`CurvedRoughLayer.pieces`): azimuths ``phi0`` .. ``phi0 + dphi`` and the face's
    generator from ``v0`` to ``v1``. Its ends are the z planes through the face at ``v0`` and
    ``v1`` (a ``G4Cons`` or ``G4Tubs`` segment), or with ``normal_ends`` the cones of the face's
    normals there (on a cone: the rings' band cones, which the rings' cells share; a
    ``G4GenericPolycone`` of the four corners), so that rings side by side can hold different
    azimuths (:func:`score4.world.boolean_layers.envelope_pieces`)."""

    phi0: float
    dphi: float
    v0: float
    v1: float
    normal_ends: bool = False


@dataclass(frozen=True, eq=False)
class BooleanFace:
    """Where a rough layer's face lies on a boolean solid: ``shape`` (the target's solid),
    ``face`` (its face name), ``clip`` (the leaf face and the solids cutting it) and
    ``transform`` (the boolean's frame to the world)."""

    shape: Shape
    face: str
    clip: FaceClip
    transform: Transform

    def on_surface(self, world: np.ndarray) -> np.ndarray:
        """True for world points of the leaf face that lie on the boolean's surface."""
        return np.asarray(self.clip.margin(self.transform.inverse_apply(world)) > 0)


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
    curved = False  # patches bent onto a face swept around z (CurvedRoughLayer)
    #: on a face of a boolean solid: the boolean and where its face lies (``target`` is then the
    #: volume seen as the leaf solid that face belongs to, :mod:`score4.world.boolean_layers`)
    on_boolean: BooleanFace | None = field(default=None, kw_only=True)
    #: with ``into`` on a tube's end face and wall: the radii of the end face's cut ring, where
    #: its cells and flat rest lie (None: the face's own)
    rest_radii: tuple[float, float] | None = field(default=None, kw_only=True)
    #: the envelope is the prism of the cells that hold a patch, not the face's (a face of a
    #: union partly covered by its other part: :mod:`score4.world.boolean_layers`)
    cells_envelope: bool = field(default=False, kw_only=True)

    @property
    def name(self) -> str:
        face = self.config.face_name
        return (
            f"{self.target.name}_rough{face}".replace("+", "p").replace("-", "m").replace(".", "_")
        )

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

        ``auto`` takes the multi-union for spike grids of equal single-layer spikes (pyramids;
        fast to track and to build, bench_solids.py), ``frustums`` (the multi-union's nodes
        placed side by side, see :mod:`score4.geometry.frustums`) for spike grids with a height
        spread or of several layers (bumps and peaks: 50 x 50 bumps of 4 layers cost 0.87x the
        pyramid multi-union's instructions per alpha event as frustums, 1.50x as a multi-union,
        benchmarks/bench_instructions.py), and ``blocks``
        otherwise (the closed body cut into small
        tessellated blocks, :mod:`score4.geometry.block_solids`): one tessellated solid per patch
        tracked alphas 10-40x slower (benchmarks/bench_surfaces.py), and a multi-union with a
        height spread explodes in voxelisation (50 x 50 pyramids with a 3 um spread: 42 s and
        1.7 GB, against 0.6 s and 10 MB tessellated). A grid of more than
        :data:`AUTO_MULTIUNION_MAX_SPIKES` spikes also gets ``frustums``: a multi-union's
        voxelisation grows ~N^2 (10^5 spikes ~7 s; 10^6 did not finish in 10 min), frustums
        build 1000 x 1000 pyramids in ~12 s (benchmarks/bench_build.py).
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
            small = grid.nx * grid.ny <= AUTO_MULTIUNION_MAX_SPIKES
            single = grid.height_sigma == 0 and grid.n_layers == 1
            return "multiunion" if single and small else "frustums"
        return choice

    def cell_centres(self) -> np.ndarray:
        """(ny, nx, 2) face-local centres of the cells."""
        return self.patch_map.cell_centres()

    def contains(self, points: np.ndarray) -> np.ndarray:
        """True for world points inside a patch body (on its boundary within the tolerance)."""
        q = self.frame.to_local(points)
        i, j = self.patch_map.cell_of(q[:, :2])
        inside = (i >= 0) & (q[:, 2] >= -BOUNDARY_TOLERANCE)
        rows = np.flatnonzero(inside)
        cx, cy = self.patch_map.cell_centre_axes()
        variant = self.cell_variants[j[rows], i[rows]]
        inside[rows[variant < 0]] = False
        for k, surface in enumerate(self.variants):
            r = rows[variant == k]
            h = surface.height_at(q[r, 0] - cx[i[r]], q[r, 1] - cy[j[r]])
            inside[r] = q[r, 2] <= self.base_thickness + h + BOUNDARY_TOLERANCE
        return inside

    def cut_from_boolean(self, points: np.ndarray) -> np.ndarray:
        """With ``into`` on a boolean's face: True for world points outside the boolean cut for
        this layer alone (``on_boolean``; in the uncut target these are the points the cut
        took: a constituent's other parts and faces stay whole, so a point in the disk under a
        post whose wall is cut is not one)."""
        on = self.on_boolean
        assert on is not None
        local = on.transform.inverse_apply(np.asarray(points, float).reshape(-1, 3))
        return np.asarray(on.shape.signed_distance(local) > BOUNDARY_TOLERANCE)

    def in_cut(self, points: np.ndarray) -> np.ndarray:
        """With ``into``: True for world points in the slab cut from the target for the layer
        (on a boolean's face: outside the boolean cut for this layer, :meth:`cut_from_boolean`)."""
        if self.on_boolean is not None:
            return self.cut_from_boolean(points)
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

    def cell_edges(self) -> tuple[np.ndarray, np.ndarray]:
        """``(x, y)``: the ``(nx + 1,)`` and ``(ny + 1,)`` cell edges in the layer's frame (cell
        ``(i, j)`` spans ``x[i]..x[i + 1]``, ``y[j]..y[j + 1]``)."""
        pm = self.patch_map
        (px, py), (lx, ly) = pm.patch_size, pm.face_size
        return -lx / 2 + np.arange(pm.nx + 1) * px, -ly / 2 + np.arange(pm.ny + 1) * py

    def cells_outline(self) -> np.ndarray:
        """The cells holding a patch as 2D triangles (two per cell, counter-clockwise) in the
        layer's frame, on the grid's edges (neighbours share their corners exactly)."""
        x, y = self.cell_edges()
        j, i = np.nonzero(self.cell_variants >= 0)
        a = np.stack([x[i], y[j]], -1)
        b = np.stack([x[i + 1], y[j]], -1)
        c = np.stack([x[i + 1], y[j + 1]], -1)
        d = np.stack([x[i], y[j + 1]], -1)
        return np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])

    def envelope_prism(self) -> TriangleMesh | None:
        """The envelope as a closed mesh (frame-local, z from -thickness/2 to +thickness/2 about
        the envelope's centre) where it is not a box or a ring: the prism of the kept cells
        (``cells_envelope``) or of a polygon face; None for a box or a ring."""
        if self.cells_envelope:
            return prism_mesh(self.cells_outline(), self.thickness)
        return None

    def in_envelope(self, points: np.ndarray) -> np.ndarray:
        """True for world points strictly inside the envelope (touching does not count)."""
        q = self.frame.to_local(np.asarray(points, float).reshape(-1, 3))
        if not self.cells_envelope:
            return self.envelope_box().contains(points)
        tol = BOUNDARY_TOLERANCE
        inside = (q[:, 2] > tol) & (q[:, 2] < self.thickness - tol)
        kept = self.cell_variants >= 0
        for sx in (-tol, tol):  # strictly inside the union of the kept cells' rectangles
            for sy in (-tol, tol):
                i, j = self.patch_map.cell_of(q[:, :2] + np.array([sx, sy]))
                ok = i >= 0
                ok[ok] = kept[j[ok], i[ok]]
                inside &= ok
        return inside

    def envelope_points(self, n: int = 25) -> np.ndarray:
        """World points of the envelope for the clearance checks: the box's grid, or with
        ``cells_envelope`` a 5 x 5 grid over each kept cell (its edges included) at the
        bottom, near it, in the middle, near the top and at the top."""
        if not self.cells_envelope:
            return self.envelope_box().grid(n)
        x, y = self.cell_edges()
        j, i = np.nonzero(self.cell_variants >= 0)
        s = np.linspace(0.0, 1.0, 5)
        u = x[i][:, None] + s[None] * (x[i + 1] - x[i])[:, None]
        v = y[j][:, None] + s[None] * (y[j + 1] - y[j])[:, None]
        uu = np.repeat(u, 5, axis=1).ravel()
        vv = np.tile(v, (1, 5)).ravel()
        h = np.array([0.0, 0.05, 0.5, 0.95, 1.0]) * self.thickness
        local = np.column_stack([np.repeat(uu, len(h)), np.repeat(vv, len(h)), np.tile(h, len(uu))])
        return self.frame.to_world(local)


@dataclass
class CurvedRoughLayer(RoughLayer):
    """A rough layer on a face swept around z (:mod:`score4.world.curved`): patches bent onto the
    surface in rings. ``frame`` is the face's frame at its middle (messages, bounds);
    ``patch_map`` is the grid (rows = rings, columns = cells of the longest ring) and ``mask``
    the cells each ring holds."""

    curved = True
    layout: RingLayout | None = None
    lift: float = 0.0  # the patches' base above the true surface (convex faces), mm
    gap: float = 0.0  # largest distance of the base from the true surface, mm
    top_margin: float = 0.0  # sagitta of the bent tops' facets (concave faces), mm
    #: with ``into`` on a wall swept around z: the target's shape cut for this layer alone and
    #: its centre's shift in the target's frame (:meth:`Shape.trimmed`)
    cut_shape: tuple[Shape, np.ndarray] | None = None
    #: with ``into``: how far the solid is cut behind the face along its normal (mm; the
    #: radius of a sphere moves by it)
    into_cut: float = 0.0
    #: on a face of a boolean partly covered or cut by its other parts: the envelope's pieces
    #: (:class:`EnvelopePiece`: azimuth range and generator range of the face; on a sphere the
    #: meridian's arc length) holding the kept cells, each a G4Cons (G4Tubs) segment, a
    #: G4GenericPolycone between band cones on a cone (``normal_ends``), on a sphere a G4Sphere
    #: segment; None: the face's whole shell
    #: (:func:`score4.world.boolean_layers.envelope_pieces`)
    pieces: list[EnvelopePiece] | None = None
    #: the envelope (a piece of it, :meth:`envelope_views`) ends on the cones of the face's
    #: normals through its ends, not on their z planes (:attr:`EnvelopePiece.normal_ends`)
    normal_ends: bool = False

    def envelope_views(self) -> list[CurvedRoughLayer]:
        """The layer's envelope as layers on sub-faces (one per piece, :attr:`pieces`; the layer
        itself when its envelope is the face's whole shell), for the clearance checks and the
        Geant4 envelopes: each view's face is the face cut to the piece's azimuth and generator
        ranges, so its shell (:meth:`shell_points`, :func:`wall_envelope`) is the piece's
        (with :attr:`EnvelopePiece.normal_ends`, the shell between the cones of normals through
        its ends: :attr:`normal_ends`)."""
        if self.pieces is None:
            return [self]
        face = self.ring_layout.face
        out = []
        for phi0, dphi, v0, v1, normal_ends in self.pieces:
            sub: RevolvedFace | SphereFace
            if isinstance(face, SphereFace):  # a G4Sphere segment: the polar angles of v0, v1
                a, b = sorted(float(x) for x in face.polar(np.array([v0, v1])))
                sub = replace(face, theta=(a, b), phi0=phi0, dphi=dphi)
            else:
                (r1, z1), (r2, z2) = face.point(0.0, np.array([v0, v1]))[:, [0, 2]]
                sub = replace(face, rz1=(float(r1), float(z1)), rz2=(float(r2), float(z2)),
                              phi0=phi0, dphi=dphi)  # fmt: skip
            view = copy.copy(self)
            view.__dict__.pop("_cache", None)
            view.layout = replace(self.ring_layout, face=sub)
            view.pieces = None
            view.normal_ends = normal_ends
            out.append(view)
        return out

    def piece_of(self, j: int, phi: float) -> int:
        """The piece (index into :meth:`envelope_views`) holding the cell of ring ``j`` at
        azimuth ``phi``."""
        if self.pieces is None:
            return 0
        v = float(self.ring_layout.v[j])
        for n, (phi0, dphi, v0, v1, _) in enumerate(self.pieces):
            a = np.mod(phi - phi0, 2 * np.pi)
            if a <= dphi + 1e-9 and v0 - 1e-9 <= v <= v1 + 1e-9:
                return n
        raise AssertionError(f"{self.name}: cell at ring {j}, phi {phi} in no envelope piece")

    def solid_kind(self, k: int) -> str:
        """``frustums`` for a spike grid on a cylinder, a cone or a sphere (``solid: auto`` or
        ``frustums``): on a cylinder each bent spike layer and each column of the bent slab is
        exactly a G4Trd, on a cone a G4Trap or G4GenericTrap in a cell of two G4Cons, on a
        sphere the same in a cell that is a G4Sphere segment, with the slab cut per spike
        (:mod:`score4.geometry.curved`); ``tessellated`` (the bent closed body as one solid)
        otherwise (also on a cone too close to a cylinder for its cells:
        :attr:`frustum_cells`)."""
        spikes = self.variants[k].spikes is not None
        return (
            "frustums"
            if spikes and self.config.solid != "tessellated" and self.frustum_cells
            else "tessellated"
        )

    @cached_property
    def frustum_cells(self) -> bool:
        """Bent frustums can be placed: on a cylinder always; on a cone where the cones of
        surface normals bounding each ring's cells (:func:`~score4.world.curved.cone_cell`)
        stay off the axis over the cell's z range (not on a cone within about
        ``patch length / radius`` of a cylinder); on a sphere always (the cells are G4Sphere
        segments, :func:`~score4.world.curved.sphere_cell`)."""
        face = self.ring_layout.face
        if isinstance(face, SphereFace):
            return True
        if self.is_cylinder:
            return True
        lay = self.ring_layout
        for j in np.flatnonzero(lay.count > 0):
            a, b, _ = cone_cell(lay, int(j), self.thickness)
            if min(a[:4]) < 0 or min(b[:4]) <= 1e-3 * float(lay.radius[j]):
                return False
        return True

    @property
    def is_cylinder(self) -> bool:
        """A face parallel to the axis (a cylinder wall or bore), not a cone or a sphere."""
        face = self.ring_layout.face
        return not isinstance(face, SphereFace) and abs(float(face.nrz[1])) <= 1e-12

    @property
    def rough_share(self) -> float:
        """Share of the face's area covered by patch cells (on a sphere: the exact areas of the
        cells' bands, which differ from px x py)."""
        lay = self.ring_layout
        face = lay.face
        if not isinstance(face, SphereFace):
            return super().rough_share
        py = self.patch_size[1]
        held = (self.cell_variants >= 0).sum(axis=1)  # all count cells but on a boolean
        covered = sum(
            face.band_area(lay.v[j] - py / 2, lay.v[j] + py / 2, float(held[j] * lay.step[j]))
            for j in range(len(lay.v))
        )
        return float(covered / self.face_area)

    @property
    def ring_layout(self) -> RingLayout:
        assert self.layout is not None
        return self.layout

    @property
    def thickness(self) -> float:
        return super().thickness + self.lift + self.top_margin

    def _flat(self, k: int) -> tuple[np.ndarray, np.ndarray, int]:
        key = ("flat", k)
        if key not in self._cache:
            sphere = isinstance(self.ring_layout.face, SphereFace)
            self._cache[key] = flat_body(self.variants[k], self.base_thickness, sphere)
        return self._cache[key]

    @cached_property
    def _cache(self) -> dict:
        return {}

    def ring_solid_key(self, j: int) -> float:
        """Rings of equal radius and slope share their bent solids (all rings of a cylinder);
        on a sphere every ring has its own (the key is its position along the meridian)."""
        return float(self._ring_solid_keys[j])

    @cached_property
    def _ring_solid_keys(self) -> np.ndarray:
        lay = self.ring_layout
        if isinstance(lay.face, SphereFace):
            return np.round(lay.v, 12) + 1e6  # apart from any radius
        return np.round(lay.radius, 12)

    def _solid(self, k: int) -> tuple[np.ndarray, np.ndarray, int]:
        """Variant ``k``'s flat body as Geant4 gets it (:func:`~score4.world.curved.solid_body`:
        the floor strip in a grid's rectangles, on a sphere the floor as it is; no facet whose
        ``Intersect`` tolerance reaches far beyond an edge). Its surface is :meth:`_flat`'s,
        which the floor's heights (``lift``) and :meth:`contains` are measured on."""
        key = ("solid", k)
        if key not in self._cache:
            sphere = isinstance(self.ring_layout.face, SphereFace)
            variant = self.variants[k]
            self._cache[key] = solid_body(self._flat(k), variant, self.base_thickness, not sphere)
        return self._cache[key]

    def bent(self, k: int, j: int) -> BentVariant:
        """Variant ``k`` bent onto ring ``j`` (cached per ring radius): the body Geant4 gets."""
        key = ("bent", k, self.ring_solid_key(j))
        if key not in self._cache:
            v, faces, n_top = self._solid(k)
            bent = self.ring_layout.bend(v, j, self.base_thickness + self.lift)
            self._cache[key] = BentVariant(bent, faces, n_top)
        return self._cache[key]

    def footprints(self, k: int) -> Footprints:
        """Variant ``k``'s flat body binned for :meth:`contains` on every ring."""
        key = ("footprints", k)
        if key not in self._cache:
            v, faces, _ = self._flat(k)
            radius = self.ring_layout.min_radius - self.thickness  # a concave face's bodies
            self._cache[key] = Footprints.make(v, faces, max(radius, 1e-3 * self.thickness))
        return self._cache[key]

    def top_area(self, k: int, j: int) -> float:
        """Area (mm2) of variant ``k``'s bent top on ring ``j`` (cached per ring solid)."""
        key = ("top_area", k, self.ring_solid_key(j))
        if key not in self._cache:
            tri = self.bent(k, j).top_triangles
            e = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
            self._cache[key] = float((0.5 * np.linalg.norm(e, axis=1)).sum())
        return self._cache[key]

    def cells(self) -> list[tuple[int, int, int, float]]:
        """(ring j, cell i, variant k, azimuth) of every patch."""
        out = []
        grid = self.cell_variants
        for j in range(len(self.ring_layout.v)):
            for i, phi in enumerate(self.ring_layout.cell_phi(j)):
                if grid[j, i] >= 0:  # a cell off a boolean's surface holds none
                    out.append((j, i, int(grid[j, i]), float(phi)))
        return out

    def contains(self, points: np.ndarray) -> np.ndarray:
        """True for world points inside a patch body or on it (within the boundary tolerance):
        the bent bodies Geant4 gets, by the parity of a ray along the surface normal."""
        q = self.target.to_local(np.asarray(points, float).reshape(-1, 3))
        lay = self.ring_layout
        j, i, local = lay.locate(q)
        inside = np.zeros(len(q), dtype=bool)
        rows = np.flatnonzero((j >= 0) & (local[:, 2] >= -BOUNDARY_TOLERANCE))
        rows = rows[local[rows, 2] <= self.thickness]
        if not len(rows):
            return inside
        variant = self.cell_variants[j[rows], i[rows]]
        offset = self.base_thickness + self.lift
        for k in np.unique(variant[variant >= 0]):
            sel = rows[variant == k]
            inside[sel] = self.footprints(int(k)).contains(
                lay, q[sel], j[sel], i[sel], local[sel], offset, BOUNDARY_TOLERANCE
            )
        return inside

    def in_cut(self, points: np.ndarray) -> np.ndarray:
        """With ``into``: True for world points in the shell cut from the solid, between the
        layer's face and the solid's face (on a wall of a G4Tubs, G4Cons or polycone: outside
        the solid cut for this layer, :attr:`cut_shape`)."""
        if not self.config.into:
            return np.zeros(len(points), dtype=bool)
        if self.on_boolean is not None:
            return self.cut_from_boolean(points)
        if self.cut_shape is not None:  # a wall: outside the solid cut for this layer alone
            shape, shift = self.cut_shape
            local = self.target.to_local(np.asarray(points, float).reshape(-1, 3)) - shift
            return np.asarray(shape.signed_distance(local) > BOUNDARY_TOLERANCE)
        face = self.ring_layout.face
        h = face.locate(self.target.to_local(np.asarray(points, float).reshape(-1, 3)))[2]
        return np.asarray((h > BOUNDARY_TOLERANCE) & (h <= self.thickness + BOUNDARY_TOLERANCE))

    def shell_points(self, n_phi: int = 72, n_v: int = 9, n_h: int = 3) -> np.ndarray:
        """World points on and in the layer's shell (the face extruded by the thickness along
        its normal; on a cone, the envelope Geant4 gets: the same between the z planes of the
        face's ends, :func:`wall_envelope`), for the clearance checks (of each piece of the
        envelope, :attr:`pieces`)."""
        if self.pieces is not None:
            return np.concatenate([v.shell_points(n_phi, n_v, n_h) for v in self.envelope_views()])
        face = self.ring_layout.face
        if self._cone_envelope:
            a1, b1, a2, b2, dz, zc = wall_envelope(self)
            (u0, u1), _ = face.extent
            u, f, g = (
                x.ravel()
                for x in np.meshgrid(
                    np.linspace(u0, u1, n_phi),
                    np.linspace(0.0, 1.0, n_v),
                    np.linspace(0.0, 1.0, n_h),
                    indexing="ij",
                )
            )
            lo, hi = a1 + f * (a2 - a1), b1 + f * (b2 - b1)
            r = lo + g * (hi - lo)
            local = np.column_stack([r * np.cos(u), r * np.sin(u), zc - dz + 2 * dz * f])
            return self.target.to_world(local)
        (u0, u1), (v0, v1) = face.extent
        grid = np.meshgrid(
            np.linspace(u0, u1, n_phi),
            np.linspace(v0, v1, n_v),
            np.linspace(0.0, self.thickness, n_h),
            indexing="ij",
        )
        u, v, h = (g.ravel() for g in grid)
        local = face.point(u, v) + h[:, None] * face.normal(u, v)
        return self.target.to_world(local)

    def in_shell(self, points: np.ndarray) -> np.ndarray:
        """True for world points strictly inside the layer's envelope (touching does not
        count)."""
        if self.pieces is not None:
            return np.logical_or.reduce([v.in_shell(points) for v in self.envelope_views()])
        face = self.ring_layout.face
        q = self.target.to_local(np.asarray(points, float).reshape(-1, 3))
        u, v, h = face.locate(q)
        (u0, u1), (v0, v1) = face.extent
        tol = BOUNDARY_TOLERANCE
        if self._cone_envelope:
            a1, b1, a2, b2, dz, zc = wall_envelope(self)
            f = (q[:, 2] - (zc - dz)) / (2 * dz)
            r = np.hypot(q[:, 0], q[:, 1])
            return np.asarray(
                (f > tol / (2 * dz))
                & (f < 1 - tol / (2 * dz))
                & (r > a1 + f * (a2 - a1) + tol)
                & (r < b1 + f * (b2 - b1) - tol)
                & (u > u0 + 1e-12)
                & (u < u1 - 1e-12)
            )
        return np.asarray(
            (h > tol)
            & (h < self.thickness - tol)
            & (v > v0 + tol)
            & (v < v1 - tol)
            & (u > u0 + 1e-12)
            & (u < u1 - 1e-12)
        )

    @property
    def _cone_envelope(self) -> bool:
        """The layer's envelope is a G4Cons between the z planes of its face's ends (a cone's
        side; a cylinder's is the same as its shell; a piece of a cone's envelope ending on
        cones of normals, :attr:`normal_ends`, is its shell)."""
        face = self.ring_layout.face
        return (
            isinstance(face, RevolvedFace)
            and abs(float(face.nrz[1])) > 1e-12
            and not self.normal_ends
        )

    def envelope_box(self) -> OrientedBox:
        """An oriented box (the target's axes) holding the layer's shell."""
        local = self.target.to_local(self.shell_points())
        lo, hi = local.min(axis=0), local.max(axis=0)
        face = self.ring_layout.face
        r = float(np.hypot(local[:, 0], local[:, 1]).max())
        if isinstance(face, SphereFace):  # the widest circle, at the equator if a piece has it
            outer = face.sphere_radius + (self.thickness if face.sign > 0 else 0.0)
            for view in self.envelope_views():
                t0, t1 = view.ring_layout.face.theta  # type: ignore[union-attr]
                r = max(r, outer * (1.0 if t0 <= np.pi / 2 <= t1 else max(np.sin([t0, t1]))))
        if face.dphi >= 2 * np.pi - 1e-9:  # the circle's extremes between the grid's points
            lo[:2], hi[:2] = -r, r
        else:  # the extremes along x and y between the points, of each piece or of the face
            spans = [(face.phi0, face.dphi)] if self.pieces is None else self.pieces
            for phi0, dphi, *_ in spans:
                for k in range(4):
                    if np.mod(k * np.pi / 2 - phi0, 2 * np.pi) <= dphi:
                        ex = r * np.array([np.cos(k * np.pi / 2), np.sin(k * np.pi / 2)])
                        lo[:2], hi[:2] = np.minimum(lo[:2], ex), np.maximum(hi[:2], ex)
        return OrientedBox(self.target.to_world((lo + hi) / 2), self.target.rotation, (hi - lo) / 2)


@dataclass
class RingRoughLayer(RoughLayer):
    """A rough layer on a flat ring (an :class:`~score4.shapes.faces.AnnulusFace`: the end face
    of a tube, cone or polycone, a flat polycone segment): its envelope is the ring
    ``rmin <= r <= rmax`` about the frame's centre (on the axis) extruded by the layer's
    thickness, not the face's bounding square, so that layers on coplanar rings of one solid (a
    BEGe's contact, the ring around it and the bottom beyond its groove) do not meet.
    ``rmin``/``rmax`` start as the face's radii; where the envelope of a curved layer of the same
    solid reaches into the ring's slab (a wall rising from the ring at a concave edge, as in a
    groove) the ring gives way (:func:`fit_rings`): the cells over that band stay flat
    (``rough_shares``)."""

    rmin: float = 0.0
    rmax: float = 0.0

    @property
    def ring(self) -> tuple[float, float]:
        """(rmin, rmax) of the envelope, mm."""
        return self.rmin, self.rmax

    def in_envelope(self, points: np.ndarray) -> np.ndarray:
        """True for world points strictly inside the envelope (touching does not count)."""
        if self.cells_envelope:
            return super().in_envelope(points)
        q = self.frame.to_local(np.asarray(points, float).reshape(-1, 3))
        tol = BOUNDARY_TOLERANCE
        rho = np.hypot(q[:, 0], q[:, 1])
        return np.asarray(
            (q[:, 2] > tol)
            & (q[:, 2] < self.thickness - tol)
            & (rho > self.rmin + tol)
            & (rho < self.rmax - tol)
        )

    def envelope_points(self, n: int = 25) -> np.ndarray:
        """World points of the envelope (rings of points from rmin to rmax at the bottom,
        middle and top, and close to its inner and outer walls), for the clearance checks
        (kept until the ring is narrowed)."""
        if self.cells_envelope:
            return super().envelope_points(n)
        key = (n, self.rmin, self.rmax, self.thickness)
        if key not in self._points:
            self._points.clear()
            self._points[key] = self._envelope_points(n)
        return self._points[key]

    @cached_property
    def _points(self) -> dict:
        return {}

    def _envelope_points(self, n: int) -> np.ndarray:
        t = self.thickness
        r = np.linspace(self.rmin, self.rmax, n)
        edge = min(0.5 * t, 0.25 * (self.rmax - self.rmin))
        r = np.unique(np.concatenate([r, [self.rmin + 0.05 * edge, self.rmin + edge]]))
        r = np.unique(np.concatenate([r, [self.rmax - 0.05 * edge, self.rmax - edge]]))
        n_phi = int(np.clip(np.ceil(2 * np.pi * self.rmax / max(t, 1e-3)), 72, 360))
        phi = np.linspace(0.0, 2 * np.pi, n_phi, endpoint=False)
        h = np.array([0.0, 0.05, 0.5, 0.95, 1.0]) * t
        rr, pp, hh = (g.ravel() for g in np.meshgrid(r, phi, h, indexing="ij"))
        local = np.column_stack([rr * np.cos(pp), rr * np.sin(pp), hh])
        return self.frame.to_world(local)

    def envelope_box(self) -> OrientedBox:
        """The square about the ring (side 2 rmax) times the thickness."""
        t = self.thickness
        return OrientedBox(
            self.frame.to_world(np.array([0.0, 0.0, t / 2])),
            self.frame.rotation,
            np.array([self.rmax, self.rmax, t / 2]),
        )

    def refit(self, rmin: float, rmax: float, where: str) -> None:
        """Narrow the envelope to ``rmin``..``rmax``: only the cells wholly inside keep their
        patch."""
        self.rmin, self.rmax = float(rmin), float(rmax)
        assert self.mask is not None
        self.mask = self.mask & ring_cells(
            self.patch_map.cell_centres(), self.patch_size, self.rmin, self.rmax
        )
        if not self.mask.any():
            px, py = self.patch_size
            raise ConfigError(
                f"{where}: no whole patch of {px * 1e3:g} x {py * 1e3:g} um fits on face "
                f"{self.config.face_name} of {self.target.name!r} between r = "
                f"{self.rmin:.6g} and {self.rmax:.6g} mm (the face less the layers of its "
                "neighbouring walls)"
            )


def ring_cells(
    centres: np.ndarray, size: tuple[float, float], rmin: float, rmax: float
) -> np.ndarray:
    """True for the (u, v) rectangles of ``size`` around ``centres`` (..., 2) that lie wholly
    in the ring ``rmin <= r <= rmax``."""
    px, py = size
    x, y = np.abs(centres[..., 0]), np.abs(centres[..., 1])
    far = np.hypot(x + px / 2, y + py / 2)
    near = np.hypot(np.maximum(x - px / 2, 0.0), np.maximum(y - py / 2, 0.0))
    return np.asarray((far <= rmax * (1 + 1e-12)) & (near >= rmin * (1 - 1e-12)))


def fit_rings(
    layers: list[RoughLayer], placed: Sequence[RoughLayer] = (), where: str | None = None
) -> None:
    """Ring layers of a solid give way to the curved layers of the same solid whose envelopes
    reach into their slab (see :class:`RingRoughLayer`).

    A wall (cylinder or cone) meeting a flat ring at a concave edge (a groove's walls and its
    bottom, a bore's wall and its bottom) has its envelope, between the z planes of its ends,
    inside the ring's slab (the ring's plane moved out by the ring layer's thickness): the ring's
    envelope then starts (or ends) where the wall's envelope ends in that slab. At a convex edge
    the two envelopes only touch and nothing changes. A wall's envelope reaching into the
    middle of a ring is left to the clearance check.

    ``placed``: layers already built in Geant4 (:class:`score4.api.World`), which must not change:
    a ring among them that would have to give way is a ConfigError (after ``where``, default
    ``targets.{entry}.rough``) naming the ring and the wall, and no ring is changed then."""
    fits: list[tuple[RingRoughLayer, float, float, CurvedRoughLayer]] = []
    for ring in layers:
        if isinstance(ring, RingRoughLayer) and not ring.config.into:
            fit = _ring_fit(ring, layers)
            if fit is not None:
                fits.append((ring, *fit))
    for ring, rmin, rmax, wall in fits:
        if any(ring is p for p in placed):
            name = ring.target.name
            raise ConfigError(
                f"{where or f'targets.{ring.target.entry}.rough'}: the layer on face "
                f"{wall.config.face_name} of {name!r} reaches into the slab of the rough ring on "
                f"face {ring.config.face_name}, which is placed already and cannot give way to it "
                f"(r = {ring.rmin:.6g} .. {ring.rmax:.6g} mm would become {rmin:.6g} .. "
                f"{rmax:.6g} mm): roughen a wall before the rings it meets, or both in one call "
                "(a list of faces)"
            )
    for ring, rmin, rmax, _ in fits:
        ring.refit(rmin, rmax, where or f"targets.{ring.target.entry}.rough")


def _ring_fit(
    ring: RingRoughLayer, layers: list[RoughLayer]
) -> tuple[float, float, CurvedRoughLayer] | None:
    """The radii ``ring`` narrows to for the walls among ``layers`` (see :func:`fit_rings`) and
    the last wall that narrowed it; None when it keeps its radii."""
    if ring.on_boolean is not None:
        return None
    face = ring.target.face(ring.config.face_name)
    assert isinstance(face, AnnulusFace)
    z0 = float(face.frame.translation[2])
    nz = float(face.frame.rotation[2, 2])
    slab = sorted((z0, z0 + nz * ring.thickness))
    rmin, rmax = ring.rmin, ring.rmax
    by: CurvedRoughLayer | None = None
    for wall in layers:
        if (
            not isinstance(wall, CurvedRoughLayer)
            or not isinstance(wall.ring_layout.face, RevolvedFace)
            or wall.on_boolean is not None
            or wall.target is not ring.target
        ):
            continue
        a1, b1, a2, b2, dz, zc = wall_envelope(wall)
        lo, hi = max(slab[0], zc - dz), min(slab[1], zc + dz)
        if hi - lo <= BOUNDARY_TOLERANCE:
            continue  # the envelopes touch at most (a convex edge)
        at = [(z - (zc - dz)) / (2 * dz) if dz > 0 else 0.0 for z in (lo, hi)]
        radii = [a1 + f * (a2 - a1) for f in at] + [b1 + f * (b2 - b1) for f in at]
        r_lo, r_hi = min(radii), max(radii)
        if r_hi <= rmin + BOUNDARY_TOLERANCE or r_lo >= rmax - BOUNDARY_TOLERANCE:
            continue
        if r_lo <= rmin + BOUNDARY_TOLERANCE:
            rmin, by = r_hi, wall
        elif r_hi >= rmax - BOUNDARY_TOLERANCE:
            rmax, by = r_lo, wall
    if by is None or (rmin, rmax) == (ring.rmin, ring.rmax):
        return None
    return rmin, rmax, by


#: How far (mm) a bent patch's floor may dip below the true surface (a tenth of Geant4's
#: surface tolerance, 1e-9 mm).
FLOOR_ROUNDING = 1e-10
#: A cone narrowing to a point: rounds of leaving its narrowest rings flat until the bent base
#: keeps within the gap limit, and the factor on the radius where the gap (falling as
#: 1 / radius) meets it (the lift of the rings kept changes it a little).
TIP_ROUNDS = 4
TIP_MARGIN = 1.02


def wall_envelope(layer: CurvedRoughLayer) -> tuple[float, float, float, float, float, float]:
    """``(rmin1, rmax1, rmin2, rmax2, dz, z_centre)`` of a curved layer's envelope on a cylinder
    or cone (the shape's frame): the face and the same moved out by the layer thickness along
    its normal, between the z planes of the face's ends (the ``G4Cons`` of
    :mod:`score4.geometry.curved`)."""
    face = layer.ring_layout.face
    assert isinstance(face, RevolvedFace)
    (r1, z1), (r2, z2) = face.rz1, face.rz2
    if z1 > z2:
        (r1, z1), (r2, z2) = (r2, z2), (r1, z1)
    tz = abs(float(face._tangent[1]))
    shift = float(np.sign(face.nrz[0])) * layer.thickness / tz  # the offset surface, same z
    a1, b1 = sorted((r1, r1 + shift))
    a2, b2 = sorted((r2, r2 + shift))
    return float(a1), float(b1), float(a2), float(b2), 0.5 * (z2 - z1), 0.5 * (z1 + z2)


def normal_envelope(layer: CurvedRoughLayer) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """``(r, z)``: the corners (the shape's frame, a meridian section) of the envelope of a
    curved layer on a cylinder or cone that ends on the cones of its face's normals through its
    ends (:attr:`CurvedRoughLayer.normal_ends`): the face's ends and the same moved out by the
    layer thickness along the normal, a rectangle (the ``G4GenericPolycone`` of
    :mod:`score4.geometry.curved`)."""
    face = layer.ring_layout.face
    assert isinstance(face, RevolvedFace)
    (_, _), (v0, v1) = face.extent
    t = layer.thickness
    v = np.array([v0, v0, v1, v1])
    p = face.point(np.zeros(4), v) + np.array([0.0, t, t, 0.0])[:, None] * face.normal(0.0, v)
    return tuple(float(x) for x in p[:, 0]), tuple(float(x) for x in p[:, 2])


@dataclass
class PolygonRoughLayer(RoughLayer):
    """A rough layer on a flat face of any outline (:mod:`score4.world.facets`): ``outline``
    holds the face's triangles in the layer's frame (x, y; centred on the patch grid), the
    envelope is their prism (``prism``, z from -thickness/2 to +thickness/2 about the envelope's
    centre), ``mask`` the cells wholly in the face."""

    outline: np.ndarray = field(default_factory=lambda: np.zeros((0, 3, 2)))
    part: int = -1  # the plane's index on a face of several planes (-1: a face of one plane)
    # where the face's flat rest lies (the layer's frame): the outline, or with ``into`` the
    # outline cut to the solid's section at the cut (it is narrower where a side leans inward)
    base_outline: np.ndarray | None = None

    @property
    def name(self) -> str:
        base = super().name
        return base if self.part < 0 else f"{base}_{self.part}"

    @cached_property
    def prism(self):
        """The envelope: the face's polygon extruded by the layer's thickness (frame-local,
        centred on the envelope box's centre)."""
        return prism_mesh(self.outline, self.thickness)

    def envelope_prism(self) -> TriangleMesh | None:
        return super().envelope_prism() if self.cells_envelope else self.prism

    def in_face(self, xy: np.ndarray, tol: float = BOUNDARY_TOLERANCE) -> np.ndarray:
        """True for frame-local (x, y) points in the face's polygon."""
        return point_in_triangles(np.asarray(xy, float).reshape(-1, 2), self.outline, tol)

    def in_envelope(self, points: np.ndarray) -> np.ndarray:
        """True for world points strictly inside the envelope (touching does not count)."""
        if self.cells_envelope:
            return super().in_envelope(points)
        q = self.frame.to_local(np.asarray(points, float).reshape(-1, 3))
        tol = BOUNDARY_TOLERANCE
        inside = (q[:, 2] > tol) & (q[:, 2] < self.thickness - tol)
        rows = np.flatnonzero(inside)
        inside[rows] = self.in_face(q[rows, :2], -tol)
        return inside

    def envelope_points(self, n: int = 25) -> np.ndarray:
        """World points of the envelope (a grid of its box kept in the polygon, and the
        polygon's corners), at the bottom, middle and top, for the clearance checks."""
        if self.cells_envelope:
            return super().envelope_points(n)
        lu, lv = self.frame.size
        u, v = np.meshgrid(np.linspace(-lu / 2, lu / 2, n), np.linspace(-lv / 2, lv / 2, n))
        xy = np.column_stack([u.ravel(), v.ravel()])
        xy = np.concatenate([xy[self.in_face(xy)], self.outline.reshape(-1, 2)])
        t = self.thickness
        pts = [np.column_stack([xy, np.full(len(xy), h)]) for h in (0.0, t / 2, t)]
        # along the outline, just inside it and low: where the layer of a neighbouring face
        # meets this one at a concave edge (a region about t x t along the edge)
        edges = boundary_edges(self.outline)
        s = np.linspace(0.0, 1.0, n)
        for a, b in edges:
            d = b - a
            inward = np.array([-d[1], d[0]]) / max(float(np.hypot(*d)), 1e-300)
            line = a + s[:, None] * d
            for off in (0.05, 0.25, 0.5):
                for h in (0.05, 0.25, 0.5, 0.95):
                    q = line + off * t * inward
                    q = q[self.in_face(q)]  # not past a neighbouring edge at a sharp corner
                    pts.append(np.column_stack([q, np.full(len(q), h * t)]))
        return self.frame.to_world(np.concatenate(pts))

    def envelope_box(self) -> OrientedBox:
        """The prism's bounding box (the polygon reaches past the whole cells' grid)."""
        flat = self.outline.reshape(-1, 2)
        lo, hi = flat.min(axis=0), flat.max(axis=0)
        t = self.thickness
        centre = np.array([*(lo + hi) / 2, t / 2])
        return OrientedBox(
            self.frame.to_world(centre), self.frame.rotation, np.array([*(hi - lo) / 2, t / 2])
        )

    def in_cut(self, points: np.ndarray) -> np.ndarray:
        """With ``into``: True for world points in the slab the (convex) solid is clipped by:
        the whole slab under the face's plane, as deep as the layer, not only under the
        polygon."""
        q = self.frame.to_local(np.asarray(points, float).reshape(-1, 3))
        return (q[:, 2] > BOUNDARY_TOLERANCE) & (q[:, 2] <= self.thickness + BOUNDARY_TOLERANCE)


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
    # GDML volumes a source names that are not targets (not scored; Scene.unscored_target)
    unscored: list[TargetVolume] = field(default_factory=list)

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
        hits = hits or [t for t in self.unscored if t.column == ref]
        if hits:
            return hits
        hits = [t for t in self.targets if t.config.label == ref]
        if hits:
            return hits
        if self.model is not None:
            found = self.model.resolve(ref, parameter)
            instances = {i.index for i in found}
            hits = [t for t in self.targets if t.instance and t.instance.index in instances]
            if hits:
                return hits
            if parameter.startswith("source"):  # a source may sit on a volume not scored
                return [self.unscored_target(ref, inst, parameter) for inst in found]
        raise ConfigError(
            f"{parameter}: {ref!r} is not a target; targets are: {', '.join(self.columns)}"
        )

    def unscored_target(self, ref: str, inst: Instance, parameter: str) -> TargetVolume:
        """The volume ``inst`` of the GDML world as a target that is not scored: a source may
        sit on it or in it; it has no scoring column, no rough layers and no activeness."""
        from score4.inputs.config import GdmlVolume

        assert self.model is not None
        for t in self.unscored:
            if t.instance is not None and t.instance.index == inst.index:
                return t
        target = gdml_target(
            self.model,
            GdmlVolume(volume=ref),
            -1,
            inst,
            None,
            parameter,
            column=self.model.column(inst),
        )
        self.unscored.append(target)
        return target

    def layer(self, volume: str, face: str) -> RoughLayer | None:
        return next(
            (r for r in self.layers if r.target.name == volume and r.config.face_name == face), None
        )

    def layers_of(self, volume: str) -> list[RoughLayer]:
        return [r for r in self.layers if r.target.name == volume]

    def inside_target(self, volume: str, points: np.ndarray) -> np.ndarray:
        """True for points in the volume (less the slabs of ``into`` layers) or its rough layers."""
        points = np.asarray(points, float).reshape(-1, 3)
        target = self.target(volume)
        inside = target.contains(points)
        into = {r.config.face_name: r.thickness for r in self.layers_of(volume) if r.config.into}
        shape = target.shape
        if into and isinstance(shape, RevolvedShape) and shape.kind in SWEPT_INTO:
            # the solid Geant4 gets (geometry.built.cut_for_layers): their joint cut
            trimmed = shape.trimmed(into)
            assert trimmed is not None
            local = target.to_local(points) - trimmed[1]
            inside &= trimmed[0].signed_distance(local) <= BOUNDARY_TOLERANCE
            into = {}
        for layer in self.layers_of(volume):
            if layer.config.face_name in into:
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


def _same_size(a: float, b: float) -> bool:
    return abs(a - b) <= 1e-9 * max(abs(a), abs(b))


def resolve_targets(config: RunConfig, model: GeometryModel | None) -> list[TargetVolume]:
    """One :class:`TargetVolume` per configured box and per copy of each GDML target."""
    from score4.inputs.config import BoxVolume

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
    if t.pattern:
        where = f"targets.{entry}.{'volume_regex' if t.volume_regex else 'volume'}"
        if t.volume is None and t.volume_regex is None:
            where = f"targets.{entry}.material"
        glob = t.volume if t.volume is not None and any(c in t.volume for c in "*?") else None
        if t.volume is not None and glob is None:  # a name with a material: the name's copies
            named = model.resolve(t.volume, where)
            instances = [i for i in named if model.logicals[i.logical].material == t.material]
            if not instances:
                have = model.logicals[named[0].logical].material
                raise ConfigError(
                    f"{where}: {t.volume!r} is of material {have!r}, not {t.material!r}"
                )
        else:
            instances = model.select(glob, t.volume_regex, t.material, where)
        return [
            gdml_target(model, t, entry, inst, None, where, column=model.column(inst))
            for inst in instances
        ]
    assert t.volume is not None  # a name: the validator's rule
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
            PlacedShape(b.described("targets"), b.transform)
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
    column: str | None = None,
) -> TargetVolume:
    """The target of GDML volume entry ``t`` (``targets[entry]``) at placement ``inst``.

    ``k`` numbers the placement when the entry names several (its column is ``name_k``), else
    ``None``. ``where`` names the configuration key in errors (default ``targets.<entry>.volume``).
    Raises :class:`~score4.errors.ConfigError` for the world volume, a reflected placement or a
    volume inside a replica.
    """
    where = where or f"targets.{entry}.volume"
    if inst.index == 0:
        raise ConfigError(f"{where}: {t.label!r} is the world volume; score a volume inside it")
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
    if column is None:
        assert t.volume is not None  # a pattern's volumes come with their columns
        column = t.volume if k is None else f"{t.volume.split('[')[0]}_{k}"
        if k is None and "[" in t.volume:
            column = f"{inst.name}_{inst.occurrence}"
    assert inst.mother is not None  # only the world has none
    mother = model.instances[inst.mother]
    data = lv.solid.get("shape")
    exclude, unknown = daughter_shapes(model, inst)
    shape = shape_from_dict(data) if data else None
    meta = model.metadata.get(inst.name)
    if isinstance(shape, G4GenericPolycone) and is_hpge_metadata(meta):
        assert meta is not None
        shape = hpge_groups(shape, meta)  # the pplus, passive and nplus groups of an HPGe
    elif (
        isinstance(shape, BooleanShape)
        and isinstance(shape.first, G4GenericPolycone)
        and is_hpge_metadata(meta)
    ):
        assert meta is not None  # an HPGe with a cut (legend-pygeom-hpges' P00664B, V02160A):
        # the groups of its polycone, on the boolean's faces
        shape = replace(shape, first=hpge_groups(shape.first, meta), aliases=HPGE_GROUPS)
    if isinstance(shape, BooleanShape):  # its area estimate, made once per solid
        shape = replace(shape, area_cache=cache_dir(BOOLEAN_AREAS))
    return TargetVolume(
        column,
        entry,
        t,
        lv.material,
        lv.solid_type,
        shape,
        Transform(inst.rotation, inst.translation),
        np.asarray(lv.solid["lo"], float),
        np.asarray(lv.solid["hi"], float),
        inst,
        mother,
        exclude,
        unknown,
    )


def rough_faces(target: TargetVolume, rough: RoughFace) -> list[str]:
    """The faces a rough entry names: its face names, groups (``outer``, ``pplus``, ...) and
    lists of them, resolved on the target's shape; ConfigError listing the faces and groups
    for a name the shape lacks."""
    names = rough.face_list
    if target.shape is None:
        return names
    out: list[str] = []
    for name in names:
        try:
            faces = target.shape.resolve_faces(name)
        except ConfigError:
            target_face(target, name)  # raises, naming the solid's faces and groups
            raise
        out += [f for f in faces if f not in out]
    return out


def make_layer(
    surfaces: dict[str, Surface],
    target: TargetVolume,
    j: int,
    rough: RoughFace,
    where: str | None = None,
    triangles: np.ndarray | None = None,
    part: int = -1,
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
    if triangles is not None:  # one plane of a face of several
        face = plane_face(rough.face_name, triangles)
        return make_polygon_layer(
            target, rough, face, names, variants, size, where, triangles, part
        )
    try:
        geometry = target_face(target, rough.face_name)
    except ConfigError as err:
        raise ConfigError(f"{where}: {err}") from None
    if isinstance(geometry, RevolvedFace | SphereFace):
        return make_curved_layer(target, rough, geometry, names, variants, size, where)
    if (
        isinstance(geometry, PlaneFace)
        and not isinstance(geometry, AnnulusFace)
        and (not geometry.rectangle or (rough.into and not _trimmable(target, rough.face_name)))
    ):  # a polygon; or a rectangle of a solid cut by clipping (into), like its other faces
        return make_polygon_layer(target, rough, geometry, names, variants, size, where)
    try:
        frame = face_frame(target, rough.face_name)
    except ConfigError as err:
        raise ConfigError(f"{where}: {err}") from None
    round_face = isinstance(geometry, AnnulusFace)
    if (
        rough.into
        and round_face
        and isinstance(target.shape, RevolvedShape)
        and target.shape.kind != "G4Tubs"
        and (target.shape.kind not in SWEPT_INTO or not target.shape.full_phi)
    ):
        raise ConfigError(
            f"{where}: into: true on the flat face {rough.face_name} of {target.name!r} (a "
            f"{target.solid}) is supported on a G4Tubs and on a full G4Cons, G4Polycone or "
            "G4GenericPolycone (a slanting neighbour changes the ring's radii at the cut, which "
            "score4 follows on a full circle only); put the layer outside the volume "
            "(into: false)"
        )
    if round_face:  # the whole cells of the bounding square, centred
        cells = [max(int(np.floor(frame.size[a] / size[a] * (1 + 1e-9))), 1) for a in (0, 1)]
        frame = FaceFrame(frame.centre, frame.rotation, (cells[0] * size[0], cells[1] * size[1]))
    if rough.tiling == "portal" and target.instance is not None:
        raise ConfigError(
            f"{where}: tiling portal works on boxes of the configuration in a generated world; "
            "a GDML volume takes tiling: native (the default)"
        )
    patch_map = _rough_patch_map(
        frame.size, size, rough, f"{where} (face {rough.face_name} of {target.name})"
    )
    mask, area = None, frame.size[0] * frame.size[1]
    if isinstance(geometry, AnnulusFace):
        mask = geometry.covers(patch_map.cell_centres(), patch_map.patch_size)
        area = float(geometry.area)
        if not mask.any():
            raise ConfigError(
                f"{where}: no whole patch of {size[0] * 1e3:g} x {size[1] * 1e3:g} um fits on "
                f"face {rough.face_name} of {target.name!r}"
            )
        if rough.native_layout == "replicas":
            raise ConfigError(
                f"{where}: native_layout replicas fills a rectangle; a round face takes auto, "
                "nested or placements"
            )
    layer = (
        RingRoughLayer(
            target,
            rough,
            frame,
            names,
            variants,
            patch_map,
            mask,
            area,
            rmin=geometry.rmin,
            rmax=geometry.rmax,
        )
        if isinstance(geometry, AnnulusFace)
        else RoughLayer(target, rough, frame, names, variants, patch_map, mask, area)
    )
    for k, n in enumerate(names):
        try:
            check_patch(variants[k], layer.solid_kind(k), rough.block_cells)
        except ConfigError as err:
            raise ConfigError(f"{where} (surface {n!r}): {err}") from None
    if rough.into:
        extent = target.described("into").thickness_along(geometry.frame.rotation[:, 2])
        if layer.thickness >= extent:
            raise ConfigError(
                f"{where}: into: the layer ({layer.thickness * 1e3:.4g} um) is not thinner than "
                f"{target.name!r} ({extent * 1e3:.4g} um along the face normal)"
            )
        layer.frame = frame.shifted(-layer.thickness)
    return layer


def make_curved_layer(
    target: TargetVolume,
    rough: RoughFace,
    face: RevolvedFace | SphereFace,
    names: list[str],
    variants: list[Surface],
    size: tuple[float, float],
    where: str,
) -> CurvedRoughLayer:
    """The rough layer on a face swept around z (:mod:`score4.world.curved`)."""
    what = f"face {rough.face_name} of {target.name!r}"
    if rough.into:
        if not _trimmable(target, rough.face_name):
            raise ConfigError(
                f"{where}: into: true on a curved face ({what}, a {target.solid}) is supported "
                "on the walls of a G4Tubs, G4Cons, G4Polycone or G4GenericPolycone and the outer "
                "and inner faces of a G4Sphere or G4Orb only; the layer goes outside the volume "
                "(into: false)"
            )
        if isinstance(face, SphereFace):
            return _into_sphere(target, rough, face, names, variants, size, where)
        return _into_revolved(target, rough, face, names, variants, size, where)
    if rough.tiling == "portal":
        raise ConfigError(
            f"{where}: tiling portal on a curved face ({what}): a portal's jumps are pure "
            "translations between the flat cells of one plane, and bent patches differ from ring "
            "to ring; a curved face takes tiling: native"
        )
    if rough.native_layout == "replicas":
        raise ConfigError(
            f"{where}: native_layout replicas fills a rectangle; a curved face takes auto"
        )
    if rough.solid not in ("auto", "tessellated", "frustums"):
        raise ConfigError(
            f"{where}: solid {rough.solid} on a curved face ({what}); its patches are bent "
            "tessellated bodies or, for spike grids, bent frustums (solid: auto, "
            "tessellated or frustums)"
        )
    if rough.solid == "frustums" and any(s.spikes is None for s in variants):
        raise ConfigError(
            f"{where}: solid frustums on a curved face ({what}) needs spike-grid surfaces; "
            "use solid: auto or tessellated"
        )
    limit = gap_limit(max(s.max_height for s in variants))
    layer = _bent_layer(target, rough, face, names, variants, size, where, 0.0)
    if layer.gap > limit and not isinstance(face, SphereFace) and abs(face.nrz[1]) > 1e-12:
        # a cone: the gap grows as 1 / radius towards its narrow end (a drill tip closing to a
        # point); the rings narrower than where it meets the limit stay flat
        # (``rough_shares``), as a sphere's rings near its poles do
        least = _tip_radius(layer, limit / TIP_MARGIN)
        for _ in range(TIP_ROUNDS if least is not None else 0):
            assert least is not None
            layer = _bent_layer(target, rough, face, names, variants, size, where, least)
            if layer.gap <= limit:
                break
            # the rows moved a little (their gap depends on the narrowest ring): one ring more
            lay = layer.ring_layout
            held = np.flatnonzero(lay.count > 0)
            if len(held) < 2:
                break
            least = float(np.sort(_inner_radii(lay)[held])[1])
    layout = layer.ring_layout
    check_radius(layout, layer.gap, limit, where, target.name, rough.face_name)
    _tip_pieces(layer)
    if rough.solid == "frustums" and not layer.frustum_cells:
        raise ConfigError(
            f"{where}: solid frustums on {what}: the cone is too close to a cylinder for cells "
            "of bent frustums (the cones of its normals through a patch's ends meet the axis); "
            "use solid: auto or tessellated"
        )
    return layer


def _tip_pieces(layer: CurvedRoughLayer) -> None:
    """A cone whose narrowest rings stay flat (:attr:`RingLayout.least`): its envelope ends at
    the held rings' cells, short of the flat tip (where a G4Cons of radius 0 at one end would
    also have its inner radius moved off 0 by Geant4); again whenever the layer's thickness
    changes (the cells reach beyond their band by it)."""
    lay = layer.ring_layout
    if lay.least <= 0:
        return
    face = lay.face
    assert isinstance(face, RevolvedFace)
    held = np.flatnonzero(lay.count > 0)
    span = np.array([cone_ring_span(lay, int(j), layer.thickness) for j in held])
    (_, _), (fv0, fv1) = face.extent
    v0 = fv0 if held[0] == 0 else float(span[:, 0].min())
    v1 = fv1 if held[-1] == len(lay.v) - 1 else float(span[:, 1].max())
    layer.pieces = [EnvelopePiece(face.phi0, face.dphi, v0, v1, False)]


def _inner_radii(lay: RingLayout) -> np.ndarray:
    """The smallest radius each ring reaches (the radius :meth:`RingLayout.make` compares with
    ``least``)."""
    py = lay.patch_size[1]
    return np.minimum(lay.face.radius(lay.v - py / 2), lay.face.radius(lay.v + py / 2))


def _tip_radius(layer: CurvedRoughLayer, limit: float) -> float | None:
    """The least ring radius of a cone's layer whose bent base keeps within ``limit`` of the
    true surface when only the rings at least that wide hold patches: each ring's floor is
    measured unlifted (:func:`measure_floor`); the rings kept, widest first, need the lift of
    the deepest and leave the gap of the highest; None where not even the widest ring fits."""
    lay = layer.ring_layout
    held = np.flatnonzero(lay.count > 0)
    inner = _inner_radii(lay)
    order = held[np.argsort(-inner[held], kind="stable")]
    lows, highs = np.full(len(order), np.inf), np.full(len(order), -np.inf)
    for k in range(len(layer.variants)):
        flat = layer._flat(k)
        for n, j in enumerate(order):
            lo, hi = measure_floor(lay, flat, layer.base_thickness, int(j))
            lows[n], highs[n] = min(lows[n], lo), max(highs[n], hi)
    gap = np.maximum.accumulate(highs) + np.maximum(-np.minimum.accumulate(lows), 0.0)
    fits = np.flatnonzero(gap <= limit)
    if not len(fits) or fits[0] != 0:
        return None
    last = int(np.flatnonzero(gap > limit)[0]) - 1 if (gap > limit).any() else len(order) - 1
    return float(inner[order[last]])


def _bent_layer(
    target: TargetVolume,
    rough: RoughFace,
    face: RevolvedFace | SphereFace,
    names: list[str],
    variants: list[Surface],
    size: tuple[float, float],
    where: str,
    least: float,
) -> CurvedRoughLayer:
    """The bent layer of :func:`make_curved_layer` with its rings below radius ``least`` flat
    (:meth:`RingLayout.make`), its lift and gap measured on the rings that hold patches."""
    what = f"face {rough.face_name} of {target.name!r}"
    reserve = 1.05 * (rough.base_thickness + max(s.max_height for s in variants)) + 1e-4
    row_gap = 0.0
    if isinstance(face, SphereFace) or abs(face.nrz[1]) > 1e-12:  # rings apart by twice the
        # walls' chord sagitta (a cone, a sphere: neighbouring rings bend with other radii)
        probe = RingLayout.make(face, size, reserve, least=least)
        if len(probe.v):
            sag = max(top_sagitta(probe, flat_body(v, rough.base_thickness)) for v in variants)
            row_gap = 2 * sag + 1e-7
    layout = RingLayout.make(face, size, reserve, row_gap, least)
    if layout.n_cells == 0:
        raise ConfigError(
            f"{where}: no whole patch of {size[0] * 1e3:g} x {size[1] * 1e3:g} um fits on {what} "
            f"(generator {face.length:.4g} mm, radius {float(face.radius(0.0)):.4g} mm)"
        )
    ny, nx = len(layout.v), int(layout.count.max())
    patch_map = _rough_patch_map((nx * size[0], ny * size[1]), size, rough, f"{where} ({what})")
    mask = np.arange(nx)[None, :] < layout.count[:, None]
    placed = target.transform @ face.frame
    frame = FaceFrame(placed.translation, placed.rotation, (nx * size[0], ny * size[1]))
    layer = CurvedRoughLayer(
        target, rough, frame, names, variants, patch_map, mask, float(face.area), layout
    )
    rows = {0, ny - 1}
    if least > 0:  # the held rings' ends (the narrowest held ring bends its patches most)
        held = np.flatnonzero(layout.count > 0)
        rows = {int(held[0]), int(held[-1])}
    if isinstance(face, SphereFace):  # the rings' shapes differ all along the meridian
        rows = {int(j) for j in np.flatnonzero(layout.count > 0)}

    def floor_heights(lift: float) -> tuple[float, float]:
        lows, highs = [], []
        for k in range(len(variants)):
            flat = layer._flat(k)
            spikes = variants[k].spikes
            column = spikes.width_x if spikes is not None and isinstance(face, SphereFace) else None
            for j in rows:
                lo, hi = measure_floor(layout, flat, rough.base_thickness, j, column, lift)
                lows.append(lo)
                highs.append(hi)
        return min(lows), max(highs)

    low, high = floor_heights(0.0)
    tops = [top_sagitta(layout, layer._flat(k)) for k in range(len(variants))]
    convex = face.sign > 0 if isinstance(face, SphereFace) else face.nrz[0] > 0
    layer.lift = max(-low, 0.0)
    layer.gap = high + layer.lift
    if layer.lift > 0:  # lifted, the floor's chords span a larger circle and dip a little deeper
        # (by about lift^2 / radius): once more at that height where that is more than
        # FLOOR_ROUNDING (a cylinder's 2e-14 mm or an orb's 2.5e-11 mm would move the patches for
        # nothing, and change every run's tracks)
        low, high = floor_heights(layer.lift)
        if -low > FLOOR_ROUNDING:
            layer.lift -= low
            layer.gap = high - low
    layer.top_margin = 0.0 if convex else max(tops)
    return layer


def _into_sphere(
    target: TargetVolume,
    rough: RoughFace,
    face: SphereFace,
    names: list[str],
    variants: list[Surface],
    size: tuple[float, float],
    where: str,
) -> CurvedRoughLayer:
    """The layer of ``rough`` grown into a G4Sphere or G4Orb: laid out on the face of the solid
    made thinner by the layer's thickness (the radius moved in for ``outer``, out for
    ``inner``), its top padded to reach the face (the bent layer's thickness changes a little
    with the radius: the cut is taken again until the layer fits)."""
    outside = rough.model_copy(update={"into": False})
    shape = target.described("into")
    cut = make_curved_layer(target, outside, face, names, variants, size, where).thickness
    if isinstance(shape, G4SphereShape):
        lo, hi = shape.rmin, shape.rmax
    else:
        assert isinstance(shape, G4OrbShape)  # _trimmable: a G4Sphere or a G4Orb
        lo, hi = 0.0, shape.r
    for _ in range(4):
        if cut >= hi - lo:
            raise ConfigError(
                f"{where}: into: the layer ({cut * 1e3:.4g} um) is not thinner than "
                f"{target.name!r} ({(hi - lo) * 1e3:.4g} um between its spheres)"
            )
        trimmed = shape.trimmed({rough.face_name: cut})
        assert trimmed is not None
        inner = trimmed[0].face(rough.face_name)
        assert isinstance(inner, SphereFace)
        layer = make_curved_layer(target, outside, inner, names, variants, size, where)
        if layer.thickness <= cut:
            layer.top_margin += cut - layer.thickness  # the top where the face was
            layer.config = rough
            layer.into_cut = cut
            return layer
        cut = layer.thickness * (1 + 1e-9)
    raise ConfigError(f"{where}: into: the layer on {face.name} does not settle on a cut")


def _into_revolved(
    target: TargetVolume,
    rough: RoughFace,
    face: RevolvedFace,
    names: list[str],
    variants: list[Surface],
    size: tuple[float, float],
    where: str,
    others: dict[str, float] | None = None,
) -> CurvedRoughLayer:
    """The layer of ``rough`` cut into a wall of a G4Tubs, G4Cons or polycone (``others``: the
    cuts of the target's other ``into`` faces, which move the wall's ends): laid out on the
    wall of the solid cut by the layer's thickness (:meth:`RevolvedShape.cut_contour`: the wall
    moved inward along its normal, its neighbours' lines kept), its top padded to reach the old
    face; the cut is taken again until the bent layer (whose lift grows as the radius falls)
    fits."""
    outside = rough.model_copy(update={"into": False})
    shape = target.described("into")
    assert isinstance(shape, RevolvedShape)  # _trimmable: a G4Tubs, G4Cons or polycone
    name = rough.face_name
    cut = make_curved_layer(target, outside, face, names, variants, size, where).thickness
    for _ in range(4):
        try:
            trimmed = shape.trimmed({name: cut})
            moved = shape.cut_face(name, {**(others or {}), name: cut}).as_face(name)
        except ConfigError as err:
            raise ConfigError(
                f"{where}: into: the layer ({cut * 1e3:.4g} um) on face {name} of "
                f"{target.name!r}: {err}"
            ) from None
        assert trimmed is not None
        assert isinstance(moved, RevolvedFace)
        layer = make_curved_layer(target, outside, moved, names, variants, size, where)
        if layer.thickness <= cut:
            layer.top_margin += cut - layer.thickness  # the top where the face was
            layer.config = rough
            layer.cut_shape = trimmed
            layer.into_cut = cut
            _tip_pieces(layer)
            return layer
        cut = layer.thickness * (1 + 1e-9)
    raise ConfigError(f"{where}: into: the layer on {name} does not settle on a cut")


def make_polygon_layer(
    target: TargetVolume,
    rough: RoughFace,
    face: PlaneFace,
    names: list[str],
    variants: list[Surface],
    size: tuple[float, float],
    where: str,
    triangles: np.ndarray | None = None,
    part: int = -1,
) -> PolygonRoughLayer:
    """The rough layer on a flat face of any outline (:mod:`score4.world.facets`): the face's
    triangles (shape frame; default: all of face ``rough.face``), ``part``: the plane's index
    on a face of several planes."""
    what = f"face {rough.face_name} of {target.name!r}"
    solid = None if target.shape is None else solid_triangles(target.shape)
    if rough.into and (solid is None or not is_convex(solid)):
        raise ConfigError(
            f"{where}: into: true on {what} (a {target.solid}) cuts the volume below the face, "
            "which score4 does for a box, a tube's end faces and convex solids of flat facets "
            "(G4Trd, G4Trap, a convex G4Polyhedra, tessellated or extruded solid) only; this "
            "solid is not one: put the layer outside the volume (into: false)"
        )
    if rough.tiling == "portal":
        raise ConfigError(
            f"{where}: tiling portal on {what} (a {target.solid}): a portal's subworlds must lie "
            "where no particle goes, which score4 knows only in the world it generates, whose "
            "targets are boxes; a face of a GDML solid takes tiling: native"
        )
    if rough.native_layout in ("replicas", "nested"):
        raise ConfigError(
            f"{where}: native_layout {rough.native_layout} fills a rectangle; {what} (a polygon) "
            "takes auto or placements"
        )
    if triangles is None:
        triangles = face_triangles(target.described("rough"), rough.face_name)
    if part >= 0:
        what += f" (plane {part})"
    local = face.frame.inverse_apply(triangles.reshape(-1, 3))
    local = local.reshape(-1, 3, 3)
    check_one_plane(local, where, rough.face_name, target.name)
    flat = local[..., :2]
    lo, hi = flat.reshape(-1, 2).min(axis=0), flat.reshape(-1, 2).max(axis=0)
    mid = (lo + hi) / 2
    cells = [max(int(np.floor((hi[a] - lo[a]) / size[a] * (1 + 1e-9))), 1) for a in (0, 1)]
    extent = (cells[0] * size[0], cells[1] * size[1])
    frame = FaceFrame(
        target.to_world(face.frame.apply(np.array([mid[0], mid[1], 0.0]))),
        target.rotation @ face.frame.rotation,
        extent,
    )
    outline = ccw(flat - mid)
    patch_map = _rough_patch_map(extent, size, rough, f"{where} ({what})")
    scale = max(float(np.abs(outline).max()), 1.0)
    mask = cells_inside(outline, patch_map.cell_centres(), size, 1e-9 * scale)
    if not mask.any():
        raise ConfigError(
            f"{where}: no whole patch of {size[0] * 1e3:g} x {size[1] * 1e3:g} um fits on {what} "
            f"(a polygon of {(hi - lo)[0]:.4g} x {(hi - lo)[1]:.4g} mm)"
        )
    layer = PolygonRoughLayer(
        target, rough, frame, names, variants, patch_map, mask, float(face.area), outline, part
    )
    for k, n in enumerate(names):
        try:
            check_patch(variants[k], layer.solid_kind(k), rough.block_cells)
        except ConfigError as err:
            raise ConfigError(f"{where} (surface {n!r}): {err}") from None
    if rough.into:
        assert solid is not None
        _into_polygon(layer, solid, where, what)
    return layer


def _into_polygon(layer: PolygonRoughLayer, solid: np.ndarray, where: str, what: str) -> None:
    """Move a polygon layer into its (convex) solid by its thickness: the solid is clipped by
    the face's plane moved inward (:func:`score4.world.facets.clip_convex`), the layer's frame
    moved with it; the cells whose patch would overhang the cut (where a neighbouring face
    leans inward) stay flat."""
    target, t = layer.target, layer.thickness
    n = target.rotation.T @ layer.frame.normal
    top = float(n @ target.to_local(layer.frame.centre[None])[0])
    extent = top - float((solid.reshape(-1, 3) @ n).min())
    if t >= extent:
        raise ConfigError(
            f"{where}: into: the layer ({t * 1e3:.4g} um) is not thinner than "
            f"{target.name!r} ({extent * 1e3:.4g} um along the normal of {what})"
        )
    layer.frame = layer.frame.shifted(-t)
    cap = section(solid, n, top - t)  # the solid's cut, where the patches' base lies
    local = layer.frame.to_local(target.to_world(cap.reshape(-1, 3))).reshape(-1, 3, 3)
    scale = max(float(np.abs(layer.outline).max()), 1.0)
    assert layer.mask is not None
    centres = layer.patch_map.cell_centres()
    cap2d = ccw(local[..., :2])
    layer.mask = layer.mask & cells_inside(cap2d, centres, layer.patch_size, 1e-9 * scale)
    layer.base_outline = ccw(clip_to_convex(layer.outline, cap2d))  # the flat rest lies there
    if not layer.mask.any():
        raise ConfigError(f"{where}: into: no whole patch fits on the cut below {what}")


#: solids swept around z whose faces ``into`` layers cut along their normals (not a polyhedra's
#: planes)
SWEPT_INTO = ("G4Tubs", "G4Cons", "G4Polycone", "G4GenericPolycone")


def check_into_edges(scene: Scene, target: TargetVolume, where: str | None = None) -> None:
    """Lay out the ``into`` layers of a solid swept around z on their joint cut
    (:func:`joint_layout`): faces that share an edge (a circle of the contour's corner) each
    end where the other's cut begins. With a phi segment ``into`` on two faces that share an
    edge is refused (on a boolean's constituents:
    :func:`score4.world.boolean_layers.into_joint`).
    Errors start with ``where`` (default ``targets.{entry}.rough``)."""
    where = where or f"targets.{target.entry}.rough"
    shape = target.shape
    layers = {r.config.face_name: r for r in scene.layers_of(target.name) if r.config.into}
    if not layers or not isinstance(shape, RevolvedShape) or shape.kind not in SWEPT_INTO:
        return
    if shape.full_phi:
        new = joint_layout(target, layers, where)
        for name, old in layers.items():
            if new[name] is not old:
                scene.layers[scene.layers.index(old)] = new[name]
        return
    edge = shared_edge(shape, layers)
    if edge is not None:
        name, other, r, z = edge
        raise shared_edge_error(
            where,
            (name, other),
            target.name,
            f"which share an edge ({edge_circle(r, z)}), on a {shape.kind} with a phi segment",
            "on a full circle only",
        )


def shared_edge(
    shape: RevolvedShape, faces: Collection[str]
) -> tuple[str, str, float, float] | None:
    """The first two of ``faces`` that meet along the contour of ``shape`` (a solid swept around
    z), with the edge's circle (r, z in mm, the solid's frame); None if no two of them meet."""
    poly, names = shape.contour()
    for k, name in enumerate(names):
        other = names[(k + 1) % len(names)]
        if name in faces and other in faces:
            r, z = poly[(k + 1) % len(poly)]
            return name, other, float(r), float(z)
    return None


def edge_circle(r: float, z: float) -> str:
    """An edge of a solid swept around z, in words: the circle of radius ``r`` at ``z`` (mm)."""
    return f"the circle r = {r:.4g} mm at z = {z:.4g} mm"


def shared_edge_error(
    where: str, faces: tuple[str, str], volume: str, shared: str, only: str
) -> ConfigError:
    """The one-line refusal of ``into`` on two ``faces`` of ``volume`` that share an edge:
    ``shared`` says how they share it, ``only`` on which solids score4 cuts such faces together
    (:func:`check_into_edges`, :func:`score4.world.boolean_modes.joint_leaves`)."""
    a, b = faces
    return ConfigError(
        f"{where}: into: true on faces {a} and {b} of {volume!r}, {shared}: score4 cuts such "
        f"faces together {only}; put one of them outside the volume (into: false)"
    )


def joint_layout(
    target: TargetVolume,
    layers: dict[str, RoughLayer],
    where: str,
    fixed: dict[str, float] | None = None,
) -> dict[str, RoughLayer]:
    """``into`` layers of a full solid swept around z (by face name) laid out on the joint cut
    (every into face moved inward by its layer's thickness,
    :func:`~score4.shapes.revolved.offset_contour`; the solid Geant4 gets,
    :func:`score4.geometry.built.cut_for_layers`); ``fixed``: further faces of the solid moved
    by given depths (< 0: outward; a constituent of a union grown down into another part's cut,
    :func:`score4.world.boolean_modes.standing_cuts`), which the layers' faces end on. Returns
    the layers by face name: a wall's layer laid out again, a ring's narrowed in place.

    A wall's layer is laid out again on its face of the joint cut, which ends where its
    neighbours' moved lines meet it (until the walls' thicknesses settle). A flat ring's layer
    lies on the cut plane; its envelope is the ring the solid fills over the whole slab (the
    face's radii, less where a slanting neighbour narrows the solid within the slab), its cells
    lie in that ring and in the joint cut's face, and its flat rest on the joint cut's face
    (``rest_radii``). The old volume between two layers at a shared edge (the cut of one face x
    the other's) belongs to neither: it is cut away, like the space between the patches' tips."""
    shape = target.shape
    assert isinstance(shape, RevolvedShape)
    layers = dict(layers)
    cuts = {**(fixed or {}), **{name: layer.thickness for name, layer in layers.items()}}
    walls = [n for n, layer in layers.items() if isinstance(layer, CurvedRoughLayer)]
    if len(cuts) > 1 and walls:
        for _ in range(4):
            settled = True
            for name in walls:
                old = layers[name]
                face = shape.face(name)
                assert isinstance(old, CurvedRoughLayer)
                assert isinstance(face, RevolvedFace)
                others = {k: v for k, v in cuts.items() if k != name}
                new = _into_revolved(
                    target, old.config, face, old.names, old.variants, old.patch_size, where, others
                )
                layers[name] = new
                if abs(new.thickness - cuts[name]) > 1e-12:
                    settled = False
                cuts[name] = new.thickness
            if settled:
                break
        else:
            raise ConfigError(
                f"{where}: into: the layers on faces {', '.join(layers)} of {target.name!r} do "
                "not settle on a joint cut"
            )
    for name, ring in layers.items():
        if not isinstance(ring, RingRoughLayer):
            continue
        face = target.face(name)
        assert isinstance(face, AnnulusFace)
        try:
            own, joint = shape.cut_face(name, {name: cuts[name]}), shape.cut_face(name, cuts)
        except ConfigError as err:
            raise ConfigError(
                f"{where}: into: the layer ({cuts[name] * 1e3:.4g} um) on face {name} of "
                f"{target.name!r}: {err}"
            ) from None
        rmin = max(face.rmin, min(own.r1, own.r2))  # where the solid fills the whole slab
        rmax = min(face.rmax, max(own.r1, own.r2))
        rest = (min(joint.r1, joint.r2), max(joint.r1, joint.r2))
        lo, hi = max(rmin, rest[0]), min(rmax, rest[1])
        cells = AnnulusFace.make(name, [lo, max(lo, hi)], 0.0, 1.0, 0.0, 2 * np.pi)
        assert ring.mask is not None  # a round face
        ring.mask = ring.mask & cells.covers(ring.patch_map.cell_centres(), ring.patch_size)
        ring.rmin, ring.rmax = rmin, rmax
        if rest != (face.rmin, face.rmax):
            ring.rest_radii = rest
        if not ring.mask.any():
            raise ConfigError(
                f"{where}: into: no whole patch fits on face {name} of {target.name!r} within "
                f"the ring r = {lo:.4g} .. {hi:.4g} mm its cut and its neighbours' leave"
            )
    return layers


def _trimmable(target: TargetVolume, face: str) -> bool:
    """The target's solid is cut for an ``into`` layer on ``face`` by a thinner solid of its own
    type (a box, a tube's end face: :meth:`Shape.trimmed`)."""
    return target.shape is not None and target.shape.trimmed({face: 0.0}) is not None


def _rough_patch_map(extent, size, rough: RoughFace, context: str) -> PatchMap:
    """The patch map of ``rough`` over ``extent`` (mm); its errors name ``context``."""
    try:
        return make_patch_map(
            extent,
            size,
            [v.density for v in rough.variant_list],
            method=rough.fill,
            seed=rough.seed,
            n_tiles=rough.n_tiles,
        )
    except ConfigError as err:
        raise ConfigError(f"{context}: {err}") from None
