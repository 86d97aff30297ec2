"""``python -m score4``: the same as the ``score4`` command."""

from .cli.main import entry_point

entry_point()
