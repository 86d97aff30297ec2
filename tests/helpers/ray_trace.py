"""An independent ray trace through triangle meshes, for the geantino-path tests."""

from __future__ import annotations

import math

import numpy as np

from score4.world.scene import CurvedRoughLayer


def mesh_path(
    o: np.ndarray, d: np.ndarray, tri: np.ndarray, *, edge: float = 0.0, merge: float = 1e-12
) -> float:
    """Path length of the ray ``o + t d`` (t > 0) in the closed mesh ``tri`` ((n, 3, 3)):
    Moeller-Trumbore hits, a hit counted within ``edge`` (barycentric) of a triangle, hits
    closer than ``merge`` mm along the ray taken as one (a ray through a shared edge), the
    crossings paired in and out."""
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    pv = np.cross(d, e2)
    det = np.einsum("ij,ij->i", e1, pv)
    ok = np.abs(det) > 1e-30
    inv = np.where(ok, 1 / np.where(ok, det, 1), 0)
    tv = o - tri[:, 0]
    u = np.einsum("ij,ij->i", tv, pv) * inv
    qv = np.cross(tv, e1)
    w = (qv @ d) * inv
    t = np.einsum("ij,ij->i", e2, qv) * inv
    hit = ok & (u >= -edge) & (w >= -edge) & (u + w <= 1 + edge) & (t > 0)
    ts = np.sort(t[hit])
    ts = ts[np.concatenate([[True], np.diff(ts) > merge])] if len(ts) else ts
    assert len(ts) % 2 == 0
    return float(np.sum(ts[1::2] - ts[0::2]))


def polycone_path(o: np.ndarray, d: np.ndarray, shape, length: float = 40.0) -> float:
    """Path of the ray in the solid from its signed distance: sign changes on a 2 um grid,
    bisected to 1e-13 mm (independent of Geant4's polycone)."""
    t = np.arange(0.0, length, 0.002)
    inside = shape.signed_distance(o + t[:, None] * d) < 0
    edges = np.flatnonzero(np.diff(inside.astype(int)))
    crossings = []
    for k in edges:
        lo, hi = t[k], t[k + 1]
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            if (shape.signed_distance((o + mid * d)[None])[0] < 0) == inside[k]:
                lo = mid
            else:
                hi = mid
        crossings.append(0.5 * (lo + hi))
    assert len(crossings) % 2 == 0
    return float(sum(crossings[1::2]) - sum(crossings[0::2]))


def patches_path(o: np.ndarray, d: np.ndarray, layer, length: float = 40.0) -> float:
    """Path of the ray in the patch bodies of a layer (each closed body on its own,
    Moeller-Trumbore) of the cells the ray passes near."""
    t = np.arange(0.0, length, 0.01)
    pts = o + t[:, None] * d
    total = 0.0
    if isinstance(layer, CurvedRoughLayer):
        lay = layer.ring_layout
        q = layer.target.to_local(pts)
        h = lay.face.locate(q)[2]
        j, i, _ = lay.locate(q[(h > -0.05) & (h < 0.05)])
        cells = {(a, b + s) for a, b in zip(j, i, strict=True) if a >= 0 for s in (-1, 0, 1)}
        cells |= {(a + s, b) for a, b in list(cells) for s in (-1, 1)}
        for a, b in cells:
            if not (0 <= a < len(lay.v)) or not (0 <= b < lay.count[a]):
                continue
            k = int(layer.cell_variants[a, b])
            if k < 0:
                continue
            body = layer.bent(k, a)
            phi = lay.cell_phi(a)[b]
            c, s = math.cos(phi), math.sin(phi)
            v = body.vertices @ np.array([[c, s, 0], [-s, c, 0], [0, 0, 1]])
            v = layer.target.to_world(v + np.array([0.0, 0.0, lay.ring_z(a)]))
            total += mesh_path(o, d, v[body.faces])
        return total
    q = layer.frame.to_local(pts)
    q = q[(q[:, 2] > -0.05) & (q[:, 2] < 0.05)]
    i, j = layer.patch_map.cell_of(q[:, :2])
    cells = {
        (b + s, a + r)
        for a, b in zip(i, j, strict=True)
        if a >= 0
        for s in (-1, 0, 1)
        for r in (-1, 0, 1)
    }
    grid = layer.cell_variants
    centres = layer.cell_centres()
    for b, a in cells:
        if not (0 <= b < grid.shape[0] and 0 <= a < grid.shape[1]) or grid[b, a] < 0:
            continue
        body = layer.variants[int(grid[b, a])].body(layer.base_thickness)
        v = body.vertices + np.array([*centres[b, a], layer.base_thickness])
        total += mesh_path(o, d, layer.frame.to_world(v)[body.faces])
    return total


def revolved_path(o: np.ndarray, d: np.ndarray, shape) -> float:
    """Path of the ray ``o + t d`` (t > 0) in a full solid of revolution (``shape.contour()``:
    its (r, z) polygon), analytic: where the ray meets the cone or plane of each contour edge
    (a quadratic in t), the pieces between crossings kept whose middle lies inside."""
    poly, _ = shape.contour()
    ts = [0.0]
    for (r1, z1), (r2, z2) in zip(poly, np.roll(poly, -1, axis=0), strict=True):
        if abs(z2 - z1) < 1e-15:  # a plane z = z1
            if abs(d[2]) > 1e-15:
                ts.append((z1 - o[2]) / d[2])
            continue
        # r = a + b z on the edge's cone: x^2 + y^2 = (a + b z)^2 with r >= 0
        b = (r2 - r1) / (z2 - z1)
        a = r1 - b * z1
        ra, rb = a + b * o[2], b * d[2]  # r(t) = ra + rb t on the cone
        qa = d[0] ** 2 + d[1] ** 2 - rb**2
        qb = 2 * (o[0] * d[0] + o[1] * d[1]) - 2 * ra * rb
        qc = o[0] ** 2 + o[1] ** 2 - ra**2
        if abs(qa) < 1e-15:
            roots = [-qc / qb] if abs(qb) > 1e-15 else []
        else:
            disc = qb * qb - 4 * qa * qc
            roots = [] if disc < 0 else [(-qb + s * math.sqrt(disc)) / (2 * qa) for s in (-1, 1)]
        ts += [t for t in roots if ra + rb * t >= 0]
    ts = np.unique([t for t in ts if t >= 0])
    mid = 0.5 * (ts[1:] + ts[:-1])
    inside = shape.signed_distance(o + mid[:, None] * d) < 0
    return float(np.sum(np.diff(ts)[inside]))


def wall_patches_near(layer, frame, at: np.ndarray, max_dphi: float) -> np.ndarray:
    """Triangles, in ``frame``'s local coordinates, of a curved layer's bent patches in the
    cells around ``at`` (a point in the layer's target frame): rings within 4 patch heights of
    it, azimuths within ``max_dphi``."""
    lay = layer.ring_layout
    tri = []
    for j, _i, v, cell_phi in layer.cells():
        dphi = (cell_phi - math.atan2(at[1], at[0]) + math.pi) % (2 * math.pi) - math.pi
        if abs(lay.ring_z(j) - at[2]) > 4 * layer.patch_size[1] or abs(dphi) > max_dphi:
            continue
        body = layer.bent(v, j)
        c_, s_ = math.cos(cell_phi), math.sin(cell_phi)
        w = body.vertices @ np.array([[c_, s_, 0], [-s_, c_, 0], [0, 0, 1]])
        w = layer.target.to_world(w + np.array([0.0, 0.0, lay.ring_z(j)]))
        tri.append(frame.to_local(w)[body.faces.ravel()].reshape(-1, 3, 3))
    return np.concatenate(tri)


def flat_patches_path(layer, o: np.ndarray, d: np.ndarray, samples: int = 40) -> float:
    """Path of the ray o + s d in the patch bodies of a flat layer's kept cells near it: the
    cells within a patch of ``samples`` points where the ray crosses the layer's slab."""
    body = layer.variants[0].body(layer.base_thickness)
    px, py = layer.patch_size
    cc = layer.cell_centres()
    lo, dl = layer.frame.to_local(o[None])[0], d @ layer.frame.rotation
    ts = np.linspace(-lo[2] / dl[2], (layer.thickness - lo[2]) / dl[2], samples)
    path = lo[None, :2] + ts[:, None] * dl[None, :2]
    near = np.zeros(layer.cell_variants.shape, dtype=bool)
    for q in path:
        near |= (np.abs(cc[..., 0] - q[0]) < px) & (np.abs(cc[..., 1] - q[1]) < py)
    out = 0.0
    for j, i in zip(*np.nonzero(near & (layer.cell_variants >= 0)), strict=True):
        v = body.vertices + np.array([*cc[j, i], layer.base_thickness])
        out += mesh_path(o, d, layer.frame.to_world(v)[body.faces], edge=1e-12, merge=1e-10)
    return out
