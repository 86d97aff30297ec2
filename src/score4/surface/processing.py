"""Height-map processing: plane levelling, cropping, resampling, filling missing points, periodic
closing.

Every function returns a new :class:`~score4.surface.heightmap.HeightMap` (mm) and keeps the
input's metadata, adding a ``processing`` list that records each step.
"""

from __future__ import annotations

import math

import numpy as np

from score4.common import limits
from score4.common.units import length_text, parse_quantity

from ..errors import ConfigError
from .heightmap import HeightMap

RESAMPLE_METHODS = ("linear", "cubic")
#: Default largest fraction of missing points that :func:`fill_missing` fills.
MAX_MISSING_FRACTION = 0.2


def _with(hm: HeightMap, z: np.ndarray, step: str, **changes) -> HeightMap:
    meta = dict(hm.metadata)
    meta["processing"] = [*hm.metadata.get("processing", []), step]
    fields = {"pitch_x": hm.pitch_x, "pitch_y": hm.pitch_y, "origin": hm.origin, **changes}
    return HeightMap(
        z, fields["pitch_x"], fields["pitch_y"], origin=fields["origin"], metadata=meta
    )


def _length(value: float | str, name: str) -> float:
    return parse_quantity(value, "length", name) if isinstance(value, str) else float(value)


# ----------------------------------------------------------------------------- levelling
def plane_fit(hm: HeightMap) -> tuple[float, float, float]:
    """Least-squares plane z = a + b x + c y through the valid points: (a, b, c) in mm, mm/mm."""
    yy, xx = np.meshgrid(hm.y, hm.x, indexing="ij")
    ok = ~np.isnan(hm.heights)
    design = np.column_stack([np.ones(ok.sum()), xx[ok], yy[ok]])
    coef, *_ = np.linalg.lstsq(design, hm.heights[ok], rcond=None)
    return float(coef[0]), float(coef[1]), float(coef[2])


def level_plane(hm: HeightMap) -> HeightMap:
    """Subtract the least-squares plane (missing points stay NaN): mean 0 and no tilt."""
    a, b, c = plane_fit(hm)
    z = hm.heights - (a + b * hm.x[None, :] + c * hm.y[:, None])
    return _with(hm, z, f"level_plane(a={a:.6g}, b={b:.6g}, c={c:.6g})")


# ----------------------------------------------------------------------------- cropping
def crop_samples(hm: HeightMap, columns: tuple[int, int], rows: tuple[int, int]) -> HeightMap:
    """Keep columns ``[c0, c1)`` and rows ``[r0, r1)`` (slice rules for the bounds, no steps)."""
    ny, nx = hm.shape
    c0, c1, _ = slice(*columns).indices(nx)
    r0, r1, _ = slice(*rows).indices(ny)
    if c1 - c0 < 2 or r1 - r0 < 2:
        raise ConfigError(
            f"columns, rows: {columns}, {rows} leave {max(c1 - c0, 0)} x {max(r1 - r0, 0)} samples "
            f"of a {nx} x {ny} map; rule: at least 2 x 2"
        )
    origin = (hm.origin[0] + c0 * hm.pitch_x, hm.origin[1] + r0 * hm.pitch_y)
    return _with(
        hm,
        hm.heights[r0:r1, c0:c1],
        f"crop_samples(columns=({c0}, {c1}), rows=({r0}, {r1}))",
        origin=origin,
    )


def crop(
    hm: HeightMap, x: tuple[float | str, float | str], y: tuple[float | str, float | str]
) -> HeightMap:
    """Keep the samples with x0 <= x <= x1 and y0 <= y <= y1 (mm, or strings with a unit)."""
    (x0, x1), (y0, y1) = ((_length(a, n), _length(b, n)) for (a, b), n in ((x, "x"), (y, "y")))
    eps_x, eps_y = (
        1e-9 * hm.pitch_x,
        1e-9 * hm.pitch_y,
    )  # coordinates that are multiples of the pitch count as inside
    c0 = math.ceil((x0 - hm.origin[0]) / hm.pitch_x - 1e-9)
    c1 = math.floor((x1 - hm.origin[0] + eps_x) / hm.pitch_x) + 1
    r0 = math.ceil((y0 - hm.origin[1]) / hm.pitch_y - 1e-9)
    r1 = math.floor((y1 - hm.origin[1] + eps_y) / hm.pitch_y) + 1
    ny, nx = hm.shape
    for name, lo, hi, k0, k1, n, start, pitch in (
        ("x", x0, x1, c0, c1, nx, hm.origin[0], hm.pitch_x),
        ("y", y0, y1, r0, r1, ny, hm.origin[1], hm.pitch_y),
    ):
        kept = max(min(k1, n) - max(k0, 0), 0)
        if kept < 2:
            raise ConfigError(
                f"{name}: {lo:.6g} to {hi:.6g} mm keeps {kept} sample(s) of the map along {name} "
                f"(it spans {start:.6g} to {start + (n - 1) * pitch:.6g} mm, pitch "
                f"{pitch:.6g} mm); rule: at least 2"
            )
    return crop_samples(hm, (max(c0, 0), min(c1, nx)), (max(r0, 0), min(r1, ny)))


# ----------------------------------------------------------------------------- resampling
def resample(
    hm: HeightMap, pitch_x: float | str, pitch_y: float | str | None = None, method: str = "linear"
) -> HeightMap:
    """Interpolate onto a new pitch over the same area, starting at the same origin.

    ``method`` ``"linear"``: bilinear; a new sample next to a missing one is NaN.
    ``"cubic"``: tensor-product cubic spline (scipy RegularGridInterpolator); needs a map
    without missing points (fill them first) and at least 4 x 4 samples.
    The new grid has floor(size / pitch) + 1 samples per axis, so it never extends past the data.
    """
    from scipy import interpolate

    if method not in RESAMPLE_METHODS:
        raise ConfigError(
            f"method: unknown resampling method {method!r}; use one of: "
            f"{', '.join(RESAMPLE_METHODS)}"
        )
    px = _length(pitch_x, "pitch_x")
    py = px if pitch_y is None else _length(pitch_y, "pitch_y")
    for name, p in (("pitch_x", px), ("pitch_y", py)):
        if not (math.isfinite(p) and p > 0):
            raise ConfigError(f"{name}: must be a positive length, got {p!r}")
    if method == "cubic" and hm.has_missing:
        raise ConfigError(
            "method: 'cubic' resampling needs a map without missing points; fill_missing first or "
            "use 'linear'"
        )
    nx = math.floor(hm.size_x / px * (1 + 1e-12)) + 1
    ny = math.floor(hm.size_y / py * (1 + 1e-12)) + 1
    if nx < 2 or ny < 2:
        raise ConfigError(
            f"pitch_x, pitch_y: {length_text(px)}, {length_text(py)} leave fewer than 2 samples "
            f"on a {length_text(hm.size_x)} x {length_text(hm.size_y)} map"
        )
    limits.check_memory(
        limits.heightmap_bytes(nx * ny),
        f"resampling the {length_text(hm.size_x)} x {length_text(hm.size_y)} map at "
        f"{length_text(px)} ({nx} x {ny} points)",
        "resample_pitch",
        "use a larger pitch",
    )
    xs = np.minimum(
        hm.origin[0] + px * np.arange(nx), hm.x[-1]
    )  # clip round-off past the last sample
    ys = np.minimum(hm.origin[1] + py * np.arange(ny), hm.y[-1])
    interp = interpolate.RegularGridInterpolator((hm.y, hm.x), hm.heights, method=method)
    yy, xx = np.meshgrid(ys, xs, indexing="ij")
    z = interp(np.stack([yy.ravel(), xx.ravel()], axis=-1)).reshape(ny, nx)
    return _with(
        hm,
        z,
        f"resample(pitch_x={px:g}, pitch_y={py:g}, method={method!r})",
        pitch_x=px,
        pitch_y=py,
    )


# ----------------------------------------------------------------------------- missing points
def fill_missing(hm: HeightMap, max_fraction: float = MAX_MISSING_FRACTION) -> HeightMap:
    """Fill NaN points by harmonic (Laplace) inpainting.

    The filled values solve the discrete Laplace equation (each equals the mean of its 4-neighbours
    inside the map) with the measured points fixed: the smoothest surface through the gap,
    without new extrema. Map edges act as mirrors (zero normal slope).

    Raises ConfigError if more than ``max_fraction`` of the points are missing (the fill would be
    invented rather than interpolated) or if every point is missing.
    """
    if not (0 <= max_fraction < 1):
        raise ConfigError(f"max_fraction: must be in [0, 1), got {max_fraction!r}")
    z = hm.heights
    missing = np.isnan(z)
    if missing.all():
        raise ConfigError("heights: every point is missing (NaN); nothing to fill from")
    frac = float(missing.mean())
    if frac > max_fraction:
        raise ConfigError(
            f"heights: {frac:.1%} of the points are missing; rule: at most max_fraction = "
            f"{max_fraction:.1%} can be filled (crop the map or raise max_fraction)"
        )
    if frac == 0:
        return _with(hm, z.copy(), "fill_missing(none missing)")
    return _with(
        hm, _laplace_fill(z, missing), f"fill_missing(laplace, {int(missing.sum())} points)"
    )


def _laplace_fill(z: np.ndarray, missing: np.ndarray) -> np.ndarray:
    """Solve sum over in-map neighbours (z_n - z_p) = 0 for the missing points p."""
    import scipy.sparse
    import scipy.sparse.linalg

    ny, nx = z.shape
    unknown = -np.ones(z.shape, dtype=np.int64)
    unknown[missing] = np.arange(int(missing.sum()))
    rows, cols, vals = [], [], []
    rhs = np.zeros(int(missing.sum()))
    jj, ii = np.nonzero(missing)
    p = unknown[jj, ii]
    degree = np.zeros(p.size)
    for dj, di in ((1, 0), (-1, 0), (0, 1), (0, -1)):
        nj, ni = jj + dj, ii + di
        inside = (nj >= 0) & (nj < ny) & (ni >= 0) & (ni < nx)
        degree += inside
        nj_in, ni_in, p_in = nj[inside], ni[inside], p[inside]
        q = unknown[nj_in, ni_in]
        is_unknown = q >= 0
        rows.append(p_in[is_unknown])
        cols.append(q[is_unknown])
        vals.append(-np.ones(is_unknown.sum()))
        np.add.at(rhs, p_in[~is_unknown], z[nj_in[~is_unknown], ni_in[~is_unknown]])
    rows.append(p)
    cols.append(p)
    vals.append(degree)
    a = scipy.sparse.csr_matrix(
        (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(p.size, p.size)
    )
    out = z.copy()
    out[jj, ii] = scipy.sparse.linalg.spsolve(a.tocsc(), rhs)
    return out


# ----------------------------------------------------------------------------- periodic maps
def close_periodic(hm: HeightMap) -> HeightMap:
    """Append the first column and row after the last: a periodic tile with its duplicated edge.

    Generated periodic maps (``periodic=True``) hold one period without the duplicate; meshes or
    tiles that need both edges use this.
    """
    z = np.vstack([hm.heights, hm.heights[:1]])
    z = np.hstack([z, z[:, :1]])
    return _with(hm, z, "close_periodic()")


def is_closed_periodic(hm: HeightMap) -> bool:
    """True if ``hm`` is a periodic map closed by :func:`close_periodic` (last step)."""
    steps = hm.metadata.get("processing", [])
    return bool(hm.metadata.get("periodic")) and bool(steps) and steps[-1] == "close_periodic()"


def one_period(hm: HeightMap) -> HeightMap:
    """``hm`` without the duplicated last row and column of a closed periodic map (else as is).

    Statistics of a periodic surface are over one period: the duplicated edge of a closed tile
    would count its points twice and weigh them in the levelling plane.
    """
    if not is_closed_periodic(hm) or min(hm.shape) < 3:
        return hm
    return _with(hm, hm.heights[:-1, :-1], "one_period()")
