"""Writing the configuration: YAML under a comment header that holds the import report, and the
files (merged depth tables) beside it.
"""

from __future__ import annotations

import datetime as dt
import os
from pathlib import Path

import yaml

from .report import ImportReport


class _Dumper(yaml.SafeDumper):
    """Block-style mappings; lists of plain values (sizes, positions) on one line."""


_Dumper.add_representer(
    list,
    lambda d, v: d.represent_sequence(
        "tag:yaml.org,2002:seq", v, flow_style=not any(isinstance(x, (dict, list)) for x in v)
    ),
)


def render_yaml(config: dict, report: ImportReport) -> str:
    """The configuration as YAML under a comment header: source macro, date, the report."""
    from ..version import package_version

    now = dt.datetime.now().astimezone().isoformat(timespec="seconds")
    header = [
        "score4 run configuration converted from an original SCoRe4 macro by 'score4 import-macro'",
        f"source macro: {report.macro.resolve()}",
        f"date:         {now} (score4 {package_version()})",
        "",
        "Lengths: the original's setters take HALF-lengths; score4 uses FULL lengths everywhere,",
        "so every length below is twice the macro's, and a pyramid is 2 x setSpikeMeanHeight high",
        "(a G4Trd of that half-height); Bump/Peak heights are 1 x setSpikeMeanHeight.",
        "See docs/import-macro.md.",
        "",
        *report.lines(),
    ]
    body = yaml.dump(
        config,
        Dumper=_Dumper,
        sort_keys=False,
        default_flow_style=False,
        width=110,
        allow_unicode=True,
    )
    return "".join(f"# {line}".rstrip() + "\n" for line in header) + "\n" + body


def write_config(
    config: dict, report: ImportReport, out: str | os.PathLike, overwrite: bool = False
) -> list[Path]:
    """Write the configuration (and any table in ``report.files``) beside each other; return the
    paths.

    Raises
    ------
    ConfigError
        An output file exists and ``overwrite`` is false, or its folder does not exist.
    """
    from ..files import atomic_output, check_output_file

    out = Path(out)
    targets = [out] + [out.parent / name for name in report.files]
    for t in targets:
        check_output_file(t, overwrite, "--out")
    texts = [render_yaml(config, report), *report.files.values()]
    for target, text in zip(
        targets[1:], texts[1:], strict=True
    ):  # tables first: the config refers to them
        with atomic_output(target) as tmp:
            tmp.write_text(text)
    with atomic_output(out) as tmp:
        tmp.write_text(texts[0])
    return targets
