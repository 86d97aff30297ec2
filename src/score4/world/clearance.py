"""Clearance checks of a run's targets and rough layers (numpy, no Geant4).

* A generated world: targets (boxes) must not overlap, and a rough layer (its envelope: the face
  extruded by the layer thickness) must not run into another target or layer.
* A GDML world: a rough layer must not meet any other daughter of its volume's mother (the
  volume's sisters, boxes of the configuration, other layers) and must stay inside the mother;
  boxes of the configuration likewise. Boxes are tested exactly (oriented boxes, separating
  axes), the other solids score4.shapes describes (booleans: a frame is a box less a box) by a
  grid of points of the envelope, the rest by their bounding box. Errors
  name what the layer meets and the free gap along the face normal.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from score4.errors import ConfigError
from score4.shapes import Shape, shape_from_dict

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
    )


@lru_cache(maxsize=256)
def _shape_of(text: str) -> Shape:
    return shape_from_dict(json.loads(text))


def _shape(data: dict) -> Shape:
    """The shape of a model's solid record (cached: a world places one solid many times)."""
    return _shape_of(json.dumps(data, sort_keys=True))


def _target_body(t: TargetVolume) -> _Body:
    return _Body(f"target {t.name!r}", target_obb(t), t.to_local, t.lo, t.hi, t.shape)


def check_gdml_clearance(scene: Scene) -> None:
    """Rough layers and boxes of a GDML world against their sisters and their mother.

    A layer on a face (outside the volume) must not meet any other daughter of the volume's
    mother (other GDML volumes, boxes of the configuration, other layers) and must stay inside
    the mother. Boxes are tested exactly (oriented boxes), the other solids score4.shapes
    describes by a grid of points of the layer's envelope, other solids by their bounding box.
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
            if _layer_meets(body, layer, box):
                raise ConfigError(_meets(layer, f"sister {body.label}", _gap(layer, body)))
        for t in scene.targets:
            if t is layer.target or t.instance is not None or t.mother != mother:
                continue
            body = _target_body(t)
            if _layer_meets(body, layer, box):
                raise ConfigError(_meets(layer, body.label, _gap(layer, body)))
        for other, other_box in layers[n + 1 :]:
            if other.target.mother != mother:
                continue
            if isinstance(other, CurvedRoughLayer):
                if other.in_shell(_envelope_points(layer, box)).any():
                    raise ConfigError(
                        _meets(layer, f"the rough layer {other.name}", _pair_gap(layer, other))
                    )
                continue
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


def _check_curved(
    model: GeometryModel, scene: Scene, layer: CurvedRoughLayer, others: list[RoughLayer]
) -> None:
    """A bent layer against the sisters of its volume, boxes and layers in the same mother, and
    its mother, by points of its shell; the gap is the least height above the face of a shell
    point inside what it meets."""
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
    for body in bodies:
        hit = body.contains(body.to_local(points), touching=False)  # type: ignore[operator]
        if hit.any():
            what = body.label if body.label.startswith("target") else f"sister {body.label}"
            k = np.flatnonzero(hit)[np.argmin(height[hit])]
            raise ConfigError(_meets(layer, what, _curved_gap(layer, body, points[k])))
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
        if meets:
            raise ConfigError(
                _meets(layer, f"the rough layer {other.name}", _pair_gap(layer, other))
            )
    body = _instance_body(model, mother)
    if not body.contains(mother.to_local(points)).all():
        raise ConfigError(
            f"{layer.name}: the rough layer on face {layer.config.face_name} of "
            f"{layer.target.name!r} "
            f"({layer.thickness * 1e3:.4g} um thick) leaves its mother volume "
            f"{model.label(mother)!r}; use a lower surface"
        )


def _curved_gap(layer: CurvedRoughLayer, body: _Body, point: np.ndarray) -> float:
    """Height above the face, bisected along the face normal under ``point``, where ``body``
    begins."""
    face = layer.ring_layout.face
    u, v, hi = (float(x[0]) for x in face.locate(layer.target.to_local(point[None, :])))
    lo = 0.0
    base, normal = face.point(u, v), face.normal(u, v)
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        p = layer.target.to_world((base + mid * normal)[None, :])
        if body.contains(body.to_local(p), touching=False)[0]:  # type: ignore[operator]
            hi = mid
        else:
            lo = mid
    return hi


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
