"""Boolean solids (G4UnionSolid, G4SubtractionSolid, G4IntersectionSolid) of shapes.

The surface of ``A op B`` is made of pieces of the surfaces of A and B. A point drawn uniformly
per area on a face of A or B is kept when it is on the boolean's surface: a step of
``PROBE`` (1e-7 mm) along its outward normal leaves the solid and a step against it enters it
(B's normals are flipped in a subtraction; a point on both A and B counts for A only). Kept
points are uniform per area on the true surface. The area of a piece is estimated from the kept
fraction of draws on its constituent face, in rounds of ``n_area`` until the standard error is
0.1 % of the face's area (:data:`AREA_PRECISION`; of the constituents' whole area for a sliver,
at most :data:`MAX_AREA_ROUNDS` rounds): :attr:`BooleanShape.face_area_errors` gives the errors.
Each face is estimated only when something asks for its area (a rough layer, a source on it;
sampling the whole surface asks for all), with its own seed drawn from the solid's description
and the face's name, so its estimate does not depend on which other faces were asked for, or in
which order. An estimate is kept per face and solid description (:attr:`BooleanShape.area_key`:
the solid's parameters, face names and the estimate's settings) in memory and, when the shape
names a folder (``area_cache``; the world gives score4's cache folder), in a small JSON file
there, so a face is estimated once, not at every scene build.

Faces are named ``first.<face of A>`` and ``second.<face of B>``; groups ``first``/``second``
(and ``first.<group of A>``, ...) select all faces of one constituent; ``aliases`` names groups
of A that are also groups of the boolean itself (an HPGe's ``pplus``, ``passive``, ``nplus`` when
the detector is a polycone with a cut).

:meth:`BooleanShape.face_clip` tells where a face lies: on a face of one *leaf* solid (not a
boolean), kept where the leaf's siblings on the way up (:class:`FaceClip`) say so; their signed
distances bound how far the kept part reaches (rough layers lay patches only where that bound
proves a whole cell kept, :mod:`score4.world.boolean_layers`).
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike

from ..errors import ConfigError
from .base import INSIDE, OUTSIDE, Shape, ShapeSample, as_points
from .placed import PlacedShape
from .transform import Transform

PROBE = 1e-7  # mm: far above Geant4's tolerance, far below any feature of a detector

#: Relative standard error the area estimate of a face aims at (issue 24: 0.1 %).
AREA_PRECISION = 1e-3
#: Most rounds of ``n_area`` draws per face for the area estimate.
MAX_AREA_ROUNDS = 40
#: Version of the area estimate's method and file (a new one leaves older cached estimates unused;
#: 2: one estimate per face, on demand, with the face's own seed).
AREA_FORMAT = 2
_EYE = np.eye(3)
#: Area estimates (area, standard error) made in this process, by (:attr:`BooleanShape.area_key`,
#: face name).
_AREAS: dict[tuple[str, str], tuple[float, float]] = {}


@dataclass(frozen=True, eq=False)
class BooleanShape(Shape):
    """``first op second``, ``second`` placed in ``first``'s frame by ``transform``.

    Parameters
    ----------
    operation
        ``union``, ``subtraction`` or ``intersection``.
    first, second
        The constituents (any shapes, booleans included).
    transform
        Object transform of ``second`` into ``first``'s frame (Geant4's
        ``G4DisplacedSolid::GetObjectRotation/GetObjectTranslation``).
    n_area
        Draws per constituent face for the area estimate.
    area_cache
        Folder where area estimates are kept between processes (None: in memory only).
    """

    operation: Literal["union", "subtraction", "intersection"]
    first: Shape
    second: Shape
    transform: Transform = field(default_factory=Transform)
    n_area: int = 50_000
    aliases: tuple[str, ...] = ()
    area_cache: Path | None = field(default=None, compare=False, repr=False)
    kind = "BooleanShape"

    def __post_init__(self) -> None:
        if self.operation not in ("union", "subtraction", "intersection"):
            raise ConfigError(f"BooleanShape: unknown operation {self.operation!r}")

    # -- frames ----------------------------------------------------------------------------------

    def _second_signed(self, p: np.ndarray) -> np.ndarray:
        return self.second.signed_distance(self.transform.inverse_apply(p))

    def signed_distance(self, points: ArrayLike) -> np.ndarray:
        p = as_points(points)
        a, b = self.first.signed_distance(p), self._second_signed(p)
        if self.operation == "union":
            return np.minimum(a, b)
        if self.operation == "intersection":
            return np.maximum(a, b)
        return np.maximum(a, -b)

    # -- faces -----------------------------------------------------------------------------------

    def _build(self):
        names = tuple(f"first.{f}" for f in self.first.faces) + tuple(
            f"second.{f}" for f in self.second.faces
        )
        groups = {"first": names[: len(self.first.faces)], "second": names[len(self.first.faces) :]}
        for tag, shape in (("first", self.first), ("second", self.second)):
            for g, members in shape.groups.items():
                if g != "all":
                    groups[f"{tag}.{g}"] = tuple(f"{tag}.{m}" for m in members)
        for g in self.aliases:
            if f"first.{g}" in groups:
                groups[g] = groups[f"first.{g}"]
        return names, groups, []

    def face_clip(self, name: str) -> FaceClip:
        """Where face ``name`` lies: a face of a leaf solid, in this boolean's frame, and the
        solids that cut it (ConfigError listing the faces for a name the boolean lacks)."""
        if name not in self.faces:
            self.resolve_faces(name)  # the error lists the faces and groups
            raise ConfigError(f"face: {name!r} names several faces of a {self.kind}; give one")
        part, rest = name.split(".", 1)
        if part == "first":
            shape, placed, other, other_at = self.first, Transform(), self.second, self.transform
        else:
            shape, placed, other, other_at = self.second, self.transform, self.first, Transform()
        inside = self.operation == "intersection" or (
            self.operation == "subtraction" and part == "second"
        )
        flipped = self.operation == "subtraction" and part == "second"
        while isinstance(shape, PlacedShape):
            placed, shape = placed @ shape.transform, shape.shape
        here = (other, other_at, inside)
        if isinstance(shape, BooleanShape):
            inner = shape.face_clip(rest)
            clips = tuple((s, placed @ t, k) for s, t, k in inner.clips)
            return FaceClip(
                inner.leaf, inner.face, placed @ inner.transform, inner.flipped != flipped,
                (*clips, here),
            )  # fmt: skip
        return FaceClip(shape, rest, placed, flipped, (here,))

    def _candidates(
        self, rng: np.random.Generator, n: int, part: str, faces: tuple[str, ...]
    ) -> tuple[ShapeSample, np.ndarray]:
        """Points on faces of one constituent (boolean frame, boolean face indices) and the mask
        of those on the boolean's surface."""
        shape = self.first if part == "first" else self.second
        s = shape.face_sampler(faces).sample(rng, n)
        pos, normal = s.position, s.normal
        if part == "second":
            pos, normal = self.transform.apply(pos), self.transform.apply_vectors(normal)
            if self.operation == "subtraction":
                normal = -normal
        out = self.inside(pos + PROBE * normal) == OUTSIDE
        out &= self.inside(pos - PROBE * normal) == INSIDE
        if part == "second":  # a piece shared with the first constituent counts once
            out &= self.first.inside(pos) != 1
        offset = 0 if part == "first" else len(self.first.faces)
        return ShapeSample(pos, normal, s.face + offset), out

    @cached_property
    def area_key(self) -> str:
        """Key of this solid's area estimate: its description (constituents, placement, face
        names) and the estimate's settings."""
        text = json.dumps(
            {
                "format": AREA_FORMAT,
                "shape": self.to_dict(),
                "faces": list(self.faces),
                "n_area": self.n_area,
                "precision": AREA_PRECISION,
                "rounds": MAX_AREA_ROUNDS,
            },
            sort_keys=True,
            default=str,
        )
        return hashlib.sha256(text.encode()).hexdigest()[:32]

    def _face_estimate(self, name: str) -> tuple[float, float]:
        """(area, standard error) of face ``name``: :meth:`_estimate_area`, once per
        :attr:`area_key` and face (in memory, and in ``area_cache`` when given)."""
        key = (self.area_key, name)
        if key in _AREAS:
            return _AREAS[key]
        path = None
        if self.area_cache is not None:
            path = Path(self.area_cache) / f"{_digest(self.area_key, name)}.json"
        found = _read_area(path, self.area_key, name) if path is not None else None
        if found is None:
            found = self._estimate_area(name)
            if path is not None:
                _write_area(path, self.area_key, name, found)
        _AREAS[key] = found
        return found

    def face_seed(self, name: str) -> int:
        """Seed of face ``name``'s area estimate: from the solid's description and the face's
        name only (not the estimate's settings, not the other faces)."""
        text = json.dumps(self.to_dict(), sort_keys=True, default=str)
        return int(_digest(text, name)[:16], 16)

    def _estimate_area(self, name: str) -> tuple[float, float]:
        """Draws on face ``name``'s constituent face in rounds of ``n_area`` until the standard
        error is at most :data:`AREA_PRECISION` of the face's area (or of the constituents' whole
        area, :func:`gross_area`, for a sliver), at most :data:`MAX_AREA_ROUNDS` rounds."""
        part, face = name.split(".", 1)
        shape = self.first if part == "first" else self.second
        full = shape.face_areas[face]
        rng = np.random.default_rng(self.face_seed(name))
        whole = gross_area(self)
        kept, drawn = 0, 0
        p = err = 0.0
        for _ in range(MAX_AREA_ROUNDS if full > 0 else 0):
            kept += int(self._candidates(rng, self.n_area, part, (face,))[1].sum())
            drawn += self.n_area
            p = kept / drawn
            err = full * float(np.sqrt(p * (1 - p) / drawn))
            if err <= AREA_PRECISION * max(full * p, AREA_PRECISION * whole):
                break
        return float(full * p), err

    @cached_property
    def face_areas(self) -> Mapping[str, float]:
        """Estimated area of every face, mm^2; a face is estimated when first read."""
        return FaceAreas(self, 0)

    @cached_property
    def face_area_errors(self) -> Mapping[str, float]:
        """Standard errors of :attr:`face_areas` (binomial, from the kept fraction); a face is
        estimated when first read."""
        return FaceAreas(self, 1)

    def face_sampler(self, faces: str | Sequence[str] = "all") -> BooleanFaceSampler:  # type: ignore[override]
        return BooleanFaceSampler(self, self.resolve_faces(faces))

    # -- volume ----------------------------------------------------------------------------------

    @cached_property
    def _volume_estimate(self) -> tuple[float, float]:
        lo, hi = self.bounding_box()
        rng = np.random.default_rng(20262)
        n = 200_000
        p = lo + rng.random((n, 3)) * (hi - lo)
        frac = float((self.inside(p) == INSIDE).mean())
        box = float(np.prod(hi - lo))
        return box * frac, box * float(np.sqrt(frac * (1 - frac) / n))

    @property
    def volume(self) -> float:
        """Volume estimated from 2 10^5 fixed-seed points in the bounding box (see
        :attr:`volume_error`)."""
        return self._volume_estimate[0]

    @property
    def volume_error(self) -> float:
        return self._volume_estimate[1]

    def bounding_box(self) -> tuple[np.ndarray, np.ndarray]:
        alo, ahi = self.first.bounding_box()
        if self.operation == "subtraction":
            return alo, ahi
        blo, bhi = self.second.bounding_box()
        corners = np.array(
            [
                [x, y, z]
                for x in (blo[0], bhi[0])
                for y in (blo[1], bhi[1])
                for z in (blo[2], bhi[2])
            ]
        )
        c = self.transform.apply(corners)
        if self.operation == "union":
            return np.minimum(alo, c.min(axis=0)), np.maximum(ahi, c.max(axis=0))
        return np.maximum(alo, c.min(axis=0)), np.minimum(ahi, c.max(axis=0))

    def to_dict(self) -> dict[str, Any]:
        return {
            "type": self.kind,
            "operation": self.operation,
            "first": self.first.to_dict(),
            "second": self.second.to_dict(),
            "transform": self.transform.to_dict(),
        }


class FaceAreas(Mapping[str, float]):
    """A boolean's face areas (``which`` 0) or their standard errors (1), by face name; each
    face is estimated when it is first read (:meth:`BooleanShape._face_estimate`), so reading
    one face costs one face's estimate and reading them all (``values()``, ``dict(...)``) costs
    all."""

    def __init__(self, shape: BooleanShape, which: int) -> None:
        self._shape, self._which = shape, which

    def __getitem__(self, name: str) -> float:
        if name not in self._shape.faces:
            raise KeyError(name)
        return self._shape._face_estimate(name)[self._which]

    def __contains__(self, name: object) -> bool:  # without estimating
        return name in self._shape.faces

    def __iter__(self) -> Iterator[str]:
        return iter(self._shape.faces)

    def __len__(self) -> int:
        return len(self._shape.faces)

    def __repr__(self) -> str:
        return repr(dict(self))


def gross_area(shape: Shape) -> float:
    """Total area of the faces of the leaf solids of ``shape`` (a boolean's surface is at most
    this), exact and without estimating any boolean face."""
    while isinstance(shape, PlacedShape):
        shape = shape.shape
    if isinstance(shape, BooleanShape):
        return gross_area(shape.first) + gross_area(shape.second)
    return shape.area


@dataclass(frozen=True, eq=False)
class FaceClip:
    """A face of a boolean solid as a face of a leaf solid and the solids that cut it.

    ``leaf``'s face ``face`` (``transform``: leaf frame to the boolean's frame; ``flipped``: the
    boolean's outward normal is against the leaf's, a face of a subtracted solid) is the
    boolean's face where, for every ``(solid, transform, inside)`` of ``clips``, the point is
    inside (``inside``) or outside that solid (placed by ``transform`` in the boolean's frame).
    """

    leaf: Shape
    face: str
    transform: Transform
    flipped: bool
    clips: tuple[tuple[Shape, Transform, bool], ...]

    def margin(self, points: ArrayLike) -> np.ndarray:
        """For points (boolean frame) on the leaf's face: a lower bound of the distance to the
        nearest point where the face stops being the boolean's (> 0: this point is on the
        boolean's surface, and so is every point of the face within that distance; < 0: it is
        not). Exact for boxes and tubes, a lower bound for every shape (their signed distances
        are)."""
        p = as_points(points)
        out = np.full(len(p), np.inf)
        for shape, transform, inside in self.clips:
            if np.array_equal(transform.rotation, _EYE):  # a shift (most cuts): no product
                local = p - transform.translation
            else:
                local = transform.inverse_apply(p)
            d = shape.signed_distance(local)
            out = np.minimum(out, -d if inside else d)
        return out


class BooleanFaceSampler:
    """Area-uniform points on faces of a boolean solid, by rejection on its constituents."""

    def __init__(self, shape: BooleanShape, faces: tuple[str, ...]) -> None:
        self.shape, self.faces = shape, faces
        self.parts = [
            (part, tuple(f.split(".", 1)[1] for f in faces if f.split(".", 1)[0] == part))
            for part in ("first", "second")
        ]
        self.parts = [(p, f) for p, f in self.parts if f]
        full = [(shape.first if p == "first" else shape.second).face_area(f) for p, f in self.parts]
        self._full = np.array(full)
        self.area = float(sum(shape.face_areas[f] for f in faces))
        self.area_error = float(np.sqrt(sum(shape.face_area_errors[f] ** 2 for f in faces)))
        if not self.area > 0:
            raise ConfigError(f"face: the selected faces ({', '.join(faces)}) have no area")
        self.planar = False

    def sample(self, rng: np.random.Generator, n: int) -> ShapeSample:
        out = ShapeSample(np.empty((0, 3)), np.empty((0, 3)), np.empty(0, np.int64))
        while len(out.face) < n:
            m = 2 * (n - len(out.face)) + 64
            which = rng.choice(len(self.parts), size=m, p=self._full / self._full.sum())
            got = [out]
            for k, (part, faces) in enumerate(self.parts):
                cnt = int((which == k).sum())
                if cnt:
                    s, keep = self.shape._candidates(rng, cnt, part, faces)
                    got.append(ShapeSample(s.position[keep], s.normal[keep], s.face[keep]))
            out = ShapeSample(
                *(
                    np.concatenate([g.__dict__[a] for g in got])
                    for a in ("position", "normal", "face")
                )
            )
        order = rng.permutation(len(out.face))[:n]  # mix the parts
        return ShapeSample(out.position[order], out.normal[order], out.face[order])


def _digest(*parts: str) -> str:
    return hashlib.sha256("\0".join(parts).encode()).hexdigest()[:32]


def _read_area(path: Path, key: str, name: str) -> tuple[float, float] | None:
    """The estimate of face ``name`` of the solid ``key`` kept by :func:`_write_area` (None if
    absent, unreadable or not for this solid, face and format)."""
    try:
        data = json.loads(path.read_text())
        found = (float(data["area"]), float(data["error"]))
        same = (data["format"], data["key"], data["face"]) == (AREA_FORMAT, key, name)
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return None
    return found if same else None


def _write_area(path: Path, key: str, name: str, found: tuple[float, float]) -> None:
    """Keep one face's estimate in ``path`` (written whole or not at all; a folder that cannot
    be written leaves the estimate in memory only)."""
    data = {"format": AREA_FORMAT, "key": key, "face": name, "area": found[0], "error": found[1]}
    text = json.dumps(data)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}.", suffix=".partial", dir=path.parent)
        try:
            with os.fdopen(fd, "w") as f:
                f.write(text)
            os.replace(tmp, path)
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise
    except OSError:
        pass
