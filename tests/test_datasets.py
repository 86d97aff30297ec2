"""Tests for score4.runner.datasets and the ``score4 data`` CLI group (loopback network only)."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import warnings
from importlib.metadata import version
from pathlib import Path

import pytest
from click.testing import CliRunner

from score4.cli.data_cmd import data
from score4.errors import ConfigError, DataError
from score4.runner import datasets
from score4.runner.datasets import DataSet, Source

from helpers.datasets_server import Route, closed_port, make_tarball, md5, serve

FAKE_FILES = {
    "FAKEDATA1.0": None,
    "FAKEDATA1.0/README": b"fake Geant4 data set for tests\n",
    "FAKEDATA1.0/sub": None,
    "FAKEDATA1.0/sub/table.dat": b"1 2 3\n4 5 6\n",
}
FAKE_TAR = make_tarball(FAKE_FILES)
FAKE = DataSet("FAKEDATA", "1.0", "G4FAKEDATA", "G4FAKEDATA", md5(FAKE_TAR))
ENV_KEYS = [
    "GEANT4_DATA_DIR",
    "SCORE4_DATA_DIR",
    "XDG_DATA_HOME",
    "SCORE4_DATASET_URL",
    "http_proxy",
    "HTTP_PROXY",
    "https_proxy",
    "HTTPS_PROXY",
    "all_proxy",
    "ALL_PROXY",
]


@pytest.fixture
def home(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """An empty HOME and no data-set variables, so nothing real is found."""
    home = tmp_path / "home"
    home.mkdir()
    monkeypatch.setenv("HOME", str(home))
    monkeypatch.setenv("NO_PROXY", "127.0.0.1,localhost")
    for key in ENV_KEYS + [ds.envvar for ds in datasets.official_datasets()] + [FAKE.envvar]:
        monkeypatch.delenv(key, raising=False)
    return home


@pytest.fixture
def fake_list(monkeypatch: pytest.MonkeyPatch) -> list[DataSet]:
    """The official list replaced by one tiny fake set."""
    monkeypatch.setattr(datasets, "official_datasets", lambda: [FAKE])
    return [FAKE]


@pytest.fixture
def fresh_cache():
    datasets._official.cache_clear()
    datasets.dataset_url.cache_clear()
    yield
    datasets._official.cache_clear()
    datasets.dataset_url.cache_clear()


def fill(folder: Path, name: str = "data.dat", content: bytes = b"x") -> Path:
    """Create ``folder`` holding one file (non-empty unless content is b'')."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / name).write_bytes(content)
    return folder


# --------------------------------------------------------------------------- official list


def test_official_list_is_parsed_from_the_extension(fresh_cache) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the fallback would warn
        sets = {ds.name: ds for ds in datasets.official_datasets()}
    assert {"G4EMLOW", "G4ENSDFSTATE", "PhotonEvaporation", "RadioactiveDecay"} <= set(sets)
    for ds in sets.values():
        assert re.fullmatch(r"[0-9a-f]{32}", ds.md5), ds
        assert re.fullmatch(r"\d+(\.\d+)*", ds.version), ds
    assert sets["G4EMLOW"].envvar == "G4LEDATA"
    assert sets["G4ENSDFSTATE"].envvar == "G4ENSDFSTATEDATA"
    assert datasets.dataset_url() == "https://cern.ch/geant4-data/datasets"


@pytest.mark.skipif(version("geant4_pybind") != "0.1.3", reason="fallback table is for 0.1.3")
def test_builtin_fallback_matches_geant4_pybind_0_1_3(fresh_cache) -> None:
    assert datasets.official_datasets() == list(datasets._FALLBACK_0_1_3)


def test_parsing_does_not_import_geant4_pybind(tmp_path: Path) -> None:
    # A fresh interpreter without GEANT4_DATA_DIR: importing geant4_pybind would prompt/download.
    env = {k: v for k, v in os.environ.items() if k not in ("GEANT4_DATA_DIR", "CI")}
    env["HOME"] = str(tmp_path)
    code = (
        "import sys; from score4.runner import datasets as d; n = len(d.official_datasets()); "
        "d.status(); print(n, 'geant4_pybind' in sys.modules)"
    )
    out = subprocess.run(
        [sys.executable, "-c", code],
        env=env,
        stdin=subprocess.DEVNULL,
        capture_output=True,
        text=True,
        check=True,
        timeout=60,
    )
    count, imported = out.stdout.split()
    assert int(count) >= 10
    assert imported == "False"


def test_fallback_warns_once_when_extension_unreadable(
    fresh_cache, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    junk = tmp_path / "junk.so"
    junk.write_bytes(b"\x00ELF no data-set list here\nDATASETS = not a list\n")
    monkeypatch.setattr(datasets, "_extension_path", lambda: junk)
    with pytest.warns(RuntimeWarning, match="built-in list"):
        first = datasets.official_datasets()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        second = datasets.official_datasets()
    assert first == second == list(datasets._FALLBACK_0_1_3)
    assert datasets.dataset_url() == "https://cern.ch/geant4-data/datasets"


def test_dataset_names() -> None:
    ds = DataSet("PhotonEvaporation", "6.1.2", "G4PhotonEvaporation", "G4LEVELGAMMADATA", "0" * 32)
    assert ds.dirname == "PhotonEvaporation6.1.2"
    assert ds.tarball == "G4PhotonEvaporation.6.1.2.tar.gz"


# --------------------------------------------------------------------------- locating


def test_default_data_dir_order(tmp_path: Path) -> None:
    home = {"HOME": str(tmp_path)}
    assert datasets.default_data_dir(home) == tmp_path / ".local/share/score4/geant4-data"
    xdg = {**home, "XDG_DATA_HOME": "/x"}
    assert datasets.default_data_dir(xdg) == Path("/x/score4/geant4-data")
    assert datasets.default_data_dir({**xdg, "SCORE4_DATA_DIR": "/s"}) == Path("/s")
    assert (
        datasets.default_data_dir({**home, "XDG_DATA_HOME": ""})
        == tmp_path / ".local/share/score4/geant4-data"
    )


def test_locate_search_order(tmp_path: Path) -> None:
    home = tmp_path / "home"
    own = fill(tmp_path / "own")
    g4 = fill(tmp_path / "g4data" / FAKE.dirname).parent
    pybind = fill(home / ".geant4_pybind" / FAKE.dirname)
    score4 = fill(home / ".local/share/score4/geant4-data" / FAKE.dirname)
    env = {"HOME": str(home), FAKE.envvar: str(own), "GEANT4_DATA_DIR": str(g4)}

    assert datasets.locate_with_source(FAKE, env) == (own, Source.ENVVAR)
    del env[FAKE.envvar]
    assert datasets.locate_with_source(FAKE, env) == (g4 / FAKE.dirname, Source.GEANT4_DATA_DIR)
    del env["GEANT4_DATA_DIR"]
    assert datasets.locate_with_source(FAKE, env) == (pybind, Source.GEANT4_PYBIND)
    (pybind / "data.dat").unlink()
    assert datasets.locate_with_source(FAKE, env) == (score4, Source.SCORE4)
    assert datasets.locate(FAKE, env) == score4
    (score4 / "data.dat").unlink()
    assert datasets.locate(FAKE, env) is None


def test_empty_files_do_not_count_as_data(tmp_path: Path) -> None:
    # score4's lite stub: an empty ENSDFSTATE.dat must never pass for the real data set.
    stub = fill(tmp_path / "stub" / FAKE.dirname, "ENSDFSTATE.dat", b"")
    (stub / "empty_sub").mkdir()
    real = tmp_path / "home/.geant4_pybind" / FAKE.dirname
    env = {
        "HOME": str(tmp_path / "home"),
        FAKE.envvar: str(stub),
        "GEANT4_DATA_DIR": str(stub.parent),
    }
    assert datasets.locate(FAKE, env) is None
    fill(real / "deep" / "deeper", "z.dat", b"1")  # one non-empty file anywhere below counts
    assert datasets.locate_with_source(FAKE, env) == (real, Source.GEANT4_PYBIND)
    (real / "deep/deeper/z.dat").write_bytes(b"")
    assert datasets.locate(FAKE, env) is None


def test_a_file_is_not_a_data_folder(tmp_path: Path) -> None:
    not_a_dir = tmp_path / "file"
    not_a_dir.write_bytes(b"data")
    assert datasets.locate(FAKE, {"HOME": str(tmp_path), FAKE.envvar: str(not_a_dir)}) is None


# --------------------------------------------------------------------------- status and modes


def test_status_modes_and_missing(tmp_path: Path, home: Path) -> None:
    g4 = tmp_path / "g4"
    for ds in datasets.official_datasets():
        if ds.name in ("G4EMLOW", "G4ENSDFSTATE"):
            fill(g4 / ds.dirname)
    env = {"HOME": str(home), "GEANT4_DATA_DIR": str(g4)}
    statuses = datasets.status(env)
    by_name = {s.name: s for s in statuses}
    assert [s.name for s in statuses] == [ds.name for ds in datasets.official_datasets()]
    assert by_name["G4EMLOW"].source is Source.GEANT4_DATA_DIR
    assert by_name["G4EMLOW"].found
    assert by_name["RadioactiveDecay"].path is None
    assert by_name["RadioactiveDecay"].source is None
    assert datasets.available_modes(statuses) == {"lite": True, "full": True, "decay": False}
    assert datasets.missing_for("decay", statuses) == ["PhotonEvaporation", "RadioactiveDecay"]
    assert datasets.missing_for("full", statuses) == []
    assert datasets.missing_for("lite", []) == []
    env_vars = datasets.geant4_env(statuses)
    assert env_vars["G4LEDATA"] == str(by_name["G4EMLOW"].path)
    assert "G4RADIOACTIVEDATA" not in env_vars
    with pytest.raises(ConfigError, match=r"mode='heavy'.*lite, full, decay"):
        datasets.missing_for("heavy", statuses)


def test_export_line_quotes_the_path(tmp_path: Path) -> None:
    assert datasets.export_line(tmp_path / "a b") == f"export GEANT4_DATA_DIR='{tmp_path}/a b'"


# --------------------------------------------------------------------------- install


def test_install_success(tmp_path: Path, home: Path, fake_list) -> None:
    target = tmp_path / "data"
    routes = {f"/datasets/{FAKE.tarball}": Route(FAKE_TAR)}
    with serve(routes) as server:
        paths = datasets.install(target, base_url=server.base_url, progress=False)
    assert paths == [target / FAKE.dirname]
    assert (target / "FAKEDATA1.0/sub/table.dat").read_bytes() == b"1 2 3\n4 5 6\n"
    assert os.listdir(target) == [FAKE.dirname]  # no temp files left
    assert datasets.locate(FAKE, {"HOME": str(home), "GEANT4_DATA_DIR": str(target)}) == paths[0]
    assert datasets.export_line(target) == f"export GEANT4_DATA_DIR={target}"


def test_install_default_dir_and_url_from_env(
    tmp_path: Path, home: Path, fake_list, monkeypatch: pytest.MonkeyPatch
) -> None:
    routes = {f"/datasets/{FAKE.tarball}": Route(FAKE_TAR)}
    with serve(routes) as server:
        monkeypatch.setenv("SCORE4_DATASET_URL", server.base_url)
        paths = datasets.install(progress=False)
        assert datasets.install(progress=False) == []  # nothing missing any more
        assert server.requests == [f"/datasets/{FAKE.tarball}"]
    assert paths == [home / ".local/share/score4/geant4-data" / FAKE.dirname]
    assert datasets.locate_with_source(FAKE) == (paths[0], Source.SCORE4)


def test_install_only_skips_sets_already_in_directory(
    tmp_path: Path, home: Path, fake_list
) -> None:
    present = fill(tmp_path / "data" / FAKE.dirname)
    with serve({}) as server:
        assert datasets.install(
            tmp_path / "data", only=["FAKEDATA"], base_url=server.base_url, progress=False
        ) == [present]
        assert server.requests == []


def test_install_replaces_lite_stub(tmp_path: Path, home: Path, fake_list) -> None:
    target = tmp_path / "data"
    fill(target / FAKE.dirname, "ENSDFSTATE.dat", b"")  # empty stub: not data
    with serve({f"/datasets/{FAKE.tarball}": Route(FAKE_TAR)}) as server:
        datasets.install(target, only=["FAKEDATA"], base_url=server.base_url, progress=False)
    assert sorted(p.name for p in (target / FAKE.dirname).iterdir()) == ["README", "sub"]
    assert os.listdir(target) == [FAKE.dirname]


def test_install_md5_mismatch_leaves_nothing(tmp_path: Path, home: Path, fake_list) -> None:
    other = make_tarball({"FAKEDATA1.0/README": b"tampered\n"})
    target = tmp_path / "data"
    with (
        serve({f"/datasets/{FAKE.tarball}": Route(other)}) as server,
        pytest.raises(DataError) as err,
    ):
        datasets.install(target, base_url=server.base_url, progress=False)
    msg = str(err.value)
    assert FAKE.tarball in msg
    assert FAKE.md5 in msg
    assert md5(other) in msg
    assert os.listdir(target) == []


def test_install_server_dies_mid_download(tmp_path: Path, home: Path, fake_list) -> None:
    target = tmp_path / "data"
    with (
        serve({f"/datasets/{FAKE.tarball}": Route(FAKE_TAR, truncate=True)}) as server,
        pytest.raises(DataError, match=r"ended after \d+ of \d+ bytes"),
    ):
        datasets.install(target, base_url=server.base_url, progress=False)
    assert os.listdir(target) == []


def test_install_server_stalls_mid_download(tmp_path: Path, home: Path, fake_list) -> None:
    target = tmp_path / "data"
    with (
        # the server stalls until the test ends: the client's 0.3 s timeout ends the download
        # however loaded the machine (a short stall could end first and close the connection)
        serve({f"/datasets/{FAKE.tarball}": Route(FAKE_TAR, stall=600.0)}) as server,
        pytest.raises(DataError, match=r"download of .* failed: timed out; fetch the data"),
    ):
        datasets.install(target, base_url=server.base_url, progress=False, timeout=0.3)
    assert os.listdir(target) == []


def test_install_http_error(tmp_path: Path, home: Path, fake_list) -> None:
    with serve({}) as server, pytest.raises(DataError) as err:
        datasets.install(tmp_path / "data", base_url=server.base_url, progress=False)
    msg = str(err.value)
    assert f"{server.base_url}/{FAKE.tarball}" in msg
    assert "HTTP 404" in msg
    assert "machine with internet" in msg
    assert "\n" not in msg


def test_install_connection_refused(tmp_path: Path, home: Path, fake_list) -> None:
    url = f"http://127.0.0.1:{closed_port()}/datasets"
    target = tmp_path / "data"
    with pytest.raises(DataError) as err:
        datasets.install(target, base_url=url, progress=False, timeout=5)
    msg = str(err.value)
    assert msg.startswith(f"cannot download {url}/{FAKE.tarball}: ")
    assert "refused" in msg.lower()
    assert f"copy them here as {target}/<name><version>/" in msg
    assert "\n" not in msg
    assert os.listdir(target) == []


def test_install_unknown_name(tmp_path: Path, home: Path, fake_list) -> None:
    with pytest.raises(
        DataError, match="only=G4NOPE: unknown data-set name; valid names are FAKEDATA"
    ):
        datasets.install(tmp_path / "data", only=["G4NOPE"], base_url="http://127.0.0.1:9")
    assert not (tmp_path / "data").exists()


def test_install_rejects_bad_timeout(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="timeout=0"):
        datasets.install(tmp_path, timeout=0)


@pytest.mark.parametrize(
    ("members", "rule"),
    [
        ({"FAKEDATA1.0/README": b"ok", "../evil": b"pwned"}, "path traversal"),
        ({"FAKEDATA1.0/../../evil": b"pwned"}, "path traversal"),
        ({"/tmp/evil": b"pwned"}, "absolute paths"),
        ({"FAKEDATA1.0/README": b"ok", "OTHER2.0/x": b"y"}, "must lie in FAKEDATA1.0/"),
        ({"FAKEDATA1.0": None}, "exactly one non-empty folder"),
    ],
)
def test_install_refuses_bad_tarballs(
    tmp_path: Path,
    home: Path,
    monkeypatch: pytest.MonkeyPatch,
    members: dict[str, bytes | None],
    rule: str,
) -> None:
    tar = make_tarball(members)
    bad = DataSet("FAKEDATA", "1.0", "G4FAKEDATA", "G4FAKEDATA", md5(tar))
    monkeypatch.setattr(datasets, "official_datasets", lambda: [bad])
    target = tmp_path / "data"
    with (
        serve({f"/datasets/{bad.tarball}": Route(tar)}) as server,
        pytest.raises(DataError, match=rule),
    ):
        datasets.install(target, base_url=server.base_url, progress=False)
    assert os.listdir(target) == []
    assert not (tmp_path / "evil").exists()


def test_interrupted_unpack_leaves_nothing(
    tmp_path: Path, home: Path, fake_list, monkeypatch: pytest.MonkeyPatch
) -> None:
    real_extract = datasets._extract_checked

    def extract_then_interrupt(*args: object) -> Path:
        real_extract(*args)  # the data are fully unpacked in the temp folder ...
        raise KeyboardInterrupt  # ... and the user presses Ctrl-C before the rename

    monkeypatch.setattr(datasets, "_extract_checked", extract_then_interrupt)
    target = tmp_path / "data"
    with (
        serve({f"/datasets/{FAKE.tarball}": Route(FAKE_TAR)}) as server,
        pytest.raises(KeyboardInterrupt),
    ):
        datasets.install(target, base_url=server.base_url, progress=False)
    assert os.listdir(target) == []


# --------------------------------------------------------------------------- CLI


def test_cli_status_json(home: Path) -> None:
    result = CliRunner().invoke(data, ["status", "--json"])
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    assert set(doc) == {"datasets", "modes", "default_dir"}
    names = [d["name"] for d in doc["datasets"]]
    assert "G4EMLOW" in names
    assert "G4ENSDFSTATE" in names
    assert all(set(d) == {"name", "version", "envvar", "path", "source"} for d in doc["datasets"])
    assert all(d["path"] is None and d["source"] is None for d in doc["datasets"])
    assert doc["modes"]["lite"] == {"available": True, "missing": []}
    assert doc["modes"]["full"] == {"available": False, "missing": ["G4EMLOW", "G4ENSDFSTATE"]}
    assert doc["modes"]["decay"]["available"] is False


def test_cli_status_table(tmp_path: Path, home: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    emlow = next(ds for ds in datasets.official_datasets() if ds.name == "G4EMLOW")
    folder = fill(tmp_path / "emlow")
    monkeypatch.setenv(emlow.envvar, str(folder))
    result = CliRunner().invoke(data, ["status"])
    assert result.exit_code == 0, result.output
    line = next(line for line in result.stdout.splitlines() if line.startswith("G4EMLOW "))
    assert str(folder) in line
    assert f"${emlow.envvar}" in line
    assert re.search(r"^G4ENSDFSTATE\s+\S+\s+MISSING", result.stdout, re.MULTILINE)
    assert re.search(r"^  full\s+missing G4ENSDFSTATE\b", result.stdout, re.MULTILINE)
    assert re.search(r"^  lite\s+available", result.stdout, re.MULTILINE)


def test_cli_install_prints_export_line(tmp_path: Path, home: Path, fake_list) -> None:
    target = tmp_path / "data"
    with serve({f"/datasets/{FAKE.tarball}": Route(FAKE_TAR)}) as server:
        result = CliRunner().invoke(
            data,
            [
                "install",
                "--dir",
                str(target),
                "--only",
                "FAKEDATA",
                "--url",
                server.base_url,
                "--no-progress",
            ],
        )
    assert result.exit_code == 0, result.output
    assert result.stdout.splitlines()[-1] == f"export GEANT4_DATA_DIR={target}"
    assert (target / FAKE.dirname / "README").is_file()


def test_cli_install_mode_installs_what_the_mode_lacks(
    tmp_path: Path, home: Path, fake_list, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setitem(datasets.MODES, "full", ("FAKEDATA",))
    target = tmp_path / "data"
    args = ["install", "--dir", str(target), "--mode", "full", "--no-progress"]
    with serve({f"/datasets/{FAKE.tarball}": Route(FAKE_TAR)}) as server:
        first = CliRunner().invoke(data, [*args, "--url", server.base_url])
        monkeypatch.setenv("GEANT4_DATA_DIR", str(target))
        second = CliRunner().invoke(data, [*args, "--url", server.base_url])
        assert server.requests == [f"/datasets/{FAKE.tarball}"]
    assert first.exit_code == 0
    assert f"ready: {target / FAKE.dirname}" in first.stdout
    assert second.exit_code == 0
    assert "everything physics mode 'full' needs" in second.stdout


def test_cli_error_is_one_line_exit_2(tmp_path: Path, home: Path, fake_list) -> None:
    result = CliRunner().invoke(data, ["install", "--dir", str(tmp_path), "--only", "NOPE"])
    assert result.exit_code == 2
    assert result.stderr.startswith("score4: error: only=NOPE: unknown data-set name")
    assert result.stderr.count("\n") == 1
    assert result.stdout == ""
