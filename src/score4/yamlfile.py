"""Reading YAML input strictly: a key given twice in one mapping is an error, not "the last wins".

PyYAML's ``safe_load`` keeps the last of two equal keys silently (``energy: 5.3 MeV`` then
``energy: 1 keV`` runs at 1 keV). :func:`load_yaml` refuses that, naming the key path, both
lines and the file. Keys brought in by a merge key (``<<: *defaults``) may still be
overridden, as YAML intends.
"""

from __future__ import annotations

from pathlib import Path

import yaml

from .errors import ConfigError


def _scalar_key(node) -> object:
    return node.value if isinstance(node, yaml.ScalarNode) else None


def find_duplicate_key(node, path: str = "") -> tuple[str, int, int] | None:
    """The first (key path, first line, second line) of a key repeated in one mapping, or None."""
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


def load_yaml(path: str | Path, what: str = "config") -> object:
    """Parse the YAML file ``path``; any problem is one :class:`ConfigError` line naming the file.

    ``what`` starts the message when the file cannot be read at all ("config", "surface").
    """
    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"{what}: file {str(path)!r} does not exist")
    try:
        loader = yaml.SafeLoader(path.read_text())
        try:
            node = loader.get_single_node()
            repeated = find_duplicate_key(node) if node is not None else None
            if repeated is None:
                return loader.construct_document(node) if node is not None else None
        finally:
            loader.dispose()
    except (yaml.YAMLError, UnicodeDecodeError) as err:
        where = getattr(err, "problem_mark", None)
        line = f" line {where.line + 1}" if where is not None else ""
        raise ConfigError(
            f"{what}: {path}{line}: not valid YAML ({getattr(err, 'problem', err)})"
        ) from None
    key, first, second = repeated
    raise ConfigError(
        f"{path}: {key}: key given twice (lines {first} and {second}); keep one of them"
    )
