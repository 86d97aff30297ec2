"""Ions into blocks with score4's own transport: the score4 side of ``score4 range``.

Like Geant4's TestEm7 or SRIM's range tables: ions of one energy enter a block of one material
at its entry point, along +z tilted by the incidence angle in the x-z plane. A block is
semi-infinite (10 cm deep and wide) or a layer of a given thickness. The ions go through the
same :class:`~score4.sim.simulation.Simulation` as any run, so alphas are tracked by Geant4 and
heavy ions follow TRIM trajectories, exactly as in a run.

Geant4 keeps one run manager per process, so :func:`simulate_ranges` puts one block per case
side by side in one world (300 mm apart) and runs all cases in one go.
"""

from __future__ import annotations

import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from score4.inputs.config import RunConfig, parse_config

from ..errors import ConfigError
from ..ions.composition import Composition
from ..ions.srim_reference import RangeSample
from ..source.primaries import Primaries
from .runtime import resolve_physics

#: Size of a "semi-infinite" block (mm): far beyond any range score4 is meant for.
SEMI_INFINITE = 100.0
#: Distance between the entry points of neighbouring blocks (mm).
PITCH = 300.0
#: Ions start this far (mm) in front of the entry face, in vacuum.
START_GAP = 1e-7


@dataclass(frozen=True)
class RangeCase:
    """Ions of ``energy_mev`` into ``material`` (``thickness_mm`` None: semi-infinite)."""

    ion: str
    energy_mev: float
    material: str
    thickness_mm: float | None = None
    angle_deg: float = 0.0

    def __post_init__(self) -> None:
        if not self.energy_mev > 0:
            raise ConfigError(f"energy: must be > 0, got {self.energy_mev} MeV")
        if self.thickness_mm is not None and not self.thickness_mm > 0:
            raise ConfigError(f"thickness: must be > 0, got {self.thickness_mm} mm")
        if not 0 <= self.angle_deg < 90:
            raise ConfigError(
                f"angle: must be >= 0 and < 90 degrees from the normal, got {self.angle_deg}"
            )

    @property
    def depth(self) -> float:
        return SEMI_INFINITE if self.thickness_mm is None else float(self.thickness_mm)

    @property
    def direction(self) -> np.ndarray:
        theta = np.radians(self.angle_deg)
        return np.array([np.sin(theta), 0.0, np.cos(theta)])


def _block(k: int) -> str:
    return f"block{k}"


def range_config(
    cases: list[RangeCase],
    physics: str = "auto",
    materials: dict | None = None,
    histories: int | None = None,
    alphas: str = "geant4",
) -> RunConfig:
    """One run configuration holding a block per case; block ``k``'s entry point
    is (k PITCH, 0, 0)."""
    phys: dict = {"mode": physics, "alphas": alphas}
    if histories is not None:
        phys["trim_histories"] = histories
    first = cases[0]
    data: dict = {
        "physics": phys,
        "targets": [
            {
                "name": _block(k),
                "material": case.material,
                "size": [f"{SEMI_INFINITE} mm", f"{SEMI_INFINITE} mm", f"{case.depth!r} mm"],
                "position": [f"{k * PITCH!r} mm", "0 mm", f"{case.depth / 2!r} mm"],
            }
            for k, case in enumerate(cases)
        ],
        "source": {
            "particle": first.ion,
            "energy": f"{first.energy_mev!r} MeV",
            "direction": "normal",
            "surface": {"volume": _block(0), "face": "-z"},
        },
        "run": {"events": 1, "seed": 1},
    }
    if materials:
        data["materials"] = materials
    return parse_config(data, origin="range")


def beams(cases: list[RangeCase], events: int) -> Primaries:
    """``events`` ions per case, each hitting its block's entry point."""
    n = int(events)
    parts = []
    for k, case in enumerate(cases):
        d = case.direction
        start = np.array([k * PITCH, 0.0, 0.0]) - START_GAP * d
        parts.append(
            Primaries(
                event=np.arange(n),
                particle=np.full(n, case.ion),
                energy=np.full(n, float(case.energy_mev)),
                position=np.tile(start, (n, 1)),
                direction=np.tile(d, (n, 1)),
            )
        )
    return Primaries.concatenate(parts)


def simulate_ranges(
    cases: list[RangeCase],
    events: int,
    seed: int,
    materials: dict | None = None,
    physics: str = "auto",
    histories: int | None = None,
    log_path: Path | None = None,
    alphas: str = "geant4",
) -> list[tuple[RangeSample, Composition]]:
    """Run ``events`` ions per case; return per case where they ended and the block's matter."""
    from score4.runner.run_plan import plan_run

    from .simulation import Simulation

    if not cases:
        raise ConfigError("range: no case to run")
    if int(events) < 1:
        raise ConfigError(f"events: must be >= 1, got {events}")
    config = range_config(cases, physics, materials, histories, alphas)
    choice = resolve_physics(config.physics.mode)
    if log_path is None:
        log_path = Path(tempfile.mkdtemp(prefix="score4-range-")) / "geant4.log"
    sim = Simulation(plan_run(config, seed=int(seed), physics=choice), log_path=log_path)
    scores = sim.run(beams(cases, events), int(seed), endpoints=True)
    endpoints = sim.endpoints
    assert endpoints is not None  # asked for above
    out = []
    for k, case in enumerate(cases):
        rows = slice(k * events, (k + 1) * events)
        ends = endpoints[rows]
        position = ends[:, :3] - np.array([k * PITCH, 0.0, 0.0])
        left = ends[:, 3] > 0
        sample = RangeSample(
            final_position=position,
            stopped=~left,
            backscattered=left & (position[:, 2] <= 0),
            transmitted=left & (position[:, 2] >= case.depth),
            exit_energy=np.where(left, ends[:, 3], 0.0),
            deposited=scores["edep"][rows, k].copy(),
        )
        material = sim.geometry.scoring[_block(k)][0].GetMaterial()
        out.append((sample, Composition.from_g4_material(material)))
    return out


def simulate_range(
    ion: str,
    energy_mev: float,
    material: str,
    events: int,
    seed: int,
    thickness_mm: float | None = None,
    angle_deg: float = 0.0,
    materials: dict | None = None,
    physics: str = "auto",
    histories: int | None = None,
    alphas: str = "geant4",
) -> tuple[RangeSample, Composition]:
    """One case of :func:`simulate_ranges`."""
    case = RangeCase(ion, float(energy_mev), material, thickness_mm, float(angle_deg))
    return simulate_ranges([case], events, seed, materials, physics, histories, alphas=alphas)[0]
