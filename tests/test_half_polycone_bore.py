"""A rough wall of a half polycone bore (issue 24): a copper box less a G4Polycone of half a
circle (phi 0 .. 180 deg: a cone r 2 -> 2.5 mm, a ledge, a cone r 4 -> 4.5 mm), its lower cone
rough (score4.world.boolean_modes.polycone_wall turns it as the inner wall of a G4Cons with
the polycone's phi segment). Geantino paths from inside the half bore out through its walls
against an analytic ray trace of the box less the half bore (grown behind the rough wall with
``into``) plus the patch bodies, 1e-9 mm; Geant4's volume against the analytic one."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from score4.inputs.config import parse_config
from score4.world.boolean_modes import into_depth
from score4.world.resolve import build_scene

from helpers.geantinos import geantino_config, rough_targets

PYRAMIDS = {"kind": "spikes", "nx": 5, "ny": 5, "width": "50 um", "height": "20 um"}
HALF = 10.0
LOWER, UPPER = (2.0, 2.5), (4.0, 4.5)  # radii at the bottom and top of the two cones


@pytest.fixture(scope="module")
def gdml(tmp_path_factory) -> Path:
    """``half``: a 20 mm copper box less the half polycone along its z axis, from z = 5 mm up
    through its top (the bore's frame: z = 0 at the box's top), the polycone's flat side in the
    box's xz plane, its half on y > 0."""
    from helpers.boolean_worlds import write_box_holes

    def holes(s, reg) -> dict:
        half = s.Polycone("half_b", 0, np.pi, [-5, -2, -2, 5], [0] * 4, [*LOWER, *UPPER], reg)
        return {"half": (half, [0.0, 0.0, HALF], 0.0)}

    return write_box_holes(tmp_path_factory.mktemp("half_bore") / "half.gdml", holes, HALF)


def config(gdml: Path, into: bool) -> dict:
    targets = rough_targets({"half": ["second.seg_1"]}, into=into)
    return geantino_config(
        gdml, {"p": PYRAMIDS}, targets, ("half", "first.-z"), output={"track_length": True}
    )


class _Solid:
    """The box less the half bore, its lower cone moved out by ``grown`` (radially, mm), for
    helpers.ray_trace.polycone_path (its sign only); written out from the solids'
    parameters."""

    def __init__(self, grown: float) -> None:
        self.grown = grown

    def signed_distance(self, q: np.ndarray) -> np.ndarray:
        rho, z = np.hypot(q[:, 0], q[:, 1]), q[:, 2] - 10.0
        lower = LOWER[0] + (LOWER[1] - LOWER[0]) * (z + 5.0) / 3.0 + self.grown
        upper = UPPER[0] + (UPPER[1] - UPPER[0]) * (z + 2.0) / 7.0
        bore = (q[:, 1] >= 0) & (z >= -5) & (z <= 5) & (rho <= np.where(z <= -2, lower, upper))
        inside = (np.abs(q) < HALF).all(axis=1) & ~bore
        return np.where(inside, -1.0, 1.0)


def volume(grown: float) -> float:
    """The box less the half bore inside it (z from -5 to the box's top, 0), mm3."""

    def frustum(h: float, r1: float, r2: float) -> float:
        return math.pi * h / 3 * (r1 * r1 + r1 * r2 + r2 * r2)

    top = UPPER[0] + (UPPER[1] - UPPER[0]) * 2.0 / 7.0
    bore = frustum(3.0, LOWER[0] + grown, LOWER[1] + grown) + frustum(2.0, UPPER[0], top)
    return (2 * HALF) ** 3 - bore / 2


def rays(n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Rays (box frame) from inside the half bore, 0.3 mm off its flat side, out through its
    curved walls at azimuths 0.3 .. pi - 0.3: half at the lower cone (z 5 .. 8 mm), half at the
    upper one (in the box), some first across the flat side's plane (aimed from y = 0.3 mm at
    azimuths under 0.6 rad)."""
    phi = rng.uniform(0.3, np.pi - 0.3, n)
    start = np.column_stack([np.zeros(n), np.full(n, 0.3), rng.uniform(5.5, 9.5, n)])
    aim_z = np.where(np.arange(n) < n // 2, rng.uniform(5.2, 7.8, n), rng.uniform(8.2, 9.8, n))
    aim = np.column_stack([5 * np.cos(phi), 5 * np.sin(phi), aim_z])
    d = aim - start
    return start, d / np.linalg.norm(d, axis=1, keepdims=True)


@pytest.mark.parametrize(
    "into", [pytest.param(False, marks=pytest.mark.deep), True], ids=["outside", "into"]
)
def test_geantino_paths_through_a_half_polycone_bore_wall(gdml, tmp_path, into):
    """Geantinos from inside the half bore out through its walls: Geant4's track length in
    the box equals the analytic path in the box less the half bore (its lower cone grown by the
    layer's cut along its normal with ``into``) plus the path in the patch bodies, 1e-9 mm;
    most rays at the lower cone cross a patch; the layer's cells lie within the half circle;
    Geant4's volume of the box less its layer is the analytic one to 2e-4."""
    from helpers.geantinos import assert_box_paths
    from helpers.ray_trace import polycone_path

    data = config(gdml, into)
    scene = build_scene(parse_config(data))
    (layer,) = scene.layers_of("half")
    assert layer.curved
    phis = np.concatenate([layer.ring_layout.cell_phi(j) for j in range(len(layer.ring_layout.v))])
    step = float(layer.ring_layout.step.max())
    assert phis.min() - step / 2 >= -1e-12
    assert phis.max() + step / 2 <= np.pi + 1e-12
    grown = into_depth(layer, True) * math.hypot(1.0, 0.5 / 3.0) if into else 0.0
    start, d = rays(16, np.random.default_rng(9))
    crossed = assert_box_paths(
        data,
        scene,
        start,
        d,
        ["half"] * len(start),
        lambda name, o, w: polycone_path(o, w, _Solid(grown)),
        lambda name: volume(grown),
        tmp_path,
    )
    assert crossed >= len(start) // 4
