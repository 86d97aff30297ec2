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

import itertools
import re
from dataclasses import dataclass, field

import numpy as np


@dataclass
class OverlapReport:
    checked: int = 0  # placements Geant4 checked
    exact: int = 0  # patch placements covered by the exact cell-containment check
    total: int = 0
    overlaps: list[str] = field(default_factory=list)
    curved: int = 0  # cells of curved layers covered by the exact tiling check
    sampled: int = 0  # of the placements Geant4 checked, those in sampled neighbourhoods
    # solids Geant4 cannot put points on (thin boolean cells), left to the exact tiling check
    no_points: list[str] = field(default_factory=list)
    # Geant4's reports between two G4TessellatedSolids that the exact re-test finds false
    # (:func:`retest_report`): not overlaps, listed as such
    false_reports: list[str] = field(default_factory=list)

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


#: Geant4's boolean solids (their points on the surface are drawn by rejection).
BOOLEANS = ("G4IntersectionSolid", "G4UnionSolid", "G4SubtractionSolid")

#: Neighbourhoods Geant4 checks in a crowded volume of a curved layer: the placements nearest
#: to each of the first, middle and last one (by their solids' centres), this many each.
SAMPLE_NEIGHBOURS = 9


def _centres(pvs: list) -> np.ndarray:
    """Centres (the mother's frame) of the bounding boxes of placed volumes."""
    import geant4_pybind as g4

    local: dict[str, object] = {}
    out = np.empty((len(pvs), 3))
    for n, pv in enumerate(pvs):
        lv = pv.GetLogicalVolume()
        key = str(lv.GetName())
        if key not in local:
            lo, hi = g4.G4ThreeVector(), g4.G4ThreeVector()
            lv.GetSolid().BoundingLimits(lo, hi)
            local[key] = (lo + hi) * 0.5
        c = g4.G4ThreeVector(local[key])
        c.transform(pv.GetObjectRotationValue())
        c += pv.GetObjectTranslation()
        out[n] = (c.x, c.y, c.z)
    return out


def sample_neighbourhoods(pvs: list, per_seed: int = SAMPLE_NEIGHBOURS) -> list[int]:
    """Indices of the placements nearest (bounding-box centres) to the first, middle and last
    of ``pvs``: each one with its neighbours in every direction (on a curved layer, the cells
    beside it in its ring, across the phi seam, and in the rings on either side)."""
    centres = _centres(pvs)
    chosen: set[int] = set()
    for seed in sorted({0, len(pvs) // 2, len(pvs) - 1}):
        d = np.linalg.norm(centres - centres[seed], axis=1)
        chosen.update(int(i) for i in np.argsort(d, kind="stable")[:per_seed])
    return sorted(chosen)


def check_placements(
    world_pv,
    points: int = 1000,
    tolerance: float = 0.0,
    max_placements: int = 500,
    layers=(),
    progress=None,
    read_log=None,
) -> OverlapReport:
    """``CheckOverlaps(points, tolerance)`` on every placement of the world's tree.

    A daughter holding more than ``max_placements`` placements (a large rough layer, one of
    ``layers`` by name) has its patches checked with :func:`patches_fit_their_cells` instead.
    A curved layer's cells are checked exactly by :func:`curved_cells_tile` (numpy); Geant4
    checks each distinct logical volume inside it once, and in a volume crowded with more than
    ``max_placements`` daughters (a ring of cells, a cone's envelope) the placements of a few
    neighbourhoods (:func:`sample_neighbourhoods`), placed again at the same transforms in a
    copy of that volume holding only them (Geant4 tests every point against every sister: the
    full volume's 80 000 cells would make it quadratic). All cells of a ring are the same
    logical volume turned about the axis, so a neighbourhood stands for the ring.
    ``progress``: called with a line of text per curved layer. ``read_log``: returns Geant4's
    output since its last call; with it, a placement of a G4TessellatedSolid is checked against
    every sister (not only up to its first report), and each report of a point of it inside a
    sister G4TessellatedSolid is re-tested exactly (:func:`retest_report`): reports that are
    false go to ``false_reports``, and the placement overlaps only if another report stands.
    """
    import geant4_pybind as g4

    report = OverlapReport()
    by_name = {layer.name: layer for layer in layers}
    # a curved layer's further envelope pieces (:func:`score4.geometry.curved.place_curved`):
    # their cells were tiled with the first piece's; Geant4 samples their volumes as its
    pieces = {
        f"{layer.name}_env{n}": layer
        for layer in layers
        for n in range(1, len(getattr(layer, "pieces", None) or ()))
    }
    seen: dict[int, object] = {}  # logical volumes visited (a shared one once)
    scratch: list = []  # the sampled copies (kept alive until the checks are done)

    def check(pv) -> None:
        report.checked += 1
        solid = pv.GetLogicalVolume().GetSolid()
        retest = read_log is not None and str(solid.GetEntityType()) == TESSELLATED
        if retest:
            read_log()  # what Geant4 wrote before this check
        if not pv.CheckOverlaps(points, tolerance, False, ALL_REPORTS if retest else 1):
            return
        if retest:
            stands, false = retest_reports(pv, read_log(), tolerance, facets)
            report.false_reports.extend(false)
            if not stands:
                return
        report.overlaps.append(f"{pv.GetName()} (copy {pv.GetCopyNo()})")

    facets: dict[str, np.ndarray] = {}  # each tessellated solid's triangles, by name

    pointable: dict[str, bool] = {}

    def has_points(pv) -> bool:
        """Geant4 can put points on the solid's surface (a boolean cell a few um wide on a
        40 mm ring, one column of spikes, is 1/25 000 of its constituents' surface: Geant4's
        100 000 tries fail and it returns points elsewhere, reported as centimetre overlaps)."""
        solid = pv.GetLogicalVolume().GetSolid()
        key = str(solid.GetName())
        if key not in pointable:
            ok = True
            if str(solid.GetEntityType()) in BOOLEANS:
                # as Geant4 draws them: a point on a constituent (by area) kept when on the
                # solid's surface; fewer than 1 in 1000 kept and its 100 000 tries can fail
                parts = [solid.GetConstituentSolid(i) for i in (0, 1)]
                area = np.array([p.GetSurfaceArea() for p in parts])
                rng = np.random.default_rng(0)
                picks = rng.choice(2, size=20_000, p=area / area.sum())
                kept = sum(
                    solid.Inside(parts[int(i)].GetPointOnSurface()) == g4.EInside.kSurface
                    for i in picks
                )
                ok = kept >= 20
            pointable[key] = ok
            if not ok:
                report.no_points.append(key)
        return pointable[key]

    def visit_curved(lv, visited: dict[int, int], depth: int = 0) -> None:
        """Inside a curved layer: crowded volumes by sampled neighbourhoods, copies of one
        volume by the first, its neighbour and the last; below, at each depth the first and
        the last distinct logical volume (the first and last rings: each ring of a cone has its
        own, and Geant4's points on a thin boolean cell cost it ~1 s per placement)."""
        inner = _daughters(lv)
        shared = len({id(pv.GetLogicalVolume()) for pv in inner}) == 1
        if len(inner) > max_placements:
            picked = [inner[i] for i in sample_neighbourhoods(inner)]
        elif shared and len(inner) > 3:  # copies of one volume turned about the axis
            picked = [inner[0], inner[1], inner[-1]]
        else:
            picked = inner
        if len(picked) < len(inner):
            copy = g4.G4LogicalVolume(lv.GetSolid(), lv.GetMaterial(), f"{lv.GetName()}_sample")
            scratch.append(copy)
            for pv in picked:
                if not has_points(pv):
                    continue
                placed = g4.G4PVPlacement(
                    g4.G4Transform3D(pv.GetObjectRotationValue(), pv.GetObjectTranslation()),
                    pv.GetLogicalVolume(),
                    str(pv.GetName()),
                    copy,
                    False,
                    pv.GetCopyNo(),
                    False,
                )
                scratch.append(placed)
                check(placed)
                report.sampled += 1
        else:
            for pv in picked:
                if has_points(pv):
                    check(pv)
        report.total += len(inner)
        distinct: dict[int, object] = {}
        for pv in inner:
            distinct.setdefault(id(pv.GetLogicalVolume()), pv.GetLogicalVolume())
        children = list(distinct.items())
        for key, child in [*children[:1], *children[1:][-1:]]:
            if key in seen or visited.get(depth, 0) >= 2:
                continue
            seen[key] = child
            visited[depth] = visited.get(depth, 0) + 1
            visit_curved(child, visited, depth + 1)

    def sample_envelope(child) -> str:
        """Geant4's sampled check of a curved layer's envelope (or a further piece of it), once
        per logical volume; what it checked, for the progress line."""
        before, sampled = report.checked, report.sampled
        if id(child) not in seen:
            seen[id(child)] = child
            visit_curved(child, {})
        return f"Geant4 checked {report.checked - before} placements" + (
            f" ({report.sampled - sampled} of them in sampled neighbourhoods)"
            if report.sampled > sampled
            else ""
        )

    def visit(lv) -> None:
        for pv in _daughters(lv):
            report.total += 1
            check(pv)
            child = pv.GetLogicalVolume()
            inner = _daughters(child)
            layer = by_name.get(str(pv.GetName()))
            if str(pv.GetName()) in pieces:
                checked = sample_envelope(child)
                if progress is not None:
                    progress(
                        f"{pv.GetName()}: a further piece of {pieces[str(pv.GetName())].name}'s "
                        f"envelope; {checked}"
                    )
            elif layer is not None and hasattr(layer, "ring_layout"):
                # a curved layer: its cells exactly in numpy, its volumes by Geant4 (sampled)
                n_cells, problems = curved_cells_tile(layer, tolerance)
                report.curved += n_cells
                report.overlaps += problems
                checked = sample_envelope(child)
                if progress is not None:
                    progress(
                        f"{layer.name}: {n_cells} cells tile the envelope exactly"
                        + ("" if not problems else f" except {len(problems)} problem(s)")
                        + f"; {checked}"
                    )
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


#: Geant4's type name of the tessellated solids whose overlap reports are re-tested.
TESSELLATED = "G4TessellatedSolid"

#: ``maxErr`` of ``CheckOverlaps`` for a tessellated placement: every sister reported, so a real
#: overlap is not hidden behind a false report on an earlier sister.
ALL_REPORTS = 1_000_000

_SISTER = re.compile(
    r"Overlap is detected for volume (\S+):(-?\d+) \((\w+)\) with (\S+):(-?\d+) \((\w+)\)\s*\n"
    r"\s*overlap at local point \(([^)]*)\) by ([-+\d.eE]+) (\w+)"
)
_HELD = re.compile(
    r"Overlap is detected for volume (\S+):(-?\d+) \((\w+)\)\s*\n"
    r"\s*apparently fully encapsulating volume (\S+):(-?\d+) \((\w+)\)"
)
_MOTHER = "Overlap with mother volume"


def retest_reports(pv, text: str, tolerance: float, facets: dict) -> tuple[bool, list[str]]:
    """Geant4's reports for placement ``pv`` in ``text`` (its output of one ``CheckOverlaps``):
    (whether a report stands, the false ones as lines). A report of a point inside a sister
    G4TessellatedSolid, or of holding one whole, when both solids are tessellated, is re-tested
    exactly (:func:`retest_report`, :func:`retest_encapsulation`); every other report (the
    mother, a sister of another type) stands, and so does the check when no report is read."""
    sisters = list(_SISTER.finditer(text))
    held = list(_HELD.finditer(text))
    stands = _MOTHER in text or not (sisters or held)
    false: list[str] = []
    mother = pv.GetMotherLogical()
    daughters = {
        (str(d.GetName()), d.GetCopyNo()): d
        for d in (mother.GetDaughter(i) for i in range(mother.GetNoDaughters()))
    }
    this = f"{pv.GetName()} (copy {pv.GetCopyNo()})"
    for m in sisters:
        name, copy, kind = m.group(4), int(m.group(5)), m.group(6)
        sister = daughters.get((name, copy))
        if kind != TESSELLATED or m.group(3) != TESSELLATED or sister is None:
            stands = True
            continue
        point = np.array([float(x) for x in m.group(7).split(",")])
        found_out = retest_report(pv, sister, point, tolerance, facets)
        if found_out is None:
            stands = True
            continue
        outside, rounding = found_out
        where = (
            f"point lies {outside * 1e6:.3g} nm outside (+-{rounding * 1e6:.2g} nm, the printed "
            "point's rounding)"
            if outside > rounding
            else f"no point of its surface within {rounding * 1e6:.2g} nm of the printed point "
            "(its rounding) lies inside"
        )
        false.append(
            f"{this} with {name} (copy {copy}), reported by {m.group(8)} {m.group(9)}: Geant4's "
            f"tessellated Inside is not exact here: {where}"
        )
    for m in held:
        name, copy, kind = m.group(4), int(m.group(5)), m.group(6)
        sister = daughters.get((name, copy))
        out = None
        if kind == TESSELLATED and m.group(3) == TESSELLATED and sister is not None:
            out = retest_encapsulation(pv, sister, facets)
        if out is None:
            stands = True
            continue
        false.append(
            f"{this} said to hold {name} (copy {copy}) whole: Geant4's tessellated Inside is "
            f"not exact here: a corner of it lies {out * 1e6:.3g} nm outside"
        )
    return stands, false


def _triangles(solid, facets: dict) -> np.ndarray:
    """(n, 3, 3) corners of a G4TessellatedSolid's facets, as Geant4 holds them (cached)."""
    key = str(solid.GetName())
    if key not in facets:
        out = np.empty((solid.GetNumberOfFacets(), 3, 3))
        for i in range(len(out)):
            facet = solid.GetFacet(i)
            for k in range(3):
                c = facet.GetVertex(k)
                out[i, k] = (c.x, c.y, c.z)
        facets[key] = out
    return facets[key]


def _frame(pv) -> tuple[np.ndarray, np.ndarray]:
    """(rotation, translation) taking ``pv``'s local points to its mother's frame."""
    r = pv.GetObjectRotationValue()
    rot = np.array([[r.xx, r.xy, r.xz], [r.yx, r.yy, r.yz], [r.zx, r.zy, r.zz]])
    t = pv.GetObjectTranslation()
    return rot, np.array([t.x, t.y, t.z])


#: Directions of the exact ray-parity test (:func:`parity_inside`): fixed, not along any axis.
_RAYS = np.random.default_rng(2024).normal(size=(7, 3))
_RAYS /= np.linalg.norm(_RAYS, axis=1)[:, None]


def parity_inside(points: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """Inside a closed triangle mesh: the parity of each point's crossings along seven fixed
    rays, each ray that passes within 1e-9 (relative) of a facet's edge or plane left out,
    the majority of the others (True where more rays say inside)."""
    a = tri[:, 0]
    e1, e2 = tri[:, 1] - a, tri[:, 2] - a
    votes = np.zeros(len(points), int)
    counted = np.zeros(len(points), int)
    for d in _RAYS:
        pv = np.cross(d, e2)
        det = np.einsum("nc,nc->n", pv, e1)
        ok = np.abs(det) > 1e-300
        inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
        for n, p in enumerate(points):
            tv = p - a
            u = np.einsum("nc,nc->n", tv, pv) * inv
            qv = np.cross(tv, e1)
            w = (qv @ d) * inv
            t = np.einsum("nc,nc->n", qv, e2) * inv
            eps = 1e-9
            near = ok & (u > -eps) & (w > -eps) & (u + w < 1 + eps) & (t > -eps)
            clear = (u > eps) & (w > eps) & (u + w < 1 - eps) & (t > eps)
            if (near & ~clear).any():
                continue  # through an edge, a corner or from the surface: no vote
            counted[n] += 1
            votes[n] += int((near & clear).sum() % 2)
    return votes * 2 > counted


def retest_report(
    pv, sister, point: np.ndarray, tolerance: float, facets: dict, samples: int = 500
) -> tuple[float, float] | None:
    """Re-test exactly Geant4's report of a point of ``pv``'s surface inside ``sister`` (both
    G4TessellatedSolids) at ``point``: the sister's frame, printed with six significant digits,
    so the true point lies within ``reach`` (half the last digit of each coordinate) of it.
    A printed point outside the sister by more than ``reach`` (the distance to its facets,
    exact; outside by the parity of seven rays, :func:`parity_inside`, and the winding number)
    puts the true point outside. Nearer, points of ``pv``'s surface within ``reach`` of it
    (``samples`` per facet there, :func:`_near_points`) are tested the same way. Returns (the
    printed point's distance outside, mm; ``reach``, mm) when the report is false; None when a
    point lies inside the sister by more than ``tolerance`` (1e-9 mm at least: a real overlap)
    or no point of ``pv`` lies that near."""
    from score4.shapes.mesh_shape import MeshShape, _tri_distance

    other = _triangles(sister.GetLogicalVolume().GetSolid(), facets)
    mesh = MeshShape(other)
    digit = 10.0 ** (np.floor(np.log10(np.maximum(np.abs(point), 1e-300))) - 5)
    reach = float(np.linalg.norm(0.5 * digit)) * (1 + 1e-6) + 1e-12
    printed = float(mesh.signed_distance(point[None])[0])
    if printed > reach and not parity_inside(point[None], other)[0]:
        return printed, reach
    own = _triangles(pv.GetLogicalVolume().GetSolid(), facets)
    rot_a, t_a = _frame(pv)
    rot_b, t_b = _frame(sister)
    here = rot_a.T @ (rot_b @ point + t_b - t_a)  # the point in pv's frame
    near = own[_tri_distance(here[None], own)[0] <= reach]
    if not len(near):
        return None
    q = _near_points(here, near, reach, samples)
    if not len(q):
        return None
    in_sister = (q @ rot_a.T + t_a - t_b) @ rot_b  # pv's frame -> mother -> sister's frame
    signed = mesh.signed_distance(in_sister)
    deepest = np.argsort(signed)[:20]
    inside = signed < 0
    inside[deepest] |= parity_inside(in_sister[deepest], other)
    if (inside & (np.abs(signed) > max(tolerance, 1e-9))).any():
        return None  # a point of pv's surface inside the sister: a real overlap
    return printed, reach


def _near_points(here: np.ndarray, tri: np.ndarray, reach: float, n: int) -> np.ndarray:
    """Points of the triangles ``tri`` within ``reach`` of ``here``: each triangle's nearest
    point to it and ``n`` points drawn uniformly in the disc of radius ``reach`` about its foot
    in the triangle's plane, those inside the triangle and within ``reach``."""
    rng = np.random.default_rng(0)
    out = []
    for t in tri:
        e1, e2 = t[1] - t[0], t[2] - t[0]
        normal = np.cross(e1, e2)
        normal /= np.linalg.norm(normal)
        u = e1 / np.linalg.norm(e1)
        w = np.cross(normal, u)
        foot = here - np.dot(here - t[0], normal) * normal
        r = reach * np.sqrt(rng.random(n))
        a = rng.random(n) * 2 * np.pi
        p = foot + (r * np.cos(a))[:, None] * u + (r * np.sin(a))[:, None] * w
        # barycentric (s, t) of p in the triangle: p - t0 = s e1 + t e2
        m = np.array([[e1 @ e1, e1 @ e2], [e1 @ e2, e2 @ e2]])
        st = np.linalg.solve(m, np.stack([(p - t[0]) @ e1, (p - t[0]) @ e2]))
        keep = (st[0] >= 0) & (st[1] >= 0) & (st.sum(axis=0) <= 1)
        keep &= np.linalg.norm(p - here, axis=1) <= reach
        out.append(p[keep])
        out.append(_nearest_on(here, t)[None])
    points = np.concatenate(out)
    return points[np.linalg.norm(points - here, axis=1) <= reach * (1 + 1e-9)]


def _nearest_on(p: np.ndarray, t: np.ndarray) -> np.ndarray:
    """The point of triangle ``t`` nearest to ``p``: its foot when inside, else the nearest
    point of its edges."""
    e1, e2 = t[1] - t[0], t[2] - t[0]
    m = np.array([[e1 @ e1, e1 @ e2], [e1 @ e2, e2 @ e2]])
    s, w = np.linalg.solve(m, np.array([(p - t[0]) @ e1, (p - t[0]) @ e2]))
    if s >= 0 and w >= 0 and s + w <= 1:
        return t[0] + s * e1 + w * e2
    best = t[0]
    for a, b in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0])):
        d = b - a
        c = a + np.clip((p - a) @ d / (d @ d), 0.0, 1.0) * d
        if np.linalg.norm(p - c) < np.linalg.norm(p - best):
            best = c
    return best


def retest_encapsulation(pv, sister, facets: dict) -> float | None:
    """Geant4's report that ``pv`` fully holds ``sister`` (both G4TessellatedSolids): the
    largest exact distance (mm) by which a vertex of the sister lies outside ``pv`` when one
    does by more than 1e-9 mm (the report is false), else None."""
    from score4.shapes.mesh_shape import MeshShape

    own = _triangles(pv.GetLogicalVolume().GetSolid(), facets)
    other = _triangles(sister.GetLogicalVolume().GetSolid(), facets)
    rot_a, t_a = _frame(pv)
    rot_b, t_b = _frame(sister)
    corners = np.unique(other.reshape(-1, 3), axis=0)
    in_pv = (corners @ rot_b.T + t_b - t_a) @ rot_a
    out = float(MeshShape(own).signed_distance(in_pv).max())
    return out if out > 1e-9 else None


def _cell_corners(layer, j: int) -> np.ndarray:
    """The four corners (meridian plane at azimuth 0, the target's frame) of the cell that
    Geant4 places for a patch of ring ``j`` (the region its patch bodies must keep to): on a
    cone the common part of the two ``G4Cons`` of :func:`score4.world.curved.cone_cell`, on a
    sphere the ``G4Sphere`` segment of :func:`score4.world.curved.sphere_cell`, on a cylinder
    the ring's ``G4Tubs``; for bent tessellated bodies (no cell solid) the region between the
    face, the face moved out by the layer's thickness and the normals through the patch's
    ends (moved apart by the rows' gap)."""
    from score4.shapes.faces import SphereFace
    from score4.world.curved import cone_cell, sphere_cell

    lay = layer.ring_layout
    face = lay.face
    t = layer.thickness
    if isinstance(face, SphereFace):
        lo, hi, th0, dth, _ = sphere_cell(lay, j, t)
        pts = [(r * np.sin(th), r * np.cos(th)) for r in (lo, hi) for th in (th0, th0 + dth)]
    elif layer.is_cylinder:
        from score4.world.scene import wall_envelope

        rmin, rmax, *_ = wall_envelope(layer)
        z, half = lay.ring_z(j), lay.patch_size[1] / 2
        pts = [(r, zz) for r in (rmin, rmax) for zz in (z - half, z + half)]
    elif layer.frustum_cells:
        a, b, zc = cone_cell(lay, j, t)
        z0, z1 = lay.ring_z(j) + zc - a[4], lay.ring_z(j) + zc + a[4]
        # the shell's two lines and the band's two lines (r at z0, z1), each cut by each
        lines_a = [((a[0], z0), (a[2], z1)), ((a[1], z0), (a[3], z1))]
        lines_b = [((b[0], z0), (b[2], z1)), ((b[1], z0), (b[3], z1))]
        pts = [_meet(p, q) for p in lines_a for q in lines_b]
    else:
        e = 0.5 * lay.row_gap
        py = lay.patch_size[1]
        pts = []
        for vv in lay.v[j] + np.array([-py / 2 - e, py / 2 + e]):
            for h in (0.0, t):
                p = face.point(0.0, vv) + h * face.normal(0.0, vv)
                pts.append((float(p[0]), float(p[2])))
    return np.array([[r, 0.0, z] for r, z in pts])


def _meet(p: tuple, q: tuple) -> tuple[float, float]:
    """Where the line through ``p[0], p[1]`` meets the line through ``q[0], q[1]`` ((r, z))."""
    (a, b), (c, d) = np.asarray(p, float), np.asarray(q, float)
    m = np.column_stack([b - a, c - d])
    s = np.linalg.solve(m, c - a)
    r, z = a + s[0] * (b - a)
    return float(r), float(z)


def _cells_in_pieces(layer, cells: list, tol: float) -> list[str]:
    """The cells of a curved layer whose envelope is in pieces (a face a boolean's other parts
    cut, :attr:`~score4.world.scene.CurvedRoughLayer.pieces`) that do not lie wholly in one
    piece's azimuth and generator ranges (a cylinder's cell spans its ring's band; a cone's
    cell the generator range whose z planes hold its corners, :func:`_cell_corners`, or in a
    piece ending on cones of normals, the range of its corners' feet on the face; a sphere's
    cell its ring's band and half the rows' gap beyond)."""
    if layer.pieces is None:
        return []
    from score4.shapes.faces import SphereFace

    lay = layer.ring_layout
    py = lay.patch_size[1]
    sphere = isinstance(lay.face, SphereFace)
    cone = not layer.is_cylinder and not sphere
    out = 0
    ranges: dict[int, tuple[float, float, tuple[float, float]]] = {}  # per ring (its cells')
    for j, _, _, phi in cells:
        step, r = float(lay.step[j]), float(lay.radius[j]) + layer.thickness
        if j not in ranges:
            lo_v, hi_v = float(lay.v[j]) - py / 2, float(lay.v[j]) + py / 2
            if sphere:  # the G4Sphere cell's polar-angle cones, half the rows' gap beyond the patch
                lo_v, hi_v = lo_v - lay.row_gap / 2, hi_v + lay.row_gap / 2
            feet = (lo_v, hi_v)
            if cone:  # the corners' z as generator arc length of the face, and their feet on it
                corners = _cell_corners(layer, j)
                v = (corners[:, 2] - lay.face._mid[1]) / lay.face._tangent[1]
                lo_v, hi_v = float(v.min()), float(v.max())
                foot = lay.face.locate(corners)[1]
                feet = (float(foot.min()), float(foot.max()))
            ranges[j] = (lo_v, hi_v, feet)
        lo_v, hi_v, feet = ranges[j]
        fits = False
        for p0, dp, v0, v1, normal_ends in layer.pieces:
            lo, hi = feet if normal_ends else (lo_v, hi_v)
            a = np.mod(phi - step / 2 - p0 + tol / r, 2 * np.pi) - tol / r
            if a + step <= dp + tol / r and lo >= v0 - tol and hi <= v1 + tol:
                fits = True
                break
        out += not fits
    if not out:
        return []
    return [f"{layer.name}: {out} cell(s) lie outside the pieces of the layer's envelope"]


def _pieces_apart(layer, tol: float) -> list[str]:
    """Pairs of pieces of a curved layer's envelope that overlap (exact): their azimuth ranges
    share more than ``tol`` at the layer's top, and so do their generator ranges (pieces ending
    both on z planes or both on cones of normals), or the z ranges of their corners (one of
    each kind)."""
    if layer.pieces is None or len(layer.pieces) < 2:
        return []
    from score4.shapes.faces import SphereFace
    from score4.world.scene import EnvelopePiece

    pieces = [EnvelopePiece(*p) for p in layer.pieces]

    face = layer.ring_layout.face
    t = layer.thickness
    (_, _), (fv0, fv1) = face.extent
    if isinstance(face, SphereFace):
        r = face.sphere_radius + t
    else:
        r = float(np.max(face.radius(np.array([fv0, fv1])))) + t

    def z_range(p) -> tuple[float, float]:
        v = np.array([p.v0, p.v1])
        z = face.point(np.zeros(2), v)[:, 2]
        if p.normal_ends:
            z = np.concatenate([z, z + t * float(face.nrz[1])])
        return float(z.min()), float(z.max())

    out = []
    for (m, a), (n, b) in itertools.combinations(enumerate(pieces), 2):
        if np.mod(b.phi0 - a.phi0, 2 * np.pi) >= a.dphi - tol / r and (
            np.mod(a.phi0 - b.phi0, 2 * np.pi) >= b.dphi - tol / r
        ):
            continue  # apart in azimuth (touching at most)
        (a0, a1), (b0, b1) = (
            ((a.v0, a.v1), (b.v0, b.v1)) if a.normal_ends == b.normal_ends else
            (z_range(a), z_range(b))
        )  # fmt: skip
        if min(a1, b1) - max(a0, b0) > tol:
            out.append(
                f"{layer.name}: pieces {m} and {n} of the envelope overlap by "
                f"{(min(a1, b1) - max(a0, b0)) * 1e3:.4g} um along the face"
            )
    return out


def curved_cells_tile(layer, tolerance: float = 1e-9) -> tuple[int, list[str]]:
    """Exact check (numpy) that the cells of a curved layer tile its envelope: neighbouring rings
    share their bounding cones (or polar-angle cones), neighbouring cells of a ring their
    azimuths, no cell leaves the envelope (the face, the face moved out by the layer's
    thickness, its ends and its phi range), and every patch body's vertices lie in their cell.
    Gaps and overlaps beyond ``tolerance`` (mm; an azimuth's times the radius) are reported.
    Returns (cells checked, problems)."""
    lay = layer.ring_layout
    face = lay.face
    t = layer.thickness
    tol = max(tolerance, 0.0) + 1e-12
    problems: list[str] = []
    name = layer.name
    held = [int(j) for j in np.flatnonzero(lay.count > 0)]
    (u0, u1), (v0, v1) = face.extent
    spans: dict[int, tuple[np.ndarray, np.ndarray]] = {}  # ring: (v at h = 0, t), its ends
    for j in held:
        _, v, h = face.locate(_cell_corners(layer, j))
        low, high = np.abs(h) <= tol, np.abs(h - t) <= tol
        if low.sum() != 2 or high.sum() != 2:
            problems.append(
                f"{name}: ring {j}'s cell is not between the face and the layer's top "
                f"(heights {np.round(h * 1e3, 6).tolist()} um)"
            )
            continue
        spans[j] = (np.sort(v[low]), np.sort(v[high]))
        lo_v, hi_v = float(v.min()), float(v.max())
        if lo_v < v0 - tol or hi_v > v1 + tol:
            problems.append(
                f"{name}: ring {j}'s cell leaves the face's ends by "
                f"{max(v0 - lo_v, hi_v - v1) * 1e3:.4g} um"
            )
    for j, k in itertools.pairwise(held):
        if k != j + 1 or j not in spans or k not in spans:
            continue
        for level, (a, b) in enumerate(zip(spans[j], spans[k], strict=True)):
            # ring j's far side against ring k's near side, at the face and at the top
            (a0, a1), (b0, b1) = a, b
            if a0 > b0:
                (a0, a1), (b0, b1) = (b0, b1), (a0, a1)
            step = float(b0 - a1)
            if abs(step) > tol:
                what = "a gap" if step > 0 else "an overlap"
                problems.append(
                    f"{name}: rings {j} and {k} leave {what} of {abs(step) * 1e3:.4g} um "
                    f"between them {('at the face', 'at the layer top')[level]}"
                )
    cells = layer.cells()
    problems += _cells_in_pieces(layer, cells, tol) + _pieces_apart(layer, tol)
    by_ring: dict[int, list[tuple[int, float]]] = {}
    for j, _, k, phi in cells:
        by_ring.setdefault(j, []).append((k, phi))
    full = face.dphi >= 2 * np.pi - 1e-12
    for j, row in sorted(by_ring.items()):
        r = float(lay.radius[j]) + t
        step = float(lay.step[j])
        phis = np.sort(np.array([p for _, p in row]))
        d = np.diff(phis)
        over = d < step - tol / r
        if over.any():
            problems.append(
                f"{name}: {int(over.sum())} neighbouring cells of ring {j} overlap by up to "
                f"{float((step - d[over]).max()) * r * 1e3:.4g} um"
            )
        if full:
            wrap = phis[0] + 2 * np.pi - phis[-1]
            if len(phis) > 1 and wrap < step - tol / r:
                problems.append(
                    f"{name}: the first and last cells of ring {j} overlap across the seam by "
                    f"{(step - wrap) * r * 1e3:.4g} um"
                )
        else:
            out = max(u0 - (phis[0] - step / 2), phis[-1] + step / 2 - u1)
            if out > tol / r:
                problems.append(
                    f"{name}: ring {j}'s cells leave the face's phi range by {out * r * 1e3:.4g} um"
                )
        # the patch bodies of the ring (each variant once: all cells of a ring are turned
        # copies) in their cell: azimuth, generator span and height
        if j not in spans:
            continue
        (lv0, lv1), (hv0, hv1) = spans[j]
        for k in sorted({k for k, _ in row}):
            body = layer.bent(k, j)
            q = body.vertices + np.array([0.0, 0.0, lay.ring_z(j)])
            u, v, h = face.locate(q)
            du = (np.mod(u + np.pi, 2 * np.pi) - np.pi) * np.hypot(q[:, 0], q[:, 1])  # cell at 0
            frac = np.clip(h / t, 0.0, 1.0)  # the span at that height (linear between the two)
            lo_at, hi_at = lv0 + frac * (hv0 - lv0), lv1 + frac * (hv1 - lv1)
            half = step / 2 * np.hypot(q[:, 0], q[:, 1])
            worst = max(
                float((np.abs(du) - half).max()),
                float((lo_at - v).max()),
                float((v - hi_at).max()),
                float(-h.min()),
                float((h - t).max()),
            )
            if worst > tol:
                problems.append(
                    f"{name}: variant {layer.names[k]!r} on ring {j} reaches {worst * 1e3:.4g} um "
                    "outside its cell"
                )
    return len(cells), problems
