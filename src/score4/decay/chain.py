"""Decay chains: members, branching, Bateman activities, and chain events with coincidences.

A chain is a head nuclide and every nuclide its decays lead to (through every branch in the
data) down to a stable one or to ``until`` (excluded); or an explicit list of members, whose
decays into nuclides outside the list are not followed.

Relative activities
-------------------
* ``secular`` equilibrium: every member decays as often as it is fed, ``A_j = sum_i A_i b_ij``
  with ``A_head = 1``: the chain's cumulative branching.
* ``since_deposition = t``: pure head atoms deposited at time 0, activities at time ``t`` from the
  Bateman equations ``dN/dt = M N`` (:func:`bateman`), solved exactly for the triangular ``M``.

Events and coincidences
-----------------------
Each event is one decay of a member, drawn by its share of the activities, with all its
radiations. A daughter that decays within ``window`` of the event's first decay (Bi-212 ->
Po-212, 0.3 us; Bi-214 -> Po-214, 164 us) joins that event: its delay is drawn from its
lifetime and its radiations are added with their decay ``time`` (s after the first decay). Such
daughters then appear alone only in the share ``A_d - sum_p A_p b_pd (1 - exp(-lambda_d
window))`` of their activity. Every row records the ``nuclide`` (ZAI code ``10000 Z + 10 A +
I``) whose decay emitted it.

Normalisation
-------------
``head_decays_per_event``: the head decays one event stands for (the sum of the event shares
over the head's activity, inverted): ``simulated_decays = n_events * head_decays_per_event``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from ..errors import ConfigError
from .nuclear_data import ZAI, decay_data, nuclide_record
from .scheme import decay_scheme

__all__ = [
    "Chain",
    "ChainEvents",
    "bateman",
    "bateman_coefficients",
    "build_chain",
    "decays_until",
    "fill_empty_events",
    "secular_activities",
]

LN2 = np.log(2.0)


@dataclass(frozen=True)
class Chain:
    """Members in decay order (head first), decay constants (1/s), branching ``b[i, j]``."""

    members: tuple[str, ...]
    decay_constant: np.ndarray
    branching: np.ndarray

    @property
    def head(self) -> str:
        return self.members[0]

    def index(self, name: str) -> int:
        return self.members.index(name)


def build_chain(
    head: str | list[str], until: str | None = None, what: str = "source.decay"
) -> Chain:
    """The chain from ``head`` down to stable nuclides or ``until``, or the listed members.

    Raises
    ------
    ConfigError
        Unknown nuclides, nuclides without decay data, ``until`` not in the chain, a listed
        member that no earlier member feeds.
    """
    nuclides = decay_data()["nuclides"]
    if isinstance(head, list):
        if not head:
            raise ConfigError(f"{what}.chain: give at least one nuclide")
        members = [nuclide_record(n, f"{what}.chain")[0] for n in head]
        if len(set(members)) != len(members):
            raise ConfigError(f"{what}.chain: a nuclide is listed twice: {', '.join(members)}")
        if until is not None:
            raise ConfigError(f"{what}.until: only with a chain head, not with a list of members")
    else:
        start = nuclide_record(head, f"{what}.chain")[0]
        stop = None if until is None else _until_name(until, what)
        if stop == start:
            raise ConfigError(
                f"{what}.until: {stop} is the chain's head; until names the first nuclide "
                f"after the last one wanted (the chain would be empty)"
            )
        members, seen = [], set()
        todo = [start]
        while todo:
            name = todo.pop()
            if name in seen or name == stop:
                continue
            seen.add(name)
            members.append(name)
            todo.extend(p for p in decay_scheme(name).products if p in nuclides)
        if stop is not None and not _reaches(start, stop):
            raise ConfigError(
                f"{what}.until: {stop} is not in the chain of {start} "
                f"(it reaches {', '.join(_order(members, nuclides))} and "
                f"{', '.join(_stable_ends(members))})"
            )
    if not isinstance(head, list):  # a listed chain keeps its order (checked below)
        members = _order(members, nuclides)
    else:
        fed = {members[0]}
        for name in members:
            if name not in fed:
                raise ConfigError(
                    f"{what}.chain: {name} is not a daughter of an earlier member "
                    f"({', '.join(members[: members.index(name)])}); list the chain in decay order"
                )
            fed.update(decay_scheme(name).products)
    lam = np.array([LN2 / decay_scheme(m).half_life_s for m in members])
    b = np.zeros((len(members), len(members)))
    for i, name in enumerate(members):
        for product, share in decay_scheme(name).product_fractions().items():
            if product in members:
                b[i, members.index(product)] += share
    return Chain(tuple(members), lam, b)


def _until_name(until: str, what: str) -> str:
    from .nuclear_data import nuclide_name

    return nuclide_name(until, f"{what}.until")


def _reaches(start: str, stop: str) -> bool:
    nuclides = decay_data()["nuclides"]
    todo, seen = [start], set()
    while todo:
        name = todo.pop()
        if name == stop:
            return True
        if name in seen or name not in nuclides:
            continue
        seen.add(name)
        todo.extend(decay_scheme(name).products)
    return False


def _stable_ends(members: list[str]) -> list[str]:
    nuclides = decay_data()["nuclides"]
    ends = {p for m in members for p in decay_scheme(m).products if p not in nuclides}
    return sorted(ends)


def _order(members: list[str], nuclides: dict) -> list[str]:
    """Decay order: a parent before its daughters (Kahn's topological sort), head first."""
    fed_by = {m: {p for p in members if m in decay_scheme(p).products and p != m} for m in members}
    ordered: list[str] = []
    remaining = list(members)
    while remaining:
        ready = [m for m in remaining if not (fed_by[m] - set(ordered))] or remaining[:1]
        ordered.append(ready[0])
        remaining.remove(ready[0])
    return ordered


def secular_activities(chain: Chain) -> np.ndarray:
    """Activities relative to the head's in secular equilibrium (cumulative branching)."""
    a = np.zeros(len(chain.members))
    a[0] = 1.0
    for j in range(1, len(a)):
        a[j] = float(a[:j] @ chain.branching[:j, j])
    return a


def bateman_coefficients(decay_constant: np.ndarray, branching: np.ndarray) -> np.ndarray:
    """``c`` with ``N_j(t) = sum_k c_jk exp(-lambda_k t)`` for one atom of the first member at 0.

    ``dN_j/dt = -lambda_j N_j + sum_i b_ij lambda_i N_i`` with members in decay order
    (``b`` strictly upper triangular): ``c_jk = sum_i b_ij lambda_i c_ik / (lambda_j -
    lambda_k)`` for ``j > k``, ``c_kk`` fixed by the initial condition (all decay constants
    distinct).
    """
    lam = np.asarray(decay_constant, float)
    b = np.asarray(branching, float)
    n = len(lam)
    c = np.zeros((n, n))
    for k in range(n):
        c[k, k] = (1.0 if k == 0 else 0.0) - float(c[k, :k].sum())
        for j in range(k + 1, n):
            c[j, k] = float(np.sum(b[:j, j] * lam[:j] * c[:j, k])) / (lam[j] - lam[k])
    return c


def bateman(decay_constant: np.ndarray, branching: np.ndarray, t: float) -> np.ndarray:
    """Atoms ``N(t)`` of each member per atom of the first one at ``t = 0`` (none of the others),
    the exact solution of the Bateman equations (:func:`bateman_coefficients`)."""
    c = bateman_coefficients(decay_constant, branching)
    return c @ np.exp(-np.asarray(decay_constant, float) * t)


def decays_until(decay_constant: np.ndarray, branching: np.ndarray, t: float) -> np.ndarray:
    """Decays of each member in ``[0, t]`` per atom of the first one deposited at 0:
    ``lambda_j integral N_j = lambda_j sum_k c_jk (1 - exp(-lambda_k t)) / lambda_k``."""
    lam = np.asarray(decay_constant, float)
    c = bateman_coefficients(lam, branching)
    return lam * (c @ (-np.expm1(-lam * t) / lam))


def chain_activities(chain: Chain, since_deposition: float | None) -> np.ndarray:
    """Activities relative to the head's: secular (``None``) or at ``since_deposition`` (s)."""
    if since_deposition is None:
        return secular_activities(chain)
    atoms = bateman(chain.decay_constant, chain.branching, since_deposition)
    activity = chain.decay_constant * atoms
    if activity[0] <= 0:
        raise ConfigError("source.decay.since_deposition: the head has decayed away by then")
    return activity / activity[0]


@dataclass
class ChainEvents:
    """Samples events of a chain (see the module docstring)."""

    chain: Chain
    since_deposition_s: float | None = None
    window_s: float = 1e-5
    activity: np.ndarray = field(init=False)
    share: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        self.activity = chain_activities(self.chain, self.since_deposition_s)
        merged = np.zeros(len(self.activity))
        for j in range(len(merged)):
            feed = float(self.activity @ self.chain.branching[:, j])
            merged[j] = feed * self._merge_probability(j)
        self.share = np.maximum(self.activity - merged, 0.0)

    def _merge_probability(self, j: int) -> float:
        return float(-np.expm1(-self.chain.decay_constant[j] * self.window_s))

    @cached_property
    def head_decays_per_event(self) -> float:
        """Head decays that one event stands for."""
        return float(self.activity[0] / self.share.sum())

    def sample(self, rng: np.random.Generator, n: int) -> dict[str, np.ndarray]:
        """Rows of ``n`` events: ``event``, ``kind``, ``energy`` (MeV), ``particle`` (names),
        ``nuclide`` (ZAI), ``time`` (s after the event's first decay), ``recoil_of`` (row of
        the alpha a recoil balances, -1 otherwise)."""
        members = self.chain.members
        cdf = np.cumsum(self.share / self.share.sum())
        first = np.minimum(np.searchsorted(cdf, rng.random(n), side="right"), len(cdf) - 1)
        parts: list[dict[str, np.ndarray]] = []
        names: dict[str, int] = {}  # particle names of all members, coded as int16
        queue = []
        for m in range(len(members)):
            events = np.nonzero(first == m)[0]
            queue.append((m, events, np.zeros(len(events))))
        while queue:
            m, events, t0 = queue.pop(0)
            if not len(events):
                continue
            scheme = decay_scheme(members[m])
            em = scheme.sample(rng, len(events))
            codes = np.array([names.setdefault(x, len(names)) for x in em.names], np.int16)
            parts.append(
                {
                    "event": events[em.event],
                    "kind": em.kind,
                    "energy": em.energy,
                    "particle": codes[em.particle],
                    "nuclide": np.full(len(em.event), ZAI(members[m]), np.int64),
                    "time": t0[em.event],
                }
            )
            products = np.asarray(em.products)[em.product]
            for d, name in enumerate(members):
                if self._merge_probability(d) <= 0:
                    continue
                sel = np.nonzero(products == name)[0]
                if not len(sel):
                    continue
                delay = rng.exponential(1.0 / self.chain.decay_constant[d], len(sel))
                t = t0[sel] + delay
                keep = t < self.window_s
                queue.append((d, events[sel[keep]], t[keep]))
        zai = np.array([ZAI(m) for m in members], np.int64)[first]
        return fill_empty_events(parts, n, zai, list(names))

    def histories(
        self, rng: np.random.Generator, n_atoms: int, until_s: float | None = None
    ) -> dict[str, np.ndarray]:
        """Per-atom histories: every decay of ``n_atoms`` deposited head atoms, in order.

        Each atom decays down the chain (lifetimes drawn) until a stable nuclide, a nuclide
        outside the chain, or ``until_s`` seconds after deposition. The branch of each decay is
        the one its sampled radiations took (an alpha decay of Bi-212 leads to Tl-208 and emits
        a Tl-208 recoil, its beta decay to Po-212), so the nuclide an atom becomes and the
        recoil it received agree. Events are numbered atom by atom, in time order; a decay
        within the window of its event's first decay joins that event (as in :meth:`sample`).
        Rows as :meth:`sample`, plus ``atom`` (the deposited atom), ``decay_index`` (0 for
        the atom's first decay, 1 for its daughter's, ...) and ``decay_time`` (s since
        deposition). Whoever moves a decay's vertex (recoil implantation) follows an atom by
        ``atom`` and ``decay_index``: an alpha decay's recoil row is where the atom went.
        """
        members = self.chain.members
        lam = self.chain.decay_constant
        atom = np.arange(n_atoms)
        member = np.zeros(n_atoms, np.int64)
        t = np.zeros(n_atoms)
        # (atoms, member, times, delays, emissions): the delays since the atom's previous decay
        # are kept apart, because a time since deposition of 1e17 s (Th-232) cannot resolve
        # microseconds
        decays: list[tuple[np.ndarray, int, np.ndarray, np.ndarray, object]] = []
        while len(atom):
            delay = rng.exponential(1.0, len(atom)) / lam[member]
            t = t + delay
            keep = t <= until_s if until_s is not None else np.ones(len(atom), bool)
            atom, member, t, delay = atom[keep], member[keep], t[keep], delay[keep]
            nxt = np.full(len(atom), -1, np.int64)
            for m in np.unique(member):
                sel = np.nonzero(member == m)[0]
                em = decay_scheme(members[m]).sample(rng, len(sel))
                decays.append((atom[sel], int(m), t[sel], delay[sel], em))
                to = np.array([members.index(x) if x in members else -1 for x in em.products])
                nxt[sel] = to[em.product] if len(to) else -1
            alive = nxt >= 0
            atom, member, t = atom[alive], nxt[alive], t[alive]
        return self._history_rows(decays)

    def _history_rows(self, decays) -> dict[str, np.ndarray]:
        members = self.chain.members
        if not decays:
            none = np.zeros(0, np.int64)
            per_atom = {"decay_time": np.zeros(0), "atom": none, "decay_index": none}
            return fill_empty_events([], 0, none, [], per_atom)
        d_atom = np.concatenate([d[0] for d in decays])
        d_member = np.concatenate([np.full(len(d[0]), d[1]) for d in decays])
        d_time = np.concatenate([d[2] for d in decays])
        d_delay = np.concatenate([d[3] for d in decays])
        step = np.concatenate([np.full(len(d[0]), i) for i, d in enumerate(decays)])
        order = np.lexsort((step, d_atom))  # an atom's decays in the order they happened
        rank = np.empty(len(order), np.int64)  # position of each decay in that order
        rank[order] = np.arange(len(order))
        d_atom, d_member, d_time, d_delay = (
            d_atom[order],
            d_member[order],
            d_time[order],
            d_delay[order],
        )
        first_of_atom = np.r_[True, d_atom[1:] != d_atom[:-1]]
        start = np.maximum.accumulate(np.where(first_of_atom, np.arange(len(d_atom)), 0))
        d_index = np.arange(len(d_atom)) - start  # 0 for an atom's first decay
        # events: a decay opens a new event unless it falls within the window of the open one
        event = np.zeros(len(d_atom), np.int64)
        since = np.zeros(len(d_atom))  # s after the event's first decay
        current, elapsed = -1, 0.0
        window = self.window_s
        for i, (new_atom, delay) in enumerate(
            zip(first_of_atom.tolist(), d_delay.tolist(), strict=True)
        ):
            if new_atom or elapsed + delay >= window:  # one pass over the decays
                current += 1
                elapsed = 0.0
            else:
                elapsed += delay
            event[i], since[i] = current, elapsed
        parts: list[dict[str, np.ndarray]] = []
        names: dict[str, int] = {}
        offset = 0
        for _, m, _, _, em in decays:
            n_here = len(em.product)
            codes = np.array([names.setdefault(x, len(names)) for x in em.names], np.int16)
            rows_of = rank[offset + em.event]
            offset += n_here
            parts.append(
                {
                    "event": event[rows_of],
                    "decay": rows_of,
                    "kind": em.kind,
                    "energy": em.energy,
                    "particle": codes[em.particle] if len(codes) else em.particle,
                    "nuclide": np.full(len(em.event), ZAI(members[m]), np.int64),
                    "time": since[rows_of],
                    "decay_time": d_time[rows_of],
                    "atom": d_atom[rows_of],
                    "decay_index": d_index[rows_of],
                }
            )
        n_events = int(event[-1]) + 1
        first = np.r_[True, event[1:] != event[:-1]]
        zai = np.array([ZAI(m) for m in members], np.int64)[d_member[first]]
        per_event = {
            "decay": np.flatnonzero(first),
            "decay_time": d_time[first],
            "atom": d_atom[first],
            "decay_index": d_index[first],
        }
        rows = fill_empty_events(parts, n_events, zai, list(names), per_event)
        order = np.lexsort((rows["decay"], rows["event"]))  # stable: by decay, then as made
        return {k: v[order] for k, v in rows.items() if k != "decay"}

    def table(self) -> list[tuple[str, float, float]]:
        """(member, activity relative to the head, share of the events) per member."""
        share = self.share / self.share.sum()
        return [
            (m, float(a), float(s))
            for m, a, s in zip(self.chain.members, self.activity, share, strict=True)
        ]


def fill_empty_events(
    parts: list[dict[str, np.ndarray]],
    n: int,
    zai: np.ndarray,
    names: list[str],
    per_event: dict[str, np.ndarray] | None = None,
) -> dict:
    """Join row parts event-major (``particle`` coded as indices into ``names``, returned as
    names); a decay that emitted nothing (capture in the M shell, the IT of Pa-234m) keeps its
    event with one ``geantino`` of energy 0, so that events and decays stay one to one."""
    names = [*names, "geantino"]
    rows = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]} if parts else {}
    seen = np.zeros(n, bool)
    if rows:
        seen[rows["event"]] = True
    empty = np.nonzero(~seen)[0]
    if len(empty) or not rows:
        filler: dict[str, np.ndarray] = {
            "event": empty,
            "kind": np.full(len(empty), -1, np.int8),
            "energy": np.zeros(len(empty)),
            "particle": np.full(len(empty), len(names) - 1, np.int16),
            "nuclide": zai[empty],
            "time": np.zeros(len(empty)),
            **{k: v[empty] for k, v in (per_event or {}).items()},
        }
        rows = filler if not rows else {k: np.concatenate([rows[k], filler[k]]) for k in rows}
    order = np.argsort(rows["event"].astype(np.int32), kind="stable")
    out = {k: v[order] for k, v in rows.items()}
    out["particle"] = np.asarray(names)[out["particle"]]
    return out
