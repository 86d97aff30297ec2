"""Fuzz suite: generated run descriptions and command lines never crash score4.

The strategies (tests/helpers/fuzz.py) derive from the schema and the click command tree, so
keys and options added later are fuzzed without new test code. Asserted for every example: the
input is accepted or refused with one :class:`~score4.errors.Score4Error` line (CLI: exit 0 or
2, one ``score4: error:`` line), no other exception, no traceback, no hang (an alarm), nothing
written on an error, no input changed. The default run is small and derandomized (the same
examples every time); ``make test-deep`` runs many more, and command lines in subprocesses
(``run``, ``range`` and ``geometry check`` start Geant4, which pytest itself never imports).
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import re
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, assume, event, given, settings
from hypothesis import strategies as st

from score4.cli.main import cli, main
from score4.common import limits
from score4.common.units import parse_count
from score4.errors import ConfigError, Score4Error
from score4.inputs.config import load_config
from score4.source.build import make_source
from score4.world.resolve import build_scene

from helpers.bad_inputs import results_file, text_grid
from helpers.fuzz import VALID, command_line, commands, documents

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
# Commands that start Geant4 (in the calling process or a spawned one), or install data from the
# internet.
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


def _check_activeness(scene, points: np.ndarray) -> None:
    """With activeness: its weights at the drawn vertices (on and under the rough face) are
    finite and in [0, 1], and every distance to the volume's surface is finite and >= 0."""
    if not any(t.config.activeness for t in scene.targets):
        return
    from score4.world.activeness import target_distances, volume_activeness

    distances = target_distances(scene)
    for model, distance in zip(volume_activeness(scene, distances), distances, strict=True):
        if model is None or distance is None:
            continue
        below = points - [0.0, 0.0, 2e-3]  # 2 um under each vertex as well
        probe = np.concatenate([points, below])
        w = model.weights(probe)
        assert np.isfinite(w).all()
        assert ((w >= 0) & (w <= 1)).all()
        d = distance.to_surface(probe)
        assert np.isfinite(d).all()
        assert (d >= 0).all()
    event("valid: activeness weighed")


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
            primaries = make_source(config, scene).events(
                config.run.seed, 0, min(config.run.events, 30)
            )
            event("valid: scene built, events drawn")
            _check_activeness(scene, primaries.position)
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


# ----------------------------------------------------------------- issue 26: outputs, sizes, Ctrl-C

#: Commands with outputs, each with the inputs it reads and its output options.
WRITERS = [
    (["vertices", "c.yaml"], ["c.yaml"], ["--out"]),
    (["template", "r.h5", "--activity", "1 mBq/cm2"], ["r.h5"], ["--out", "--root", "--plot"]),
    (["export", "r.h5"], ["r.h5"], ["--csv", "--events-csv", "--root"]),
    (["plot", "r.h5"], ["r.h5"], ["--out"]),
    (["surface", "show", "s.s4s.h5"], ["s.s4s.h5"], ["--png"]),
    (["surface", "export", "s.s4s.h5"], ["s.s4s.h5"], ["--stl"]),
    (["import-macro", "m.mac"], ["m.mac"], ["--out"]),
    (["geometry", "export", "c.yaml"], ["c.yaml"], ["--gdml"]),
]


def _spellings(name: str) -> st.SearchStrategy:
    """Other names of the file ``name`` in the work folder: ./x, dir/../x, a link to it."""
    return st.sampled_from([name, f"./{name}", f"dir/../{name}", f"link-to-{name}"])


@st.composite
def outputs_onto_inputs(draw) -> tuple[list[str], str]:
    """A command line one of whose outputs is one of its inputs (under any spelling) or another
    of its outputs; and the words the refusal must hold."""
    head, inputs, options = draw(st.sampled_from(WRITERS))
    argv = list(head)
    clash = draw(st.sampled_from(options))
    if len(options) > 1 and draw(st.booleans()):  # two outputs, one file
        other = draw(st.sampled_from([o for o in options if o != clash]))
        name = draw(st.sampled_from(["same.h5", "same.png"]))
        argv += [other, name, clash, draw(st.sampled_from([name, f"./{name}"]))]
        expect = "is also the output of"
    else:
        argv += [clash, draw(_spellings(draw(st.sampled_from(inputs))))]
        expect = "an output never replaces an input"
    return [*argv, "--overwrite"], expect


@settings(max_examples=12, **FAST)
@given(case=outputs_onto_inputs())
def test_an_output_never_replaces_an_input_nor_another_output(case, work, pool):
    argv, expect = case
    for name in ("c.yaml", "r.h5", "s.yaml", "s.s4s.h5", "m.mac"):
        (work / f"link-to-{name}").unlink(missing_ok=True)
        (work / f"link-to-{name}").symlink_to(name)
    before = _digests(work)
    err = io.StringIO()
    with alarm(HANG), contextlib.chdir(work), contextlib.redirect_stderr(err):
        code = main(argv)
    said = err.getvalue()
    assert code == 2, (argv, said)
    assert len(said.strip().splitlines()) == 1, (argv, said)
    assert expect in said, (argv, said)
    assert _digests(work) == before, argv
    _restore(work, pool)


#: Sizes a user types, by command line; each must be refused naming its limit when huge.
SIZES = [
    ["plot", "r.h5", "--out", "p.png", "--bins"],
    ["export", "r.h5", "--csv", "x.csv", "--bins"],
    ["summary", "r.h5", "--bins"],
    ["vertices", "c.yaml", "--out", "v9.h5", "--n"],
]


@settings(max_examples=10, **FAST)
@given(
    argv=st.sampled_from(SIZES),
    size=st.one_of(st.integers(10**6 + 1, 10**12), st.sampled_from([10**8, 10**15, 2**63 - 1])),
)
def test_huge_sizes_are_refused_naming_the_limit(argv, size, work, pool):
    """Far more than the memory (or score4's limit) allows: one line naming the limit, at
    once, nothing written (not the machine's whole memory, not a traceback)."""
    before = _digests(work)
    err = io.StringIO()
    with (
        alarm(HANG),
        contextlib.chdir(work),
        contextlib.redirect_stderr(err),
        pytest.MonkeyPatch.context() as mp,
    ):
        mp.setattr(limits, "memory_limit", lambda: FUZZ_MEMORY)
        assert main([*argv, str(size)]) == 2
    said = err.getvalue()
    assert len(said.strip().splitlines()) == 1, said
    assert re.search(r"limit|needs about|more than", said), said
    assert _digests(work) == before
    _restore(work, pool)


@settings(max_examples=10, **FAST)
@given(
    key=st.sampled_from(
        [("output", "histogram", "bins"), ("run", "chunk_events"), ("run", "events")]
    ),
    size=st.sampled_from([10**7, 10**13, 10**18]),
)
def test_huge_sizes_in_a_description_are_refused(key, size, work):
    doc = yaml.safe_load((work / "c.yaml").read_text())
    node = doc
    for k in key[:-1]:
        node = node.setdefault(k, {})
    node[key[-1]] = size
    path = work / "huge.yaml"
    path.write_text(yaml.safe_dump(doc))
    (work / "v2.h5").unlink(missing_ok=True)
    err = io.StringIO()
    with (
        alarm(HANG),
        contextlib.chdir(work),
        contextlib.redirect_stderr(err),
        pytest.MonkeyPatch.context() as mp,
    ):
        mp.setattr(limits, "memory_limit", lambda: FUZZ_MEMORY)
        code = main(["vertices", "huge.yaml", "--out", "v2.h5"])
    said = err.getvalue()
    if key[-1] == "chunk_events":  # a chunk never holds more than the run's events
        assert code in (0, 2), said
        (work / "v2.h5").unlink(missing_ok=True)
        return
    assert code == 2, said
    assert len(said.strip().splitlines()) == 1, said
    assert re.search(r"limit|needs about|less than or equal|more than", said), said
    assert not (work / "v2.h5").exists()


# ``python -m score4`` that says on stdout when score4's interrupt hook is in: before that
# moment a Ctrl-C meets Python's own start-up, which no program controls, and how long that
# takes depends on the machine's load, so the delay counts from the hook.
_HOOKED_MAIN = (
    "import runpy, sys; from score4.cli import quiet_interrupts; quiet_interrupts(); "
    "sys.stdout.write('hooked\\n'); sys.stdout.flush(); "
    "sys.argv[0] = 'python -m score4'; runpy.run_module('score4', run_name='__main__')"
)


def _interrupted_run(folder: Path, delay: float) -> tuple[int, str]:
    p = subprocess.Popen(
        [sys.executable, "-c", _HOOKED_MAIN, "run", "c.yaml", "--out", "ctrl.h5"],
        cwd=folder,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert p.stdout is not None
    assert p.stdout.readline() == "hooked\n"
    time.sleep(delay)
    p.send_signal(signal.SIGINT)
    _out, err = p.communicate(timeout=HANG)
    return p.returncode, err


def _check_interrupted(code: int, err: str, folder: Path) -> None:
    assert "Traceback" not in err, err[-2000:]
    if code == -signal.SIGINT:  # after the run: Python's exit gives SIGINT its default back
        assert err.rstrip().endswith("Geant4 output: ctrl.geant4.log"), err[-2000:]
        code = 0
    assert code in (0, 130), (code, err[-2000:])
    if code == 130:  # interrupted: one last line, no results, no half-written file
        assert err.strip().splitlines()[-1].startswith("score4: "), err[-2000:]
        assert not (folder / "ctrl.h5").exists()
    assert not list(folder.glob("*.partial"))
    assert not list(folder.glob(".*.partial"))


def test_a_ctrl_c_swallowed_by_a_c_extension_still_ends_the_command():
    """A KeyboardInterrupt raised where C code can only report it as "Exception ignored"
    (here a ``__del__``; in real runs pydantic-core building a validator) still ends the
    command with ``score4: aborted`` and status 130, instead of being lost. The command goes
    on in short sleeps (the interrupt is delivered between two of them, at once), for up to
    60 s: a lost interrupt prints ``went on`` then, however loaded the machine."""
    code = (
        "import time; from score4.cli import quiet_interrupts; quiet_interrupts()\n"
        "class Swallowed:\n"
        "    def __del__(self):\n"
        "        raise KeyboardInterrupt\n"
        "Swallowed()\n"
        "end = time.monotonic() + 60\n"
        "while time.monotonic() < end:\n"
        "    time.sleep(0.01)\n"
        "print('went on')\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert done.returncode == 130, (done.returncode, done.stderr)
    assert done.stderr.strip().splitlines()[-1] == "score4: aborted", done.stderr
    assert "went on" not in done.stdout
    assert "Traceback" not in done.stderr


@settings(max_examples=3, **FAST)
@given(delay=st.floats(0.0, 2.5))
def test_ctrl_c_at_any_moment_ends_in_one_line(delay, work, pool):
    """Ctrl-C from the moment score4's hook is in (while it imports its commands, builds the
    scene, starts Geant4): ``score4: aborted`` or the run's own message, status 130, never a
    traceback."""
    try:
        code, err = _interrupted_run(work, delay)
        event(f"exit {code}")
        _check_interrupted(code, err, work)
    finally:  # a failing example is replayed: it must find the same folder
        _restore(work, pool)


@pytest.mark.deep
@settings(max_examples=25, **FAST)
@given(delay=st.floats(0.0, 6.0))
def test_deep_ctrl_c_at_any_moment(delay, work, pool):
    try:
        code, err = _interrupted_run(work, delay)
        event(f"exit {code}")
        _check_interrupted(code, err, work)
    finally:  # a failing example is replayed: it must find the same folder
        _restore(work, pool)
