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
    ``progress``: called with a line of text per curved layer.
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
        if pv.CheckOverlaps(points, tolerance, False, 1):
            report.overlaps.append(f"{pv.GetName()} (copy {pv.GetCopyNo()})")

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
