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
    if total == 0:  # only the shells are known: the total is their sum
        total = k + lsh + rest
    return total, k, lsh, rest


def _norm(d: dict) -> tuple[float, float, float, float]:
    """ENSDF's normalisation: NR (photons), its relative uncertainty, NB (feedings), BR."""
    rec = d["decaySchemeNormalization"][0]["normalizationRecord"][0]
    br = float(rec["multiplerBranchingRatio"] or 1.0) if rec["recordExistsBR"] else 1.0
    nb = float(rec["multiplerLeptonIntensity"] or 1.0) if rec["recordExistsNB"] else 1.0
    nr = float(rec["multiplerPhotonIntensity"] or 1.0) if rec["recordExistsNR"] else 1.0
    dnr = float(rec["dMultiplerPhotonIntensity"] or 0.0) if rec["recordExistsNR"] else 0.0
    return nr, dnr / nr, nb, br


# where a transition's intensity comes from (column 9 of a transition)
FROM_DATA, FROM_FEEDING = 0, 1


def _levels(d: dict, isomers: set[float]) -> tuple[list[float], list[list[float]], list[int]]:
    """Level energies, transitions and stop levels of a data set, intensities as evaluated.

    A transition is ``[from, to, E, I, dI, a, aK, aL, aM+, origin, e0, I_data]`` with
    ``I = RI x NR`` the gamma intensity per 100 decays of the mode (ENSDF's per 100 decays of
    the parent is that times BR), ``dI`` its uncertainty (RI's and NR's), ``origin``
    FROM_DATA and ``e0`` 1 for an E0 transition (no gamma: ``I`` is then its conversion
    intensity); ``I_data`` keeps the data set's ``RI x NR`` (0 where it gives none) when
    :func:`_balance` fills ``I``. Transitions the data set gives no usable intensity (RI blank:
    E0 branches, gammas seen only in coincidence; or ``RI NR (1 + a)`` above 110 per 100
    decays, which cannot be a gamma
    intensity: Ra-228's 12.75 keV) get theirs in :func:`_balance`.
    """
    nr, dnr, _, _ = _norm(d)
    levels = [_energy(lv["levelEnergy"]) for lv in d["levelScheme"]]
    transitions = []
    for i, lv in enumerate(d["levelScheme"]):
        for g in lv.get("gammaDecay") or []:
            j = g["levelIndexFinal"]
            energy = float(g["gammaEnergy"] or 0.0)
            if j is None or j >= i or energy <= 0:
                continue
            a, k, lsh, rest = _conversion(g)
            ri, dri = float(g["gammaIntensity"] or 0.0), float(g["dGammaIntensity"] or 0.0)
            e0 = str(g["multipolarity"] or "").strip("()[]") == "E0"
            if e0:
                a = k = lsh = rest = 0.0
            if ri * nr * (1.0 + a) > 110.0:
                ri = dri = 0.0
            di = ri * nr * ((dri / ri) ** 2 + dnr**2) ** 0.5 if ri > 0 else 0.0
            transitions.append(
                [i, j, energy, ri * nr, di, a, k, lsh, rest, FROM_DATA, int(e0), ri * nr]
            )
    stops = [i for i, e in enumerate(levels) if i and round(e, 2) in isomers]
    return levels, transitions, stops


def _balance(
    d: dict,
    feeds: list[dict],
    levels: list[float],
    transitions: list[list[float]],
    stops: list[int],
) -> tuple[list[dict], list[list[float]], float]:
    """Feedings, transition intensities and their scale that make one consistent cascade.

    The data set's gamma intensities ``I (1 + a)`` (its RI records) are kept as they are; the
    level feedings and the transitions the data set gives no intensity (E0 branches, unobserved
    gammas) are what adjusts. Level by level from the top, with ``in`` the transition intensity
    into a level, ``out`` the known intensity out of it and ``f`` ENSDF's feeding:

    * a fed level without any transition in the data set de-excites straight to the ground
      state by one gamma of its energy (origin FROM_FEEDING; U-235's 331 keV level of Th-231);
    * a level with transitions without intensity passes ``f + in - out`` (if positive) through
      them, shared equally (origin FROM_FEEDING: U-234's 810 keV E0 branch in Pa-234m decay,
      the 43.5 and 99.9 keV transitions below it, which the data set gives no RI);
    * a level with only known transitions out is fed ``out - in`` (ENSDF's feedings are
      themselves such balances; they differ within their uncertainties, mostly: the alpha
      feedings of U-235, Th-227, Pa-231 and Ac-227, measured directly, differ more, because
      the balance of their highly converted low-energy transitions does not close; the gamma
      lines are kept and the alpha intensities follow, docs/decay.md);
    * where ``in`` exceeds ``out`` and the level has no transitions without intensity, the
      filled (FROM_FEEDING) transitions into it are lowered first, with the feeding of the
      level they leave (Ra-228: the 12.75 keV transition into the 20.19 keV level, whose one
      known line, 13.52 keV, is measured at 1.6(8) %); what remains goes straight to the
      ground state as one gamma of the level's energy (origin FROM_FEEDING: a line the data
      set does not list, e.g. Ac-228's 968.3 keV level receives 2.1 % by the 674.75 keV line,
      which ENSDF places twice, and emits 0.20 % by its two lines);
    * the ground state gets the rest up to 100 per 100 decays of the mode; where the rest is
      negative (the data set's transition intensities to the ground state, with what the rules
      above add, exceed 100), every feeding is scaled down to make 100 and the mode's
      ``intensity_scale`` says by how much: every line of the mode comes out that much below
      the data set (Pa-234, Tl-210, Fr-223 beta-, U-235; docs/decay.md).

    Feedings come out per 100 decays of the mode (``intensity``) with ENSDF's own
    (``intensity_ensdf`` = I x NB).
    """
    _, _, nb, _ = _norm(d)
    if not levels:  # no level scheme (Po-218 and At-219 beta-): the ground state
        return feeds, transitions, 1.0
    ensdf = {f["level"]: f["intensity"] * nb for f in feeds}
    template = dict.fromkeys(feeds[0]) if feeds else {"intensity": 0.0}
    by_from: dict[int, list[list[float]]] = {}
    by_to: dict[int, list[list[float]]] = {}
    for t in transitions:
        by_from.setdefault(int(t[0]), []).append(t)
        by_to.setdefault(int(t[1]), []).append(t)
    feed = [0.0] * len(levels)

    def total(t: list[float]) -> float:
        return t[3] * (1.0 + t[5])

    for i in range(len(levels) - 1, 0, -1):
        into = sum(total(t) for t in by_to.get(i, []))
        ts = by_from.get(i, [])
        known = [t for t in ts if t[9] == FROM_DATA and t[3] > 0]
        unknown = [t for t in ts if t not in known]
        out = sum(total(t) for t in known)
        if i in stops or not ts:
            feed[i] = ensdf.get(i, 0.0)
            if not ts and i not in stops and feed[i] + into > 0:  # no known de-excitation
                extra = [i, 0, levels[i], feed[i] + into, 0, 0, 0, 0, 0, FROM_FEEDING, 0, 0]
                transitions.append(extra)
                by_from.setdefault(i, []).append(extra)
                by_to.setdefault(0, []).append(extra)
            continue
        if unknown:
            feed[i] = ensdf.get(i, 0.0)
            rest = feed[i] + into - out
            if rest < 0:  # the known lines carry more than ENSDF's feeding: feed the level more
                feed[i] -= rest
                rest = 0.0
            for t in unknown:
                t[3] = rest / len(unknown) / (1.0 + t[5])
                t[9] = FROM_FEEDING
            continue
        if into > out:
            for t in by_to.get(i, []):
                if t[9] != FROM_FEEDING or into <= out:
                    continue
                src = int(t[0])
                cut = min(total(t), into - out, feed[src])
                t[3] -= cut / (1.0 + t[5])
                feed[src] -= cut
                into -= cut
        if into > out:  # what still arrives unaccounted for goes to the ground state
            extra = [i, 0, levels[i], into - out, 0, 0, 0, 0, 0, FROM_FEEDING, 0, 0]
            transitions.append(extra)
            by_from.setdefault(i, []).append(extra)
            by_to.setdefault(0, []).append(extra)
            out = into
        feed[i] = out - into
    feed[0] = 100.0 - sum(feed[1:])
    scale = 1.0
    if feed[0] < 0:
        scale = 100.0 / sum(feed[1:])
        feed = [0.0] + [f * scale for f in feed[1:]]
        # the transitions keep the data set's intensities: a level's branching ratios do not
        # change, and its flux scales with the feedings
    by_level = {f["level"]: f for f in feeds}
    out_feeds = []
    for i, f in enumerate(feed):
        if f <= 1e-12:
            continue
        rec = dict(by_level.get(i, {**template, "level": i}))
        rec["intensity"] = f
        rec["intensity_ensdf"] = ensdf.get(i, 0.0)
        if "pk" in rec and rec["pk"] is None:
            rec.update(pk=1.0, pl=0.0, ec=f, beta_plus=0.0)
        out_feeds.append(rec)
    return out_feeds, transitions, scale


def _energy(value: object) -> float:
    """A level energy; "73.92+X" (an offset x not known, small) counts as 73.92."""
    return float(re.match(r"[\d.]+", str(value)).group(0))  # type: ignore[union-attr]


def _alpha_feeds(d: dict) -> list[dict]:
    return [
        {
            "level": i,
            "intensity": a["alphaIntensity"],
            "alpha_keV": a["alphaEnergy"],
            "d_alpha_keV": a.get("dAlphaEnergy"),
        }
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
        found = sets.get((parent, round(level, 2)))
        if not found:
            raise SystemExit(f"no ENSDF decay data set for {name}")
        pd = found[0]["parentDecay"][0]
        hl = pd["halfLife"][0]
        record: dict = {
            "z": found[0]["parentAtomicNumber"],
            "a": found[0]["parentAtomicMass"],
            "level_keV": level,
            "half_life_s": hl["halfLifeConverted"],
            "half_life": f"{hl['halfLifeBest']} {hl['unitHalfLifeBest']}",
            "mass_u": rd.Nuclide(parent).atomic_mass,
            "modes": [],
        }
        total_br = 0.0
        for d in found:
            br = _br(d)
            total_br += br
            if br < MIN_BRANCH:
                continue
            mode = MODES[d["decayMode"]]
            daughter = d["daughterID"]
            symbol = re.match(r"[A-Z][a-z]?", daughter)
            assert symbol is not None, daughter
            elements.add(symbol.group(0))
            iso = isomer_levels.get(daughter, set())
            levels, transitions, stops = _levels(d, iso)
            feeds = {"A": _alpha_feeds, "B-": _beta_feeds, "EC": _ec_feeds}[mode](d)
            feeds, transitions, scale = _balance(d, feeds, levels, transitions, stops)
            q_ensdf = float(d["parentDecay"][0]["valueQ"])  # each mode has its own Q
            dq_ensdf = float(d["parentDecay"][0]["dValueQ"] or 0.0)
            q = _q_ame(parent, daughter, mode)
            record["modes"].append(
                {
                    "mode": mode,
                    "branching": br,
                    "daughter": daughter,
                    "daughter_z": d["daughterAtomicNumber"],
                    "daughter_mass_u": rd.Nuclide(daughter).atomic_mass,
                    "q_keV": round(q, 2),
                    "q_source": "AME2020",
                    "q_ensdf_keV": q_ensdf,
                    "dq_ensdf_keV": dq_ensdf,
                    "dataset": d["_file"],
                    "levels_keV": levels,
                    "stop_levels": {str(s): _name(daughter, levels[s]) for s in stops},
                    "transitions": transitions,
                    "feeds": feeds,
                    "intensity_scale": scale,
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
        "format_version": 2,
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


def _q_ame(parent: str, daughter: str, mode: str) -> float:
    """Q of a ground-state decay (keV) from the AME2020 atomic masses."""
    import radioactivedecay as rd

    u_kev = 931494.10242
    dm = rd.Nuclide(parent).atomic_mass - rd.Nuclide(daughter).atomic_mass
    if mode == "A":
        dm -= rd.Nuclide("He4").atomic_mass
    return dm * u_kev


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
