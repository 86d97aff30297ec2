"""The portal's teleporting user actions (geometry: :mod:`score4.geometry.portal`).

Only steps that start in a portal box or a trigger reach Python: those boxes form a region with
a regional stepping action (compared by volume object, never by name); steps anywhere else,
above all in the patches and the targets, stay in C++. The boxes are vacuum, so such a step is a
straight flight of no physical consequence, and the jump undoes it: the particle is moved from
the step's start (position, direction, kinetic energy, times of the pre-step point). Rules:

* a step in a **portal** that started on its boundary moving in (the particle entered from the
  world, the target or anything else): jump to the matching point of the subworld of the cell
  entered (cell from the entry point in face coordinates, clamped to the grid). A step that
  started on the boundary moving out is left alone: the zero step out after a jump back, or a
  particle whose direction multiple scattering turned back on the step that reached the portal;
* a step in a **trigger** that started on its subworld's boundary moving out (the particle left
  the subworld): the face(s) it left through follow from the exit point and direction (a face
  counts when the point lies on it within :data:`EDGE_TOLERANCE` and the direction points out
  through it, so an exit through an edge or corner goes to the diagonal neighbour). Through a
  cell border into a cell of the grid it jumps to that cell's subworld; through the top or bottom
  of the layer or the outer border of the grid, back to the matching point of the portal
  boundary. Moving back in (turned on the boundary) it is left alone: Geant4 steps it back;
* a step in a trigger that started on the trigger's own boundary came from the vacuum world
  beyond ``Lab``: the particle left the native world's volume and is killed.

Momentum, energy and time are those at the boundary; positions land exactly on the boundary (no
nudge, so path lengths match native tiling). A jump is ``track.SetPosition``, the tracking
navigator's ``LocateGlobalPointAndUpdateTouchable`` for the track's touchable and next touchable,
then ``step.InitializeStep(track)``, which gives the next step the material, cuts and sensitive
detector of the volume landed in. Deposits are never lost: the step that reached the portal or
trigger was scored by the sensitive detectors before any user action ran, and the vacuum step is
not scored. A side effect: the step after a jump starts with status ``fUndefined`` instead of
``fGeomBoundary`` (``G4StepPoint.SetStepStatus`` is not bound), so multiple scattering restarts
its step limitation as after an ordinary step (a statistical, not systematic, difference: the
tests compare alpha spectra of both tilings).

Grid position per track. The cell belongs to the track: ``history[track id]`` lists
``(time, cell)`` from each jump (cell ``(layer, i, j)`` or None outside the grid). Primaries
that start in a portal box are started at their subworld point by the generator
(:meth:`Teleporter.map_primaries`) with their cell known; a secondary takes its parent's cell at
its creation time (a parent is always tracked to its end before its secondaries).

Python runs only where a particle crosses a portal: no user action runs for the tracks of an
event (~190 delta electrons per Po-210 event) as long as its cells are unambiguous. Per event and
per (layer, subworld) the teleporter keeps the first cell entered (by a primary's start or a jump):
while every subworld has been entered in at most one cell, a track with no history that leaves
subworld k can only be in that subworld's one cell, whatever its ancestry. Each variant has one
subworld per parity of the cell indices (:func:`score4.geometry.portal.cell_slots`), so a jump
through a cell border or corner never makes an event ambiguous: that takes a particle entering
two cells of one parity (two borders crossed, or the portal entered twice). When a jump
(or the primaries of one event) enters a second cell of some subworld, a Python tracking action is
switched on for the rest of the event (off again when the next event begins): from then on every
new track gets its cell from its parent as above, and a parent with no history can only have
started before the switch, in its subworld's first cell. The cells are the same as with a tracking
action for every track (tests/test_portal.py compares with native tiling). A track that leaves a
subworld with no known cell (impossible by construction) is killed and counted in
:attr:`Teleporter.anomalies`.
"""

from __future__ import annotations

import math
from bisect import bisect_left
from collections.abc import Callable
from typing import Any

import numpy as np

from ..geometry.portal import PortalGeometry, PortalMap

#: An exit point this close (mm) to a second face of a subworld also crosses that face.
EDGE_TOLERANCE = 1e-8

_PORTAL, _TRIGGER = 0, 1


class _Layer:
    """Plain-float copy of one portal layer for the per-step code (no numpy scalars there)."""

    def __init__(self, pmap: PortalMap) -> None:
        layer = pmap.layer
        self.r = [[float(x) for x in row] for row in layer.frame.rotation]
        r = self.r  # R^T row by row, flat: one unpacking per call of local()
        self.rt = tuple(r[m][col] for col in range(3) for m in range(3))
        self.centre = tuple(float(x) for x in layer.frame.centre)
        self.sub = [tuple(float(x) for x in c) for c in pmap.subworld_centres]
        a, eu, ev = pmap.offsets()
        self.a = [tuple(float(x) for x in row) for row in a]
        self.eu = tuple(float(x) for x in eu)
        self.ev = tuple(float(x) for x in ev)
        self.px, self.py = (float(x) for x in layer.patch_size)
        self.hu, self.hv = (float(x) / 2 for x in layer.frame.size)
        self.half = tuple(float(x) for x in pmap.half)
        self.portal_centre = tuple(float(x) for x in pmap.portal_centre)
        lu, lv = layer.frame.size
        self.portal_half = (lu / 2, lv / 2, self.half[2])
        self.nx, self.ny = layer.patch_map.nx, layer.patch_map.ny
        self.slots = pmap.slots.tolist()  # the subworld of each cell, [j][i]

    def local(self, x: float, y: float, z: float, c) -> tuple[float, float, float]:
        """Face-frame components of the world point (x, y, z) relative to ``c``: R^T (p - c)."""
        r00, r10, r20, r01, r11, r21, r02, r12, r22 = self.rt
        dx, dy, dz = x - c[0], y - c[1], z - c[2]
        return (
            r00 * dx + r10 * dy + r20 * dz,
            r01 * dx + r11 * dy + r21 * dz,
            r02 * dx + r12 * dy + r22 * dz,
        )

    def jump(self, i: int, j: int) -> tuple[float, float, float]:
        """T[i, j]: portal point + T = subworld point (same expression as
        PortalMap.translations)."""
        a, eu, ev = self.a[self.slots[j][i]], self.eu, self.ev
        return (
            a[0] - i * eu[0] - j * ev[0],
            a[1] - i * eu[1] - j * ev[1],
            a[2] - i * eu[2] - j * ev[2],
        )

    def cell(self, qu: float, qv: float) -> tuple[int, int]:
        """Cell of a face point, clamped to the grid (entry points lie on the portal boundary)."""
        i = min(max(math.floor((qu + self.hu) / self.px), 0), self.nx - 1)
        j = min(max(math.floor((qv + self.hv) / self.py), 0), self.ny - 1)
        return i, j

    def exit_faces(self, pos, d) -> tuple[int, int, bool] | None:
        """(di, dj, through_top_or_bottom) for a particle at ``pos`` on a subworld's boundary moving
        along ``d`` (face frame, relative to the subworld centre); None if it does not leave.

        A face is crossed when the point lies on it (within EDGE_TOLERANCE) and the direction points
        out through it; two faces at once make a corner crossing. A particle on the boundary moving
        back in (its direction turned by multiple scattering on the boundary step) does not leave.
        """
        out = outward_faces(pos, d, self.half)
        if not any(out):
            return None
        return out[0], out[1], out[2] != 0


def outward_faces(pos, d, half) -> list[int]:
    """Per axis: +1 or -1 where ``pos`` lies on that face of the box of half-lengths ``half``
    (within EDGE_TOLERANCE) and ``d`` points out through it, else 0."""
    (c0, c1, c2), (u0, u1, u2), (h0, h1, h2) = pos, d, half  # written out: per-step code
    return [
        (1 if c0 > 0 else -1) if (h0 - abs(c0) <= EDGE_TOLERANCE and c0 * u0 > 0) else 0,
        (1 if c1 > 0 else -1) if (h1 - abs(c1) <= EDGE_TOLERANCE and c1 * u1 > 0) else 0,
        (1 if c2 > 0 else -1) if (h2 - abs(c2) <= EDGE_TOLERANCE and c2 * u2 > 0) else 0,
    ]


def enters(pos, d, half) -> bool:
    """True if ``pos`` lies inside the box, or on a face of it with ``d`` pointing in through that
    face."""
    (c0, c1, c2), (u0, u1, u2), (h0, h1, h2) = pos, d, half  # written out: per-step code
    if max(abs(c0) - h0, abs(c1) - h1, abs(c2) - h2) < -EDGE_TOLERANCE:
        return True
    return (
        (h0 - abs(c0) <= EDGE_TOLERANCE and c0 * u0 < 0)
        or (h1 - abs(c1) <= EDGE_TOLERANCE and c1 * u1 < 0)
        or (h2 - abs(c2) <= EDGE_TOLERANCE and c2 * u2 < 0)
    )


class Teleporter:
    """State and rules of the portal jumps of one Geant4 application.

    Parameters
    ----------
    g4
        The geant4_pybind module.
    portals
        The placed portal layers (:attr:`score4.geometry.world.BuiltGeometry.portals`).
    """

    def __init__(self, g4, portals: list[PortalGeometry]) -> None:
        self.g4 = g4
        self.maps = [p.map for p in portals]
        self.layers = [_Layer(p.map) for p in portals]
        self.roles: dict = {}
        for n, p in enumerate(portals):
            self.roles[p.portal_pv] = (_PORTAL, n, -1)
            for k, pv in enumerate(p.trigger_pvs):
                self.roles[pv] = (_TRIGGER, n, k)
        self.navigator = (
            g4.G4TransportationManager.GetTransportationManager().GetNavigatorForTracking()
        )
        self.stop_and_kill = g4.G4TrackStatus.fStopAndKill
        self.vector = g4.G4ThreeVector
        self.history: dict[int, tuple[list[float], list]] = {}
        self.primary_cells: list = []
        self.first_row = 0
        self.n_primaries = 0  # of the current event: its primaries are tracks 1 .. n_primaries
        # (layer, subworld) -> first cell entered
        self.first_cell: dict[tuple[int, int], tuple] = {}
        self.tracking = True  # is the tracking action on (see the module docstring)
        # set by make_actions: switches the tracking action on or off
        self.set_tracking: Callable[[bool], None] | None = None
        self._keep_actions: Any = None  # keeps the tracking action alive while it is off
        self.tracked_events = 0  # events that needed the tracking action (for benchmarks)
        self.jumps = 0  # counters, for tests and benchmarks
        self.secondary_jumps = 0
        self.left_lab = 0
        self.anomalies = 0
        # (track id, step number) of the zero step out of the portal that follows a jump back to
        # its boundary: on_step returns at once for it (see on_step)
        self.exit_step: tuple[int, int] | None = None
        self.quick_exits = 0

    # --- primaries ------------------------------------------------------------------------

    def map_primaries(self, positions: np.ndarray) -> np.ndarray:
        """Start positions for the gun: vertices in a portal box moved to their subworld point.

        Also remembers each row's cell, which :meth:`start_track` gives the primary's track.
        """
        positions = np.asarray(positions, float)
        mapped = positions.copy()
        cells: list = [None] * len(positions)
        for n, pmap in enumerate(self.maps):
            moved, inside, i, j = pmap.to_subworld(positions)
            mapped[inside] = moved[inside]
            for row in np.flatnonzero(inside).tolist():
                cells[row] = (n, int(i[row]), int(j[row]))
        self.primary_cells = cells
        return mapped

    def begin_event(self, first_row: int, end_row: int) -> None:
        """A new event whose primaries are rows ``first_row .. end_row - 1``."""
        self.history.clear()
        self.first_cell.clear()
        self.exit_step = None
        self.first_row = first_row
        self.n_primaries = end_row - first_row
        cells = self.primary_cells[first_row:end_row]
        ambiguous = False
        for cell in cells:
            if cell is not None:
                ambiguous = self._enter(cell) or ambiguous
        self._track(ambiguous)

    def _enter(self, cell) -> bool:
        """Note that ``cell`` was entered; True if its subworld had been entered in another cell."""
        n, i, j = cell
        return self.first_cell.setdefault((n, self.layers[n].slots[j][i]), cell) != cell

    def _track(self, on: bool) -> None:
        """Switch the tracking action on or off (no-op if it already is)."""
        if on != self.tracking and self.set_tracking is not None:
            self.set_tracking(on)
            self.tracking = on
            self.tracked_events += on

    def _subworld(self, x: float, y: float, z: float) -> tuple[int, int] | None:
        """(layer, subworld) of the subworld holding the world point (x, y, z), or None."""
        for n, lay in enumerate(self.layers):
            for k, centre in enumerate(lay.sub):
                local = lay.local(x, y, z, centre)
                if max(abs(c) - h for c, h in zip(local, lay.half, strict=False)) <= EDGE_TOLERANCE:
                    return n, k
        return None

    # --- tracks ---------------------------------------------------------------------------

    def start_track(self, track) -> None:
        """Give a new track its cell: a primary from its row, a secondary from its parent.

        Called only while the tracking action is on (see the module docstring).
        """
        parent = track.GetParentID()
        if (
            parent == 0
        ):  # Geant4 numbers an event's primaries 1, 2, ... in the order they were given
            tid = track.GetTrackID()
            row = self.first_row + tid - 1
            cell = self.primary_cells[row] if row < len(self.primary_cells) else None
            if cell is not None:
                self.history[tid] = ([-math.inf], [cell])
            return
        h = self.history.get(parent)
        if h is None:
            # The parent started before the tracking action was switched on and never
            # jumped: it stayed in the first cell of its subworld, or in Lab.
            p = track.GetPosition()
            where = self._subworld(p.x, p.y, p.z)
            cell = None if where is None else self.first_cell.get(where)
        else:
            times, cells = h
            # Born at the time of a jump = born in the step that triggered it: the old cell.
            # A parent that never jumped has one cell: no need to ask for the time.
            cell = (
                cells[0]
                if len(cells) == 1
                else cells[bisect_left(times, track.GetGlobalTime()) - 1]
            )
        if cell is not None:
            self.history[track.GetTrackID()] = ([-math.inf], [cell])

    def _record(self, track_id: int, time: float, cell, before) -> None:
        """Track ``track_id`` jumped at ``time`` from cell ``before`` into ``cell``."""
        h = self.history.get(track_id)
        if h is None:
            self.history[track_id] = ([-math.inf, time], [before, cell])
        else:
            h[0].append(time)
            h[1].append(cell)
        if cell is not None and self._enter(cell) and not self.tracking:
            self._track(True)

    # --- steps ----------------------------------------------------------------------------

    def _move(
        self, step, track, pre, d, time: float, tid: int, x: float, y: float, z: float
    ) -> None:
        """Undo the vacuum step and restart track ``tid`` at (x, y, z) with the pre-step state
        (``d`` and ``time``: the pre-step point's direction and global time, already read)."""
        track.SetMomentumDirection(d)
        track.SetKineticEnergy(pre.GetKineticEnergy())
        track.SetGlobalTime(time)
        track.SetLocalTime(pre.GetLocalTime())
        track.SetProperTime(pre.GetProperTime())
        pos = self.vector(x, y, z)
        track.SetPosition(pos)
        self.navigator.LocateGlobalPointAndUpdateTouchable(pos, d, track.GetTouchable(), False)
        self.navigator.LocateGlobalPointAndUpdateTouchable(pos, d, track.GetNextTouchable(), False)
        step.InitializeStep(track)
        self.jumps += 1
        if tid > self.n_primaries:  # not one of the event's primaries (tracks 1 .. n)
            self.secondary_jumps += 1

    def _kill(self, track) -> None:
        track.SetTrackStatus(self.stop_and_kill)

    def on_step(self, step) -> None:
        """Apply the rules to a step that started in a portal box or a trigger.

        The step that follows a jump back to the portal's boundary (half of all calls) is known
        by its track and step number and returns before asking Geant4 anything else: it starts
        on the boundary moving out, so the rules leave it alone (a track landed in the target
        instead never matches again, as step numbers only grow).
        """
        track = step.GetTrack()
        if self.exit_step is not None:
            exit_step, self.exit_step = self.exit_step, None
            if (track.GetTrackID(), track.GetCurrentStepNumber()) == exit_step:
                self.quick_exits += 1
                return
        # The pre-step point's volume: the track's touchable is the pre-step point's until the
        # next step begins (one binding call less than pre.GetTouchable().GetVolume()).
        role = self.roles.get(track.GetVolume())
        if role is None:
            return
        kind, n, k = role
        pre = step.GetPreStepPoint()
        lay = self.layers[n]
        p = pre.GetPosition()
        x, y, z = p.x, p.y, p.z
        time = pre.GetGlobalTime()
        tid = track.GetTrackID()
        d = pre.GetMomentumDirection()
        dl = lay.local(d.x, d.y, d.z, (0.0, 0.0, 0.0))
        if kind == _PORTAL:
            q = lay.local(x, y, z, lay.portal_centre)
            if not enters(q, dl, lay.portal_half):
                # on the boundary moving out (after a jump back, or turned back):
                # Geant4 takes it out
                return
            i, j = lay.cell(q[0], q[1])
            t = lay.jump(i, j)
            self._move(step, track, pre, d, time, tid, x + t[0], y + t[1], z + t[2])
            self._record(tid, time, (n, i, j), None)
            return
        local = lay.local(x, y, z, lay.sub[k])
        (c0, c1, c2), (h0, h1, h2) = local, lay.half
        if max(abs(c0) - h0, abs(c1) - h1, abs(c2) - h2) > EDGE_TOLERANCE:
            self._kill(track)  # came into the trigger from the world beyond Lab
            self.left_lab += 1
            return
        crossing = lay.exit_faces(local, dl)
        if crossing is None:
            return  # touched the subworld's boundary and turned back: Geant4 steps back in
        h = self.history.get(tid)
        # no history: the track never jumped and started in its subworld's first cell
        cell = h[1][-1] if h is not None else self.first_cell.get((n, k))
        if cell is None or cell[0] != n or lay.slots[cell[2]][cell[1]] != k:
            self._kill(track)
            self.anomalies += 1
            return
        _, i, j = cell
        di, dj, through_z = crossing
        t = lay.jump(i, j)
        x, y, z = x - t[0], y - t[1], z - t[2]  # the matching point of the portal
        i, j = i + di, j + dj
        if through_z or not (0 <= i < lay.nx and 0 <= j < lay.ny):
            self._move(step, track, pre, d, time, tid, x, y, z)
            self._record(tid, time, None, cell)
            self.exit_step = (tid, track.GetCurrentStepNumber() + 1)
        else:
            t = lay.jump(i, j)
            self._move(step, track, pre, d, time, tid, x + t[0], y + t[1], z + t[2])
            self._record(tid, time, (n, i, j), cell)


def make_actions(g4, teleporter: Teleporter, regions: list) -> tuple:
    """(stepping action, tracking action) driving ``teleporter``.

    The stepping action is installed here as the regional action of ``regions`` (the portal
    regions); register the returned tracking action with the run manager. It is Geant4's own
    no-op (no Python per track); the teleporter swaps in the one that gives every new track its
    cell only for the rest of an event whose cells became ambiguous (see the module docstring).
    """
    on_step = teleporter.on_step
    start_track = teleporter.start_track

    # The teleporter's bound methods are the overrides themselves (the binding looks them up by
    # name on the object and calls them with the step or track): no Python frame in between.
    class PortalStepping(g4.G4UserSteppingAction):
        UserSteppingAction = staticmethod(on_step)

    class PortalTracking(g4.G4UserTrackingAction):
        PreUserTrackingAction = staticmethod(start_track)

    stepping = PortalStepping()
    for region in regions:
        region.SetRegionalSteppingAction(stepping)
    tracking = PortalTracking()
    events = g4.G4EventManager.GetEventManager()

    def set_tracking(on: bool) -> None:
        # Off: Geant4's own no-op action, a new one each time (a few bytes that Geant4 never
        # frees: the binding hands a plain C++ object to Geant4 once only). A Python subclass
        # that overrides nothing costs a GIL round trip and an override lookup per track and
        # call: measured, portal/native CPU per Po-210 event (~200 tracks) 1.49 with it, 1.34
        # with the plain C++ action (benchmarks/bench_runloop.py, shared machine).
        events.SetUserAction(tracking if on else g4.G4UserTrackingAction())

    teleporter.set_tracking = set_tracking
    teleporter.tracking = False
    teleporter._keep_actions = tracking
    idle = g4.G4UserTrackingAction()
    return stepping, idle
