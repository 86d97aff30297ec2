"""Exceptions raised by score4.

Every error a user can cause by bad input is a :class:`Score4Error`; its message names the
parameter, the value and the rule, in one line, so the CLI can print it as it is.
"""


class Score4Error(Exception):
    """Base class for errors caused by input (configuration, files, data sets)."""


class ConfigError(Score4Error, ValueError):
    """A configuration value is invalid."""


class DataError(Score4Error):
    """Geant4 data sets are missing, corrupt or cannot be installed."""


class PhysicsUnavailableError(Score4Error):
    """The requested physics needs data sets that are not installed."""
