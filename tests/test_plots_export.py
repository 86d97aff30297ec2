"""Spectra and depth plots, CSV and ROOT exports, and the ``score4 plot`` / ``score4 export``
commands.

Two small real lite runs (5.3 MeV alphas from the flat top face of the crystal) feed every test:
``a`` (200 events, one volume, default histogram settings) and ``b`` (100 events, a second
volume ``absorber`` 5 mm above the face that catches alphas flying up, histogram 50 bins to 6 MeV,
track lengths scored).
"""

from __future__ import annotations

import dataclasses
import json
import sys
import types
from pathlib import Path

import h5py
import numpy as np
import pytest
import uproot
from PIL import Image

from score4.analysis.export import export_csv, export_events_csv, export_root
from score4.analysis.plots import default_label, describe_run, file_kind, plot_depths, plot_spectra
from score4.cli.main import main
from score4.errors import ConfigError, Score4Error
from score4.inputs.config import parse_config
from score4.runner.engine import run
from score4.runner.output import read_results

from conftest import BASE_CONFIG, config_dict

# Its module fixture runs once, on one pytest-xdist worker (not once per worker).
pytestmark = pytest.mark.xdist_group("plots-export")

ABSORBER = {
    "name": "absorber",
    "material": "G4_Si",
    "size": ["1 cm", "1 cm", "1 mm"],
    "position": ["0 cm", "0 cm", "0.5 cm"],
}


@pytest.fixture(scope="module")
def runs(tmp_path_factory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("runs")
    a = parse_config(config_dict(run={"events": 200, "seed": 7}))
    b = parse_config(
        config_dict(
            run={"events": 100, "seed": 8},
            targets=[*BASE_CONFIG["targets"], ABSORBER],
            output={"histogram": {"bins": 50, "max": "6 MeV"}, "track_length": True},
        )
    )
    quiet = {"progress": False, "echo": lambda m: None}
    return {"a": run(a, folder / "a.h5", **quiet), "b": run(b, folder / "b.h5", **quiet)}


def assert_png(path: Path) -> None:
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert path.stat().st_size > 10_000  # axes, ticks, legend and curves, not an empty canvas
    with Image.open(path) as im:
        assert im.size[0] >= 600
        assert im.size[1] >= 400


def nonzero(e: np.ndarray) -> np.ndarray:
    return e[e != 0]


def assert_centred(edges, lo, hi, bins, line):
    """Bins of width (hi - lo) / bins covering [lo, hi + width / 2] with ``line`` mid-bin."""
    width = (hi - lo) / bins
    assert np.allclose(np.diff(edges), width, rtol=1e-9, atol=0)
    assert edges[0] <= lo < edges[0] + width
    assert edges[-1] >= hi + width / 2 - 1e-12
    k = np.searchsorted(edges, line) - 1
    assert (line - edges[k]) == pytest.approx(width / 2, rel=1e-9)
    assert (edges[k + 1] - line) == pytest.approx(width / 2, rel=1e-9)


# --- spectra ---------------------------------------------------------------------------------


def test_spectrum_of_one_run_is_the_histogram_of_its_deposits(runs, tmp_path):
    res = read_results(runs["a"])
    e = res.edep["crystal"]
    (s,) = plot_spectra(runs["a"], tmp_path / "a.png")
    assert_png(tmp_path / "a.png")
    # defaults: bins of 5.3 MeV / 100 from 0 to the largest primary energy (5.3 MeV), shifted
    # by half a bin so the full-energy line sits in the middle of the last bin
    edges = s.hist.edges
    assert_centred(edges, 0.0, 5.3, 100, line=5.3)
    assert edges[-1] == pytest.approx(5.3 + 0.053 / 2, rel=1e-12)
    assert (e <= edges[-1]).all()
    expected, _ = np.histogram(nonzero(e), bins=edges)
    assert np.array_equal(s.hist.counts, expected)
    assert np.allclose(s.y, expected / (np.diff(edges) * 1e3), rtol=1e-12)
    # about half the alphas fly away: present in the data, absent from the curve, stated in the
    # legend
    n_zero = int(np.count_nonzero(e == 0))
    assert 60 < n_zero < 140
    assert s.hist.n_zero == n_zero
    assert s.hist.counts.sum() == len(e) - n_zero
    assert f"{n_zero} of 200 events without deposit" in s.legend
    assert s.label == "a: alpha 5.3 MeV, flat +z, lite physics"


def test_two_runs_per_event_share_edges_and_compare(runs, tmp_path):
    out = tmp_path / "two.png"
    spectra = plot_spectra(
        [runs["a"], runs["b"]], out, volume="crystal", per_event=True, labels=["A", "B"]
    )
    assert_png(out)
    sa, sb = spectra
    assert [s.label for s in spectra] == ["A", "B"]
    assert sa.volume == sb.volume == "crystal"
    # common binning: bins of the first run (100), top = larger of the runs' tops (b: 6 MeV),
    # centred on the full-energy line (5.3 MeV)
    assert_centred(sa.hist.edges, 0.0, 6.0, 100, line=5.3)
    assert sa.hist.edges is sb.hist.edges
    for s, key in ((sa, "a"), (sb, "b")):
        res = read_results(runs[key])
        e = res.edep["crystal"]
        expected, _ = np.histogram(nonzero(e), bins=s.hist.edges)
        assert np.array_equal(s.hist.counts, expected)
        widths_keV = np.diff(s.hist.edges) * 1e3
        assert np.allclose(s.y * widths_keV * res.n_events, expected, rtol=1e-12)
        # per event: the area is the fraction of events with a deposit, whatever the run size
        assert np.sum(s.y * widths_keV) == pytest.approx(np.count_nonzero(e) / res.n_events)


def test_full_energy_peak_falls_in_one_bin_with_errors(runs, tmp_path):
    """--emin 4 MeV --emax 6 MeV --bins 40: 5.3 MeV is a grid point; the peak must not split."""
    e = read_results(runs["a"]).edep["crystal"]
    full = np.count_nonzero(e > 5.3 * (1 - 1e-6))
    assert full > 50
    (s,) = plot_spectra(runs["a"], tmp_path / "peak.png", emin=4.0, emax=6.0, bins=40, errors=True)
    assert_png(tmp_path / "peak.png")
    assert_centred(s.hist.edges, 4.0, 6.0, 40, line=5.3)
    k = np.searchsorted(s.hist.edges, 5.3) - 1
    assert s.hist.counts[k] >= full
    assert s.hist.counts[k + 1] == 0
    # the frame is past the peak: the x axis ends half a bin above emax
    assert s.hist.edges[-1] == pytest.approx(6.025)
    assert main(["plot", str(runs["a"]), "--out", str(tmp_path / "cli.png"), "--errors"]) == 0


def test_all_volumes_and_custom_range(runs, tmp_path):
    spectra = plot_spectra(runs["b"], tmp_path / "b.png", logy=False)
    assert [s.volume for s in spectra] == ["crystal", "absorber"]
    assert spectra[1].label.endswith("[absorber]")
    res = read_results(runs["b"])
    # the absorber above the face catches alphas flying up
    assert spectra[1].hist.counts.sum() == np.count_nonzero(res.edep["absorber"]) > 0
    # the run's own histogram settings: 50 bins up to 6 MeV
    assert_centred(spectra[0].hist.edges, 0.0, 6.0, 50, line=5.3)
    (low,) = plot_spectra(runs["a"], tmp_path / "low.png", emax="500 keV", bins=10)  # x axis in keV
    assert_png(tmp_path / "low.png")
    e = read_results(runs["a"]).edep["crystal"]
    # no line inside the range: bin centres on the round grid 0, 50, ..., 500 keV
    assert_centred(low.hist.edges, 0.0, 0.5, 10, line=0.25)
    top = low.hist.edges[-1]
    assert top == pytest.approx(0.525)
    assert (
        low.hist.n_overflow == np.count_nonzero(e > top) > 50
    )  # full-energy alphas are off this range
    assert low.hist.counts.sum() == np.count_nonzero((e > 0) & (e <= top))
    assert f"{low.hist.n_overflow} above range" in low.legend


def test_spectrum_errors(runs, tmp_path):
    with pytest.raises(
        Score4Error,
        match=r"volume: 'nope' is not a volume of .*b\.h5; volumes are: crystal, absorber",
    ):
        plot_spectra(runs["b"], tmp_path / "x.png", volume="nope")
    with pytest.raises(ConfigError, match="1 label"):
        plot_spectra([runs["a"], runs["b"]], tmp_path / "x.png", labels=["only one"])
    with pytest.raises(ConfigError, match="emax: must be larger than emin"):
        plot_spectra(runs["a"], tmp_path / "x.png", emin="2 MeV", emax="1 MeV")
    with pytest.raises(Score4Error, match=r"folder .* does not exist"):
        plot_spectra(runs["a"], tmp_path / "missing" / "x.png")
    assert not (tmp_path / "x.png").exists()


def test_description_survives_other_config_versions(runs):
    res = read_results(runs["a"])
    later = {
        **res.run["config"],
        "new_section": {"x": 1},
        "surfaces": {"pyr": {"kind": "spikes", "nx": 3}},
        "targets": [{"name": "crystal", "rough": [{"face": "+z", "surface": "pyr"}]}],
        "source": {
            "decay": "Po210",
            "particle": None,
            "surface": {"volume": "crystal", "face": "+z"},
            "depth": {"profile": "exponential", "mean": "2e-05 mm"},
        },
    }
    assert (
        describe_run(dataclasses.replace(res, run={**res.run, "config": later}))
        == "Po210, rough +z (spikes), exponential depth, lite physics"
    )
    odd = dataclasses.replace(res, run={"config": "not a mapping", "physics_mode": 3})
    assert describe_run(odd) == ""
    assert default_label(odd) == "a"


# --- depths ----------------------------------------------------------------------------------


def write_vertex_file(path: Path, depth: np.ndarray, units: str | None = "mm") -> Path:
    with h5py.File(path, "w") as f:
        f.attrs["format"] = "score4-vertices"
        d = f.create_dataset("vertices/depth", data=depth)
        if units:
            d.attrs["units"] = units
    return path


def test_depth_histograms_from_arrays_and_files(tmp_path):
    rng = np.random.default_rng(5)
    depth_mm = rng.exponential(20e-6, 2000)  # 20 nm mean
    v = write_vertex_file(tmp_path / "v.h5", depth_mm * 1e6, units="nm")
    hists = plot_depths([depth_mm, v], tmp_path / "d.png", bins=40, dmax="100 nm")
    assert_png(tmp_path / "d.png")
    expected, edges = np.histogram(depth_mm * 1e6, bins=np.linspace(0, 100, 41))
    for h in hists:
        assert np.allclose(h.edges_nm, edges)
        assert np.array_equal(h.counts, expected)
        assert np.allclose(h.per_nm, expected / 2.5)
    assert [h.label for h in hists] == ["depths 1", "v"]
    assert file_kind(v) == "vertices"


def test_depth_errors(tmp_path):
    with pytest.raises(Score4Error, match="units 'parsec'"):
        plot_depths(
            write_vertex_file(tmp_path / "bad.h5", np.ones(3), units="parsec"), tmp_path / "d.png"
        )
    with pytest.raises(ConfigError, match="1-D array"):
        plot_depths(np.ones((2, 2)), tmp_path / "d.png")
    with pytest.raises(ConfigError, match="non-finite"):
        plot_depths(np.array([1e-6, np.nan]), tmp_path / "d.png")
    assert not (tmp_path / "d.png").exists()


# --- exports ---------------------------------------------------------------------------------


def read_csv(path: Path):
    lines = [line for line in path.read_text().splitlines() if not line.startswith("#")]
    return np.genfromtxt(lines, delimiter=",", names=True, dtype=None, encoding="utf-8")


def test_histogram_csv_matches_numpy(runs, tmp_path):
    res = read_results(runs["b"])
    out = tmp_path / "h.csv"
    export_csv(res, out, bins=60, emax="6 MeV")
    text = out.read_text()
    assert f"# file: {runs['b']}\n# events: 100\n# physics mode: lite\n# seed: 8\n" in text
    table = read_csv(out)
    assert table.dtype.names == (
        "volume",
        "bin_low_MeV",
        "bin_high_MeV",
        "counts",
        "counts_per_keV",
    )
    edges = np.linspace(0, 6.0, 61)
    for name in ("crystal", "absorber"):
        block = table[table["volume"] == name]
        e = res.edep[name]
        expected, _ = np.histogram(nonzero(e), bins=edges)
        assert np.array_equal(block["bin_low_MeV"], edges[:-1])
        assert np.array_equal(block["bin_high_MeV"], edges[1:])
        assert np.array_equal(block["counts"], expected)
        assert np.array_equal(block["counts_per_keV"], expected / (np.diff(edges) * 1e3))
        assert block["counts"].sum() == np.count_nonzero((e > 0) & (e <= 6.0))
        assert f"# volume {name}: {np.count_nonzero(e == 0)} events without deposit" in text
    only = tmp_path / "one.csv"
    export_csv(res, only, volume="absorber", bins=60, emax=6.0)
    assert set(read_csv(only)["volume"]) == {"absorber"}
    with pytest.raises(Score4Error, match="volumes are: crystal, absorber"):
        export_csv(res, tmp_path / "no.csv", volume="Crystal")
    assert not (tmp_path / "no.csv").exists()


def test_events_csv_round_trip(runs, tmp_path):
    res = read_results(runs["b"])
    out = tmp_path / "ev.csv"
    assert export_events_csv(res, out) == [
        "event_id",
        "primary_energy_MeV",
        "edep_crystal_MeV",
        "edep_absorber_MeV",
        "track_length_crystal_mm",
        "track_length_absorber_mm",
    ]
    table = read_csv(out)
    assert np.array_equal(table["event_id"], res.event_id)
    assert np.array_equal(table["primary_energy_MeV"], res.primary_energy)
    for name in ("crystal", "absorber"):
        assert np.array_equal(table[f"edep_{name}_MeV"], res.edep[name])
        assert np.array_equal(table[f"track_length_{name}_mm"], res.scores["track_length"][name])
    assert (table["track_length_crystal_mm"][table["edep_crystal_MeV"] > 0] > 0).all()


def test_root_round_trip(runs, tmp_path):
    res = read_results(runs["b"])
    out = export_root(res, tmp_path / "b.root", bins=60, emax="6 MeV")
    with uproot.open(out) as f:
        assert f.classnames() == {
            "events;1": "TTree",
            "edep_crystal;1": "TH1D",
            "edep_absorber;1": "TH1D",
            "run;1": "TObjString",
        }
        tree = f["events"].arrays(library="np")
        assert set(tree) == {
            "event_id",
            "primary_energy",
            "edep_crystal",
            "edep_absorber",
            "track_length_crystal",
            "track_length_absorber",
        }
        assert np.array_equal(tree["track_length_absorber"], res.scores["track_length"]["absorber"])
        assert tree["event_id"].dtype == np.int64
        assert np.array_equal(tree["event_id"], res.event_id)
        assert np.array_equal(tree["primary_energy"], res.primary_energy)
        edges = np.linspace(0, 6.0, 61)
        for name in ("crystal", "absorber"):
            assert np.array_equal(tree[f"edep_{name}"], res.edep[name])
            h = f[f"edep_{name}"]
            expected, _ = np.histogram(nonzero(res.edep[name]), bins=edges)
            assert np.allclose(h.axis().edges(), edges, rtol=0, atol=1e-12)
            assert np.array_equal(h.values(), expected)
            assert h.values(flow=True)[0] == 0
            assert h.values(flow=True)[-1] == 0
            assert h.member("fEntries") == expected.sum()
            inside = nonzero(res.edep[name])
            assert h.member("fTsumwx") == pytest.approx(inside.sum())
        record = json.loads(str(f["run"]))
        assert record["seed"] == 8
        assert record["physics_mode"] == "lite"
        assert record["config"]["source"]["energy"] == "5.3 MeV"


# --- command line ----------------------------------------------------------------------------


def test_cli_plot_and_export(runs, tmp_path, capsys):
    png = tmp_path / "cli.png"
    assert (
        main(
            [
                "plot",
                str(runs["a"]),
                str(runs["b"]),
                "--out",
                str(png),
                "--volume",
                "crystal",
                "--per-event",
                "--emax",
                "6 MeV",
                "--bins",
                "30",
                "--label",
                "A",
                "--label",
                "B",
            ]
        )
        == 0
    )
    assert_png(png)
    assert "2 spectra" in capsys.readouterr().out
    csv, root, ev = tmp_path / "cli.csv", tmp_path / "cli.root", tmp_path / "cli_ev.csv"
    assert (
        main(
            [
                "export",
                str(runs["b"]),
                "--csv",
                str(csv),
                "--events-csv",
                str(ev),
                "--root",
                str(root),
                "--bins",
                "60",
                "--emax",
                "6 MeV",
            ]
        )
        == 0
    )
    ref = tmp_path / "ref.csv"
    export_csv(read_results(runs["b"]), ref, bins=60, emax=6.0)
    assert csv.read_text() == ref.read_text()
    with uproot.open(root) as f:
        assert np.array_equal(f["edep_absorber"].values(), read_csv(ref)["counts"][60:])
    assert read_csv(ev)["event_id"].tolist() == list(range(100))


def test_cli_plot_and_export_replace_files_only_with_overwrite(runs, tmp_path, capsys):
    png, csv, ev, root = (tmp_path / n for n in ("s.png", "h.csv", "e.csv", "r.root"))
    for path in (png, csv, ev, root):
        path.write_text("old")
    assert main(["plot", str(runs["a"]), "--out", str(png)]) == 2
    assert main(["export", str(runs["b"]), "--csv", str(csv), "--root", str(root)]) == 2
    assert all(p.read_text() == "old" for p in (png, csv, ev, root))
    capsys.readouterr()
    assert main(["plot", str(runs["a"]), "--out", str(png), "--overwrite"]) == 0
    assert_png(png)
    argv = ["export", str(runs["b"]), "--csv", str(csv), "--events-csv", str(ev), "--root"]
    assert main([*argv, str(root), "--overwrite"]) == 0
    ref = tmp_path / "ref.csv"
    export_csv(read_results(runs["b"]), ref)
    assert csv.read_text() == ref.read_text()
    assert read_csv(ev)["event_id"].tolist() == list(range(100))
    with uproot.open(root) as f:
        assert f["events"].num_entries == 100


def test_cli_plot_vertex_file(tmp_path, capsys):
    v = write_vertex_file(tmp_path / "v.h5", np.linspace(0, 50e-6, 101))
    assert main(["plot", str(v), "--out", str(tmp_path / "d.png")]) == 0
    assert_png(tmp_path / "d.png")
    assert "1 depth histogram" in capsys.readouterr().out


@pytest.fixture
def surface_file(tmp_path) -> Path:
    from score4.surface.spec import build_surface, parse_surface_spec
    from score4.surface.store import save_surface

    spec = parse_surface_spec(
        {"kind": "spikes", "nx": 3, "ny": 2, "width": "10 um", "height": "5 um"}
    )
    return save_surface(build_surface(spec), tmp_path / "pyr.s4s.h5")


def test_cli_plot_surface_dispatches_to_surface_plot(surface_file, tmp_path, monkeypatch):
    calls = []
    fake = types.ModuleType("score4.surface.plot")
    fake.plot_surface = lambda surface, path: (
        calls.append((surface, Path(path))) or Path(path).write_bytes(b"x")
    )
    monkeypatch.setitem(sys.modules, "score4.surface.plot", fake)
    assert file_kind(surface_file) == "surface"
    assert main(["plot", str(surface_file), "--out", str(tmp_path / "s.png")]) == 0
    ((surface, path),) = calls
    assert path == tmp_path / "s.png"
    assert surface.spec.kind == "spikes"
    assert surface.spikes.heights.shape == (2, 3)


def test_cli_plot_surface_without_surface_plot_module(surface_file, tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(
        sys.modules, "score4.surface.plot", None
    )  # import fails as if the module did not exist
    assert main(["plot", str(surface_file), "--out", str(tmp_path / "s.png")]) == 2
    assert "needs score4.surface.plot" in capsys.readouterr().err
    assert not (tmp_path / "s.png").exists()


def _cli_error_cases(runs, tmp):
    plain = tmp / "plain.h5"
    with h5py.File(plain, "w") as f:
        f.create_dataset("x", data=[1, 2])
    text = tmp / "notes.h5"
    text.write_text("not hdf5")
    vert = write_vertex_file(tmp / "v.h5", np.ones(5) * 1e-6)
    a, b, png = str(runs["a"]), str(runs["b"]), str(tmp / "o.png")
    return [
        (
            ["plot", str(tmp / "missing.h5"), "--out", png],
            "file '" + str(tmp / "missing.h5") + "' does not exist",
        ),
        (
            ["plot", str(plain), "--out", png],
            "is not a score4 results, vertex or surface file (no format attribute)",
        ),
        (["plot", str(text), "--out", png], "is not an HDF5 file"),
        (
            ["plot", b, "--out", png, "--volume", "nope"],
            "'nope' is not a volume of " + b + "; volumes are: crystal, absorber",
        ),
        (
            ["plot", a, str(vert), "--out", png],
            "cannot mix kinds of files in one plot: a.h5 (results), v.h5 (vertices)",
        ),
        (
            ["plot", str(vert), "--out", png, "--emax", "6 MeV"],
            "--emax apply to results files only",
        ),
        (["plot", a, "--out", png, "--emax", "6"], "--emax: '6' has no unit"),
        (["plot", a, b, "--out", png, "--label", "x"], "labels: 1 label(s) given for 2 run(s)"),
        (["plot", a, "--out", str(tmp / "o.bmpx")], "unknown image format '.bmpx'"),
        (["export", b], "give at least one of --csv"),
        (["export", str(plain), "--csv", str(tmp / "o.csv")], "is not a score4 results file"),
        (
            ["export", b, "--csv", str(tmp / "o.csv"), "--volume", "foo"],
            "volumes are: crystal, absorber",
        ),
        (
            ["export", b, "--csv", str(tmp / "o.csv"), "--root", str(tmp / "no" / "o.root")],
            "folder",
        ),
    ]


def test_cli_errors_exit_2_with_one_line(runs, tmp_path, capsys):
    for argv, message in _cli_error_cases(runs, tmp_path):
        assert main(argv) == 2, argv
        err = capsys.readouterr().err.strip()
        assert err.startswith("score4: error: "), (argv, err)
        assert "\n" not in err, (argv, err)
        assert message in err, (argv, err)
    written = {p.name for p in tmp_path.iterdir()}
    assert written == {"plain.h5", "notes.h5", "v.h5"}  # no output (nor temporary file) left behind


def test_vertex_depths_are_counted_once_per_event(tmp_path):
    """Po-210 events have two primaries (alpha and recoil) at one vertex: one depth per event."""
    from score4.analysis.plots import read_vertex_depths
    from score4.source.emitters import Po210Emitter, make_primaries
    from score4.source.vertex_file import write_vertex_file

    rng = np.random.default_rng(0)
    depth = rng.uniform(0, 1e-4, 50)
    p = make_primaries(
        Po210Emitter(), rng, np.zeros((50, 3)), np.tile([0, 0, 1.0], (50, 1)), depth=depth
    )
    path = write_vertex_file(tmp_path / "v.h5", p, {}, 0)
    np.testing.assert_array_equal(read_vertex_depths(path), depth)
