"""Emitters of evaluated radioactive decays (``source.decay``): one nuclide or a chain.

Each event is one decay (a chain event may hold a fast daughter's decay too, see
:mod:`score4.decay.chain`), with a variable number of primaries: alphas with their recoil ions,
betas, conversion and Auger electrons, gammas and X-rays. Every primary row carries the extra
columns ``nuclide`` (ZAI code ``10000 Z + 10 A + I`` of the decaying nuclide) and ``time`` (s
after the event's first decay).

Directions: every particle independently by the source's direction law, except a recoil ion,
which goes opposite to its alpha.

With ``implantation`` (chains only) the unit is a deposited head atom instead of an event:
:meth:`DecayEmitter.emit_rows` gives, for ``n`` vertices, every decay of ``n`` atoms
(:meth:`score4.decay.chain.ChainEvents.histories`), each row at the vertex of its atom
(``DecayRows.vertex``) and with the extra columns ``atom``, ``decay_index`` and
``decay_time``. The simulation then moves each decay after an alpha decay to where the alpha's
recoil stopped (:mod:`score4.sim.implantation`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from score4.decay.nuclear_data import ZAI

from ..decay.chain import ChainEvents, build_chain, fill_empty_events
from ..decay.scheme import KINDS, decay_scheme
from .emitters import DirectionKind, _check_direction, sample_directions

if TYPE_CHECKING:
    from score4.inputs.config import RunUnit

__all__ = ["DecayEmitter", "DecayRows"]

_RECOIL, _ALPHA = KINDS.index("recoil"), KINDS.index("alpha")


@dataclass
class DecayRows:
    """Rows of a batch of decay events (event-major)."""

    event: np.ndarray
    particle: np.ndarray
    energy: np.ndarray
    direction: np.ndarray
    extra: dict[str, np.ndarray]
    #: index of the vertex each row starts at: its atom with implantation, else its event (None)
    vertex: np.ndarray | None = None


class DecayEmitter:
    """Decays of one nuclide (``nuclide``) or of a chain (``chain``: a :class:`ChainEvents`).

    Parameters
    ----------
    nuclide
        Nuclide name (``"Pb210"``, ``"Pb-210"``, ``"210Pb"``); or None with ``chain``.
    chain
        Chain event sampler; or None with ``nuclide``.
    direction
        Direction law of every emitted particle (recoils go opposite their alpha).
    implantation
        Chains only: ``n`` vertices are ``n`` deposited head atoms, each followed down the
        chain (see the module docstring).
    """

    def __init__(
        self,
        nuclide: str | None = None,
        chain: ChainEvents | None = None,
        direction: DirectionKind = "isotropic",
        implantation: bool = False,
    ) -> None:
        if (nuclide is None) == (chain is None):
            raise ValueError("DecayEmitter: give exactly one of nuclide and chain")
        if implantation and chain is None:
            raise ValueError("DecayEmitter: implantation follows the atoms of a chain")
        self.scheme = decay_scheme(nuclide) if nuclide is not None else None
        self.chain = chain
        self.direction = _check_direction(direction)
        self.implantation = implantation

    @classmethod
    def for_chain(
        cls,
        head: str | list[str],
        until: str | None = None,
        since_deposition_s: float | None = None,
        window_s: float = 1e-5,
        direction: DirectionKind = "isotropic",
        implantation: bool = False,
    ) -> DecayEmitter:
        """A chain emitter: secular equilibrium when ``since_deposition_s`` is None;
        ``implantation``: per-atom histories (``since_deposition_s`` must be None)."""
        if implantation and since_deposition_s is not None:
            raise ValueError("DecayEmitter: implantation follows whole histories (secular)")
        return cls(
            chain=ChainEvents(build_chain(head, until), since_deposition_s, window_s),
            direction=direction,
            implantation=implantation,
        )

    @property
    def activity_nuclide(self) -> str:
        """The nuclide a quoted activity refers to: the nuclide, or the chain's head."""
        return self.scheme.nuclide if self.scheme is not None else self.chain.chain.head  # type: ignore[union-attr]

    @property
    def unit(self) -> RunUnit:
        """What one vertex stands for: ``"event"``, or ``"atom"`` with implantation."""
        return "atom" if self.implantation else "event"

    @property
    def decays_per_event(self) -> float:
        """Decays of :attr:`activity_nuclide` that one vertex (an event, or an atom with
        implantation: its head decays once) stands for."""
        if self.chain is None or self.implantation:
            return 1.0
        return self.chain.head_decays_per_event

    def emit_rows(self, rng: np.random.Generator, n: int, normals: np.ndarray | None) -> DecayRows:
        """The primaries of ``n`` decay events (``normals``: (n, 3), if the law needs them)."""
        if self.scheme is not None:
            em = self.scheme.sample(rng, n)
            part = {
                "event": em.event,
                "kind": em.kind,
                "energy": em.energy,
                "particle": em.particle,
                "nuclide": np.full(len(em.event), ZAI(self.scheme.nuclide), np.int64),
                "time": np.zeros(len(em.event)),
            }
            if np.bincount(em.event, minlength=n).all():  # usual: every decay emitted something
                rows = {**part, "particle": np.asarray(em.names)[em.particle]}
            else:
                zai = np.full(n, ZAI(self.scheme.nuclide))
                rows = fill_empty_events([part], n, zai, list(em.names))
        elif self.implantation:
            assert self.chain is not None
            rows = self.chain.histories(rng, n)
        else:
            assert self.chain is not None
            rows = self.chain.sample(rng, n)
        event = rows["event"]
        vertex = rows["atom"] if self.implantation else event
        direction = sample_directions(
            rng, self.direction, len(event), None if normals is None else normals[vertex]
        )
        recoil = np.nonzero(rows["kind"] == _RECOIL)[0]
        if len(recoil):
            if not (rows["kind"][recoil - 1] == _ALPHA).all():
                raise RuntimeError("decay rows: a recoil ion does not follow its alpha")
            direction[recoil] = -direction[recoil - 1]
        extra = {"nuclide": rows["nuclide"], "time": rows["time"]}
        if self.implantation:
            extra.update({k: rows[k] for k in ("atom", "decay_index", "decay_time")})
        return DecayRows(
            event=event,
            particle=rows["particle"],
            energy=rows["energy"],
            direction=direction,
            extra=extra,
            vertex=vertex if self.implantation else None,
        )
