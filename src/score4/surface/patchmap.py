"""The patch map of a large rough face: which surface variant each tile of the face shows.

A face of ``Lx`` x ``Ly`` is covered by an ``nx`` x ``ny`` grid of equal rectangular patches of
``px`` x ``py`` (``Lx = nx px``, ``Ly = ny py``). Each cell shows one of ``K`` surface variants
(for example three random-surface patches with different seeds, or spike grids of different
heights), chosen with target densities ``d_k`` (normalised to sum 1).

Conventions:

* ``variants[j, i]`` is the variant of cell ``(i, j)``: row ``j`` is the y index, column ``i``
  the x index (C order, like every height map in :mod:`score4.surface`);
* the face is centred on (0, 0): cell ``(i, j)`` spans
  ``[-Lx/2 + i px, -Lx/2 + (i+1) px) x [-Ly/2 + j py, -Ly/2 + (j+1) py)`` (half-open, so a point
  on an inner cell boundary belongs to the cell with the larger index; points on the outer
  border belong to the border cell);
* method ``"exact"``: the counts per variant follow the largest-remainder method
  (:func:`largest_remainder`), so ``|count_k - n d_k| < 1`` for every ``k``, and the positions
  are a uniformly random permutation drawn with ``numpy.random.default_rng(seed)``;
  method ``"random"``: every cell is drawn independently with probabilities ``d_k``, as in the
  original SCoRe4 (realised fractions then scatter binomially around the targets);
  method ``"tiles"``: the map is made of a small library of ``n_tiles`` random tiles of
  ``T`` x ``T`` cells (filled like ``"exact"`` over the whole library: largest-remainder counts
  over its ``n_tiles T^2`` cells, random positions), laid on the face in random order, each
  tile used equally often (to within one use)
  (:func:`tile_cells` gives ``T``: the size of the groups that native tiling places, so Geant4
  holds each library tile once instead of one placement per cell);
  method ``"given"``: a grid supplied by the user (:func:`given_patch_map`).

The map is stored with a run so that the same geometry can be rebuilt: :meth:`PatchMap.to_dict`
gives a JSON-able dictionary (the grid as an exact run-length string), :meth:`PatchMap.save_h5`
writes it into an HDF5 group.
"""

from __future__ import annotations

import math
import numbers
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from score4.inputs import limits
from score4.inputs.units import parse_quantity

from ..errors import ConfigError, Score4Warning

METHODS = ("exact", "random", "tiles", "given")

#: Format name and version written by :meth:`PatchMap.to_dict` and :meth:`PatchMap.save_h5`.
FORMAT = "score4-patch-map"
FORMAT_VERSION = 1

#: Relative tolerance within which ``nx * px`` must reproduce the requested face length.
SIZE_RTOL = 1e-9

#: Tolerance on the sum of the densities before they are renormalised with a warning.
DENSITY_SUM_TOL = 1e-9

#: Largest number of cells a map may hold (10^8 cells are 400 MB of variant indices).
MAX_CELLS = 10**8

#: Most boxes the envelope of a native face holds directly (50 x 50); above, cells are grouped
#: (score4.geometry.tiling). ``fill: tiles`` uses tiles of that group size.
MAX_TOP_BOXES = 2500
#: Tiles in the library of ``fill: tiles`` unless given.
DEFAULT_TILES = 64

_VARIANT_DTYPE = np.int32
_DICT_KEYS = (
    "format",
    "format_version",
    "shape",
    "patch_size",
    "densities",
    "method",
    "seed",
    "variants",
)


# --- input helpers ---------------------------------------------------------------------------


def _fmt(v: float) -> str:
    return f"{v:.12g}"


def _length(value: object, name: str) -> float:
    """A positive finite length in mm, from a number (mm) or a string with a unit."""
    v = parse_quantity(value, "length", name) if isinstance(value, str) else value
    if (
        isinstance(v, bool)
        or not isinstance(v, numbers.Real)
        or not (math.isfinite(v) and float(v) > 0)
    ):
        raise ConfigError(f"{name}: must be a positive length, got {value!r}")
    return float(v)


def _pair(value: object, name: str) -> tuple[float, float]:
    """``(x, y)`` lengths in mm; a single length means a square."""
    if isinstance(value, (str, numbers.Real)):
        v = _length(value, name)
        return v, v
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if not isinstance(value, Sequence) or len(value) != 2:
        raise ConfigError(f"{name}: must be a length or a pair (x, y) of lengths, got {value!r}")
    return _length(value[0], f"{name}[0]"), _length(value[1], f"{name}[1]")


def _seed(seed: object) -> int | None:
    if seed is None:
        return None
    if isinstance(seed, bool) or not isinstance(seed, numbers.Integral) or seed < 0:
        raise ConfigError(f"seed: must be an integer >= 0 or None, got {seed!r}")
    return int(seed)


def _method(method: object, allowed: Sequence[str] = METHODS) -> str:
    if method not in allowed:
        raise ConfigError(f"method: must be one of {', '.join(allowed)}, got {method!r}")
    return str(method)


def _cells_along(face: float, patch: float, axis: str) -> int:
    """Number of patches ``round(face / patch)``; the face must be a whole number of patches."""
    if patch > face * (1 + SIZE_RTOL):
        raise ConfigError(
            f"patch_size: {_fmt(patch)} mm along {axis} is larger than the face "
            f"(face_size {_fmt(face)} mm); the face must hold at least one patch"
        )
    n = max(1, round(face / patch))
    if abs(n * patch - face) > SIZE_RTOL * face:
        lo = max(1, math.floor(face / patch))
        hi = max(lo + 1, math.ceil(face / patch))
        raise ConfigError(
            f"face_size: {_fmt(face)} mm along {axis} is not a whole number of {_fmt(patch)} mm "
            f"patches; nearest valid sizes {_fmt(lo * patch)} mm ({lo} patches) or "
            f"{_fmt(hi * patch)} mm ({hi} patches)"
        )
    return n


def _densities(densities: object) -> np.ndarray:
    """Positive finite weights, normalised to sum 1 (with a warning if they did not)."""
    if isinstance(densities, (str, bytes)) or not isinstance(densities, (Sequence, np.ndarray)):
        raise ConfigError(f"densities: must be a sequence of positive numbers, got {densities!r}")
    if isinstance(densities, np.ndarray) and densities.ndim != 1:
        raise ConfigError(
            f"densities: must be a 1-D sequence of positive numbers, got shape {densities.shape}"
        )
    values = list(densities)
    if not values:
        raise ConfigError("densities: must hold at least one value, got an empty sequence")
    for k, v in enumerate(values):
        if isinstance(v, bool) or not isinstance(v, numbers.Real):
            raise ConfigError(f"densities[{k}]: must be a positive number, got {v!r}")
        if not math.isfinite(v):
            raise ConfigError(f"densities[{k}]: must be finite, got {v!r}")
        if v <= 0:
            raise ConfigError(f"densities[{k}]: must be positive, got {v!r}")
    d = np.array(values, dtype=float)
    total = float(d.sum())
    if abs(total - 1.0) > DENSITY_SUM_TOL:
        normalised = ", ".join(_fmt(x) for x in d / total)
        warnings.warn(
            f"densities: sum is {_fmt(total)}, not 1; normalised to [{normalised}]",
            Score4Warning,
            stacklevel=3,
        )
    return d / total


def largest_remainder(n: int, weights: Sequence[float] | np.ndarray) -> np.ndarray:
    """Split ``n`` items among ``K`` classes in proportion to ``weights`` (largest-remainder
    method).

    Each class first gets ``floor(n w_k)`` (weights normalised to sum 1); the items left over
    go, one each, to the classes with the largest fractional parts ``n w_k - floor(n w_k)``,
    ties broken by class order. The counts sum to ``n`` and ``|count_k - n w_k| < 1``.

    Parameters
    ----------
    n
        Number of items, >= 0.
    weights
        Non-negative weights with a positive sum.

    Returns
    -------
    numpy.ndarray
        ``(K,)`` int64 counts.
    """
    w = np.asarray(weights, dtype=float)
    if w.ndim != 1 or w.size == 0 or not np.all(np.isfinite(w)) or np.any(w < 0) or w.sum() <= 0:
        raise ConfigError(
            f"weights: must be non-negative finite numbers with a positive sum, got {weights!r}"
        )
    given: object = n  # checked at run time: callers may pass anything
    if isinstance(given, bool) or not isinstance(given, numbers.Integral) or given < 0:
        raise ConfigError(f"n: must be an integer >= 0, got {n!r}")
    quota = n * (w / w.sum())
    # Quotas within rounding noise of an integer are that integer (n * 0.3 for n = 40000 is
    # 12000 up to one ulp); fractional parts are compared at 1e-9 so equal targets tie exactly.
    nearest = np.rint(quota)
    quota = np.where(np.abs(quota - nearest) <= 1e-9 * np.maximum(1.0, quota), nearest, quota)
    base = np.floor(quota).astype(np.int64)
    left = int(n - base.sum())
    frac = np.round(quota - base, 9)
    order = np.argsort(-frac, kind="stable")
    counts = base.copy()
    counts[order[: max(left, 0)]] += 1
    return counts


# --- run-length text of a grid ---------------------------------------------------------------


def _rle_encode(flat: np.ndarray) -> str:
    if flat.size == 0:
        return ""
    starts = np.flatnonzero(np.diff(flat)) + 1
    starts = np.concatenate(([0], starts))
    lengths = np.diff(np.concatenate((starts, [flat.size])))
    values = flat[starts]
    return ",".join(
        f"{v}" if c == 1 else f"{v}*{c}"
        for v, c in zip(values.tolist(), lengths.tolist(), strict=True)
    )


def _rle_decode(text: str, size: int) -> np.ndarray:
    values: list[int] = []
    lengths: list[int] = []
    try:
        for token in text.split(","):
            v, star, c = token.partition("*")
            values.append(int(v))
            lengths.append(int(c) if star else 1)
    except ValueError:
        raise ConfigError(
            f"variants: cannot read the run-length text near {token[:30]!r}; expected 'v' or "
            "'v*count' items separated by commas"
        ) from None
    if min(lengths) < 1:
        raise ConfigError(f"variants: run-length counts must be >= 1, got {min(lengths)}")
    if sum(lengths) != size:
        raise ConfigError(
            f"variants: the run-length text holds {sum(lengths)} cells, expected {size} (shape)"
        )
    return np.repeat(np.array(values, dtype=np.int64), lengths)


# --- the map ---------------------------------------------------------------------------------


def _check_variants(
    variants: object, n_variants: int | None, name: str = "variants"
) -> tuple[np.ndarray, int]:
    """An (ny, nx) integer grid of indices in 0..K-1 (integral floats accepted) and K."""
    a = np.asarray(variants)
    if a.ndim != 2 or a.size == 0:
        raise ConfigError(f"{name}: must be a non-empty 2-D (ny, nx) array, got shape {a.shape}")
    if a.dtype == bool or not (
        np.issubdtype(a.dtype, np.integer) or np.issubdtype(a.dtype, np.floating)
    ):
        raise ConfigError(f"{name}: must hold integer variant indices, got dtype {a.dtype}")
    if np.issubdtype(a.dtype, np.floating):
        bad = ~np.isfinite(a) | (a != np.round(a))
        if bad.any():
            j, i = np.argwhere(bad)[0]
            raise ConfigError(
                f"{name}: must hold integer variant indices, got {a[j, i].item()!r} at row {j}, "
                f"column {i}"
            )
    lo, hi = int(a.min()), int(a.max())
    if n_variants is None:
        k = hi + 1
    else:
        given: object = n_variants  # checked at run time: callers may pass anything
        if isinstance(given, bool) or not isinstance(given, numbers.Integral) or given < 1:
            raise ConfigError(f"n_variants: must be an integer >= 1, got {n_variants!r}")
        k = int(n_variants)
    if lo < 0 or hi >= k:
        bad_value = lo if lo < 0 else hi
        j, i = np.argwhere(a == bad_value)[0]
        raise ConfigError(
            f"{name}: value {bad_value} at row {j}, column {i} is out of range 0..{k - 1}"
            + (f" (n_variants={k})" if n_variants is not None else "")
        )
    if a.size > MAX_CELLS:
        raise ConfigError(f"{name}: {a.size} cells exceed the limit of {MAX_CELLS}")
    out = np.array(a, dtype=_VARIANT_DTYPE, order="C")
    out.setflags(write=False)
    return out, k


@dataclass(frozen=True, eq=False)
class PatchMap:
    """Which of ``K`` surface variants each cell of an ``nx`` x ``ny`` patch grid shows.

    Build one with :func:`make_patch_map`, :func:`uniform_patch_map` or :func:`given_patch_map`.

    Parameters
    ----------
    variants
        ``(ny, nx)`` integer array, ``variants[j, i]`` is the variant of cell ``(i, j)``
        (stored as a read-only int32 copy).
    patch_size
        ``(px, py)`` full patch size in mm (or strings with units).
    densities
        The ``K`` target densities, non-negative, summing to 1 (``K`` is their number).
    method
        ``"exact"``, ``"random"`` or ``"given"``: how the map was made.
    seed
        Seed of ``numpy.random.default_rng`` that drew the map, or None.
    """

    variants: np.ndarray
    patch_size: tuple[float, float]
    densities: tuple[float, ...]
    method: str = "given"
    seed: int | None = None
    _counts: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        given: object = self.densities  # checked at run time: callers may pass anything
        if (
            isinstance(given, (str, bytes))
            or not isinstance(given, (Sequence, np.ndarray))
            or len(given) == 0
        ):
            raise ConfigError(f"densities: must be a non-empty sequence, got {given!r}")
        d = np.asarray(given, dtype=float)
        if (
            d.ndim != 1
            or not np.all(np.isfinite(d))
            or np.any(d < 0)
            or abs(d.sum() - 1) > DENSITY_SUM_TOL
        ):
            raise ConfigError(
                "densities: must be non-negative finite numbers summing to 1, got "
                f"{self.densities!r}"
            )
        variants, _ = _check_variants(self.variants, len(d))
        self._set("variants", variants)
        self._set("densities", tuple(float(x) for x in d))
        self._set("patch_size", _pair(self.patch_size, "patch_size"))
        self._set("method", _method(self.method))
        self._set("seed", _seed(self.seed))
        if len(d) == 1:  # every cell shows variant 0 (checked): no pass over 10^7 cells
            counts = np.array([variants.size], dtype=np.int64)
        else:
            counts = np.bincount(variants.ravel(), minlength=len(d)).astype(np.int64)
        counts.setflags(write=False)
        self._set("_counts", counts)

    def _set(self, name: str, value: object) -> None:
        object.__setattr__(self, name, value)  # frozen: normalise once here

    # --- sizes and statistics ---------------------------------------------------------------

    @property
    def nx(self) -> int:
        """Number of patches along x."""
        return int(self.variants.shape[1])

    @property
    def ny(self) -> int:
        """Number of patches along y."""
        return int(self.variants.shape[0])

    @property
    def n_cells(self) -> int:
        """Number of cells ``nx * ny``."""
        return int(self.variants.size)

    @property
    def n_variants(self) -> int:
        """Number ``K`` of surface variants."""
        return len(self.densities)

    @property
    def face_size(self) -> tuple[float, float]:
        """``(Lx, Ly) = (nx px, ny py)`` in mm."""
        return self.nx * self.patch_size[0], self.ny * self.patch_size[1]

    @property
    def counts(self) -> np.ndarray:
        """``(K,)`` number of cells showing each variant (read-only)."""
        return self._counts

    @property
    def fractions(self) -> np.ndarray:
        """``(K,)`` realised fraction of cells showing each variant."""
        return self._counts / self.n_cells

    # --- geometry ---------------------------------------------------------------------------

    def cell_centre_axes(self) -> tuple[np.ndarray, np.ndarray]:
        """``(x, y)``: the ``(nx,)`` x and ``(ny,)`` y of the cell centres (cell ``(i, j)`` is
        centred at ``(x[i], y[j])``), without the ``(ny, nx, 2)`` array of
        :meth:`cell_centres` (640 MB on a 10 m^2 face of 0.5 mm cells)."""
        (px, py), (lx, ly) = self.patch_size, self.face_size
        x = -lx / 2 + (np.arange(self.nx) + 0.5) * px
        y = -ly / 2 + (np.arange(self.ny) + 0.5) * py
        return x, y

    def cell_centres(self) -> np.ndarray:
        """``(ny, nx, 2)`` cell centres (x, y) in mm, face centred on (0, 0).

        Cell ``(i, j)`` is centred at ``(-Lx/2 + (i + 0.5) px, -Ly/2 + (j + 0.5) py)`` and is
        found at ``[j, i]``.
        """
        x, y = self.cell_centre_axes()
        out = np.empty((self.ny, self.nx, 2))
        out[..., 0] = x[None, :]
        out[..., 1] = y[:, None]
        return out

    def cell_of(self, xy: np.ndarray | Sequence[Sequence[float]]) -> tuple[np.ndarray, np.ndarray]:
        """Indices ``(i, j)`` of the cells holding points ``xy`` (mm, face centred on (0, 0)).

        Parameters
        ----------
        xy
            ``(..., 2)`` points; typically ``(n, 2)``.

        Returns
        -------
        (i, j)
            int64 arrays of shape ``xy.shape[:-1]``: column (x) and row (y) index, so the
            variant is ``variants[j, i]``. Points outside the face (or not finite) give -1 in
            both. Inner boundaries belong to the cell with the larger index; the outer border
            belongs to the border cell.
        """
        p = np.asarray(xy, dtype=float)
        if p.ndim < 1 or p.shape[-1] != 2:
            raise ConfigError(
                f"xy: must be an array of (x, y) points with shape (n, 2), got shape {p.shape}"
            )
        (px, py), (lx, ly) = self.patch_size, self.face_size
        x, y = p[..., 0], p[..., 1]
        with np.errstate(invalid="ignore"):
            inside = (np.abs(x) <= lx / 2) & (np.abs(y) <= ly / 2)
            i = np.floor((np.where(inside, x, 0.0) + lx / 2) / px)
            j = np.floor((np.where(inside, y, 0.0) + ly / 2) / py)
        i = np.clip(i, 0, self.nx - 1).astype(np.int64)
        j = np.clip(j, 0, self.ny - 1).astype(np.int64)
        i[~inside] = -1
        j[~inside] = -1
        return i, j

    # --- storage ----------------------------------------------------------------------------

    def to_dict(self) -> dict[str, Any]:
        """A JSON-able dictionary that :meth:`from_dict` turns back into the same map exactly.

        Lengths keep their unit (``"0.5 mm"``, written with ``repr`` so floats round-trip); the
        grid is a run-length text over the cells in C order (row j = 0 first): comma-separated
        items ``v`` (one cell of variant v) or ``v*c`` (c cells in a row).
        """
        return {
            "format": FORMAT,
            "format_version": FORMAT_VERSION,
            "shape": [self.ny, self.nx],
            "patch_size": [f"{v!r} mm" for v in self.patch_size],
            "densities": list(self.densities),
            "method": self.method,
            "seed": self.seed,
            "variants": _rle_encode(self.variants.ravel()),
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> PatchMap:
        """The map stored by :meth:`to_dict`; ``variants`` may also be a list of rows."""
        if not isinstance(d, dict):
            raise ConfigError(f"patch map: must be a mapping, got {type(d).__name__}")
        if d.get("format", FORMAT) != FORMAT:
            raise ConfigError(f"format: expected {FORMAT!r}, got {d.get('format')!r}")
        version = d.get("format_version", FORMAT_VERSION)
        if version != FORMAT_VERSION:
            raise ConfigError(
                f"format_version: this score4 reads version {FORMAT_VERSION}, got {version!r}"
            )
        missing = [k for k in ("patch_size", "densities", "variants") if k not in d]
        if missing:
            raise ConfigError(f"patch map: missing key(s) {', '.join(missing)}")
        unknown = sorted(set(d) - set(_DICT_KEYS))
        if unknown:
            raise ConfigError(f"patch map: unknown key(s) {', '.join(unknown)}")
        variants = d["variants"]
        if isinstance(variants, str):
            shape = d.get("shape")
            if not (
                isinstance(shape, (list, tuple))
                and len(shape) == 2
                and all(isinstance(s, int) and not isinstance(s, bool) and s >= 1 for s in shape)
            ):
                raise ConfigError(f"shape: must be [ny, nx] with positive integers, got {shape!r}")
            if shape[0] * shape[1] > MAX_CELLS:
                raise ConfigError(
                    f"shape: {shape[0] * shape[1]} cells exceed the limit of {MAX_CELLS}"
                )
            variants = _rle_decode(variants, shape[0] * shape[1]).reshape(shape)
        else:
            variants = np.asarray(variants)
            if "shape" in d and list(variants.shape) != list(d["shape"]):
                raise ConfigError(
                    f"shape: {d['shape']!r} does not match the variants grid of shape "
                    f"{list(variants.shape)}"
                )
        return cls(
            variants, d["patch_size"], d["densities"], d.get("method", "given"), d.get("seed")
        )

    def save_h5(self, group: Any) -> None:
        """Write the map into an open ``h5py`` group: dataset ``variants`` plus group attributes.

        Attributes: ``format``, ``format_version``, ``patch_size`` (mm, with ``units = "mm"``),
        ``densities``, ``method`` and ``seed`` (absent when None).
        """
        group.create_dataset("variants", data=self.variants, compression="gzip", shuffle=True)
        attrs = group.attrs
        attrs["format"] = FORMAT
        attrs["format_version"] = FORMAT_VERSION
        attrs["patch_size"] = np.asarray(self.patch_size, dtype=float)
        attrs["units"] = "mm"
        attrs["densities"] = np.asarray(self.densities, dtype=float)
        attrs["method"] = self.method
        if self.seed is not None:
            attrs["seed"] = self.seed

    @classmethod
    def load_h5(cls, group: Any) -> PatchMap:
        """The map written by :meth:`save_h5` into ``group``."""
        attrs = group.attrs
        fmt = attrs.get("format")
        if isinstance(fmt, bytes):
            fmt = fmt.decode()
        if fmt != FORMAT:
            raise ConfigError(
                f"format: group {group.name!r} holds no {FORMAT!r} (format attribute {fmt!r})"
            )
        version = int(attrs["format_version"])
        if version != FORMAT_VERSION:
            raise ConfigError(
                f"format_version: this score4 reads version {FORMAT_VERSION}, got {version}"
            )
        method = attrs["method"]
        method = method.decode() if isinstance(method, bytes) else str(method)
        seed = int(attrs["seed"]) if "seed" in attrs else None
        px, py = (float(v) for v in attrs["patch_size"])
        return cls(
            group["variants"][...],
            (px, py),
            tuple(float(v) for v in attrs["densities"]),
            method,
            seed,
        )

    # --- text -------------------------------------------------------------------------------

    def describe(self) -> str:
        """One-paragraph summary: grid, patch and face size, method, realised/target fractions."""
        (px, py), (lx, ly) = self.patch_size, self.face_size
        how = {
            "exact": "exact counts",
            "random": "independent draws",
            "tiles": "random tiles from a library",
            "given": "given grid",
        }[self.method]
        seed = f", seed {self.seed}" if self.seed is not None else ""
        parts = ", ".join(
            f"{k}: {self.fractions[k]:.4f} ({self.counts[k]} cells; target {self.densities[k]:.4f})"
            for k in range(self.n_variants)
        )
        return (
            f"Patch map of {self.nx} x {self.ny} patches of {_fmt(px)} mm x {_fmt(py)} mm covering "
            f"{_fmt(lx)} mm x {_fmt(ly)} mm, {self.n_variants} variant(s) placed by {how} "
            f"(method '{self.method}'{seed}); realised fractions {parts}."
        )


# --- builders --------------------------------------------------------------------------------


def _grid(face_size: object, patch_size: object) -> tuple[int, int, tuple[float, float]]:
    face = _pair(face_size, "face_size")
    patch = _pair(patch_size, "patch_size")
    nx = _cells_along(face[0], patch[0], "x")
    ny = _cells_along(face[1], patch[1], "y")
    if nx * ny > MAX_CELLS:
        raise ConfigError(
            f"patch_size: {nx} x {ny} = {nx * ny} patches exceed the limit of {MAX_CELLS}; use "
            "larger patches"
        )
    return nx, ny, patch


def make_patch_map(
    face_size: float | str | Sequence[float | str],
    patch_size: float | str | Sequence[float | str],
    densities: Sequence[float],
    method: str = "exact",
    seed: int | None = 0,
    n_tiles: int = DEFAULT_TILES,
) -> PatchMap:
    """Cover a face with a grid of patches, each showing one of ``K`` variants.

    Parameters
    ----------
    face_size, patch_size
        ``(x, y)`` full sizes in mm (floats) or strings with units (``"10 cm"``); a single value
        means a square. The face must be a whole number of patches along each axis (relative
        tolerance :data:`SIZE_RTOL`).
    densities
        ``K`` positive target densities, one per variant; normalised with a ``Score4Warning`` if
        their sum differs from 1 by more than :data:`DENSITY_SUM_TOL`.
    method
        ``"exact"`` (largest-remainder counts, random positions), ``"random"`` (an independent
        draw per cell, as in the original SCoRe4) or ``"tiles"`` (tiles of :func:`tile_cells`
        cells drawn from a library of ``n_tiles`` exact-filled tiles).
    seed
        Seed of ``numpy.random.default_rng``; None draws a fresh, unrepeatable map.

    Returns
    -------
    PatchMap

    Raises
    ------
    ConfigError
        On non-positive sizes, a patch larger than the face, a face that is not a whole number
        of patches (the message gives the two nearest valid sizes), bad densities or method.
    """
    nx, ny, patch = _grid(face_size, patch_size)
    method = _method(method, ("exact", "random", "tiles"))
    seed = _seed(seed)
    d = _densities(densities)
    n = nx * ny
    rng = np.random.default_rng(seed)
    if method == "tiles":
        grid = _tiled(nx, ny, d, n_tiles, rng)
        return PatchMap(grid, patch, tuple(d.tolist()), method, seed)
    if d.size == 1:  # one variant: every cell (what both fills give, without drawing)
        flat = np.zeros(n, dtype=_VARIANT_DTYPE)
    elif method == "exact":
        counts = largest_remainder(n, d)
        _every_variant(
            counts, d, f"the face has {n} cell(s)", "use smaller patches or fewer variants"
        )
        flat = rng.permutation(np.repeat(np.arange(d.size, dtype=_VARIANT_DTYPE), counts))
    else:
        flat = rng.choice(d.size, size=n, p=d).astype(_VARIANT_DTYPE)
    return PatchMap(flat.reshape(ny, nx), patch, tuple(d.tolist()), method, seed)


def tile_cells(nx: int, ny: int, max_boxes: int = MAX_TOP_BOXES) -> int:
    """Side ``T`` of the tiles of ``fill: tiles``: the smallest that leaves at most ``max_boxes``
    tiles on an ``nx`` x ``ny`` grid (1 if the grid needs no grouping). Native tiling groups a
    grid above ``max_boxes`` cells first by this factor (score4.geometry.tiling.grouping_plan),
    so each library tile becomes one shared group volume."""
    t = 1
    while -(-nx // t) * -(-ny // t) > max_boxes:
        t += 1
    return t


def _tiled(
    nx: int, ny: int, d: np.ndarray, n_tiles: object, rng, max_boxes: int = MAX_TOP_BOXES
) -> np.ndarray:
    """An (ny, nx) grid of tiles drawn uniformly from ``n_tiles`` random tiles (see the module
    doc); tiles on the far edges are cut to the grid."""
    if isinstance(n_tiles, bool) or not isinstance(n_tiles, numbers.Integral) or n_tiles < 1:
        raise ConfigError(f"n_tiles: must be a whole number >= 1, got {n_tiles!r}")
    t, k = tile_cells(nx, ny, max_boxes), int(n_tiles)
    limits.check_memory(
        k * t * t * limits.CELL_BYTES, f"a library of {k} tiles of {t} x {t} cells", "n_tiles"
    )
    # The library as a whole has exact counts (largest remainder over its k t^2 cells; one tile
    # alone would round each density to 1 / t^2), and every tile is used equally often.
    counts = largest_remainder(k * t * t, d)
    need = math.ceil(1 / (float(d[d > 0].min()) * t * t))
    _every_variant(
        counts,
        d,
        f"n_tiles: the library of {k} tile(s) of {t} x {t} cells has {k * t * t} cell(s)",
        f"give n_tiles >= {need}",
    )
    cells = np.repeat(np.arange(d.size, dtype=_VARIANT_DTYPE), counts)
    library = rng.permutation(cells).reshape(k, t, t)
    gy, gx = -(-ny // t), -(-nx // t)
    pick = rng.permutation(np.arange(gy * gx) % k).reshape(gy, gx)
    grid = library[pick].transpose(0, 2, 1, 3).reshape(gy * t, gx * t)
    return np.ascontiguousarray(grid[:ny, :nx])


def _every_variant(counts: np.ndarray, d: np.ndarray, where: str, fix: str) -> None:
    """Refuse a fill that leaves a variant of non-zero density without a single cell."""
    lost = np.flatnonzero((counts == 0) & (d > 0))
    if len(lost):
        k = int(lost[0])
        raise ConfigError(
            f"{where}, and variant {k} (density {d[k]:.3g}) gets none of them; {fix} (no variant "
            "may be dropped silently)"
        )


def uniform_patch_map(
    face_size: float | str | Sequence[float | str], patch_size: float | str | Sequence[float | str]
) -> PatchMap:
    """A map in which every cell shows variant 0 (``K = 1``, method ``"exact"``)."""
    nx, ny, patch = _grid(face_size, patch_size)
    return PatchMap(np.zeros((ny, nx), dtype=_VARIANT_DTYPE), patch, (1.0,), "exact", None)


def given_patch_map(
    variants: np.ndarray | Sequence[Sequence[int]],
    patch_size: float | str | Sequence[float | str],
    n_variants: int | None = None,
) -> PatchMap:
    """A map from a user-supplied grid (for example read from a file).

    Parameters
    ----------
    variants
        ``(ny, nx)`` variant indices, ``variants[j, i]`` for cell ``(i, j)``; integers (or
        floats with integral values) in ``0 .. n_variants - 1``.
    patch_size
        ``(px, py)`` in mm or strings with units; a single value means a square.
    n_variants
        Number of variants ``K``; None means ``max(variants) + 1``. Variants that occur in no
        cell are allowed when ``n_variants`` is given.

    Returns
    -------
    PatchMap
        Method ``"given"``, seed None; ``densities`` are the realised fractions.
    """
    grid, k = _check_variants(variants, n_variants)
    patch = _pair(patch_size, "patch_size")
    fractions = np.bincount(grid.ravel(), minlength=k) / grid.size
    return PatchMap(grid, patch, tuple(fractions.tolist()), "given", None)
