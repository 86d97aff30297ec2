"""SRIM/TRIM reference ranges of the ions and detector materials of the field (issue 10, 1 and 5).

Run: ``.venv/bin/python tools/figures/srim_reference_table.py [--pb-ions 1000] [--alpha-ions 500]``.

Prints and writes two tables (lunasrim 1.0.0 = SRIM-2013):

* ``docs/data/srim_reference.csv``: projected range, longitudinal and lateral straggling of
  Pb-206 (50, 103.144, 200 keV) and alphas (1, 3, 5.3 MeV) in Si, Ge, Cu, CaWO4, TeO2 and NaI,
  from SRIM's analytic range table (SRModule) and from TRIM's Monte Carlo (N ions stated,
  seed stated, semi-infinite block, normal incidence).
* ``docs/data/srim_thin_layers.csv``: TRIM's transmitted fraction and mean exit energy of
  Pb-206 (103.144 keV) through 10, 20, 40 nm and of 5.3 MeV alphas through 5, 10, 20 um, at 0
  and 60 degrees from the normal, in the same six materials.

``--markdown`` reads the two CSV files instead (no TRIM run) and prints the excerpt tables of
docs/physics.md and the figures its text quotes about them (``make docs-check`` compares them).

Each material is the Geant4 one (G4NistManager; TeO2 has no NIST name and is a ``materials:``
entry, formula TeO2, 6.02 g/cm3), and TRIM gets its atoms and **its density**, so depths in nm
compare directly with Geant4 runs in that material. TRIM results are cached
(``~/.cache/score4/srim``); the first full run takes several minutes of one core.
Definitions (TRIM's): range = mean depth of the stopped ions, straggling = their depth rms
about the mean, lateral = rms lateral displacement on one axis (both axes pooled).
"""

from __future__ import annotations

import argparse
import csv
import math
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

# label -> (Geant4 material, how it is defined)
MATERIALS = {
    "Si": "G4_Si",
    "Ge": "G4_Ge",
    "Cu": "G4_Cu",
    "CaWO4": "G4_CALCIUM_TUNGSTATE",
    "TeO2": "TeO2",  # no NIST name: a materials: entry
    "NaI": "G4_SODIUM_IODIDE",
}
TEO2 = {"formula": "TeO2", "density": "6.02 g/cm3"}
CASES = [("Pb206", e) for e in (0.050, 0.103144, 0.200)] + [("alpha", e) for e in (1.0, 3.0, 5.3)]
THIN = [("Pb206", 0.103144, t * 1e-6) for t in (10, 20, 40)] + [
    ("alpha", 5.3, t * 1e-3) for t in (5, 10, 20)
]
ANGLES = (0.0, 60.0)


def compositions() -> dict:
    """Composition of each material as Geant4 builds it (atoms and density)."""
    from score4.inputs.materials import find_material
    from score4.ions.composition import Composition
    from score4.sim.runtime import import_geant4, resolve_physics

    g4 = import_geant4(resolve_physics("lite"))
    out = {}
    for label, name in MATERIALS.items():
        material = find_material(g4, name, label, {"TeO2": TEO2})
        comp = Composition.from_g4_material(material)
        out[label] = Composition(name, comp.atoms, comp.density)
    return out


def _g4_label(comp) -> str:
    return comp.name if comp.name.startswith("G4_") else f"materials: {comp.name}"


def atoms_text(comp) -> str:
    return ";".join(f"{s}:{f:.9g}" for s, f in comp.atoms)


def reference_rows(comps: dict, pb_ions: int, alpha_ions: int, seed: int) -> list[dict]:
    from score4.ions.species import parse_ion
    from score4.ions.srim_reference import srim_range_sample, stopping_table_reference, summarize

    rows = []
    for ion, energy in CASES:
        n = pb_ions if ion == "Pb206" else alpha_ions
        for label, comp in comps.items():
            t0 = time.perf_counter()
            table = stopping_table_reference(ion, energy, comp)
            s = summarize(srim_range_sample(ion, energy, comp, n, seed))
            rows.append(
                {
                    "ion": parse_ion(ion).label,
                    "energy_keV": f"{energy * 1e3:.6g}",
                    "material": label,
                    "geant4_material": _g4_label(comp),
                    "density_g_cm3": f"{comp.density:.6g}",
                    "atoms": atoms_text(comp),
                    "table_range_nm": f"{table['projected_range_nm']:.6g}",
                    "table_straggling_nm": f"{table['straggling_nm']:.6g}",
                    "table_lateral_nm": f"{table['lateral_nm']:.6g}",
                    "trim_ions": n,
                    "trim_seed": seed,
                    "trim_range_nm": f"{s['projected_range_nm']:.6g}",
                    "trim_range_err_nm": f"{s['projected_range_err_nm']:.3g}",
                    "trim_straggling_nm": f"{s['straggling_nm']:.6g}",
                    "trim_lateral_nm": f"{s['lateral_nm']:.6g}",
                    "trim_backscattered_fraction": f"{s['backscattered_fraction']:.4g}",
                }
            )
            print(
                f"  {rows[-1]['ion']:7s} {rows[-1]['energy_keV']:>8s} keV {label:6s} "
                f"({time.perf_counter() - t0:.1f} s)",
                flush=True,
            )
    return rows


def thin_rows(comps: dict, pb_ions: int, alpha_ions: int, seed: int) -> list[dict]:
    from score4.ions.species import parse_ion
    from score4.ions.srim_reference import srim_range_sample, summarize

    rows = []
    for ion, energy, thickness in THIN:
        n = pb_ions if ion == "Pb206" else alpha_ions
        for angle in ANGLES:
            for label, comp in comps.items():
                s = summarize(srim_range_sample(ion, energy, comp, n, seed, thickness, angle))
                rows.append(
                    {
                        "ion": parse_ion(ion).label,
                        "energy_keV": f"{energy * 1e3:.6g}",
                        "material": label,
                        "geant4_material": _g4_label(comp),
                        "density_g_cm3": f"{comp.density:.6g}",
                        "thickness_nm": f"{thickness * 1e6:.6g}",
                        "angle_deg": f"{angle:g}",
                        "trim_ions": n,
                        "trim_seed": seed,
                        "transmitted_fraction": f"{s['transmitted_fraction']:.4f}",
                        "transmitted_fraction_err": f"{s['transmitted_fraction_err']:.4f}",
                        "mean_exit_energy_keV": f"{s['mean_exit_energy_keV']:.5g}",
                        "mean_exit_energy_err_keV": f"{s['mean_exit_energy_err_keV']:.3g}",
                        "backscattered_fraction": f"{s['backscattered_fraction']:.4f}",
                    }
                )
    return rows


def write_csv(path: Path, rows: list[dict], comment: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", newline="") as fh:
        fh.write(f"# {comment}\n")
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)


def print_table(rows: list[dict], columns: list[str]) -> None:
    widths = [max(len(c), *(len(str(r[c])) for r in rows)) for c in columns]
    print("  ".join(c.rjust(w) for c, w in zip(columns, widths, strict=True)))
    for r in rows:
        print("  ".join(str(r[c]).rjust(w) for c, w in zip(columns, widths, strict=True)))


def _read_csv(path: Path) -> list[dict]:
    with open(path) as fh:
        return list(csv.DictReader(line for line in fh if not line.startswith("#")))


def _sig4(x: float) -> str:
    """Four significant digits, but never a digit of a length above 1000 nm dropped (26437)."""
    return f"{x:.{max(0, 3 - math.floor(math.log10(abs(x))))}f}" if x else "0"


def markdown(folder: Path) -> None:
    """Print docs/physics.md's excerpts of the two CSV files, and the ratios its text quotes."""
    rows = _read_csv(folder / "srim_reference.csv")
    excerpt = [r for r in rows if r["energy_keV"] in ("103.144", "5300")]

    def length(r: dict, key: str) -> str:  # Pb-206 in nm to 0.1 nm, alphas to 4 digits
        return f"{float(r[key]):.1f}" if r["ion"] == "Pb-206" else _sig4(float(r[key]))

    header = ["ion", "energy", "material (Geant4)", "density g/cm3", "table range nm",
              "table straggling nm", "table lateral nm", "TRIM range nm", "TRIM straggling nm",
              "TRIM lateral nm"]  # fmt: skip
    print("| " + " | ".join(header) + " |")
    print("| --- " * 10 + "|")
    for r in excerpt:
        cells = [
            r["ion"],
            f"{r['energy_keV']} keV",
            f"{r['material']} ({r['geant4_material']})",
            r["density_g_cm3"],
            *(length(r, k) for k in ("table_range_nm", "table_straggling_nm", "table_lateral_nm")),
            f"{length(r, 'trim_range_nm')} ± {float(r['trim_range_err_nm']):.2g}",
            length(r, "trim_straggling_nm"),
            length(r, "trim_lateral_nm"),
        ]
        print("| " + " | ".join(cells) + " |")

    # the text under the table: TRIM's Monte Carlo against SRIM's analytic table, all 36 rows
    def spread(key: str, ion: str | None = None) -> list[float]:
        return [
            float(r[f"trim_{key}"]) / float(r[f"table_{key}"])
            for r in rows
            if ion is None or r["ion"] == ion
        ]

    worst = max(abs(x - 1) for x in spread("range_nm"))
    print(f"\nTRIM range / table range: within {100 * worst:.1f} % (all rows)")
    worst = max(abs(x - 1) for x in spread("lateral_nm"))
    print(f"TRIM lateral / table lateral: within {100 * worst:.1f} % (all rows)")
    worst = max(abs(x - 1) for x in spread("straggling_nm", "Pb-206"))
    print(f"TRIM straggling / table straggling, Pb-206: within {100 * worst:.1f} %")
    alpha = [1 / x for x in spread("straggling_nm", "alpha")]
    print(f"table straggling / TRIM straggling, alphas: {min(alpha):.2f}-{max(alpha):.2f}")

    thin = _read_csv(folder / "srim_thin_layers.csv")
    print("\n| ion | material | layer | angle | transmitted fraction | mean exit energy keV |")
    print("| --- " * 6 + "|")
    for r in thin:
        if r["material"] not in ("Si", "CaWO4"):
            continue
        nm = float(r["thickness_nm"])
        layer = f"{nm:g} nm" if r["ion"] == "Pb-206" else f"{nm / 1e3:g} um"
        exit_kev = "-" if r["mean_exit_energy_keV"] == "nan" else r["mean_exit_energy_keV"]
        fraction = f"{float(r['transmitted_fraction']):.3f} ± "
        fraction += f"{float(r['transmitted_fraction_err']):.3f}"
        cells = [r["ion"], r["material"], layer, f"{r['angle_deg']}°", fraction, exit_kev]
        print("| " + " | ".join(cells) + " |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pb-ions", type=int, default=1000, help="TRIM ions per Pb-206 case")
    parser.add_argument("--alpha-ions", type=int, default=500, help="TRIM ions per alpha case")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "data")
    parser.add_argument(
        "--markdown", action="store_true", help="print the docs' tables from the CSV files in --out"
    )
    args = parser.parse_args()
    if args.markdown:
        markdown(args.out)
        return
    import lunasrim

    t0 = time.perf_counter()
    comps = compositions()
    print("materials (Geant4 compositions and densities used for TRIM):")
    for label, comp in comps.items():
        print(f"  {label:6s} {comp.name:22s} {comp.density:.6g} g/cm3  atoms {atoms_text(comp)}")
    version = f"lunasrim {lunasrim.__version__} (SRIM-2013)"
    print(f"\nranges, {version}; TRIM: semi-infinite block, normal incidence")
    rows = reference_rows(comps, args.pb_ions, args.alpha_ions, args.seed)
    print_table(
        rows,
        ["ion", "energy_keV", "material", "geant4_material", "density_g_cm3", "table_range_nm",
         "table_straggling_nm", "table_lateral_nm", "trim_ions", "trim_range_nm",
         "trim_range_err_nm", "trim_straggling_nm", "trim_lateral_nm"],
    )  # fmt: skip
    write_csv(
        args.out / "srim_reference.csv",
        rows,
        f"written by tools/figures/srim_reference_table.py with {version}; lengths in nm; "
        f"table_* = SRIM range table, trim_* = TRIM Monte Carlo (trim_ions ions, seed trim_seed)",
    )
    print(f"\nthin layers, {version}: TRIM transmitted fraction and mean exit energy")
    thin = thin_rows(comps, args.pb_ions, args.alpha_ions, args.seed)
    print_table(
        thin,
        ["ion", "material", "thickness_nm", "angle_deg", "trim_ions", "transmitted_fraction",
         "transmitted_fraction_err", "mean_exit_energy_keV", "mean_exit_energy_err_keV",
         "backscattered_fraction"],
    )  # fmt: skip
    write_csv(
        args.out / "srim_thin_layers.csv",
        thin,
        f"written by tools/figures/srim_reference_table.py with {version}; TRIM ions through a "
        f"layer at angle_deg from the normal; energies in keV",
    )
    print(
        f"\nwrote {args.out / 'srim_reference.csv'} and {args.out / 'srim_thin_layers.csv'} "
        f"in {time.perf_counter() - t0:.0f} s (shared machine: times are indicative)"
    )


if __name__ == "__main__":
    main()
