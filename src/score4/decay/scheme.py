"""One nuclide's decay, compiled from the evaluated data into arrays and sampled in numpy.

Per decay (:meth:`DecayScheme.sample`):

1. the branch (decay mode and fed daughter level) by its intensity: ENSDF feeding intensities
   times the mode's branching ratio; the modes are renormalised to 1 (``not_simulated``
   keeps what is dropped: spontaneous fission, branches below 1e-5);
2. what the branch emits:

   * **alpha**: the alpha at ENSDF's measured energy and the recoiling daughter (an ion
     primary such as ``"Pb206"``) with the alpha's momentum, back to back (exact relativistic
     kinematics, AME2020 atomic masses minus the electrons); where the line has no uncertainty
     or lies more than 2 sigma from ``Q + E(parent level) - E(daughter level)``, the two share
     that energy by two-body kinematics instead;
   * **beta-** / **beta+**: the electron or positron from the branch's spectrum
     (:mod:`score4.decay.spectra`); the antineutrino/neutrino is not emitted; the beta recoil
     (at most a few tens of eV here) is not emitted either;
   * **electron capture**: a vacancy in the K or L shell by ENSDF's capture fractions (M and
     higher: nothing is emitted); the neutrino is not emitted;

3. the gamma cascade from the fed level down to the ground state (or to a long-lived level that
   is a nuclide of its own, Pa-234m): at each level a transition by its total intensity
   ``I_gamma (1 + alpha)`` (the data set's, or from level feeding: ``tools/make_decay_data.py``);
   an E0 transition is a conversion electron only; any other is a gamma, or a conversion
   electron from the K, L or M+ shell by the BrIcc shell coefficients, with energy
   ``E_gamma - B`` (binding energy of the shell's first subshell: K, L1, M1);
4. each K or L vacancy (conversion or capture) fills by one photon or one electron: a K (L3)
   X-ray line by its relative intensity with probability omega_K (omega_L3), else a KLL
   (L3MM) Auger electron of energy ``B_K - B_L2 - B_L3`` (``B_L3 - B_M4 - B_M5``). The vacancies
   this leaves are not followed (their energy, a few keV at most, is not emitted).

All directions are isotropic and independent (no angular correlations) except the recoil,
opposite to its alpha. Emitted energy per decay is at most Q by construction, plus for alpha
decays the measured line's excess over ``Q - E(level)`` (``alpha_excess_kev``, within 2 sigma).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cache

import numpy as np

from ..elements import split_nuclide
from .nuclear_data import decay_data, nuclide_record
from .spectra import ELECTRON_MASS_KEV, BetaSpectrum, shape_factor

__all__ = ["KINDS", "DecayScheme", "Emissions", "Line", "decay_scheme", "two_body_kinetic"]

#: Radiation kinds of emitted rows (``Emissions.kind`` indexes this).
KINDS = (
    "alpha",
    "recoil",
    "beta-",
    "beta+",
    "gamma",
    "ce-K",
    "ce-L",
    "ce-M+",
    "X-K",
    "X-L",
    "Auger-K",
    "Auger-L",
)
K = {k: i for i, k in enumerate(KINDS)}
BASE_PARTICLES = ("alpha", "e-", "e+", "gamma")
U_MEV = 931.49410242
ALPHA_MASS_MEV = 3727.3794066
ME_MEV = ELECTRON_MASS_KEV / 1e3
GRID = 2048  # points of each tabulated beta spectrum
INVERSE_POINTS = 4096  # points of its inverse CDF, uniform in probability


def two_body_kinetic(total_kinetic: float, m1: float, m2: float) -> tuple[float, float]:
    """Kinetic energies of two bodies from rest sharing ``total_kinetic`` (all in one unit).

    Exact relativistic kinematics: ``T1 = (E^2 + m1^2 - m2^2) / (2 E) - m1`` with
    ``E = m1 + m2 + T``; ``T2 = T - T1``.
    """
    e = m1 + m2 + total_kinetic
    t1 = (e * e + m1 * m1 - m2 * m2) / (2.0 * e) - m1
    return t1, total_kinetic - t1


@dataclass
class Emissions:
    """Sampled radiations of a batch of decays, one row per emitted particle, event-major.

    ``event`` (rows), ``kind`` (index into :data:`KINDS`), ``energy`` (MeV) and ``particle``
    (index into ``names``: Geant4 particle or ion names); per decay: ``product`` (index into
    ``products``: the nuclide the decay leaves, e.g. ``"Bi210"``).
    """

    event: np.ndarray
    kind: np.ndarray
    energy: np.ndarray
    particle: np.ndarray
    names: tuple[str, ...]
    product: np.ndarray
    products: tuple[str, ...]

    def total_per_event(self, n: int, kinds: tuple[str, ...] | None = None) -> np.ndarray:
        """Summed emitted energy (MeV) of each of the ``n`` decays (only ``kinds`` if given)."""
        rows = np.ones(len(self.event), bool)
        if kinds is not None:
            rows = np.isin(self.kind, [K[k] for k in kinds])
        return np.bincount(self.event[rows], weights=self.energy[rows], minlength=n)


@dataclass(frozen=True)
class Line:
    """One line of a decay-radiation table: intensity per decay (0..1), energy in keV.

    ``kind`` is one of :data:`KINDS`; for ``beta-``/``beta+`` ``energy`` is the endpoint and
    ``mean`` the mean energy of the branch (``mean_ensdf`` ENSDF's, when given).
    """

    kind: str
    energy: float
    intensity: float
    mean: float = float("nan")
    mean_ensdf: float = float("nan")
    note: str = ""


@dataclass
class _Entries:
    """The branches (mode x fed level), flat."""

    cdf: np.ndarray  # (e,) cumulative probability
    prob: np.ndarray
    kind: np.ndarray  # 0 alpha, 1 beta-, 2 EC/beta+, 3 IT
    level: np.ndarray  # global level index
    t_alpha: np.ndarray  # MeV
    t_recoil: np.ndarray  # MeV
    ion: np.ndarray  # particle index of the recoil
    spectrum: np.ndarray  # row in the spectra table (-1: none)
    p_plus: np.ndarray  # probability of beta+ (EC/beta+ branches)
    plus_spectrum: np.ndarray
    pk: np.ndarray
    pl: np.ndarray
    atom: np.ndarray  # atom index of the daughter


@dataclass
class DecayScheme:
    """A nuclide's decay compiled into arrays; see the module docstring for the physics."""

    nuclide: str
    half_life_s: float
    not_simulated: float
    q_max_kev: float  # largest Q (+ parent level) over the modes
    alpha_excess_kev: float  # largest measured alpha + recoil above Q - E(level) (within 2 sigma)
    names: tuple[str, ...]
    products: tuple[str, ...]
    entries: _Entries
    spectra: list[BetaSpectrum]
    spectrum_info: list[dict]
    level_energy: np.ndarray  # (L,) keV, global levels
    level_product: np.ndarray  # (L,) product index when the cascade ends there, -1 otherwise
    level_atom: np.ndarray
    trans_key: np.ndarray  # (T,) level + cumulative probability within the level
    trans_from: np.ndarray
    trans_to: np.ndarray
    trans_energy: np.ndarray  # keV
    trans_cum: np.ndarray  # (T, 3): cumulative P(gamma), +P(ce-K), +P(ce-L)
    ce_energy: np.ndarray  # (T, 3): keV of ce-K, ce-L, ce-M+
    trans_origin: np.ndarray  # (T,) 0 the data set's intensity, 1 from level feeding
    assumed_transitions: int
    atoms: list[dict] = field(default_factory=list)
    _inverse: np.ndarray = field(default_factory=lambda: np.zeros((0, INVERSE_POINTS)))

    # ---------------------------------------------------------------------------------------
    # sampling
    # ---------------------------------------------------------------------------------------

    def sample(self, rng: np.random.Generator, n: int) -> Emissions:
        """Sample ``n`` decays; rows grouped by decay (event 0 .. n-1)."""
        out: list[tuple[np.ndarray, np.ndarray | int, np.ndarray, np.ndarray | int]] = []
        ent = self.entries
        e = np.searchsorted(ent.cdf, rng.random(n) * ent.cdf[-1], side="right")
        e = np.minimum(e, len(ent.cdf) - 1)
        idx = np.arange(n)
        kind = ent.kind[e]
        # alpha + recoil
        sel = idx[kind == 0]
        if len(sel):
            es = e[sel]
            out.append((sel, K["alpha"], ent.t_alpha[es], 0))
            out.append((sel, K["recoil"], ent.t_recoil[es], ent.ion[es]))
        # beta-
        sel = idx[kind == 1]
        if len(sel):
            es = e[sel]
            out.append((sel, K["beta-"], self._beta(rng, ent.spectrum[es]), 1))
        # EC / beta+
        vac_k: list[np.ndarray] = [np.zeros(0, np.int64)]
        vac_l: list[np.ndarray] = [np.zeros(0, np.int64)]
        sel = idx[kind == 2]
        if len(sel):
            es = e[sel]
            u = rng.random(len(sel))
            plus = u < ent.p_plus[es]
            if plus.any():
                out.append((sel[plus], K["beta+"], self._beta(rng, ent.plus_spectrum[es[plus]]), 2))
            cap, ec = sel[~plus], es[~plus]
            u = rng.random(len(cap))
            vac_k.append(cap[u < ent.pk[ec]])
            vac_l.append(cap[(u >= ent.pk[ec]) & (u < ent.pk[ec] + ent.pl[ec])])
        # cascade
        level = ent.level[e]
        final = self._cascade(rng, idx, level, out, vac_k, vac_l)
        atom = ent.atom[e]  # every vacancy of a decay is in its daughter's atom
        self._relax(rng, np.concatenate(vac_k), atom, "K", out)
        self._relax(rng, np.concatenate(vac_l), atom, "L", out)
        return self._assemble(out, n, self.level_product[final])

    def _beta(self, rng: np.random.Generator, rows: np.ndarray) -> np.ndarray:
        """Beta kinetic energies (MeV) of spectra ``rows``: tabulated inverse CDFs, interpolated."""
        x = rng.random(len(rows)) * (INVERSE_POINTS - 1)
        i = np.minimum(x.astype(np.int64), INVERSE_POINTS - 2)
        flat = rows * INVERSE_POINTS + i
        lo = self._inverse.ravel()
        return (lo[flat] + (x - i) * (lo[flat + 1] - lo[flat])) / 1e3

    def _cascade(self, rng, idx, level, out, vac_k, vac_l) -> np.ndarray:
        final = level.copy()
        active = idx[self.level_product[level] < 0]
        cur = level[active]
        while len(active):
            t = np.searchsorted(self.trans_key, cur + rng.random(len(active)), side="right")
            t = np.minimum(t, len(self.trans_key) - 1)
            u = rng.random(len(active))
            cum = self.trans_cum[t]
            gamma = u < cum[:, 0]
            ck = ~gamma & (u < cum[:, 1])
            cl = ~gamma & ~ck & (u < cum[:, 2])
            cm = ~(gamma | ck | cl)
            out.append((active[gamma], K["gamma"], self.trans_energy[t[gamma]] / 1e3, 3))
            for shell, sel in enumerate((ck, cl, cm)):
                if sel.any():
                    kind = ("ce-K", "ce-L", "ce-M+")[shell]
                    out.append((active[sel], K[kind], self.ce_energy[t[sel], shell] / 1e3, 1))
            vac_k.append(active[ck])
            vac_l.append(active[cl])
            cur = self.trans_to[t]
            final[active] = cur
            keep = self.level_product[cur] < 0
            active, cur = active[keep], cur[keep]
        return final

    def _relax(self, rng, events: np.ndarray, atom: np.ndarray, shell: str, out) -> None:
        """One X-ray (probability omega) or one Auger electron per vacancy in ``shell``."""
        if not len(events):
            return
        atoms = atom[events]
        for a in np.unique(atoms):
            ev = events[atoms == a]
            info = self.atoms[a][shell]
            u = rng.random(len(ev))
            xray = u < info["omega"]
            if xray.any():
                line = np.searchsorted(info["line_cdf"], rng.random(int(xray.sum())), side="right")
                line = np.minimum(line, len(info["line_energy"]) - 1)
                out.append((ev[xray], K[f"X-{shell}"], info["line_energy"][line] / 1e3, 3))
            if (~xray).any():
                out.append(
                    (
                        ev[~xray],
                        K[f"Auger-{shell}"],
                        np.full(int((~xray).sum()), info["auger"] / 1e3),
                        1,
                    )
                )

    def _assemble(self, out, n: int, product: np.ndarray) -> Emissions:
        parts = [p for p in out if len(p[0])]
        if not parts:
            z = np.zeros(0, np.int64)
            return Emissions(
                z,
                z.astype(np.int8),
                np.zeros(0),
                z.astype(np.int16),
                self.names,
                product,
                self.products,
            )
        ev = np.concatenate([p[0] for p in parts])
        # a stable sort keeps each decay's rows in the order they were made (alpha, recoil,
        # then the cascade); the parts are sorted runs, which the merge sort takes fast
        order = np.argsort(ev.astype(np.int32), kind="stable")
        ev = ev[order]
        kind = np.concatenate([np.full(len(p[0]), p[1], np.int8) for p in parts])[order]
        energy = np.concatenate([p[2] for p in parts])[order]
        particle = np.concatenate(
            [np.broadcast_to(np.asarray(p[3], np.int16), len(p[0])) for p in parts]
        )[order]
        return Emissions(ev, kind, energy, particle, self.names, product, self.products)

    # ---------------------------------------------------------------------------------------
    # the radiation table, computed exactly from the same arrays
    # ---------------------------------------------------------------------------------------

    def lines(self) -> list[Line]:
        """Expected radiations per decay (the decay-radiation table), sorted by kind and energy."""
        ent = self.entries
        flux = np.zeros(len(self.level_energy))
        acc: dict[tuple[str, float], float] = {}
        betas: list[Line] = []
        vac = {"K": np.zeros(len(self.atoms)), "L": np.zeros(len(self.atoms))}

        def add(kind: str, energy: float, p: float) -> None:
            if p > 0:
                key = (kind, round(float(energy), 4))
                acc[key] = acc.get(key, 0.0) + p

        for i, p in enumerate(ent.prob):
            flux[ent.level[i]] += p
            if ent.kind[i] == 0:
                add("alpha", ent.t_alpha[i] * 1e3, p)
                add("recoil", ent.t_recoil[i] * 1e3, p)
            elif ent.kind[i] == 1:
                betas.append(self._beta_line("beta-", ent.spectrum[i], p))
            elif ent.kind[i] == 2:
                if ent.p_plus[i] > 0:
                    betas.append(self._beta_line("beta+", ent.plus_spectrum[i], p * ent.p_plus[i]))
                pe = p * (1 - ent.p_plus[i])
                vac["K"][ent.atom[i]] += pe * ent.pk[i]
                vac["L"][ent.atom[i]] += pe * ent.pl[i]
        starts = np.searchsorted(self.trans_from, np.arange(len(self.level_energy)), side="left")
        stops = np.searchsorted(self.trans_from, np.arange(len(self.level_energy)), side="right")
        for lev in range(len(self.level_energy) - 1, -1, -1):
            if flux[lev] == 0 or self.level_product[lev] >= 0:
                continue
            lo = float(lev)
            for t in range(starts[lev], stops[lev]):
                p = flux[lev] * (self.trans_key[t] - lo)
                lo = self.trans_key[t]
                cum = self.trans_cum[t]
                add("gamma", self.trans_energy[t], p * cum[0])
                add("ce-K", self.ce_energy[t, 0], p * (cum[1] - cum[0]))
                add("ce-L", self.ce_energy[t, 1], p * (cum[2] - cum[1]))
                add("ce-M+", self.ce_energy[t, 2], p * (1.0 - cum[2]))
                atom = self.level_atom[lev]
                vac["K"][atom] += p * (cum[1] - cum[0])
                vac["L"][atom] += p * (cum[2] - cum[1])
                flux[self.trans_to[t]] += p
        for shell in ("K", "L"):
            for a, pv in enumerate(vac[shell]):
                if pv <= 0:
                    continue
                info = self.atoms[a][shell]
                probs = np.diff(np.concatenate([[0.0], info["line_cdf"]]))
                for energy, pl in zip(info["line_energy"], probs, strict=True):
                    add(f"X-{shell}", energy, pv * info["omega"] * pl)
                add(f"Auger-{shell}", info["auger"], pv * (1 - info["omega"]))
        lines = [Line(k, e, p) for (k, e), p in acc.items()] + betas
        return sorted(lines, key=lambda ln: (KINDS.index(ln.kind), ln.energy))

    def product_fractions(self) -> dict[str, float]:
        """Fraction of the decays that leave each product nuclide (exact, through the cascade)."""
        flux = np.zeros(len(self.level_energy))
        np.add.at(flux, self.entries.level, self.entries.prob)
        out = dict.fromkeys(self.products, 0.0)
        starts = np.searchsorted(self.trans_from, np.arange(len(flux)), side="left")
        stops = np.searchsorted(self.trans_from, np.arange(len(flux)), side="right")
        for lev in range(len(flux) - 1, -1, -1):
            if flux[lev] == 0:
                continue
            if self.level_product[lev] >= 0:
                out[self.products[self.level_product[lev]]] += flux[lev]
                continue
            lo = float(lev)
            for t in range(starts[lev], stops[lev]):
                flux[self.trans_to[t]] += flux[lev] * (self.trans_key[t] - lo)
                lo = self.trans_key[t]
        return out

    def _beta_line(self, kind: str, row: int, p: float) -> Line:
        info = self.spectrum_info[row]
        return Line(
            kind,
            info["endpoint"],
            p,
            self.spectra[row].mean_kev,
            float(info["mean_ensdf"]) if info["mean_ensdf"] else float("nan"),
            info["shape"],
        )


# -------------------------------------------------------------------------------------------
# compiling the data
# -------------------------------------------------------------------------------------------


def _atom_tables(symbol: str) -> dict:
    atom = decay_data()["atoms"][symbol]
    b = atom["binding_keV"]
    out = {"binding": b}
    for shell, lines_key, omega, auger in (
        ("K", "K_lines", atom["omega_K"], b["K"] - b["L2"] - b["L3"]),
        ("L", "L3_lines", atom["omega_L3"], b["L3"] - b["M4"] - b["M5"]),
    ):
        lines = atom[lines_key]
        energy = np.array([ln[0] for ln in lines], float)
        weight = np.array([ln[1] for ln in lines], float)
        if not len(energy) or weight.sum() <= 0:
            energy, weight, omega = np.array([0.0]), np.array([1.0]), 0.0
        out[shell] = {
            "omega": float(omega),
            "line_energy": energy,
            "line_cdf": np.cumsum(weight) / weight.sum(),
            "auger": max(float(auger), 0.0),
        }
    return out


def _symbol(name: str) -> str:
    """The element symbol of a nuclide name of the data file (``"Pa234m"`` -> ``"Pa"``)."""
    parts = split_nuclide(name, metastable=True)
    assert parts is not None, name  # the data file's names are normalised
    return parts[0]


@cache
def decay_scheme(name: str) -> DecayScheme:
    """The compiled :class:`DecayScheme` of a nuclide (``"Pb210"``, ``"Pb-210"``, ...), cached."""
    key, rec = nuclide_record(name)
    return _compile(key, rec)


def _compile(key: str, rec: dict) -> DecayScheme:
    modes = rec["modes"]
    total = sum(m["branching"] for m in modes)
    scale = 1.0 / total
    not_simulated = max(0.0, 1.0 - total)  # fission, branches below the data's threshold
    names: list[str] = list(BASE_PARTICLES)
    products: list[str] = []
    atom_names: list[str] = []
    spectra: list[BetaSpectrum] = []
    spectrum_info: list[dict] = []
    ent: dict[str, list] = {k: [] for k in _Entries.__dataclass_fields__ if k != "cdf"}
    lev_e: list[float] = []
    lev_prod: list[int] = []
    lev_atom: list[int] = []
    trans: list[tuple] = []
    assumed = 0
    parent_level = float(rec["level_keV"])
    q_max = 0.0
    excess = 0.0

    def index(lst: list[str], item: str) -> int:
        if item not in lst:
            lst.append(item)
        return lst.index(item)

    for m in modes:
        br = m["branching"] * scale
        q = float(m["q_keV"]) + (parent_level if m["mode"] != "IT" else 0.0)
        q_max = max(q_max, q)
        daughter = m["daughter"]
        if m["mode"] == "IT":  # the isomer's rest: to its ground state, no radiation emitted
            base = len(lev_e)
            lev_e.append(0.0)
            lev_prod.append(index(products, daughter))
            lev_atom.append(0)
            _add_entry(ent, br, 3, base)
            continue
        symbol = _symbol(daughter)
        atom = index(atom_names, symbol)
        binding = decay_data()["atoms"][symbol]["binding_keV"]
        base = len(lev_e)
        levels = m["levels_keV"] or [0.0]  # no level scheme given: the ground state
        stops = {int(k): v for k, v in m["stop_levels"].items()}
        for i, energy in enumerate(levels):
            lev_e.append(energy)
            lev_atom.append(atom)
            if i == 0:
                lev_prod.append(index(products, daughter))
            elif i in stops:
                lev_prod.append(index(products, stops[i]))
            else:
                lev_prod.append(-1)
        by_level: dict[int, list] = {}
        for t in m["transitions"]:
            by_level.setdefault(int(t[0]), []).append(t)
        for i in range(1, len(levels)):
            if i in stops:
                continue
            ts = by_level.get(i)
            if not ts:  # no known de-excitation: straight to the ground state as one gamma
                ts = [[i, 0, levels[i], 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1, 0]]
                assumed += 1
            weights = np.array([t[3] * (1.0 + t[5]) for t in ts])
            if weights.sum() <= 0:
                weights = np.ones(len(ts))
            cum = np.cumsum(weights) / weights.sum()
            # an E0 branch converts like the level's other transitions (K, L, M+ shares)
            ref = [t for t in ts if not t[10] and sum(t[6:9]) > 0]
            e0_shells = np.array(ref[0][6:9], float) if ref else np.array([1.0, 0.0, 0.0])
            for t, c in zip(ts, cum, strict=True):
                # the level difference caps the line energy: the cascade never emits more
                # than the level held (ENSDF's fitted gamma and level energies differ slightly)
                energy = min(t[2], levels[i] - levels[int(t[1])])
                a = t[5]
                shells = np.array(t[6:9], float)
                if t[10]:  # E0: conversion only (no gamma; pairs need more than 1022 keV)
                    shells = e0_shells.copy()
                elif a > 0 and shells.sum() > 0:
                    shells *= a / shells.sum()
                ce = energy - np.array([binding["K"], binding["L1"], binding["M1"]])
                for s in (0, 1):  # a shell bound tighter than the transition converts further out
                    if ce[s] <= 0 and shells[s] > 0:
                        shells[s + 1] += shells[s]
                        shells[s] = 0.0
                p = np.concatenate([[1.0], shells]) / (1.0 + shells.sum())
                if t[10]:
                    p = np.concatenate([[0.0], shells]) / shells.sum()
                trans.append(
                    (
                        base + i,
                        base + int(t[1]),
                        energy,
                        base + i + c,
                        np.cumsum(p)[:3],
                        np.maximum(ce, 0.0),
                        int(t[9]),
                    )
                )
        feeds = m["feeds"]
        if not feeds:  # ENSDF gives no feeding (Po-218 and At-219 beta-): the ground state
            feeds = [{"level": 0, "intensity": 1.0, "pk": 1.0, "pl": 0.0, "ec": 1.0}]
        weight_sum = sum(f["intensity"] for f in feeds)
        for f in feeds:
            p = br * f["intensity"] / weight_sum
            lev = base + f["level"]
            kinetic = q - levels[f["level"]]
            if m["mode"] == "A":
                m_d = m["daughter_mass_u"] * U_MEV - m["daughter_z"] * ME_MEV
                ta, tr = two_body_kinetic(kinetic / 1e3, ALPHA_MASS_MEV, m_d)
                measured = _measured_alpha(f, m, m_d, kinetic)
                if measured is not None:  # the measured line; the recoil takes its momentum
                    ta, tr = measured
                    excess = max(excess, (ta + tr) * 1e3 - kinetic)
                _add_entry(
                    ent, p, 0, lev, t_alpha=ta, t_recoil=tr, ion=index(names, daughter), atom=atom
                )
            elif m["mode"] == "B-":
                if kinetic <= 0:
                    continue
                row = _add_spectrum(
                    spectra,
                    spectrum_info,
                    kinetic,
                    m["daughter_z"],
                    rec["a"],
                    False,
                    f.get("forbiddenness"),
                    key,
                    f.get("mean_keV"),
                )
                _add_entry(ent, p, 1, lev, spectrum=row, atom=atom)
            else:
                ec, bp = float(f.get("ec") or 0.0), float(f.get("beta_plus") or 0.0)
                plus_end = kinetic - 2 * ELECTRON_MASS_KEV
                p_plus = bp / (ec + bp) if ec + bp > 0 and plus_end > 0 else 0.0
                row = -1
                if p_plus > 0:
                    row = _add_spectrum(
                        spectra,
                        spectrum_info,
                        plus_end,
                        m["daughter_z"],
                        rec["a"],
                        True,
                        f.get("forbiddenness"),
                        key,
                        f.get("mean_keV"),
                    )
                _add_entry(
                    ent,
                    p,
                    2,
                    lev,
                    p_plus=p_plus,
                    plus_spectrum=row,
                    pk=f["pk"],
                    pl=f["pl"],
                    atom=atom,
                )
    trans.sort(key=lambda t: (t[0], t[3]))
    entries = _Entries(
        cdf=np.cumsum(ent["prob"]),
        **{k: np.asarray(v) for k, v in ent.items()},
    )
    scheme = DecayScheme(
        nuclide=key,
        half_life_s=float(rec["half_life_s"]),
        not_simulated=not_simulated,
        q_max_kev=q_max,
        alpha_excess_kev=excess,
        names=tuple(names),
        products=tuple(products),
        entries=entries,
        spectra=spectra,
        spectrum_info=spectrum_info,
        level_energy=np.asarray(lev_e, float),
        level_product=np.asarray(lev_prod, np.int64),
        level_atom=np.asarray(lev_atom, np.int64),
        trans_key=np.asarray([t[3] for t in trans], float),
        trans_from=np.asarray([t[0] for t in trans], np.int64),
        trans_to=np.asarray([t[1] for t in trans], np.int64),
        trans_energy=np.asarray([t[2] for t in trans], float),
        trans_cum=np.asarray([t[4] for t in trans], float).reshape(-1, 3),
        ce_energy=np.asarray([t[5] for t in trans], float).reshape(-1, 3),
        trans_origin=np.asarray([t[6] for t in trans], np.int8),
        assumed_transitions=assumed,
        atoms=[_atom_tables(a) for a in atom_names],
    )
    if spectra:
        u = np.linspace(0.0, 1.0, INVERSE_POINTS)
        scheme._inverse = np.array([np.interp(u, sp.cdf, sp.energy_kev) for sp in spectra])
    return scheme


def _measured_alpha(f: dict, m: dict, m_d: float, kinetic: float) -> tuple[float, float] | None:
    """Alpha and recoil energies (MeV) of ENSDF's measured line, if it agrees with ``Q - E``.

    The measured line is taken when it has an uncertainty and alpha + recoil lies within
    2 sigma (the line's and ENSDF's Q uncertainty combined) of ``Q - E(level)``; otherwise
    (weak lines listed without uncertainty, At-219, At-218) two-body kinematics gives it.
    """
    e, de = f.get("alpha_keV"), f.get("d_alpha_keV")
    if not e or not de or float(de) > 0.01 * float(e):
        return None
    ta = float(e) / 1e3
    tr = float(np.sqrt(ta * ta + 2.0 * ta * ALPHA_MASS_MEV + m_d * m_d) - m_d)
    sigma = float(np.hypot(float(de), float(m.get("dq_ensdf_keV") or 0.0)))
    if abs((ta + tr) * 1e3 - kinetic) > 2.0 * sigma:
        return None
    return ta, tr


def _add_entry(ent: dict, prob: float, kind: int, level: int, **kw) -> None:
    defaults = dict(
        t_alpha=0.0,
        t_recoil=0.0,
        ion=0,
        spectrum=-1,
        p_plus=0.0,
        plus_spectrum=-1,
        pk=0.0,
        pl=0.0,
        atom=0,
    )
    defaults.update(kw)
    ent["prob"].append(prob)
    ent["kind"].append(kind)
    ent["level"].append(level)
    for k, v in defaults.items():
        ent[k].append(v)


def _add_spectrum(spectra, info, endpoint, z, a, positron, forbiddenness, parent, mean) -> int:
    spectra.append(
        BetaSpectrum.build(
            endpoint,
            z,
            a,
            positron=positron,
            forbiddenness=forbiddenness,
            parent=parent,
            points=GRID,
        )
    )
    info.append(
        {
            "endpoint": endpoint,
            "mean_ensdf": mean,
            "shape": shape_factor(forbiddenness, parent),
            "forbiddenness": forbiddenness,
        }
    )
    return len(spectra) - 1
