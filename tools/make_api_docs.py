#!/usr/bin/env python3
"""Write the reference part of docs/api.md from the docstrings of :mod:`score4.api`.

The page's reference lies between the lines ``<!-- api: begin -->`` and ``<!-- api: end -->``;
the rest of the page (introduction, example, transcript) is written by hand and kept. The
reference lists, in the order of the module's ``__all__`` grouped as in :data:`SECTIONS`, every
function with its signature and docstring, and every class with its constructor, docstring and
public methods and properties (for classes defined elsewhere and re-exported, the members named
in :data:`MEMBERS`). numpy-style sections (Parameters, Returns, Attributes) become lists; Sphinx
roles (:func:`x`) and double backquotes become Markdown code.

    python tools/make_api_docs.py          # rewrite docs/api.md
    python tools/make_api_docs.py --check  # exit 1 if docs/api.md is not what it would write

``tests/test_api_docs.py`` runs the check, so the page cannot drift from the code.
"""

from __future__ import annotations

import argparse
import inspect
import re
import sys
import textwrap
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "api.md"
BEGIN, END = "<!-- api: begin -->", "<!-- api: end -->"

#: Sections of the reference and the names of score4.api in them, in order.
SECTIONS = {
    "Geant4 set-up": ["import_geant4", "physics_list", "after_initialize"],
    "Surfaces": ["build_surface", "load_surface", "save_surface", "Surface"],
    "Your world: rough faces and sources": ["World", "RoughenedVolume"],
    "A run configuration": ["plan_run", "RunPlan"],
    "Events": ["PrimaryGenerator", "HeavyIonReplay", "ReplayedIon"],
    "What sources give": ["SampledSource", "BulkSource", "Primaries"],
}

#: Members shown for classes re-exported from other modules (their other members are internal).
MEMBERS = {
    "Surface": ["size_x", "size_y", "max_height", "top_mesh", "height_at"],
    "SampledSource": ["events", "primaries"],
    "BulkSource": ["events", "primaries"],
    "Primaries": ["n_events", "event_offsets", "select_events"],
    "RunPlan": ["output", "model", "per_atom"],
}

_ROLE = re.compile(r":(?:func|class|meth|attr|mod|data|exc):`~?([^`]+)`")
_SECTION = re.compile(
    r"^(Parameters|Returns|Attributes|Raises|Notes|Examples)\n-{3,}\n", re.MULTILINE
)


def _inline(text: str) -> str:
    """Sphinx roles and ``literals`` as Markdown code."""
    text = _ROLE.sub(lambda m: f"`{m.group(1)}`", text)
    return text.replace("``", "`")


def _entries(body: str) -> list[str]:
    """numpy-style entries (``name : type`` line, indented description) as list items."""
    items: list[str] = []
    lines = body.splitlines()
    i = 0
    while i < len(lines):
        head = lines[i].strip()
        i += 1
        if not head:
            continue
        desc = []
        while i < len(lines) and (not lines[i].strip() or lines[i].startswith(" ")):
            desc.append(lines[i].strip())
            i += 1
        name, _, kind = head.partition(" : ")
        label = f"`{name}`" + (f" ({_inline(kind)})" if kind else "")
        if " " in name and not kind:  # a Returns entry: a type, not a name
            label = _inline(name)
        text = " ".join(d for d in desc if d)
        items.append(f"- {label}: {_inline(text)}" if text else f"- {label}")
    return items


def docstring_markdown(doc: str | None) -> str:
    """A numpy-style docstring as Markdown."""
    if not doc:
        return ""
    doc = inspect.cleandoc(doc)
    parts = _SECTION.split(doc)
    out = [_paragraphs(parts[0])]
    for title, body in zip(parts[1::2], parts[2::2], strict=True):
        body = textwrap.dedent(body)
        if title in ("Parameters", "Returns", "Attributes", "Raises"):
            out.append(f"**{title}**\n\n" + "\n".join(_entries(body)))
        else:
            out.append(f"**{title}**\n\n" + _paragraphs(body))
    return "\n\n".join(p for p in out if p.strip())


def _paragraphs(text: str) -> str:
    """Paragraphs joined into single lines; bullet items (``* ``) kept as a list; a line
    ending in ``::`` or an indented block kept as it is."""
    blocks = re.split(r"\n\s*\n", text.strip())
    out = []
    for block in blocks:
        lines = block.splitlines()
        if lines and lines[0].lstrip().startswith(("* ", "- ")):
            items: list[str] = []
            for line in lines:
                stripped = line.strip()
                if stripped.startswith(("* ", "- ")):
                    items.append("- " + stripped[2:])
                else:
                    items[-1] += " " + stripped
            out.append("\n".join(_inline(item) for item in items))
        elif lines and all(line.startswith("    ") for line in lines):
            out.append("```bash\n" + textwrap.dedent(block) + "\n```")
        else:
            out.append(_inline(" ".join(line.strip() for line in lines)))
    return "\n\n".join(out)


def _signature(obj, name: str) -> str:
    try:
        sig = inspect.signature(obj)
    except (TypeError, ValueError):
        return f"{name}(...)"
    params = [p for p in sig.parameters.values() if p.name != "self"]
    text = str(sig.replace(parameters=params, return_annotation=inspect.Signature.empty))
    return f"{name}{_plain(text)}"


def _plain(signature: str) -> str:
    """A signature without type annotations (their names are internal; the text says)."""
    out, depth, skip = [], 0, False
    for ch in signature:
        if ch in "([{":
            depth += 1
        elif ch in ")]}":
            depth -= 1
            if depth == 0:
                skip = False
        if skip and not (ch in ",=" and depth == 1) and not (ch == ")" and depth == 0):
            continue
        if ch == ":" and depth == 1:
            skip = True
            continue
        if ch in ",=" and depth == 1:
            skip = False
        out.append(ch)
    return re.sub(r"\s*=\s*", "=", "".join(out)).replace("=<factory>", "=...")


def _members(cls, name: str) -> list[tuple[str, object]]:
    if name in MEMBERS:
        return [(m, inspect.getattr_static(cls, m)) for m in MEMBERS[name]]
    return [
        (m, value)
        for m, value in vars(cls).items()
        if not m.startswith("_") and (inspect.isfunction(value) or isinstance(value, property))
    ]


def _member(cls_name: str, member: str, value) -> str:
    if isinstance(value, property):
        head = f"#### `{cls_name}.{member}` (property)"
        doc = value.fget.__doc__ if value.fget else None
    elif hasattr(value, "func"):  # functools.cached_property
        head = f"#### `{cls_name}.{member}` (property)"
        doc = value.func.__doc__
    else:
        func = value.__func__ if isinstance(value, (classmethod, staticmethod)) else value
        head = f"#### `{_signature(func, f'{cls_name}.{member}')}`"
        doc = func.__doc__
    return head + ("\n\n" + docstring_markdown(doc) if doc else "")


def render() -> str:
    """The reference part of docs/api.md."""
    sys.path.insert(0, str(ROOT / "src"))
    import score4.api as api

    listed = [n for names in SECTIONS.values() for n in names]
    if sorted(listed) != sorted(api.__all__):
        missing = sorted(set(api.__all__) - set(listed))
        extra = sorted(set(listed) - set(api.__all__))
        raise SystemExit(f"make_api_docs: SECTIONS misses {missing}, has extra {extra}")
    out = [BEGIN, ""]
    for section, names in SECTIONS.items():
        out += [f"## {section}", ""]
        for name in names:
            obj = getattr(api, name)
            where = f"*{obj.__module__}*" if obj.__module__ != "score4.api" else ""
            if inspect.isclass(obj):
                out.append(f"### `class {_signature(obj, name)}`")
                if where:
                    out += ["", f"From {where}."]
                out += ["", docstring_markdown(obj.__doc__), ""]
                for member, value in _members(obj, name):
                    out += [_member(name, member, value), ""]
            else:
                out.append(f"### `{_signature(obj, name)}`")
                if where:
                    out += ["", f"From {where}."]
                out += ["", docstring_markdown(obj.__doc__), ""]
    out.append(END)
    return "\n".join(line.rstrip() for line in "\n".join(out).splitlines()) + "\n"


def page_text(current: str) -> str:
    """``current`` (the page) with its reference part replaced by :func:`render`."""
    if BEGIN not in current or END not in current:
        raise SystemExit(f"make_api_docs: {PAGE} needs the lines {BEGIN} and {END}")
    head, rest = current.split(BEGIN, 1)
    _, tail = rest.split(END, 1)
    return head + render().rstrip("\n") + tail


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="compare only; exit 1 on change")
    args = parser.parse_args(argv)
    current = PAGE.read_text()
    new = page_text(current)
    if args.check:
        if new != current:
            print(f"{PAGE.relative_to(ROOT)} is out of date: run python tools/make_api_docs.py")
            return 1
        print(f"{PAGE.relative_to(ROOT)} is up to date")
        return 0
    PAGE.write_text(new)
    print(f"wrote {PAGE.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
