"""The ``ldpipe`` command: one subcommand per stage (``main``), the orbit and NHIM commands in
``orbits`` and ``nhim``."""

from .main import main

__all__ = ["main"]
