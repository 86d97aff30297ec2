"""Click's usage errors (unknown option, missing argument, bad value) as one line.

Click prints three lines (Usage, Try, Error). score4 prints every input error as one line
``score4: error: <message>`` (see :mod:`score4.cli.main`); usage errors get the same form,
with the subcommand first and the help to read last, e.g.
``score4: error: run: no such option --evnts (did you mean --events?); try 'score4 run --help'``.
"""

from __future__ import annotations

import re

import click

PROG = "score4"


def _sentence(text: str) -> str:
    """Click's message as a clause: no final full stop, lower-case first letter."""
    text = text.strip().rstrip(".")
    return text[:1].lower() + text[1:] if text[:2] != text[:2].upper() else text


def _alternatives(possibilities) -> str:
    return f" (did you mean {' or '.join(possibilities)}?)" if possibilities else ""


def _bounds(text: str) -> str:
    """click's range notation in words: 'x>=1' -> '>= 1', '0<=x<=9' -> 'in [0, 9]'."""
    one = re.fullmatch(r"x([<>]=?)(.+)", text)
    if one:
        return f"{one[1]} {one[2]}"
    two = re.fullmatch(r"(.+?)(<=?)x(<=?)(.+)", text)
    if two:
        return (
            f"in {'[' if two[2] == '<=' else '('}{two[1]}, {two[4]}{']' if two[3] == '<=' else ')'}"
        )
    return f"in the range {text}"


def _rule(message: str) -> str:
    """A bad value's message as score4 says it: 'must be <rule>, got <value>'."""
    text = message.strip().rstrip(".")
    said = re.fullmatch(r"(.+) is not in the range (.+)", text)
    if said:
        return f"must be {_bounds(said[2])}, got {said[1]}"
    said = re.fullmatch(r"(.+) is not one of (.+)", text)
    if said:
        return f"must be one of {said[2]}, got {said[1]}"
    return _sentence(text)


def _param_name(param: click.Parameter | None) -> str:
    """How the user writes ``param``: its long option (--events) or its metavar (CONFIG.yaml)."""
    if param is None:
        return "value"
    if isinstance(param, click.Option):
        longs = [o for o in param.opts if o.startswith("--")]
        return (longs or param.opts)[0]
    return param.human_readable_name


def _hint(err: click.BadParameter) -> str:
    if isinstance(err.param_hint, str):
        return err.param_hint
    if err.param_hint is not None:
        return " / ".join(err.param_hint)
    return _param_name(err.param)


def _what(err: click.UsageError) -> str:
    """The error itself, in the user's terms."""
    if isinstance(err, click.NoSuchOption):
        return f"no such option {err.option_name}{_alternatives(err.possibilities)}"
    command_name = getattr(err, "command_name", None)  # click >= 8.4: NoSuchCommand
    if command_name is not None:
        found = getattr(err, "possibilities", None)
        return f"no such command {command_name!r}{_alternatives(found)}"
    if isinstance(err, click.MissingParameter):
        kind = err.param_type or (err.param.param_type_name if err.param else "parameter")
        return f"missing {kind} {_hint(err)}"
    if isinstance(err, click.BadParameter):
        return f"{_hint(err)}: {_rule(err.message)}"
    if isinstance(err, click.BadOptionUsage):
        said = re.fullmatch(r"Option '(.+)' requires (an argument|\d+ arguments)\.?", err.message)
        if said:
            count = (
                "a value" if said[2] == "an argument" else said[2].replace("arguments", "values")
            )
            return f"{said[1]}: needs {count}"
        said = re.fullmatch(r"Option '(.+)' does not take a value\.?", err.message)
        if said:
            return f"{said[1]}: takes no value"
    extra = re.fullmatch(r"Got unexpected extra arguments? \((.*)\)\.?", err.message)
    if extra:
        return f"unexpected extra argument(s): {extra[1]}"
    return _sentence(err.message)


def command_path(root: click.Command, args: list[str]) -> str:
    """The command that ``args`` call ("score4 surface show"), for errors raised without context."""
    words, command = [PROG], root
    for arg in args:
        if not isinstance(command, click.Group):
            break
        if arg.startswith("-"):
            continue
        sub = command.commands.get(arg)
        if sub is None:
            break
        words.append(arg)
        command = sub
    return " ".join(words)


def usage_error_line(err: click.UsageError, path: str = PROG) -> str:
    """``err`` as the one line printed after ``score4: error: ``.

    ``path`` names the command when click raised the error without a context (its option
    parser does, e.g. for an option given without its value).
    """
    path = err.ctx.command_path if err.ctx is not None else path
    command = path.removeprefix(PROG).strip()
    line = _what(err)
    if command:
        line = f"{command}: {line}"
    return f"{line}; try '{path} --help'"
