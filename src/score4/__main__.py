"""``python -m score4``: the same as the ``score4`` command."""

from .cli import quiet_interrupts

quiet_interrupts()

from .cli.main import entry_point  # noqa: E402  (after the hook: a Ctrl-C while importing)

entry_point()
