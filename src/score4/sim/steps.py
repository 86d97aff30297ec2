"""Steps with a deposit in the scored volumes, recorded by a Python stepping action.

Only built when a run asks for steps (``output.steps``) or for activeness
(``targets[].activeness``): every step of every track then calls Python
(benchmarks/bench_steps.py measures the cost). A step counts for the scored volume of its
pre-step point, as Geant4's ``G4PSEnergyDeposit`` counts it, so the steps of an event add up to
the event's ``edep``. Like remage's germanium output: steps without deposit are dropped, the
position is the mid-point of the step (remage's default ``StepPositionMode Average``; a photon's
is its post-step point), the time is the pre-step point's global time.

Heavy ions moved along TRIM trajectories (:mod:`score4.sim.heavy_ions`) deposit outside Geant4:
each piece of a replayed ion's path (between TRIM's points, cut at boundaries) that deposited is
a step at its mid-point, ``particle`` the ion's PDG code, ``time`` the global time the ion
started at (0 for a primary, like every primary vertex here; its creation time for a secondary
taken from Geant4). The replay keeps no time along the path: a heavy ion of a few hundred keV
stops within a picosecond, far below the nanosecond resolution of the table.
"""

from __future__ import annotations

from typing import Any

import numpy as np

#: Step columns: event index in the batch, volume column, PDG code, edep (MeV), time (ns),
#: x, y, z (mm, world).
COLUMNS = ("event", "volume", "particle", "edep", "time", "x", "y", "z")


class StepRecorder:
    """Collects steps; :meth:`take` returns them as arrays and starts again."""

    def __init__(
        self, g4: Any, scoring: dict[str, list], volumes: list[str], current_event
    ) -> None:
        self.g4 = g4
        self.column_of = {
            id(lv): volumes.index(name) for name, lvs in scoring.items() for lv in lvs
        }
        self._keep = [lv for lvs in scoring.values() for lv in lvs]  # ids stay the volumes'
        self.current_event = current_event  # callable: index of the event being tracked
        self.rows: list[tuple] = []
        self.action = self._make_action()

    def _make_action(self) -> Any:
        g4: Any = self.g4
        column_of, rows, current = self.column_of, self.rows, self.current_event
        gamma = g4.G4Gamma.Definition()

        class Steps(g4.G4UserSteppingAction):
            def UserSteppingAction(self, step):
                edep = step.GetTotalEnergyDeposit()
                if edep <= 0.0:
                    return
                pre = step.GetPreStepPoint()
                c = column_of.get(id(pre.GetTouchable().GetVolume().GetLogicalVolume()))
                if c is None:
                    return
                post = step.GetPostStepPoint().GetPosition()
                track = step.GetTrack()
                definition = track.GetDefinition()
                if definition == gamma:
                    x, y, z = post.x, post.y, post.z
                else:
                    p = pre.GetPosition()
                    x, y, z = (p.x + post.x) / 2, (p.y + post.y) / 2, (p.z + post.z) / 2
                rows.append(
                    (current(), c, definition.GetPDGEncoding(), edep, pre.GetGlobalTime(), x, y, z)
                )

        return Steps()

    def add(
        self, event: int, volume: int, pdg: int, edep: float, position, time: float = 0.0
    ) -> None:
        """A deposit made outside Geant4 (a TRIM replay), as one step at global ``time`` (ns)."""
        self.rows.append((event, volume, pdg, edep, float(time), *map(float, position)))

    def take(self) -> dict[str, np.ndarray]:
        rows = self.rows
        data = np.array(rows, dtype=float).reshape(-1, len(COLUMNS))
        rows.clear()
        out = {name: data[:, i] for i, name in enumerate(COLUMNS)}
        for name in ("event", "volume", "particle"):
            out[name] = out[name].astype(np.int64)
        return out


def wants_steps(config) -> bool:
    """True when a run records steps: ``output.steps`` or any ``targets[].activeness``."""
    return bool(config.output.steps or any(t.activeness for t in config.targets))


def active_deposits(steps: dict[str, np.ndarray], activeness: list, edep: np.ndarray) -> np.ndarray:
    """(n_events, n_volumes) active energy (MeV): each step's deposit times the activeness at
    its position; volumes without activeness keep their whole ``edep``."""
    out = np.array(edep, dtype=float, copy=True)
    for c, model in enumerate(activeness):
        if model is None:
            continue
        rows = steps["volume"] == c
        points = np.column_stack([steps["x"][rows], steps["y"][rows], steps["z"][rows]])
        w = model.weights(points)
        out[:, c] = np.bincount(
            steps["event"][rows], weights=steps["edep"][rows] * w, minlength=len(edep)
        )
    return out
