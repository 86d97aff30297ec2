"""Confinement on volumes of a GDML world (source.confine): a vertex must lie in the volume's own
material, not in one of its daughters, and on solids other than boxes the true solid counts,
not its bounding box. The volume model is given as data (no Geant4 needed)."""

from __future__ import annotations

import numpy as np
import pytest

from score4.inputs.config import parse_config
from score4.shapes import G4Box, G4Orb
from score4.source.build import make_source
from score4.world.gdml_model import GeometryModel
from score4.world.resolve import build_scene


def _solid(shape) -> dict:
    lo, hi = shape.bounding_box()
    return {
        "type": shape.kind,
        "name": shape.kind,
        "params": {},
        "shape": shape.to_dict(),
        "lo": list(lo),
        "hi": list(hi),
        "volume_mm3": shape.volume,
        "area_mm2": shape.area,
    }


def _placement(name: str, logical: int, z: float) -> dict:
    return {
        "name": name,
        "copy": 0,
        "logical": logical,
        "rotation": [1, 0, 0, 0, 1, 0, 0, 0, 1],
        "translation": [0.0, 0.0, z],
        "kind": "placement",
        "multiplicity": 1,
    }


def _model() -> GeometryModel:
    """A copper holder (20 x 20 x 10 mm) with a vacuum pocket (6 x 6 x 2 mm) 0.5 mm below its
    top face, and a copper ball (a G4Orb, r = 5 mm) beside it."""
    holder = G4Box(10, 10, 5)
    solid = _solid(holder)
    solid["params"] = {"x": 10.0, "y": 10.0, "z": 5.0}
    ball = _solid(G4Orb(5))
    world = _solid(G4Box(50, 50, 50))
    ball_placement = _placement("ball", 3, 0.0)
    ball_placement["translation"] = [30.0, 0.0, 0.0]
    return GeometryModel.from_dict(
        {
            "source": "pocket.gdml",
            "world": 0,
            "world_name": "world",
            "materials": {},
            "logicals": [
                {
                    "name": "World",
                    "solid": world,
                    "material": "G4_Galactic",
                    "daughters": [_placement("holder", 1, 0.0), ball_placement],
                },
                {
                    "name": "Holder",
                    "solid": solid,
                    "material": "G4_Cu",
                    "daughters": [_placement("pocket", 2, 3.5)],
                },
                {
                    "name": "Pocket",
                    "solid": _solid(G4Box(3, 3, 1)),
                    "material": "G4_Galactic",
                    "daughters": [],
                },
                {"name": "Ball", "solid": ball, "material": "G4_Cu", "daughters": []},
            ],
        }
    )


def _source(tmp_path, source: dict):
    gdml = tmp_path / "pocket.gdml"
    gdml.write_text("<gdml/>")  # the model is given; the file is never read
    config = parse_config(
        {
            "world": {"gdml": str(gdml)},
            "targets": [{"volume": "holder"}, {"volume": "ball"}],
            "source": {"particle": "alpha", "energy": "5 MeV", **source},
            "run": {"events": 4000},
        }
    )
    scene = build_scene(config, _model())
    return scene, make_source(config, scene).primaries(np.random.default_rng(1), 0, 4000)


def _in_pocket(p: np.ndarray) -> np.ndarray:
    return (np.abs(p[:, 0]) < 3) & (np.abs(p[:, 1]) < 3) & (p[:, 2] > 2.5) & (p[:, 2] < 4.5)


def test_confined_vertices_avoid_the_daughter(tmp_path):
    depth = {"profile": "uniform", "max": "1 mm"}
    scene, p = _source(tmp_path, {"surface": {"volume": "holder", "face": "+z"}, "depth": depth})
    assert not _in_pocket(p.position).any()
    assert scene.inside_target("holder", p.position).all()
    # the pocket's shadow (36 of 400 mm2) keeps its vertices above the pocket (0.5 mm of copper)
    shadow = (np.abs(p.position[:, 0]) < 3) & (np.abs(p.position[:, 1]) < 3)
    assert p.extra["depth"][shadow].max() <= 0.5 + 1e-9
    assert p.extra["depth"][~shadow].max() > 0.99
    # the share of the shadow is what is left of it: 36 mm2 x 0.5 mm of 400 mm2 x 1 mm, less
    expected = 36 * 0.5 / (400 * 1 - 36 * 0.5)
    n = len(p.position)
    assert shadow.mean() == pytest.approx(expected, abs=4 * np.sqrt(expected / n))
    # without confinement the pocket gets vertices
    _, free = _source(
        tmp_path,
        {"surface": {"volume": "holder", "face": "+z"}, "depth": depth, "confine": False},
    )
    assert _in_pocket(free.position).mean() == pytest.approx(36 * 0.5 / 400, abs=0.015)


def test_inside_target_uses_the_true_solid_and_the_material(tmp_path):
    scene, _ = _source(tmp_path, {"volume": "holder"})
    ball = scene.target("ball")
    assert ball.shape is not None
    # in the ball's bounding box, outside the ball (r 6.4 mm); inside (r 4.2 mm and 0.5 mm)
    pts = np.array([[30 + 4.5, 4.5, 0.0], [30 + 3.0, 3.0, 0.0], [30.0, 0.0, 0.5]])
    assert scene.inside_target("ball", pts).tolist() == [False, True, True]
    # confine by material: both copper volumes, not the pocket
    pts = np.array([[0, 0, 3.5], [0, 0, 0], [30, 0, 0], [0, 0, 4.9]])
    assert scene.inside_material("G4_Cu", pts).tolist() == [False, True, True, True]
