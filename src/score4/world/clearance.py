"""Clearance checks of a run's targets and rough layers (numpy, no Geant4).

* A generated world: targets (boxes) must not overlap, and a rough layer (its envelope: the face
  extruded by the layer thickness) must not run into another target or layer.
* A GDML world: a rough layer must not meet any other daughter of its volume's mother (the
  volume's sisters, boxes of the configuration, other layers) and must stay inside the mother;
  boxes of the configuration likewise. Against a flat layer, boxes are tested exactly
  (oriented boxes, separating axes), other solids (their bounding box where score4.shapes does
  not describe them) by a grid of points of the envelope, then by a certified search of its
  box (:func:`flat_meet`). A curved layer is tested against everything by a certified search
  of its shell (:func:`certified_meet`). Both go down to a tenth of the layer. Errors name what
  the layer meets and the free gap along the face normal.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass, replace
from functools import lru_cache

import numpy as np

from score4.errors import ConfigError
from score4.shapes import Shape, shape_from_dict
from score4.shapes.csg import G4Orb, G4Sphere, _Hexahedron
from score4.shapes.faces import SphereFace
from score4.shapes.revolved import RevolvedShape, _PolyhedraBase

from .facets import boundary_edges, point_in_triangles
from .gdml_model import GeometryModel, Instance
from .obb import OrientedBox
from .scene import (
    BOUNDARY_TOLERANCE,
    CurvedRoughLayer,
    PolygonRoughLayer,
    RingRoughLayer,
    RoughLayer,
    Scene,
    TargetVolume,
    layer_aabb,
    shape_contains,
    target_aabb,
    target_obb,
    wall_envelope,
)


def _overlap(a: tuple[np.ndarray, np.ndarray], b: tuple[np.ndarray, np.ndarray]) -> bool:
    """Boxes share volume (touching faces are fine)."""
    return bool(np.all(np.minimum(a[1], b[1]) - np.maximum(a[0], b[0]) > BOUNDARY_TOLERANCE))


def check_clearance(scene: Scene) -> None:
    """Refuse targets that overlap, and rough layers that run into another target or rough layer."""
    if scene.model is not None:
        check_gdml_clearance(scene)
        return
    boxes = {t.name: target_aabb(t) for t in scene.targets}
    names = list(boxes)
    for a, name in enumerate(names):
        for other in names[a + 1 :]:
            if _overlap(boxes[name], boxes[other]):
                raise ConfigError(
                    f"targets: {name!r} and {other!r} overlap; Geant4 needs volumes that do not "
                    "overlap"
                )
    layers = [(layer, layer_aabb(layer)) for layer in scene.layers]
    for n, (layer, box) in enumerate(layers):
        others = [(f"target {name!r}", b) for name, b in boxes.items() if name != layer.target.name]
        others += [(f"the rough layer {o.name}", ob) for o, ob in layers[n + 1 :]]
        for what, other_box in others:
            if _overlap(box, other_box):
                axis = int(np.argmax(np.abs(layer.frame.normal)))
                gap = (
                    (other_box[0][axis] - box[0][axis])
                    if layer.frame.normal[axis] > 0
                    else (box[1][axis] - other_box[1][axis])
                )
                raise ConfigError(_meets(layer, what, gap))


def _meets(layer: RoughLayer, what: str, gap: float) -> str:
    return (
        f"{layer.name}: the rough layer on face {layer.config.face_name} of "
        f"{layer.target.name!r} is {layer.thickness * 1e3:.4g} um thick (base "
        f"{layer.base_thickness * 1e3:.4g} um + highest tip) and runs into {what} "
        f"(free gap there: {max(gap, 0.0) * 1e3:.4g} um); move the volumes apart, use a lower "
        "surface"
        + (
            " or into: true (the layer inside the volume)"
            if not layer.config.into
            else " (into: the layers of two faces that share an edge meet below it)"
        )
    )


@dataclass(frozen=True)
class _Body:
    """A solid in some mother, for the clearance checks of a GDML world."""

    label: str
    obb: OrientedBox
    to_local: object  # world -> the solid's frame
    lo: np.ndarray
    hi: np.ndarray
    shape: Shape | None = None  # the solid as score4.shapes describes it (None: not described)
    axis: tuple[np.ndarray, np.ndarray] | None = (
        None  # its z axis in the world (a point, a direction)
    )

    @property
    def box_like(self) -> bool:
        """The solid is its oriented bounding box (a box)."""
        return self.shape is not None and self.shape.box_like

    def meets(self, box: OrientedBox) -> bool:
        if not self.obb.overlaps(box):
            return False
        if self.box_like:
            return True  # the bounding box is the solid
        q = self.to_local(box.grid())  # type: ignore[operator]
        return bool(self.contains(q, touching=False).any())

    def contains(self, q: np.ndarray, touching: bool = True) -> np.ndarray:
        """Points (the solid's frame) in the solid: exact for every solid score4.shapes
        describes (a frame: a box less a box), else its bounding box. ``touching=False``:
        points on the surface of a shape do not count (a layer may touch a sister)."""
        return shape_contains(self.shape, self.lo, self.hi, q, touching)

    def signed(self, world: np.ndarray) -> np.ndarray:
        """Signed distance of world points to the solid (negative inside): the shape's
        (:meth:`score4.shapes.Shape.signed_distance`, which changes by no more than the distance
        a point moves), else the bounding box's."""
        local = self.to_local(np.asarray(world, float).reshape(-1, 3))  # type: ignore[operator]
        q = np.asarray(local, dtype=np.float64)
        if self.shape is not None:
            return np.asarray(self.shape.signed_distance(q))
        return np.asarray(np.maximum(self.lo - q, q - self.hi).max(axis=1))

    def round_about(self, axis: tuple[np.ndarray, np.ndarray]) -> bool:
        """The solid is round about ``axis`` (a full solid of revolution, a sphere, on it)."""
        return self.axis is not None and _round_shape(self.shape) and _same_axis(self.axis, axis)

    def probe_points(self, box: OrientedBox) -> np.ndarray:
        """Points of ``box`` whose containment in this solid tells whether the whole box is
        in it: the corners for a box, a grid otherwise."""
        return box.corners() if self.box_like else box.grid()


def _instance_body(model: GeometryModel, inst: Instance, label: str | None = None) -> _Body:
    lv = model.logicals[inst.logical]
    lo, hi = np.asarray(lv.solid["lo"], float), np.asarray(lv.solid["hi"], float)
    obb = OrientedBox(inst.to_world((lo + hi) / 2), inst.rotation, (hi - lo) / 2)
    data = lv.solid.get("shape")
    return _Body(
        label or f"volume {model.label(inst)!r}",
        obb,
        inst.to_local,
        lo,
        hi,
        _shape(data) if data else None,
        _axis(inst),
    )


def _affine(f: Callable[[np.ndarray], np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """``(A, b)`` of an affine map of points: ``f(p) = p @ A.T + b``."""
    b = np.asarray(f(np.zeros((1, 3))), float)[0]
    a = np.asarray(f(np.eye(3)), float) - b
    return a.T, b


def _planes_in(body: _Body, target: TargetVolume) -> tuple[np.ndarray, np.ndarray] | None:
    """The body's depth (minus its signed distance) as the least of affine functions
    ``c + m . p`` of points ``p`` in ``target``'s frame, ``(m, c)``: for a solid of planes (a
    box, a trapezoid; an undescribed solid's bounding box), else None."""
    if body.shape is None:
        lo, hi = body.lo, body.hi
        normals = np.concatenate([np.eye(3), -np.eye(3)])
        offsets = np.concatenate([hi, -lo])
    elif isinstance(body.shape, _Hexahedron):
        normals, offsets = body.shape._planes()  # n . q <= h inside (unit normals)
    else:
        return None
    # q = M p + k: the target's frame to the body's
    (rt, tt), (ab, bb) = _affine(target.to_world), _affine(body.to_local)  # type: ignore[arg-type]
    m_q, k = ab @ rt, ab @ tt + bb
    # depth = min (h - n . q) = min (h - n . k - (n M) . p)
    return -(normals @ m_q), offsets - normals @ k


def _layer_planes(other: RoughLayer, target: TargetVolume) -> tuple[np.ndarray, np.ndarray] | None:
    """Planes ``(m, c)`` (as :func:`_planes_in`, in ``target``'s frame) whose least bounds a flat
    layer's depth (:func:`_depth`) from above: its box's six for a box envelope, the two of its
    slab (the face and its offset) for a prism or a ring; None for a curved layer."""
    if isinstance(other, CurvedRoughLayer):
        return None
    rt, tt = _affine(target.to_world)
    if _shaped(other):  # depth <= the height above the face, and below its offset
        a, b = _affine(other.frame.to_local)
        normals, offsets = np.array([[0.0, 0.0, -1.0], [0.0, 0.0, 1.0]]), np.array([0.0, 1.0])
        offsets[1] = other.thickness
    else:
        box = other.envelope_box()
        a, b = _affine(box.transform.inverse_apply)
        normals = np.concatenate([np.eye(3), -np.eye(3)])
        offsets = np.concatenate([box.half, box.half])
    m_q, k = a @ rt, a @ tt + b
    return -(normals @ m_q), offsets - normals @ k


def _round_shape(shape: Shape | None) -> bool:
    """The shape is round about its z axis: a full tube, cone or polycone, a sphere over the
    full circle, an orb."""
    if isinstance(shape, RevolvedShape) and not isinstance(shape, _PolyhedraBase):
        return shape.full_phi
    if isinstance(shape, G4Sphere):
        return bool(shape.dphi >= 2 * np.pi)
    return isinstance(shape, G4Orb)


@lru_cache(maxsize=256)
def _shape_of(text: str) -> Shape:
    return shape_from_dict(json.loads(text))


def _shape(data: dict) -> Shape:
    """The shape of a model's solid record (cached: a world places one solid many times)."""
    return _shape_of(json.dumps(data, sort_keys=True))


def _target_body(t: TargetVolume) -> _Body:
    return _Body(f"target {t.name!r}", target_obb(t), t.to_local, t.lo, t.hi, t.shape, _axis(t))


def check_gdml_clearance(scene: Scene) -> None:
    """Rough layers and boxes of a GDML world against their sisters and their mother.

    A layer on a face (outside the volume) must not meet any other daughter of the volume's
    mother (other GDML volumes, boxes of the configuration, other layers) and must stay inside
    the mother. For a flat layer, boxes are tested exactly (oriented boxes), other solids by
    :func:`_sister_meets`; a curved layer by :func:`_check_curved`.
    """
    model = scene.model
    assert model is not None
    for t in scene.targets:
        if t.instance is not None:
            continue
        assert t.mother is not None
        box = target_obb(t)
        for inst in model.children.get(t.mother.index, []):
            body = _instance_body(model, model.instances[inst])
            if body.meets(box):
                raise ConfigError(
                    f"targets.{t.entry}: box {t.name!r} overlaps {body.label} in "
                    f"{model.label(t.mother)!r}; Geant4 needs volumes that do not overlap"
                )
        mother_body = _instance_body(model, t.mother)
        pts = mother_body.probe_points(box)
        if not mother_body.contains(t.mother.to_local(pts)).all():
            raise ConfigError(
                f"targets.{t.entry}: box {t.name!r} sticks out of its mother "
                f"{model.label(t.mother)!r}; position is in the mother's frame"
            )
    layers = [(layer, layer.envelope_box()) for layer in scene.layers]
    for n, (layer, box) in enumerate(layers):
        if isinstance(layer, CurvedRoughLayer):
            _check_curved(model, scene, layer, [o for o, _ in layers[n + 1 :]])
            continue
        mother = layer.target.mother
        assert mother is not None  # in a GDML world every target has a mother (the world at least)
        own = layer.target.instance.index if layer.target.instance is not None else -1
        if _shaped(layer) and not layer.config.into:
            # (into: the layer is in the slab the solid is cut or clipped by)
            own_body = _target_body(layer.target)
            if _layer_meets(own_body, layer, box):  # a concave edge of its own solid
                raise ConfigError(_meets(layer, f"its own volume {layer.target.name!r}", 0.0))
        for inst in model.children.get(mother.index, []):
            if inst == own:
                continue
            body = _instance_body(model, model.instances[inst], None)
            gap = _sister_meets(body, layer, box)
            if gap is not None:
                raise ConfigError(_meets(layer, f"sister {body.label}", gap))
        for t in scene.targets:
            if t is layer.target or t.instance is not None or t.mother != mother:
                continue
            body = _target_body(t)
            gap = _sister_meets(body, layer, box)
            if gap is not None:
                raise ConfigError(_meets(layer, body.label, gap))
        for other, other_box in layers[n + 1 :]:
            if other.target.mother != mother:
                continue
            if isinstance(other, CurvedRoughLayer):
                hit = None
                if not other.in_shell(_envelope_points(layer, box)).any():
                    hit = shells_meet(other, layer) if other.envelope_box().overlaps(box) else None
                    if hit is None:
                        continue
                gap = _pair_gap(layer, other) if hit is None else _gap_under(other, layer, hit)
                raise ConfigError(_meets(layer, f"the rough layer {other.name}", gap))
            if _shaped(layer) or _shaped(other):
                met = other_box.overlaps(box) and bool(
                    _in_envelope(other, other_box, _envelope_points(layer, box)).any()
                    or _in_envelope(layer, box, _envelope_points(other, other_box)).any()
                )
            else:
                met = other_box.overlaps(box)
            if met:
                raise ConfigError(
                    _meets(layer, f"the rough layer {other.name}", _pair_gap(layer, other))
                )
        _check_inside_mother(model, mother, layer, box)


#: Flat layers whose envelope is not their box: a polygon's prism, a ring.
_SHAPED = (PolygonRoughLayer, RingRoughLayer)


def _shaped(layer: RoughLayer) -> bool:
    """A flat layer whose envelope is not its box: a polygon's prism, a ring, or the prism of
    its kept cells (``cells_envelope``)."""
    return isinstance(layer, _SHAPED) or layer.cells_envelope


def _envelope_points(layer: RoughLayer, box: OrientedBox) -> np.ndarray:
    """Points of a flat layer's envelope: its prism's for a polygon face, its ring's for a
    round face, else its box's grid."""
    return layer.envelope_points() if _shaped(layer) else box.grid()


def _in_envelope(layer: RoughLayer, box: OrientedBox, points: np.ndarray) -> np.ndarray:
    """True for world points strictly inside a flat layer's envelope."""
    if _shaped(layer):
        return layer.in_envelope(points)
    return box.contains(points)


def _points_of(layer: RoughLayer) -> np.ndarray:
    """World points of a layer's envelope (its shell on a curved face)."""
    if isinstance(layer, CurvedRoughLayer):
        return layer.shell_points()
    return _envelope_points(layer, layer.envelope_box())


def _inside(layer: RoughLayer, points: np.ndarray) -> np.ndarray:
    """World points strictly inside a layer's envelope (its shell on a curved face)."""
    if isinstance(layer, CurvedRoughLayer):
        return layer.in_shell(points)
    return _in_envelope(layer, layer.envelope_box(), points)


def _height(layer: RoughLayer, points: np.ndarray) -> np.ndarray:
    """Height of world points above the layer's face, along its normal."""
    if isinstance(layer, CurvedRoughLayer):
        return layer.ring_layout.face.locate(layer.target.to_local(points))[2]
    return layer.frame.to_local(points)[:, 2]


def _pair_gap(layer: RoughLayer, other: RoughLayer) -> float:
    """The free gap between ``layer``'s face and the envelope of ``other`` where they meet: the
    least height above the face of a point of ``other``'s envelope inside ``layer``'s."""
    pts = _points_of(other)
    hit = _inside(layer, pts)
    if not hit.any():
        return 0.0
    return max(float(_height(layer, pts[hit]).min()), 0.0)


def _layer_meets(body: _Body, layer: RoughLayer, box: OrientedBox) -> bool:
    """The layer's envelope (a box, the prism of a polygon face or a ring) meets ``body``."""
    if not _shaped(layer):
        return body.meets(box)
    if not body.obb.overlaps(box):
        return False
    q = body.to_local(layer.envelope_points())  # type: ignore[operator]
    return bool(body.contains(q, touching=False).any())


def _world_planes(body: _Body) -> tuple[np.ndarray, np.ndarray]:
    """Planes ``(m, c)`` on world points ``p`` whose least ``c + m . p`` bounds ``body``'s depth
    (minus its signed distance) from above: a solid of planes' own (a box, a trapezoid), else
    the faces of its bounding box (every solid lies in it, so its depth is no more than the
    box's)."""
    if isinstance(body.shape, _Hexahedron):
        normals, offsets = body.shape._planes()  # n . q <= h inside (unit normals)
    else:
        normals = np.concatenate([np.eye(3), -np.eye(3)])
        offsets = np.concatenate([body.hi, -body.lo])
    a, b = _affine(body.to_local)  # type: ignore[arg-type]
    return -(normals @ a), offsets - normals @ b


def flat_meet(
    layer: RoughLayer,
    depth: Depth,
    resolution: float,
    what: str,
    tol: float = BOUNDARY_TOLERANCE,
    planes: tuple[np.ndarray, np.ndarray] | None = None,
) -> np.ndarray | None:
    """A world point of a flat layer's envelope where ``depth`` (how deep world points lie in
    something else: positive inside, changing by no more than the distance a point moves)
    exceeds ``tol``, or None when there is none deeper than ``tol + resolution``: the search of
    :func:`certified_meet` on the cells of the envelope's box (its own frame: three orthogonal
    sides, so no point of a cell is further from its centre than half its diagonal). A prism
    or a ring envelope is searched in its box on the least of ``depth`` and the envelope's own
    (:func:`_depth`). ``planes`` (``(m, c)`` on world points, :func:`_world_planes`): ``depth``
    is no more than the least of ``c + m . p``, bounded exactly over each cell (at a corner),
    which drops the cells along a plane the envelope touches (a solid standing on the layer).
    The prism of a layer's kept cells is searched in those cells' columns
    (:func:`_kept_runs`)."""
    box = layer.envelope_box()
    shaped = _shaped(layer)
    half, to_world = box.half, box.transform

    if planes is not None:  # in the box's frame: p = R q + centre
        m_world, c_world = planes
        m_box = m_world @ to_world.rotation
        c_box = c_world + m_world @ to_world.translation
    resolution = max(resolution, 1e-7)
    if layer.cells_envelope:  # the kept cells' columns, a run of them along a row at a time
        lo, hi = _kept_runs(layer, float(half[2]))
        shaped = False  # (the cells are the envelope: no point outside it is searched)
    else:
        side = max(float(half.max()) / 32, float(half[2]) * 2, 1e-7)  # at most 64 a side
        n = np.clip(np.ceil(2 * half / side), 1, 64).astype(int)
        edges = [np.linspace(-h, h, k + 1) for h, k in zip(half, n, strict=True)]
        idx = [g.ravel() for g in np.meshgrid(*(np.arange(k) for k in n), indexing="ij")]
        lo = np.column_stack([e[i] for e, i in zip(edges, idx, strict=True)])
        hi = np.column_stack([e[i + 1] for e, i in zip(edges, idx, strict=True)])
    while len(lo):
        mid = 0.5 * (lo + hi)
        world = to_world.apply(mid)
        d = np.array(depth(world), dtype=float)
        size = hi - lo
        reach = 0.5 * np.linalg.norm(size, axis=1)
        if shaped:  # (the envelope's own depth only where the other's keeps the cell)
            near = np.flatnonzero(d + reach > tol)
            d[near] = np.minimum(d[near], _depth(layer, world[near]))
        deep = np.flatnonzero(d > tol)
        if len(deep):
            return np.asarray(world[deep[np.argmax(d[deep])]])
        open_ = (d + reach > tol) & (reach > resolution)
        if planes is not None and open_.any():
            keep = np.flatnonzero(open_)
            bound = c_box[None, :] + mid[keep] @ m_box.T + (0.5 * size[keep]) @ np.abs(m_box).T
            open_[keep[bound.min(axis=1) <= tol]] = False
        lo, hi, size = lo[open_], hi[open_], size[open_]
        if len(lo) > MAX_CELLS // 2:
            raise ConfigError(
                f"{layer.name}: the clearance check against {what} needs more than "
                f"{MAX_CELLS} cells (the two touch over a large area); move them apart "
                "by a micrometre"
            )
        rows = np.arange(len(lo))
        axis = np.argmax(size, axis=1)
        cut = 0.5 * (lo[rows, axis] + hi[rows, axis])
        lo2, hi2 = lo.copy(), hi.copy()
        hi[rows, axis] = cut
        lo2[rows, axis] = cut
        lo, hi = np.concatenate([lo, lo2]), np.concatenate([hi, hi2])
    return None


def _kept_runs(layer: RoughLayer, half_height: float) -> tuple[np.ndarray, np.ndarray]:
    """The prism of a layer's kept cells (``cells_envelope``) as boxes ``(lo, hi)`` in its
    envelope box's frame (the layer's frame, centred on its height): one per run of kept cells
    along a row of the grid, the layer's thickness high."""
    x, y = layer.cell_edges()
    step = np.diff(np.pad(layer.cell_variants >= 0, ((0, 0), (1, 1))).astype(np.int8), axis=1)
    rows, first = np.nonzero(step == 1)  # (row-major: the ends pair with the starts in order)
    _, end = np.nonzero(step == -1)
    h = np.full(len(rows), half_height)
    lo = np.column_stack([x[first], y[rows], -h])
    hi = np.column_stack([x[end], y[rows + 1], h])
    return lo, hi


#: The pattern search's moves over a flat face: along its axes and its diagonals (a solid of
#: planes' tip has square level sets, on whose diagonal no move along an axis gets lower).
_MOVES = np.array([[1.0, 0], [-1, 0], [0, 1], [0, -1], [1, 1], [1, -1], [-1, 1], [-1, -1]])


def _flat_gap(layer: RoughLayer, depth: Depth, point: np.ndarray) -> float:
    """Height above a flat layer's face, along its normal, where ``depth`` (of what the layer
    meets) turns above the boundary tolerance: bisected under ``point`` (a point of the envelope
    inside), then made least about it by a pattern search over the face (steps along its axes
    and diagonals, halved down to a nanometre), as :func:`_least_gap` on a curved face (mm)."""
    frame = layer.frame
    x, y, h_in = (float(c) for c in frame.to_local(point[None, :])[0])
    h_in = min(max(h_in, 0.0), layer.thickness)
    tol = BOUNDARY_TOLERANCE

    def gaps(xy: np.ndarray) -> np.ndarray:
        def inside(h: np.ndarray) -> np.ndarray:
            return depth(frame.to_world(np.column_stack([xy, h]))) > tol

        return _entry_height(inside, len(xy), h_in)

    best = float(gaps(np.array([[x, y]]))[0])
    if not np.isfinite(best):
        return h_in
    return _descend(gaps, np.array([x, y]), best, 10 * layer.thickness, lambda step: step * _MOVES)


def _sister_meets(body: _Body, layer: RoughLayer, box: OrientedBox) -> float | None:
    """The free gap (mm) when a flat layer's envelope meets ``body``, else None: by the grid
    of points (:func:`_layer_meets`, the gap by :func:`_gap`), then, for a solid that is not
    its bounding box or an envelope that is not a box, by the certified search
    (:func:`flat_meet`) on the solid's signed distance, bounded by its planes (the gap under
    the point found, :func:`_flat_gap`)."""
    if _layer_meets(body, layer, box):
        return _gap(layer, body)
    if not body.obb.overlaps(box) or (body.box_like and not _shaped(layer)):
        return None  # (two boxes: the separating axes are exact)

    def depth(world: np.ndarray) -> np.ndarray:
        return -body.signed(world)

    found = flat_meet(
        layer,
        depth,
        RESOLUTION_SHARE * layer.thickness,
        body.label,
        planes=_world_planes(body),
    )
    return None if found is None else _flat_gap(layer, depth, found)


def _round_cover(shape: Shape | None, axis: tuple[np.ndarray, np.ndarray]) -> Depth | None:
    """An upper bound of how deep points (the shape's frame) lie in ``shape`` that is the same
    at every azimuth about ``axis`` (a point and a direction in that frame), or None: the depth
    of a round solid about it that holds the shape (the shape itself; a tube, cone, polycone or
    sphere over part of the circle: the same over the full circle), or for a boolean the least
    of its parts' (a subtraction: of the first part and of the outside of a round second part;
    an intersection: of either part). A solid round about the axis of a curved layer that it
    holds is searched on one half-plane (:func:`certified_meet` with ``coaxial``): when that
    finds nothing, the solid cannot meet the layer either."""
    from score4.shapes.boolean import BooleanShape
    from score4.shapes.placed import PlacedShape

    if shape is None:
        return None
    if isinstance(shape, PlacedShape):
        inner = shape.transform
        bound = _round_cover(shape.shape, _axis_through(inner, axis))
        return None if bound is None else (lambda q: bound(inner.inverse_apply(q)))
    if isinstance(shape, BooleanShape):
        first = _round_cover(shape.first, axis)
        moved = shape.transform
        second_axis = _axis_through(moved, axis)
        parts: list[Depth] = [] if first is None else [first]
        if shape.operation == "subtraction":
            if _round_shape(shape.second) and _same_axis(second_axis, _Z_AXIS):
                second = shape.second
                parts.append(lambda q: np.asarray(second.signed_distance(moved.inverse_apply(q))))
        elif shape.operation == "intersection":
            other = _round_cover(shape.second, second_axis)
            if other is not None:
                parts.append(lambda q: other(moved.inverse_apply(q)))
        else:
            return None  # (a union: deeper than either part)
        if not parts:
            return None
        return lambda q: np.asarray(np.minimum.reduce([f(q) for f in parts]))
    if not _same_axis(axis, _Z_AXIS):
        return None
    full = shape
    if (isinstance(shape, RevolvedShape) and not isinstance(shape, _PolyhedraBase)) or isinstance(
        shape, G4Sphere
    ):
        full = replace(shape, sphi=0.0, dphi=2 * np.pi)  # type: ignore[type-var]
    if _round_shape(full):
        return lambda q: -np.asarray(full.signed_distance(q))
    return None


#: A solid's own z axis (a point, a direction) in its frame.
_Z_AXIS = (np.zeros(3), np.array([0.0, 0.0, 1.0]))


def _axis_through(t: object, axis: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """``axis`` in the frame of a part placed by transform ``t`` (its frame to the outer one)."""
    point = t.inverse_apply(axis[0][None, :])[0]  # type: ignore[attr-defined]
    return point, np.asarray(axis[1] @ t.rotation, float)  # type: ignore[attr-defined]


def _round_clear(layer: CurvedRoughLayer, body: _Body, resolution: float, what: str) -> bool:
    """True when a round solid about the layer's axis that holds ``body``'s
    (:func:`_round_cover`) is proven clear of the layer by the half-plane search: then so is
    the body (no point of it deeper than the boundary tolerance and the resolution)."""
    axis = _axis(layer.target)
    if body.shape is None or body.round_about(axis):
        return False  # (a round solid: searched on the half-plane as it is)
    a, b = _affine(body.to_local)  # type: ignore[arg-type]
    bound = _round_cover(body.shape, (a @ axis[0] + b, a @ axis[1]))
    if bound is None:
        return False

    def depth(world: np.ndarray) -> np.ndarray:
        return np.asarray(bound(body.to_local(world)))  # type: ignore[operator]

    return certified_meet(layer, depth, resolution, what, coaxial=True) is None


def _check_curved(
    model: GeometryModel, scene: Scene, layer: CurvedRoughLayer, others: list[RoughLayer]
) -> None:
    """A bent layer against the sisters of its volume, boxes and layers in the same mother, and
    its mother: first by a grid of points of its shell, then by the certified search
    (:func:`certified_meet`) on the signed distance of each solid; the gap is the height above
    the face where the solid begins, least near the point found (:func:`_least_gap`)."""
    mother = layer.target.mother
    assert mother is not None
    points = layer.shell_points()
    height = layer.ring_layout.face.distance(layer.target.to_local(points))
    own = layer.target.instance.index if layer.target.instance is not None else -1
    bodies = [
        _instance_body(model, model.instances[i])
        for i in model.children.get(mother.index, [])
        if i != own
    ]
    bodies += [
        _target_body(t)
        for t in scene.targets
        if t is not layer.target and t.instance is None and t.mother == mother
    ]
    axis = _axis(layer.target)
    resolution = RESOLUTION_SHARE * layer.thickness
    envelope = layer.envelope_box()
    for body in bodies:
        what = body.label if body.label.startswith("target") else f"sister {body.label}"
        hit = body.contains(body.to_local(points), touching=False)  # type: ignore[operator]
        if hit.any():
            k = np.flatnonzero(hit)[np.argmin(height[hit])]
            found: np.ndarray | None = points[k]
        elif body.obb.overlaps(envelope) and not _round_clear(layer, body, resolution, what):
            found = certified_meet(  # between the grid's points
                layer,
                lambda world, body=body: -body.signed(world),  # type: ignore[misc]
                resolution,
                what,
                coaxial=body.round_about(axis),
                planes=_planes_in(body, layer.target),
            )
        else:
            found = None
        if found is not None:
            raise ConfigError(_meets(layer, what, _curved_gap(layer, body, found)))
    for other in others:
        if other.target.mother != mother:
            continue
        if isinstance(other, CurvedRoughLayer):
            meets = bool(other.in_shell(points).any() or layer.in_shell(other.shell_points()).any())
        else:
            box = other.envelope_box()
            meets = bool(_in_envelope(other, box, points).any()) or bool(
                layer.in_shell(_envelope_points(other, box)).any()
            )
        gap = None
        if not meets and layer.envelope_box().overlaps(other.envelope_box()):
            found = shells_meet(layer, other)  # exact, where the points are sparse
            meets = found is not None
            gap = None if found is None else _gap_under(layer, other, found)
        if meets:
            raise ConfigError(
                _meets(
                    layer,
                    f"the rough layer {other.name}",
                    _pair_gap(layer, other) if gap is None else gap,
                )
            )
    body = _instance_body(model, mother)
    out = not body.contains(mother.to_local(points)).all() or (
        certified_meet(
            layer,
            body.signed,
            resolution,
            f"its mother {model.label(mother)!r}",
            coaxial=body.round_about(axis),
        )
        is not None
    )
    if out:
        raise ConfigError(
            f"{layer.name}: the rough layer on face {layer.config.face_name} of "
            f"{layer.target.name!r} "
            f"({layer.thickness * 1e3:.4g} um thick) leaves its mother volume "
            f"{model.label(mother)!r}; use a lower surface"
        )


def _curved_gap(layer: CurvedRoughLayer, body: _Body, point: np.ndarray) -> float:
    """The free gap under a point of a curved layer's shell inside ``body``
    (:func:`_least_gap`)."""
    return _least_gap(layer, lambda world: -body.signed(world), point)


def _least_gap(
    layer: CurvedRoughLayer, depth: Depth, point: np.ndarray, tol: float = BOUNDARY_TOLERANCE
) -> float:
    """Height above a curved layer's face, along its normal, where ``depth`` (of what the
    layer meets) turns above ``tol``: bisected under ``point`` (a point of the shell inside),
    then made least about it by a pattern search over the face (steps along azimuth and
    generator, halved down to a nanometre), so the free gap is that of the closest approach
    near the point found (mm)."""
    face = layer.ring_layout.face
    (u0, u1), (v0, v1) = face.extent
    u, v, h_in = (float(x[0]) for x in face.locate(layer.target.to_local(point[None, :])))
    h_in = min(max(h_in, 0.0), layer.thickness * 2)

    def gaps(uv: np.ndarray) -> np.ndarray:
        """Gaps under face points (u, v) (inf where the point at h_in is not inside)."""
        uv = np.column_stack([np.clip(uv[:, 0], u0, u1), np.clip(uv[:, 1], v0, v1)])
        base, normal = face.point(uv[:, 0], uv[:, 1]), face.normal(uv[:, 0], uv[:, 1])

        def inside(h: np.ndarray) -> np.ndarray:
            return depth(layer.target.to_world(base + h[:, None] * normal)) > tol

        return _entry_height(inside, len(uv), h_in)

    best = float(gaps(np.array([[u, v]]))[0])
    if not np.isfinite(best):
        return h_in
    rho = max(float(np.hypot(*face.point(np.array([u]), np.array([v]))[0, :2])), 1e-9)

    def moves(step: float) -> np.ndarray:  # u is an angle: a step of arc length ``step``
        return np.array([[step / rho, 0.0], [-step / rho, 0.0], [0.0, step], [0.0, -step]])

    return _descend(gaps, np.array([u, v]), best, 10 * layer.thickness, moves)


def _gap(layer: RoughLayer, body: _Body) -> float:
    """Free space between the face and ``body``: along the face normal to its bounding box (a
    box), or the least distance from a grid of points of the face to its solid (a shape)."""
    if body.shape is not None and not body.box_like:
        return _shape_gap(layer, body)
    q = layer.frame.to_local(body.obb.corners())
    return float(q[:, 2].min())


def _shape_gap(layer: RoughLayer, body: _Body, n_face: int = 25, n_steps: int = 400) -> float:
    """Least distance along the face normal from a grid of points of the face to the solid of
    ``body`` (a shape), within the layer's thickness: marched in ``n_steps``, then bisected."""
    lu, lv = layer.frame.size
    u, v = np.meshgrid(np.linspace(-lu / 2, lu / 2, n_face), np.linspace(-lv / 2, lv / 2, n_face))
    face = np.column_stack([u.ravel(), v.ravel(), np.zeros(u.size)])
    steps = np.linspace(0.0, layer.thickness, n_steps + 1)

    def inside(local_face: np.ndarray, t: np.ndarray) -> np.ndarray:
        pts = layer.frame.to_world(local_face + t[:, None] * np.array([0.0, 0.0, 1.0]))
        return body.contains(body.to_local(pts), touching=False)  # type: ignore[operator]

    grid = inside(np.repeat(face, len(steps), axis=0), np.tile(steps, len(face)))
    hits = grid.reshape(len(face), len(steps))
    if not hits.any():
        return 0.0
    first = np.where(hits.any(axis=1), hits.argmax(axis=1), len(steps))
    k = int(np.argmin(first))
    if first[k] == 0:
        return 0.0
    lo, hi = steps[first[k] - 1], steps[first[k]]
    for _ in range(30):  # bisection on the first point that meets the solid
        mid = 0.5 * (lo + hi)
        if inside(face[k : k + 1], np.array([mid]))[0]:
            hi = mid
        else:
            lo = mid
    return float(hi)


def _check_inside_mother(
    model: GeometryModel, mother: Instance, layer: RoughLayer, box: OrientedBox
) -> None:
    lv = model.logicals[mother.logical]
    body = _instance_body(model, mother)
    pts = layer.envelope_points() if _shaped(layer) else body.probe_points(box)
    inside = body.contains(mother.to_local(pts))
    if not inside.all():
        raise ConfigError(
            f"{layer.name}: the rough layer on face {layer.config.face_name} of "
            f"{layer.target.name!r} "
            f"({layer.thickness * 1e3:.4g} um thick) leaves its mother volume "
            f"{model.label(mother)!r} ({lv.solid_type}); use into: true (the layer inside the "
            "volume) or a lower surface"
        )


def _depth(layer: RoughLayer, points: np.ndarray) -> np.ndarray:
    """How deep world points lie in a layer's envelope: positive inside, negative outside, and
    never more than the distance to the envelope's boundary (so it changes by at most the
    distance a point moves): the least of the signed distances to the surfaces that bound it
    (planes, the face and its offset, cones of normals or polar angle, half-planes of azimuth,
    cylinders of a ring, the edges of a polygon)."""
    p = np.asarray(points, float).reshape(-1, 3)
    t = layer.thickness
    if isinstance(layer, CurvedRoughLayer) and layer.pieces is not None:
        # the envelope's pieces lie apart: inside it, a point is inside one of them
        return np.asarray(np.max([_depth(v, p) for v in layer.envelope_views()], axis=0))
    if isinstance(layer, CurvedRoughLayer):
        face = layer.ring_layout.face
        q = layer.target.to_local(p)
        u, v, h = face.locate(q)
        (u0, _), (v0, v1) = face.extent
        depth = np.minimum(h, t - h)
        if layer._cone_envelope:  # the G4Cons between the z planes of the face's ends
            a1, b1, a2, b2, dz, zc = wall_envelope(layer)
            rho, z = np.hypot(q[:, 0], q[:, 1]), q[:, 2] - (zc - dz)

            def beyond(r1: float, r2: float) -> np.ndarray:  # signed distance past a line
                n = np.array([2 * dz, -(r2 - r1)]) / np.hypot(2 * dz, r2 - r1)
                return np.asarray(n[0] * (rho - r1) + n[1] * z)

            depth = np.minimum.reduce([z, 2 * dz - z, beyond(a1, a2), -beyond(b1, b2)])
        elif isinstance(face, SphereFace):
            r = np.linalg.norm(q, axis=1)
            a = np.clip((v - v0) / face.sphere_radius, -np.pi / 2, np.pi / 2)
            b = np.clip((v1 - v) / face.sphere_radius, -np.pi / 2, np.pi / 2)
            depth = np.minimum(depth, r * np.minimum(np.sin(a), np.sin(b)))
        else:
            depth = np.minimum(depth, np.minimum(v - v0, v1 - v))
        if face.dphi < 2 * np.pi - 1e-12:
            rho = np.hypot(q[:, 0], q[:, 1])
            a = u - u0  # in [0, 2 pi)
            half = np.pi / 2

            def far(x: np.ndarray) -> np.ndarray:
                return rho * np.sin(np.clip(x, 0.0, half))

            inside = a <= face.dphi
            wedge = np.where(
                inside,
                np.minimum(far(a), far(face.dphi - a)),
                -np.minimum(far(a - face.dphi), far(2 * np.pi - a)),
            )
            depth = np.minimum(depth, wedge)
        return np.asarray(depth)
    if layer.cells_envelope or isinstance(layer, PolygonRoughLayer):
        # a prism: of the kept cells of a boolean's face (a ring's too), or of the face's polygon
        q = layer.frame.to_local(p)
        if layer.cells_envelope:  # the kept cells' outline, read off the grid
            edges, inside = _cells_boundary(layer), _in_kept_cell(layer, q)
        else:
            assert isinstance(layer, PolygonRoughLayer)
            edges = boundary_edges(layer.outline)
            inside = point_in_triangles(q[:, :2], layer.outline, 0.0)
        a, b = edges[:, 0], edges[:, 1]
        d = b - a
        dd = np.maximum((d * d).sum(axis=1), 1e-300)
        gap = np.empty(len(q))
        block = max(1, 4_000_000 // max(len(edges), 1))  # points x edges per block
        for k in range(0, len(q), block):
            w = q[k : k + block, None, :2] - a[None]
            s = np.clip(np.einsum("nmc,mc->nm", w, d) / dd, 0, 1)
            gap[k : k + block] = np.linalg.norm(w - s[..., None] * d[None], axis=2).min(axis=1)
        flat = np.where(inside, gap, -gap)
        return np.asarray(np.minimum.reduce([q[:, 2], t - q[:, 2], flat]))
    if isinstance(layer, RingRoughLayer):
        q = layer.frame.to_local(p)
        rho = np.hypot(q[:, 0], q[:, 1])
        return np.asarray(
            np.minimum.reduce([q[:, 2], t - q[:, 2], rho - layer.rmin, layer.rmax - rho])
        )
    box = layer.envelope_box()
    q = box.transform.inverse_apply(p)
    return np.asarray((box.half - np.abs(q)).min(axis=1))


def _cells_boundary(layer: RoughLayer) -> np.ndarray:
    """The outline (m, 2, 2) of a layer's kept cells in its frame: the cell edges between a kept
    cell and one that is not (or the grid's rim), the edges of :meth:`RoughLayer.cells_outline`
    that belong to one triangle only (:func:`~score4.world.facets.boundary_edges`), read off
    the grid."""
    x, y = layer.cell_edges()
    kept = np.pad(layer.cell_variants >= 0, 1)
    j, i = np.nonzero(kept[1:, 1:-1] != kept[:-1, 1:-1])  # between rows j - 1 and j
    along = np.stack([np.stack([x[i], y[j]], -1), np.stack([x[i + 1], y[j]], -1)], 1)
    j, i = np.nonzero(kept[1:-1, 1:] != kept[1:-1, :-1])  # between columns i - 1 and i
    across = np.stack([np.stack([x[i], y[j]], -1), np.stack([x[i], y[j + 1]], -1)], 1)
    return np.concatenate([along, across])


def _in_kept_cell(layer: RoughLayer, q: np.ndarray) -> np.ndarray:
    """True for points (the layer's frame) over a kept cell."""
    i, j = layer.patch_map.cell_of(q[:, :2])
    inside = i >= 0
    inside[inside] = layer.cell_variants[j[inside], i[inside]] >= 0
    return inside


#: Most cells the exact search of :func:`shells_meet` keeps at once (a bound on its memory).
MAX_CELLS = 2_000_000

#: Resolution of the certified search (:func:`certified_meet`), as a share of the thinner of
#: the two layers (of the curved layer against a solid): an overlap deeper than this (plus
#: the boundary tolerance) is always found. It was a half until session 11.
RESOLUTION_SHARE = 0.1

Depth = Callable[[np.ndarray], np.ndarray]


def _axis(target: TargetVolume | Instance) -> tuple[np.ndarray, np.ndarray]:
    """A volume's z axis in the world: a point on it and its direction."""
    return (
        np.asarray(target.to_world(np.zeros((1, 3))), float)[0],
        np.asarray(target.rotation, float)[:, 2],
    )


def _same_axis(a: tuple[np.ndarray, np.ndarray], b: tuple[np.ndarray, np.ndarray]) -> bool:
    """Two axes are one line (to 1e-9)."""
    (pa, da), (pb, db) = a, b
    return bool(
        np.linalg.norm(np.cross(da, db)) < 1e-9 and np.linalg.norm(np.cross(pb - pa, da)) < 1e-9
    )


def _round_layer(layer: RoughLayer) -> bool:
    """The layer's envelope (as :func:`_depth` sees it) is round about its target's z axis: a
    curved layer over the full circle, a ring whose envelope is the ring."""
    if layer.cells_envelope:
        return False
    if isinstance(layer, CurvedRoughLayer) and layer.pieces is not None:
        return False  # an envelope in pieces of azimuth
    if isinstance(layer, CurvedRoughLayer):
        return bool(layer.ring_layout.face.dphi >= 2 * np.pi - 1e-9)
    if isinstance(layer, RingRoughLayer):
        # the ring's frame: centred on the axis, its normal along it
        axis = _axis(layer.target)
        frame = (np.asarray(layer.frame.centre, float), np.asarray(layer.frame.normal, float))
        return _same_axis(axis, frame)
    return False


def shells_meet(
    layer: CurvedRoughLayer, other: RoughLayer, tol: float = BOUNDARY_TOLERANCE
) -> np.ndarray | None:
    """A world point strictly inside both a curved layer's envelope and ``other``'s (by more
    than ``tol``), or None when there is none deeper than ``tol + resolution``, resolution
    being :data:`RESOLUTION_SHARE` of the thinner layer (1.1 um for two 11 um layers); see
    :func:`certified_meet`."""
    coaxial = _round_layer(other) and _same_axis(_axis(layer.target), _axis(other.target))
    return certified_meet(
        layer,
        lambda world: _depth(other, world),
        RESOLUTION_SHARE * min(layer.thickness, other.thickness),
        f"the rough layer {other.name}",
        tol,
        coaxial,
        _layer_planes(other, layer.target),
    )


def shell_search(
    layer: CurvedRoughLayer,
    depth: Depth,
    resolution: float,
    label: str,
    tol: float = BOUNDARY_TOLERANCE,
) -> np.ndarray | None:
    """A world point of a curved layer's envelope where ``depth`` exceeds ``tol``, or None when
    there is none deeper than ``tol + resolution`` (:func:`certified_meet`; ``label`` names
    what is searched in errors)."""
    return certified_meet(layer, depth, resolution, label, tol)


def certified_meet(
    layer: CurvedRoughLayer,
    depth: Depth,
    resolution: float,
    what: str,
    tol: float = BOUNDARY_TOLERANCE,
    coaxial: bool = False,
    planes: tuple[np.ndarray, np.ndarray] | None = None,
) -> np.ndarray | None:
    """A world point of a curved layer's envelope where ``depth`` (how deep world points lie in
    something else: positive inside, changing by no more than the distance a point moves)
    exceeds ``tol``, or None when there is none deeper than ``tol + resolution``.

    The shell is cut into cells of its (azimuth, generator, height) box; a cell whose centre is
    at depth ``d`` and whose points are all within ``R`` of its centre (half its diagonal, the
    three directions being orthogonal) holds no point deeper than ``d + R``: such cells are
    dropped, a centre deeper than ``tol`` is the answer, and the other cells are halved along
    their longest side until they are smaller than the resolution. Points are never missed
    between samples, however thin the layers (the grid of
    :meth:`CurvedRoughLayer.shell_points` can miss a 20 um layer). ``coaxial``: ``depth`` is
    the same at every azimuth about the layer's axis (a round thing on the same axis), so the
    search runs on one half-plane of the shell, in (generator, height) only. ``planes``:
    ``depth`` is the least of affine functions ``c + m . p`` of points ``p`` in the layer's
    target frame (a box or another solid of planes, :func:`_planes_in`): on a face whose
    generator is straight (a cylinder, a cone) each is bounded over a cell exactly from the
    cell's ranges of azimuth, radius and z, which drops the cells along a plane the layer
    touches (a box beside a wall, under its end) without halving them down to the
    resolution. An envelope in pieces (:attr:`CurvedRoughLayer.pieces`) is searched piece by
    piece."""
    if layer.pieces is not None:
        for view in layer.envelope_views():
            found = certified_meet(view, depth, resolution, what, tol, coaxial, planes)
            if found is not None:
                return found
        return None
    face = layer.ring_layout.face
    t = layer.thickness
    (u0, u1), (v0, v1) = face.extent
    resolution = max(resolution, 1e-7)
    cone = layer._cone_envelope
    if cone:  # cells of (azimuth, z, across) in the G4Cons between the face's z planes
        a1, b1, a2, b2, dz, zc = wall_envelope(layer)
        v0, v1 = 0.0, 2 * dz  # (v: height above the lower z plane; h: 0 inner .. t outer)
        rho_max = max(b1, b2)
        # d/dz moves along z and out by the lines' slope, d/dh across (radially) by at most
        # the widest end over t: the two add up at most
        v_scale = float(np.hypot(1.0, max(abs(a2 - a1), abs(b2 - b1)) / (2 * dz)))
        h_scale = max(b1 - a1, b2 - a2) / t
    elif isinstance(face, SphereFace):
        r_out = face.sphere_radius + t
        rho_max, v_scale, h_scale = r_out, r_out / face.sphere_radius, 1.0
    else:
        rho_max = float(np.max(face.radius(np.array([v0, v1])))) + t
        v_scale, h_scale = 1.0, 1.0

    def local_point(m: np.ndarray) -> np.ndarray:
        """Points (azimuth, v, h) in the target's frame."""
        if cone:
            f, s = m[:, 1] / (2 * dz), m[:, 2] / t
            r = (a1 + f * (a2 - a1)) + s * ((b1 + f * (b2 - b1)) - (a1 + f * (a2 - a1)))
            return np.column_stack([r * np.cos(m[:, 0]), r * np.sin(m[:, 0]), zc - dz + m[:, 1]])
        return np.asarray(
            face.point(m[:, 0], m[:, 1]) + m[:, 2, None] * face.normal(m[:, 0], m[:, 1])
        )

    def position(m: np.ndarray) -> np.ndarray:
        """World points of cell centres (azimuth, v, h)."""
        return np.asarray(layer.target.to_world(local_point(m)))

    def plane_bound(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        """The most ``depth`` reaches in each cell, by its planes: radius and z are affine
        (bilinear in a G4Cons envelope) in (v, h), so their ranges are those of the corners."""
        assert planes is not None
        m, c = planes
        corners = [
            local_point(np.column_stack([np.zeros(len(lo)), a[:, 1], b[:, 2]]))
            for a in (lo, hi)
            for b in (lo, hi)
        ]
        rho = np.stack([np.hypot(q[:, 0], q[:, 1]) for q in corners])
        z = np.stack([q[:, 2] for q in corners])
        r_lo, r_hi, z_lo, z_hi = rho.min(0), rho.max(0), z.min(0), z.max(0)
        width = np.hypot(m[:, 0], m[:, 1])[None, :]  # (cells, planes) below
        alpha = np.arctan2(m[:, 1], m[:, 0])[None, :]
        ul, uh = lo[:, 0, None], hi[:, 0, None]
        facing = np.mod(alpha - ul, 2 * np.pi) <= uh - ul
        cos = np.where(facing, 1.0, np.maximum(np.cos(ul - alpha), np.cos(uh - alpha)))
        radial = width * np.where(cos > 0, r_hi[:, None], r_lo[:, None]) * cos
        along = np.maximum(m[None, :, 2] * z_lo[:, None], m[None, :, 2] * z_hi[:, None])
        return np.asarray((c[None, :] + radial + along).min(axis=1))

    use_planes = planes is not None and not coaxial and not isinstance(face, SphereFace)

    if coaxial:  # one azimuth: the cells do not span any
        n_u, u_scale = 1, 0.0
        u0 = u1 = 0.5 * (u0 + u1)
        n_v = int(np.clip(np.ceil((v1 - v0) / t), 1, 4096))
    else:
        n_u, u_scale = (
            int(np.clip(np.ceil(rho_max * (u1 - u0) / max(v1 - v0, t)), 1, 4096)),
            rho_max,
        )
        n_v = int(np.clip(np.ceil((v1 - v0) / max(rho_max * (u1 - u0) / n_u, t)), 1, 4096))
    eu, ev = np.linspace(u0, u1, n_u + 1), np.linspace(v0, v1, n_v + 1)
    ui, vi = np.meshgrid(np.arange(n_u), np.arange(n_v), indexing="ij")
    lo = np.column_stack([eu[ui.ravel()], ev[vi.ravel()], np.zeros(ui.size)])
    hi = np.column_stack([eu[ui.ravel() + 1], ev[vi.ravel() + 1], np.full(ui.size, t)])
    scale = np.array([u_scale, v_scale, h_scale])  # mm per unit of each parameter, at most
    while len(lo):
        mid = 0.5 * (lo + hi)
        world = position(mid)
        d = depth(world)
        # the middle of each cell's outer side too: a solid beside the layer reaches in there
        # first (an overlap shallower than the cells is found there)
        top = mid.copy()
        top[:, 2] = hi[:, 2] - 0.01 * (hi[:, 2] - lo[:, 2])  # (inside: a witness is strictly in)
        world_top = position(top)
        d_top = depth(world_top)
        deep = np.flatnonzero(np.maximum(d, d_top) > tol)
        if len(deep):
            k = deep[np.argmax(np.maximum(d, d_top)[deep])]
            return np.asarray(world[k] if d[k] >= d_top[k] else world_top[k])
        size = (hi - lo) * scale
        # the azimuth's direction is orthogonal to the other two, each stretched by at most
        # ``scale``: no point of a cell is further from its centre (on a shell of normals the
        # other two are orthogonal as well; in a G4Cons they are added)
        inplane = np.hypot(size[:, 1], size[:, 2]) if not cone else size[:, 1] + size[:, 2]
        reach = 0.5 * np.hypot(size[:, 0], inplane)
        open_ = (d + reach > tol) & (reach > resolution)
        if use_planes and open_.any():  # (only where the distance alone keeps a cell)
            keep = np.flatnonzero(open_)
            open_[keep[plane_bound(lo[keep], hi[keep]) <= tol]] = False
        lo, hi, size = lo[open_], hi[open_], size[open_]
        if len(lo) > MAX_CELLS // 2:
            raise ConfigError(
                f"{layer.name}: the clearance check against {what} needs more than "
                f"{MAX_CELLS} cells (the two touch over a large area); move them apart "
                "by a micrometre"
            )
        axis = np.argmax(size, axis=1)
        cut = 0.5 * (lo[np.arange(len(lo)), axis] + hi[np.arange(len(lo)), axis])
        lo2, hi2 = lo.copy(), hi.copy()
        hi[np.arange(len(lo)), axis] = cut
        lo2[np.arange(len(lo)), axis] = cut
        lo, hi = np.concatenate([lo, lo2]), np.concatenate([hi, hi2])
    return None


def _gap_under(layer: CurvedRoughLayer, other: RoughLayer, point: np.ndarray) -> float:
    """The free gap under a point inside both a curved layer's envelope and ``other``'s
    (:func:`_least_gap`; mm)."""
    return _least_gap(layer, lambda world: _depth(other, world), point, 0.0)


def _entry_height(inside: Callable[[np.ndarray], np.ndarray], n: int, h_in: float) -> np.ndarray:
    """Per column, the least height in [0, h_in] at which ``inside(h)`` holds (36 halvings):
    0 where it holds at the foot already, inf where it does not hold even at ``h_in``."""
    lo, hi = np.zeros(n), np.full(n, h_in)
    ok = inside(hi)
    for _ in range(36):
        mid = 0.5 * (lo + hi)
        got = inside(mid)
        hi, lo = np.where(got, mid, hi), np.where(got, lo, mid)
    return np.where(ok, np.where(inside(np.zeros(n)), 0.0, hi), np.inf)


def _descend(
    gaps: Callable[[np.ndarray], np.ndarray],
    at: np.ndarray,
    best: float,
    step: float,
    moves: Callable[[float], np.ndarray],
) -> float:
    """The least gap found from ``at`` (its gap ``best``) by moving to the neighbour of least
    gap (``at + moves(step)``) while that lowers it, halving the step otherwise, down to 1 nm
    or a gap of 0."""
    while step > 1e-6 and best > 0:
        trial = at + moves(step)
        g = gaps(trial)
        k = int(np.argmin(g))
        if g[k] < best:
            best, at = float(g[k]), trial[k]
        else:
            step /= 2
    return best
