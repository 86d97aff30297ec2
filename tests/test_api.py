"""score4 as a library (score4.api, issue 17 item 7): a user's own geant4_pybind application
gives the same events as ``score4 run`` on the same world, the example runs, errors are one
line. Geant4 runs in spawned processes (tests/helpers/g4_api.py); pytest itself never imports it."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from score4.cli.main import main
from score4.inputs.config import parse_config
from score4.runner.output import read_results
from score4.world.resolve import build_scene

from helpers.spawn import run_in_spawned_process

HERE = Path(__file__).parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))
from helpers import g4_api as W  # noqa: E402 (its module level is numpy only; Geant4 stays in the functions)

#: A holder plate and a crystal 0.5 mm above it, turned by 20 degrees about z (GDML by hand).
GDML = """<?xml version="1.0" encoding="UTF-8"?>
<gdml>
  <define>
    <rotation name="turn" z="20" unit="deg"/>
  </define>
  <materials/>
  <solids>
    <box name="WorldBox" x="40" y="40" z="40" lunit="mm"/>
    <box name="HolderBox" x="30" y="30" z="2" lunit="mm"/>
    <box name="CrystalBox" x="4" y="4" z="2" lunit="mm"/>
  </solids>
  <structure>
    <volume name="HolderLV">
      <materialref ref="G4_Cu"/><solidref ref="HolderBox"/>
    </volume>
    <volume name="CrystalLV">
      <materialref ref="G4_CALCIUM_TUNGSTATE"/><solidref ref="CrystalBox"/>
    </volume>
    <volume name="WorldLV">
      <materialref ref="G4_Galactic"/><solidref ref="WorldBox"/>
      <physvol name="holder">
        <volumeref ref="HolderLV"/><position name="hp" z="-1" unit="mm"/>
      </physvol>
      <physvol name="crystal">
        <volumeref ref="CrystalLV"/><position name="cp" z="1.5" unit="mm"/>
        <rotationref ref="turn"/>
      </physvol>
    </volume>
  </structure>
  <setup name="Default" version="1.0"><world ref="WorldLV"/></setup>
</gdml>
"""


def _call(name, *args):
    sys.path.insert(0, str(HERE))
    from helpers import g4_api

    return getattr(g4_api, name)(*args)


def spawned(name, *args):
    return run_in_spawned_process(_call, name, *args)


@pytest.fixture(scope="module")
def gdml(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("api") / "module.gdml"
    path.write_text(GDML)
    return path


def test_own_application_equals_score4_run(gdml, tmp_path):
    """The same world (read from GDML by the user's program, or by score4 from the config), the
    same rough face, source and seed: per-event deposits identical, event by event (both paths
    share the scene, tiling, source, event feed and heavy-ion replay code)."""
    events, seed, histories = 300, 3, 100
    config: dict = {
        "physics": {"mode": "lite", "trim_histories": histories},
        "world": {"gdml": str(gdml)},
        "surfaces": {"pyr": W.PYRAMIDS},
    }
    config["targets"] = [
        {
            "volume": "crystal",
            "rough": [{"face": "-z", "surface": "pyr", "base_thickness": "1 um"}],
        },
        {"volume": "holder"},
    ]
    config["source"] = {
        "surface": {"volume": "crystal", "face": "-z"},
        "decay": "Po210",
        "depth": {"profile": "exponential", "mean": "20 nm"},
    }
    config["run"] = {"events": events, "seed": seed}
    cfg = tmp_path / "run.yaml"
    cfg.write_text(yaml.safe_dump(config))
    out = tmp_path / "run.h5"
    assert main(["run", str(cfg), "--out", str(out), "-q"]) == 0
    ref = read_results(out)

    own = spawned("own_run", str(gdml), events, seed, histories)
    assert own["names"] == ["crystal", "holder"] == list(ref.edep)
    assert own["holder_columns"] == ["holder"]
    assert own["scored_lvs"] == {"crystal": 2}  # the crystal and the multi-union patch
    assert own["patches"] == 40 * 40  # 4 mm face, 100 um patches
    assert own["removed"]  # lite: bremsstrahlung and the gamma process taken out
    assert own["materials"] == ["G4_CALCIUM_TUNGSTATE"]  # vertices in the crystal's material
    assert own["replayed"] == 1  # the last event's Pb-206 recoil went through the replay
    for j, name in enumerate(own["names"]):
        np.testing.assert_array_equal(own["edep"][:, j], ref.edep[name])
    # and the physics is there: the alpha into the crystal or out into the copper
    crystal, holder = ref.edep["crystal"], ref.edep["holder"]
    assert np.mean(crystal > 5.0) == pytest.approx(0.5, abs=0.1)
    assert (holder > 0).sum() > 0.3 * events
    assert (crystal + holder).max() <= 5.4075 + 1e-3  # Po-210's Q value


def test_stacking_action_replays_heavy_ion_secondaries(gdml):
    """A Pb-206 pushed onto Geant4's stack in every event of a proton run is taken by the
    replay's stacking action and replayed; the event gains its energy in the holder (the ion
    flies into the copper), the protons' own deposits stay the same."""
    out = spawned("own_secondaries", str(gdml), 20)
    assert out["intercepted_plain"] == 0  # 5 MeV protons make no heavy-ion secondary here
    assert out["counts"] == [1] * 20  # one intercepted ion per event
    holder = out["names"].index("holder")
    gained = out["pushed"][:, holder] - out["plain"][:, holder]
    np.testing.assert_allclose(gained, out["booked"], rtol=0, atol=1e-12)
    np.testing.assert_allclose(gained, 0.103144, rtol=0, atol=1e-9)  # it stops in the copper


def test_api_errors_are_one_line(gdml):
    messages = spawned("api_errors", str(gdml))
    expected = [
        (
            "roughen('cristal', '-z'): no volume named 'cristal' in world WorldLV_PV; closest: "
            "crystal, CrystalLV; World.model.rows() lists the volumes"
        ),
        "roughen('crystal', '-z'): surface: height: '10' has no unit",
        "roughen('crystal', '-z'): base_thicknes: unknown key; did you mean 'base_thickness'?",
        "runs into sister volume 'crystal' (free gap there: 500 um)",
        (
            "source.surface.face: crystal: no face '+q' on a G4Box; its faces: +x, -x, +y, -y, "
            "+z, -z; groups: all"
        ),
        "source: energy: '5' has no unit",
        "source.decay.implantation: per-atom histories need score4 run",
        "roughen(x, '-z'): give a G4VPhysicalVolume, a G4LogicalVolume or a volume name, not a G4",
        "roughen(lonely, '-z'): lonely is not in this world",
    ]
    assert len(messages) == len(expected)
    for message, part in zip(messages, expected, strict=True):
        assert part in message, message
        assert "\n" not in message


def test_example_own_application_runs():
    """examples/own_application.py, as a user runs it (a fresh process, lite physics)."""
    proc = subprocess.run(
        [sys.executable, str(ROOT / "examples" / "own_application.py"), "--events", "300"],
        capture_output=True,
        text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
        check=False,
        timeout=600,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    lines = proc.stdout.splitlines()
    table = {
        line.split()[0]: line.split()[1:]
        for line in lines
        if line.split()[:1] and line.split()[0] in ("crystal", "holder", "clamp")
    }
    crystal, holder, clamp = (table[n] for n in ("crystal", "holder", "clamp"))
    assert int(crystal[1]) == 300  # every decay leaves its alpha or its recoil in the crystal
    assert 0 < int(holder[1]) < 300  # alphas leaving the rough face reach the copper below
    assert clamp == ["0.0000", "0", "0"]  # above 5 mm of CaWO4: out of an alpha's reach
    total = next(line for line in lines if line.startswith("sum over volumes"))
    assert float(total.split("max ")[1].split()[0]) <= 5.4075 + 1e-3


def test_roughen_never_changes_placed_layers(tmp_path):
    """Layers placed by an earlier roughen do not change: a wall whose layer reaches into a
    placed ring's slab (a polycone's shoulder and the wall above it) and into on a tube's wall
    after its end face (their joint cut) are refused in one line naming the faces and the
    rule, and the placed layers keep their radii and cells; the wall first (or both in one
    call, as a configuration gives them) narrows the ring as ``score4 run`` does."""
    gdml = tmp_path / "step.gdml"
    gdml.write_text(W.STEP_GDML)
    out = spawned("api_ring_order", str(gdml))
    assert out["faces"] == ["seg_0", "seg_1", "seg_2", "seg_3", "seg_4"]
    message = out["wall_after_ring"]
    assert message.startswith(
        "roughen('step', 'seg_3'): the layer on face seg_3 of 'step' reaches into the slab of "
        "the rough ring on face seg_2, which is placed already and cannot give way to it "
        "(r = 2 .. 3 mm would become 2.01101 .. 3 mm): roughen a wall before the rings it meets"
    ), message
    assert out["ring_kept"]
    assert out["ring_radii"] == (2.0, 3.0)
    message = out["wall_after_end"]
    assert message.startswith(
        "roughen('rod', 'outer'): the layer on face +z of 'rod' is placed already and would "
        "change (into on faces that share an edge"
    ), message
    assert out["end_kept"]
    assert out["end_rest"] is None
    assert out["ends"] == ["+z", "-z"]
    for message in (out["wall_after_ring"], out["wall_after_end"]):
        assert "\n" not in message

    together = spawned("api_ring_together", str(gdml))
    config = {
        "world": {"gdml": str(gdml)},
        "surfaces": {"pyr": W.PYRAMIDS},
        "targets": [
            {"volume": "step", "rough": [{"face": ["seg_2", "seg_3"], "surface": "pyr"}]},
            {"volume": "rod", "rough": [{"face": ["+z", "outer"], "surface": "pyr", "into": True}]},
        ],
        "source": {"surface": {"volume": "step", "face": "seg_2"}, "particle": "alpha"},
    }
    config["source"]["energy"] = "5 MeV"
    scene = build_scene(parse_config(config))
    ring = scene.layer("step", "seg_2")
    assert together["layers"] == ["seg_2"]
    assert together["ring"] == ring.ring
    assert ring.ring[0] == pytest.approx(2.0 + scene.layer("step", "seg_3").thickness, abs=1e-12)
    assert together["ring_cells"] == int(ring.mask.sum())
    assert together["rod_layers"] == ["+z", "outer"]
    assert together["end_rest"] == scene.layer("rod", "+z").rest_radii
    assert together["wall_top"] == pytest.approx(1.0 - together["end_thickness"], abs=1e-12)
    assert together["scored"]["rod"] > 2  # the cut rod and the patches of both layers


#: a copper disk (r 10 mm, 10 mm high) with a post (r 7 mm, 10 mm high) on it, a union, placed
#: off the origin (GDML by hand)
STACK_GDML = """<?xml version="1.0" encoding="UTF-8"?>
<gdml><define/><materials/><solids>
<box name="WorldBox" x="100" y="100" z="100" lunit="mm"/>
<tube name="Disk" rmin="0" rmax="10" z="10" deltaphi="360" aunit="deg" lunit="mm"/>
<tube name="Post" rmin="0" rmax="7" z="10" deltaphi="360" aunit="deg" lunit="mm"/>
<union name="Stack"><first ref="Disk"/><second ref="Post"/>
  <position name="pp" z="10" unit="mm"/></union>
</solids><structure>
<volume name="StackLV"><materialref ref="G4_Cu"/><solidref ref="Stack"/></volume>
<volume name="WorldLV"><materialref ref="G4_Galactic"/><solidref ref="WorldBox"/>
  <physvol name="stack"><volumeref ref="StackLV"/>
    <position name="sp" x="3" y="-2" z="-5" unit="mm"/></physvol></volume>
</structure><setup name="Default" version="1.0"><world ref="WorldLV"/></setup></gdml>
"""


def _foot_rays(n: int) -> list:
    """Rays (world) from 0.5 mm outside the post's foot (r 7 mm, z 5 mm in the stack's frame),
    in through it to within 50 um of it and on across the post: half through the disk's slab
    under the foot."""
    rng = np.random.default_rng(12)
    phi = rng.uniform(0.0, 2 * np.pi, n)
    start = np.array([7.0, 5.0]) + 0.5 * rng.uniform(0.8, 1.2, (n, 2))
    aim = np.array([7.0, 5.0]) + rng.uniform(-0.05, 0.05, (n, 2))
    aim[::2, 1] = 5.0 - 0.005
    aim[:, 0] -= 3.0
    at = np.array([3.0, -2.0, -5.0])
    o = np.column_stack([start[:, 0] * np.cos(phi), start[:, 0] * np.sin(phi), start[:, 1]])
    a = np.column_stack([aim[:, 0] * np.cos(phi), aim[:, 0] * np.sin(phi), aim[:, 1]])
    d = (a - o) / np.linalg.norm(a - o, axis=1, keepdims=True)
    return [(p.tolist(), w.tolist()) for p, w in zip(o + at, d, strict=True)]


@pytest.mark.deep  # three Geant4 processes, each with the union's face areas (~20 s CPU)
def test_roughen_cuts_a_booleans_shared_edge_in_one_call(tmp_path):
    """into on the disk's top and the post's wall of a union (faces of two constituents that
    share the post's foot, cut together): one roughen call with both faces gives the world
    score4 run builds from the configuration (the same volumes crossed at the same points,
    1e-9 mm, by 12 rays through the foot; the same layer thicknesses); one face after the
    other is refused in one line that says to give both in one call, the placed layer kept
    as it was."""
    from helpers.export_paths import _call as export_call
    from helpers.export_paths import assert_same_paths

    gdml = tmp_path / "stack.gdml"
    gdml.write_text(STACK_GDML)
    faces = ["first.+z", "second.outer"]
    rays = _foot_rays(12)
    apart = spawned("api_joint", str(gdml), "stack", faces, rays, False)
    message = apart["refused"]
    assert message.startswith(
        "roughen('stack', 'second.outer'): the layer on face first.+z of 'stack' is placed "
        "already and would change (into on faces that share an edge: both layers are laid out "
        "on their joint cut); give these faces in one call (a list of faces)"
    ), message
    assert "\n" not in message
    assert apart["kept"]
    together = spawned("api_joint", str(gdml), "stack", faces, rays, True)
    assert together["layers"] == faces
    assert together["scored"]["stack"] > 2  # the cut union and the patches of both layers
    config = {
        "physics": "lite",
        "world": {"gdml": str(gdml)},
        "surfaces": {"pyr": W.PYRAMIDS},
        "targets": [
            {"volume": "stack", "rough": [{"face": faces, "surface": "pyr", "into": True}]}
        ],
        "source": {"surface": {"volume": "stack", "face": "first.+z"}, "particle": "geantino"},
    }
    config["source"]["energy"] = "1 MeV"
    path = tmp_path / "stack.yaml"
    path.write_text(yaml.safe_dump(config))
    scene = build_scene(parse_config(config))
    assert together["thickness"] == [scene.layer("stack", f).thickness for f in faces]
    ours = run_in_spawned_process(export_call, "trace_built", str(path), rays)
    assert_same_paths(ours, together["paths"])
    rough = sum(any("_rough" in (v or "") for v, _ in p) for p in ours)
    assert rough >= len(rays) // 2
    # the world the refused call left: the disk's layer alone, other paths
    assert any(
        [v for v, _ in a] != [v for v, _ in b] for a, b in zip(ours, apart["paths"], strict=True)
    )
