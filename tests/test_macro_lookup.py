"""Files named in a macro (``/control/execute``, ``/shift/loadShiftTable``): looked for beside the
macro, then in the working folder; a missing one is an error naming the file, the line and both
folders. Both commands share one lookup (:meth:`score4.macro.reader.Command.find_file`).
"""

from __future__ import annotations

import pytest

from score4.errors import ConfigError
from score4.macro import import_macro


@pytest.mark.parametrize(
    ("command", "what"),
    [("/control/execute", "macro"), ("/shift/loadShiftTable", "shift table")],
)
def test_missing_file_names_line_and_folders(tmp_path, monkeypatch, command, what):
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    mac = tmp_path / "m.mac"
    mac.write_text(f"/control/verbose 0\n{command} nowhere.txt\n")
    with pytest.raises(ConfigError) as err:
        import_macro(mac)
    assert str(err.value) == (
        f"{mac} line 2: {command}: {what} 'nowhere.txt' not found (looked in {tmp_path}, {work})"
    )


def test_file_found_in_working_folder(tmp_path, monkeypatch):
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    (work / "inc.mac").write_text("/gps/particle alpha\n")
    mac = tmp_path / "m.mac"
    mac.write_text(
        "/geometry/surface/setSpikeWidth_X 5 um\n/control/execute inc.mac\n/run/beamOn 3\n"
    )
    config, report = import_macro(mac, out=tmp_path / "m.yaml")
    assert config["source"]["particle"] == "alpha"
    assert "inc.mac line 1" in {i.where for i in report.converted}
