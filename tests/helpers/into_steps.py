"""Steps and activeness of a rough ``into`` face on a boolean target, against brute force:
the run whose steps the tests read, and the distance to a layer's rough surface over the
patch tops around each point."""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np

from score4.inputs.config import parse_config
from score4.runner.engine import run
from score4.runner.output import read_results
from score4.shapes.mesh_shape import _tri_distance

#: 0.5 mm patches of 5 x 5 pyramids, 20 um high
PYRAMIDS = {"kind": "spikes", "nx": 5, "ny": 5, "width": "100 um", "height": "20 um"}


def into_steps_run(
    gdml: Path, volume: str, face: str, wall: tuple[str, str], seed: int, tmp_path: Path
):
    """30 isotropic 5.3 MeV alphas from the pyramids on ``face`` of ``volume`` (``into: true``,
    1 um base), steps written, a 3 um transition layer (dlf 0.5) under ``face`` and one of
    ``wall`` = (face, fccd) with dlf 0.2. Returns the configuration, the results, and per step
    the event, the deposit (MeV), the world position and ``dist_to_surf`` (mm)."""
    import lh5

    wall_face, wall_fccd = wall
    data = {
        "physics": "lite",
        "world": {"gdml": str(gdml)},
        "surfaces": {"p": PYRAMIDS},
        "targets": [
            {
                "volume": volume,
                "rough": [{"face": face, "surface": "p", "base_thickness": "1 um", "into": True}],
                "activeness": [
                    {"fccd": "3 um", "dlf": 0.5, "faces": [face]},
                    {"fccd": wall_fccd, "dlf": 0.2, "faces": [wall_face]},
                ],
            }
        ],
        "source": {
            "particle": "alpha",
            "energy": "5.3 MeV",
            "direction": "isotropic",
            "surface": {"volume": volume, "face": face},
        },
        "run": {"events": 30, "seed": seed},
        "output": {"steps": True},
    }
    cfg = parse_config(data)
    out = tmp_path / "steps.h5"
    run(cfg, out, progress=False, echo=lambda m: None)
    res = read_results(out)
    table = lh5.read(f"stp/{volume}", str(out))
    evtid = np.asarray(table["evtid"].nda)
    edep = np.asarray(table["edep"].nda) / 1e3  # keV -> MeV
    with h5py.File(out, "r") as f:
        g = f[f"stp/{volume}"]
        world = np.column_stack([g[c][()] * 1e3 for c in ("xloc", "yloc", "zloc")])
        dist = g["dist_to_surf"][()] * 1e3
    return cfg, res, evtid, edep, world, dist


def brute_rough(layer, world: np.ndarray) -> np.ndarray:
    """Distance of world points to the layer's rough surface over the 3 x 3 cells around each
    point's cell: every top facet of a kept cell (its variant's top mesh lifted by the base),
    the flat square of any other cell. Exact where below one cell width (farther cells are)."""
    q = layer.frame.to_local(world)
    px, py = layer.patch_size
    cells = np.asarray(layer.cell_variants)
    ny, nx = cells.shape
    centres = layer.cell_centres()
    i0 = np.floor((q[:, 0] + nx * px / 2) / px).astype(int)
    j0 = np.floor((q[:, 1] + ny * py / 2) / py).astype(int)
    out = np.full(len(q), np.inf)
    tops = [
        np.asarray(v.top_mesh.vertices, float)[np.asarray(v.top_mesh.faces)]
        + np.array([0.0, 0.0, layer.base_thickness])
        for v in layer.variants
    ]
    for n in range(len(q)):
        for j in range(j0[n] - 1, j0[n] + 2):
            for i in range(i0[n] - 1, i0[n] + 2):
                if not (0 <= i < nx and 0 <= j < ny):
                    continue
                c = np.array([*centres[j, i], 0.0])
                k = cells[j, i]
                if k >= 0:
                    d = _tri_distance(q[n : n + 1] - c, tops[k]).min()
                else:
                    e = np.maximum(np.abs(q[n, :2] - c[:2]) - np.array([px, py]) / 2, 0.0)
                    d = float(np.hypot(np.hypot(*e), q[n, 2]))
                out[n] = min(out[n], d)
    return out
