"""Decay-radiation tables (like NNDC's) of a nuclide or a chain, as text, JSON and a picture."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .chain import ChainEvents, build_chain
from .nuclear_data import decay_data
from .scheme import KINDS, Line, decay_scheme

__all__ = ["plot_spectra", "radiation_table", "table_text"]

_LABEL = {
    "alpha": "alpha",
    "recoil": "recoil ion",
    "beta-": "beta-",
    "beta+": "beta+",
    "gamma": "gamma",
    "ce-K": "ce K",
    "ce-L": "ce L",
    "ce-M+": "ce M+",
    "X-K": "X-ray K",
    "X-L": "X-ray L",
    "Auger-K": "Auger K",
    "Auger-L": "Auger L",
}


def _nuclide_entry(name: str, scale: float, min_intensity: float) -> dict:
    scheme = decay_scheme(name)
    record = decay_data()["nuclides"][scheme.nuclide]
    lines = [ln for ln in scheme.lines() if ln.intensity * scale >= min_intensity]
    return {
        "nuclide": scheme.nuclide,
        "half_life": record["half_life"],
        "half_life_s": scheme.half_life_s,
        "modes": [
            {
                "mode": m["mode"],
                "branching": m["branching"],
                "daughter": m["daughter"],
                "q_keV": m["q_keV"],
                "q_source": m.get("q_source", ""),
                "q_ensdf_keV": m.get("q_ensdf_keV"),
                "dataset": m.get("dataset", ""),
                "intensity_scale": m.get("intensity_scale", 1.0),
            }
            for m in record["modes"]
        ],
        "lines_from_level_feeding": _filled_lines(record),
        "decays_per_head_decay": scale,
        "radiations": [_line_dict(ln, scale) for ln in lines],
    }


def _filled_lines(record: dict) -> list[dict]:
    """Transitions whose intensity comes from level feeding, not from the data set's records.

    Per decay of the nuclide: E0 branches and gammas the data set gives no intensity, and the
    lines to the ground state that carry what arrives at a level beyond what leaves it.
    """
    total = sum(m["branching"] for m in record["modes"])
    out = []
    for m in record["modes"]:
        levels = m.get("levels_keV") or []
        for t in m.get("transitions", []):
            if int(t[9]) != 1 or t[3] <= 0:
                continue
            share = m["branching"] / total / 100.0 * m.get("intensity_scale", 1.0)
            out.append(
                {
                    "energy_keV": round(t[2], 4),
                    "from_level_keV": levels[int(t[0])],
                    "to_level_keV": levels[int(t[1])],
                    "E0": bool(t[10]),
                    "gamma_percent": 0.0 if t[10] else 100.0 * t[3] * share,
                    "transition_percent": 100.0 * t[3] * (1.0 + t[5]) * share,
                }
            )
    return out


def _line_dict(ln: Line, scale: float) -> dict:
    out = {
        "type": ln.kind,
        "energy_keV": round(ln.energy, 4),
        "intensity_percent": 100.0 * ln.intensity * scale,
    }
    if ln.kind in ("beta-", "beta+"):
        out["mean_keV"] = round(ln.mean, 3)
        out["mean_ensdf_keV"] = None if math.isnan(ln.mean_ensdf) else ln.mean_ensdf
        out["shape"] = ln.note
    return out


def radiation_table(
    nuclide: str,
    chain: bool = False,
    until: str | None = None,
    since_deposition_s: float | None = None,
    min_intensity: float = 1e-4,
) -> dict:
    """The radiations per decay (per decay of the head for a chain), as a JSON-ready dict.

    ``min_intensity``: lines below this intensity per decay are left out (1e-4 = 0.01 %).
    """
    if not chain:
        return {"nuclides": [_nuclide_entry(nuclide, 1.0, min_intensity)]}
    ce = ChainEvents(build_chain(nuclide, until, what="decay"), since_deposition_s, 0.0)
    return {
        "chain": list(ce.chain.members),
        "activities": "secular equilibrium"
        if since_deposition_s is None
        else f"{_readable_time(since_deposition_s)} after deposition",
        "nuclides": [
            _nuclide_entry(m, float(a), min_intensity)
            for m, a in zip(ce.chain.members, ce.activity, strict=True)
        ],
    }


def _readable_time(seconds: float) -> str:
    for unit, size in (("y", 365.25 * 86400), ("d", 86400), ("h", 3600), ("min", 60)):
        if seconds >= size:
            return f"{seconds / size:.6g} {unit}"
    return f"{seconds:.6g} s"


def readable_half_life(text: str) -> str:
    """``"4468000000.0 y"`` as ``"4.468e9 y"``, ``"22.2 y"`` as it is (a record's half-life)."""
    number, _, unit = str(text).partition(" ")
    try:
        value = float(number)
    except ValueError:
        return str(text)
    shown = f"{value:.6g}"
    if "e" in shown:
        mantissa, exponent = shown.split("e")
        shown = f"{mantissa}e{int(exponent)}"
    return f"{shown} {unit}".strip()


def table_text(table: dict) -> str:
    """The table as aligned text."""
    out = []
    if "chain" in table:
        out.append(f"chain {' -> '.join(table['chain'])} ({table['activities']})")
        out.append("intensities per 100 decays of the head")
        out.append("")
    for entry in table["nuclides"]:
        modes = ", ".join(
            f"{m['mode']} {100 * m['branching']:.4g} % -> {m['daughter']}" for m in entry["modes"]
        )
        head = f"{entry['nuclide']}  half-life {readable_half_life(entry['half_life'])}  {modes}"
        if "chain" in table:
            head += f"  ({entry['decays_per_head_decay']:.4g} decays per head decay)"
        out.append(head)
        out.append(
            f"  {'type':<11}{'energy (keV)':>14}{'intensity (%)':>15}{'mean (keV)':>12}  note"
        )
        for r in entry["radiations"]:
            mean, note = "", ""
            if "mean_keV" in r:
                mean = f"{r['mean_keV']:.2f}"
                ensdf = r["mean_ensdf_keV"]
                note = r["shape"] + (f"; ENSDF mean {ensdf:g}" if ensdf else "")
                label = f"{_LABEL[r['type']]} (end)"
            else:
                label = _LABEL[r["type"]]
            cells = f"{r['energy_keV']:>14.3f}{r['intensity_percent']:>15.4g}{mean:>12}"
            out.append(f"  {label:<11}{cells}  {note}".rstrip())
        out.append("")
    return "\n".join(out).rstrip() + "\n"


def plot_spectra(
    nuclide: str,
    path: str | Path,
    chain: bool = False,
    until: str | None = None,
    since_deposition_s: float | None = None,
    decays: int = 1_000_000,
    seed: int = 1,
) -> Path:
    """Draw the emitted energy spectra (sampled ``decays``) by radiation type into ``path``."""
    import matplotlib as mpl

    mpl.use("Agg")
    import matplotlib.pyplot as plt

    from ..files import atomic_output

    rng = np.random.default_rng(seed)
    if chain:
        ce = ChainEvents(build_chain(nuclide, until, what="decay"), since_deposition_s, 0.0)
        rows = ce.sample(rng, decays)
        kind, energy = rows["kind"], rows["energy"]
        title = f"{' -> '.join(ce.chain.members)}: {decays:.0e} events"
    else:
        scheme = decay_scheme(nuclide)
        em = scheme.sample(rng, decays)
        kind, energy = em.kind, em.energy
        title = f"{scheme.nuclide}: {decays:.0e} decays"
    groups = {
        "alpha": ("alpha",),
        "recoil ions": ("recoil",),
        "beta-/beta+": ("beta-", "beta+"),
        "gamma": ("gamma",),
        "X-rays": ("X-K", "X-L"),
        "conversion electrons": ("ce-K", "ce-L", "ce-M+"),
        "Auger electrons": ("Auger-K", "Auger-L"),
    }
    e_kev = energy * 1e3
    top = max(float(e_kev.max()) * 1.05, 10.0) if len(e_kev) else 10.0
    bins = np.geomspace(1.0, top, 600)
    fig, ax = plt.subplots(figsize=(9, 5))
    for label, kinds in groups.items():
        sel = np.isin(kind, [KINDS.index(k) for k in kinds])
        if sel.any():
            counts, edges = np.histogram(e_kev[sel], bins=bins)
            ax.stairs(counts / decays, edges, label=label)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("kinetic energy (keV)")
    ax.set_ylabel("particles per decay per bin")
    ax.set_title(title)
    ax.legend(fontsize=8)
    fig.tight_layout()
    path = Path(path)
    with atomic_output(path) as tmp:
        fig.savefig(tmp, format="png", dpi=110)
    plt.close(fig)
    return path
