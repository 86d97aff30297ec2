"""tools/docs_check.py: quoted transcripts and values are compared with what commands print.

Runs the checker on a scratch document and a scratch checks.yaml whose commands are ``echo``,
so it is fast and needs no Geant4; ``make docs-check`` runs the real checks.
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
      - "echo 'wrote a.h5: 5000 events, seed 1'"
      - "echo 'wall time     3.21 s'"
      - "echo 'rough 1021 of 5000'"
      - write-block DOC.md yaml 1 copy.yaml
      - cat copy.yaml
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
```
$ score4 run x.yaml
wrote a.h5: {events} events, seed 1
wall time     9.99 s
...
answer: 42
```

The rough face has <!-- value: counts.rough -->{rough}<!-- /value --> events.
"""


@pytest.fixture
def page(tmp_path, monkeypatch):
    (tmp_path / "checks.yaml").write_text(CHECKS.replace("DOC.md", str(tmp_path / "DOC.md")))
    monkeypatch.setattr(docs_check, "CHECKS", tmp_path / "checks.yaml")
    monkeypatch.setattr(docs_check, "ROOT", tmp_path)
    monkeypatch.setattr(docs_check, "LINKED", ())

    def write(events: str, rough: str):
        doc = tmp_path / "DOC.md"
        doc.write_text(DOC.format(events=events, rough=rough))
        return doc

    return write


def test_matching_page_passes(page):
    doc = page("5000", "1021")
    assert docs_check.check_document(doc, docs_check.load_checks(), None, update=False) == 0


def test_stale_numbers_are_found_and_updated(page, capsys):
    doc = page("4999", "4233")
    checks = docs_check.load_checks()
    assert docs_check.check_document(doc, checks, None, update=False) == 2
    out = capsys.readouterr().out
    assert "quoted: wrote a.h5: 4999 events, seed 1" in out
    assert "actual: wrote a.h5: 5000 events, seed 1" in out
    assert "quoted '4233', actual '1021'" in out
    assert docs_check.check_document(doc, checks, None, update=True) == 2
    text = doc.read_text()
    assert "wrote a.h5: 5000 events" in text
    assert "-->1021<!--" in text
    assert "wall time     9.99 s" in text  # ignored lines are paired, not compared
    assert docs_check.check_document(doc, checks, None, update=False) == 0


def test_a_line_the_program_no_longer_prints_is_an_error(page, tmp_path):
    doc = page("5000", "1021")
    doc.write_text(doc.read_text().replace("seed 1", "physics full"))
    with pytest.raises(docs_check.CheckError, match="no output line has the shape"):
        docs_check.check_document(doc, docs_check.load_checks(), None, update=False)


def test_every_check_of_the_repository_is_quoted_and_every_marker_known():
    """The real docs/checks.yaml and documents agree on names (no command is run)."""
    checks = docs_check.load_checks()
    used = set()
    for path in docs_check.DOCS:
        text = path.read_text()
        used |= {
            m.group(1) for line in text.splitlines() if (m := docs_check.BLOCK_MARK.match(line))
        }
        used |= {m.group(1) for m in docs_check.VALUE_MARK.finditer(text)}
    assert used == set(checks)


SLOW_CHECKS = """\
checks:
  table:
    commands:
      - "echo '| flat | 31.65 % | 2.8 |'"
      - "echo '| rough | 14.70 % | 3.5 |'"
    mask: ["\\\\| [\\\\d.]+ \\\\|$"]
  bench:
    slow: true
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
| face | share 50-110 keV | CPU s |
| --- | --- | --- |
| flat | {flat} % | 9.9 |
| rough | 14.70 % | 0.1 |

<!-- check: bench -->
```
build 99 s
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


def test_slow_checks_run_with_all(table_page, capsys):
    doc = table_page("31.65")
    checks = docs_check.load_checks()
    assert docs_check.check_document(doc, checks, None, update=False, run_all=True) == 1
    assert "actual: build 12 s" in capsys.readouterr().out


def test_a_masked_value_is_compared_by_shape_only(table_page, capsys):
    checks = docs_check.load_checks()
    # a timing in the text (inside the mask): another figure passes
    doc = table_page("31.65", ms="7")
    assert docs_check.check_document(doc, checks, "bench", update=False) == 1  # build 99 s only
    assert "bench.ms" not in capsys.readouterr().out
    # a value outside the masked part is compared exactly
    doc = table_page("31.65", ions="999")
    assert docs_check.check_document(doc, checks, "bench", update=False) == 2
    assert "[bench.ions] quoted '999', actual '1000'" in capsys.readouterr().out
