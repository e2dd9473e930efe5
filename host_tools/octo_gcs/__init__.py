"""Octo-SIL ground-station tools (the ``octo-gcs`` command)."""

__version__ = "0.1.0"
