"""Figures that docs/decay.md quotes from score4's decay data and sampler (one per line).

python tools/figures/decay_facts.py
"""

from __future__ import annotations

import argparse
import math

from score4.decay import decay_scheme, known_nuclides
from score4.decay.chain import build_chain, chain_activities
from score4.decay.nuclear_data import decay_data
from score4.decay.spectra import BetaSpectrum
from score4.decay.table import radiation_table


def line(name: str, kind: str, energy: float):
    lines = [ln for ln in decay_scheme(name).lines() if ln.kind == kind]
    return min(lines, key=lambda ln: abs(ln.energy - energy))


def main() -> None:
    argparse.ArgumentParser(description=__doc__.splitlines()[0]).parse_args()
    print(f"Po210 alpha {line('Po210', 'alpha', 5304).energy:.2f} keV")
    print(f"Po210 recoil {line('Po210', 'recoil', 103).energy:.3f} keV")
    print(f"U238 alpha {line('U238', 'alpha', 4151).energy:.1f} keV")
    print(f"Pb210 gamma {100 * line('Pb210', 'gamma', 46.5).intensity:.2f} %")
    print(f"Bi210 mean measured {line('Bi210', 'beta-', 1162).mean:.1f} keV")
    print(f"Bi210 mean allowed {BetaSpectrum.build(1162.2, 84, 210).mean_kev:.1f} keV")
    print(f"K40 mean {line('K40', 'beta-', 1311).mean:.1f} keV")
    k40_2u = BetaSpectrum.build(1310.89, 20, 40, forbiddenness="2UF").mean_kev
    print(f"K40 mean second unique {k40_2u:.1f} keV")
    tl = line("Tl210", "beta-", 2412.4)
    print(f"Tl210 2413 difference {100 * (tl.mean / tl.mean_ensdf - 1):.1f} %")
    excess = max(decay_scheme(n).alpha_excess_kev for n in known_nuclides())
    print(f"largest measured alpha excess {excess:.1f} keV")
    print(f"U235 gamma 185.7 {100 * line('U235', 'gamma', 185.713).intensity:.1f} %")
    for name, mode in (("Pa234", "B-"), ("Tl210", "B-"), ("Fr223", "B-"), ("U235", "A")):
        m = next(m for m in decay_data()["nuclides"][name]["modes"] if m["mode"] == mode)
        print(f"{name} {mode} intensity scale {m['intensity_scale']:.2f}")
    e0 = sum(
        f["transition_percent"]
        for f in radiation_table("Pa234m")["nuclides"][0]["lines_from_level_feeding"]
        if f["E0"] and abs(f["energy_keV"] - 811) < 1
    )
    print(f"Pa234m E0 810 keV {e0:.2f} %")
    merged = 100 * (1 - math.exp(-math.log(2) * 10 / 163.6))
    print(f"Po214 merged in 10 us {merged:.1f} %")
    a = chain_activities(build_chain("Pb210"), 180 * 86400.0)
    print(f"Pb210 chain 180 d: Bi210 {a[1]:.4f} Po210 {a[2]:.3f}")


if __name__ == "__main__":
    main()
