"""Progress lines in batch logs (score4.runner.progress); what a dead worker's error line says."""

from __future__ import annotations

import io

from score4.runner.engine import _last_exception_text
from score4.runner.progress import PlainProgress, progress_bar


class Clock:
    def __init__(self) -> None:
        self.t = 0.0

    def __call__(self) -> float:
        return self.t


def test_plain_lines_at_start_every_tenth_each_minute_and_at_the_end():
    out, clock = io.StringIO(), Clock()
    bar = PlainProgress(1000, file=out, clock=clock)
    for _ in range(25):  # 25 updates of 10 events, 1 s apart
        clock.t += 1.0
        bar.update(10)
    clock.t += 61.0  # a slow minute: a line even without a new tenth
    bar.update(1)
    clock.t += 1.0
    bar.update(749)
    bar.close()
    lines = out.getvalue().splitlines()
    assert lines[0] == "run: 0 of 1000 events (0 %)"
    assert lines[1] == "run: 100 of 1000 events (10 %), 10 s, 10 events/s, about 1 min 30 s left"
    assert lines[2].startswith("run: 200 of 1000 events (20 %), 20 s, 10 events/s")
    assert lines[3].startswith("run: 251 of 1000 events (25 %), 1 min 26 s")
    assert lines[-1] == "run: 1000 of 1000 events (100 %) in 1 min 27 s"
    assert len(lines) == 5


def test_unpause_leaves_the_pause_out_of_the_time_left():
    out, clock = io.StringIO(), Clock()
    bar = PlainProgress(100, file=out, clock=clock)
    clock.t = 300.0  # five minutes building a TRIM library, no event done
    bar.unpause()
    clock.t += 10.0
    bar.update(10)  # 1 event/s since the library was built: 90 s left, not 2700 s
    assert out.getvalue().splitlines()[1].endswith("1 events/s, about 1 min 30 s left")


def test_a_file_gets_plain_lines_and_quiet_gets_nothing():
    assert isinstance(progress_bar(10, file=io.StringIO()), PlainProgress)
    silent = io.StringIO()
    bar = progress_bar(10, show=False, file=silent)
    bar.update(10)
    bar.close()
    assert silent.getvalue() == ""


def test_a_dead_worker_names_geant4s_fatal_exception_not_its_warnings(tmp_path):
    (tmp_path / "geant4-123.log").write_text(
        "-------- WWWW ------- G4Exception-START -------- WWWW -------\n\n"
        "*** G4Exception : em0002\n      issued by : G4EmModel\nonly a warning\n"
        "-------- EEEE ------- G4Exception-START -------- EEEE -------\n\n"
        "*** G4Exception : GeomSolids0002\n      issued by : G4Box::G4Box()\n"
        "Dimensions too small for Solid: b!\n"
    )
    said = _last_exception_text(tmp_path, "worker process 123 died, killed by signal SIGABRT")
    assert said == (
        "; Geant4's fatal exception: GeomSolids0002 (G4Box::G4Box()): Dimensions too small for "
        "Solid: b!"
    )
    assert _last_exception_text(tmp_path, "worker process 999 died") == ""
