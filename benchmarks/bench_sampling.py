"""Vertex sampling speed on a 10^6-facet surface (one core), with depth 'normal' and 'distance'.

Run: ``.venv/bin/python benchmarks/bench_sampling.py [--facets 1000000] [--vertices 1000000]``.
Prints set-up times and vertices per second; the target is >= 10^6 vertices/s with 'normal'.
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")  # per-core figures: keep BLAS single-threaded
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse
import time

import numpy as np

from score4.common.units import nm, um
from score4.source.depth import MeshDistance, VertexSampler
from score4.source.emitters import Po210Emitter, make_primaries
from score4.source.profiles import ExponentialProfile
from score4.source.sampling import SurfaceSampler, TiledSurfaceSampler


def pyramid_grid(n_side: int, pitch: float, rng: np.random.Generator) -> np.ndarray:
    """n_side^2 square pyramids (4 triangles each), heights 1 um +- 20 %, built vectorised."""
    i, j = (g.ravel() for g in np.meshgrid(np.arange(n_side), np.arange(n_side), indexing="ij"))
    x0, y0 = i * pitch, j * pitch
    zero = np.zeros_like(x0, dtype=float)
    corners = np.stack(
        [
            np.c_[x0, y0, zero],
            np.c_[x0 + pitch, y0, zero],
            np.c_[x0 + pitch, y0 + pitch, zero],
            np.c_[x0, y0 + pitch, zero],
        ],
        axis=1,
    )
    top = np.c_[x0 + pitch / 2, y0 + pitch / 2, rng.normal(1 * um, 0.2 * um, len(x0))]
    tris = np.stack(
        [np.stack([corners[:, k], corners[:, (k + 1) % 4], top], axis=1) for k in range(4)], axis=1
    )
    return tris.reshape(-1, 3, 3)


def height_map_mesh(n: int, pitch: float, rng: np.random.Generator) -> np.ndarray:
    """2 n^2 triangles of a periodic Gaussian random height map (Sq = 0.5 pitch), vectorised."""
    from scipy.ndimage import gaussian_filter

    z = gaussian_filter(rng.normal(size=(n + 1, n + 1)), 3.0, mode="wrap")
    z *= 0.5 * pitch / z.std()
    i, j = (g.ravel() for g in np.meshgrid(np.arange(n), np.arange(n), indexing="ij"))

    def corner(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        return np.c_[a * pitch, b * pitch, z[a, b]]

    p00, p10, p11, p01 = corner(i, j), corner(i + 1, j), corner(i + 1, j + 1), corner(i, j + 1)
    return np.concatenate([np.stack([p00, p10, p11], axis=1), np.stack([p00, p11, p01], axis=1)])


def bench_distance(name: str, tri: np.ndarray, profile, n: int, rng: np.random.Generator) -> None:
    """Set-up and sampling cost of the 'distance' definition, and raw exact-distance queries."""
    surface = SurfaceSampler(tri)
    t, distance = timed(lambda: VertexSampler(surface, profile, definition="distance"), 1)
    offset = distance.offset_surfaces[0]
    print(
        f"\n[{name}] 'distance' set-up    {t:8.3f} s   "
        f"({offset.n_valley_edges:,} valley edges, {offset.n_vertex_cones:,} vertex cones)"
    )
    t, v = timed(lambda: distance.sample(rng, n))
    print(f"vertices, depth 'distance'     {t:8.3f} s   {n / t / 1e6:6.3f} M vertices/s")
    t, md = timed(lambda: MeshDistance(tri), 1)
    print(f"MeshDistance build             {t:8.3f} s")
    t, _ = timed(lambda: md.distance(v.position))
    print(f"exact distance, {n:,} queries  {t:8.3f} s   {n / t / 1e6:6.3f} M queries/s")


def timed(fn, repeat: int = 3):
    """Best wall time of ``repeat`` calls, and the last result."""
    best, out = np.inf, None
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t)
    return best, out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--facets", type=int, default=1_000_000)
    parser.add_argument("--vertices", type=int, default=1_000_000)
    parser.add_argument("--distance-vertices", type=int, default=100_000)
    args = parser.parse_args()
    rng = np.random.default_rng(1)
    n_side = round(np.sqrt(args.facets / 4))
    tri = pyramid_grid(n_side, 1 * um, rng)
    profile = ExponentialProfile(30 * nm)
    print(
        f"surface: {len(tri):,} facets ({n_side}x{n_side} pyramids, pitch 1 um, height 1 um +- 20 "
        "%)"
    )
    print(
        f"depth profile: exponential, mean 30 nm; {args.vertices:,} vertices per timing, best of "
        "3\n"
    )

    t, surface = timed(lambda: SurfaceSampler(tri), 1)
    print(f"SurfaceSampler build           {t:8.3f} s")
    t, _ = timed(lambda: surface.sample(rng, args.vertices))
    print(f"surface points only            {t:8.3f} s   {args.vertices / t / 1e6:6.2f} M points/s")
    normal = VertexSampler(surface, profile, definition="normal")
    t, v = timed(lambda: normal.sample(rng, args.vertices))
    print(
        f"vertices, depth 'normal'       {t:8.3f} s   {args.vertices / t / 1e6:6.2f} M vertices/s"
    )
    t, _ = timed(
        lambda: make_primaries(
            Po210Emitter(), rng, v.position, v.normal, depth=v.depth, facet=v.facet
        )
    )
    print(f"+ Po-210 primaries (2/event)   {t:8.3f} s   {args.vertices / t / 1e6:6.2f} M events/s")

    bench_distance("pyramids", tri, profile, args.distance_vertices, rng)
    hm = height_map_mesh(round(np.sqrt(args.facets / 2)), 0.1 * um, rng)
    print(f"\nheight map: {len(hm):,} facets, pitch 0.1 um, Sq 50 nm, correlation ~0.3 um")
    bench_distance("height map", hm, profile, args.distance_vertices, rng)

    patch = pyramid_grid(50, 1 * um, rng)  # 10^4 facets per patch, 200 x 200 cells = 10 cm^2 scale
    face = TiledSurfaceSampler(
        [patch, pyramid_grid(50, 1 * um, rng)], rng.integers(0, 2, (200, 200)), (50 * um, 50 * um)
    )
    tiled = VertexSampler(face, profile)
    t, _ = timed(lambda: tiled.sample(rng, args.vertices))
    print(
        f"\ntiled face 200x200 cells x 10^4 facets, 'normal': {t:.3f} s   "
        f"{args.vertices / t / 1e6:.2f} M vertices/s"
    )


if __name__ == "__main__":
    main()
