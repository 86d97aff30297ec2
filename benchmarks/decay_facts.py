"""Figures that docs/decay.md quotes from score4's decay data and sampler (one per line).

python benchmarks/decay_facts.py
"""

from __future__ import annotations

import math

from score4.decay import decay_scheme
from score4.decay.chain import build_chain, chain_activities
from score4.decay.spectra import BetaSpectrum


def line(name: str, kind: str, energy: float):
    lines = [ln for ln in decay_scheme(name).lines() if ln.kind == kind]
    return min(lines, key=lambda ln: abs(ln.energy - energy))


def main() -> None:
    print(f"Po210 alpha {line('Po210', 'alpha', 5304).energy:.2f} keV")
    print(f"Po210 recoil {line('Po210', 'recoil', 103).energy:.3f} keV")
    print(f"U238 alpha {line('U238', 'alpha', 4151).energy:.1f} keV")
    print(f"Pb210 gamma {100 * line('Pb210', 'gamma', 46.5).intensity:.2f} %")
    print(f"Bi210 mean measured {line('Bi210', 'beta-', 1162).mean:.1f} keV")
    print(f"Bi210 mean allowed {BetaSpectrum.build(1162.2, 84, 210).mean_kev:.1f} keV")
    print(f"K40 mean {line('K40', 'beta-', 1311).mean:.1f} keV")
    k40_2u = BetaSpectrum.build(1310.89, 20, 40, forbiddenness="2UF").mean_kev
    print(f"K40 mean second unique {k40_2u:.1f} keV")
    tl = line("Tl210", "beta-", 2413)
    print(f"Tl210 2413 difference {100 * (tl.mean / tl.mean_ensdf - 1):.1f} %")
    merged = 100 * (1 - math.exp(-math.log(2) * 10 / 163.6))
    print(f"Po214 merged in 10 us {merged:.1f} %")
    a = chain_activities(build_chain("Pb210"), 180 * 86400.0)
    print(f"Pb210 chain 180 d: Bi210 {a[1]:.4f} Po210 {a[2]:.3f}")


if __name__ == "__main__":
    main()
