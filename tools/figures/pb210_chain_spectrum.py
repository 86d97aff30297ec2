"""The Pb-210 chain on a flat silicon face, and radon progeny implanted along their chain.

Two lite-physics runs (seconds each), the figures and tables of docs/physics.md
("The Pb-210 chain on a silicon face"):

1. ``source.decay: {chain: Pb210, equilibrium: secular}`` 20 nm (exponential mean) under the
   +z face of a 10 mm x 10 mm x 1 mm silicon crystal: each event one decay of Pb-210, Bi-210 or
   Po-210. Prints the spectrum's features (deposit windows per decaying nuclide, from the
   event's ``nuclide``) as a Markdown table: counts and shares of that nuclide's decays.
2. ``source.decay: {chain: Po218, implantation: true}``: Po-218 atoms on the same face (depth
   zero: plate-out), each followed down to Pb-206; every decay after an alpha decay happens
   where the alpha's recoil stopped. Prints the record's implantation counts and the depth of
   the decays of each member.

Also prints the lines emitted per 100 Pb-210 decays in the run against score4's decay data
(``score4 decay Pb210``: ENSDF).

    python tools/figures/pb210_chain_spectrum.py [--events 4000] [--atoms 1000] [--png FILE]
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

from score4.decay.nuclear_data import ZAI
from score4.decay.scheme import decay_scheme
from score4.inputs.config import parse_config
from score4.runner.engine import run
from score4.runner.output import read_results

PB210, BI210, PO210 = ZAI("Pb210"), ZAI("Bi210"), ZAI("Po210")
CRYSTAL = {
    "name": "crystal",
    "material": "G4_Si",
    "size": ["10 mm", "10 mm", "1 mm"],
    "position": ["0 mm", "0 mm", "-0.5 mm"],
}


def line_kev(nuclide: str, kind: str, near: float) -> float:
    lines = [ln for ln in decay_scheme(nuclide).lines() if ln.kind == kind]
    return min(lines, key=lambda ln: abs(ln.energy - near)).energy


def simulate(source: dict, events: int, seed: int, folder: Path, name: str):
    config = parse_config(
        {
            "physics": "lite",
            "targets": [CRYSTAL],
            "source": {"surface": {"volume": "crystal", "face": "+z"}, **source},
            "run": {"events": events, "seed": seed},
        }
    )
    out = folder / f"{name}.h5"
    run(config, out, jobs=2, progress=False, echo=lambda _: None)
    return read_results(out)


def emitted(p, particle: str, lo: float, hi: float) -> np.ndarray:
    """Per event: has it a primary ``particle`` with ``lo <= E < hi`` keV?"""
    e = p.energy * 1e3
    rows = (p.particle == particle) & (e >= lo) & (e < hi)
    return np.bincount(p.event[rows], minlength=p.n_events) > 0


def features(results) -> list[tuple[int, str, str, np.ndarray]]:
    """(nuclide, feature, window text, events in it) of the spectrum, in keV."""
    p = results.primaries
    first = p.event_offsets()[:-1]
    nuclide = p.extra["nuclide"][first]
    e = results.edep["crystal"] * 1e3
    alpha, recoil = line_kev("Po210", "alpha", 5304), line_kev("Po210", "recoil", 103)
    q = alpha + recoil
    ce_l, ce_m = line_kev("Pb210", "ce-L", 30), line_kev("Pb210", "ce-M+", 42.5)
    g = line_kev("Pb210", "gamma", 46.5)
    rows = [
        (PB210, "nothing deposited", "0", e == 0),
        (PB210, "beta (17 keV end point) and L Auger electrons", "0 - 25", (e > 0) & (e < 25)),
        (PB210, f"L conversion line ({ce_l:.2f} keV) on the beta", "25 - 40", (e >= 25) & (e < 40)),
        (
            PB210,
            f"M+ conversion line ({ce_m:.2f} keV), 63.5 keV beta",
            f"40 - {63.5 + 8:.1f}",
            (e >= 40) & (e < 71.5),
        ),
        (
            PB210,
            f"{g:.1f} keV gamma emitted (not tracked)",
            "-",
            emitted(p, "gamma", g - 0.01, g + 0.01),
        ),
        (PB210, "L X-rays emitted (not tracked)", "-", emitted(p, "gamma", 0.0, 15.0)),
        (BI210, "nothing deposited", "0", e == 0),
        (BI210, "beta continuum (1162 keV end point)", "0 - 1162", (e > 0) & (e <= 1162.2)),
        (BI210, "of it above 500 keV", "500 - 1162", (e > 500) & (e <= 1162.2)),
        (
            PO210,
            "recoil only (alpha left the face)",
            f"{recoil - 1:.0f} - 110",
            (e >= recoil - 1) & (e < 110),
        ),
        (
            PO210,
            "recoil + the alpha's path out (grazing alphas)",
            "110 - 1000",
            (e >= 110) & (e < 1000),
        ),
        (
            PO210,
            "alpha + part of the recoil (recoil left)",
            f"{alpha:.1f} - {q - 0.5:.1f}",
            (e >= alpha - 0.5) & (e < q - 0.5),
        ),
        (PO210, "alpha + whole recoil (both stopped)", f">= {q - 0.5:.1f}", e >= q - 0.5),
    ]
    return [(z, what, window, mask & (nuclide == z)) for z, what, window, mask in rows]


def summary_lines(results) -> list[str]:
    """Shares quoted in the text: per nuclide, decays with a deposit; Po-210 alphas inside."""
    p = results.primaries
    nuclide = p.extra["nuclide"][p.event_offsets()[:-1]]
    e = results.edep["crystal"] * 1e3
    po = nuclide == PO210
    alpha = line_kev("Po210", "alpha", 5304)
    inside = int((po & (e >= alpha - 0.5)).sum())
    out = [f"Po210 alpha in the crystal {100 * inside / po.sum():.1f} % of {int(po.sum())}"]
    for z, name in ((PB210, "Pb210"), (BI210, "Bi210"), (PO210, "Po210")):
        sel = nuclide == z
        out.append(f"{name} decays {int(sel.sum())}, with a deposit {int((sel & (e > 0)).sum())}")
    return out


def feature_table(results) -> list[str]:
    p = results.primaries
    nuclide = p.extra["nuclide"][p.event_offsets()[:-1]]
    out = [
        "| decay | feature | deposit (keV) | events | per 100 decays |",
        "| --- | --- | --- | --- | --- |",
    ]
    names = {PB210: "Pb-210", BI210: "Bi-210", PO210: "Po-210"}
    for z, what, window, mask in features(results):
        n, total = int(mask.sum()), int((nuclide == z).sum())
        share = 100 * n / total
        err = 100 * np.sqrt(share / 100 * (1 - share / 100) / total)
        out.append(f"| {names[z]} | {what} | {window} | {n} | {share:.1f} ± {err:.1f} |")
    return out


def line_table(results) -> list[str]:
    """Discrete lines emitted per 100 Pb-210 decays of the run against the decay data."""
    p = results.primaries
    pb = p.extra["nuclide"] == PB210
    decays = int((p.extra["nuclide"][p.event_offsets()[:-1]] == PB210).sum())
    e = p.energy[pb] * 1e3
    particle = p.particle[pb]
    lines = decay_scheme("Pb210").lines()
    out = [
        "| line | energy (keV) | per 100 decays, run | per 100 decays, decay data |",
        "| --- | --- | --- | --- |",
    ]
    for kind, name, what in (
        ("gamma", "gamma", "gamma"),
        ("ce-L", "e-", "conversion electron, L shell"),
        ("ce-M+", "e-", "conversion electron, M and outer shells"),
        ("X-L", "gamma", "L X-rays (all)"),
        ("Auger-L", "e-", "L Auger electron"),
    ):
        chosen = [ln for ln in lines if ln.kind == kind]
        sel = (particle == name) & np.isin(np.round(e, 4), [round(ln.energy, 4) for ln in chosen])
        n = int(sel.sum())
        energy = (
            f"{chosen[0].energy:.3f}"
            if len(chosen) == 1
            else f"{min(ln.energy for ln in chosen):.2f} - {max(ln.energy for ln in chosen):.2f}"
        )
        data = 100 * sum(ln.intensity for ln in chosen)
        err = 100 * np.sqrt(n) / decays
        out.append(f"| {what} | {energy} | {100 * n / decays:.1f} ± {err:.1f} | {data:.1f} |")
    return out


MEMBERS = ("Po218", "Pb214", "Bi214", "Po214", "Pb210", "Bi210", "Po210")


def decays_of(results) -> dict[str, np.ndarray]:
    """One entry per decay (not per event: Po-214 may share its Bi-214's event)."""
    ex = results.primaries.extra
    key = np.asarray(ex["atom"], np.int64) * 64 + np.asarray(ex["decay_index"], np.int64)
    _, first = np.unique(key, return_index=True)
    return {
        "nuclide": ex["nuclide"][first],
        "vertex": ex["vertex"][first],
        "depth": ex["depth"][first] * 1e6,  # nm
        "atom": ex["atom"][first],
        "position": results.primaries.position[first],
    }


def implantation_lines(results) -> list[str]:
    """The run record's implantation counts and a table: where each member decays."""
    run = results.run
    atoms, counts, chain = run["n_atoms"], run["implantation"], run["decay_chain"]
    per_atom = dict(zip(chain["members"], chain["decays_per_atom"], strict=True))
    d = decays_of(results)
    out = [
        (
            f"atoms {atoms}, events {run['n_events']}, "
            f"simulated_decays {run['simulated_decays']:g} of {run['activity_nuclide']}"
        ),
        (
            f"recoils followed by a decay {counts['recoils']}: deeper {counts['deeper']}, "
            f"shallower {counts['shallower']}, left the world {counts['left_world']} "
            f"({100 * counts['left_world'] / counts['recoils']:.1f} %), other volume "
            f"{counts['other_volume']}"
        ),
        f"decays lost with their atoms {counts['lost_decays']}",
        "",
        (
            "| member | decays per 100 atoms | chain (no loss) | at the deposit | implanted "
            "| mean depth (nm) | median (nm) | 90 % within (nm) |"
        ),
        "| --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for name in MEMBERS:
        sel = d["nuclide"] == ZAI(name)
        depth = d["depth"][sel]
        n = int(sel.sum())
        out.append(
            f"| {name[:2]}-{name[2:]} | {100 * n / atoms:.1f} | {100 * per_atom[name]:.1f} "
            f"| {int((d['vertex'][sel] == 0).sum())} | {int((d['vertex'][sel] == 1).sum())} "
            f"| {depth.mean():.1f} | {np.median(depth):.1f} | {np.percentile(depth, 90):.1f} |"
        )
    pb, po = d["nuclide"] == ZAI("Pb210"), d["nuclide"] == ZAI("Po210")
    where = dict(zip(d["atom"][pb], d["position"][pb].tolist(), strict=True))
    same = sum(
        where.get(a) == x for a, x in zip(d["atom"][po], d["position"][po].tolist(), strict=True)
    )
    out.append("")
    out.append(f"Po210 decays at their atom's Pb210 vertex: {same} of {int(po.sum())}")
    return out


def plot(spectrum, implanted, png: Path) -> None:
    import matplotlib as mpl

    mpl.use("Agg")
    import matplotlib.pyplot as plt

    p = spectrum.primaries
    nuclide = p.extra["nuclide"][p.event_offsets()[:-1]]
    e = spectrum.edep["crystal"] * 1e3
    fig, axes = plt.subplots(2, 2, figsize=(11, 7.5))
    colours = {PB210: "tab:blue", BI210: "tab:green", PO210: "tab:red"}
    labels = {PB210: "Pb-210", BI210: "Bi-210", PO210: "Po-210"}
    panels = [
        (axes[0, 0], np.arange(0, 121, 1.0), "deposit (keV), 1 keV bins"),
        (axes[0, 1], np.arange(0, 1250, 25.0), "deposit (keV), 25 keV bins"),
        (axes[1, 0], np.arange(5290, 5412, 2.0), "deposit (keV), 2 keV bins"),
    ]
    for ax, edges, xlabel in panels:
        for z in (PB210, BI210, PO210):
            ax.hist(
                e[(nuclide == z) & (e > 0)],
                bins=edges,
                histtype="step",
                color=colours[z],
                label=labels[z],
            )
        ax.set_yscale("log")
        ax.set_xlabel(xlabel)
        ax.set_ylabel("events")
    axes[0, 0].legend()
    axes[0, 0].set_title("Pb-210 lines, Po-210 recoil band")
    axes[0, 1].set_title("Bi-210 beta continuum")
    axes[1, 0].set_title("Po-210 alpha, alpha + recoil")
    ax = axes[1, 1]
    d = decays_of(implanted)
    zn, depth = d["nuclide"], d["depth"]
    edges = np.arange(0, 151, 3.0)
    for name, colour in (("Po214", "tab:orange"), ("Po210", "tab:red")):
        ax.hist(
            depth[zn == ZAI(name)],
            bins=edges,
            histtype="step",
            color=colour,
            label=f"{name} decays",
        )
    ax.set_xlabel("depth below the face (nm)")
    ax.set_ylabel("decays")
    ax.set_title("Po-218 plated out at the face: where its progeny decay")
    ax.legend()
    fig.suptitle("Pb-210 chain on a flat Si face (lite physics; gammas and X-rays not tracked)")
    fig.tight_layout()
    fig.savefig(png, dpi=90)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--events", type=int, default=4000)
    parser.add_argument("--atoms", type=int, default=1000)
    parser.add_argument("--png", type=Path)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        spectrum = simulate(
            {
                "decay": {"chain": "Pb210", "equilibrium": "secular"},
                "depth": {"profile": "exponential", "mean": "20 nm"},
            },
            args.events,
            1,
            folder,
            "pb210",
        )
        implanted = simulate(
            {"decay": {"chain": "Po218", "implantation": True}, "depth": {"profile": "zero"}},
            args.atoms,
            1,
            folder,
            "po218",
        )
        print(f"Pb-210 chain, secular, 20 nm under a flat Si face: {args.events} events")
        print("\n".join(feature_table(spectrum)))
        print()
        print("\n".join(line_table(spectrum)))
        print()
        g = spectrum.columns["untracked_gamma_energy"]
        print(f"photon energy not tracked: {g.sum() * 1e3:.1f} keV in {int((g > 0).sum())} events")
        print("\n".join(summary_lines(spectrum)))
        print()
        print(f"Po-218 plated out on the face, implantation along the chain: {args.atoms} atoms")
        print("\n".join(implantation_lines(implanted)))
        if args.png:
            plot(spectrum, implanted, args.png)


if __name__ == "__main__":
    main()
