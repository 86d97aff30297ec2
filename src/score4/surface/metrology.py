"""ISO 25178-2 areal surface parameters, on height maps and exactly on triangle meshes.

Two entry points return a dict keyed by ISO symbol (heights in mm, see :data:`PARAMETERS`):

* :func:`areal_parameters` on a :class:`~score4.surface.heightmap.HeightMap`: the discrete
  definitions (sums over sample points), after removing the least-squares mean plane;
* :func:`mesh_parameters` on the ``top`` faces of a
  :class:`~score4.surface.triangle_mesh.TriangleMesh`: closed-form integrals over each facet, exact
  for the piecewise-linear surface.

Definitions and discretisation (z is the height above the reference plane):

* Height parameters (ISO 25178-2 §4.1): Sa = <|z|>, Sq = <z²>^½, Ssk = <z³>/Sq³,
  Sku = <z⁴>/Sq⁴ (3 for a Gaussian surface, *not* the excess kurtosis), Sp = max z,
  Sv = -min z, Sz = Sp + Sv. Averages are over sample points (height map) or over projected
  area (mesh).
* Sdq (root mean square gradient): the exact gradient of the triangulated (piecewise-linear)
  height map, i.e. forward differences averaged per grid cell:
  Sdq² = mean over cells of [(Δx_bottom² + Δx_top²) / 2 / px² + (Δy_left² + Δy_right²) / 2 / py²].
  It is independent of the diagonal chosen for the triangles and equals the mesh Sdq of
  :func:`~score4.surface.triangle_mesh.from_heightmap` exactly. surfalize 0.19 instead averages
  every row/column forward difference with equal weight; the two differ only by the half weight of
  the border rows/columns, O(1/n) (ISO 25178-2 fixes the integral, not the difference scheme).
* Sdr (developed interfacial area ratio), in percent: each grid cell's area is the mean of its
  two triangulations, i.e. a quarter of the sum of the four corner cross products
  (px, 0, Δx) x (0, py, Δy) (the rule surfalize 0.19 attributes to ISO 25178-2:2021 Annex D,
  eq. D.15; we did not have the standard's text); Sdr = (area / projected area - 1) * 100.
  The mesh Sdr uses the mesh's own triangles (one diagonal per cell for
  :func:`~score4.surface.triangle_mesh.from_heightmap`), so the two differ at second order.
* Sal, Str (ISO 25178-2 §4.3, s = 0.2 after ISO 25178-3): from the areal autocorrelation
  function f_ACF of the centred heights, computed by zero-padded FFT as a linear (not circular)
  correlation, each lag divided by its number of overlapping valid points (unbiased), then
  normalised to 1 at zero lag. Along 360 directions over 180° (f_ACF is point-symmetric) the
  first radius where f_ACF drops below s is found by bilinear interpolation and linear
  interpolation between radial steps of a quarter pitch. Sal = shortest of these lengths;
  Str = shortest / longest. Lags are searched up to half the map size in each axis (beyond it
  fewer than half the points overlap and estimator noise can fake a crossing): Sal is NaN if no
  direction decays within that range, Str is NaN if some direction does not.
  On the exact Gaussian ACF every direction gives sqrt(ln 5) l to 0.5 %. On one realisation of
  an isotropic random field Sal reads low: the sample ACF scatters from direction to direction
  and Sal is the *shortest* length, a minimum of noisy values. Measured on periodic Gaussian maps
  with l = 6 pitches (``benchmarks/bench_sal_periodic.py``, 8 seeds): Sal / (sqrt(ln 5) l) =
  0.94 at 128 x 128 and 0.97 at 256 x 256, while the mean over directions is 1.00 +- 0.02.
  This is the ISO definition applied to a finite map, not an error of the estimator.

A periodic map closed into a tile (:func:`~score4.surface.processing.close_periodic`, the last
processing step) is reduced to one period before levelling and every parameter: its duplicated
last row and column would otherwise count twice (Sdq and Sdr then use the cells inside the
period, leaving out the one row and column of cells across the period's edge).

Missing (NaN) points of a height map are left out: of the plane fit and height parameters
(points), of Sdq/Sdr (cells with a missing corner) and of the ACF (pairs with a missing point).
"""

from __future__ import annotations

import numpy as np

from ..errors import ConfigError
from .heightmap import HeightMap
from .processing import one_period
from .triangle_mesh import TriangleMesh

#: (ISO symbol, unit kind, description). Unit kinds: "length" (mm internally),
#: "ratio" (dimensionless), "percent".
PARAMETERS: tuple[tuple[str, str, str], ...] = (
    ("Sa", "length", "arithmetical mean height"),
    ("Sq", "length", "root mean square height"),
    ("Sp", "length", "maximum peak height"),
    ("Sv", "length", "maximum pit height"),
    ("Sz", "length", "maximum height (Sp + Sv)"),
    ("Ssk", "ratio", "skewness"),
    ("Sku", "ratio", "kurtosis (3 for a Gaussian surface)"),
    ("Sdq", "ratio", "root mean square gradient"),
    ("Sdr", "percent", "developed interfacial area ratio"),
    ("Sal", "length", "autocorrelation length (s = 0.2)"),
    ("Str", "ratio", "texture aspect ratio (s = 0.2)"),
)

#: Parameters that :func:`mesh_parameters` computes exactly.
MESH_PARAMETERS = ("Sa", "Sq", "Sp", "Sv", "Sz", "Ssk", "Sku", "Sdq", "Sdr")

#: ISO 25178-3 default threshold of the autocorrelation function for Sal and Str.
ACF_THRESHOLD = 0.2

_N_DIRECTIONS = 360

#: A surface whose Sq is below this fraction of its size (largest of the lateral extents and the
#: raw height range) is flat to rounding: Ssk and Sku are then NaN (0/0), not rounding noise.
FLAT_REL_TOL = 1e-12


# --- height maps --------------------------------------------------------------------------


def mean_plane(hm: HeightMap) -> np.ndarray:
    """Least-squares plane of the valid points: (ny, nx) array of plane heights, mm."""
    x, y = hm.x - hm.x.mean(), hm.y - hm.y.mean()  # centred: well-conditioned normal equations
    ok = np.isfinite(hm.heights)
    w, z = ok.astype(float), np.where(ok, hm.heights, 0.0)
    # Normal equations from row/column sums, without an (n, 3) design matrix.
    wx, wy = w.sum(axis=0), w.sum(axis=1)
    sxy = y @ w @ x
    gram = np.array([[w.sum(), wx @ x, wy @ y], [wx @ x, wx @ x**2, sxy], [wy @ y, sxy, wy @ y**2]])
    rhs = np.array([z.sum(), z.sum(axis=0) @ x, z.sum(axis=1) @ y])
    a, b, c = np.linalg.lstsq(gram, rhs, rcond=None)[
        0
    ]  # lstsq: a single row/column is rank-deficient
    return a + b * x[None, :] + c * y[:, None]


def level(hm: HeightMap) -> HeightMap:
    """The height map minus its least-squares mean plane (NaN points stay NaN)."""
    meta = {**hm.metadata, "levelled": True}
    return HeightMap(hm.heights - mean_plane(hm), hm.pitch_x, hm.pitch_y, hm.origin, meta)


def _residual(hm: HeightMap, level: bool) -> np.ndarray:
    z = hm.heights
    return z - mean_plane(hm) if level else z - np.nanmean(z)


def _shape_moments(m3: float, m4: float, sq: float, scale: float) -> tuple[float, float]:
    """Ssk and Sku; NaN when the surface is flat to rounding (Sq <= FLAT_REL_TOL * scale)."""
    if not sq > FLAT_REL_TOL * scale:
        return float("nan"), float("nan")
    return float(m3 / sq**3), float(m4 / sq**4)


def _height_parameters(r: np.ndarray, scale: float) -> dict[str, float]:
    """Height parameters of the residual values ``r`` (1-D, finite), re-centred on their mean."""
    d = r - r.mean()
    sq = float(np.sqrt(np.mean(d**2)))
    ssk, sku = _shape_moments(float(np.mean(d**3)), float(np.mean(d**4)), sq, scale)
    sp, sv = float(d.max()), float(-d.min())
    return {
        "Sa": float(np.mean(np.abs(d))),
        "Sq": sq,
        "Sp": sp,
        "Sv": sv,
        "Sz": sp + sv,
        "Ssk": ssk,
        "Sku": sku,
    }


def _hybrid_parameters(z: np.ndarray, px: float, py: float) -> dict[str, float]:
    dx = np.diff(z, axis=1)  # (ny, nx-1): x edges; rows j and j+1 bound cell row j
    dy = np.diff(z, axis=0)  # (ny-1, nx): y edges; columns i and i+1 bound cell column i
    xb, xt, yl, yr = dx[:-1], dx[1:], dy[:, :-1], dy[:, 1:]
    grad2 = 0.5 * (xb**2 + xt**2) / px**2 + 0.5 * (yl**2 + yr**2) / py**2
    corner = lambda ex, ey: np.sqrt((py * ex) ** 2 + (px * ey) ** 2 + (px * py) ** 2)  # noqa: E731
    cell_area = 0.25 * (corner(xb, yl) + corner(xb, yr) + corner(xt, yr) + corner(xt, yl))
    ok = np.isfinite(cell_area)
    if not ok.any():
        return {"Sdq": float("nan"), "Sdr": float("nan")}
    sdr = (cell_area[ok].sum() / (ok.sum() * px * py) - 1.0) * 100.0
    return {"Sdq": float(np.sqrt(grad2[ok].mean())), "Sdr": float(sdr)}


def autocorrelation(hm: HeightMap, *, level: bool = True) -> np.ndarray:
    """Normalised areal autocorrelation function f_ACF for lags up to half the map size.

    Returns
    -------
    numpy.ndarray
        Shape (2 Ky + 1, 2 Kx + 1) with Kx = nx // 2, Ky = ny // 2; element [Ky + m, Kx + n] is
        the lag (n * pitch_x, m * pitch_y); 1 at the centre; NaN where no pair overlaps.
    """
    import scipy.fft

    r = _residual(hm, level)
    ok = np.isfinite(r)
    z0 = np.where(ok, r, 0.0)
    ny, nx = r.shape
    ky, kx = ny // 2, nx // 2
    # Padding to n + K keeps lags up to K free of wrap-around (linear correlation).
    shape = (
        scipy.fft.next_fast_len(ny + ky, real=True),
        scipy.fft.next_fast_len(nx + kx, real=True),
    )
    corr = lambda a: scipy.fft.irfft2(np.abs(scipy.fft.rfft2(a, shape)) ** 2, shape)  # noqa: E731
    iy = np.arange(-ky, ky + 1) % shape[0]
    ix = np.arange(-kx, kx + 1) % shape[1]
    num = corr(z0)[np.ix_(iy, ix)]
    count = np.rint(corr(ok.astype(float))[np.ix_(iy, ix)])
    with np.errstate(divide="ignore", invalid="ignore"):
        acf = np.where(count >= 1, num / count, np.nan)
        return acf / acf[ky, kx]


def _decay_lengths(acf: np.ndarray, px: float, py: float, s: float) -> np.ndarray:
    """First radius (mm) where ``acf`` falls below ``s`` along each direction; NaN if none."""
    from scipy import ndimage

    ky, kx = (np.array(acf.shape) - 1) // 2
    theta = np.arange(_N_DIRECTIONS) * np.pi / _N_DIRECTIONS
    c, sn = np.cos(theta), np.sin(theta)
    with np.errstate(divide="ignore"):
        rmax = np.minimum(kx * px / np.abs(c), ky * py / np.abs(sn))
    step = 0.25 * min(px, py)
    r = np.arange(0.0, rmax.max() + step, step)
    rows = ky + np.outer(sn, r) / py
    cols = kx + np.outer(c, r) / px
    vals = ndimage.map_coordinates(
        np.nan_to_num(acf, nan=1.0), [rows, cols], order=1, mode="nearest"
    )
    below = (vals < s) & (r[None, :] <= rmax[:, None] * (1 + 1e-9))
    found = below.any(axis=1)
    i = np.maximum(np.argmax(below, axis=1), 1)
    d = np.arange(_N_DIRECTIONS)
    v0, v1 = vals[d, i - 1], vals[d, i]
    with np.errstate(divide="ignore", invalid="ignore"):  # v0 == v1 only where nothing was found
        crossing = r[i - 1] + step * (v0 - s) / (v0 - v1)
    return np.where(found, crossing, np.nan)


def _spatial_parameters(hm: HeightMap, level: bool, s: float) -> dict[str, float]:
    acf = autocorrelation(hm, level=level)
    if not np.isfinite(acf[(acf.shape[0] - 1) // 2, (acf.shape[1] - 1) // 2]):
        return {"Sal": float("nan"), "Str": float("nan")}  # flat surface: no correlation to decay
    lengths = _decay_lengths(acf, hm.pitch_x, hm.pitch_y, s)
    found = np.isfinite(lengths)
    sal = float(lengths[found].min()) if found.any() else float("nan")
    strr = float(sal / lengths.max()) if found.all() else float("nan")
    return {"Sal": sal, "Str": strr}


def areal_parameters(
    hm: HeightMap, *, level: bool = True, acf_threshold: float = ACF_THRESHOLD
) -> dict[str, float]:
    """ISO 25178-2 parameters of a height map (see the module docstring for definitions).

    Parameters
    ----------
    hm
        The height map (mm).
    level
        Remove the least-squares mean plane first (ISO practice, F-operation); if False only
        the mean height is removed.
    acf_threshold
        The threshold s of f_ACF for Sal and Str, 0 < s < 1.

    Returns
    -------
    dict
        {symbol: value} for every symbol of :data:`PARAMETERS`; lengths in mm, Sdr in %.
        Ssk and Sku are NaN for a flat map; Sal/Str may be NaN (see the module docstring).
    """
    if not 0 < acf_threshold < 1:
        raise ConfigError(
            f"acf_threshold: must lie strictly between 0 and 1, got {acf_threshold!r}"
        )
    hm = one_period(hm)
    r = _residual(hm, level)
    z = hm.heights[np.isfinite(hm.heights)]
    scale = max(hm.size_x, hm.size_y, float(np.ptp(z)))
    out = _height_parameters(r[np.isfinite(r)], scale)
    out.update(_hybrid_parameters(r, hm.pitch_x, hm.pitch_y))
    out.update(_spatial_parameters(hm, level, acf_threshold))
    return {symbol: out[symbol] for symbol, _, _ in PARAMETERS}


# --- exact integration over mesh facets ---------------------------------------------------
#
# Over a triangle of projected area A on which d is linear with vertex values a, b, c:
#     ∫ d^k dA = 2 A k! / (k + 2)! * h_k(a, b, c),
# with h_k the complete homogeneous symmetric polynomial of degree k (h_1 = a + b + c,
# h_2 = a² + b² + c² + ab + bc + ca, ...), obtained from the power sums p_i = a^i + b^i + c^i
# by Newton's identity k h_k = sum_{i=1..k} p_i h_{k-i}. For products of two linear
# functions, ∫ f g dA = A/12 (sum_i f_i g_i + (sum_i f_i)(sum_i g_i)).


def _sum3(a: np.ndarray) -> np.ndarray:
    """Row sums of an (m, 3) array (much faster than ``a.sum(axis=1)`` for large m)."""
    return a[:, 0] + a[:, 1] + a[:, 2]


def _facet_power_integrals(d: np.ndarray, area: np.ndarray, kmax: int = 4) -> list[float]:
    """[∫ d^k dA for k = 1..kmax] summed over facets; ``d`` is (m, 3) vertex values."""
    power = [np.ones(len(d))]
    dk = d.copy()
    for k in range(kmax):
        if k:
            dk *= d
        power.append(_sum3(dk))
    h = [power[0]]
    for k in range(1, kmax + 1):
        h.append(np.asarray(sum(power[i] * h[k - i] for i in range(1, k + 1))) / k)
    return [float(area @ h[k]) * 2.0 / ((k + 1) * (k + 2)) for k in range(1, kmax + 1)]


def _facet_abs_integral(d: np.ndarray, area: np.ndarray) -> float:
    """∑ ∫ |d| dA over facets, splitting facets that cross d = 0 analytically."""
    d1, d2, d3 = np.sort(d, axis=1).T
    whole = area * (d1 + d2 + d3) / 3.0
    with np.errstate(divide="ignore", invalid="ignore"):
        # d1 < 0 <= d2: the negative part is the corner triangle at vertex 1 (fractions t12, t13).
        neg = area * (d1 / (d1 - d2)) * (d1 / (d1 - d3)) * d1 / 3.0
        # d2 < 0 < d3: the positive part is the corner triangle at vertex 3.
        pos = area * (d3 / (d3 - d1)) * (d3 / (d3 - d2)) * d3 / 3.0
    out = np.where(d1 >= 0, whole, -whole)
    out = np.where((d1 < 0) & (d2 >= 0) & (d3 > 0), whole - 2.0 * neg, out)
    out = np.where((d2 < 0) & (d3 > 0), 2.0 * pos - whole, out)
    return float(out.sum())


def _mesh_tilt(
    vertices: np.ndarray, faces: np.ndarray, area: np.ndarray
) -> tuple[float, float, float, float]:
    """Slopes of the continuous least-squares plane over the facets.

    Returns (x0, y0, b, c): plane z = a + b (x - x0) + c (y - y0) around the area centroid
    (x0, y0), where a is the mean height. Uses ∫ f g dA = A/12 (Σ f_i g_i + Σ f_i Σ g_i): the
    first term is a vertex sum weighted by the areas of the incident facets.
    """
    weight = np.bincount(faces.ravel(), weights=np.repeat(area, 3), minlength=len(vertices))
    corner_sum = lambda f: f[faces[:, 0]] + f[faces[:, 1]] + f[faces[:, 2]]  # noqa: E731
    total = area.sum()
    x0 = float(area @ corner_sum(vertices[:, 0])) / (3 * total)
    y0 = float(area @ corner_sum(vertices[:, 1])) / (3 * total)
    f = [vertices[:, 0] - x0, vertices[:, 1] - y0, vertices[:, 2]]  # x, y, z (centred)
    sums = [corner_sum(g) for g in f]
    prod = lambda i, j: float(weight @ (f[i] * f[j]) + area @ (sums[i] * sums[j])) / 12  # noqa: E731
    # Centred x, y are orthogonal to constants, so the slopes solve a 2 x 2 system.
    gram = np.array([[prod(0, 0), prod(0, 1)], [prod(0, 1), prod(1, 1)]])
    b, c = np.linalg.solve(gram, [prod(0, 2), prod(1, 2)])
    return x0, y0, float(b), float(c)


def mesh_parameters(mesh: TriangleMesh, *, level: bool = True) -> dict[str, float]:
    """Exact ISO 25178-2 parameters of the top surface of a mesh (a height field).

    Averages are integrals over projected area, evaluated in closed form facet by facet.
    The reference plane is the continuous least-squares plane of the surface (``level``)
    or the horizontal plane at the mean height. Vertical facets (projected area below 1e-12 of
    their area) have measure zero for the height integrals and Sdq, but count in Sdr.

    Returns
    -------
    dict
        {symbol: value} for the symbols of :data:`MESH_PARAMETERS` (lengths mm, Sdr in %).

    Raises
    ------
    ConfigError
        If the mesh has no top faces, or top faces overhang (normal pointing down).
    """
    assert mesh.top is not None  # TriangleMesh.__post_init__ fills it in
    top = np.flatnonzero(mesh.top)
    if len(top) == 0:
        raise ConfigError("mesh: has no top faces to measure")
    vec = mesh._area_vectors[top]
    area_true, proj = mesh.areas[top], vec[:, 2]
    down = proj < -1e-12 * area_true
    if down.any():
        raise ConfigError(
            f"mesh: {int(down.sum())} top faces overhang (normal points down); metrology needs a "
            "height field"
        )
    flat = proj > 1e-12 * area_true
    faces, a = mesh.faces[top[flat]], proj[flat]
    v = mesh.vertices
    z = v[:, 2]
    if level:
        x0, y0, bx, by = _mesh_tilt(v, faces, a)
        z = z - bx * (v[:, 0] - x0) - by * (v[:, 1] - y0)
        # Removing the tilt adds (b, c) A_z to the horizontal part of each area vector.
        vec = vec + proj[:, None] * np.array([bx, by, 0.0])
    total = a.sum()
    mean = float(a @ _sum3(z[faces])) / (3 * total)
    d = z[faces] - mean
    _, m2, m3, m4 = (value / total for value in _facet_power_integrals(d, a))
    sq = float(np.sqrt(m2))
    used = np.zeros(len(v), dtype=bool)
    used[mesh.faces[top]] = True
    sp, sv = float(z[used].max() - mean), float(mean - z[used].min())
    scale = float(np.ptp(v[used], axis=0).max())
    ssk, sku = _shape_moments(m3, m4, sq, scale)
    slope2 = (vec[flat, 0] ** 2 + vec[flat, 1] ** 2) / a  # A_z |grad z|²
    return {
        "Sa": _facet_abs_integral(d, a) / total,
        "Sq": sq,
        "Sp": sp,
        "Sv": sv,
        "Sz": sp + sv,
        "Ssk": ssk,
        "Sku": sku,
        "Sdq": float(np.sqrt(slope2.sum() / total)),
        "Sdr": float((np.linalg.norm(vec, axis=1).sum() / total - 1.0) * 100.0),
    }
