"""Mean beta energies of score4's spectra against ENSDF's, as the Markdown table of docs/decay.md.

    python tools/figures/decay_mean_table.py [--min-share 5]

One row per beta branch carrying at least ``--min-share`` % of its nuclide's decays.
"""

from __future__ import annotations

import argparse

from score4.decay import decay_scheme, known_nuclides


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--min-share", type=float, default=5.0)
    args = parser.parse_args()
    header = "nuclide | endpoint (keV) | share (%) | shape | mean (keV) | ENSDF mean (keV)"
    print(f"| {header} | difference (%) |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for name in known_nuclides():
        for ln in decay_scheme(name).lines():
            if ln.kind not in ("beta-", "beta+") or 100 * ln.intensity < args.min_share:
                continue
            if not ln.mean_ensdf > 0:
                continue
            diff = 100 * (ln.mean / ln.mean_ensdf - 1)
            print(
                f"| {name} | {ln.energy:.1f} | {100 * ln.intensity:.1f} | {ln.note} | "
                f"{ln.mean:.2f} | {ln.mean_ensdf:g} | {diff:+.1f} |"
            )


if __name__ == "__main__":
    main()
