"""Generate score4's compact decay-data file from evaluated data packages (run by hand, rarely).

    pip install paceENSDF==0.6.3 xraydb==4.5.8 radioactivedecay==0.6.1
    python tools/make_decay_data.py            # writes src/score4/decay/data/decay_data.json

Sources (docs/decay.md says what each gives and under which licence):

* **ENSDF** decay data sets as JSON from paceENSDF 0.6.3 (A. M. Hurst et al., ENSDF archive of
  September 2023; permissive BSD-style licence, notice kept in ``data/NOTICE``): half-lives, Q
  values, branching ratios, alpha/beta/EC feedings with forbiddenness, levels, gammas with
  their BrIcc conversion coefficients (total and per shell), EC shell fractions.
* **Atomic data** from xraydb 4.5.8 (MIT; Elam, Ravel & Sieber 2002 tables): binding energies,
  fluorescence yields, K and L3 X-ray lines with relative intensities.
* **Atomic masses** (AME2020, Wang et al., Chin. Phys. C 45 030003, 2021) as distributed with
  radioactivedecay 0.6.1; only the masses are taken (its ICRP-107 decay data are free for
  not-for-profit use only and are not shipped).

The script follows the decay chains from the heads below through every branch of at least
``MIN_BRANCH`` and stops at stable nuclides. A daughter level with its own decay data set and a
half-life above ``ISOMER_MIN_S`` (Pa-234m) is a chain member of its own: cascades stop there.
"""

from __future__ import annotations

import argparse
import json
import re
from importlib.metadata import version
from pathlib import Path

HEADS = ("U238", "U235", "Th232", "K40", "Co60", "Cs137")
MIN_BRANCH = 1e-5  # branches below this fraction of a nuclide's decays are not followed
ISOMER_MIN_S = 1e-3
OUT = Path(__file__).resolve().parents[1] / "src/score4/decay/data/decay_data.json"
MODES = {"alphaDecay": "A", "betaMinusDecay": "B-", "electronCaptureBetaPlusDecay": "EC"}
SHELLS = ("K", "L", "M", "N", "O", "P", "Q")


def _load_sets(root: Path) -> dict[tuple[str, float], list[dict]]:
    """Decay data sets by (parent, parent level keV), parent levels with a numeric energy."""
    sets: dict[tuple[str, float], list[dict]] = {}
    for path in sorted((root / "ENSDF_JSON").glob("j_input_*.json")):
        m = re.match(r"j_input_(\w+?)_(\w+?)_\d+_\d+_([\d.]+)(pX)?keV\.json$", path.name)
        if not m:
            continue
        d = json.loads(path.read_text())
        d["_file"] = path.name
        level = float(m.group(3))  # "73.92pX": the level of Pa-234m is 73.92 keV + x (x small)
        sets.setdefault((d["parentID"], round(level, 2)), []).append(d)
    return sets


def _br(d: dict) -> float:
    rec = d["decaySchemeNormalization"][0]["normalizationRecord"][0]
    return float(rec["multiplerBranchingRatio"] or 0.0) if rec["recordExistsBR"] else 1.0


def _conversion(g: dict) -> tuple[float, float, float, float]:
    """Total, K, L and (M + higher) conversion coefficients of a gamma."""
    total = float(g["calculatedTotalInternalConversionCoefficient"] or 0.0)
    shells = g["calculatedAtomicShellConversionCoefficients"][0]
    per = [
        float(shells[f"calculatedInternalConversionCoefficientAtomicShell{s}"] or 0.0)
        for s in SHELLS
    ]
    k, lsh, rest = per[0], per[1], sum(per[2:])
    if total > 0 and k + lsh + rest == 0:  # only the total is known: call it all L
        lsh = total
    return total, k, lsh, rest


def _levels(d: dict, isomers: set[float]) -> tuple[list[float], list[list[float]], list[int], int]:
    """Level energies, transitions [from, to, E, RI, a, aK, aL, aM+], stop levels, guesses."""
    levels = [_energy(lv["levelEnergy"]) for lv in d["levelScheme"]]
    transitions = []
    for i, lv in enumerate(d["levelScheme"]):
        for g in lv.get("gammaDecay") or []:
            j = g["levelIndexFinal"]
            energy = float(g["gammaEnergy"] or 0.0)
            if j is None or j >= i or energy <= 0:
                continue
            a, k, lsh, rest = _conversion(g)
            transitions.append([i, j, energy, float(g["gammaIntensity"] or 0.0), a, k, lsh, rest])
    stops = [i for i, e in enumerate(levels) if i and round(e, 2) in isomers]
    return levels, transitions, stops, 0


def _energy(value: object) -> float:
    """A level energy; "73.92+X" (an offset x not known, small) counts as 73.92."""
    return float(re.match(r"[\d.]+", str(value)).group(0))  # type: ignore[union-attr]


def _alpha_feeds(d: dict) -> list[dict]:
    return [
        {"level": i, "intensity": a["alphaIntensity"], "alpha_keV": a["alphaEnergy"]}
        for i, lv in enumerate(d["levelScheme"])
        for a in lv.get("alphaDecay") or []
        if a.get("alphaIntensity")
    ]


def _beta_feeds(d: dict) -> list[dict]:
    return [
        {
            "level": i,
            "intensity": b["betaMinusIntensity"],
            "endpoint_keV": b["endPointBetaMinusEnergy"],
            "mean_keV": b["averageBetaMinusEnergy"],
            "forbiddenness": b["forbiddennessDegree"],
        }
        for i, lv in enumerate(d["levelScheme"])
        for b in lv.get("betaMinusDecay") or []
        if b.get("betaMinusIntensity")
    ]


def _ec_feeds(d: dict) -> list[dict]:
    feeds = []
    for i, lv in enumerate(d["levelScheme"]):
        for b in lv.get("betaPlusDecay") or []:
            ec, bp = float(b["electronCaptureIntensity"] or 0), float(b["betaPlusIntensity"] or 0)
            total = float(b["totalElectronCaptureBetaPlusIntensity"] or 0) or ec + bp
            if total <= 0:
                continue
            if ec + bp == 0:
                ec = total
            fr = b["calculatedAtomicShellElectronCaptureFractions"][0]
            pk = float(fr["calculatedElectronCaptureFractionAtomicShellK"] or 0)
            pl = float(fr["calculatedElectronCaptureFractionAtomicShellL"] or 0)
            if pk + pl == 0:
                pk = 1.0
            feeds.append(
                {
                    "level": i,
                    "intensity": ec + bp,
                    "ec": ec,
                    "beta_plus": bp,
                    "endpoint_keV": b["endPointBetaPlusEnergy"],
                    "mean_keV": b["averageBetaPlusEnergy"],
                    "pk": pk,
                    "pl": pl,
                    "forbiddenness": b["forbiddennessDegree"],
                }
            )
    return feeds


def _balance_feeds(
    d: dict, feeds: list[dict], levels: list[float], transitions: list[list[float]]
) -> tuple[list[dict], bool]:
    """Feedings from the gamma intensity balance when ENSDF's own do not add up.

    ENSDF gives feedings (per 100 decays: I x NB x BR) and gamma intensities (RI x NR x BR).
    When the feedings of a data set sum to more than 2 % away from 100 x BR (Ac-228: 95.1 %,
    Pa-234, Th-231, Tl-210), each excited level's feeding is taken as its transition intensity
    out minus in, ``sum RI NR (1 + alpha)``, clipped at 0; the ground state gets the rest. The
    branch properties (endpoint, shape, mean) stay those of ENSDF's record where one exists.
    """
    rec = d["decaySchemeNormalization"][0]["normalizationRecord"][0]
    br = float(rec["multiplerBranchingRatio"] or 1.0) if rec["recordExistsBR"] else 1.0
    nb = float(rec["multiplerLeptonIntensity"] or 1.0) if rec["recordExistsNB"] else 1.0
    nr = float(rec["multiplerPhotonIntensity"] or 1.0) if rec["recordExistsNR"] else 1.0
    total = sum(f["intensity"] for f in feeds) * nb * br
    if not feeds or abs(total - 100.0 * br) <= 2.0 * br or not transitions:
        return feeds, False
    net = [0.0] * len(levels)
    for t in transitions:
        ti = t[3] * nr * br * (1.0 + t[4])
        net[int(t[0])] += ti
        net[int(t[1])] -= ti
    by_level = {f["level"]: f for f in feeds}
    template = dict.fromkeys(feeds[0])
    out = []
    for i in range(1, len(levels)):
        if net[i] > 0:
            f = dict(by_level.get(i, {**template, "level": i}))
            f["intensity"] = net[i] / (nb * br)
            out.append(f)
    rest = 100.0 * br - sum(f["intensity"] for f in out) * nb * br
    if rest > 0:
        f = dict(by_level.get(0, {**template, "level": 0}))
        f["intensity"] = rest / (nb * br)
        out.append(f)
    for f in out:
        if "pk" in f and f["pk"] is None:
            f.update(pk=1.0, pl=0.0, ec=f["intensity"], beta_plus=0.0)
    return sorted(out, key=lambda f: f["level"]), True


def _name(symbol_id: str, level: float) -> str:
    return symbol_id + ("m" if level > 0 else "")


def _atom(symbol: str) -> dict:
    import xraydb

    edges = xraydb.xray_edges(symbol)
    kev = {k: v.energy / 1e3 for k, v in edges.items()}
    out: dict = {
        "binding_keV": {
            s: kev.get(s, 0.0) for s in ("K", "L1", "L2", "L3", "M1", "M4", "M5", "N1", "O1")
        },
        "omega_K": edges["K"].fyield if "K" in edges else 0.0,
        "omega_L3": edges["L3"].fyield if "L3" in edges else 0.0,
    }
    for shell in ("K", "L3"):
        lines = xraydb.xray_lines(symbol, shell) if shell in edges else {}
        out[f"{shell}_lines"] = sorted(
            [[round(v.energy / 1e3, 4), round(v.intensity, 6), name] for name, v in lines.items()]
        )
    return out


def build(root: Path) -> dict:
    import radioactivedecay as rd

    sets = _load_sets(root)
    isomer_levels: dict[str, set[float]] = {}
    for (parent, level), group in sets.items():
        hl = group[0]["parentDecay"][0]["halfLife"]
        if level > 0 and hl and (hl[0]["halfLifeConverted"] or 0) > ISOMER_MIN_S:
            isomer_levels.setdefault(parent, set()).add(level)
    nuclides: dict[str, dict] = {}
    todo = [(h, 0.0) for h in HEADS]
    elements: set[str] = set()
    while todo:
        parent, level = todo.pop()
        name = _name(parent, level)
        if name in nuclides:
            continue
        group = sets.get((parent, round(level, 2)))
        if not group:
            raise SystemExit(f"no ENSDF decay data set for {name}")
        pd = group[0]["parentDecay"][0]
        hl = pd["halfLife"][0]
        record: dict = {
            "z": group[0]["parentAtomicNumber"],
            "a": group[0]["parentAtomicMass"],
            "level_keV": level,
            "half_life_s": hl["halfLifeConverted"],
            "half_life": f"{hl['halfLifeBest']} {hl['unitHalfLifeBest']}",
            "mass_u": rd.Nuclide(parent).atomic_mass,
            "modes": [],
        }
        total_br = 0.0
        for d in group:
            br = _br(d)
            total_br += br
            if br < MIN_BRANCH:
                continue
            mode = MODES[d["decayMode"]]
            daughter = d["daughterID"]
            elements.add(re.match(r"[A-Z][a-z]?", daughter).group(0))
            iso = isomer_levels.get(daughter, set())
            levels, transitions, stops, _ = _levels(d, iso)
            feeds = {"A": _alpha_feeds, "B-": _beta_feeds, "EC": _ec_feeds}[mode](d)
            feeds, balanced = _balance_feeds(d, feeds, levels, transitions)
            q = float(d["parentDecay"][0]["valueQ"])  # each mode has its own Q
            record["modes"].append(
                {
                    "mode": mode,
                    "branching": br,
                    "daughter": daughter,
                    "daughter_z": d["daughterAtomicNumber"],
                    "daughter_mass_u": rd.Nuclide(daughter).atomic_mass,
                    "q_keV": q,
                    "dataset": d["_file"],
                    "levels_keV": levels,
                    "stop_levels": {str(s): _name(daughter, levels[s]) for s in stops},
                    "transitions": transitions,
                    "feeds": feeds,
                    "feeds_from_gamma_balance": balanced,
                }
            )
            products = {(daughter, levels[s]) for s in stops if _reachable(s, feeds, transitions)}
            products.add((daughter, 0.0))
            for prod, lvl in products:
                if (prod, round(lvl, 2)) in sets:
                    todo.append((prod, lvl))
        record["not_simulated_fraction"] = max(0.0, 1.0 - total_br)
        if level > 0 and total_br < 1.0 - 1e-9:  # the rest of an isomer's decays: IT
            record["modes"].append(
                {"mode": "IT", "branching": 1.0 - total_br, "daughter": parent, "q_keV": level}
            )
            record["not_simulated_fraction"] = 0.0
            todo.append((parent, 0.0))
        nuclides[name] = record
    return {
        "format": "score4-decay-data",
        "format_version": 1,
        "provenance": {
            "decay": "ENSDF decay data sets (archive of September 2023) as JSON, "
            f"paceENSDF {version('paceENSDF')}",
            "atoms": f"xraydb {version('xraydb')} "
            "(Elam, Ravel, Sieber, Radiat. Phys. Chem. 63 (2002) 121)",
            "masses": "AME2020 atomic masses as distributed with "
            f"radioactivedecay {version('radioactivedecay')}",
            "min_branch": MIN_BRANCH,
        },
        "nuclides": dict(sorted(nuclides.items())),
        "atoms": {e: _atom(e) for e in sorted(elements)},
    }


def _reachable(level: int, feeds: list[dict], transitions: list[list[float]]) -> bool:
    """Whether the cascade can reach ``level`` from a fed level."""
    seen = {f["level"] for f in feeds}
    grow = True
    while grow:
        new = {int(t[1]) for t in transitions if int(t[0]) in seen} - seen
        seen |= new
        grow = bool(new)
    return level in seen


def main() -> None:
    import paceENSDF

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=OUT)
    args = parser.parse_args()
    data = build(Path(paceENSDF.__file__).parent)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(data, separators=(",", ":")) + "\n")
    for name, rec in data["nuclides"].items():
        modes = ", ".join(
            f"{m['mode']} {m['branching']:.4g} -> {m['daughter']}" for m in rec["modes"]
        )
        print(f"{name:8s} {rec['half_life']:>16s}  {modes}")
    print(f"{len(data['nuclides'])} nuclides, {args.out.stat().st_size / 1e3:.0f} kB -> {args.out}")


if __name__ == "__main__":
    main()
