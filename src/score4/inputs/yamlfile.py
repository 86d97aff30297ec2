"""Reading YAML input strictly: a key given twice in one mapping is an error, not "the last wins".

PyYAML's ``safe_load`` keeps the last of two equal keys silently (``energy: 5.3 MeV`` then
``energy: 1 keV`` runs at 1 keV). :func:`load_yaml` refuses that, naming the key path, both
lines and the file. Keys brought in by a merge key (``<<: *defaults``) may still be
overridden, as YAML intends.

It also bounds what a document may expand to (:data:`score4.inputs.limits.MAX_YAML_DEPTH` levels of
nesting, :data:`score4.inputs.limits.MAX_YAML_VALUES` values once aliases are expanded, no alias
that contains itself), before anything is built from it: a 1 kB file of nested aliases ("billion
laughs") would otherwise expand to 10^9 values and hang whatever reads it, and 5000 nested
brackets would overflow Python's recursion.
"""

from __future__ import annotations

from pathlib import Path

from score4.errors import ConfigError, brief

from .limits import MAX_YAML_DEPTH, MAX_YAML_VALUES


def _scalar_key(node) -> object:
    import yaml  # imported in each function: a worker process never reads YAML

    return node.value if isinstance(node, yaml.ScalarNode) else None


def find_duplicate_key(node, path: str = "") -> tuple[str, int, int] | None:
    """The first (key path, first line, second line) of a key repeated in one mapping, or None."""
    import yaml

    stack, seen_nodes = [(node, path)], set()
    while stack:
        node, path = stack.pop()
        if id(node) in seen_nodes:  # aliases may share (or cycle through) nodes
            continue
        seen_nodes.add(id(node))
        if isinstance(node, yaml.MappingNode):
            lines: dict[object, int] = {}
            for key_node, value_node in node.value:
                key = _scalar_key(key_node)
                if key_node.tag == "tag:yaml.org,2002:merge" or key is None:
                    continue
                line = key_node.start_mark.line + 1
                where = f"{path}.{key}" if path else str(key)
                if key in lines:
                    return where, lines[key], line
                lines[key] = line
                stack.append((value_node, where))
        elif isinstance(node, yaml.SequenceNode):
            stack.extend((item, f"{path}.{i}") for i, item in reversed(list(enumerate(node.value))))
    return None


def _check_depth(text: str) -> None:
    """Refuse nesting deeper than MAX_YAML_DEPTH, reading only the parser's events (the
    parser keeps its own stack; composing a node tree would recurse in Python)."""
    import yaml

    loader = yaml.SafeLoader(text)
    try:
        depth = 0
        while loader.check_event():
            event = loader.get_event()
            if isinstance(event, yaml.CollectionStartEvent):
                depth += 1
                if depth > MAX_YAML_DEPTH:
                    line = event.start_mark.line + 1 if event.start_mark else 0
                    raise _Refused(
                        f"line {line}: nested deeper than {MAX_YAML_DEPTH} levels (a run "
                        "description needs fewer than 10)"
                    )
            elif isinstance(event, yaml.CollectionEndEvent):
                depth -= 1
    finally:
        loader.dispose()


class _Refused(Exception):
    """A document beyond what :func:`load_yaml` accepts (depth, size, self-reference)."""


def _check_expansion(root) -> None:
    """Refuse a node graph that expands to more than MAX_YAML_VALUES values or contains itself.

    Aliases share nodes, so the expanded size is counted once per distinct node (memoised).
    """
    import yaml

    size: dict[int, int] = {}
    active: set[int] = set()
    stack: list[tuple[yaml.Node, bool]] = [(root, False)]
    while stack:
        node, done = stack.pop()
        key = id(node)
        children = node.value if isinstance(node, yaml.SequenceNode) else []
        if isinstance(node, yaml.MappingNode):
            children = [n for pair in node.value for n in pair]
        if done:
            active.discard(key)
            size[key] = 1 + sum(size[id(c)] for c in children)
            if size[key] > MAX_YAML_VALUES:
                line = node.start_mark.line + 1
                raise _Refused(
                    f"line {line}: expands to more than {MAX_YAML_VALUES} values through aliases "
                    "(*name); a run description holds a few hundred"
                )
            continue
        if key in size:
            continue
        if key in active:
            raise _Refused(
                f"line {node.start_mark.line + 1}: an alias (*name) refers to the node that "
                "contains it (a value cannot contain itself)"
            )
        active.add(key)
        stack.append((node, True))
        stack.extend((c, False) for c in children if id(c) not in size)


def load_yaml(path: str | Path, what: str = "config") -> object:
    """Parse the YAML file ``path``; any problem is one :class:`ConfigError` line naming the file.

    ``what`` starts the message when the file cannot be read at all ("config", "surface").
    """
    import yaml

    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"{what}: file {brief(str(path))} does not exist")
    try:
        text = path.read_text()
        _check_depth(text)
        loader = yaml.SafeLoader(text)
        try:
            node = loader.get_single_node()
            if node is not None:
                _check_expansion(node)
            repeated = find_duplicate_key(node) if node is not None else None
            if repeated is None:
                return loader.construct_document(node) if node is not None else None
        finally:
            loader.dispose()
    except _Refused as err:
        raise ConfigError(f"{path}: {err}") from None
    except (ValueError, OSError) as err:
        if isinstance(err, (yaml.YAMLError, UnicodeDecodeError)):
            raise _invalid(err, what, path) from None
        raise ConfigError(f"{what}: {path}: cannot be read ({str(err)[:120]})") from None
    except yaml.YAMLError as err:
        raise _invalid(err, what, path) from None
    key, first, second = repeated
    raise ConfigError(
        f"{path}: {key if len(key) <= 200 else brief(key)}: key given twice (lines {first} and "
        f"{second}); keep one of them"
    )


def _invalid(err: Exception, what: str, path: Path) -> ConfigError:
    """One line for a YAML syntax error: file, line and PyYAML's short description."""
    where = getattr(err, "problem_mark", None)
    line = f" line {where.line + 1}" if where is not None else ""
    problem = str(getattr(err, "problem", None) or err)
    return ConfigError(f"{what}: {path}{line}: not valid YAML ({problem[:200]})")
