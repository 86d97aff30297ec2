#!/usr/bin/env python3
"""Re-run the commands behind the transcripts and figures of README.md and docs/*.md.

Fails on any difference, and on any transcript or figure that no check covers. The conventions
are written for authors at the top of ``docs/checks.yaml``; in short:

* ``docs/checks.yaml`` declares the checks: each a list of shell commands, run in a scratch
  folder that links the repository's ``examples``, ``docs``, ``tests``, ``benchmarks`` and
  ``tools`` folders, with the ``score4`` of the running Python first on PATH. Their combined output
  (stdout and stderr) is what the documents quote. Two helpers take code from the documents:
  ``write-block DOC LANG N FILE`` writes the N-th (from 1) fenced block of language LANG
  (``-``: none) in DOC to FILE; ``python-block DOC N [ARGS]`` runs the N-th ``python`` block.
* A **transcript** is a fenced block with ``<!-- check: NAME -->`` on the line above it. Every
  line is compared. ``$ COMMAND`` (one of the check's commands, shown without a trailing
  ``|| true`` / ``; test $? -eq N`` and without leading ``env`` settings, or as the check's
  ``{run: ..., shown: ...}`` entry says) starts that command's output; a block without ``$``
  lines is the whole output of the check, or of the command the marker names
  (``<!-- check: NAME: COMMAND -->``). Lines are paired in
  order by their *shape* (numbers as ``#``), then compared exactly. Omitted lines must be
  marked: a line ``...`` stands for one or more lines, ``[N lines omitted]`` for exactly N (the
  count is checked). ``...`` inside a line stands for any text. Lines matching one of the
  check's ``ignore`` patterns are paired but not compared.
* A **table** with the marker above it is compared with a whole Markdown table that the check
  prints (header, rule and rows; a row of ``...`` cells marks omitted rows).
* A **value**: ``<!-- value: NAME.KEY -->4248<!-- /value -->``, where ``values: {KEY: REGEX}``
  of the check takes the first group of the first output line the regex matches.
* Machine-dependent figures: a check's ``mask`` patterns mark the parts of a line compared by
  shape only; ``slow: true`` checks (benchmarks of minutes) run only with ``--all``.
* ``--smoke`` (``make docs-check``) also runs each slow check with the small arguments of its
  ``smoke:`` entry (every slow check needs one) and compares only the shape of its output:
  exit status 0, the quoted lines and table rows by smoke_shape() (numbers, and runs of them,
  as ``#``; rows a subset, in order), each value's pattern matching a line.
* **Coverage**: every fenced block needs a check marker, an input language (``yaml``,
  ``python``, ``bash``, ...: code the reader types, with no ``$`` prompt lines) or
  ``<!-- not-output: WHAT IT IS -->`` above it; every table holding a figure needs a check
  marker or ``<!-- not-output: ... -->``; every figure in the text (a time, a memory size, a
  percentage, a factor such as ``3x``, ``N of M``, a number of four or more significant
  digits) must be a value or sit in ``<!-- not-output: WHY -->...<!-- /not-output -->`` (one
  line), or in a paragraph or list item with ``<!-- not-output: WHY -->`` on the line above it.

``--update`` rewrites the quoted lines, counts and values from the new output instead of
failing (then read the diff); with ``--remeasure`` it also takes the masked figures (timings,
and the date and load of a measurement) from the new run, which ``--update`` alone keeps.
``--only NAME`` runs one check; ``--all`` adds the slow checks; ``--coverage`` checks coverage
only, running nothing (a second). Exit status 0: everything matches and is covered; 1: some
lines or values differ, or are not covered (each printed as file:line); 2: a check or marker is
broken.

Usage: python tools/docs_check.py [--update [--remeasure]] [--all | --smoke] [--only NAME]
       [--coverage]
"""

from __future__ import annotations

import argparse
import difflib
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parent.parent
CHECKS = ROOT / "docs" / "checks.yaml"
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
LINKED = ("examples", "docs", "tests", "benchmarks", "tools")

# --remeasure: take masked figures (timings) and values from the new output too
REMEASURE = False

# code a reader types, not output: a block in one of these languages needs no marker
INPUT_LANGUAGES = {"yaml", "yml", "python", "py", "bash", "sh", "shell", "toml", "ini", "cpp"}

NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")
FENCE = re.compile(r"^(\s*)(```+)\s*([\w+-]*)")
CHECK_MARK = re.compile(r"^\s*<!-- check: ([\w.-]+)(?:: ((?:(?!-->).)+?))? -->\s*$")
NOT_OUTPUT_MARK = re.compile(r"^\s*<!-- not-output(?:: *((?:(?!-->).)*?))? *-->\s*$")
TABLE_ROW = re.compile(r"^\s*\|")
TABLE_RULE = re.compile(r"^\s*\|[\s:|-]+\|\s*$")
VALUE_MARK = re.compile(r"<!-- value: ([\w.-]+)\.(\w+) -->(.*?)<!-- /value -->")
NOT_OUTPUT_SPAN = re.compile(r"<!-- not-output(?::[^>]*)? -->.*?<!-- /not-output -->")
LIST_ITEM = re.compile(r"^\s*(?:[*+-]|\d+\.) ")
OMITTED = re.compile(r"^\s*\[(\d+) lines? omitted\]\s*$")
OMITTED_ROW = re.compile(r"^\s*\|(\s*(\.\.\.)?\s*\|)+\s*$")

# a figure in the text: a number with a unit of time or memory, a percentage, a factor
# (3x, 1.8 times), "N of M", or a number of four or more significant digits
_NUM = r"[~\u2248]?\d[\d.,]*(?:\s?[-\u2013]\s?\d[\d.,]*)?"  # ~ and approx; - and en dash
_UNIT = (
    r"(?:\s?(?:ns|us|µs|μs|ms|s|min|minutes?|h|hours?|seconds?|days?|B|bytes|kB|KB|MB|GB|TB"
    r"|KiB|MiB|GiB|TiB|%)|[x\u00d7]|\s(?:times))(?![\w])"  # x and the multiplication sign
)
FIGURE = re.compile(
    rf"(?<![\w.^/:-])(?:{_NUM}{_UNIT}|\d+ of \d+(?![\w.])|(?<!ISO )\d[\d.]*(?![\w.]))"
)

HOW_TO_COVER = """\
How to cover a figure or transcript (conventions: top of docs/checks.yaml):
  * output of a command: add a check to docs/checks.yaml (commands: [...]) and put
    <!-- check: NAME --> on the line above the block or table, or write a figure as
    <!-- value: NAME.KEY -->12.3<!-- /value --> with values: {KEY: REGEX} in the check;
    then `python tools/docs_check.py --only NAME` (and --update to fill in the numbers);
  * a timing or memory figure: a `slow: true` check or a `mask:` pattern (compared by shape),
    and say in the page when, with which command and on what machine it was measured;
  * not output of a program (an input file, a file layout, a rule, a default, a tolerance,
    a literature value): <!-- not-output: what it is --> on the line above the block, table,
    paragraph or list item, or <!-- not-output: why -->1 %<!-- /not-output --> around the
    figure (on one line);
  * code the reader types: give the block its language (```yaml, ```python, ```bash)."""


class CheckError(Exception):
    """A broken check or marker (exit status 2)."""


@dataclass
class Check:
    name: str
    commands: list[str]
    shown: dict[str, str] = field(default_factory=dict)  # command -> how pages show it
    ignore: list[re.Pattern] = field(default_factory=list)
    mask: list[re.Pattern] = field(default_factory=list)
    slow: bool = False
    values: dict[str, re.Pattern] = field(default_factory=dict)
    smoke: str | dict[str, str] | None = None  # a slow check's small arguments (see smoked())
    smoked: bool = False  # runs the smoke commands: its output is compared by shape only
    original: list[str] = field(default_factory=list)  # smoked: the check's own commands
    outputs: list[list[str]] | None = None  # per command
    seconds: float = 0.0

    @property
    def output(self) -> list[str] | None:
        """All output lines, in order (None before the check ran)."""
        if self.outputs is None:
            return None
        return [line for lines in self.outputs for line in lines]


def load_checks() -> dict[str, Check]:
    raw = yaml.safe_load(CHECKS.read_text())
    checks = {}
    for name, spec in raw["checks"].items():
        commands = [c if isinstance(c, str) else c["run"] for c in spec["commands"]]
        shown = {c["run"]: c["shown"] for c in spec["commands"] if not isinstance(c, str)}
        checks[name] = Check(
            name=name,
            commands=commands,
            shown=shown,
            ignore=[re.compile(p) for p in spec.get("ignore", [])],
            mask=[re.compile(p) for p in spec.get("mask", [])],
            slow=bool(spec.get("slow", False)),
            values={k: re.compile(v) for k, v in spec.get("values", {}).items()},
            smoke=spec.get("smoke"),
        )
        check = checks[name]
        if check.slow and not isinstance(check.smoke, (str, dict)):
            raise CheckError(
                f"check {name}: a slow check needs `smoke:` (the small arguments that "
                "`--smoke` runs it with: a string appended to its benchmark commands, or "
                "{OLD: NEW} text replacements; '' runs the commands as they are)"
            )
        if check.smoke is not None and not check.slow:
            raise CheckError(f"check {name}: `smoke:` is for slow checks only")
    return checks


BENCHMARK = re.compile(r"\bbenchmarks/\w+\.py\b")


def smoked(check: Check) -> Check:
    """The slow check as ``--smoke`` runs it: its commands with the small arguments of its
    ``smoke:`` entry (a string: appended to every command that runs a ``benchmarks/`` script,
    where argparse takes an option's last value; a mapping: each OLD text replaced by NEW, and
    each must occur), its output compared by shape only (shape_document())."""
    commands = list(check.commands)
    if isinstance(check.smoke, str) and check.smoke.strip():
        hit = False
        for i, command in enumerate(commands):
            script = BENCHMARK.search(command)
            if script is None:
                continue
            hit = True
            # the arguments go before a trailing redirection or pipe, if any
            rest = re.search(r"\s(?:[|>]|&&)", command[script.end() :])
            cut = len(command) if rest is None else script.end() + rest.start()
            commands[i] = f"{command[:cut]} {check.smoke.strip()}{command[cut:]}"
        if not hit:
            raise CheckError(f"check {check.name}: smoke arguments, but no benchmarks/ command")
    elif isinstance(check.smoke, dict):
        for old, new in check.smoke.items():
            if not any(old in c for c in commands):
                raise CheckError(f"check {check.name}: smoke replaces {old!r}: in no command")
            commands = [c.replace(old, str(new)) for c in commands]
    shown = {
        new: check.shown.get(old, display(old))
        for old, new in zip(check.commands, commands, strict=True)
    }
    return Check(
        name=check.name,
        commands=commands,
        shown=shown,
        ignore=check.ignore,
        mask=check.mask,
        slow=True,
        values=check.values,
        smoke=check.smoke,
        smoked=True,
        original=check.commands,
    )


def doc_block(doc: str, lang: str, n: int) -> str:
    """The n-th (from 1) fenced block of language ``lang`` in the document ``doc``."""
    blocks = re.findall(
        rf"^```{re.escape(lang)}\n(.*?)^```", (ROOT / doc).read_text(), re.MULTILINE | re.DOTALL
    )
    if not 1 <= n <= len(blocks):
        raise CheckError(f"{doc} has {len(blocks)} ```{lang} blocks, not {n}")
    return blocks[n - 1]


def _expand(command: str, tmp: Path) -> str:
    """Expand the write-block / python-block helpers into plain shell commands."""
    words = command.split()
    if words[0] == "write-block" and len(words) == 5:
        lang = "" if words[2] == "-" else words[2]
        (tmp / words[4]).write_text(doc_block(words[1], lang, int(words[3])))
        return "true"
    if words[0] == "python-block" and len(words) >= 3:
        script = tmp / f"_block_{Path(words[1]).stem}_{words[2]}.py"
        script.write_text(doc_block(words[1], "python", int(words[2])))
        return " ".join(["python", script.name, *words[3:]])
    return command


def run_check(check: Check) -> list[str]:
    """Run the check's commands in a scratch folder; return the output lines."""
    if check.outputs is not None:
        return check.output or []
    env = dict(os.environ)
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}"
    env["PYTHONPATH"] = f"{ROOT / 'src'}{os.pathsep}{env.get('PYTHONPATH', '')}"
    env["COLUMNS"] = "80"  # click wraps --help to the terminal width
    start = time.perf_counter()
    outputs: list[list[str]] = []
    with tempfile.TemporaryDirectory(prefix=f"docs-check-{check.name}-") as tmp:
        for name in LINKED:
            os.symlink(ROOT / name, Path(tmp) / name)
        for command in check.commands:
            proc = subprocess.run(
                _expand(command, Path(tmp)),
                shell=True,
                cwd=tmp,
                env=env,
                stdout=subprocess.PIPE,
                stderr=subprocess.STDOUT,
                text=True,
            )
            if proc.returncode != 0:
                raise CheckError(
                    f"check {check.name}: {command!r} exited {proc.returncode}:\n{proc.stdout}"
                )
            outputs.append([line.rstrip() for line in proc.stdout.splitlines()])
    check.seconds = time.perf_counter() - start
    check.outputs = outputs
    return check.output or []


def shape(line: str) -> str:
    """The line with every number replaced by ``#`` and runs of blanks by one blank."""
    return re.sub(r"\s+", " ", NUMBER.sub("#", line.strip()))


def masked(check: Check, line: str) -> str:
    """The line with every part a ``mask`` pattern matches reduced to its shape."""
    if REMEASURE:
        return line
    for pattern in check.mask:
        line = pattern.sub(lambda m: NUMBER.sub("#", m.group(0)), line)
    return line


def display(command: str) -> str:
    """A check's command as a page shows it after ``$``: no exit-status plumbing, no env."""
    shown = re.sub(r"\s*(\|\|\s*true|;\s*test \$\? -eq \d+)\s*$", "", command.strip())
    return re.sub(r"^(?:env(?: -u \w+| \w+=\S+)+ |(?:\w+=\S+ )+)", "", shown)


# ---------------------------------------------------------------------------------------------
# comparing a quoted block with output, line by line


@dataclass
class Item:
    """One quoted line: text to compare, or an omission of some output lines."""

    index: int  # line index in the block
    text: str
    omit: bool = False
    count: int | None = None  # "[N lines omitted]"; None for "..."
    rule: bool = False  # a table's | --- | line


def _items(lines: list[str], first: int, table: bool = False) -> list[Item]:
    items = []
    for k, line in enumerate(lines):
        text = line.rstrip()
        if table and TABLE_RULE.match(text):
            items.append(Item(first + k, text, rule=True))
        elif (table and OMITTED_ROW.match(text) and "..." in text) or text.strip() == "...":
            items.append(Item(first + k, text, omit=True))
        elif m := OMITTED.match(text):
            items.append(Item(first + k, text, omit=True, count=int(m.group(1))))
        else:
            items.append(Item(first + k, text))
    return items


def smoke_shape(line: str) -> str:
    """The shape of a line, a run of numbers (``1, 2, 3``, table cells ``| 1 | 2 |``) as one
    ``#``: a smoke run's lists (rounds, sizes) are shorter than a full run's."""
    return re.sub(r"#(?:[\s,|]+#)+", "#", shape(line))


def _pattern(text: str, shaper: Callable[[str], str] = shape) -> re.Pattern:
    """The quoted line's shape; ``...`` inside it stands for any text."""
    return re.compile(".*".join(re.escape(shaper(p)) for p in text.split("...")))


def align(
    items: list[Item], output: list[str], shaper: Callable[[str], str] = shape
) -> list[tuple[int, int]] | None:
    """Pair items with output lines: (start, end) per item, or None if they do not pair (lines
    compared as ``shaper`` gives them)."""
    patterns = [None if it.omit or it.rule else _pattern(it.text, shaper) for it in items]
    shapes = [shaper(line) for line in output]

    @cache
    def go(i: int, j: int) -> tuple[tuple[int, int], ...] | None:
        if i == len(items):
            return () if j == len(output) else None
        if items[i].omit:  # one or more lines
            for k in range(j + 1, len(output) + 1):
                rest = go(i + 1, k)
                if rest is not None:
                    return ((j, k), *rest)
            return None
        if j == len(output):
            return None
        pattern = patterns[i]
        ok = TABLE_RULE.match(output[j]) if pattern is None else pattern.fullmatch(shapes[j])
        if ok:
            rest = go(i + 1, j + 1)
            if rest is not None:
                return ((j, j + 1), *rest)
        return None

    found = go(0, 0)
    return None if found is None else list(found)


def _with_elision(quoted: str, actual: str) -> str:
    """The output line, keeping the quoted line's in-line ``...`` elisions."""
    parts = quoted.split("...")
    if len(parts) == 1:
        return actual
    tail = actual[len(actual) - len(parts[-1]) :] if parts[-1] else ""
    return actual[: len(parts[0])] + "..." + tail


@dataclass
class Difference:
    line: int  # index in the document
    quoted: str
    actual: str


def compare_items(
    check: Check, items: list[Item], output: list[str]
) -> tuple[list[Difference], bool]:
    """Differences between paired items and output; False if the lines do not pair at all."""
    pairs = align(items, output)
    if pairs is None:
        return [], False
    found = []
    for item, (start, end) in zip(items, pairs, strict=True):
        if item.omit:
            if item.count is not None and item.count != end - start:
                n = end - start
                new = re.sub(r"\d+ lines?", f"{n} line{'s' if n != 1 else ''}", item.text)
                found.append(Difference(item.index, item.text, new))
            continue
        if item.rule:
            continue
        actual = output[start]
        if any(p.search(actual) for p in check.ignore):
            continue
        new = _with_elision(item.text, actual)
        if masked(check, new) != masked(check, item.text):
            found.append(Difference(item.index, item.text, new))
    return found, True


def _output_of(check: Check, command: str) -> list[str]:
    """The output of one of the check's commands, named as in checks.yaml or after ``$``."""
    assert check.outputs is not None
    for i, c in enumerate(check.commands):
        if command in (c, check.shown.get(c, display(c)), *check.original[i : i + 1]):
            return check.outputs[i]
    raise CheckError(f"{command!r} is not a command of check {check.name}")


def _segments(
    check: Check, block: list[str], first: int, command: str | None = None
) -> list[tuple[list[Item], list[str]]]:
    """Split a transcript at its ``$ COMMAND`` lines: (items, output of that command)."""
    commands = [line for line in block if line.strip().startswith("$ ")]
    if command is not None:
        if commands:
            raise CheckError(f"line {first + 1}: a marker that names a command, and $ lines")
        return [(_items(block, first), _output_of(check, command))]
    if not commands:
        return [(_items(block, first), check.output or [])]
    if block[0].strip() and not block[0].strip().startswith("$ "):
        raise CheckError(f"line {first + 1}: a transcript with $ lines must start with one")
    shown = [check.shown.get(c, display(c)) for c in check.commands]
    segments = []
    after = 0
    for k, line in enumerate(block):
        text = line.strip()
        if not text.startswith("$ "):
            continue
        command = text[2:].removeprefix(".venv/bin/")
        if command not in shown:
            raise CheckError(
                f"line {first + k + 1}: '$ {command}' is not a command of check {check.name} "
                f"(its commands: {'; '.join(shown)})"
            )
        index = next((i for i in range(after, len(shown)) if shown[i] == command), None)
        index = shown.index(command) if index is None else index
        after = index + 1
        end = next((n for n in range(k + 1, len(block)) if block[n].strip().startswith("$ ")), None)
        body = block[k + 1 : len(block) if end is None else end]
        assert check.outputs is not None
        segments.append((_items(body, first + k + 1), check.outputs[index]))
    return segments


def _tables(output: list[str]) -> list[list[str]]:
    """The Markdown tables in the output: maximal runs of lines that start with ``|``."""
    tables: list[list[str]] = []
    run: list[str] = []
    for line in [*output, ""]:
        if TABLE_ROW.match(line):
            run.append(line)
        elif run:
            tables.append(run)
            run = []
    return tables


def compare_block(
    check: Check, block: list[str], first: int, table: bool = False, command: str | None = None
) -> list[tuple[list[Difference], list[Item], list[str] | None]]:
    """Compare a quoted block with the check's output.

    Returns per segment: the differences, the items, and the output lines if the segment did
    not pair with them at all (None if it did).
    """
    run_check(check)
    if table:
        items = _items(block, first, table=True)
        output = check.output if command is None else _output_of(check, command)
        for candidate in _tables(output or []):
            found, paired = compare_items(check, items, candidate)
            if paired:
                return [(found, items, None)]
        same_header = [t for t in _tables(output or []) if t[0].strip() == block[0].strip()]
        return [([], items, same_header[0] if same_header else [])]
    results = []
    for items, output in _segments(check, block, first, command):
        found, paired = compare_items(check, items, output)
        results.append((found, items, None if paired else output))
    return results


def value_of(check: Check, key: str) -> tuple[str, bool]:
    """The value, and whether a ``mask`` pattern covers it (then it is compared by shape)."""
    if key not in check.values:
        raise CheckError(f"check {check.name}: no value {key!r} in docs/checks.yaml")
    for line in run_check(check):
        m = check.values[key].search(line)
        if m:
            spans = [s.span() for p in check.mask for s in p.finditer(line)]
            covered = any(a <= m.start(1) and m.end(1) <= b for a, b in spans)
            return m.group(1), covered
    raise CheckError(f"check {check.name}: value {key!r} matched no output line")


def _general(pattern: re.Pattern) -> re.Pattern:
    """A value's pattern with its literal numbers as any number (a smoke run's sizes differ)."""
    return re.compile(
        re.sub(r"(?<![\\{,\d])\d+(?:\\?\.\d+)?(?![\d},])", r"[\\d.]+", pattern.pattern)
    )


def _rows_in_order(items: list[Item], table: list[str]) -> bool:
    """Whether the output table has the quoted header and rule, and rows that each pair with a
    quoted row (by smoke_shape(), in the quoted order; a row of ``...`` cells: any row as wide
    as the header), at least one. A smoke run may leave cases out: their rows are not printed."""
    if len(table) < 3 or len(items) < 2 or not items[1].rule:
        return False
    if smoke_shape(table[0]) != smoke_shape(items[0].text) or not TABLE_RULE.match(table[1]):
        return False
    width = items[0].text.count("|")
    k = 2
    for row in table[2:]:
        while k < len(items):
            it = items[k]
            k += 1
            if it.omit and row.count("|") == width:
                k -= 1  # an omission stands for any number of rows
                break
            if not it.omit and _pattern(it.text, smoke_shape).fullmatch(smoke_shape(row)):
                break
        else:
            return False
    return True


def shape_problems(check: Check, part: Part, lines: list[str]) -> list[str]:
    """Why the smoke output of a slow check does not have the shape of the part quoting it
    (empty: it does). A transcript: its lines pair with the quoted lines as align() pairs them,
    each line as its smoke_shape(); a table: see _rows_in_order()."""
    block = lines[part.first : part.end]
    if part.kind == "table":
        items = _items(block, part.first, table=True)
        output = check.output if part.command is None else _output_of(check, part.command)
        tables = _tables(output or [])
        if any(_rows_in_order(items, t) for t in tables):
            return []
        same = [t for t in tables if shape(t[0]) == shape(block[0])]
        if not same:
            return [f"no table with the header {block[0].strip()!r} in the output"]
        diff = difflib.unified_diff(
            [smoke_shape(b) for b in block], [smoke_shape(r) for r in same[0]], "q", "smoke", n=0
        )
        return ["the table's rows do not pair with the quoted rows:\n  " + "\n  ".join(diff)]
    problems = []
    for items, output in _segments(check, block, part.first, part.command):
        if align(items, output, smoke_shape) is None:
            quoted = [smoke_shape(it.text) for it in items]
            diff = difflib.unified_diff(quoted, [smoke_shape(o) for o in output], "q", "smoke", n=0)
            problems.append(
                "the output does not pair with the quoted lines by shape:\n  "
                + "\n  ".join(d.rstrip("\n") for d in list(diff)[:30])
            )
    return problems


def runs(check: Check, only: str | None, run_all: bool) -> bool:
    """Whether this invocation runs the check (slow ones only with --all or --only)."""
    if only is not None:
        return check.name == only
    return run_all or not check.slow or check.smoked


# ---------------------------------------------------------------------------------------------
# the parts of a document


@dataclass
class Part:
    """A fenced block or a table: its lines [first, end) and the marker above it."""

    kind: str  # "block", "table" or "paragraph" (under a not-output marker)
    first: int  # first quoted line (after the fence)
    end: int
    after: int  # the line after the part
    lang: str = ""
    check: str | None = None
    command: str | None = None  # the block is this command's output (<!-- check: NAME: CMD -->)
    not_output: str | None = None


def _paragraph(lines: list[str], i: int, reason: str | None, rel: str) -> Part:
    """The paragraph or list item below a not-output marker on line i: up to a blank line, the
    next list item, marker, code block or table."""
    if not reason:
        raise CheckError(f"{rel}:{i + 1}: <!-- not-output: ... --> must say what it marks")
    end = i + 2
    stop = (LIST_ITEM, NOT_OUTPUT_MARK, CHECK_MARK, FENCE, TABLE_ROW)
    while end < len(lines) and lines[end].strip() and not any(p.match(lines[end]) for p in stop):
        end += 1
    return Part("paragraph", i + 1, end, end, not_output=reason)


def parts(lines: list[str], rel: str) -> list[Part]:
    """The fenced blocks and tables of a document, with the marker on the line above each."""
    found = []
    i = 0
    while i < len(lines):
        above = lines[i - 1] if i else ""
        m = FENCE.match(lines[i])
        if m:
            indent, fence = m.group(1), m.group(2)
            close = re.compile(rf"^{re.escape(indent)}\s{{0,3}}{fence}\s*$")
            end = next((k for k in range(i + 1, len(lines)) if close.match(lines[k])), None)
            if end is None:
                raise CheckError(f"{rel}:{i + 1}: the code block is not closed")
            part = Part("block", i + 1, end, end + 1, lang=m.group(3).lower())
        elif TABLE_ROW.match(lines[i]):
            end = i
            while end < len(lines) and TABLE_ROW.match(lines[end]):
                end += 1
            part = Part("table", i, end, end)
        else:
            nxt = lines[i + 1] if i + 1 < len(lines) else ""
            below = bool(FENCE.match(nxt) or TABLE_ROW.match(nxt))
            marker = NOT_OUTPUT_MARK.match(lines[i])
            if marker and nxt.strip() and not below:
                found.append(_paragraph(lines, i, marker.group(1), rel))
                i = found[-1].after
                continue
            if (CHECK_MARK.match(lines[i]) or marker) and not below:
                raise CheckError(
                    f"{rel}:{i + 1}: a check marker must be on the line directly above a "
                    "``` block or a table (a not-output marker: also above a paragraph)"
                )
            i += 1
            continue
        if m := CHECK_MARK.match(above):
            part.check, part.command = m.group(1), m.group(2)
        elif m := NOT_OUTPUT_MARK.match(above):
            if not m.group(1):
                raise CheckError(f"{rel}:{i}: <!-- not-output: ... --> must say what it marks")
            part.not_output = m.group(1)
        found.append(part)
        i = part.after
    return found


def prose(text: str) -> str:
    """A line of text without what is covered or not a figure: values, not-output spans,
    inline code, link targets, comments, images, dates, years and version numbers."""
    text = VALUE_MARK.sub(" ", text)
    text = NOT_OUTPUT_SPAN.sub(" ", text)
    text = re.sub(r"`[^`]*`", " ", text)
    text = re.sub(r"!\[[^\]]*\]", " ", text)  # an image's alt text
    text = re.sub(r"\]\([^)]*\)|<https?://[^>]*>|https?://\S+", " ", text)
    text = re.sub(r"<!--.*?-->", " ", text)
    text = re.sub(r"\b\d{4}-\d\d-\d\d\b", " ", text)
    return re.sub(r"\b\d+\.\d+\.\d+\b", " ", text)


def outside_code(line: str, fn) -> str:
    """Apply ``fn`` to the parts of a line outside inline code (``...``): a marker written in
    backticks is an example, not a marker."""
    parts = re.split(r"(`[^`]*`)", line)
    return "".join(p if k % 2 else fn(p) for k, p in enumerate(parts))


def _significant(number: str) -> int:
    number = number.replace(",", "")
    if "." in number:
        return len(number.replace(".", "").lstrip("0"))
    return len(number.strip("0"))


def figures(text: str) -> list[str]:
    """The figures in a line of text that a check must cover (see FIGURE)."""
    found = []
    for m in FIGURE.finditer(prose(text)):
        number = m.group(0)
        if re.fullmatch(r"\d[\d.]*", number) and _significant(number) < 4:
            continue
        if re.fullmatch(r"(?:19|20)\d\d", number):  # a year
            continue
        found.append(number.strip())
    return found


def coverage(path: Path, lines: list[str] | None = None) -> list[str]:
    """Where the document holds a transcript or figure that no check covers."""
    rel = _rel(path)
    lines = path.read_text().splitlines() if lines is None else lines
    problems = []
    covered: set[int] = set()
    for part in parts(lines, rel):
        covered.update(range(part.first - (part.kind == "block"), part.after))
        if part.kind == "paragraph":
            continue
        if part.check or part.not_output:
            continue
        body = lines[part.first : part.end]
        where = f"{rel}:{part.first if part.kind == 'block' else part.first + 1}"
        if part.kind == "block":
            if part.lang not in INPUT_LANGUAGES:
                kind = f"```{part.lang}" if part.lang else "```"
                problems.append(
                    f"{where}: a {kind} block with no check: mark it "
                    "<!-- check: NAME --> (program output) or <!-- not-output: what it is -->, "
                    "or give it its input language"
                )
            elif any(line.strip().startswith("$ ") for line in body):
                problems.append(
                    f"{where}: a ```{part.lang} block with $ lines is a transcript: "
                    "put <!-- check: NAME --> above it"
                )
        else:
            rows = [r for r in body if not TABLE_RULE.match(r)]
            found = [f for row in rows for f in figures(row)]
            if found:
                problems.append(
                    f"{where}: a table with figures ({', '.join(found[:3])}"
                    f"{', ...' if len(found) > 3 else ''}) and no check: put <!-- check: NAME --> "
                    "or <!-- not-output: what it is --> on the line above it"
                )
    for n, line in enumerate(lines):
        if n in covered or CHECK_MARK.match(line) or NOT_OUTPUT_MARK.match(line):
            continue
        rest = NOT_OUTPUT_SPAN.sub(" ", VALUE_MARK.sub(" ", re.sub(r"`[^`]*`", " ", line)))
        if re.search(r"<!-- (value:|/value|not-output|/not-output)", rest):
            problems.append(f"{rel}:{n + 1}: a value or not-output marker must close on its line")
        uncovered = figures(line)
        problems.extend(f"{rel}:{n + 1}: figure '{f}' is not covered by a check" for f in uncovered)
    return problems


def _rel(path: Path) -> str:
    try:
        return str(path.relative_to(ROOT))
    except ValueError:
        return str(path)


# ---------------------------------------------------------------------------------------------
# checking a document


def check_document(
    path: Path,
    checks: dict[str, Check],
    only: str | None,
    update: bool,
    run_all: bool = False,
) -> int:
    """Check (or update) one document; return the number of differences."""
    lines = path.read_text().splitlines()
    rel = _rel(path)
    differences = 0
    edits: list[tuple[int, int, list[str]]] = []  # replace lines [a, b) by these
    for part in parts(lines, rel):
        if part.check is None:
            continue
        if part.check not in checks:
            raise CheckError(f"{rel}:{part.first}: unknown check {part.check!r}")
        check = checks[part.check]
        if not runs(check, only, run_all):
            continue
        block = lines[part.first : part.end]
        if check.smoked:
            run_check(check)
            for problem in shape_problems(check, part, lines):
                differences += 1
                print(f"{rel}:{part.first + 1}: [{check.name}, smoke run] {problem}")
            continue
        try:
            results = compare_block(check, block, part.first, part.kind == "table", part.command)
        except CheckError as err:
            raise CheckError(f"{rel}:{err}") from None
        for found, items, unpaired in results:
            for d in found:
                differences += 1
                print(f"{rel}:{d.line + 1}: [{check.name}]")
                print(f"  quoted: {d.quoted}\n  actual: {d.actual}")
                edits.append((d.line, d.line + 1, [d.actual]))
            if unpaired is None:
                continue
            differences += 1
            start = items[0].index if items else part.first
            end = items[-1].index + 1 if items else start
            quoted = lines[start:end]
            diff = list(difflib.unified_diff(quoted, unpaired, "quoted", "actual", "", "", n=1))
            if len(diff) > 40:
                diff = [*diff[:40], f"[{len(diff) - 40} more lines of the diff]"]
            can = not any(it.omit for it in items) and unpaired
            print(
                f"{rel}:{start + 1}: [{check.name}] the quoted lines do not pair with the "
                f"output line for line{'' if can else ' (edit them: --update cannot)'}; "
                "mark omitted lines with ... or [N lines omitted]:\n  "
                + "\n  ".join(d.rstrip("\n") for d in diff)
            )
            if can:
                edits.append((start, end, list(unpaired)))

    def replace(match: re.Match, line: int) -> str:
        nonlocal differences
        name, key, quoted = match.groups()
        if name not in checks:
            raise CheckError(f"{rel}:{line}: unknown check {name!r}")
        if not runs(checks[name], only, run_all):
            return match.group(0)
        if checks[name].smoked:
            pattern = checks[name].values.get(key)
            out = run_check(checks[name])
            if pattern is None or not any(_general(pattern).search(o) for o in out):
                differences += 1
                print(
                    f"{rel}:{line}: [{name}.{key}, smoke run] the value's pattern matches no line"
                )
            return match.group(0)
        actual, by_shape = value_of(checks[name], key)
        if actual == quoted or (by_shape and not REMEASURE and shape(actual) == shape(quoted)):
            return match.group(0)
        differences += 1
        print(f"{rel}:{line}: [{name}.{key}] quoted {quoted!r}, actual {actual!r}")
        return f"<!-- value: {name}.{key} -->{actual}<!-- /value -->"

    for n, line in enumerate(lines):
        new = outside_code(line, lambda t, n=n: VALUE_MARK.sub(lambda m: replace(m, n + 1), t))
        if new != line:
            edits.append((n, n + 1, [new]))
    if update and edits:
        for start, end, new_lines in sorted(edits, reverse=True):
            lines[start:end] = new_lines
        path.write_text("\n".join(lines) + "\n")
    return differences


def quoted_names() -> list[str]:
    """The names of the checks that the documents quote, in order of first mention."""
    names: dict[str, None] = {}
    for path in DOCS:
        for line in path.read_text().splitlines():
            if m := CHECK_MARK.match(line):
                names[m.group(1)] = None
            text = re.sub(r"`[^`]*`", " ", line)  # a marker in inline code is an example
            names.update((m.group(1), None) for m in VALUE_MARK.finditer(text))
    return list(names)


def run_ahead(checks: list[Check], only: str | None, run_all: bool) -> None:
    """Run the checks side by side, one per core (each check's commands are processes)."""
    todo = [c for c in checks if runs(c, only, run_all)]
    # the longest first, so that the last one to finish is a short one
    order: tuple[str, ...] = ("ion-setups", "heavy-ions", "alpha-ranges", "demo", "vertices-replay")
    order += ("solid-speed", "bege-whole-speed", "face-size-speed")  # the longest smoke runs
    todo.sort(key=lambda c: order.index(c.name) if c.name in order else len(order))
    with ThreadPoolExecutor(max_workers=os.cpu_count() or 1) as pool:
        for future in [pool.submit(run_check, c) for c in todo]:
            future.result()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--update", action="store_true", help="rewrite the quoted numbers")
    parser.add_argument("--only", metavar="NAME", help="run one check (also a slow one)")
    parser.add_argument("--all", action="store_true", help="also run the slow checks")
    parser.add_argument("--coverage", action="store_true", help="check coverage only, run nothing")
    parser.add_argument(
        "--remeasure",
        action="store_true",
        help="with --update: also take the masked figures (timings, dates, loads) from the run",
    )
    parser.add_argument(
        "--smoke",
        action="store_true",
        help="also run the slow checks, with the small arguments of their `smoke:` entry, and "
        "check only their output's shape (exit status, tables, lines, values); not with --update",
    )
    args = parser.parse_args(argv)
    if args.smoke and (args.update or args.all):
        parser.error(
            "--smoke runs the slow checks small and compares shapes only: no --update/--all"
        )
    global REMEASURE
    REMEASURE = args.remeasure
    try:
        uncovered = [p for path in DOCS for p in coverage(path)]
    except CheckError as err:
        print(f"docs-check: {err}")
        return 2
    for problem in uncovered:
        print(problem)
    if uncovered:
        print(f"docs-check: {len(uncovered)} transcripts or figures not covered by a check")
        print(HOW_TO_COVER)
    if args.coverage:
        if not uncovered:
            print(f"docs-check: every transcript and figure of {len(DOCS)} pages has a check")
        return 1 if uncovered else 0
    if shutil.which("score4", path=str(Path(sys.executable).parent)) is None:
        print(f"docs-check: no score4 next to {sys.executable} (pip install -e .)")
        return 2
    try:
        checks = load_checks()
        if args.only and args.only not in checks:
            raise CheckError(f"--only: unknown check {args.only!r}")
        if args.smoke:
            for name, check in checks.items():
                if check.slow and args.only in (None, name):
                    checks[name] = smoked(check)
        run_ahead([checks[n] for n in quoted_names() if n in checks], args.only, args.all)
        differences = sum(check_document(p, checks, args.only, args.update, args.all) for p in DOCS)
        unused = [
            c.name
            for c in checks.values()
            if c.outputs is None and args.only is None and (args.all or not c.slow)
        ]
        if unused:
            raise CheckError(f"checks not quoted by any document: {', '.join(unused)}")
    except CheckError as err:
        print(f"docs-check: {err}")
        return 2
    ran = [c for c in checks.values() if c.outputs is not None]
    timing = ", ".join(f"{c.name} {c.seconds:.1f} s" for c in ran)
    verb = "updated" if args.update else "differ"
    if differences:
        print(f"docs-check: {differences} quoted lines/values {verb} ({timing})")
        return 0 if args.update and not uncovered else 1
    if uncovered:
        return 1
    skipped = [c.name for c in checks.values() if c.slow and c.outputs is None and not args.only]
    note = f"; skipped (slow, run with --all): {', '.join(skipped)}" if skipped else ""
    smoke = [c.name for c in ran if c.smoked]
    if smoke:
        note += f"; {len(smoke)} slow checks run small (--smoke), their output's shape matches"
    print(f"docs-check: {len(ran)} checks, every quoted line and value matches ({timing}){note}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
