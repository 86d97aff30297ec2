"""Per nuclide of the U-238, U-235 and Th-232 chains, Pb-210 and K-40: Q values, the gamma lines
of the data sets and the lines that come from level feeding (docs/decay.md's tables).

python tools/figures/decay_evaluated_table.py
"""

from __future__ import annotations

import argparse

from score4.decay import decay_scheme
from score4.decay.chain import build_chain
from score4.decay.nuclear_data import decay_data
from score4.decay.table import _filled_lines

MIN_PERCENT = 0.05


def main() -> None:
    names = sorted(
        {m for head in ("U238", "U235", "Th232") for m in build_chain(head).members}
        | {"Pb210", "K40"}
    )
    print(
        "| nuclide | mode | Q AME2020 (keV) | Q ENSDF (keV) | gammas >= 0.05 % | "
        "largest gamma deviation (%) | largest feeding change (% per decay) | intensity scale | "
        "from level feeding >= 0.05 % |"
    )
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for name in names:
        rec = decay_data()["nuclides"][name]
        total = sum(m["branching"] for m in rec["modes"])
        table: dict[float, float] = {}
        for ln in decay_scheme(name).lines():
            if ln.kind == "gamma":
                key = round(ln.energy, 4)
                table[key] = table.get(key, 0.0) + 100.0 * ln.intensity
        filled = _filled_lines(rec)
        for m in rec["modes"]:
            if m["mode"] == "IT":
                continue
            share = m["branching"] / total
            levels = m.get("levels_keV") or []
            data: dict[float, float] = {}
            fill: dict[float, float] = {}
            for t in m["transitions"]:
                if t[10] or t[3] <= 0:
                    continue
                key = round(min(t[2], levels[int(t[0])] - levels[int(t[1])]), 4)
                if int(t[9]) == 1:
                    fill[key] = fill.get(key, 0.0) + t[3] * share
                else:  # the data set's intensity (a scaled line emits another)
                    data[key] = data.get(key, 0.0) + t[11] * share
            scale = m.get("intensity_scale", 1.0)
            shown = {k: v for k, v in data.items() if v >= MIN_PERCENT}
            worst = max(
                (
                    abs(table.get(k, 0.0) - fill.get(k, 0.0) * scale - v) / v
                    for k, v in shown.items()
                ),
                default=0.0,
            )
            mine = [
                f
                for f in filled
                if any(abs(f["energy_keV"] - round(t[2], 4)) < 1e-9 for t in m["transitions"])
                and f["transition_percent"] >= MIN_PERCENT
            ]
            fed = ", ".join(
                f"{f['energy_keV']:g}{' E0' if f['E0'] else ''} ({f['transition_percent']:.3g})"
                for f in mine
            )
            q_ensdf = f"{m['q_ensdf_keV']:g}({m['dq_ensdf_keV']:g})"
            moved = max(
                (
                    abs(f["intensity"] - f.get("intensity_ensdf", f["intensity"]))
                    for f in m["feeds"]
                ),
                default=0.0,
            )
            print(
                f"| {name} | {m['mode']} | {m['q_keV']:.2f} | {q_ensdf} | {len(shown)} | "
                f"{100 * worst:.2f} | {moved * share:.2f} | {scale:.4g} | {fed or '-'} |"
            )


if __name__ == "__main__":
    argparse.ArgumentParser(description=__doc__.splitlines()[0]).parse_args()
    main()
