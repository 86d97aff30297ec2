"""score4 model: predicted spectra from templates, the binned Poisson fit, its pulls, bad input.

Templates come from two real small Geant4 runs: Po-210 on the facing faces of two silicon
detectors (50 um apart); the model is the lower detector's spectrum. Pseudo-data drawn from the
model at known activities must give back those activities: pulls ~ N(0, 1).
"""

from __future__ import annotations

import json

import numpy as np
import pytest
import yaml

from score4.analysis.model import build_model, fit_model, load_model, pseudo_data
from score4.cli.main import main

from conftest import DETECTOR_PAIR

# Its module fixture runs once, on one pytest-xdist worker (not once per worker).
pytestmark = pytest.mark.xdist_group("model")


def _template(folder, name: str, face: dict, seed: int) -> str:
    cfg = folder / f"{name}.yaml"
    cfg.write_text(
        yaml.safe_dump(
            {
                "physics": "lite",
                "targets": DETECTOR_PAIR,
                "source": {
                    "decay": "Po210",
                    "surface": face,
                    "depth": {"profile": "exponential", "mean": "0.5 um"},
                },
                "run": {"events": 800, "seed": seed},
            }
        )
    )
    run, out = folder / f"{name}.h5", folder / f"{name}.tpl.h5"
    assert main(["-q", "run", str(cfg), "--out", str(run)]) == 0
    assert (
        main(
            [
                "-q",
                "template",
                str(run),
                "--activity",
                "1 mBq/cm2",
                "--emax",
                "6 MeV",
                "--bins",
                "60",
                "--out",
                str(out),
            ]
        )
        == 0
    )
    return out.name


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    folder = tmp_path_factory.mktemp("model")
    _template(folder, "topface", {"volume": "top", "face": "-z"}, 2)
    _template(folder, "bottomface", {"volume": "bottom", "face": "+z"}, 3)
    return folder


def write_model(folder, name="model.yaml", **extra) -> str:
    data = {
        "detector": "bottom",
        "livetime": "200 d",
        "range": ["0.5 MeV", "6 MeV"],
        "roi": ["5 MeV", "5.5 MeV"],
        "components": [
            {"name": "top face", "template": "topface.tpl.h5", "activity": "3 mBq/cm2"},
            {"name": "bottom face", "template": "bottomface.tpl.h5", "activity": "1 mBq/cm2"},
        ],
        **extra,
    }
    path = folder / name
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return str(path)


def _pulls(folder, n: int) -> np.ndarray:
    model = build_model(load_model(write_model(folder)))
    truth = np.array([3.0, 1.0])  # mBq/cm2
    pulls = []
    for seed in range(n):
        fit = fit_model(model, pseudo_data(model, seed))
        assert fit.valid
        pulls.append(
            [(fit.activity[c] - t) / fit.error[c] for c, t in zip(fit.names, truth, strict=True)]
        )
    return np.array(pulls)


def test_fit_recovers_activities_from_pseudo_data_pulls_are_standard_normal(folder):
    """200 pseudo-experiments: mean pull within 0.25 of 0 (3.5 sigma of the mean of 200) and
    standard deviation within 0.15 of 1 (3 sigma of the width of 200: 1/sqrt(2 * 200) = 0.05)."""
    pulls = _pulls(folder, 200)
    assert np.all(np.abs(pulls.mean(axis=0)) < 0.25), pulls.mean(axis=0)
    assert np.all(np.abs(pulls.std(axis=0) - 1) < 0.15), pulls.std(axis=0)


@pytest.mark.deep
def test_pulls_deep(folder):
    """2000 pseudo-experiments: mean within 0.08, width within 0.05 of 1 (~3 sigma each)."""
    pulls = _pulls(folder, 2000)
    assert np.all(np.abs(pulls.mean(axis=0)) < 0.08), pulls.mean(axis=0)
    assert np.all(np.abs(pulls.std(axis=0) - 1) < 0.05), pulls.std(axis=0)


def test_cli_pseudo_data_fit_plots_and_json(folder, capsys):
    model = write_model(folder)
    data = folder / "pd.csv"
    assert main(["model", model, "--pseudo-data", str(data), "--seed", "4", "--overwrite"]) == 0
    capsys.readouterr()
    plot, fit_plot = folder / "m.png", folder / "f.png"
    assert (
        main(
            [
                "model",
                model,
                "--data",
                str(data),
                "--plot",
                str(plot),
                "--fit-plot",
                str(fit_plot),
                "--json",
                "--overwrite",
            ]
        )
        == 0
    )
    report = json.loads(capsys.readouterr().out)
    fit = report["fit"]
    assert fit["valid"]
    assert fit["correlation"]["order"] == ["top face", "bottom face"]
    for name, truth in (("top face", 3.0), ("bottom face", 1.0)):
        a = fit["activities"][name]
        assert a["unit"] == "mBq/cm2"
        assert abs(a["value"] - truth) < 4 * a["error"]
    assert report["model"]["expected_counts"] == pytest.approx(
        sum(c["expected_counts"] for c in report["model"]["components"].values())
    )
    assert plot.stat().st_size > 10_000
    assert fit_plot.stat().st_size > 10_000


def test_coarser_data_bins_and_a_root_histogram_fit(folder, capsys):
    uproot = pytest.importorskip("uproot")
    model = build_model(load_model(write_model(folder)))
    fine = pseudo_data(model, 9)
    coarse_counts = fine.counts.reshape(-1, 2).sum(axis=1)  # 200 keV bins from 100 keV ones
    coarse_edges = fine.edges_kev[::2]
    path = folder / "coarse.root"
    with uproot.recreate(path) as f:
        f["spectrum"] = (coarse_counts, coarse_edges)
    assert (
        main(
            ["model", write_model(folder), "--data", str(path), "--histogram", "spectrum", "--json"]
        )
        == 0
    )
    fit = json.loads(capsys.readouterr().out)["fit"]
    assert fit["bins"] == 27
    assert fit["valid"]


def test_binning_mismatch_and_bad_models_exit_2(folder, capsys):
    bad = folder / "shifted.csv"
    bad.write_text(
        "bin_low_keV,bin_high_keV,counts\n"
        + "".join(f"{25 + 50 * k},{75 + 50 * k},3\n" for k in range(100))
    )
    out = folder / "mismatch.png"
    assert main(["model", write_model(folder), "--data", str(bad), "--fit-plot", str(out)]) == 2
    err = capsys.readouterr().err
    assert "cannot be matched" in err
    assert err.count("\n") == 1
    assert not out.exists()
    for extra, message in (
        ({"livetime": "200"}, "has no unit"),
        (
            {"components": [{"name": "x", "template": "topface.tpl.h5", "activity": "1 mBq/kg"}]},
            "per mass",
        ),
        ({"kind": "m3"}, "kind"),
        ({"colour": "red"}, "unknown key"),
    ):
        assert main(["model", write_model(folder, "bad.yaml", **extra)]) == 2
        err = capsys.readouterr().err
        assert message in err, err
        assert err.count("\n") == 1, err


def test_runs_of_one_source_merge_weighted_by_decays(folder):
    """Two templates files of one source (here: one run, quoted at 1 and at 4 mBq/cm2) merge into
    the template of the first one's activity."""
    run = folder / "topface.h5"
    assert (
        main(
            [
                "-q",
                "template",
                str(run),
                "--activity",
                "4 mBq/cm2",
                "--emax",
                "6 MeV",
                "--bins",
                "60",
                "--out",
                str(folder / "topface4.tpl.h5"),
                "--overwrite",
            ]
        )
        == 0
    )
    single = build_model(load_model(write_model(folder)))
    merged_file = write_model(
        folder,
        "merged.yaml",
        components=[
            {
                "name": "top face",
                "template": ["topface.tpl.h5", "topface4.tpl.h5"],
                "activity": "3 mBq/cm2",
            },
            {"name": "bottom face", "template": "bottomface.tpl.h5", "activity": "1 mBq/cm2"},
        ],
    )
    merged = build_model(load_model(merged_file))
    np.testing.assert_allclose(merged.expected(), single.expected(), rtol=1e-12)
    assert merged.components[0].template.normalisation["simulated_decays"] == 1600
