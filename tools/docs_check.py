#!/usr/bin/env python3
"""Re-run the commands behind the numbers quoted in README.md and docs/*.md; fail on any difference.

What is checked is declared in ``docs/checks.yaml``: each check is a list of shell commands
(run in a scratch folder that links the repository's ``examples``, ``docs``, ``tests`` and
``benchmarks`` folders, with the ``score4`` of the running Python first on PATH) whose combined
output (stdout and stderr) the documents quote. A document refers to a check in these ways:

* a transcript: the line ``<!-- check: NAME -->`` directly above a fenced code block. Each
  line of the block that is not a command (``$ ...``), an elision (``...``) or empty must be
  an output line of the check: lines are paired in order (after a ``$ COMMAND`` line that is one
of the check's commands, from that command's output on) by their *shape* (the line with every
  number replaced by ``#``), then compared exactly. A block line holding ``...`` is compared
  around the elision. Lines matching one of the check's ``ignore`` patterns (wall times) are
  paired but not compared.
* Commands may use two helpers that take code from the documents themselves, so a quoted
  configuration or script cannot drift from what runs: ``write-block DOC LANG N FILE`` writes
  the N-th (from 1) fenced block of language LANG (``-``: no language) in DOC to FILE;
  ``python-block DOC N [ARGS]`` runs the N-th ``python`` block of DOC.
* a table: the same marker directly above a Markdown table. Its rows that hold a number are
  paired and compared like the lines of a transcript (not the header, not the ``| --- |`` line),
  so the check prints the rows exactly as the page shows them.
* a value in the text: ``<!-- value: NAME.KEY -->4248<!-- /value -->``, where ``KEY`` is a
  value of the check: ``values: {KEY: REGEX}`` in checks.yaml, the first group of the first
  output line the regex matches. A value inside a part of that line that a ``mask`` pattern
  matches (a timing) is compared by shape only.

Machine-dependent figures are never compared digit for digit. A check's ``mask`` patterns
(timings, memory) mark the parts of a line compared by shape only: the rest of the line is
compared exactly. A check marked ``slow: true`` (a benchmark of minutes, timing figures) is
skipped unless ``--all`` is given; the documents label its figures as measurements with their
command and date.

``--update`` rewrites the quoted lines and values from the new output instead of failing
(run it after a change that moves the numbers, then read the diff). ``--only NAME`` runs one
check; ``--all`` adds the slow checks. Exit status 0: every quoted line and value is what the
program prints today; 1: some differ (each printed as file:line, quoted and actual); 2: a check
or marker is broken.

Usage: python tools/docs_check.py [--update] [--all] [--only NAME]
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parent.parent
CHECKS = ROOT / "docs" / "checks.yaml"
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
LINKED = ("examples", "docs", "tests", "benchmarks")

NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")
BLOCK_MARK = re.compile(r"^<!-- check: ([\w.-]+) -->\s*$")
TABLE_ROW = re.compile(r"^\s*\|")
TABLE_RULE = re.compile(r"^\s*\|[\s:|-]+\|\s*$")
VALUE_MARK = re.compile(r"<!-- value: ([\w.-]+)\.(\w+) -->(.*?)<!-- /value -->")


class CheckError(Exception):
    """A broken check or marker (exit status 2)."""


@dataclass
class Check:
    name: str
    commands: list[str]
    ignore: list[re.Pattern] = field(default_factory=list)
    mask: list[re.Pattern] = field(default_factory=list)
    slow: bool = False
    values: dict[str, re.Pattern] = field(default_factory=dict)
    output: list[str] | None = None
    starts: dict[str, int] = field(default_factory=dict)  # command -> first line of its output
    seconds: float = 0.0


def load_checks() -> dict[str, Check]:
    raw = yaml.safe_load(CHECKS.read_text())
    checks = {}
    for name, spec in raw["checks"].items():
        checks[name] = Check(
            name=name,
            commands=list(spec["commands"]),
            ignore=[re.compile(p) for p in spec.get("ignore", [])],
            mask=[re.compile(p) for p in spec.get("mask", [])],
            slow=bool(spec.get("slow", False)),
            values={k: re.compile(v) for k, v in spec.get("values", {}).items()},
        )
    return checks


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
    if check.output is not None:
        return check.output
    env = dict(os.environ)
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}"
    env["PYTHONPATH"] = f"{ROOT / 'src'}{os.pathsep}{env.get('PYTHONPATH', '')}"
    env["COLUMNS"] = "80"  # click wraps --help to the terminal width
    start = time.perf_counter()
    lines: list[str] = []
    with tempfile.TemporaryDirectory(prefix=f"docs-check-{check.name}-") as tmp:
        for name in LINKED:
            os.symlink(ROOT / name, Path(tmp) / name)
        for command in check.commands:
            check.starts.setdefault(command, len(lines))
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
            lines += proc.stdout.splitlines()
    check.seconds = time.perf_counter() - start
    check.output = lines
    return lines


def shape(line: str) -> str:
    """The line with every number replaced by ``#`` and runs of blanks by one blank."""
    return re.sub(r"\s+", " ", NUMBER.sub("#", line.strip()))


def _quoted(block: list[str], i: int) -> bool:
    text = block[i].strip()
    if text.startswith("|"):  # a table row with a number; not the header above the | --- | line
        header = i + 1 < len(block) and TABLE_RULE.match(block[i + 1])
        return bool(re.search(r"\d", text)) and not header
    return bool(text) and not text.startswith("$ ") and text != "..."


def masked(check: Check, line: str) -> str:
    """The line with every part a ``mask`` pattern matches reduced to its shape."""
    for pattern in check.mask:
        line = pattern.sub(lambda m: NUMBER.sub("#", m.group(0)), line)
    return line


def compare_block(check: Check, block: list[str]) -> list[tuple[int, str, str]]:
    """Pair the block's output lines with the check's output; return (index, quoted, actual)."""
    output = run_check(check)
    found: list[tuple[int, str, str]] = []
    pos = 0
    for i, line in enumerate(block):
        text = line.strip()
        if text.startswith("$ "):  # pair what follows with that command's output
            command = text[2:].removeprefix(".venv/bin/")
            if command in check.starts:
                pos = check.starts[command]
        if not _quoted(block, i):
            continue
        parts = line.rstrip().split("...")  # an elision "..." stands for any text
        pattern = re.compile(".*".join(re.escape(shape(p)) for p in parts))
        for j in range(pos, len(output)):
            if pattern.fullmatch(shape(output[j])):
                break
        else:
            raise CheckError(
                f"check {check.name}: no output line has the shape of {line.strip()!r}; "
                f"output was:\n" + "\n".join(output)
            )
        pos = j + 1
        actual = output[j].rstrip()
        if any(p.search(actual) for p in check.ignore):
            continue
        if len(parts) > 1:  # keep the elision, take the text around it from the output
            tail = actual[len(actual) - len(parts[-1]) :] if parts[-1] else ""
            new = actual[: len(parts[0])] + "..." + tail
        else:
            new = actual
        if masked(check, new) != masked(check, line.rstrip()):
            found.append((i, line.rstrip(), new))
    return found


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


def runs(check: Check, only: str | None, run_all: bool) -> bool:
    """Whether this invocation runs the check (slow ones only with --all or --only)."""
    if only is not None:
        return check.name == only
    return run_all or not check.slow


def _block_after(lines: list[str], i: int, rel: Path) -> tuple[int, int, int]:
    """The quoted lines [first, end) after the marker on line i, and the line after them."""
    if i + 1 < len(lines) and lines[i + 1].startswith("```"):
        end = next((k for k in range(i + 2, len(lines)) if lines[k].startswith("```")), None)
        if end is None:
            raise CheckError(f"{rel}:{i + 2}: the code block is not closed")
        return i + 2, end, end + 1
    if i + 1 < len(lines) and TABLE_ROW.match(lines[i + 1]):
        end = i + 1
        while end < len(lines) and TABLE_ROW.match(lines[end]):
            end += 1
        return i + 1, end, end
    raise CheckError(f"{rel}:{i + 1}: a check marker must precede a ``` block or a table")


def check_document(
    path: Path,
    checks: dict[str, Check],
    only: str | None,
    update: bool,
    run_all: bool = False,
) -> int:
    """Check (or update) one document; return the number of differences."""
    lines = path.read_text().splitlines(keepends=True)
    rel = path.relative_to(ROOT)
    differences = 0
    i = 0
    while i < len(lines):
        m = BLOCK_MARK.match(lines[i])
        if m:
            name = m.group(1)
            if name not in checks:
                raise CheckError(f"{rel}:{i + 1}: unknown check {name!r}")
            first, end, after = _block_after(lines, i, rel)
            if runs(checks[name], only, run_all):
                block = [ln.rstrip("\n") for ln in lines[first:end]]
                for k, quoted, actual in compare_block(checks[name], block):
                    differences += 1
                    where = f"{rel}:{first + 1 + k}: [{name}]"
                    print(f"{where}\n  quoted: {quoted}\n  actual: {actual}")
                    if update:
                        lines[first + k] = actual + "\n"
            i = after
            continue

        def replace(match: re.Match, line: int = i + 1) -> str:
            nonlocal differences
            name, key, quoted = match.groups()
            if name not in checks:
                raise CheckError(f"{rel}:{line}: unknown check {name!r}")
            if not runs(checks[name], only, run_all):
                return match.group(0)
            actual, by_shape = value_of(checks[name], key)
            if actual == quoted or (by_shape and shape(actual) == shape(quoted)):
                return match.group(0)
            differences += 1
            print(f"{rel}:{line}: [{name}.{key}] quoted {quoted!r}, actual {actual!r}")
            return f"<!-- value: {name}.{key} -->{actual}<!-- /value -->"

        lines[i] = VALUE_MARK.sub(replace, lines[i])
        i += 1
    if update and differences:
        path.write_text("".join(lines))
    return differences


def quoted_names() -> list[str]:
    """The names of the checks that the documents quote, in order of first mention."""
    names: dict[str, None] = {}
    for path in DOCS:
        for line in path.read_text().splitlines():
            if m := BLOCK_MARK.match(line):
                names[m.group(1)] = None
            names.update((m.group(1), None) for m in VALUE_MARK.finditer(line))
    return list(names)


def run_ahead(checks: list[Check], only: str | None, run_all: bool) -> None:
    """Run the checks side by side, one per core (each check's commands are processes)."""
    todo = [c for c in checks if runs(c, only, run_all)]
    with ThreadPoolExecutor(max_workers=os.cpu_count() or 1) as pool:
        for future in [pool.submit(run_check, c) for c in todo]:
            future.result()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--update", action="store_true", help="rewrite the quoted numbers")
    parser.add_argument("--only", metavar="NAME", help="run one check (also a slow one)")
    parser.add_argument("--all", action="store_true", help="also run the slow checks")
    args = parser.parse_args(argv)
    if shutil.which("score4", path=str(Path(sys.executable).parent)) is None:
        print(f"docs-check: no score4 next to {sys.executable} (pip install -e .)")
        return 2
    try:
        checks = load_checks()
        if args.only and args.only not in checks:
            raise CheckError(f"--only: unknown check {args.only!r}")
        run_ahead([checks[n] for n in quoted_names() if n in checks], args.only, args.all)
        differences = sum(check_document(p, checks, args.only, args.update, args.all) for p in DOCS)
        unused = [
            c.name
            for c in checks.values()
            if c.output is None and args.only is None and (args.all or not c.slow)
        ]
        if unused:
            raise CheckError(f"checks not quoted by any document: {', '.join(unused)}")
    except CheckError as err:
        print(f"docs-check: {err}")
        return 2
    ran = [c for c in checks.values() if c.output is not None]
    timing = ", ".join(f"{c.name} {c.seconds:.1f} s" for c in ran)
    verb = "updated" if args.update else "differ"
    if differences:
        print(f"docs-check: {differences} quoted lines/values {verb} ({timing})")
        return 0 if args.update else 1
    skipped = [c.name for c in checks.values() if c.slow and c.output is None and not args.only]
    note = f"; skipped (slow, run with --all): {', '.join(skipped)}" if skipped else ""
    print(f"docs-check: {len(ran)} checks, every quoted line and value matches ({timing}){note}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
