"""Sal of periodic Gaussian random surfaces against the generator's correlation length.

Prints, per seed, Sal / (sqrt(ln 5) * corr_length) measured three ways: on one period (what
``score4 surface stats`` measures now), on the closed tile with its duplicated edge counted
(what it measured before), and without levelling; then the decay length averaged over all
directions instead of the shortest one, and Sal of the exact Gaussian ACF. Finding: the
direction mean is 1.00 and the exact ACF gives 1.00, so Sal of one realisation reads low because
it is the minimum over directions of a noisy sample ACF (see score4.surface.metrology). Usage:

    python benchmarks/bench_sal_periodic.py [n] [corr_px] [seeds]
"""

from __future__ import annotations

import argparse

import numpy as np

from score4.surface.heightmap import HeightMap
from score4.surface.metrology import _decay_lengths, areal_parameters, autocorrelation
from score4.surface.processing import close_periodic
from score4.surface.random import SAL_PER_CORR_LENGTH, gaussian_random_surface


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("n", nargs="?", type=int, default=128, help="pixels per side (128)")
    parser.add_argument("corr_px", nargs="?", type=float, default=6.0, help="corr. length (6)")
    parser.add_argument("seeds", nargs="?", type=int, default=6, help="realisations (6)")
    args = parser.parse_args()
    n, corr, seeds = args.n, args.corr_px, args.seeds
    expected = SAL_PER_CORR_LENGTH["gaussian"] * corr
    cases: list[list[float]] = []
    for seed in range(seeds):
        period = gaussian_random_surface(
            n, n, 1.0, sq=1.0, corr_length_x=corr, seed=seed, periodic=True
        )
        closed = close_periodic(period)
        raw = HeightMap(closed.heights, closed.pitch_x, closed.pitch_y)  # edge counted twice
        cases.append(
            [
                areal_parameters(closed)["Sal"] / expected,
                areal_parameters(raw)["Sal"] / expected,
                areal_parameters(closed, level=False)["Sal"] / expected,
                np.nanmean(_decay_lengths(autocorrelation(closed), 1.0, 1.0, 0.2)) / expected,
            ]
        )
    rows = np.array(cases)
    print(f"{n} x {n} periodic Gaussian maps, corr_length {corr} px, {seeds} seeds")
    print("Sal / (sqrt(ln 5) l):   one period   closed tile  not levelled  direction mean")
    for seed, r in enumerate(rows):
        print(f"  seed {seed}:             {r[0]:10.3f} {r[1]:13.3f} {r[2]:13.3f} {r[3]:15.3f}")
    mean, sem = rows.mean(axis=0), rows.std(axis=0, ddof=1) / np.sqrt(len(rows))
    cells = "  ".join(f"{m:6.3f} +- {e:.3f}" for m, e in zip(mean, sem, strict=True))
    print("  mean +- s.e.:     " + cells)
    lag = np.arange(-(n // 2), n // 2 + 1)
    x, y = np.meshgrid(lag, lag)
    exact = _decay_lengths(np.exp(-(x**2 + y**2) / corr**2), 1.0, 1.0, 0.2) / expected
    print(f"exact Gaussian ACF: shortest {exact.min():.4f}, longest {exact.max():.4f}")


if __name__ == "__main__":
    main()
