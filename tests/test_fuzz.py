"""Fuzz suite: generated run descriptions and command lines never crash score4.

The strategies (tests/_fuzz.py) derive from the schema and the click command tree, so keys and
options added later are fuzzed without new test code. Asserted for every example: the input is
accepted or refused with one :class:`~score4.errors.Score4Error` line (CLI: exit 0 or 2, one
``score4: error:`` line), no other exception, no traceback, no hang (an alarm), nothing written
on an error, no input changed. The default run is small and derandomized (the same examples
every time); ``make test-deep`` runs many more, and command lines in subprocesses (``run``,
``range`` and ``geometry check`` start Geant4, which pytest itself never imports).
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import shutil
import signal
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
import yaml
from _bad_inputs import results_file, text_grid
from _fuzz import VALID, command_line, commands, documents
from hypothesis import HealthCheck, assume, event, given, settings

from score4.cli.main import cli, main
from score4.errors import ConfigError, Score4Error
from score4.inputs import limits
from score4.inputs.config import load_config
from score4.inputs.units import parse_count
from score4.source.build import make_source
from score4.world.scene import build_scene

ROOT = Path(__file__).resolve().parents[1]
# hypothesis warns when it prints a failing example with a 10 kB string (one of the hostile
# values); the failure itself is what counts
pytestmark = pytest.mark.filterwarnings("ignore:Generating overly large repr")
FAST = dict(
    derandomize=True,
    database=None,
    deadline=None,
    suppress_health_check=list(HealthCheck),
)
#: Seconds one example may take before it counts as a hang.
HANG = 120
#: Memory a fuzzed surface or run may plan (refused above: the memory checks are fuzzed too).
FUZZ_MEMORY = 256 * 2**20
# Commands that start Geant4 in the calling process, or install data from the internet.
GEANT4_COMMANDS = {"run", "range", "geometry check"}
OFFLINE_SKIP = {"data install"}


@contextlib.contextmanager
def alarm(seconds: int) -> Iterator[None]:
    """Fail an example that takes longer than ``seconds`` (a hang), instead of waiting on it."""

    def hang(signum, frame):
        raise TimeoutError(f"no answer within {seconds} s: a hang")

    previous = signal.signal(signal.SIGALRM, hang)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)


def _one_line(err: Exception) -> None:
    text = str(err)
    assert text, type(err)
    assert "\n" not in text, text
    assert len(text) < 1500, text[:300]


@pytest.fixture(scope="module")
def pool(tmp_path_factory) -> Path:
    """The files command lines and descriptions refer to: valid ones, broken ones, a folder."""
    folder = tmp_path_factory.mktemp("pristine")
    (folder / "c.yaml").write_text(yaml.safe_dump(VALID))
    spikes = {"kind": "spikes", "nx": 3, "ny": 2, "width": "5 um", "height": "2 um"}
    (folder / "s.yaml").write_text(yaml.safe_dump(spikes))
    text_grid(folder / "g.txt")
    (folder / "depth.txt").write_text("# unit: nm\n0 1\n20 1\n")
    (folder / "bad.yaml").write_text("targets: [\n")
    (folder / "dir").mkdir()
    shutil.copy(ROOT / "tests" / "data" / "macros" / "portal_example.mac", folder / "m.mac")
    results_file(folder / "r.h5")
    with contextlib.chdir(folder), contextlib.redirect_stderr(io.StringIO()):
        assert main(["surface", "generate", "s.yaml", "--out", "s.s4s.h5"]) == 0
        assert main(["vertices", "c.yaml", "--out", "v.h5"]) == 0
    return folder


def _digests(folder: Path) -> dict[str, str]:
    return {
        str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in folder.rglob("*")
        if p.is_file()
    }


@pytest.fixture
def work(pool: Path, tmp_path: Path) -> Path:
    folder = tmp_path / "work"
    shutil.copytree(pool, folder)
    return folder


def _restore(folder: Path, pool: Path) -> None:
    shutil.rmtree(folder)
    shutil.copytree(pool, folder)


def check_document(doc: dict, folder: Path) -> None:
    """Validate ``doc`` as a file in ``folder``; if valid, build its scene and draw events."""
    path = folder / "doc.yaml"
    path.write_text(yaml.safe_dump(doc, allow_unicode=True))
    with alarm(HANG), pytest.MonkeyPatch.context() as mp:
        mp.setattr(limits, "memory_limit", lambda: FUZZ_MEMORY)
        try:
            config = load_config(path)
        except ConfigError as err:
            _one_line(err)
            event("refused when validated")
            return
        try:
            scene = build_scene(config)
            make_source(config, scene).events(config.run.seed, 0, min(config.run.events, 30))
            event("valid: scene built, events drawn")
        except Score4Error as err:
            _one_line(err)
            event("refused when built")


def check_command(argv: list[str], folder: Path, pool: Path) -> None:
    """Run ``score4 argv`` in ``folder``: exit 0 or 2, one error line, inputs unchanged."""
    before = _digests(folder)
    err, out = io.StringIO(), io.StringIO()
    with (
        alarm(HANG),
        contextlib.chdir(folder),
        contextlib.redirect_stderr(err),
        contextlib.redirect_stdout(out),
        pytest.MonkeyPatch.context() as mp,
    ):
        mp.setattr(limits, "memory_limit", lambda: FUZZ_MEMORY)
        code = main(argv)
    event(f"{' '.join(a for a in argv[:2] if not a.startswith('-'))}: exit {code}")
    _check_outcome(argv, code, err.getvalue(), before, _digests(folder))
    _restore(folder, pool)


def _check_outcome(argv, code, err: str, before: dict, after: dict) -> None:
    assert code in (0, 2), (argv, code, err[-2000:])
    assert "Traceback" not in err, (argv, err[-2000:])
    if code == 2:
        lines = [line for line in err.splitlines() if line.startswith("score4: error:")]
        assert len(lines) == 1, (argv, err[-2000:])
        assert lines[0] == err.splitlines()[-1], (argv, err[-2000:])
        assert after == before, (argv, "an output was written although the command failed")
        return
    changed = {name for name, h in before.items() if after.get(name) != h}
    # what follows an option may be an output the command was told to write (--png x
    # --overwrite); the other words name inputs, which must stay as they were
    given = {argv[i + 1] for i, a in enumerate(argv[:-1]) if a.startswith("-")}
    assert not changed & (set(argv) - given), (argv, "an input file was changed", changed)


@settings(max_examples=80, **FAST)
@given(doc=documents())
def test_fuzzed_descriptions_are_accepted_or_refused_in_one_line(doc, work):
    check_document(doc, work)


IN_PROCESS = commands(cli, GEANT4_COMMANDS | OFFLINE_SKIP)


@settings(max_examples=25, **FAST)
@given(argv=command_line(IN_PROCESS))
def test_fuzzed_command_lines_exit_0_or_2(argv, work, pool):
    check_command(argv, work, pool)


# ------------------------------------------------------------------------------------- deep


@pytest.mark.deep
@settings(max_examples=3000, **FAST)
@given(doc=documents())
def test_deep_fuzzed_descriptions(doc, work):
    check_document(doc, work)


@pytest.mark.deep
@settings(max_examples=600, **FAST)
@given(argv=command_line(IN_PROCESS))
def test_deep_fuzzed_command_lines(argv, work, pool):
    check_command(argv, work, pool)


def _small(argv: list[str]) -> bool:
    """Command lines whose Geant4 work stays small (a fuzz run is not a benchmark)."""
    for opt in ("--events", "--n", "--srim-events", "--points", "--max-placements"):
        if opt in argv[:-1]:
            try:
                if parse_count(argv[argv.index(opt) + 1]) > 2000:
                    return False
            except ConfigError:
                pass
    return "--compare-srim" not in argv


@pytest.mark.deep
@settings(max_examples=120, **FAST)
@given(argv=command_line(commands(cli, OFFLINE_SKIP)))
def test_deep_fuzzed_command_lines_in_subprocesses(argv, work, pool):
    """Every command, Geant4 ones included, as its own process: no signal, no hang."""
    assume(_small(argv))
    before = _digests(work)
    try:
        p = subprocess.run(
            [sys.executable, "-m", "score4", *argv],
            cwd=work,
            capture_output=True,
            text=True,
            timeout=HANG * 3,
            check=False,
        )
    except subprocess.TimeoutExpired:
        pytest.fail(f"{argv}: no answer within {HANG * 3} s (a hang)")
    assert p.returncode >= 0, (argv, "killed by a signal", p.stderr[-2000:])
    _check_outcome(argv, p.returncode, p.stderr, before, _digests(work))
    _restore(work, pool)
