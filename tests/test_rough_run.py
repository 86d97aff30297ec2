"""Rough faces end to end: patches placed by Geant4 where the sampler puts vertices, spectra, vertex
files."""

from __future__ import annotations

import h5py
import numpy as np
import pytest

from score4.cli.main import main
from score4.errors import ConfigError, PhysicsUnavailableError
from score4.inputs.config import parse_config
from score4.runner.engine import run
from score4.runner.output import read_results
from score4.source.build import make_source
from score4.source.vertex_file import write_vertex_file
from score4.world.resolve import build_scene
from score4.world.scene import face_frame

from conftest import config_dict

PYRAMIDS = {
    "kind": "spikes",
    "nx": 5,
    "ny": 5,
    "width": "20 um",
    "height": "10 um",
    "height_sigma": "2 um",
    "seed": 4,
}
RANDOM = {
    "kind": "random",
    "nx": 40,
    "ny": 40,
    "pitch": "2.5 um",
    "sq": "1 um",
    "corr_length": "8 um",
    "seed": 2,
}
TARGET = {
    "name": "crystal",
    "material": "G4_Si",
    "size": ["0.4 mm", "0.2 mm", "0.3 mm"],
    "position": ["0 mm", "0 mm", "-0.15 mm"],
}


def geantino_vertex_run(
    tmp_path, face: str, surface: dict, solid: str, events: int = 300, layout: str = "placements"
):
    """Vertices sampled below the rough face, then geantinos from them along the inward normal."""
    target = {
        **TARGET,
        "rough": [{"face": face, "surface": "s", "solid": solid, "native_layout": layout}],
    }
    data = config_dict(
        surfaces={"s": surface},
        targets=[target],
        source={
            "particle": "geantino",
            "energy": "1 MeV",
            "surface": {"volume": "crystal", "face": face},
            "depth": {"profile": "exponential", "mean": "0.5 um"},
        },
        output={"track_length": True},
        run={"events": events, "seed": 5},
    )
    config = parse_config(data)
    scene = build_scene(config)
    primaries = make_source(config, scene).primaries(np.random.default_rng(1), 0, events)
    frame = face_frame(config.targets[0], face)
    primaries.direction[:] = -frame.normal
    vfile = write_vertex_file(tmp_path / "v.h5", primaries, {}, 1)
    replay = parse_config({**data, "source": {"vertices": str(vfile)}})
    return (
        config,
        frame,
        read_results(run(replay, tmp_path / "g.h5", progress=False, echo=lambda m: None)),
    )


@pytest.mark.parametrize(
    ("face", "surface", "solid", "layout"),
    [
        pytest.param(*("+z", PYRAMIDS, "multiunion", "placements"), marks=pytest.mark.deep),
        pytest.param(*("-x", RANDOM, "tessellated", "placements"), marks=pytest.mark.deep),
        pytest.param(*("+y", PYRAMIDS, "tessellated", "placements"), marks=pytest.mark.deep),
        ("-x", PYRAMIDS, "multiunion", "replicas"),
        ("+z", RANDOM, "tessellated", "nested"),
        ("+y", RANDOM, "blocks", "placements"),
        pytest.param(*("-z", PYRAMIDS, "blocks", "replicas"), marks=pytest.mark.deep),
    ],
)
def test_geantino_path_through_placed_patches_matches_the_sampled_vertex(
    tmp_path, face, surface, solid, layout
):
    """A geantino started at a vertex below the rough top and sent along the inward face normal
    stays in material (the surface is a height field) down through the slab and the box: its path
    is exactly the vertex's height above the far face. A misplaced, mis-rotated or missing patch,
    or a vertex outside the material, breaks this."""
    config, frame, r = geantino_vertex_run(tmp_path, face, surface, solid, layout=layout)
    height = frame.to_local(r.primaries.position)[:, 2]  # above the box face, along n
    axis = int(np.flatnonzero(frame.normal)[0])
    assert (
        height > 0
    ).mean() > 0.9  # most vertices are in the rough layer (base slab 1 um + the surface)
    np.testing.assert_allclose(
        r.scores["track_length"]["crystal"],
        height + config.targets[0].size[axis],
        rtol=0,
        atol=1e-9,
    )
    assert build_scene(config).inside_target("crystal", r.primaries.position).all()


def alpha_config(rough: bool, events: int = 1500):
    # 2 mm x 1 mm: few alphas leave through the side walls (range 27 um)
    wide = {**TARGET, "size": ["2 mm", "1 mm", "0.3 mm"]}
    target = {**wide, "rough": [{"face": "+z", "surface": "p"}]} if rough else wide
    return parse_config(
        config_dict(
            # the paper's pyramids: 10 um wide and high, smaller than the 27 um alpha range
            surfaces={
                "p": {"kind": "spikes", "nx": 20, "ny": 10, "width": "10 um", "height": "10 um"}
            },
            targets=[target],
            source={
                "particle": "alpha",
                "energy": "5.3 MeV",
                "direction": "isotropic",
                "surface": {"volume": "crystal", "face": "+z"},
                "depth": {"profile": "exponential", "mean": "20 nm"},
            },
            run={"events": events, "seed": 11},
        )
    )


def test_rough_surface_moves_alpha_counts_below_full_energy(tmp_path):
    """Paper figure, small: alphas leaving a steep pyramid face re-enter the neighbours and deposit
    a
    part of their energy. Flat face: the outward half escapes after 20 nm / cos(theta) (above
    0.2 MeV only if cos(theta) < 0.02), the inward half deposits all (except near the side walls).
    Rough: many outward alphas deposit between 0.2 and 4 MeV. Measured with 3000 events (seed 11):
    flat 42, rough 655 events in that window."""
    flat = read_results(
        run(alpha_config(False), tmp_path / "flat.h5", progress=False, echo=lambda m: None)
    ).edep["crystal"]
    rough = read_results(
        run(alpha_config(True), tmp_path / "rough.h5", progress=False, echo=lambda m: None)
    ).edep["crystal"]
    mid = lambda e: int(((e > 0.2) & (e < 4.0)).sum())  # noqa: E731
    n = len(flat)
    # 1500 events: flat ~1.4 %, rough ~22 % (binomial sigma ~1 %)
    assert mid(flat) < 0.03 * n
    assert mid(rough) > 0.15 * n
    assert mid(rough) - mid(flat) > 5 * np.sqrt(mid(rough) + mid(flat))
    # never more than emitted (nuclear stopping, which overshot it, is off: sim.physics)
    assert rough.max() <= 5.3 + 1e-6


def test_po210_source_emits_alpha_and_recoil_per_event(tmp_path):
    alpha_config(True, events=100).model_copy()
    data = config_dict(
        surfaces={"p": {"kind": "spikes", "nx": 10, "ny": 5, "width": "40 um", "height": "40 um"}},
        targets=[{**TARGET, "rough": [{"face": "+z", "surface": "p"}]}],
        source={
            "particle": None,
            "energy": None,
            "decay": "Po210",
            "surface": {"volume": "crystal", "face": "+z"},
            "depth": {"profile": "uniform", "min": "10 nm", "max": "50 nm"},
        },
        run={"events": 100, "seed": 3},
    )
    r = read_results(
        run(parse_config(data), tmp_path / "po.h5", progress=False, echo=lambda m: None)
    )
    p = r.primaries
    assert len(p.event) == 200
    assert set(p.particle[0::2]) == {"alpha"}
    assert set(p.particle[1::2]) == {"Pb206"}
    np.testing.assert_allclose(p.direction[0::2], -p.direction[1::2], atol=1e-12)
    depth = p.extra["depth"]
    assert depth.min() >= 1e-5
    assert depth.max() <= 5e-5
    # alpha + recoil energy can be deposited at most
    assert r.edep["crystal"].max() <= 5.30433 + 0.1032 + 1e-6


def test_vertex_file_reproduces_the_direct_run(tmp_path):
    """score4 vertices draws chunks like score4 run: running the file gives the same events."""
    data = config_dict(
        surfaces={"p": {"kind": "spikes", "nx": 10, "ny": 5, "width": "40 um", "height": "40 um"}},
        targets=[{**TARGET, "rough": [{"face": "+z", "surface": "p"}]}],
        source={
            "surface": {"volume": "crystal", "face": "+z"},
            "depth": {"profile": "exponential", "mean": "20 nm"},
        },
        run={"events": 120, "seed": 9, "chunk_events": 50},
    )
    import yaml

    cfg = tmp_path / "c.yaml"
    cfg.write_text(yaml.safe_dump(data))
    vfile = tmp_path / "v.h5"
    assert main(["vertices", str(cfg), "--out", str(vfile)]) == 0
    with h5py.File(vfile) as f:
        assert f["vertices/xloc"].attrs["units"] == "mm"
        assert f["vertices/depth"].attrs["units"] == "mm"
        assert (
            f["vertices"].attrs["datatype"].startswith("table{event,particle,energy,xloc,yloc,zloc")
        )
        assert len(f["vertices/event"]) == 120
        np.testing.assert_array_equal(
            f["vtx/pos/zloc"][()], f["vertices/zloc"][()]
        )  # one primary per event here
        assert f["vtx/pos"].attrs["datatype"] == "table{xloc,yloc,zloc}"
        assert f["vtx/pos/xloc"].attrs["units"] == "mm"
    assert main(["vertices", str(cfg), "--out", str(vfile)]) == 2  # exists: refused, file kept
    direct = read_results(
        run(parse_config(data), tmp_path / "direct.h5", progress=False, echo=lambda m: None)
    )
    from_file = {**data, "source": {"vertices": str(vfile)}}
    replay = read_results(
        run(parse_config(from_file), tmp_path / "replay.h5", progress=False, echo=lambda m: None)
    )
    np.testing.assert_array_equal(direct.primaries.position, replay.primaries.position)
    np.testing.assert_array_equal(direct.edep["crystal"], replay.edep["crystal"])
    too_many = {**from_file, "run": {**data["run"], "events": 121}}
    with pytest.raises(ConfigError, match="holds 120 events"):
        run(parse_config(too_many), tmp_path / "x.h5", progress=False, echo=lambda m: None)


def test_bad_rough_configs_fail_before_any_worker_starts(tmp_path):
    bad_size = config_dict(
        surfaces={"p": {"kind": "spikes", "nx": 3, "ny": 3, "width": "30 um", "height": "10 um"}},
        targets=[{**TARGET, "rough": [{"face": "+z", "surface": "p"}]}],
    )
    with pytest.raises(ConfigError, match=r"targets.0.rough.0 .*nearest valid"):
        run(parse_config(bad_size), tmp_path / "a.h5", progress=False, echo=lambda m: None)
    with pytest.raises(ConfigError, match="no target is made of 'G4_Cu'"):
        run(
            parse_config(config_dict(source={"confine": "G4_Cu"})),
            tmp_path / "b.h5",
            progress=False,
            echo=lambda m: None,
        )
    assert not list(tmp_path.iterdir())


def test_surface_taller_than_the_gap_to_a_facing_target_is_refused():
    """A second target 8 um above the face: 10 um pyramids (plus the 1 um base) do not fit."""
    facing = {
        "name": "lid",
        "material": "G4_Cu",
        "size": ["0.4 mm", "0.2 mm", "0.1 mm"],
        "position": ["0 mm", "0 mm", "0.058 mm"],
    }
    data = config_dict(
        surfaces={"p": {"kind": "spikes", "nx": 20, "ny": 10, "width": "20 um", "height": "10 um"}},
        targets=[{**TARGET, "rough": [{"face": "+z", "surface": "p"}]}, facing],
    )
    with pytest.raises(ConfigError, match=r"runs into target 'lid' \(free gap there: 8 um\)"):
        build_scene(parse_config(data))
    facing["position"] = ["0 mm", "0 mm", "0.0611 mm"]  # 11.1 um gap: fits
    assert build_scene(parse_config(data)).layers[0].thickness < 0.0111


def test_nuclide_sources_need_radioactive_decay_data(tmp_path):
    data = config_dict(source={"particle": None, "energy": None, "nuclide": "Pb210"})
    with pytest.raises(PhysicsUnavailableError, match="lite mode cannot do decays"):
        run(
            parse_config({**data, "physics": "lite"}),
            tmp_path / "n.h5",
            progress=False,
            echo=lambda m: None,
        )
    assert not list(tmp_path.iterdir())


def test_confinement_to_a_material_no_target_at_the_face_has_fails_with_counts(tmp_path):
    """Vertices drawn at a silicon crystal's face are never in the copper block beside it."""
    copper = {
        "name": "block",
        "material": "G4_Cu",
        "size": ["1 mm", "1 mm", "1 mm"],
        "position": ["7 mm", "0 mm", "0 mm"],
    }
    data = config_dict(
        targets=[config_dict()["targets"][0], copper],
        source={"confine": "G4_Cu", "depth": {"profile": "exponential", "mean": "20 nm"}},
    )
    with pytest.raises(ConfigError, match="outside the confinement"):
        run(parse_config(data), tmp_path / "c.h5", progress=False, echo=lambda m: None)


def test_overlapping_targets_are_refused():
    second = {
        "name": "other",
        "material": "G4_Cu",
        "size": ["1 mm", "1 mm", "1 mm"],
        "position": ["0.5 mm", "0 mm", "0 mm"],
    }
    with pytest.raises(ConfigError, match="'crystal' and 'other' overlap"):
        build_scene(parse_config(config_dict(targets=[config_dict()["targets"][0], second])))


def test_vertex_file_sources_refuse_keys_they_would_ignore(tmp_path):
    with pytest.raises(
        ConfigError, match=r"vertices: a vertex file already holds .*drop depth, direction"
    ):
        parse_config(
            config_dict(
                source={
                    "vertices": "v.h5",
                    "particle": None,
                    "energy": None,
                    "surface": None,
                    "direction": "inward",
                    "depth": {"profile": "exponential", "mean": "1 nm"},
                }
            )
            | {}
        )


def test_replaying_a_nuclide_vertex_file_needs_decay_data(tmp_path):
    from score4.source.emitters import NuclideEmitter, make_primaries

    p = make_primaries(NuclideEmitter("Pb210"), np.random.default_rng(0), np.zeros((5, 3)))
    vfile = write_vertex_file(tmp_path / "n.h5", p, {"source": {"nuclide": "Pb210"}}, 0)
    data = config_dict(source={"vertices": str(vfile)}, run={"events": 5, "seed": 1})
    data["source"] = {"vertices": str(vfile)}
    with pytest.raises(PhysicsUnavailableError, match="lite mode cannot do decays"):
        run(parse_config(data), tmp_path / "n_out.h5", progress=False, echo=lambda m: None)


def test_depth_window_errors_use_the_config_names():
    data = config_dict(source={"depth": {"profile": "zero", "min": "1 nm"}})
    from score4.source.build import make_source

    config = parse_config(data)
    scene = build_scene(config)
    with pytest.raises(ConfigError, match=r"^source\.depth: min"):
        make_source(config, scene)
