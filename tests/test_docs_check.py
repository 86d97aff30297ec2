"""tools/docs_check.py: quoted transcripts and values are compared with what commands print, and
every transcript and figure of the documents is covered by a check.

Runs the checker on scratch documents and a scratch checks.yaml whose commands are ``echo``,
so it is fast and needs no Geant4; ``make docs-check`` runs the real checks. The last tests
apply the coverage rule and the marker names to the repository's own pages (no command run).
"""

from __future__ import annotations

import importlib.util
import sys

import pytest

from conftest import ROOT

spec = importlib.util.spec_from_file_location("docs_check", ROOT / "tools" / "docs_check.py")
docs_check = importlib.util.module_from_spec(spec)
sys.modules["docs_check"] = docs_check
spec.loader.exec_module(docs_check)

CHECKS = """\
checks:
  counts:
    commands:
      - "printf 'wrote a.h5: 5000 events, seed 1\\\\nwall time     3.21 s\\\\ndone\\\\n'"
      - "echo 'rough 1021 of 5000'"
      - write-block DOC.md yaml 1 copy.yaml
      - cat copy.yaml
      - "printf 'a 1\\\\nb 2\\\\nc 3\\\\n'; false || true"
    ignore: ["wall time"]
    values:
      rough: "^rough (\\\\d+) of"
"""

DOC = """\
# A page

```yaml
answer: 42
```

<!-- check: counts -->
```text
$ printf 'wrote a.h5: 5000 events, seed 1\\nwall time     3.21 s\\ndone\\n'
wrote a.h5: {events} events, seed 1
wall time     9.99 s
done
$ cat copy.yaml
answer: 42
```

<!-- check: counts: echo 'rough 1021 of 5000' -->
```text
rough {rough} of 5000
```

{abc}

The rough face has <!-- value: counts.rough -->{rough}<!-- /value --> events.
"""

ABC = """<!-- check: counts -->
```text
$ printf 'a 1\\nb 2\\nc 3\\n'; false
{lines}
```"""


@pytest.fixture
def page(tmp_path, monkeypatch):
    (tmp_path / "checks.yaml").write_text(CHECKS.replace("DOC.md", str(tmp_path / "DOC.md")))
    monkeypatch.setattr(docs_check, "CHECKS", tmp_path / "checks.yaml")
    monkeypatch.setattr(docs_check, "ROOT", tmp_path)
    monkeypatch.setattr(docs_check, "LINKED", ())

    def write(events: str = "5000", rough: str = "1021", abc: str = "a 1\nb 2\nc 3"):
        doc = tmp_path / "DOC.md"
        doc.write_text(DOC.format(events=events, rough=rough, abc=ABC.format(lines=abc)))
        return doc

    return write


def check(doc, update: bool = False) -> int:
    return docs_check.check_document(doc, docs_check.load_checks(), None, update=update)


def test_matching_page_passes(page):
    assert check(page()) == 0


def test_stale_numbers_are_found_and_updated(page, capsys):
    doc = page(events="4999", rough="4233")
    assert check(doc) == 3
    out = capsys.readouterr().out
    assert "quoted: wrote a.h5: 4999 events, seed 1" in out
    assert "actual: wrote a.h5: 5000 events, seed 1" in out
    assert "quoted '4233', actual '1021'" in out
    assert check(doc, update=True) == 3
    text = doc.read_text()
    assert "wrote a.h5: 5000 events" in text
    assert "rough 1021 of 5000" in text
    assert "-->1021<!--" in text
    assert "wall time     9.99 s" in text  # ignored lines are paired, not compared
    assert check(doc) == 0


def test_a_line_left_out_silently_is_a_difference(page, capsys):
    doc = page(abc="a 1\nc 3")
    assert check(doc) == 1
    assert "do not pair with the output line for line" in capsys.readouterr().out
    assert check(doc, update=True) == 1  # no omission marked: the block is rewritten
    assert "a 1\nb 2\nc 3\n```" in doc.read_text()
    assert check(doc) == 0


@pytest.mark.parametrize("lines", ["a 1\n...", "...\nc 3", "a 1\n[1 line omitted]\nc 3", "..."])
def test_marked_omissions_pass(page, lines):
    assert check(page(abc=lines)) == 0


def test_a_wrong_omission_count_is_a_difference_and_updated(page, capsys):
    doc = page(abc="[1 lines omitted]\nc 3")
    assert check(doc) == 1
    assert "actual: [2 lines omitted]" in capsys.readouterr().out
    check(doc, update=True)
    assert check(doc) == 0


def test_a_line_the_program_no_longer_prints_is_a_difference(page, capsys):
    doc = page(abc="a 1\nb 2\nc 3\nd 4\n...")
    assert check(doc) == 1
    assert check(doc, update=True) == 1
    assert "(edit them: --update cannot)" in capsys.readouterr().out  # omissions: by hand


def test_a_dollar_line_must_be_a_command_of_the_check(page):
    doc = page()
    doc.write_text(doc.read_text().replace("$ cat copy.yaml", "$ cat other.yaml"))
    with pytest.raises(docs_check.CheckError, match="is not a command of check counts"):
        check(doc)


def test_a_wrapped_command_is_shown_as_the_check_says(tmp_path, monkeypatch):
    (tmp_path / "checks.yaml").write_text(
        "checks:\n  wrapped:\n    commands:\n"
        "      - {run: \"sh -c 'echo hello'\", shown: echo hello}\n"
    )
    monkeypatch.setattr(docs_check, "CHECKS", tmp_path / "checks.yaml")
    monkeypatch.setattr(docs_check, "LINKED", ())
    doc = tmp_path / "DOC.md"
    doc.write_text("<!-- check: wrapped -->\n```text\n$ echo hello\nhello\n```\n")
    assert check(doc) == 0


SLOW_CHECKS = """\
checks:
  table:
    commands:
      - "echo 'some text'; echo '| face | share | CPU s |'; echo '| --- | --- | --- |'"
      - "echo '| flat | 31.65 % | 2.8 |'; echo '| rough | 14.70 % | 3.5 |'; echo 'end'"
    mask: ["\\\\| [\\\\d.]+ \\\\|$"]
  bench:
    slow: true
    smoke: ""
    commands:
      - "echo 'build 12 s'"
      - "echo 'TRIM 4 ms per ion, 1000 ions'"
    mask: ["\\\\d+ ms per ion"]
    values:
      ms: "^TRIM (\\\\d+) ms"
      ions: "(\\\\d+) ions"
"""

TABLE_DOC = """\
<!-- check: table -->
| face | share | CPU s |
|---|---|---|
| flat | {flat} % | 9.9 |
| rough | 14.70 % | 0.1 |

<!-- check: bench -->
```text
build 99 s
...
```

About <!-- value: bench.ms -->{ms}<!-- /value --> ms per ion,
<!-- value: bench.ions -->{ions}<!-- /value --> ions.
"""


@pytest.fixture
def table_page(tmp_path, monkeypatch):
    (tmp_path / "checks.yaml").write_text(SLOW_CHECKS)
    monkeypatch.setattr(docs_check, "CHECKS", tmp_path / "checks.yaml")
    monkeypatch.setattr(docs_check, "ROOT", tmp_path)
    monkeypatch.setattr(docs_check, "LINKED", ())

    def write(flat: str, ms: str = "4", ions: str = "1000"):
        doc = tmp_path / "DOC.md"
        doc.write_text(TABLE_DOC.format(flat=flat, ms=ms, ions=ions))
        return doc

    return write


def test_table_rows_are_compared_and_masked_cells_only_by_shape(table_page, capsys):
    doc = table_page("31.65")
    checks = docs_check.load_checks()
    # the CPU cells differ (masked); the slow check is not run by default
    assert docs_check.check_document(doc, checks, None, update=False) == 0
    assert checks["bench"].output is None
    doc = table_page("31.64")
    assert docs_check.check_document(doc, checks, None, update=False) == 1
    assert "actual: | flat | 31.65 % | 2.8 |" in capsys.readouterr().out


def test_a_table_must_be_printed_whole(table_page, capsys):
    doc = table_page("31.65")
    doc.write_text(doc.read_text().replace("| rough | 14.70 % | 0.1 |\n", ""))
    assert docs_check.check_document(doc, docs_check.load_checks(), None, update=False) == 1
    assert "+| rough | 14.70 % | 3.5 |" in capsys.readouterr().out


def test_slow_checks_run_with_all(table_page, capsys):
    doc = table_page("31.65")
    checks = docs_check.load_checks()
    assert docs_check.check_document(doc, checks, None, update=False, run_all=True) == 1
    assert "actual: build 12 s" in capsys.readouterr().out


def test_a_masked_value_is_compared_by_shape_only_unless_remeasured(
    table_page, capsys, monkeypatch
):
    checks = docs_check.load_checks()
    # a timing in the text (inside the mask): another figure passes
    doc = table_page("31.65", ms="7")
    assert docs_check.check_document(doc, checks, "bench", update=False) == 1  # build 99 s only
    assert "bench.ms" not in capsys.readouterr().out
    # a value outside the masked part is compared exactly
    doc = table_page("31.65", ions="999")
    assert docs_check.check_document(doc, checks, "bench", update=False) == 2
    assert "[bench.ions] quoted '999', actual '1000'" in capsys.readouterr().out
    # --remeasure: masked figures are taken from the new run too
    monkeypatch.setattr(docs_check, "REMEASURE", True)
    doc = table_page("31.65", ms="7")
    assert docs_check.check_document(doc, checks, None, update=True, run_all=True) == 4
    assert "-->4<!--" in doc.read_text()
    assert "| flat | 31.65 % | 2.8 |" in doc.read_text()


# --- --smoke: the slow checks run small, their output compared by shape ---------------------

FAKE_BENCH = """\
import argparse, sys
p = argparse.ArgumentParser()
p.add_argument("--cases", default="a,b,c")
p.add_argument("--rounds", type=int, default=3)
p.add_argument("--header", default="case")
p.add_argument("--fail", action="store_true")
a = p.parse_args()
print("measured 2026-11-27, load 0.5 at the start")
print(f"| {a.header} | ms per event | ratio |")
print("| --- | --- | --- |")
for k, case in enumerate(a.cases.split(",")):
    print(f"| {case} {k + 1} um | {10.5 * (k + 1):.3f} | {k + 1:.2f} |")
print("rounds: " + ", ".join(f"{r + 0.5:.2f}" for r in range(a.rounds)))
sys.exit(1 if a.fail else 0)
"""

SMOKE_DOC = """\
Measured at load <!-- value: fake.load -->0.3<!-- /value -->.

<!-- check: fake -->
| case | ms per event | ratio |
| --- | --- | --- |
| a 1 um | 9.100 | 1.00 |
| b 2 um | 18.200 | 2.00 |
| c 3 um | 27.300 | 3.00 |

<!-- check: fake -->
```text
$ python BENCH --rounds 5
measured 2026-11-20, load 2.0 at the start
...
rounds: 0.40, 1.40, 2.40, 3.40, 4.40
```
"""


@pytest.fixture
def smoke_page(tmp_path, monkeypatch):
    bench = tmp_path / "benchmarks" / "fake.py"
    bench.parent.mkdir()
    bench.write_text(FAKE_BENCH)
    monkeypatch.setattr(docs_check, "CHECKS", tmp_path / "checks.yaml")
    monkeypatch.setattr(docs_check, "ROOT", tmp_path)
    monkeypatch.setattr(docs_check, "LINKED", ())
    doc = tmp_path / "DOC.md"
    doc.write_text(SMOKE_DOC.replace("BENCH", str(bench)))
    monkeypatch.setattr(docs_check, "DOCS", [doc])

    def write(smoke: str) -> None:
        (tmp_path / "checks.yaml").write_text(
            "checks:\n  fake:\n    slow: true\n"
            f"    smoke: {smoke}\n"
            f"    commands: ['python {bench} --rounds 5']\n"
            "    values: {load: 'load ([\\d.]+) at'}\n"
        )

    return write


def test_smoke_runs_a_slow_check_small_and_compares_the_shape_only(smoke_page, capsys):
    # fewer cases and rounds: other numbers, fewer table rows, a shorter list: the same shape
    smoke_page("'--cases a,c --rounds 1'")
    assert docs_check.main(["--smoke"]) == 0
    assert "1 slow checks run small (--smoke)" in capsys.readouterr().out
    assert docs_check.main([]) == 0  # without --smoke: skipped, as before
    assert "skipped (slow, run with --all): fake" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("smoke", "status", "message"),
    [
        ("'--header name'", 1, "no table with the header '| case | ms per event | ratio |'"),
        ("'--cases a,d'", 1, "the table's rows do not pair with the quoted rows"),
        ("'--cases c,a'", 1, "the table's rows do not pair with the quoted rows"),  # order
        ("'--fail'", 2, "exited 1"),
        ("'--rounds 0'", 1, "does not pair with the quoted lines by shape"),  # no number
        ("{'--rounds 5': '--rounds 2'}", 0, "run small"),
        ("{'--round 9': '--rounds 2'}", 2, "smoke replaces '--round 9': in no command"),
    ],
)
def test_smoke_finds_a_changed_shape_a_failed_run_and_a_stale_smoke(
    smoke_page, capsys, smoke, status, message
):
    smoke_page(smoke)
    assert docs_check.main(["--smoke"]) == status
    assert message in capsys.readouterr().out


def test_a_slow_check_needs_smoke_arguments_and_they_go_before_a_pipe(smoke_page):
    smoke_page("''")
    text = docs_check.CHECKS.read_text()
    docs_check.CHECKS.write_text(text.replace("    smoke: ''\n", ""))
    with pytest.raises(docs_check.CheckError, match="a slow check needs `smoke:`"):
        docs_check.load_checks()
    check = docs_check.Check("x", ["python benchmarks/b.py --n 9 --md > t.md && cat t.md"])
    check.smoke = "--n 1"
    assert docs_check.smoked(check).commands == [
        "python benchmarks/b.py --n 9 --md --n 1 > t.md && cat t.md"
    ]


# --- the coverage rule ---------------------------------------------------------------------


def problems(tmp_path, text: str) -> list[str]:
    doc = tmp_path / "page.md"
    doc.write_text(text)
    return docs_check.coverage(doc)


@pytest.mark.parametrize(
    "text",
    [
        "```yaml\nrun: {events: 10}\n```\n",
        "```bash\nscore4 run x.yaml\n```\n",
        "<!-- not-output: the layout of a file -->\n```text\n/run  attrs\n```\n",
        "Built in <!-- value: x.seconds -->12<!-- /value --> s.\n",
        "At most <!-- not-output: a rule -->25 %<!-- /not-output --> may lie below.\n",
        "<!-- not-output: a rule -->25 %<!-- /not-output --> may lie below.\n",
        "A 50 x 50 grid of 10 um pyramids, 5000 events, seed 1, `--events 2000`, 2026-11-25.\n",
        "ENSDF archive of September 2023 ![1 m face, 2.2 GB](img/x.png)\n",
        "<!-- not-output: ENSDF -->\n* Po-210 5304.33 keV, Bi-214 45.49 %\n  and 2614.511\n",
        "| key | default |\n| --- | --- |\n| `events` | `1000` |\n",
        "<!-- not-output: the options -->\n| option | meaning |\n| --- | --- |\n| x | 89.99 |\n",
    ],
)
def test_covered_or_not_a_figure(tmp_path, text):
    assert problems(tmp_path, text) == []


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("```\nwrote x.h5: 10 events\n```\n", "a ``` block with no check"),
        ("```text\nwrote x.h5\n```\n", "a ```text block with no check"),
        ("```bash\n$ score4 run x.yaml\nwrote x.h5\n```\n", "is a transcript"),
        ("The run took 90 s.\n", "figure '90 s'"),
        ("It peaks at ~2.2 GB.\n", "figure '~2.2 GB'"),
        ("Blocks are 10-20x faster.\n", "figure '10-20x'"),
        ("31 % of the vertices.\n", "figure '31 %'"),
        ("A mean deposit of 2.6976 MeV.\n", "figure '2.6976'"),
        ("with 789 of 2000 full-energy events\n", "figure '789 of 2000'"),
        ("| case | s |\n| --- | --- |\n| flat | 12 s |\n", "a table with figures (12 s)"),
        ("<!-- not-output: ENSDF -->\n* Po-210 5304.33 keV\n* took 12 s\n", "figure '12 s'"),
    ],
)
def test_uncovered_transcripts_and_figures_are_found(tmp_path, text, message):
    found = problems(tmp_path, text)
    assert len(found) == 1
    assert message in found[0]
    assert found[0].startswith(str(tmp_path / "page.md"))


def test_a_span_must_close_on_its_line(tmp_path):
    found = problems(tmp_path, "shares <!-- not-output: areas -->0.05,\n0.10<!-- /not-output -->\n")
    assert found
    assert all("must close on its line" in p for p in found)


def test_a_marker_must_stand_above_a_block_or_table(tmp_path):
    with pytest.raises(docs_check.CheckError, match="directly above"):
        problems(tmp_path, "<!-- check: x -->\n\n```text\nout\n```\n")
    with pytest.raises(docs_check.CheckError, match="must say what it marks"):
        problems(tmp_path, "<!-- not-output -->\n```text\nout\n```\n")


def test_every_transcript_and_figure_of_the_repository_is_covered():
    """The coverage rule on README.md and docs/*.md: nothing is run, so this is quick."""
    found = [p for path in docs_check.DOCS for p in docs_check.coverage(path)]
    assert found == [], "\n".join([*found, docs_check.HOW_TO_COVER])


def test_every_check_of_the_repository_is_quoted_and_every_marker_known():
    """The real docs/checks.yaml and documents agree on names (no command is run)."""
    assert set(docs_check.quoted_names()) == set(docs_check.load_checks())
