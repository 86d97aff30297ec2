"""Overlap check of a built geometry with Geant4's own ``CheckOverlaps``.

Every placement of the world's tree (targets, rough-layer envelopes, the volumes of a GDML
world at any depth, each logical volume's daughters once) is checked; inside a rough layer the patch
placements are all checked up to ``max_placements`` per layer. Beyond that, Geant4's check is too
slow to be useful: it tests each point against every sister volume, and a 200 x 200 grid has 40 000
sisters (20 placements x 100 points took 5 min). Large layers get the exact equivalent instead
(:func:`patches_fit_their_cells`, run on every layer, since the patches sit one level down in their
cell boxes): every patch body lies inside its own cell column, so no two patches can overlap and
none can leave the envelope. In the nested layout (:func:`score4.geometry.tiling.place_nested`) the
envelope holds group boxes that hold the cell boxes; the groups tile the envelope and the cells
their group by construction (tests/test_tiling_nested.py checks every cell's position through the
volume tree), so the same exact check covers every cell; ``exact`` counts the cells. Geant4 prints
the details of each overlap to its log.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class OverlapReport:
    checked: int = 0  # placements Geant4 checked
    exact: int = 0  # patch placements covered by the exact cell-containment check
    total: int = 0
    overlaps: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return not self.overlaps


def _daughters(lv) -> list:
    return [lv.GetDaughter(i) for i in range(lv.GetNoDaughters())]


def patches_fit_their_cells(layer, tolerance: float = 0.0) -> list[str]:
    """Variants of a rough layer whose closed body leaves its cell column (exact, from the
    meshes)."""
    px, py = layer.patch_size
    lo = np.array([-px / 2, -py / 2, -layer.base_thickness]) - tolerance
    hi = np.array([px / 2, py / 2, layer.thickness - layer.base_thickness]) + tolerance
    bad = []
    for name, surface in zip(layer.names, layer.variants, strict=True):
        v = surface.top_mesh.vertices  # the body adds only walls and a bottom inside the same box
        if (v < lo).any() or (v > hi).any():
            bad.append(
                f"{layer.name}: variant {name!r} reaches outside its {px * 1e3:g} x {py * 1e3:g} "
                "um cell"
            )
    return bad


def check_placements(
    world_pv, points: int = 1000, tolerance: float = 0.0, max_placements: int = 500, layers=()
) -> OverlapReport:
    """``CheckOverlaps(points, tolerance)`` on every placement of the world's tree.

    A daughter holding more than ``max_placements`` placements (a large rough layer, one of
    ``layers`` by name) has its patches checked with :func:`patches_fit_their_cells` instead.
    """
    report = OverlapReport()
    by_name = {layer.name: layer for layer in layers}
    seen: dict[int, object] = {}  # logical volumes visited (a shared one once)

    def check(pv) -> None:
        report.checked += 1
        if pv.CheckOverlaps(points, tolerance, False, 1):
            report.overlaps.append(f"{pv.GetName()} (copy {pv.GetCopyNo()})")

    def visit(lv) -> None:
        for pv in _daughters(lv):
            report.total += 1
            check(pv)
            child = pv.GetLogicalVolume()
            inner = _daughters(child)
            layer = by_name.get(str(pv.GetName()))
            if layer is not None and hasattr(layer, "ring_layout"):
                # a curved layer: its rings or patches by Geant4 (no cell boxes to prove it)
                if len(inner) > max_placements:
                    report.total += len(inner)
                    report.overlaps.append(
                        f"{pv.GetName()}: {len(inner)} bent patches not checked (more than "
                        f"{max_placements})"
                    )
                elif id(child) not in seen:
                    seen[id(child)] = child
                    visit(child)
            elif layer is not None:  # the patches inside their cell boxes: exact, any grid size
                report.total += len(inner)
                if len(inner) <= max_placements:
                    for d in inner:
                        check(d)
                report.exact += layer.patch_map.n_cells
                report.total += layer.patch_map.n_cells - len(inner)  # nested: groups hold cells
                report.overlaps += patches_fit_their_cells(layer, tolerance)
            elif len(inner) > max_placements:
                report.total += len(inner)
                report.overlaps.append(
                    f"{pv.GetName()}: {len(inner)} placements not checked (more than "
                    f"{max_placements})"
                )
            elif id(child) not in seen:  # a GDML world: volumes at any depth
                seen[id(child)] = child
                visit(child)

    visit(world_pv.GetLogicalVolume())
    return report
