"""The decay generator against evaluated data and independent references.

References nobody here wrote:

* ENSDF as published (NNDC NuDat 3 decay radiation tables, the evaluations of Nuclear Data
  Sheets: A=210 Basunia 2014, A=214 Wu 2009, A=208 Martin 2007, A=228 Abusaleem 2014,
  A=212 Auranen & McCutchan 2020, A=40 Chen 2017, A=60 Browne & Tuli 2013, A=137 Browne & Tuli
  2007, A=222 Singh 2011, A=226 Singh 2011, A=238 Browne & Tuli 2015);
* radioactivedecay 0.6.1 (Bateman solutions with ICRP-107 data);
* analytic identities (energy balance, exponential delays).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from score4.decay import KINDS, decay_scheme, known_nuclides
from score4.decay.chain import ChainEvents, bateman, build_chain, chain_activities
from score4.decay.spectra import BetaSpectrum
from score4.errors import ConfigError

# (nuclide, radiation, published energy keV, published intensity % per decay, tolerance on the
# intensity (relative), why). Energies: gammas within 0.1 keV (score4 caps a line at its level
# difference); alphas within 2 keV (score4 takes the measured line where it agrees with
# Q - E(level) within 2 sigma, else shares Q - E(level) by two-body kinematics).
PUBLISHED = [
    ("Pb210", "gamma", 46.539, 4.25, 0.01, "ENSDF's measured 4.25(4) %"),
    ("Po210", "alpha", 5304.33, 100.0, 0.01, ""),
    ("Bi214", "gamma", 609.312, 45.49, 0.03, ""),
    ("Bi214", "gamma", 1120.287, 14.91, 0.03, ""),
    ("Bi214", "gamma", 1764.494, 15.31, 0.03, ""),
    ("Pb214", "gamma", 351.932, 35.60, 0.03, ""),
    ("Tl208", "gamma", 2614.511, 99.754, 0.01, ""),
    ("Tl208", "gamma", 583.187, 85.0, 0.03, ""),
    ("Tl208", "gamma", 860.557, 12.50, 0.03, ""),
    ("Ac228", "gamma", 911.204, 25.8, 0.01, ""),
    ("Ac228", "gamma", 968.971, 15.8, 0.01, ""),
    ("Bi212", "gamma", 727.330, 6.67, 0.03, ""),
    ("Bi212", "alpha", 6050.78, 25.13, 0.03, ""),
    ("K40", "gamma", 1460.820, 10.66, 0.01, ""),
    ("Co60", "gamma", 1173.228, 99.85, 0.01, ""),
    ("Co60", "gamma", 1332.492, 99.9826, 0.01, ""),
    ("Cs137", "gamma", 661.657, 85.10, 0.01, "through Ba-137m"),
    ("Rn222", "alpha", 5489.48, 99.92, 0.01, ""),
    ("Ra226", "alpha", 4784.34, 93.84, 0.01, ""),
    ("Po214", "alpha", 7686.82, 99.9895, 0.01, ""),
    ("Po212", "alpha", 8784.86, 100.0, 0.01, ""),
    ("U238", "alpha", 4198.0, 79.0, 0.03, ""),
]


@pytest.mark.parametrize(("nuclide", "kind", "energy", "intensity", "tol", "why"), PUBLISHED)
def test_lines_against_ensdf(nuclide, kind, energy, intensity, tol, why):
    lines = [ln for ln in decay_scheme(nuclide).lines() if ln.kind == kind]
    line = min(lines, key=lambda ln: abs(ln.energy - energy))
    assert abs(line.energy - energy) < (0.1 if kind == "gamma" else 2.0)
    assert 100 * line.intensity == pytest.approx(intensity, rel=tol), why


def test_alpha_recoil_energy_of_po210_matches_the_builtin_emitter():
    """The generic two-body split gives the Po-210 emitter's 103.144 keV recoil."""
    from score4.source.emitters import PO210_ALPHA_ENERGY, PO210_RECOIL_ENERGY

    lines = {ln.kind: ln for ln in decay_scheme("Po210").lines() if ln.intensity > 0.5}
    assert lines["alpha"].energy / 1e3 == pytest.approx(PO210_ALPHA_ENERGY, abs=5e-5)
    assert lines["recoil"].energy / 1e3 == pytest.approx(PO210_RECOIL_ENERGY, abs=2e-6)


def _branches():
    for name in known_nuclides():
        for ln in decay_scheme(name).lines():
            if ln.kind in ("beta-", "beta+") and ln.intensity >= 0.01 and ln.mean_ensdf > 0:
                yield name, ln


# Branches whose mean differs from ENSDF's on purpose (docs/decay.md): Bi-210 follows the measured
# shape factor (ENSDF's mean is the allowed shape's); K-40 is third-forbidden unique (ENSDF's mean
# is a second-forbidden unique shape's); Tl-210's 2413 keV branch has no forbiddenness in ENSDF.
SHAPE_EXCEPTIONS = {("Bi210", 1162), ("K40", 1311), ("Tl210", 2413)}


def test_mean_beta_energies_within_3_percent_of_ensdf():
    checked = 0
    for name, ln in _branches():
        if any(name == n and abs(ln.energy - e) < 2 for n, e in SHAPE_EXCEPTIONS):
            continue
        # AME2020's Q moves the endpoint from ENSDF's (Ra-228: 0.26 keV of 12.7 keV)
        dq = _q_shift(name) / ln.energy
        assert ln.mean == pytest.approx(ln.mean_ensdf, rel=0.03 + dq), (name, ln)
        checked += 1
    assert checked > 60


def test_the_shape_exceptions_are_what_docs_say():
    # Bi-210: ENSDF's 389.0 keV is the allowed shape's; the measured C(W) lowers the mean
    allowed = BetaSpectrum.build(1162.2, 84, 210).mean_kev
    assert allowed == pytest.approx(389.0, rel=0.01)
    measured = next(ln for ln in decay_scheme("Bi210").lines() if ln.kind == "beta-")
    assert measured.mean < 0.85 * allowed
    # K-40: ENSDF's 560.18 keV is the second-forbidden unique shape's, below the third's
    assert BetaSpectrum.build(1310.89, 20, 40, forbiddenness="2UF").mean_kev == pytest.approx(
        560.18, rel=0.005
    )
    k40 = next(ln for ln in decay_scheme("K40").lines() if ln.kind == "beta-")
    assert k40.mean > 570


def test_energy_per_decay_at_most_q_and_alpha_shares_q_minus_level():
    """10^5 decays of every nuclide: emitted energy <= Q (+ a measured alpha line's excess
    over Q - E(level), within 2 sigma of ENSDF's Q and line uncertainties); alpha + recoil is
    one of the branches' values, within that excess of Q - E(level)."""
    rng = np.random.default_rng(18)
    n = 100_000
    for name in known_nuclides():
        scheme = decay_scheme(name)
        em = scheme.sample(rng, n)
        total = em.total_per_event(n) * 1e3
        assert scheme.alpha_excess_kev < 11.0, name
        assert total.max() <= scheme.q_max_kev + scheme.alpha_excess_kev + 1e-6, name
        alpha = em.kind == KINDS.index("alpha")
        if alpha.any():
            two_body = em.total_per_event(n, ("alpha", "recoil"))[em.event[alpha]] * 1e3
            record = scheme.entries
            sums = (record.t_alpha + record.t_recoil)[record.kind == 0] * 1e3
            allowed = np.unique(np.round(sums, 6))
            assert np.isin(np.round(two_body, 6), allowed).all(), name
            # and those are Q minus the fed level energies, up to a measured line's excess
            q = max(m["q_keV"] for m in _modes(name) if m["mode"] == "A")
            fed = scheme.level_energy[record.level[record.kind == 0]]
            diff = sums - (q - fed)
            assert (np.abs(diff) <= 2 * 11.0).all(), name
            assert diff.max() <= scheme.alpha_excess_kev + 1e-6, name


def _q_shift(name):
    from score4.decay.nuclear_data import decay_data

    return max(
        abs(m["q_keV"] - m["q_ensdf_keV"])
        for m in decay_data()["nuclides"][name]["modes"]
        if m.get("q_ensdf_keV") is not None
    )


def _modes(name):
    from score4.decay.nuclear_data import decay_data

    rec = decay_data()["nuclides"][name]
    return [{**m, "q_keV": m["q_keV"] + rec["level_keV"]} for m in rec["modes"]]


@pytest.mark.parametrize("name", ["Pb210", "Bi214", "Ac228", "Th234"])
def test_sampled_intensities_match_the_table(name):
    """Chi-square of sampled line counts against the tabulated intensities (p > 1e-4)."""
    n = 200_000
    _chi2_lines(name, n)
    scheme = decay_scheme(name)
    em = scheme.sample(np.random.default_rng(7), n)
    betas = em.kind == KINDS.index("beta-")
    if betas.any():
        lines = [ln for ln in scheme.lines() if ln.kind == "beta-"]
        mean = sum(ln.mean * ln.intensity for ln in lines) / sum(ln.intensity for ln in lines)
        sampled = em.energy[betas] * 1e3
        assert sampled.mean() == pytest.approx(
            mean, abs=4 * sampled.std() / math.sqrt(len(sampled))
        )


# ------------------------------------------------------------------------------------------
# chains
# ------------------------------------------------------------------------------------------


def _rd_chain(rd, head: str):
    """Members, decay constants and branching of radioactivedecay's own (ICRP-107) chain."""
    members, todo = [], [head]
    while todo:
        n = todo.pop(0)
        if n in members or n == "SF" or rd.Nuclide(n).half_life("s") == float("inf"):
            continue
        members.append(n)
        todo.extend(rd.Nuclide(n).progeny())
    # decay order: a parent before its daughters
    order = []
    while members:
        for m in members:
            if not any(m in rd.Nuclide(p).progeny() for p in members if p != m):
                order.append(m)
                members.remove(m)
                break
    lam = np.array([math.log(2) / rd.Nuclide(m).half_life("s") for m in order])
    b = np.zeros((len(order), len(order)))
    for i, m in enumerate(order):
        for d, f in zip(rd.Nuclide(m).progeny(), rd.Nuclide(m).branching_fractions(), strict=True):
            if d in order:
                b[i, order.index(d)] = f
    return order, lam, b


@pytest.mark.parametrize(
    ("head", "days"), [("Pb-210", [1, 30, 180, 3650]), ("Rn-222", [0.001, 0.1, 1, 10])]
)
def test_bateman_against_radioactivedecay(head, days):
    rd = pytest.importorskip("radioactivedecay")
    members, lam, b = _rd_chain(rd, head)
    for d in days:
        ours = lam * bateman(lam, b, d * 86400.0)
        theirs = rd.Inventory({head: 1.0}, "num").decay(d, "d").activities("Bq")
        for m, a in zip(members, ours, strict=True):
            assert a == pytest.approx(theirs[m], rel=1e-6, abs=1e-12 * ours[0]), (m, d)


def test_chain_activities_from_ensdf_close_to_radioactivedecay():
    """score4's own chain (ENSDF half-lives) against ICRP-107's within 0.5 %."""
    rd = pytest.importorskip("radioactivedecay")
    chain = build_chain("Pb210")
    for d in (30, 180, 1000):
        ours = chain_activities(chain, d * 86400.0)
        theirs = rd.Inventory({"Pb-210": 1.0}, "num").decay(d, "d").activities("Bq")
        head = theirs["Pb-210"]
        for m, a in zip(chain.members, ours, strict=True):
            assert a == pytest.approx(theirs[m[:2] + "-" + m[2:]] / head, rel=5e-3), (m, d)


def test_secular_chain_members_and_branches():
    chain = build_chain("Th232")
    assert chain.members[0] == "Th232"
    assert {"Bi212", "Po212", "Tl208"} <= set(chain.members)
    ce = ChainEvents(chain, None, 0.0)
    share = dict(zip(chain.members, ce.activity, strict=True))
    assert share["Tl208"] == pytest.approx(0.3594, rel=1e-3)
    assert share["Po212"] == pytest.approx(0.6406, rel=1e-3)
    assert ce.head_decays_per_event == pytest.approx(1 / sum(ce.activity))


def test_coincidence_window_merges_fast_daughters():
    n = 100_000
    rng = np.random.default_rng(3)
    # Bi-212 -> Po-212 (0.299 us) with a 10 us window: every Po-212 joins its Bi-212 event
    ce = ChainEvents(build_chain(["Bi212", "Po212"]), None, 1e-5)
    rows = ce.sample(rng, n)
    po = rows["nuclide"] == 842120
    assert ce.share[1] / ce.share.sum() < 1e-9
    delays = rows["time"][po & (rows["kind"] == KINDS.index("alpha"))]
    assert len(delays) == pytest.approx(0.6406 * n, rel=0.02)
    tau = 0.299e-6 / math.log(2)
    assert delays.mean() == pytest.approx(tau, rel=0.03)
    # Bi-214 -> Po-214 (163.6 us): a 10 us window merges 1 - exp(-ln2 10/163.6) = 4.15 %
    ce = ChainEvents(build_chain(["Bi214", "Po214"]), None, 1e-5)
    rows = ce.sample(rng, n)
    first = np.unique(rows["event"][rows["nuclide"] == 832140])
    merged = np.unique(rows["event"][(rows["nuclide"] == 842140) & (rows["time"] > 0)])
    assert len(np.intersect1d(first, merged)) / len(first) == pytest.approx(
        0.99979 * (1 - math.exp(-math.log(2) * 10 / 163.6)), abs=0.004
    )


def test_chain_events_share_the_activities():
    ce = ChainEvents(build_chain("Pb210"), 180 * 86400.0, 1e-5)
    rows = ce.sample(np.random.default_rng(5), 60_000)
    first_rows = np.r_[True, np.diff(rows["event"]) > 0]
    counts = np.array([np.sum(rows["nuclide"][first_rows] == z) for z in (822100, 832100, 842100)])
    expected = 60_000 * ce.share / ce.share.sum()
    assert np.all(np.abs(counts - expected) < 5 * np.sqrt(expected))


@pytest.mark.parametrize(
    ("args", "message"),
    [
        ((["Xx210"], None), "unknown element symbol 'Xx'"),
        ((["Pb206"], None), "no decay data for Pb206"),
        (("Pb210", "Pb207"), "Pb207 is not in the chain of Pb210"),
        ((["Pb210", "Po214"], None), "Po214 is not a daughter of an earlier member"),
        (("U238", "U238"), "U238 is the chain's head"),
    ],
)
def test_bad_chains(args, message):
    with pytest.raises(ConfigError, match=message):
        build_chain(*args)


@pytest.mark.deep
@pytest.mark.parametrize("head", ["U-238", "U-235", "Th-232"])
def test_bateman_whole_chains_against_radioactivedecay(head):
    """Stiff chains (half-lives from 0.3 us to 1e10 y) from 1 d to 1e5 y."""
    rd = pytest.importorskip("radioactivedecay")
    members, lam, b = _rd_chain(rd, head)
    for d in (1, 365, 3650, 1e5 * 365):
        ours = lam * bateman(lam, b, d * 86400.0)
        theirs = rd.Inventory({head: 1.0}, "num").decay(d, "d").activities("Bq")
        for m, a in zip(members, ours, strict=True):
            if theirs[m] > 1e-12 * ours[0]:
                assert a == pytest.approx(theirs[m], rel=1e-3), (m, d)


@pytest.mark.deep
def test_energy_at_most_q_over_a_million_decays_of_every_nuclide():
    rng = np.random.default_rng(1818)
    for name in known_nuclides():
        scheme = decay_scheme(name)
        em = scheme.sample(rng, 1_000_000)
        top = scheme.q_max_kev + scheme.alpha_excess_kev + 1e-6
        assert em.total_per_event(1_000_000).max() * 1e3 <= top, name


@pytest.mark.deep
@pytest.mark.parametrize("name", known_nuclides())
def test_sampled_intensities_of_every_nuclide(name):
    _chi2_lines(name, 1_000_000)


def _chi2_lines(name: str, n: int) -> None:
    from scipy.stats import chi2

    scheme = decay_scheme(name)
    em = scheme.sample(np.random.default_rng(11), n)
    expected, observed = [], []
    # lines of one kind that the energy match below cannot tell apart (U-235: 185.713 keV and
    # the 185.7143 keV line from level feeding) count as one
    merged: list[list] = []
    for ln in scheme.lines():
        if merged and merged[-1][0] == ln.kind and np.isclose(ln.energy, merged[-1][1], atol=5e-4):
            merged[-1][2] += ln.intensity
        else:
            merged.append([ln.kind, ln.energy, ln.intensity])
    for kind, energy, intensity in merged:
        if kind in ("beta-", "beta+") or n * intensity < 30:
            continue
        rows = (em.kind == KINDS.index(kind)) & np.isclose(em.energy * 1e3, energy, atol=5e-4)
        expected.append(n * intensity)
        observed.append(int(rows.sum()))
    if expected:
        e, o = np.array(expected), np.array(observed)
        assert chi2.sf(float(np.sum((o - e) ** 2 / e)), len(e)) > 1e-4, name


def test_atom_histories_decay_as_bateman_says():
    """Per-atom histories (the unit for recoil implantation along a chain): decays per deposited
    atom match the cumulative branching (whole history) and the integrated Bateman activities
    (histories cut at 180 d)."""
    from score4.decay.chain import decays_until

    n = 20_000
    ce = ChainEvents(build_chain("Pb210"), None, 1e-5)
    counts = {}
    for label, until in (("all", None), ("180 d", 180 * 86400.0)):
        rows = ce.histories(np.random.default_rng(9), n, until)
        first = np.r_[True, np.diff(rows["event"]) > 0]
        counts[label] = np.array(
            [np.sum(rows["nuclide"][first] == z) for z in (822100, 832100, 842100)]
        )
        # an atom's events come in time order
        atom, t = rows["atom"][first], rows["decay_time"][first]
        same = atom[1:] == atom[:-1]
        assert (np.diff(atom) >= 0).all()
        assert (t[1:][same] >= t[:-1][same]).all()
    assert (counts["all"] == n).all()
    expected = n * decays_until(ce.chain.decay_constant, ce.chain.branching, 180 * 86400.0)
    assert np.all(np.abs(counts["180 d"] - expected) < 5 * np.sqrt(expected))


def test_atom_histories_merge_fast_daughters():
    ce = ChainEvents(build_chain("Th232"), None, 1e-5)
    rows = ce.histories(np.random.default_rng(4), 5000)
    po212 = rows["nuclide"] == 842120
    # every Po-212 decay (0.3 us) rides in its Bi-212 event, also 1e17 s after deposition
    assert (rows["time"][po212] > 0).all()
    events = np.unique(rows["event"])
    assert len(events) == pytest.approx(5000 * ce.share.sum(), rel=0.01)
