"""``into`` on the wall of a drilled hole (score4.world.boolean_layers._grown_wall_extent): a
copper box less a G4GenericPolycone (a cylinder r 3 mm over a drill-tip cone closing at 90
degrees). Grown by the layer's cut, the cylinder meets the kept cone line further up, so the
wall gets shorter by the cut: the layer is laid out on the part that is kept (before, its
envelope reached the old end, into the solid, and was refused). Geantino paths against an
analytic ray trace of the box less the grown hole plus the patch bodies (1e-9 mm), Geant4's
volume to 2e-4, Geant4's overlap check (deep)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from score4.inputs.config import parse_config
from score4.world.boolean_modes import into_depth
from score4.world.resolve import build_scene

from helpers.geantinos import geantino_config, rough_targets

pytestmark = pytest.mark.xdist_group("drill-bore-into")

PYRAMIDS = {"kind": "spikes", "nx": 5, "ny": 5, "width": "50 um", "height": "20 um"}
HALF = 10.0  # the box's half width, mm
AT = 5.0  # the hole's frame's z in the box
R = 3.0  # the bore's radius
TIP = -5.0  # the drill tip's z (hole frame); the cone reaches r 3 at z -2


@pytest.fixture(scope="module")
def gdml(tmp_path_factory) -> Path:
    """The copper box less the hole, written as GDML text."""
    from helpers.boolean_worlds import copper_world_text

    corners = [(0, TIP), (R, TIP + R), (R, 15), (0, 15)]
    points = "".join(f'<rzpoint r="{r}" z="{z}"/>' for r, z in corners)
    solids = f"""
<box name="world_s" x="100" y="100" z="100" lunit="mm"/>
<box name="drill_a" x="{2 * HALF}" y="{2 * HALF}" z="{2 * HALF}" lunit="mm"/>
<genericPolycone name="drill_b" startphi="0" deltaphi="360" aunit="deg" lunit="mm">{points}
</genericPolycone>
<subtraction name="drill_s"><first ref="drill_a"/><second ref="drill_b"/>
  <position name="drill_p" x="0" y="0" z="{AT}" unit="mm"/></subtraction>"""
    path = tmp_path_factory.mktemp("drill") / "drill.gdml"
    path.write_text(copper_world_text(solids, {"drill": (0.0, 0.0, 0.0)}))
    return path


def config(gdml: Path, into: bool) -> dict:
    targets = rough_targets({"drill": ["second.seg_1"]}, into=into)
    return geantino_config(
        gdml, {"p": PYRAMIDS}, targets, ("drill", "first.-z"), output={"track_length": True}
    )


class _Solid:
    """The box less the hole whose cylinder has grown by ``g`` (mm), the cone's line kept:
    for helpers.ray_trace.polycone_path (its sign only)."""

    def __init__(self, g: float) -> None:
        self.g = g

    def signed_distance(self, q: np.ndarray) -> np.ndarray:
        z = q[:, 2] - AT
        rho = np.hypot(q[:, 0], q[:, 1])
        hole = (z >= TIP) & (rho <= np.minimum(R + self.g, z - TIP))
        return np.where((np.abs(q) < HALF).all(axis=1) & ~hole, -1.0, 1.0)


def rays(n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Rays (box frame) from the hole's axis out through its wall, a third of them at the
    0.3 mm above the old wall's foot."""
    phi = rng.uniform(0, 2 * np.pi, n)
    start = np.column_stack([np.zeros((n, 2)), rng.uniform(4.0, 9.0, n)])
    low = AT + TIP + R  # the old wall's foot, box frame
    aim_z = np.where(np.arange(n) % 3 == 0, rng.uniform(low, low + 0.3, n), rng.uniform(4, 9.5, n))
    aim = np.column_stack([3.5 * np.cos(phi), 3.5 * np.sin(phi), aim_z])
    d = aim - start
    return start, d / np.linalg.norm(d, axis=1, keepdims=True)


def _wall_ends(scene) -> tuple[float, float, float]:
    """The z range (box frame) of the wall's layer's face and the hole's growth."""
    (layer,) = scene.layers_of("drill")
    g = into_depth(layer, True) if layer.config.into else 0.0
    lo = scene.target("drill").to_local(layer.target.to_world(np.zeros((1, 3))))[0, 2]
    face = layer.ring_layout.face
    a, b = sorted(z + lo for z in (face.rz1[1], face.rz2[1]))
    return a, b, g


def test_the_wall_starts_where_the_grown_cylinder_meets_the_cone(gdml):
    """With ``into`` the wall's layer is laid out from where the grown cylinder meets the kept
    cone line (its cut above the old foot) up to the box's top; without, from the old foot;
    every ring holds cells."""
    for into in (False, True):
        scene = build_scene(parse_config(config(gdml, into)))
        a, b, g = _wall_ends(scene)
        assert a == pytest.approx(AT + TIP + R + g, abs=1e-9)  # the (grown) wall's foot
        assert b == pytest.approx(HALF, abs=1e-9)  # the box's top
        assert (g > 0.02) == into
        (layer,) = scene.layers_of("drill")
        assert (layer.cell_variants >= 0).any(axis=1).all()


@pytest.mark.deep  # ~5 s each
@pytest.mark.parametrize("into", [False, True], ids=["outside", "into"])
def test_geantino_paths_through_a_drilled_holes_rough_wall(gdml, tmp_path, into):
    """Geantinos from the hole's axis out through the wall, a third of them near its lower
    end: Geant4's track length in the box equals the analytic path in the box less the (grown)
    hole plus the patch bodies, 1e-9 mm; Geant4's volume to 2e-4."""
    from helpers.geantinos import assert_box_paths
    from helpers.ray_trace import polycone_path

    data = config(gdml, into)
    scene = build_scene(parse_config(data))
    g = _wall_ends(scene)[2]
    n = 12
    start, d = rays(n, np.random.default_rng(5))
    hole = math.pi * (R + g) ** 2 * (HALF - AT - TIP - R - g) + math.pi / 3 * (R + g) ** 3
    crossed = assert_box_paths(
        data,
        scene,
        start,
        d,
        ["drill"] * n,
        lambda name, o, d: polycone_path(o, d, _Solid(g)),
        lambda name: (2 * HALF) ** 3 - hole,
        tmp_path,
    )
    assert crossed >= n // 2


def test_the_wall_laid_out_over_its_old_length_runs_into_the_solid(gdml, monkeypatch):
    """Laid out over the old wall's length (as before), the layer's shell reaches below the
    grown wall's foot, under the kept cone line, into the box: refused in one line."""
    from score4.errors import ConfigError
    from score4.world import boolean_layers

    monkeypatch.setattr(boolean_layers, "_grown_wall_extent", lambda clip, layer: None)
    with pytest.raises(ConfigError) as err:
        build_scene(parse_config(config(gdml, True)))
    assert "runs into the solid itself" in str(err.value)
    assert "\n" not in str(err.value)


@pytest.mark.deep
def test_a_drilled_holes_rough_wall_passes_the_overlap_check(gdml, tmp_path):
    """Geant4's overlap check (``score4 geometry check``, in its own process) finds no overlap
    between the wall's layer and the box rebuilt around the grown hole."""
    import yaml

    from helpers.g4_geometry_check import assert_no_overlaps

    path = tmp_path / "drill.yaml"
    path.write_text(yaml.safe_dump(config(gdml, True)))
    assert_no_overlaps(path)


@pytest.mark.deep
def test_a_drilled_holes_rough_wall_exports_with_the_same_paths(gdml, tmp_path, monkeypatch):
    """The wall's layer with ``into`` in a world written by `score4 geometry export`: Geant4
    reads the file back, and the file pyg4ometry reads and writes again, with the same geantino
    paths (volumes and points, 1e-9 mm) as the world score4 builds (the grown polycone in the
    boolean); most rays cross a patch."""
    import yaml

    from score4.cli.main import main

    from helpers.export_paths import assert_same_paths, three_paths

    path = tmp_path / "drill.yaml"
    path.write_text(yaml.safe_dump(config(gdml, True)))
    out = tmp_path / "drill.gdml"
    assert main(["geometry", "export", str(path), "--gdml", str(out)]) == 0
    start, d = rays(12, np.random.default_rng(41))
    out_rays = [(o.tolist(), w.tolist()) for o, w in zip(start, d, strict=True)]
    ours, back, relay = three_paths(path, out, out_rays, monkeypatch)
    assert_same_paths(ours, back, relay)
    assert sum(any("_rough" in (v or "") for v, _ in p) for p in ours) >= len(out_rays) // 2
