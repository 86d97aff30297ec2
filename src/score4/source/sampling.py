"""Random sampling building blocks: discrete choices, tabulated 1-D laws, points on surfaces.

Everything here is vectorised numpy and takes a seeded :class:`numpy.random.Generator`.

* :class:`DiscreteSampler` draws indices with probability proportional to weights in O(1)
  expected time per draw (a guide table over the cumulative weights, then a few vectorised
  bisection steps), never by a linear scan.
* :class:`PiecewiseLinear` and :class:`Histogram` are 1-D laws given by a table; both are
  sampled exactly by inverting their CDF. :func:`read_table` reads such a table from a text
  file with a ``# unit: nm`` header.
* :class:`SurfaceSampler` draws points uniformly per true area on a triangle set;
  :class:`TiledSurfaceSampler` does the same on a face tiled from patch variants (choose the
  cell by the true area of its variant, then a triangle, then a point, then translate).

Triangles are plain arrays: ``(m, 3, 3)`` vertex coordinates, or ``vertices (n, 3)`` +
``faces (m, 3)``. The outward normal of a triangle ``(a, b, c)`` is ``(b - a) x (c - a)``
normalised, i.e. faces are wound counter-clockwise seen from outside (from the vacuum side).
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from score4.common import limits
from score4.common.units import DIMENSIONS

from ..errors import ConfigError, brief

__all__ = [
    "DiscreteSampler",
    "Histogram",
    "PiecewiseLinear",
    "SurfaceSample",
    "SurfaceSampler",
    "TiledSurfaceSampler",
    "as_triangles",
    "orthonormal_basis",
    "read_table",
    "triangle_areas",
    "triangle_normals",
]


# --------------------------------------------------------------------------------------------
# Discrete choice
# --------------------------------------------------------------------------------------------


class DiscreteSampler:
    """Draw indices ``i`` with probability ``weights[i] / sum(weights)``.

    Entries of weight zero are never drawn. Set-up is O(m); a draw costs one guide-table
    look-up plus ``ceil(log2(max bucket size))`` vectorised bisection steps (1-3 for usual
    weight sets), so the cost does not grow with the number of entries like a CDF scan.

    Parameters
    ----------
    weights
        (m,) non-negative finite weights, at least one positive.
    name
        Parameter name used in error messages.
    """

    def __init__(self, weights: ArrayLike, name: str = "weights") -> None:
        w = np.asarray(weights, dtype=float)
        if w.ndim != 1 or len(w) == 0:
            raise ConfigError(f"{name}: need a non-empty 1-D array of weights, got shape {w.shape}")
        if not np.isfinite(w).all() or (w < 0).any():
            raise ConfigError(f"{name}: weights must be finite and >= 0")
        self._index = np.flatnonzero(w > 0)  # only positive entries take part
        if len(self._index) == 0:
            raise ConfigError(
                f"{name}: all {len(w)} weights are zero; at least one must be positive"
            )
        self.n = len(w)
        self._cum = np.concatenate([[0.0], np.cumsum(w[self._index])])
        self.total = float(self._cum[-1])
        self._build_guide()

    def _build_guide(self) -> None:
        k = len(self._index)
        self._n_buckets = k
        edges = np.arange(k + 1) * (self.total / k)
        first = np.searchsorted(self._cum, edges, side="right") - 1
        # one entry of margin on each side absorbs rounding between bucket edges and draws
        self._lo = np.clip(first[:-1] - 1, 0, k - 1)
        self._hi = np.clip(first[1:] + 1, 0, k - 1)
        widest = int((self._hi - self._lo).max()) + 1
        self._steps = int(np.ceil(np.log2(widest))) if widest > 1 else 0

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """Return ``n`` indices (int64) into the original weight array."""
        r = rng.random(n)
        u = r * self.total
        bucket = np.minimum((r * self._n_buckets).astype(np.intp), self._n_buckets - 1)
        lo = np.take(self._lo, bucket)
        hi = np.take(self._hi, bucket)
        for _ in range(self._steps):  # bisection: largest j with cum[j] <= u, inside [lo, hi]
            mid = (lo + hi + 1) >> 1
            go = np.take(self._cum, mid) <= u
            lo = np.where(go, mid, lo)
            hi = np.where(go, hi, mid - 1)
        return np.take(self._index, lo).astype(np.int64)


# --------------------------------------------------------------------------------------------
# Tabulated 1-D laws
# --------------------------------------------------------------------------------------------


def _check_table(
    x: np.ndarray, w: np.ndarray, labels: Sequence[str], what: str, xname: str
) -> None:
    """Validate a (x, weight) table; ``labels[i]`` is where row i came from (line or index)."""
    if len(x) < 2:
        raise ConfigError(f"{what}: needs at least 2 rows '{xname} weight', got {len(x)}")
    for i in range(len(x)):
        if not (np.isfinite(x[i]) and np.isfinite(w[i])):
            raise ConfigError(
                f"{what} {labels[i]}: values must be finite, got {xname} {float(x[i]):g}, weight "
                f"{float(w[i]):g}"
            )
    bad = np.flatnonzero(x < 0)
    if len(bad):
        i = bad[0]
        raise ConfigError(f"{what} {labels[i]}: negative {xname} {x[i]:g}; {xname}s must be >= 0")
    bad = np.flatnonzero(w < 0)
    if len(bad):
        i = bad[0]
        raise ConfigError(f"{what} {labels[i]}: negative weight {w[i]:g}; weights must be >= 0")
    bad = np.flatnonzero(np.diff(x) <= 0)
    if len(bad):
        i = bad[0] + 1
        rule = "duplicate" if x[i] == x[i - 1] else "unsorted"
        raise ConfigError(
            f"{what} {labels[i]}: {rule} {xname} {x[i]:g} after {x[i - 1]:g} ({labels[i - 1]}); "
            f"{xname}s must increase strictly"
        )
    if not (w > 0).any():
        raise ConfigError(f"{what}: all weights are zero; at least one must be positive")


class PiecewiseLinear:
    """A law whose density is linear between table points and zero outside them.

    Parameters
    ----------
    x
        (k,) strictly increasing abscissae (k >= 2), in internal units.
    w
        (k,) non-negative density values at ``x`` (any normalisation, not all zero).
    what, xname
        Names used in error messages (e.g. ``"depth table"``, ``"depth"``).

    Notes
    -----
    The density is normalised by the exact trapezoid integral, so uneven spacing is
    handled correctly. Sampling chooses a segment by its mass and solves the quadratic
    CDF of that segment in a cancellation-free form: exact inversion, no binning.
    """

    def __init__(self, x: ArrayLike, w: ArrayLike, what: str = "table", xname: str = "x") -> None:
        x = np.asarray(x, dtype=float).ravel()
        w = np.asarray(w, dtype=float).ravel()
        if len(x) != len(w):
            raise ConfigError(f"{what}: {len(x)} {xname} values but {len(w)} weights")
        _check_table(x, w, [f"row {i}" for i in range(len(x))], what, xname)
        widths = np.diff(x)
        mass = 0.5 * widths * (w[:-1] + w[1:])
        norm = mass.sum()
        self.x, self.w = x, w / norm
        self._h = widths
        self._slope = np.diff(self.w) / widths
        self._cum = np.concatenate([[0.0], np.cumsum(mass / norm)])
        self._cum[-1] = 1.0

    @property
    def support(self) -> tuple[float, float]:
        return float(self.x[0]), float(self.x[-1])

    def pdf(self, v: ArrayLike) -> np.ndarray:
        """Normalised density at ``v`` (zero outside the table)."""
        v = np.asarray(v, dtype=float)
        return np.interp(v, self.x, self.w, left=0.0, right=0.0)

    def cdf(self, v: ArrayLike) -> np.ndarray:
        v = np.asarray(v, dtype=float)
        k = np.clip(np.searchsorted(self.x, v, side="right") - 1, 0, len(self._h) - 1)
        t = np.clip(v - self.x[k], 0.0, self._h[k])
        inside = self._cum[k] + self.w[k] * t + 0.5 * self._slope[k] * t * t
        return np.where(v < self.x[0], 0.0, np.where(v >= self.x[-1], 1.0, inside))

    def ppf(self, q: ArrayLike) -> np.ndarray:
        """Exact inverse CDF for ``q`` in [0, 1]."""
        q = np.asarray(q, dtype=float)
        k = np.clip(np.searchsorted(self._cum, q, side="right") - 1, 0, len(self._h) - 1)
        r = np.maximum(q - self._cum[k], 0.0)
        b = self.w[k]
        root = np.sqrt(np.maximum(b * b + 2.0 * self._slope[k] * r, 0.0))
        den = b + root
        with np.errstate(divide="ignore", invalid="ignore"):
            t = np.where(den > 0, 2.0 * r / den, 0.0)  # root of b t + slope t^2 / 2 = r
        return self.x[k] + np.clip(t, 0.0, self._h[k])

    def sample(
        self, rng: np.random.Generator, n: int, lo: float = -np.inf, hi: float = np.inf
    ) -> np.ndarray:
        """``n`` exact draws, truncated to ``[lo, hi]`` (which must hold probability)."""
        qlo, qhi = (float(c) for c in self.cdf(np.array([lo, hi])))
        return self.ppf(qlo + rng.random(n) * (qhi - qlo))


class Histogram:
    """A law with constant density inside each bin.

    Parameters
    ----------
    edges
        (k + 1,) strictly increasing bin edges.
    contents
        (k,) non-negative bin contents (counts or probabilities, not densities).
    """

    def __init__(
        self, edges: ArrayLike, contents: ArrayLike, what: str = "histogram", xname: str = "x"
    ) -> None:
        edges = np.asarray(edges, dtype=float).ravel()
        contents = np.asarray(contents, dtype=float).ravel()
        if len(edges) != len(contents) + 1:
            raise ConfigError(
                f"{what}: need len(edges) == len(contents) + 1, got {len(edges)} and "
                f"{len(contents)}"
            )
        _check_table(
            edges, np.append(contents, 0.0), [f"row {i}" for i in range(len(edges))], what, xname
        )
        self.edges = edges
        self.p = contents / contents.sum()
        self._cum = np.concatenate([[0.0], np.cumsum(self.p)])
        self._cum[-1] = 1.0
        self._bins = DiscreteSampler(self.p, what)

    @property
    def support(self) -> tuple[float, float]:
        return float(self.edges[0]), float(self.edges[-1])

    def pdf(self, v: ArrayLike) -> np.ndarray:
        v = np.asarray(v, dtype=float)
        k = np.clip(np.searchsorted(self.edges, v, side="right") - 1, 0, len(self.p) - 1)
        dens = self.p[k] / np.diff(self.edges)[k]
        return np.where((v < self.edges[0]) | (v >= self.edges[-1]), 0.0, dens)

    def cdf(self, v: ArrayLike) -> np.ndarray:
        return np.interp(np.asarray(v, dtype=float), self.edges, self._cum)

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        k = self._bins.sample(rng, n)
        return self.edges[k] + rng.random(n) * (self.edges[k + 1] - self.edges[k])


_UNIT_LINE = re.compile(r"^#\s*unit\s*[:=]\s*(\S+)\s*$", re.IGNORECASE)


def read_table(
    path: str | Path, dimension: str, unit: str | None = None, what: str = "table", xname: str = "x"
) -> tuple[np.ndarray, np.ndarray]:
    """Read a two-column ``value weight`` text table; values are returned in internal units.

    Lines are ``<value> <weight>`` (separated by blanks or one comma). ``#`` starts a comment;
    blank lines are skipped. The unit of the first column comes from a header line
    ``# unit: nm`` or from ``unit``; one of them is required, and they must agree if both are
    given. Values must be >= 0 and strictly increasing, weights >= 0 and not all zero.

    Raises
    ------
    ConfigError
        Naming the file, the line and the broken rule.
    """
    path = Path(path)
    units = DIMENSIONS[dimension]
    label = f"{what} {path}"
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as err:
        raise ConfigError(f"{label}: cannot read the file ({err})") from None
    header_unit, rows, lines = None, [], []
    for number, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if match := _UNIT_LINE.match(line):
            if header_unit not in (None, match.group(1)):
                raise ConfigError(
                    f"{label} line {number}: second unit header {match.group(1)!r} differs from "
                    f"{header_unit!r}"
                )
            header_unit = match.group(1)
            continue
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        fields = [f for f in re.split(r"[,\s]+", line) if f]
        try:
            if len(fields) != 2:
                raise ValueError
            rows.append((float(fields[0]), float(fields[1])))
        except ValueError:
            raise ConfigError(
                f"{label} line {number}: cannot read {brief(raw.strip())} as two numbers '{xname} "
                "weight'"
            ) from None
        lines.append(f"line {number}")
    if header_unit and unit and header_unit != unit:
        raise ConfigError(
            f"{label}: header says unit {header_unit!r} but {unit!r} was given; they must agree"
        )
    chosen = header_unit or unit
    if chosen is None:
        raise ConfigError(
            f"{label}: no unit for the {xname} column; add a header line '# unit: "
            f"{next(iter(units))}' or pass the unit (one of: {', '.join(units)})"
        )
    if chosen not in units:
        raise ConfigError(
            f"{label}: unknown {dimension} unit {chosen!r}; use one of: {', '.join(units)}"
        )
    data = np.array(rows, dtype=float).reshape(-1, 2)
    x, w = data[:, 0] * units[chosen], data[:, 1]
    _check_table(x / units[chosen], w, lines, label, xname)
    top = {"length": (limits.MAX_LENGTH, "100 m"), "energy": (limits.MAX_ENERGY, "100 TeV")}
    if dimension in top and x[-1] > top[dimension][0]:
        raise ConfigError(
            f"{label} {lines[-1]}: {xname} {x[-1] / units[chosen]:g} {chosen} is above "
            f"{top[dimension][1]}, score4's limit for any {dimension} (a unit slip?)"
        )
    return x, w


# --------------------------------------------------------------------------------------------
# Triangles
# --------------------------------------------------------------------------------------------


def as_triangles(
    triangles: ArrayLike | None = None,
    *,
    vertices: ArrayLike | None = None,
    faces: ArrayLike | None = None,
) -> np.ndarray:
    """Return an ``(m, 3, 3)`` float array from either a triangle array or vertices + faces."""
    if triangles is not None:
        if vertices is not None or faces is not None:
            raise ConfigError("triangles: give either triangles or vertices + faces, not both")
        tri = np.asarray(triangles, dtype=float)
    else:
        if vertices is None or faces is None:
            raise ConfigError(
                "triangles: give triangles (m, 3, 3) or both vertices (n, 3) and faces (m, 3)"
            )
        v = np.asarray(vertices, dtype=float)
        f = np.asarray(faces)
        if v.ndim != 2 or v.shape[1] != 3 or f.ndim != 2 or f.shape[1] != 3:
            raise ConfigError(
                f"triangles: need vertices (n, 3) and faces (m, 3), got {v.shape} and {f.shape}"
            )
        if (
            not np.issubdtype(f.dtype, np.integer)
            or f.min(initial=0) < 0
            or f.max(initial=0) >= len(v)
        ):
            raise ConfigError(f"faces: must be integer indices in [0, {len(v) - 1}]")
        tri = v[f]
    if tri.ndim != 3 or tri.shape[1:] != (3, 3) or len(tri) == 0:
        raise ConfigError(f"triangles: need a non-empty (m, 3, 3) array, got shape {tri.shape}")
    if not np.isfinite(tri).all():
        raise ConfigError("triangles: vertex coordinates must be finite")
    return tri


def _cross(tri: np.ndarray) -> np.ndarray:
    return np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])


def triangle_areas(triangles: np.ndarray) -> np.ndarray:
    """(m,) areas of ``(m, 3, 3)`` triangles."""
    return 0.5 * np.linalg.norm(_cross(triangles), axis=1)


def triangle_normals(triangles: np.ndarray) -> np.ndarray:
    """(m, 3) unit normals ``(b - a) x (c - a)``; zero rows for degenerate triangles."""
    c = _cross(triangles)
    norm = np.linalg.norm(c, axis=1, keepdims=True)
    return np.divide(c, norm, out=np.zeros_like(c), where=norm > 0)


@dataclass
class SurfaceSample:
    """Points drawn on a surface.

    Attributes
    ----------
    position
        (n, 3) points in mm.
    normal
        (n, 3) unit outward normals of the triangle each point lies on.
    facet
        (n,) triangle index, or the caller's per-triangle id when ids were given.
    patch
        (n,) flat cell index on a tiled face (``i * ny + j``), else None.
    variant
        (n,) patch variant of that cell on a tiled face, else None.
    face
        (n,) index of the volume's face the point lies on (samplers on several faces of a
        shape, :mod:`score4.source.shape_sampling`), else None.
    """

    position: np.ndarray
    normal: np.ndarray
    facet: np.ndarray
    patch: np.ndarray | None = None
    variant: np.ndarray | None = None
    face: np.ndarray | None = None


class SurfaceSampler:
    """Uniform points per true area on a set of triangles.

    Parameters
    ----------
    triangles
        (m, 3, 3) vertex coordinates (or pass ``vertices`` and ``faces``).
    facet_ids
        Optional (m,) integer ids reported instead of the triangle index.

    Notes
    -----
    A triangle is chosen with probability proportional to its area (:class:`DiscreteSampler`),
    then a point uniformly inside it: two uniforms ``(s, t)`` reflected into ``s + t <= 1``
    give ``a + s (b - a) + t (c - a)``. Zero-area triangles are never chosen.
    """

    def __init__(
        self,
        triangles: ArrayLike | None = None,
        *,
        vertices: ArrayLike | None = None,
        faces: ArrayLike | None = None,
        facet_ids: ArrayLike | None = None,
    ) -> None:
        tri = as_triangles(triangles, vertices=vertices, faces=faces)
        self.triangles = tri
        self.areas = triangle_areas(tri)
        if not (self.areas > 0).any():
            raise ConfigError(f"triangles: all {len(tri)} triangles have zero area")
        self.normals = triangle_normals(tri)
        self.area = float(self.areas.sum())
        self.facet_ids = None
        if facet_ids is not None:
            ids = np.asarray(facet_ids)
            if ids.shape != (len(tri),) or not np.issubdtype(ids.dtype, np.integer):
                raise ConfigError(
                    f"facet_ids: need ({len(tri)},) integers, got {ids.dtype} {ids.shape}"
                )
            self.facet_ids = ids.astype(np.int64)
        # contiguous per-triangle arrays make the per-draw gathers cheap
        self._a = np.ascontiguousarray(tri[:, 0])
        self._e1 = np.ascontiguousarray(tri[:, 1] - tri[:, 0])
        self._e2 = np.ascontiguousarray(tri[:, 2] - tri[:, 0])
        self._choice = DiscreteSampler(self.areas, "triangle areas")

    def __len__(self) -> int:
        return len(self.triangles)

    def facet_id(self, index: np.ndarray) -> np.ndarray:
        """Map triangle indices to the reported facet ids."""
        return index if self.facet_ids is None else np.take(self.facet_ids, index)

    def points_in(self, rng: np.random.Generator, index: np.ndarray) -> np.ndarray:
        """One uniform point inside each triangle ``index[i]``."""
        st = rng.random((2, len(index)))
        flip = st.sum(axis=0) > 1.0
        st[:, flip] = 1.0 - st[:, flip]
        return (
            np.take(self._a, index, axis=0)
            + st[0, :, None] * np.take(self._e1, index, axis=0)
            + st[1, :, None] * np.take(self._e2, index, axis=0)
        )

    def sample_index(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """``n`` triangle indices drawn by area."""
        return self._choice.sample(rng, n)

    def sample(self, rng: np.random.Generator, n: int) -> SurfaceSample:
        """``n`` points uniform per area, with their triangle's outward normal and id."""
        index = self.sample_index(rng, n)
        return SurfaceSample(
            position=self.points_in(rng, index),
            normal=np.take(self.normals, index, axis=0),
            facet=self.facet_id(index),
        )


class IndexedSurfaceSampler(SurfaceSampler):
    """A :class:`SurfaceSampler` that keeps ``vertices`` and ``faces`` (shared with their
    owner) and gathers the drawn triangles' corners per draw instead of holding every
    triangle's corners, edges and normal: the same points and normals (the same arithmetic on
    the same rows) in a tenth of the memory."""

    def __init__(self, vertices: np.ndarray, faces: np.ndarray) -> None:
        self._vertices, self._faces = vertices, faces
        tri = vertices[faces]
        self.areas = triangle_areas(tri)
        if not (self.areas > 0).any():
            raise ConfigError(f"triangles: all {len(tri)} triangles have zero area")
        self.area = float(self.areas.sum())
        self.facet_ids = None
        self._choice = DiscreteSampler(self.areas, "triangle areas")

    def __len__(self) -> int:
        return len(self._faces)

    def _corners(self, index: np.ndarray) -> np.ndarray:
        return self._vertices[self._faces[index]]

    def points_in(self, rng: np.random.Generator, index: np.ndarray) -> np.ndarray:
        st = rng.random((2, len(index)))
        flip = st.sum(axis=0) > 1.0
        st[:, flip] = 1.0 - st[:, flip]
        tri = self._corners(index)
        return (
            tri[:, 0]
            + st[0, :, None] * (tri[:, 1] - tri[:, 0])
            + st[1, :, None] * (tri[:, 2] - tri[:, 0])
        )

    def sample(self, rng: np.random.Generator, n: int) -> SurfaceSample:
        index = self.sample_index(rng, n)
        return SurfaceSample(
            position=self.points_in(rng, index),
            normal=triangle_normals(self._corners(index)),
            facet=index,
        )


def orthonormal_basis(n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors ``(e1, e2)`` completing unit vectors ``n`` (k, 3) to right-handed frames."""
    helper = np.zeros_like(n)
    use_x = np.abs(n[:, 0]) < 0.9  # any axis not nearly parallel to n
    helper[use_x, 0] = 1.0
    helper[~use_x, 1] = 1.0
    e1 = np.cross(helper, n)
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    return e1, np.cross(n, e1)


def _rotation(rotation: ArrayLike | None) -> np.ndarray:
    if rotation is None:
        return np.eye(3)
    r = np.asarray(rotation, dtype=float)
    if r.shape != (3, 3) or not np.allclose(r @ r.T, np.eye(3), atol=1e-9) or np.linalg.det(r) < 0:
        raise ConfigError("rotation: must be a 3 x 3 proper rotation matrix (orthonormal, det +1)")
    return r


class TiledSurfaceSampler:
    """Uniform points per true area on a face tiled from patch variants.

    The face is an ``nx x ny`` grid of cells of size ``pitch = (px, py)``. Cell ``(i, j)`` holds
    patch variant ``layout[i, j]``; each variant is a triangle set in patch-local coordinates
    (normally spanning ``[0, px] x [0, py]`` in x, y). A point in cell ``(i, j)`` is
    ``origin + rotation @ (local + (i px, j py, 0))``.

    Parameters
    ----------
    variants
        One :class:`SurfaceSampler` (or ``(m, 3, 3)`` triangle array) per variant.
    layout
        (nx, ny) integer array of variant indices; -1 marks a cell without patch (the cells
        of a round face that are not wholly inside it).
    pitch
        (px, py) cell size in mm.
    origin
        (3,) position of the corner of cell (0, 0), in mm.
    rotation
        Optional 3 x 3 rotation from face coordinates to world coordinates.

    Notes
    -----
    A variant ``k`` is chosen with probability ``n_k A_k / sum_l n_l A_l`` (``n_k`` cells of
    true area ``A_k``), then one of its cells uniformly, which is the same as choosing a
    cell with probability proportional to its true area. The reported ``patch`` is the flat
    index ``i * ny + j`` of the cell the surface point lies in.
    """

    def __init__(
        self,
        variants: Sequence[SurfaceSampler | ArrayLike],
        layout: ArrayLike,
        pitch: tuple[float, float],
        origin: ArrayLike = (0.0, 0.0, 0.0),
        rotation: ArrayLike | None = None,
    ) -> None:
        self.variants = [
            v if isinstance(v, SurfaceSampler) else SurfaceSampler(v) for v in variants
        ]
        grid = np.asarray(layout)
        if grid.ndim != 2 or grid.size == 0 or not np.issubdtype(grid.dtype, np.integer):
            raise ConfigError(
                f"layout: need a non-empty 2-D integer array of variant indices, got {grid.dtype} "
                f"{grid.shape}"
            )
        if grid.min() < -1 or grid.max() >= len(self.variants) or grid.max() < 0:
            raise ConfigError(
                f"layout: variant indices must be in [0, {len(self.variants) - 1}] (-1: a cell "
                f"without patch, not all), got {grid.min()}..{grid.max()}"
            )
        sizes = tuple(float(p) for p in pitch)
        if len(sizes) != 2 or not all(np.isfinite(p) and p > 0 for p in sizes):
            raise ConfigError(f"pitch: need two positive cell sizes (px, py) in mm, got {pitch!r}")
        self.pitch = (sizes[0], sizes[1])
        self.origin = np.asarray(origin, dtype=float).reshape(3)
        self.rotation = _rotation(rotation)
        self.layout = grid
        self.shape = grid.shape
        lo, hi = int(grid.min()), int(grid.max())
        self._cells_of: list[np.ndarray | None]
        if lo == hi:  # one variant in every cell: cell n is the n-th (no 10^7-cell index arrays)
            self.cell_counts = np.zeros(len(self.variants), dtype=np.int64)
            self.cell_counts[lo] = grid.size
            self._cells_of = [None] * len(self.variants)
        else:
            flat = grid.astype(np.int64).ravel()
            order = np.argsort(flat, kind="stable")
            order = order[flat[order] >= 0]  # cells of -1 hold no patch (outside a round face)
            self.cell_counts = np.bincount(flat[flat >= 0], minlength=len(self.variants))
            self._cells_of = list(np.split(order, np.cumsum(self.cell_counts)[:-1]))
        variant_area = np.array([v.area for v in self.variants])
        self.area = float((self.cell_counts * variant_area).sum())
        self._variant_choice = DiscreteSampler(self.cell_counts * variant_area, "variant areas")

    def cell_offset(self, patch: np.ndarray) -> np.ndarray:
        """(n, 3) local offsets ``(i px, j py, 0)`` of flat cell indices."""
        i, j = np.divmod(patch, self.shape[1])
        return np.stack([i * self.pitch[0], j * self.pitch[1], np.zeros(len(patch))], axis=1)

    def to_world(self, local: np.ndarray, patch: np.ndarray) -> np.ndarray:
        """Patch-local points of cells ``patch`` to world coordinates."""
        return self.origin + (local + self.cell_offset(patch)) @ self.rotation.T

    def sample_cells(self, rng: np.random.Generator, variant: np.ndarray) -> np.ndarray:
        """A uniformly chosen cell of each requested variant."""
        patch = np.empty(len(variant), dtype=np.int64)
        for k, cells in enumerate(self._cells_of):
            rows = np.flatnonzero(variant == k)
            if len(rows):
                n = int(self.cell_counts[k])
                pick = rng.integers(0, n, len(rows))
                patch[rows] = pick if cells is None else cells[pick]
        return patch

    def sample(self, rng: np.random.Generator, n: int) -> SurfaceSample:
        """``n`` points uniform per true area over the whole face."""
        variant = self._variant_choice.sample(rng, n)
        patch = self.sample_cells(rng, variant)
        local = np.empty((n, 3))
        normal = np.empty((n, 3))
        facet = np.empty(n, dtype=np.int64)
        for k, sampler in enumerate(self.variants):
            rows = np.flatnonzero(variant == k)
            if len(rows):
                s = sampler.sample(rng, len(rows))
                local[rows], normal[rows], facet[rows] = s.position, s.normal, s.facet
        return SurfaceSample(
            position=self.to_world(local, patch),
            normal=normal @ self.rotation.T,
            facet=facet,
            patch=patch,
            variant=variant,
        )


class RingSurfaceSampler:
    """Uniform points per true area on the bent patch tops of a rough layer on a face swept
    around z (:class:`score4.world.scene.CurvedRoughLayer`), in world coordinates.

    A cell is chosen with probability proportional to the area of its variant's bent top
    (exact: the triangles Geant4 gets), then a point uniformly on those triangles, rotated
    about z to the cell's azimuth and moved to its ring. ``patch`` is the flat cell index
    ``j * nx + i`` (ring j, cell i), ``variant`` the cell's variant.
    """

    def __init__(self, layer: Any) -> None:
        self.layer = layer
        cells = layer.cells()
        self.ring = np.array([c[0] for c in cells], np.int64)
        self.index = np.array([c[1] for c in cells], np.int64)
        self.variant = np.array([c[2] for c in cells], np.int64)
        self.phi = np.array([c[3] for c in cells], float)
        self.nx = int(layer.cell_variants.shape[1])
        self.z = np.array([layer.ring_layout.ring_z(j) for j in range(len(layer.ring_layout.v))])
        self._samplers: dict[tuple[int, int], SurfaceSampler] = {}
        key = np.array([layer.ring_solid_key(j) for j in range(len(layer.ring_layout.v))])
        first = np.array([int(np.flatnonzero(key == r)[0]) for r in key], np.int64)
        self.keys = np.column_stack([self.variant, first[self.ring]])  # cells sharing a mesh
        # the tops' areas only: a ring's sampler is made when a point is drawn on it (a sphere
        # has a mesh per ring, ~2 MB each as triangles)
        area_of = {
            (int(k), int(j)): layer.top_area(int(k), int(j))
            for k, j in np.unique(self.keys, axis=0)
        }
        area = np.array([area_of[(int(k), int(j))] for k, j in self.keys])
        self.area = float(area.sum())
        self._choice = DiscreteSampler(area, "cell areas")

    def _sampler(self, k: int, j: int) -> SurfaceSampler:
        if (k, j) not in self._samplers:
            bent = self.layer.bent(k, j)
            self._samplers[(k, j)] = IndexedSurfaceSampler(bent.vertices, bent.faces[: bent.n_top])
        return self._samplers[(k, j)]

    def sample(self, rng: np.random.Generator, n: int) -> SurfaceSample:
        cell = self._choice.sample(rng, n)
        local, normal = np.empty((n, 3)), np.empty((n, 3))
        facet = np.empty(n, np.int64)
        chosen = self.keys[cell]
        for k, j in {(int(a), int(b)) for a, b in chosen}:
            rows = np.flatnonzero((chosen[:, 0] == k) & (chosen[:, 1] == j))
            s = self._sampler(k, j).sample(rng, len(rows))
            local[rows], normal[rows], facet[rows] = s.position, s.normal, s.facet
        c, s_ = np.cos(self.phi[cell]), np.sin(self.phi[cell])

        def turn(p: np.ndarray) -> np.ndarray:
            return np.column_stack(
                [c * p[:, 0] - s_ * p[:, 1], s_ * p[:, 0] + c * p[:, 1], p[:, 2]]
            )

        pos = turn(local)
        pos[:, 2] += self.z[self.ring[cell]]
        target = self.layer.target
        return SurfaceSample(
            position=target.to_world(pos),
            normal=turn(normal) @ target.rotation.T,
            facet=facet,
            patch=self.ring[cell] * self.nx + self.index[cell],
            variant=self.variant[cell],
        )


class CurvedRemainderSampler:
    """Uniform points on the part of a curved face that holds no patch (the strips at the ends
    of the generator and beside the cells of each ring), on the exact surface: drawn on the
    whole face per area, points in a patch's cell rejected."""

    def __init__(self, layer: Any) -> None:
        self.layer = layer
        face = layer.ring_layout.face
        self.patch = _revolved_patch(face)
        py = layer.patch_size[1]
        # the cells' share of the face, exactly: each cell spans its angular pitch over py
        lay = layer.ring_layout
        covered = 0.0
        for j in range(len(lay.v)):
            held = int((layer.cell_variants[j] >= 0).sum())  # all count cells but on a boolean
            if hasattr(face, "band_area"):  # a sphere
                v0, v1 = lay.v[j] - py / 2, lay.v[j] + py / 2
                covered += face.band_area(v0, v1, float(held * lay.step[j]))
                continue
            r_lo, r_hi = face.radius(lay.v[j] - py / 2), face.radius(lay.v[j] + py / 2)
            covered += float(held * lay.step[j] * py * 0.5 * (r_lo + r_hi))
        self.area = max(float(face.area) - covered, 0.0)

    def sample(self, rng: np.random.Generator, n: int) -> SurfaceSample:
        pts = np.empty((0, 3))
        nrm = np.empty((0, 3))
        while len(pts) < n:
            m = 4 * (n - len(pts)) + 16
            p, q = self.patch.sample(rng, m)
            j, i, _ = self.layer.ring_layout.locate(p)
            keep = j < 0
            keep[~keep] = self.layer.cell_variants[j[~keep], i[~keep]] < 0
            pts, nrm = np.concatenate([pts, p[keep]]), np.concatenate([nrm, q[keep]])
        target = self.layer.target
        none = np.full(n, -1, np.int64)
        return SurfaceSample(
            target.to_world(pts[:n]),
            nrm[:n] @ target.rotation.T,
            none.copy(),
            none.copy(),
            none.copy(),
        )


def _revolved_patch(face: Any) -> Any:
    from ..shapes.base import Revolved, SphereZone

    if hasattr(face, "sphere_radius"):
        return SphereZone(0, face.sphere_radius, face.theta, face.phi0, face.dphi, face.sign)
    return Revolved(0, face.rz1, face.rz2, face.phi0, face.dphi, face.nrz)
