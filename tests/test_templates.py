"""score4 template: normalisation, multiplicity, response, files read by lh5/hist/uproot, bad input.

Real (small) Geant4 runs: 5.3 MeV alphas on a flat silicon face, and Po-210 between two silicon
detectors facing each other (50 um apart, the source on the lower one's top face), with the
deposits split by particle class.
"""

from __future__ import annotations

import json

import h5py
import numpy as np
import pytest
import yaml

from score4.analysis.templates import build_templates
from score4.cli.main import main
from score4.inputs.response_spec import ResponseConfig
from score4.runner.output import read_results

from conftest import DETECTOR_PAIR, config_dict

# Its module fixture runs once, on one pytest-xdist worker (not once per worker).
pytestmark = pytest.mark.xdist_group("templates")

PAIR = {
    "physics": "lite",
    "targets": DETECTOR_PAIR,
    "source": {
        "decay": "Po210",
        "surface": {"volume": "bottom", "face": "+z"},
        "depth": {"profile": "uniform", "max": "100 nm"},
    },
    "run": {"events": 1500, "seed": 5},
    "output": {"split_by_particle": True},
}
Q_PO210 = 5.40745  # MeV: alpha 5.30433 + recoil 0.10312 (ENSDF)


def _run(tmp_path_factory, name: str, data: dict):
    folder = tmp_path_factory.mktemp(name)
    cfg = folder / f"{name}.yaml"
    cfg.write_text(yaml.safe_dump(data))
    out = folder / f"{name}.h5"
    assert main(["-q", "run", str(cfg), "--out", str(out)]) == 0
    return out


@pytest.fixture(scope="module")
def alpha_run(tmp_path_factory):
    return _run(tmp_path_factory, "alpha", config_dict(run={"events": 2000, "seed": 11}))


@pytest.fixture(scope="module")
def pair_run(tmp_path_factory):
    return _run(tmp_path_factory, "pair", PAIR)


def test_surface_template_integral_is_activity_area_time_over_mass_times_share(
    alpha_run, tmp_path, capsys
):
    """Analytic: a flat-face surface emitter of a Bq/mm2 on A mm2 gives, in a detector of mass m
    over a live time T, a * A * T * share counts; isotropic alphas from a flat face: share 1/2."""
    out = tmp_path / "t.h5"
    assert (
        main(
            [
                "template",
                str(alpha_run),
                "--activity",
                "1 mBq/cm2",
                "--livetime",
                "30 d",
                "--emax",
                "6 MeV",
                "--bins",
                "60",
                "--out",
                str(out),
                "--json",
            ]
        )
        == 0
    )
    report = json.loads(capsys.readouterr().out)
    results = read_results(alpha_run)
    n = results.n_events
    share = np.count_nonzero(results.edep["crystal"]) / n
    assert abs(share - 0.5) < 3 * np.sqrt(0.25 / n)  # half the alphas go inward, all deposit
    area, mass = 100.0, 2.33e-3  # 1 cm x 1 cm face (mm2), 1 cm3 of silicon (kg)
    per_kg_day = 1e-5 * area * 86400 / mass * share  # 1 mBq/cm2 = 1e-5 Bq/mm2
    det = report["detectors"]["crystal"]
    assert report["simulated_decays"] == n
    assert report["activity"]["total_Bq"] == pytest.approx(1e-5 * area, rel=1e-12)
    assert det["mass_kg"] == pytest.approx(mass, rel=1e-12)
    assert det["counts_per_kg_day"] == pytest.approx(per_kg_day, rel=1e-12)
    assert det["counts_per_kg_day_error"] == pytest.approx(
        per_kg_day / np.sqrt(share * n), rel=1e-12
    )
    with h5py.File(out, "r") as f:
        g = f["deposit/detectors/crystal"]
        edges = g["all/binning/axis_0/binedges"][()]
        assert g["all/binning/axis_0/binedges"].attrs["units"] == "keV"
        integral = (g["all/weights"][()] * np.diff(edges)).sum()
        expected = g["all_expected/weights"][()].sum()
    assert integral == pytest.approx(per_kg_day, rel=1e-12)
    assert expected == pytest.approx(1e-5 * area * 30 * 86400 * share, rel=1e-12)
    assert det["expected_counts"] == pytest.approx(expected, rel=1e-12)


def test_multiplicity_templates_add_up_and_match_the_events(pair_run):
    results = read_results(pair_run)
    ts = build_templates(results, "1 mBq/cm2", emax="6 MeV", bins=120)
    stage = ts.stages["deposit"]
    e = np.column_stack([results.edep["top"], results.edep["bottom"]])
    seen = e > 0
    both = seen.all(axis=1)
    assert 0 < both.sum() < len(e)
    for k, d in enumerate(("top", "bottom")):
        kinds = stage.detectors[d]
        assert kinds["all"].counts.sum() == seen[:, k].sum()
        assert kinds["m1"].counts.sum() == (seen[:, k] & ~both).sum()
        assert kinds["m2"].counts.sum() == both.sum()
        np.testing.assert_allclose(
            kinds["m1"].rate + kinds["m2"].rate, kinds["all"].rate, rtol=1e-12
        )
    pair = stage.pairs[("top", "bottom")]
    assert pair.counts.sum() == both.sum() == stage.m2_sum.counts.sum()
    np.testing.assert_array_equal(pair.counts.sum(axis=1), stage.detectors["top"]["m2"].counts)
    # the two detectors share one Po-210 decay: the M2 sum never passes its Q value
    sums = e[both].sum(axis=1)
    assert sums.max() <= Q_PO210 + 1e-3
    # M2 and pairs are per kg of both detectors together
    assert pair.mass_kg == pytest.approx(2 * ts.masses["top"], rel=1e-12)


def test_files_read_back_with_lh5_hist_and_uproot(pair_run, tmp_path):
    lh5 = pytest.importorskip("lh5")
    uproot = pytest.importorskip("uproot")
    out, root = tmp_path / "t.h5", tmp_path / "t.root"
    assert (
        main(
            [
                "-q",
                "template",
                str(pair_run),
                "--activity",
                "2 mBq/cm2",
                "--livetime",
                "1 yr",
                "--emax",
                "6 MeV",
                "--bins",
                "60",
                "--out",
                str(out),
                "--root",
                str(root),
            ]
        )
        == 0
    )
    ts = build_templates(read_results(pair_run), "2 mBq/cm2", emax="6 MeV", bins=60)
    ours = ts.stages["deposit"].detectors["top"]["all"]
    h = lh5.read("deposit/detectors/top/all", out)
    np.testing.assert_allclose(h.binning[0].edges, ours.edges[0])
    np.testing.assert_allclose(h.weights.nda, ours.rate, rtol=1e-12)
    assert h.isdensity
    assert h.attrs["units"] == "counts/(keV kg day)"
    counts = lh5.read("deposit/detectors/top/all_counts", out).view_as("hist")  # a hist.Hist
    np.testing.assert_array_equal(counts.values(), ours.counts)
    assert list(counts.axes[0].edges) == pytest.approx(list(ours.edges[0]))
    pair = lh5.read("deposit/pairs/top__bottom_counts", out).view_as("hist")
    assert pair.values().sum() == ts.stages["deposit"].pairs[("top", "bottom")].counts.sum()
    norm = lh5.read("normalisation", out)
    assert norm["simulated_decays"].value == 1500
    assert norm["area"].value == pytest.approx(4.0)
    assert norm["area"].attrs["units"] == "mm2"
    with uproot.open(root) as f:
        th1 = f["deposit_top_all"]
        np.testing.assert_allclose(th1.values(), ours.rate, rtol=1e-12)
        np.testing.assert_allclose(th1.errors(), ours.error, rtol=1e-12)
        assert th1.member("fXaxis").member("fTitle") == "energy [keV]"
        th2 = f["deposit_pair_top__bottom"]
        np.testing.assert_allclose(
            th2.values(), ts.stages["deposit"].pairs[("top", "bottom")].rate, rtol=1e-12
        )
        assert json.loads(str(f["normalisation"]))["simulated_decays"] == 1500


def test_particle_classes_and_response(pair_run):
    results = read_results(pair_run)
    s = results.scores
    for d in ("top", "bottom"):
        total = s["edep_alpha"][d] + s["edep_electron"][d] + s["edep_ion"][d]
        np.testing.assert_allclose(total, s["edep"][d], rtol=1e-9, atol=1e-12)
    # the only ion is the 103 keV Pb-206 recoil (TRIM replay): it stays below its start energy
    p = results.primaries
    recoil = p.energy[p.particle == "Pb206"].max()
    alpha = p.energy[p.particle == "alpha"].max()
    assert s["edep_ion"]["bottom"].max() <= recoil * (1 + 1e-9)
    assert np.count_nonzero(s["edep_ion"]["bottom"]) > 0.4 * results.n_events
    assert s["edep_alpha"]["top"].max() <= alpha * (1 + 1e-9)
    response = ResponseConfig.model_validate(
        {
            "quenching": {"alpha": 0.25, "ion": 0.05},
            "resolution": {"a": "20 keV"},
            "threshold": "50 keV",
            "seed": 3,
        }
    )
    ts = build_templates(results, "1 mBq/cm2", emax="6 MeV", bins=120, response=response)
    from score4.analysis.response import apply_response, visible_energy

    seen = apply_response(results.scores, ["bottom"], response)["bottom"]
    quenched = visible_energy(results.scores, "bottom", response)
    shown = seen > 0
    assert (seen[shown] > 0.05).all()  # the threshold
    # pulls of the smearing, away from the threshold (near it only upward fluctuations pass)
    far = shown & (quenched > 0.05 + 5 * 0.02)
    pull = (seen[far] - quenched[far]) / 0.02
    assert far.sum() > 300
    assert abs(pull.mean()) < 4 / np.sqrt(far.sum())
    assert abs(pull.std() - 1) < 4 / np.sqrt(2 * far.sum())
    assert ts.stages["visible"].detectors["bottom"]["all"].counts.sum() == shown.sum()
    # quenched alphas (and their recoils) sit near a quarter of 5.3 MeV, below 2 MeV
    assert np.median(quenched[quenched > 1.0]) < 2.0


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--activity", "1 mBq"], "surface source"),
        (["--activity", "5 mBq/kg"], "give an activity per area"),
        (["--activity", "3"], "has no unit"),
        (["--activity", "1 mBq/cm2", "--detector", "nothing"], "not a volume"),
        (["--activity", "1 mBq/cm2", "--livetime", "3 parsecs"], "--livetime"),
    ],
)
def test_bad_input_is_one_line_and_writes_nothing(alpha_run, tmp_path, capsys, args, message):
    out = tmp_path / "t.h5"
    assert main(["template", str(alpha_run), *args, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0
    assert err.startswith("score4: error:")
    assert message in err
    assert not out.exists()


def test_response_problems_exit_2(alpha_run, tmp_path, capsys):
    out = tmp_path / "t.h5"
    cases = [
        ("quenching: {alpha: 5}\n", "quenching.alpha"),  # out of range
        ("quenching: {alpha: 0.2}\nresolution: {a: 5 keV}\n", "split_by_particle"),
    ]
    for i, (text, named) in enumerate(cases):
        response = tmp_path / f"r{i}.yaml"
        response.write_text(text)
        args = [str(alpha_run), "--activity", "1 mBq/cm2", "--response", str(response)]
        assert main(["template", *args, "--out", str(out)]) == 2
        assert named in capsys.readouterr().err
    assert not out.exists()


def test_results_without_normalisation_are_refused(alpha_run, tmp_path, capsys):
    old = tmp_path / "old.h5"
    old.write_bytes(alpha_run.read_bytes())
    with h5py.File(old, "r+") as f:  # a file of an older score4: no normalisation entries
        for key in ("volumes", "source", "simulated_decays", "activity_nuclide"):
            del f["run"].attrs[key]
    out = tmp_path / "t.h5"
    assert main(["template", str(old), "--activity", "1 mBq/cm2", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "no normalisation data" in err
    assert "score4 run" in err
    assert err.count("\n") == 1
    assert not out.exists()


def test_resolution_formula_and_table(tmp_path):
    from score4.analysis.response import sigma_function

    formula = ResponseConfig.model_validate(
        {"resolution": {"a": "1 keV", "b": "0.3 eV", "c": 0.002}}
    ).resolution
    e = np.array([0.0, 1.0, 2.6])  # MeV
    expected = np.sqrt(1e-3**2 + 0.3e-6 * e + (0.002 * e) ** 2)
    np.testing.assert_allclose(sigma_function(formula)(e), expected, rtol=1e-12)
    table = tmp_path / "sigma.txt"
    table.write_text("# unit: keV\n0 1\n1000 3\n")
    tab = ResponseConfig.model_validate(
        {"resolution": {"kind": "table", "file": str(table)}}
    ).resolution
    np.testing.assert_allclose(sigma_function(tab)(np.array([0.5, 2.0])), [2e-3, 3e-3])


def test_the_run_configurations_response_applies_without_response_file(pair_run, tmp_path, capsys):
    run = tmp_path / "with_response.h5"
    run.write_bytes(pair_run.read_bytes())
    with h5py.File(run, "r+") as f:  # as if the run's YAML had a response: section
        config = json.loads(f["run"].attrs["config"])
        config["response"] = {"threshold": "6 MeV"}
        f["run"].attrs["config"] = json.dumps(config)
    assert (
        main(
            [
                "template",
                str(run),
                "--activity",
                "1 mBq/cm2",
                "--out",
                str(tmp_path / "t.h5"),
                "--json",
            ]
        )
        == 0
    )
    report = json.loads(capsys.readouterr().out)
    assert report["stage"] == "visible"
    assert report["detectors"]["bottom"]["counts_per_kg_day"] == 0  # nothing above 6 MeV
    assert report["detectors"]["bottom"]["before_response"]["simulated_counts"] > 0


def test_templates_as_hist_objects_with_errors(pair_run, tmp_path):
    from score4.analysis.templates import read_hist, write_templates_h5

    ts = build_templates(read_results(pair_run), "1 mBq/cm2", emax="6 MeV", bins=60)
    out = write_templates_h5(ts, tmp_path / "t.h5")
    ours = ts.stages["deposit"].detectors["bottom"]["m1"]
    h = read_hist(out, "deposit/detectors/bottom/m1")
    np.testing.assert_allclose(h.values(), ours.rate, rtol=1e-12)
    np.testing.assert_allclose(np.sqrt(h.variances()), ours.error, rtol=1e-12)
    np.testing.assert_allclose(h.axes[0].edges, ours.edges[0])
    pair = read_hist(out, "deposit/pairs/top__bottom")
    assert pair.ndim == 2
    assert pair.sum().value == pytest.approx(
        ts.stages["deposit"].pairs[("top", "bottom")].rate.sum()
    )
