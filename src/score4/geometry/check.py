"""Overlap check of a built geometry with Geant4's own ``CheckOverlaps``.

Every placement directly in the world (targets, rough-layer envelopes) is checked; inside a
rough layer the patch placements are all checked up to ``max_placements`` per layer, beyond
that a seeded random sample of them plus the four corner cells (a 200 x 200 grid has 40 000
copies of a few patch volumes: checking a sample of each variant finds a systematic error
without minutes of point sampling). Geant4 prints the details of each overlap to its log.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class OverlapReport:
    checked: int = 0
    total: int = 0
    overlaps: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return not self.overlaps


def _daughters(lv) -> list:
    return [lv.GetDaughter(i) for i in range(lv.GetNoDaughters())]


def check_placements(world_pv, points: int = 1000, tolerance: float = 0.0, max_placements: int = 500,
                     seed: int = 0) -> OverlapReport:
    """Run ``CheckOverlaps(points, tolerance)`` on the world's daughters and their daughters."""
    report = OverlapReport()
    rng = np.random.default_rng(seed)
    for pv in _daughters(world_pv.GetLogicalVolume()):
        inner = _daughters(pv.GetLogicalVolume())
        report.total += 1 + len(inner)
        chosen = inner
        if len(inner) > max_placements:
            pick = set(rng.choice(len(inner), max_placements, replace=False).tolist())
            pick |= {0, len(inner) - 1}
            chosen = [inner[k] for k in sorted(pick)]
        for d in [pv, *chosen]:
            report.checked += 1
            if d.CheckOverlaps(points, tolerance, False, 1):
                report.overlaps.append(f"{d.GetName()} (copy {d.GetCopyNo()})")
    return report
