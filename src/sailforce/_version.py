"""The package's version: the one place it is written (pyproject.toml reads it from here when the package is built).

A literal, not ``importlib.metadata.version("sailforce")``: that import costs
about 50 ms, a twentieth of a short ``sail`` command, and every command
reads the version (the calibration file's ``software`` field, ``--version``).
"""

__version__ = "0.1.0"
