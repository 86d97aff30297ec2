"""What ``score4 geometry list`` prints: the volume tree of a run's world (no Geant4 here)."""

from __future__ import annotations

import numpy as np

from score4.shapes.hpge import HPGE_GROUPS

from .scene import Scene


def _target_rows(scene: Scene, faces: bool = False) -> list[dict]:
    rows = []
    for t in scene.targets:
        layers = scene.layers_of(t.name)
        shape = t.shape
        rows.append(
            {
                "target": t.name,
                "faces": list(shape.faces) if shape is not None else [],
                "groups": {k: list(v) for k, v in shape.groups.items()}
                if shape is not None
                else {},
                "volume": t.config.label,
                "gdml_volume": None
                if t.instance is None or scene.model is None
                else scene.model.label(t.instance),
                "solid": t.solid,
                "material": t.material,
                "position_mm": t.translation.tolist(),
                "rough_faces": [
                    {
                        "face": r.config.face_name,
                        "layer": r.name,
                        "into": r.config.into,
                        "cells": int(r.patch_map.variants.size if r.mask is None else r.mask.sum()),
                        "rough_share": r.rough_share,
                        "thickness_um": r.thickness * 1e3,
                    }
                    for r in layers
                ],
            }
        )
        if faces:  # areas of boolean solids' faces are estimated: only when asked
            rows[-1]["face_areas_mm2"] = dict(shape.face_areas) if shape is not None else {}
    return rows


def geometry_rows(scene: Scene, faces: bool = False) -> dict:
    """Plain data: ``volumes`` (GDML world: every physical volume) and ``targets`` (``faces``:
    with their faces' areas)."""
    model = scene.model
    return {
        "world": "generated box"
        if model is None
        else str(scene.config.world.gdml)
        if scene.config is not None
        else model.source,
        "volumes": list(model.rows()) if model is not None else [],
        "truncated": bool(model.truncated) if model is not None else False,
        "targets": _target_rows(scene, faces),
    }


def _fmt_mass(kg: float) -> str:
    if kg == 0:
        return "0"
    if abs(kg) >= 1:
        return f"{kg:.4g} kg"
    if abs(kg) >= 1e-3:
        return f"{kg * 1e3:.4g} g"
    return f"{kg * 1e6:.4g} mg"


def _faces_text(t: dict) -> list[str]:
    """A target's faces with their areas, and its groups (``all`` left out)."""
    if not t["faces"]:
        return ["    faces: not known (a solid score4.shapes does not describe)"]
    areas = t.get("face_areas_mm2", {})
    out = [
        "    faces: "
        + ", ".join(f"{f} ({areas[f]:.5g} mm2)" if f in areas else f for f in t["faces"])
    ]
    groups = {g: f for g, f in t.get("groups", {}).items() if g != "all"}
    if groups:
        out.append("    groups: " + "; ".join(f"{g} = {', '.join(f)}" for g, f in groups.items()))
    return out


def geometry_text(rows: dict, faces: bool = False) -> str:
    """The listing as text: the tree, its overlaps, then the targets (``faces``: with each
    target's faces, their areas and its groups)."""
    out = []
    if rows["volumes"]:
        out.append(f"world {rows['world']}: {len(rows['volumes'])} physical volumes")
        out.append(
            f"  {'volume':<34} {'copy':>4} {'solid':<20} {'material':<26} {'mass':>10} "
            f"{'area mm2':>11}  position mm"
        )
        for r in rows["volumes"]:
            name = "  " * r["depth"] + r["label"]
            pos = ", ".join(f"{round(x, 9) + 0.0:.4g}" for x in r["position_mm"])
            flags = (" reflected" if r["reflected"] else "") + (
                " (in a replica)" if r["replicated"] else ""
            )
            out.append(
                f"  {name:<34} {r['copy']:>4} {r['solid']:<20} {r['material']:<26} "
                f"{_fmt_mass(r['mass_kg']):>10} {r['area_mm2']:>11.5g}  ({pos}){flags}"
            )
        if rows["truncated"]:
            out.append("  ... (more volumes: the listing stops at 200000)")
    else:
        out.append("world: a generated box around the targets")
    out.extend(
        f"overlap: {o['volumes'][0]} and {o['volumes'][1]} by {o['by']} (Geant4 "
        "CheckOverlaps; a run needs --allow-overlaps)"
        for o in rows.get("overlaps", [])
    )
    if not rows["targets"]:
        out.append(
            "targets: none yet; score a volume with targets: [{volume: NAME}] in a run "
            "configuration (NAME as listed above, name[copy] for one copy)"
        )
        return "\n".join(out)
    out.append("targets (scoring columns):")
    for t in rows["targets"]:
        where = f" = {t['gdml_volume']}" if t["gdml_volume"] else ""
        pos = ", ".join(f"{x:.4g}" for x in np.round(t["position_mm"], 9))
        out.append(f"  {t['target']}{where}: {t['solid']}, {t['material']}, at ({pos}) mm")
        if faces:
            out.extend(_faces_text(t))
        named = [g for g in HPGE_GROUPS if g in t.get("groups", {})]
        if named:  # a detector whose metadata name its surfaces
            out.append(
                "    surfaces (metadata): "
                + "; ".join(f"{g} {', '.join(t['groups'][g])}" for g in named)
            )
        out.extend(
            f"    rough face {f['face']}: {f['cells']} patches, {100 * f['rough_share']:.4g} % "
            f"of the face rough, layer {f['thickness_um']:.4g} um"
            + (" inside the volume (into)" if f["into"] else " on the face")
            for f in t["rough_faces"]
        )
    return "\n".join(out)
