"""The ``score4`` command line."""
